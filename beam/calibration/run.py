"""Calibrate the beam on a measurement window and predict the rest of the record.

What is calibrated is a :class:`~beam.calibration.spec.CalibrationSpec` (the keyword options of
every function here build one); the MAP is searched, and remembered, by an
:class:`~beam.calibration.engine.Engine` (default: the process's).

:func:`calibrate` runs MAP + Laplace (the preview), then emcee to a target ESS (or a fixed
number of steps), and returns a :class:`CalibrationResult` with posterior summaries, RMSE in the
calibration and prediction windows, coverage of the 95 % prediction band on the held-out part
(every sample outside the window), convergence diagnostics, the posterior correlation matrix
(Pearson, of the draws in the sampling coordinates: log for the positive physical parameters)
and the predictive bands over the whole record. :func:`calibration_preview` stops after the
Laplace step (what a ranking of candidate effects needs, and what the dashboard draws on every
slider move).

The preview is the fast path: the MAP by the lock-step search of :mod:`beam.calibration.fit`
(the same MAP and finite-difference Hessian as :func:`beam.inference.find_map`, from a third of
the model evaluations), the bands by the compiled kernel of :mod:`beam.calibration.bands` (the
same bands as :func:`beam.inference.predictive_bands` from the same draws). A ``start`` (the
previous window's MAP) warm-starts it.
"""

from __future__ import annotations

import io
import logging
import math
import time
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from beam.calibration.bands import fast_predictive_bands
from beam.calibration.fit import fast_map
from beam.calibration.free_averaged import AVERAGED_NOTE, AveragedDragModel, averaged_laplace
from beam.calibration.free_starts import nonlinear_free_starts, projected_starting_points
from beam.calibration.records import decimate_measurement
from beam.calibration.spec import CalibrationSpec
from beam.calibration.setup import (
    BeamCalibrationSetup,
    build_problem,
    make_setup,
)
from beam.calibration.engine import FIRST_STAGE, MAP, Engine, default_engine
from beam.calibration.starts import SEARCH_GAIN_NATS, has_second_stage, kept_nested, null_starts  # noqa: F401
from beam.errors import BeamInputError
from beam.inference import (
    NOISE_SD,
    EnsembleRun,
    LaplaceResult,
    MapResult,
    PosteriorResult,
    PredictiveBands,
    Problem,
    Progress,
    laplace,
)
from beam.inference.sampling import ENSEMBLES
from beam.inference.summaries import summarize_draws
from beam.io.anchor import mode_order_warnings
from beam.io.limits import MAX_CALIBRATION_SAMPLES
from beam.io.measurement import Measurement
from beam.physics.effects import EFFECTS, effect_of_parameter, parameter_spec
from beam.io.text import atomic_write_texts

LOGGER = logging.getLogger(__name__)
#: The warning of a nonlinear free decay's calibration, which ends at its Laplace approximation.
LAPLACE_ONLY = ("a free decay with a nonlinear effect is not sampled: the posterior is the Laplace approximation "
                "at the MAP and the bands are linearised (one evaluation integrates the decay and refits its "
                "initial state)")
#: Posterior draws pushed through the model for the predictive bands.
BAND_DRAWS = 400
#: Header of the predictive band CSV written by ``--save``.
BAND_COLUMNS = (
    "time_s,displacement_m,in_window,mean_m,credible_lower_m,credible_upper_m,prediction_lower_m,prediction_upper_m"
)


def band_columns(output_column: str = "displacement_m") -> str:
    """Header of the band CSV for a record's output column (:data:`BAND_COLUMNS` for displacement)."""
    suffix = output_column.split("_", 1)[1]
    return (f"time_s,{output_column},in_window,mean_{suffix},credible_lower_{suffix},credible_upper_{suffix},"
            f"prediction_lower_{suffix},prediction_upper_{suffix}")


@dataclass
class CalibrationResult:
    """A calibrated beam model and how well it predicts the held-out record.

    Attributes
    ----------
    setup : BeamCalibrationSetup
        Measurement, window, effects, modes, likelihood.
    problem : Problem
        The inference problem (data = the window's displacement).
    laplace : LaplaceResult
        MAP and Laplace preview.
    posterior : PosteriorResult or None
        MCMC result (None for a preview).
    bands : PredictiveBands
        Predictive bands on the whole record.
    seconds : float
        Wall time of the whole calibration (s).
    approximation : str or None
        None for a result of the model itself; else what stands in for it, in words: a preview of
        a cheaper model (:data:`~beam.calibration.free_averaged.AVERAGED_NOTE`: the averaged drag
        model, the first event of :func:`calibration_stream` on a free decay with the drag), whose
        laplace, bands and MAP prediction are that model's. Never remembered as the model's MAP.
    final : bool
        True for the last result of :func:`calibration_stream`: after MCMC, or a nonlinear free
        decay's Laplace result (which is not sampled, so ``is_preview`` stays True).
    """

    setup: BeamCalibrationSetup
    problem: Problem
    laplace: LaplaceResult
    posterior: PosteriorResult | None
    bands: PredictiveBands
    seconds: float
    _draws: dict[str, np.ndarray] = field(default=None, repr=False)
    _map_output: np.ndarray = field(default=None, repr=False)
    #: A screening fit (:func:`calibration_preview` with ``search=False``): the first of the engine's
    #: two stages only. Never remembered as the model's MAP (:func:`known_map` refuses it).
    screened: bool = False
    approximation: str | None = None
    final: bool = False

    @property
    def is_averaged(self) -> bool:
        """Whether this is the averaged drag model's preview (:attr:`approximation`)."""
        return self.approximation == AVERAGED_NOTE

    @property
    def spec(self) -> CalibrationSpec:
        """The resolved :class:`~beam.calibration.spec.CalibrationSpec` of the model calibrated
        (window, effects, modes, likelihood)."""
        return CalibrationSpec.of_setup(self.setup)

    # -- draws ------------------------------------------------------------------------------
    @property
    def is_preview(self) -> bool:
        return self.posterior is None

    def draws(self) -> dict[str, np.ndarray]:
        """Posterior draws (natural units): MCMC draws, or Laplace draws for a preview."""
        if self._draws is None:
            self._draws = self.posterior.draws() if self.posterior is not None else self.laplace.draws(4000, seed=0)
        return self._draws

    def summary(self) -> dict[str, dict[str, float]]:
        """``{name: {"mean", "sd", "q025", "q975"}}`` of every sampled parameter."""
        return summarize_draws(self.draws())

    def correlation(self) -> dict[str, dict[str, float]]:
        """Posterior correlations of the sampled parameters, in their sampling coordinates."""
        draws = self.draws()
        names = list(self.problem.names)
        z = self.problem.to_internal(draws)
        matrix = np.corrcoef(z, rowvar=False) if z.shape[0] > 2 else np.eye(len(names))
        return {a: {b: float(matrix[i, j]) for j, b in enumerate(names)} for i, a in enumerate(names)}

    # -- prediction -------------------------------------------------------------------------
    @property
    def held_out_mask(self) -> np.ndarray:
        """Samples outside the calibration window (clipped ones left out)."""
        return self.setup.held_out_mask

    @property
    def rmse_calibration(self) -> float:
        """RMSE of the band's mean in the calibration window (output's unit; clipped samples left out)."""
        return self.bands.rmse(self.setup.measurement.output, self.setup.fit_mask)

    @property
    def rmse_prediction(self) -> float:
        return self.bands.rmse(self.setup.measurement.output, self.held_out_mask) if self.held_out_mask.any() else math.nan

    @property
    def coverage95_prediction(self) -> float:
        if not self.held_out_mask.any():
            return math.nan
        return self.bands.coverage(self.setup.measurement.output, self.held_out_mask)

    def map_prediction(self) -> np.ndarray:
        """The MAP model's output over the whole record (m, m/s or m/s²): the point prediction
        (computed once, read-only: a result computed in a worker process carries it, so the
        dashboard's server never runs the model)."""
        if self._map_output is None:
            values = {name: np.atleast_1d(v) for name, v in self.laplace.map.values.items()}
            output = np.array(self.problem.predict(values, self.setup.measurement.time_s)[0])
            output.flags.writeable = False
            self._map_output = output
        return self._map_output

    @property
    def rmse_prediction_map(self) -> float:
        """Held-out RMSE of the MAP prediction (m): robust where the Laplace draws are not
        (a parameter pressed against a bound spreads them)."""
        if not self.held_out_mask.any():
            return math.nan
        residual = (self.setup.measurement.output - self.map_prediction())[self.held_out_mask]
        return float(np.sqrt(np.mean(residual**2)))

    @property
    def rmse_calibration_map(self) -> float:
        """RMSE of the MAP prediction in the calibration window (output's unit; clipped samples out)."""
        residual = (self.setup.measurement.output - self.map_prediction())[self.setup.fit_mask]
        return float(np.sqrt(np.mean(residual**2)))

    def rmse_map(self, start_s: float, end_s: float) -> float:
        """RMSE of the MAP prediction over [start_s, end_s] (output's unit; clipped samples left out)."""
        m = self.setup.measurement
        mask = (m.time_s >= start_s - 1e-12) & (m.time_s <= end_s + 1e-12) & self.setup.usable_mask
        if not mask.any():
            return math.nan
        residual = (m.output - self.map_prediction())[mask]
        return float(np.sqrt(np.mean(residual**2)))

    @property
    def pressed_parameters(self) -> tuple[str, ...]:
        """Physical parameters whose MAP sits on a prior bound other than the end where their effect
        vanishes (a damping the prior cannot make large enough): the calibration has not found their
        value, so it is not called converged (:meth:`to_json`)."""
        out = []
        for name in self.laplace.map.at_bound:
            if name not in self.setup.physical_names:
                continue
            effect = effect_of_parameter(name)
            spec = parameter_spec(name)
            prior = self.problem.parameter(name).prior
            value = float(self.laplace.map.values[name])
            upper = abs(value - prior.upper) <= abs(value - prior.lower)
            if effect is not None and spec.absent_at in ("low", "high") and (spec.absent_at == "high") == upper:
                continue  # the effect switched off: nothing is claimed of it
            out.append(name)
        return tuple(out)

    def linear_fit(self) -> dict | None:
        """For a free response: the initial-state amplitudes and the sensor's offset (output's
        unit, with its conditional sd) at the MAP, profiled out of the calibration; else None."""
        if not self.setup.is_free:
            return None
        return self.problem.model.linear_fit(self.laplace.map.values)

    # -- output -----------------------------------------------------------------------------
    def to_json(self) -> dict:
        """The summary of the CLI's ``--json`` (see the README)."""
        summary = self.summary()
        diagnostics = self.posterior.diagnostics if self.posterior is not None else None
        physical = {name: summary[name] for name in self.setup.physical_names}
        noise = {name: summary[name] for name in self.problem.noise_names if name in summary}
        m = self.setup.measurement
        linear = self.linear_fit()
        return {
            "measurement": m.name,
            "output": m.output_kind,
            "output_unit": m.output_unit,
            "input": m.input_kind,
            "clipped_samples": m.clipped_count,
            **({"free_response_start_s": self.setup.free_start_s,
                "free_response_release_s": float(m.time_s[self.setup.free_start_indices[0]]),
                "release_transient_samples_left_out": int(np.diff(self.setup.free_start_indices)[0])}
               if self.setup.is_free else {}),
            **({"output_offset": linear["output_offset"], "output_offset_sd": linear["output_offset_sd"]}
               if linear is not None and self.setup.measurement.output_kind != "displacement" else {}),
            "window_s": list(self.setup.window),
            "effects": list(self.setup.effects),
            "modes": self.setup.modes,
            **({"modes_reason": self.setup.mode_choice.reason} if self.setup.mode_choice is not None else {}),
            "likelihood": self.setup.likelihood,
            "parameters": physical,
            "noise_sd": noise.get(NOISE_SD),
            **({"ar1_coefficient": noise["ar1_coefficient"]} if "ar1_coefficient" in noise else {}),
            "rmse_calibration": self.rmse_calibration,
            "rmse_prediction": self.rmse_prediction,
            "coverage95_prediction": self.coverage95_prediction,
            "ess_min": diagnostics.ess_min if diagnostics is not None else None,
            "rhat_max": diagnostics.rhat_max if diagnostics is not None else None,
            "converged": bool(diagnostics.converged and not self.pressed_parameters) if diagnostics is not None else False,
            "warnings": [*(diagnostics.warnings if diagnostics is not None else self.laplace.warnings),
                         *mode_order_warnings(m, self.setup.model, self.laplace.map.values),
                         *(f"{n} sits at a bound of its prior: its value is not found there, the calibration is not "
                           "converged on it" for n in self.pressed_parameters)],
            "log_evidence_laplace": float(self.laplace.log_evidence),
            "map": {name: float(v) for name, v in self.laplace.map.values.items()},
            "log_posterior_map": float(self.laplace.map.log_posterior),
            "correlation": self.correlation(),
            "seconds": self.seconds,
            "preview": self.is_preview,
        }

    def band_table(self) -> str:
        """The predictive band over the record as CSV text (one row per sample, full precision)."""
        m, b = self.setup.measurement, self.bands
        columns = np.column_stack([
            m.time_s, m.output, self.setup.window_mask.astype(float), b.mean,
            b.credible_lower, b.credible_upper, b.prediction_lower, b.prediction_upper,
        ])
        buffer = io.StringIO()
        np.savetxt(buffer, columns, fmt="%.17g", delimiter=",", comments="", header=band_columns(m.output_column))
        return buffer.getvalue()

    def save(self, prefix: str | Path) -> list[Path]:
        """Write ``PREFIX.band.csv`` and, after MCMC, ``PREFIX.nc`` (ArviZ InferenceData)."""
        prefix = Path(prefix)
        prefix.parent.mkdir(parents=True, exist_ok=True)
        written = atomic_write_texts({prefix.with_name(prefix.name + ".band.csv"): self.band_table()})
        if self.posterior is not None:
            path = prefix.with_name(prefix.name + ".nc")
            temporary = path.with_name(path.name + ".tmp")
            self.posterior.to_netcdf(temporary)
            temporary.replace(path)
            written.append(path)
        return written


def prepare(
    measurement: Measurement,
    spec: CalibrationSpec | None = None,
    *,
    extra_guesses: Iterable[dict[str, float]] = (),
    start: Mapping[str, float] | None = None,
    search: bool = True,
    engine: Engine | None = None,
    **options,
) -> tuple[BeamCalibrationSetup, Problem]:
    """Validated setup and inference problem with its starting points (``search``: with the
    searched stratified design, :meth:`Engine.starting_points` of ``engine``, default the process's).

    ``spec`` (or the keywords ``options``, fields of :class:`CalibrationSpec`, which replace its
    values) says what is calibrated; it is resolved on the record (:meth:`CalibrationSpec.resolve`).

    The problem's ``initial_guesses`` hook returns the starting points of the MAP search: those
    of :func:`beam.calibration.starts.starting_points` (the one start strategy of every
    calibration: short-window MAP, spectral starts, screened design over the effects), then the
    :data:`KEPT_GUESSES` best ``extra_guesses``; with a warm ``start`` (see
    :func:`calibration_preview`) the warm start replaces the short-window MAP.

    A record longer than :data:`beam.io.limits.MAX_CALIBRATION_SAMPLES` is decimated first (anti-
    aliased; see :mod:`beam.io.limits`): ``setup.measurement`` is then the decimated record.
    """
    engine = default_engine() if engine is None else engine
    measurement, _ = decimate_measurement(measurement, MAX_CALIBRATION_SAMPLES)
    spec = CalibrationSpec.of(spec, **options).resolve(measurement)
    setup = make_setup(measurement, window=spec.window, effects=spec.effects, modes=spec.modes,
                       likelihood=spec.likelihood)
    setup.mode_choice = spec.mode_choice
    extra = [dict(g) for g in extra_guesses]
    warm = None if start is None else checked_start(start, setup.physical_names)

    def starts(problem: Problem) -> list[dict[str, float]]:
        warm_start = None if warm is None else clip_to_prior(problem, warm)
        if "patch_coupling_NmV" in setup.physical_names:
            chosen = engine.starting_points(problem, setup, warm_start, search=search)
        elif setup.is_free and setup.model.is_nonlinear:  # the linear sub-model's optimum, nested
            chosen = nonlinear_free_starts(problem, setup, linear_sub_map(setup, engine), warm_start)
            if sum(EFFECTS[e].nonlinear for e in setup.effects) > 1:  # a sub-model with a nonlinear effect of its own
                chosen += null_starts(problem, setup, engine)  # remembered (the drag's before the friction): nested too
        else:  # free response (initial state profiled out) or point force: no coupling to solve for
            chosen = projected_starting_points(problem, setup, warm_start) + null_starts(problem, setup, engine)
        return chosen + (best_guesses(problem, extra) if extra else [])

    return setup, build_problem(setup, initial_guesses=starts)


def linear_sub_map(setup: BeamCalibrationSetup, engine: Engine) -> dict[str, float]:
    """The MAP (natural units) of :func:`calibration_preview` of ``setup``'s model without its
    nonlinear effects (same record, window, modes and likelihood; no bands), remembered by
    ``engine``: the nested start of a nonlinear free decay's calibration and of its averaged drag
    preview."""
    linear_effects = tuple(e for e in setup.effects if not EFFECTS[e].nonlinear)
    spec = CalibrationSpec(window=setup.window, effects=linear_effects, modes=setup.modes, likelihood=setup.likelihood)
    return preview_map(setup.measurement, spec, engine=engine)[2].map.values


def checked_start(start: Mapping[str, float], names: Iterable[str]) -> dict[str, float]:
    """The values of ``start`` for the physical parameters ``names`` it has, as floats (natural
    units; names it lacks, e.g. of an effect just added, start at their prior centres).

    Raises
    ------
    BeamInputError
        When one of them is not a finite positive number.
    """
    out = {}
    for name in names:
        if name in start:
            try:
                value = float(start[name])
            except (TypeError, ValueError):
                value = math.nan
            if not (math.isfinite(value) and value > 0.0):
                raise BeamInputError(f"warm start {name} = {start[name]!r} is not a finite positive number")
            out[name] = value
    return out


def clip_to_prior(problem: Problem, values: Mapping[str, float]) -> dict[str, float]:
    """``values`` clipped into their priors' supports (natural units)."""
    return {name: float(np.clip(v, problem.parameter(name).prior.lower, problem.parameter(name).prior.upper))
            for name, v in values.items()}


#: Starting points a MAP search keeps after screening (each costs a least-squares run).
KEPT_GUESSES = 3


def best_guesses(problem: Problem, guesses: list[dict[str, float]], keep: int = KEPT_GUESSES) -> list[dict[str, float]]:
    """The ``keep`` guesses with the smallest residual RMS on the window, scored in one
    vectorised model call (the noise profiled out: for Gaussian noise the likelihood maximised
    over its sd is a monotone function of the residual RMS)."""
    if len(guesses) <= keep:
        return guesses
    names = [n for n in problem.names if n not in problem.noise_names]
    batch = {name: np.array([g[name] for g in guesses], dtype=float) for name in names if all(name in g for g in guesses)}
    if len(batch) != len(names):
        return guesses[:keep]
    residual = problem.data - problem.predict(batch)
    rms = np.sqrt(np.mean(residual**2, axis=1))
    rms[~np.isfinite(rms)] = np.inf
    return [guesses[i] for i in np.argsort(rms, kind="stable")[:keep]]


def default_walkers(n_parameters: int) -> int:
    """``2 * ENSEMBLES * n_parameters`` (48 for six parameters): :data:`~beam.inference.sampling.ENSEMBLES`
    independent ensembles of ``2 * n_parameters`` walkers each, the fewest the DE move allows,
    so that R-hat compares independent chains. Measured on lab_run_1 (0-1.05 s, air damping,
    Kelvin-Voigt, tip mass; seed 0): one ensemble of 24 walkers needs 1,970 steps (47,000
    evaluations: R-hat over walkers, which only the chain length brings down, set the run's
    length), four ensembles of 12 need 642 (31,000 evaluations: the ESS sets the length)."""
    return 2 * ENSEMBLES * int(n_parameters)


def preview_fit(problem: Problem) -> LaplaceResult:
    """MAP + Laplace of a prepared problem by the fast search of :mod:`beam.calibration.fit`
    from the starts of the problem's ``initial_guesses`` hook (see :func:`prepare`).

    Returns
    -------
    LaplaceResult
        ``seconds`` is the wall time of the search and the approximation.
    """
    t0 = time.perf_counter()
    result = laplace(problem, fast_map(problem, problem.initial_guesses(problem)))
    result.seconds = time.perf_counter() - t0
    return result


def _laplace_at(problem: Problem, found: MapResult, seconds: float = 0.0) -> LaplaceResult:
    """The Laplace approximation at ``found``; ``seconds`` (plus its own time) as its wall time."""
    t0 = time.perf_counter()
    result = laplace(problem, found)
    result.seconds = seconds + time.perf_counter() - t0
    return result


def _kept_nested(engine: Engine, problem: Problem, setup: BeamCalibrationSetup, result: LaplaceResult) -> LaplaceResult:
    """``result``, or the Laplace approximation at a remembered sub-model's optimum embedded in
    the model when the search ended lower (:func:`beam.calibration.starts.kept_nested`): nested
    fits are monotone."""
    t0 = time.perf_counter()
    found = kept_nested(problem, setup, result.map, engine)
    return result if found is result.map else _laplace_at(problem, found, result.seconds + time.perf_counter() - t0)


def _searched_laplace(engine: Engine, problem: Problem, setup: BeamCalibrationSetup,
                      quick: LaplaceResult) -> LaplaceResult:
    """``quick`` (the preview's MAP + Laplace), or the Laplace approximation at a better MAP found
    by the engine's second stage (:meth:`Engine.searched_map`)."""
    if "patch_coupling_NmV" not in setup.physical_names:  # free response / point force: projected starts
        return quick
    t0 = time.perf_counter()
    found = engine.searched_map(problem, setup, quick.map)
    if found is None:
        return quick  # the same basin (or worse): the preview's MAP stands, to the last digit
    return _kept_nested(engine, problem, setup, _laplace_at(problem, found, quick.seconds + time.perf_counter() - t0))


def _recalled_laplace(engine: Engine, problem: Problem, setup: BeamCalibrationSetup,
                      cold: bool) -> LaplaceResult | None:
    """For a cold start: the Laplace approximation at the engine's remembered MAP of this very
    model, or None when none is remembered (the same MAP, to the last digit)."""
    if not cold:
        return None
    found = engine.recall(setup)
    return None if found is None else _laplace_at(problem, found)


def _first_stage(engine: Engine, problem: Problem, setup: BeamCalibrationSetup, cold: bool) -> LaplaceResult:
    """The first stage of a preview (:func:`preview_fit`, kept no lower than a remembered
    sub-model's optimum), or for a cold start the engine's remembered first-stage MAP of this model
    (a screening fit's, from the same starts)."""
    found = engine.recall(setup, FIRST_STAGE) if cold else None
    return _kept_nested(engine, problem, setup, preview_fit(problem)) if found is None else _laplace_at(problem, found)


def _remember(engine: Engine, setup: BeamCalibrationSetup, found: MapResult, cold: bool, kind: str = MAP) -> None:
    """Keep a cold-started calibration's MAP in the engine (for the nested and null starts of
    larger models and later calibrations of this one)."""
    if cold:
        engine.remember(setup, found, kind)


def known_map(result: CalibrationResult) -> tuple[tuple[str, ...], MapResult]:
    """``(effects, MAP)`` of a cold-started preview or calibration, for :func:`remember_maps`; of a
    screening fit ``((FIRST_STAGE, *effects), MAP)`` (its first stage's MAP, never the model's).

    A convenience for callers that send MAPs by model; :meth:`Engine.export` and
    :meth:`Engine.merge` send a whole engine's memory (keyed by record and spec)."""
    effects = tuple(result.setup.effects)
    return ((FIRST_STAGE, *effects) if result.screened else effects), result.laplace.map


def remember_maps(measurement: Measurement, *, window: tuple[float, float], modes: int,
                  maps: Iterable[tuple[tuple[str, ...], MapResult]], likelihood: str = "iid",
                  engine: Engine | None = None) -> None:
    """Keep MAPs found in another process (:func:`known_map` of cold-started calibrations of this
    record, window, modes and likelihood) in ``engine`` (default: the process's): what the
    process would have found itself."""
    engine = default_engine() if engine is None else engine
    measurement, _ = decimate_measurement(measurement, MAX_CALIBRATION_SAMPLES)
    for effects, found in maps:
        first = bool(effects) and effects[0] == FIRST_STAGE
        setup = make_setup(measurement, window=window, effects=effects[1:] if first else effects, modes=modes,
                           likelihood=likelihood)
        _remember(engine, setup, found, cold=True, kind=FIRST_STAGE if first else MAP)


def calibration_preview(
    measurement: Measurement,
    spec: CalibrationSpec | None = None,
    *,
    extra_guesses: Iterable[dict[str, float]] = (),
    start: Mapping[str, float] | None = None,
    search: bool = True,
    engine: Engine | None = None,
    **options,
) -> CalibrationResult:
    """MAP + Laplace only: parameters, bands, RMSE and coverage in a fraction of a second.

    Parameters
    ----------
    measurement : Measurement
        The record (displacement in m, voltage in V).
    spec : CalibrationSpec, optional
        Window, effects, modes, likelihood and seed (of the Laplace draws behind the bands);
        default :class:`CalibrationSpec`'s defaults.
    **options
        Fields of :class:`CalibrationSpec` (``window``, ``effects``, ``modes``, ``likelihood``,
        ``seed``, ...), which replace the spec's: a convenience that builds the spec.
    extra_guesses : iterable of mapping
        More starting points (natural units), screened with the spectral ones.
    start : mapping of str to float, optional
        Warm start: parameter values in natural units, e.g. ``previous.laplace.map.values`` of a
        preview of the same record and model on a nearby window (extra names are ignored, a
        missing one starts at its prior centre). It replaces the short-window MAP among the
        starting points (the spectral starts stay), so a window moved by a few percent
        converges in a few iterations. Far from the window it came from (a window several
        times longer, another record) it may lead to a worse optimum than the cold search.
    search : bool
        False for a **screening fit**: the engine's first stage only (the quick search from the
        short-window, spectral, nested and screened-design starts), without the searched stratified
        design and the walk along the ridge (:func:`beam.calibration.starts.searched_map`); marked
        ``screened`` and never remembered as the model's MAP (unless the model has no second stage,
        :func:`beam.calibration.starts.has_second_stage`: then it is the engine's MAP). The diagnosis's climb screens its candidates so
        (:func:`beam.discovery.report.climb_on`). A remembered two-stage MAP of the model is used
        when there is one.
    engine : Engine, optional
        The engine that searches and remembers (default: the process's, :func:`default_engine`).
    """
    t0 = time.perf_counter()
    spec = CalibrationSpec.of(spec, **options)
    setup, problem, laplace_result, screened = preview_map(measurement, spec, extra_guesses=extra_guesses, start=start,
                                                           search=search, engine=engine)
    bands = preview_bands(laplace_result, setup, spec.seed)
    return CalibrationResult(setup, problem, laplace_result, None, bands, time.perf_counter() - t0, screened=screened)


def preview_map(measurement: Measurement, spec: CalibrationSpec, *, extra_guesses: Iterable[dict[str, float]] = (),
                start: Mapping[str, float] | None = None, search: bool = True,
                engine: Engine | None = None) -> tuple[BeamCalibrationSetup, Problem, LaplaceResult, bool]:
    """The MAP + Laplace of :func:`calibration_preview` without its bands: ``(setup, problem,
    laplace, screened)`` (same arguments; the same search, recall and memory of the engine)."""
    extra_guesses = tuple(extra_guesses)
    engine = default_engine() if engine is None else engine
    setup, problem = prepare(measurement, spec, extra_guesses=extra_guesses, start=start, search=False, engine=engine)
    cold = start is None and not extra_guesses
    laplace_result = _recalled_laplace(engine, problem, setup, cold)
    screened = False
    if laplace_result is None:
        quick = _first_stage(engine, problem, setup, cold)
        if not search:
            laplace_result, screened = quick, has_second_stage(setup)  # else it is the engine's MAP
            _remember(engine, setup, quick.map, cold, FIRST_STAGE if screened else MAP)
        else:
            laplace_result = _searched_laplace(engine, problem, setup, quick)  # the two stages of calibration_stream
            _remember(engine, setup, laplace_result.map, cold)
    return setup, problem, laplace_result, screened


def preview_bands(laplace_result: LaplaceResult, setup: BeamCalibrationSetup, seed: int) -> PredictiveBands:
    """Predictive bands of :data:`BAND_DRAWS` Laplace draws over the record (:func:`record_bands`).

    The same draws and bands as ``laplace_result.predict(time_s, n_draws=BAND_DRAWS, seed=seed)``
    (to the tolerance of the prediction band's edges), by :func:`fast_predictive_bands`.
    """
    linearised = getattr(laplace_result.problem.model, "linearised_bands", None)
    if linearised is not None:  # a nonlinear free decay: the delta method (beam.calibration.free_nonlinear)
        return _lead_nan(setup, linearised(laplace_result, setup.measurement.time_s[setup.free_start_indices[1]:]))
    return record_bands(laplace_result.problem, setup, laplace_result.draws(BAND_DRAWS, seed))


def record_bands(problem: Problem, setup: BeamCalibrationSetup, draws: Mapping[str, np.ndarray]) -> PredictiveBands:
    """Predictive bands of ``draws`` over the whole record (output's unit), by
    :func:`fast_predictive_bands`; for a free response NaN before its start
    (:attr:`~beam.calibration.setup.BeamCalibrationSetup.free_start_s`): the model describes the
    beam from the end of the release's transient on, and extrapolated backwards its decaying terms
    grow without bound (adxl_50cm_114759, released at 0.33 s: 1e22 m/s² at t = 0)."""
    time_s = setup.measurement.time_s
    first = setup.free_start_indices[1] if setup.is_free else 0
    return _lead_nan(setup, fast_predictive_bands(problem, draws, time_s[first:]))


def _lead_nan(setup: BeamCalibrationSetup, bands: PredictiveBands) -> PredictiveBands:
    """``bands`` from a free response's start on, extended back over the whole record with NaN."""
    time_s = setup.measurement.time_s
    first = time_s.size - bands.time_s.size
    if first == 0:
        return bands
    lead = np.full(first, np.nan)
    return replace(bands, time_s=time_s, **{name: np.concatenate([lead, getattr(bands, name)]) for name in (
        "mean", "credible_lower", "credible_upper", "prediction_lower", "prediction_upper")})


def calibrate(measurement: Measurement, spec: CalibrationSpec | None = None, **options) -> CalibrationResult:
    """Full calibration: preview, then emcee to ``spec.target_ess`` (or exactly ``spec.steps`` steps).

    Takes the arguments of :func:`calibration_stream` and returns its final result.
    """
    final = None
    for event in calibration_stream(measurement, spec, averaged=False, **options):  # nobody watches its previews
        if isinstance(event, CalibrationResult) and (final is None or final.is_preview):
            final = event
    return final


def averaged_preview(setup: BeamCalibrationSetup, problem: Problem, engine: Engine) -> CalibrationResult | None:
    """The averaged drag model's preview of a free decay whose only nonlinear effect is
    ``quadratic_drag`` (:class:`~beam.calibration.free_averaged.AveragedDragModel`, no integration),
    or None for any other model or when the averaged model does not apply (a mode overdamped at
    the start, a singular Laplace matrix) or fails: logged, never raised.

    Its MAP and Laplace covariance are the averaged model's from the linear sub-model's optimum
    (:func:`linear_sub_map`, remembered by ``engine``: the full calibration starts from it
    too), as :func:`~beam.calibration.free_averaged.averaged_laplace`; its bands and MAP
    prediction are the averaged model's, linearised
    (:meth:`~beam.calibration.free_averaged.AveragedDragModel.bands`); it is labelled
    (:attr:`CalibrationResult.approximation`, ``laplace.warnings``) with
    :data:`~beam.calibration.free_averaged.AVERAGED_NOTE`.
    """
    if not (setup.is_free and tuple(e for e in setup.effects if EFFECTS[e].nonlinear) == ("quadratic_drag",)):
        return None
    t0 = time.perf_counter()
    try:
        model = AveragedDragModel(problem.model)
        fit = model.fit_nested(problem, linear_sub_map(setup, engine))
        bands = _lead_nan(setup, model.bands(fit, problem, setup.measurement.time_s[setup.free_start_indices[1]:]))
        laplace_result = averaged_laplace(problem, fit, time.perf_counter() - t0)
    except (BeamInputError, np.linalg.LinAlgError) as exc:  # the averaged model does not apply
        LOGGER.info("no averaged drag preview for %s: %s", setup.measurement.name, exc)
        return None
    except Exception:  # an optional first look: its failure must not cost the calibration
        LOGGER.warning("the averaged drag preview of %s failed", setup.measurement.name, exc_info=True)
        return None
    prediction = bands.mean.copy()
    prediction.flags.writeable = False
    return CalibrationResult(setup, problem, laplace_result, None, bands, time.perf_counter() - t0,
                             _map_output=prediction, approximation=fit.note)


def calibration_stream(
    measurement: Measurement,
    spec: CalibrationSpec | None = None,
    *,
    every: int = 50,
    start: Mapping[str, float] | None = None,
    engine: Engine | None = None,
    averaged: bool = True,
    **options,
) -> Iterator[CalibrationResult | Progress]:
    """The calibration as a generator: the preview result, then :class:`Progress` while sampling,
    then the final result. A caller (the dashboard) can stop at any point by leaving the loop.

    On a free decay whose only nonlinear effect is ``quadratic_drag`` (and with ``averaged``), a
    first event comes before the preview: the averaged drag model's (:func:`averaged_preview`,
    :attr:`CalibrationResult.approximation` set, :data:`~beam.calibration.free_averaged.AVERAGED_NOTE`
    among its Laplace warnings), while the full model's MAP, which integrates the decay, is searched.

    Parameters
    ----------
    measurement : Measurement
        The record (displacement in m, voltage in V).
    spec : CalibrationSpec, optional
        Window, effects, modes, likelihood, seed, walkers, steps, target ESS and step cap
        (:class:`CalibrationSpec`; default its defaults).
    **options
        Fields of :class:`CalibrationSpec`, which replace the spec's: a convenience that builds the spec.
    every : int
        Steps between :class:`Progress` events.
    start : mapping of str to float, optional
        Warm start of the MAP search (see :func:`calibration_preview`).
    engine : Engine, optional
        The engine that searches and remembers (default: the process's, :func:`default_engine`).
    averaged : bool
        False to leave out the averaged drag preview (:func:`calibrate` does: nobody sees it).

    Notes
    -----
    The first event (the preview) is the MAP from every start but the searched stratified design
    (:func:`beam.calibration.starts.searched_starts`), which costs 0.5-1.5 s with an effect that
    changes the modes (lab_run_1, 7 modes); the search then continues from those starts and the
    preview's MAP, and the sampler starts at the better of the two: the final result's MAP is
    the one :func:`calibration_preview` finds (it runs the same two stages); the quick MAP stands
    unless the search beats it by :data:`SEARCH_GAIN_NATS`. Without a mode-changing effect both
    stages are the same.
    """
    spec = CalibrationSpec.of(spec, **options)
    walkers, steps, seed = spec.walkers, spec.steps, spec.seed
    if walkers is not None and (isinstance(walkers, bool) or walkers < 2):
        raise BeamInputError(f"walkers must be an integer >= 2, got {walkers}")
    if steps is not None and (isinstance(steps, bool) or steps < 10):
        raise BeamInputError(f"steps must be an integer >= 10, got {steps}")
    t0 = time.perf_counter()
    # the quick stage: every start but the searched stratified design, shown as the preview ...
    engine = default_engine() if engine is None else engine
    setup, problem = prepare(measurement, spec, start=start, search=False, engine=engine)
    recalled = _recalled_laplace(engine, problem, setup, cold=start is None)  # this model's MAP, found before
    first = averaged_preview(setup, problem, engine) if averaged and recalled is None else None
    if first is not None:  # seconds while the full model's MAP is searched
        first.seconds = time.perf_counter() - t0
        yield first
    laplace_result = _first_stage(engine, problem, setup, cold=False) if recalled is None else recalled
    preview = CalibrationResult(setup, problem, laplace_result, None, preview_bands(laplace_result, setup, seed),
                                time.perf_counter() - t0)
    yield preview
    if recalled is None:
        # ... then the searched design (0.5-1.5 s with a mode-changing effect), from which the MAP
        # search continues together with the preview's MAP: the sampler starts in the best basin found
        laplace_result = _searched_laplace(engine, problem, setup, laplace_result)
        _remember(engine, setup, laplace_result.map, cold=start is None)
    if setup.is_free and setup.model.is_nonlinear:  # the Laplace posterior: see beam.calibration.free_nonlinear
        laplace_result.warnings.append(LAPLACE_ONLY)
        bands = preview.bands if laplace_result is preview.laplace else preview_bands(laplace_result, setup, seed)
        yield CalibrationResult(setup, problem, laplace_result, None, bands, time.perf_counter() - t0, final=True)
        return
    if walkers is not None and walkers < 2 * problem.ndim:
        raise BeamInputError(f"walkers must be at least 2 x {problem.ndim} parameters = {2 * problem.ndim}, got {walkers}")
    run = EnsembleRun(problem, laplace_result, n_walkers=walkers or default_walkers(problem.ndim), seed=seed)
    if steps is not None:
        yield from run.sample(steps, every=every)
        posterior = run.result(target_ess=spec.target_ess)
    else:
        yield from run.sample_to_ess(spec.target_ess, every=every, max_steps=spec.max_steps)
        posterior = run.result(target_ess=spec.target_ess)
    bands = record_bands(problem, setup, posterior.thinned_draws(BAND_DRAWS, seed))  # = posterior.predict
    yield CalibrationResult(setup, problem, laplace_result, posterior, bands, time.perf_counter() - t0, final=True)
