"""Calibrate the beam on a measurement window and predict the rest of the record.

What is calibrated is a :class:`~beam.calibration.spec.CalibrationSpec` (the keyword options of
every function here build one); how, the setup's calibration model
(:mod:`beam.calibration.pipeline`); the MAP is searched, and remembered, by an
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
import math
import time
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from beam.calibration.engine import FIRST_STAGE, MAP, Engine, default_engine  # noqa: F401 - re-exported
from beam.calibration.pipeline import (  # noqa: F401 - the pipeline's stages, re-exported
    BAND_DRAWS,
    KEPT_GUESSES,
    LAPLACE,
    LAPLACE_ONLY,
    LOGGER,
    best_guesses,
    checked_start,
    clip_to_prior,
    default_walkers,
    first_stage,
    laplace_at,
    linear_sub_map,
    make_setup,
    prepare,
    preview_fit,
    preview_map,
    recalled_laplace,
    record_bands,
    remember,
    sample_posterior,
    second_stage,
)
from beam.calibration.records import decimate_measurement
from beam.calibration.setup import BeamCalibrationSetup
from beam.calibration.spec import CalibrationSpec
from beam.calibration.starts import SEARCH_GAIN_NATS  # noqa: F401 - re-exported
from beam.inference import (
    NOISE_SD,
    LaplaceResult,
    MapResult,
    PosteriorResult,
    PredictiveBands,
    Problem,
    Progress,
)
from beam.inference.summaries import summarize_draws
from beam.io.anchor import mode_order_warnings
from beam.io.artifacts import record_warnings
from beam.io.limits import MAX_CALIBRATION_SAMPLES
from beam.io.measurement import Measurement
from beam.physics.effects import effect_of_parameter, parameter_spec
from beam.io.text import atomic_write_texts

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
        a cheaper model (the averaged model's note, :data:`~beam.calibration.free_averaged.AVERAGED_NOTE`
        for the drag: the first event of :func:`calibration_stream` on a free decay whose nonlinear
        effect has an averaged form), whose laplace, bands and MAP prediction are that model's.
        Never remembered as the model's MAP.
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
        """Whether this is the averaged model's preview (:attr:`approximation`)."""
        return self.approximation is not None

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
        """RMSE of the MAP prediction in the calibration window (output's unit; clipped samples left
        out): the one figure of the model's error in the window that the JSON, the diagnosis's
        header, ladder and verdict and the dashboard quote (:attr:`rmse_calibration_map`)."""
        return self.rmse_calibration_map

    @property
    def rmse_prediction(self) -> float:
        """Held-out RMSE of the MAP prediction (output's unit; NaN without a held-out part): the one
        figure of the model's error after the window everything quotes (:attr:`rmse_prediction_map`;
        the band gives the coverage, :attr:`coverage95_prediction`)."""
        return self.rmse_prediction_map

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
        return self.setup.calibration.linear_fit(self.problem, self.laplace.map.values)

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
            **self.setup.calibration.json_extras(self.setup),
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
                         *mode_order_warnings(m, self.setup.model, self.laplace.map.values), *record_warnings(m),
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
        spec = CalibrationSpec(window=window, effects=effects[1:] if first else effects, modes=modes, likelihood=likelihood)
        remember(engine, make_setup(measurement, spec, engine=engine), found, cold=True, kind=FIRST_STAGE if first else MAP)


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


def preview_bands(laplace_result: LaplaceResult, setup: BeamCalibrationSetup, seed: int) -> PredictiveBands:
    """Predictive bands of the preview over the record: the setup's calibration model's
    (:meth:`~beam.calibration.pipeline.CalibrationModel.bands`; :data:`BAND_DRAWS` Laplace
    draws, the same bands as ``laplace_result.predict(time_s, n_draws=BAND_DRAWS, seed=seed)`` to the
    tolerance of the prediction band's edges, or a nonlinear free decay's linearised bands)."""
    return setup.calibration.bands(laplace_result, setup, seed)


def calibrate(measurement: Measurement, spec: CalibrationSpec | None = None, **options) -> CalibrationResult:
    """Full calibration: preview, then emcee to ``spec.target_ess`` (or exactly ``spec.steps`` steps).

    Takes the arguments of :func:`calibration_stream` and returns its final result.
    """
    final = None
    for event in calibration_stream(measurement, spec, averaged=False, **options):  # nobody watches its previews
        if isinstance(event, CalibrationResult) and (final is None or final.is_preview):
            final = event
    return final


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

    On a free decay whose only nonlinear effect has an averaged form (``quadratic_drag``; with
    ``averaged``), a first event comes before the preview: the averaged model's (the calibration
    model's :meth:`~beam.calibration.pipeline.CalibrationModel.first_look`,
    :attr:`CalibrationResult.approximation` set, :data:`~beam.calibration.free_averaged.AVERAGED_NOTE`
    among its Laplace warnings), while the full model's MAP, which integrates the decay, is searched.

    One straight path for every kind of record: the setup's calibration model
    (:mod:`beam.calibration.pipeline`, chosen once by :func:`~beam.calibration.pipeline.make_setup`)
    carries what differs: its starts, search, second stage, posterior (MCMC or Laplace) and bands.

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
        False to leave out the averaged preview (:func:`calibrate` does: nobody sees it).

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
    t0 = time.perf_counter()
    engine = default_engine() if engine is None else engine
    # the quick stage: every start but the second stage's, shown as the preview ...
    setup, problem = prepare(measurement, spec, start=start, search=False, engine=engine)
    kind = setup.calibration
    recalled = recalled_laplace(engine, problem, setup, cold=start is None)  # this model's MAP, found before
    look = kind.first_look(setup, problem, engine) if averaged and recalled is None else None
    if look is not None:  # a cheaper model's preview while the model's own MAP is searched
        yield CalibrationResult(setup, problem, look.laplace, None, look.bands, time.perf_counter() - t0,
                                _map_output=look.prediction, approximation=look.note)
    laplace_result = first_stage(engine, problem, setup, cold=False) if recalled is None else recalled
    preview = CalibrationResult(setup, problem, laplace_result, None, kind.bands(laplace_result, setup, spec.seed),
                                time.perf_counter() - t0)
    yield preview
    if recalled is None:
        # ... then the second stage (the searched design, 0.5-1.5 s with a mode-changing effect), from
        # which the MAP search continues together with the preview's MAP: the sampler starts in the best basin found
        laplace_result = second_stage(engine, problem, setup, laplace_result)
        remember(engine, setup, laplace_result.map, cold=start is None)
    if kind.posterior == LAPLACE:  # the Laplace approximation is the posterior (a nonlinear free decay's)
        laplace_result.warnings.append(kind.note)
        bands = preview.bands if laplace_result is preview.laplace else kind.bands(laplace_result, setup, spec.seed)
        yield CalibrationResult(setup, problem, laplace_result, None, bands, time.perf_counter() - t0, final=True)
        return
    posterior = yield from sample_posterior(problem, laplace_result, spec, every)
    bands = kind.posterior_bands(problem, setup, posterior, spec.seed)
    yield CalibrationResult(setup, problem, laplace_result, posterior, bands, time.perf_counter() - t0, final=True)
