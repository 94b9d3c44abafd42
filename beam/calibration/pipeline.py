"""One calibration pipeline: the calibration model is chosen once, where the setup is made.

:func:`make_setup` validates a :class:`~beam.calibration.spec.CalibrationSpec` on a record and
chooses its **calibration model** (:func:`calibration_model_for`), a small strategy object that
carries what differs between kinds of record and model (like emcee's moves):

======================  =================================  ================  ==========  =====================
calibration model       records                            starts            posterior   bands
======================  =================================  ================  ==========  =====================
:class:`PatchDriven`    driven by the patch voltage        the engine's      MCMC        draws
                                                           strategies, then
                                                           its second stage
:class:`ForceDriven`    driven by a point force            projected, null   MCMC        draws
:class:`FreeLinear`     free responses, linear model       projected, null   MCMC        draws
:class:`FreeNonlinear`  free responses, nonlinear effects  the linear        Laplace     linearised
                                                           sub-model's,
                                                           nested
:class:`Averaged`       the first look of a free decay     the linear        Laplace     linearised
                        with one effect that has an        sub-model's
                        averaged form
``JointModel``          several records of one beam        the records'      MCMC        draws, per record
                        (:mod:`beam.calibration.joint`)    own MAPs
======================  =================================  ================  ==========  =====================

Every calibration then runs the same stages (:mod:`beam.calibration.run`):
:func:`prepare` (the setup and the problem, its starts from the calibration model),
:func:`recalled_laplace` (the engine's remembered MAP of this model) or :func:`first_stage`
(the model's starts and search, kept no lower than a remembered sub-model's optimum), the
preview's bands, the model's second stage, and :func:`sample_posterior` (MCMC) or the Laplace
approximation as the posterior.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import replace
from typing import NamedTuple

import numpy as np

from beam.calibration.bands import fast_predictive_bands
from beam.calibration.defaults import DEFAULT_MODES
from beam.calibration.engine import FIRST_STAGE, MAP, Engine, default_engine
from beam.calibration.fit import fast_map
from beam.calibration.forward import BeamForwardModel
from beam.calibration.free import ProjectedFreeModel
from beam.calibration.free_starts import nonlinear_free_starts, projected_starting_points
from beam.calibration.records import check_calibration_record, decimate_measurement
from beam.calibration.setup import (
    MIN_WINDOW_SAMPLES,
    BeamCalibrationSetup,
    build_problem,
    check_window_holds_a_period,
    resolve_window,
    window_samples,
)
from beam.calibration.spec import CalibrationSpec
from beam.calibration.starts import kept_nested, null_starts
from beam.calibration.starts.search import has_second_stage
from beam.errors import BeamInputError
from beam.inference import EnsembleRun, LaplaceResult, MapResult, PosteriorResult, PredictiveBands, Problem, Progress, laplace
from beam.inference.progress import reporting
from beam.inference.sampling import ENSEMBLES
from beam.io.limits import MAX_CALIBRATION_SAMPLES
from beam.io.measurement import Measurement, true_unit_problem
from beam.physics.basis import DEFAULT_INTERVALS, DEFAULT_KNOTS
from beam.physics.effects import EFFECTS
from beam.physics.effects.base import PATCH_COUPLING
from beam.physics.model import BeamModel

__all__ = ["BAND_DRAWS", "KEPT_GUESSES", "LAPLACE", "LAPLACE_ONLY", "MCMC", "Averaged", "CalibrationModel",
           "FirstLook", "ForceDriven", "FreeLinear", "FreeNonlinear", "PatchDriven", "averaged_drag_preview",
           "best_guesses", "calibration_model_for", "checked_start", "clip_to_prior", "default_walkers", "first_stage",
           "kept_nested_laplace", "laplace_at", "lead_nan", "linear_sub_map", "make_setup", "prepare", "preview_fit",
           "preview_map", "recalled_laplace", "record_bands", "remember", "sample_posterior", "second_stage"]

#: The calibration's logger (one for the pipeline and its front doors, :mod:`beam.calibration.run`).
LOGGER = logging.getLogger("beam.calibration.run")

#: Posterior kinds: emcee's draws, or the Laplace approximation at the MAP itself.
MCMC = "mcmc"
LAPLACE = "laplace"
#: Posterior draws pushed through the model for the predictive bands.
BAND_DRAWS = 400
#: The warning of a nonlinear free decay's calibration, which ends at its Laplace approximation.
LAPLACE_ONLY = ("a free decay with a nonlinear effect is not sampled: the posterior is the Laplace approximation "
                "at the MAP and the bands are linearised (one evaluation integrates the decay and refits its "
                "initial state)")
#: Starting points a MAP search keeps after screening (each costs a least-squares run).
KEPT_GUESSES = 3


class FirstLook(NamedTuple):
    """A cheaper model's preview shown before the model's own (:meth:`CalibrationModel.first_look`):
    its Laplace approximation (on the model's problem), bands over the record, MAP prediction
    (read-only) and the label of what it approximates."""

    laplace: LaplaceResult
    bands: PredictiveBands
    prediction: np.ndarray
    note: str


# ---------------------------------------------------------------------------------------------
# the calibration models


class CalibrationModel:
    """How one kind of record and model is calibrated (see the module notes).

    Attributes
    ----------
    name : str
        A few words for reports.
    free : bool
        The record is a free response (its initial state profiled out, its start found).
    posterior : {"mcmc", "laplace"}
        What stands for the posterior: emcee's draws, or the Laplace approximation at the MAP.
    note : str or None
        A warning the final result carries (why it is not sampled), or None.
    """

    name = "calibration model"
    free = False
    posterior = MCMC
    note: str | None = None

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"

    # -- the setup ---------------------------------------------------------------------------
    def build(self, measurement: Measurement, spec: CalibrationSpec, model: BeamModel,
              engine: Engine) -> tuple[object, tuple[int, int]]:
        """The forward model of the record and the (release, first) sample indices the model
        describes; BeamInputError when this kind of calibration refuses the record or window."""
        raise NotImplementedError

    def fit_forward(self, setup: BeamCalibrationSetup, mask: np.ndarray) -> tuple[object, np.ndarray]:
        """The forward model on the record's samples ``mask`` and their times (the problem's)."""
        return setup.forward, setup.measurement.time_s[mask].copy()

    def proportional_parameter(self, setup: BeamCalibrationSetup) -> str | None:
        """The parameter the prediction is proportional to (:class:`beam.inference.Problem`), or None."""
        return None

    def likelihood_correction(self, forward) -> object | None:
        """The term the problem adds to the log likelihood of ``forward``'s prediction (the
        marginalisation over coefficients it profiles out, :class:`beam.inference.Problem`), or None."""
        return None

    # -- the search --------------------------------------------------------------------------
    def starts(self, problem: Problem, setup: BeamCalibrationSetup, engine: Engine, warm: Mapping[str, float] | None,
               search: bool) -> list[dict[str, float]]:
        """The starting points of the MAP search (natural units, physical parameters); ``warm`` a
        caller's start, ``search`` whether the second stage's starts are wanted too."""
        raise NotImplementedError

    def search(self, problem: Problem, guesses: list[dict[str, float]]) -> MapResult:
        """The MAP from ``guesses`` (:func:`beam.calibration.fit.fast_map`)."""
        return fast_map(problem, guesses)

    def has_second_stage(self, setup: BeamCalibrationSetup) -> bool:
        """Whether :meth:`second_stage` can move the first stage's MAP."""
        return False

    def second_stage(self, problem: Problem, setup: BeamCalibrationSetup, engine: Engine,
                     quick: LaplaceResult) -> LaplaceResult:
        """``quick`` (the first stage's MAP + Laplace), or the Laplace approximation at a better MAP."""
        return quick

    def first_look(self, setup: BeamCalibrationSetup, problem: Problem, engine: Engine) -> FirstLook | None:
        """A cheaper model's preview to show while the model's own MAP is searched, or None."""
        return None

    # -- results -----------------------------------------------------------------------------
    def bands(self, laplace_result: LaplaceResult, setup: BeamCalibrationSetup, seed: int) -> PredictiveBands:
        """Predictive bands over the record of the Laplace approximation (:data:`BAND_DRAWS` draws)."""
        return record_bands(laplace_result.problem, setup, laplace_result.draws(BAND_DRAWS, seed))

    def posterior_bands(self, problem: Problem, setup: BeamCalibrationSetup, posterior: PosteriorResult,
                        seed: int) -> PredictiveBands:
        """Predictive bands over the record of the posterior's draws (= ``posterior.predict``)."""
        return record_bands(problem, setup, posterior.thinned_draws(BAND_DRAWS, seed))

    def linear_fit(self, problem: Problem, values: Mapping[str, float]) -> dict | None:
        """The coefficients profiled out of the calibration at ``values`` (a free response's), or None."""
        return None

    def json_extras(self, setup: BeamCalibrationSetup) -> dict:
        """Keys this kind adds to the result's JSON (a free response's start)."""
        return {}


class _Driven(CalibrationModel):
    """A record driven by its input (the patch voltage or a point force), from rest."""

    def build(self, measurement, spec, model, engine):
        if model.is_nonlinear and (not measurement.uniform or measurement.output_kind != "displacement"):
            nonlinear = ", ".join(e for e in spec.effects if EFFECTS[e].nonlinear)
            raise BeamInputError(
                f"{nonlinear} is calibrated on a free decay, or on a driven record with uniform time stamps and a "
                "displacement output"
            )
        return BeamForwardModel(model, measurement, int(spec.modes)), (0, 0)


class PatchDriven(_Driven):
    """A record driven by the patch voltage: the engine's start strategies (k_p solved for by least
    squares, :mod:`beam.calibration.starts`) and its second stage; MCMC."""

    name = "driven by the patch voltage"

    def proportional_parameter(self, setup):
        """k_p for a linear model: its only input enters as k_p V, so the prediction is proportional
        to k_p (tested for every catalogue effect in ``tests/test_calibration_fit.py``)."""
        name = PATCH_COUPLING.name
        return name if not setup.model.is_nonlinear and name in setup.physical_names else None

    def starts(self, problem, setup, engine, warm, search):
        return engine.starting_points(problem, setup, warm, search=search)

    def has_second_stage(self, setup):
        return has_second_stage(setup)

    def second_stage(self, problem, setup, engine, quick):
        t0 = time.perf_counter()
        found = engine.searched_map(problem, setup, quick.map)
        if found is None:
            return quick  # the same basin (or worse): the preview's MAP stands, to the last digit
        return kept_nested_laplace(engine, problem, setup,
                                   laplace_at(problem, found, quick.seconds + time.perf_counter() - t0))


def _projected_starts(problem, setup, engine, warm) -> list[dict[str, float]]:
    """No coupling to solve for: spectral and screened starts with the linear coefficients
    profiled (:func:`~beam.calibration.free_starts.projected_starting_points`), then the
    remembered sub-models' optima (:func:`~beam.calibration.starts.null_starts`)."""
    return projected_starting_points(problem, setup, warm) + null_starts(problem, setup, engine)


class ForceDriven(_Driven):
    """A record driven by a measured point force: projected and null starts; MCMC."""

    name = "driven by a point force"

    def starts(self, problem, setup, engine, warm, search):
        return _projected_starts(problem, setup, engine, warm)


class FreeLinear(CalibrationModel):
    """A free response of a linear model: its initial state and offset profiled out
    (:class:`~beam.calibration.free.ProjectedFreeModel`), the release's transient left out;
    projected and null starts; MCMC."""

    name = "free response"
    free = True
    forward_class = ProjectedFreeModel

    def build(self, measurement, spec, model, engine):
        modes, window = int(spec.modes), spec.window
        indices = engine.free_start_indices(measurement, modes)
        t = measurement.time_s
        released = t >= t[indices[1]]
        mask = window_samples(measurement, window) & ~measurement.left_out & released
        if np.count_nonzero(mask) < MIN_WINDOW_SAMPLES:
            raise BeamInputError(
                f"calibration window {window[0]:g}:{window[1]:g} s holds fewer than {MIN_WINDOW_SAMPLES} samples after "
                f"the start of the free response at {t[np.argmax(released)]:g} s (the release of the beam and its "
                f"transient left out)"
            )
        self.check_start(measurement, model, mask, released)
        forward = self.forward_class(model, modes, measurement.output_kind, t[mask], measurement.output[mask],
                                     spec.likelihood)
        return forward, indices

    def check_start(self, measurement, model, mask, released) -> None:
        """Refuse a window that does not suit this model (a linear free response takes any)."""

    def fit_forward(self, setup, mask):
        """The forward model projecting on exactly the samples ``mask`` (rebuilt for another set)."""
        measurement, forward = setup.measurement, setup.forward
        data = measurement.output[mask]
        if not (forward.fit_time_s.size == data.size and np.array_equal(forward.fit_time_s, measurement.time_s[mask])):
            forward = self.forward_class(setup.model, setup.modes, measurement.output_kind, measurement.time_s[mask],
                                         data, setup.likelihood)
        return forward, forward.fit_time_s

    def starts(self, problem, setup, engine, warm, search):
        return _projected_starts(problem, setup, engine, warm)

    def likelihood_correction(self, forward):
        """The initial state and offset integrated out (:meth:`~beam.calibration.free.ProjectedFreeModel.log_likelihood_correction`)."""
        return forward.log_likelihood_correction

    def linear_fit(self, problem, values):
        return problem.model.linear_fit(values)

    def json_extras(self, setup):
        release, first = setup.start_indices
        return {"free_response_start_s": setup.free_start_s,
                "free_response_release_s": float(setup.measurement.time_s[release]),
                "release_transient_samples_left_out": int(first - release)}


class FreeNonlinear(FreeLinear):
    """A free decay with a nonlinear effect (:class:`~beam.calibration.free_nonlinear.NonlinearFreeModel`):
    started from the linear sub-model's optimum (nested), searched by its joint least squares,
    the Laplace approximation as the posterior and linearised bands; the averaged model's preview
    first where one effect has an averaged form (:class:`Averaged`)."""

    name = "free decay with a nonlinear effect"
    posterior = LAPLACE
    note = LAPLACE_ONLY

    @property
    def forward_class(self):
        from beam.calibration.free_nonlinear import NonlinearFreeModel

        return NonlinearFreeModel

    def check_start(self, measurement, model, mask, released):
        t = measurement.time_s
        if np.any(released & ~measurement.left_out & (t < t[mask][0])):
            nonlinear = ", ".join(e for e in model.effects if EFFECTS[e].nonlinear)
            raise BeamInputError(
                f"{nonlinear} on a free decay is integrated forward from the window's first sample: start the window "
                f"at the start of the free response ({t[np.argmax(released)]:g} s) or earlier"
            )

    def starts(self, problem, setup, engine, warm, search):
        from beam.calibration.slowflow import curve_starts

        linear = linear_sub_map(setup, engine)
        chosen = nonlinear_free_starts(problem, setup, linear, warm)
        if sum(EFFECTS[e].nonlinear for e in setup.effects) > 1:  # a sub-model with a nonlinear effect of its own
            chosen += null_starts(problem, setup, engine)  # remembered (the drag's before the friction): nested too
        # the averaged MAP on the record's own backbone and damping curves: where the averaged
        # time-domain model, started at the nested optimum, cannot leave the null (a joint that
        # never slips moves nothing, so its gradient there vanishes)
        curves = curve_starts(setup.measurement, setup.effects, setup.window, linear, setup.physical_names)
        problem.model.curve_starts = curves
        return chosen + curves

    def search(self, problem, guesses):
        return problem.model.map_search(problem, guesses)

    def bands(self, laplace_result, setup, seed):
        """The delta method (:meth:`~beam.calibration.free_nonlinear.NonlinearFreeModel.linearised_bands`)."""
        time_s = setup.measurement.time_s[setup.start_indices[1]:]
        return lead_nan(setup, laplace_result.problem.model.linearised_bands(laplace_result, time_s))

    def first_look(self, setup, problem, engine):
        averaged = Averaged.of(setup)
        return None if averaged is None else averaged.look(setup, problem, engine)


class Averaged(CalibrationModel):
    """The averaged (slow-flow) calibration of a free decay whose nonlinear effects all have an
    averaged form (:attr:`~beam.physics.effects.effect.Effect.averaged`, :mod:`beam.calibration.free_averaged`):
    no integration; started from the linear sub-model's optimum; its Laplace approximation and
    linearised bands are the averaged model's (they do not include its approximation error).
    The first look of :class:`FreeNonlinear` and :func:`averaged_drag_preview`."""

    name = "averaged free decay"
    free = True
    posterior = LAPLACE

    def __init__(self, effect: str, *more: str) -> None:
        self.effect = effect
        self.effects = (effect, *more)

    def __repr__(self) -> str:
        return f"Averaged({', '.join(repr(e) for e in self.effects)})"

    @classmethod
    def of(cls, setup: BeamCalibrationSetup) -> Averaged | None:
        """The averaged calibration of a free decay whose nonlinear effects all have averaged forms, else None."""
        nonlinear = [e for e in setup.effects if EFFECTS[e].nonlinear]
        if not setup.calibration.free or not nonlinear or any(EFFECTS[e].averaged is None for e in nonlinear):
            return None
        return cls(*nonlinear)

    def fit(self, setup: BeamCalibrationSetup, problem: Problem, engine: Engine):
        """The averaged model's MAP and Laplace covariance (:class:`~beam.calibration.free_averaged.AveragedDragFit`)
        from the linear sub-model's optimum (:func:`linear_sub_map`, remembered by ``engine``)."""
        from beam.calibration.free_averaged import AveragedDragModel

        return AveragedDragModel(problem.model).fit_nested(problem, linear_sub_map(setup, engine))

    def look(self, setup: BeamCalibrationSetup, problem: Problem, engine: Engine) -> FirstLook | None:
        """:meth:`fit` as a first look (bands and MAP prediction, labelled with the form's note), or
        None when the averaged model does not apply (a mode overdamped at the start, a singular
        Laplace matrix) or fails: logged, never raised."""
        from beam.calibration.free_averaged import AveragedDragModel, averaged_laplace

        t0 = time.perf_counter()
        try:
            fit = self.fit(setup, problem, engine)
            times = setup.measurement.time_s[setup.start_indices[1]:]
            bands = lead_nan(setup, AveragedDragModel(problem.model).bands(fit, problem, times))
            laplace_result = averaged_laplace(problem, fit, time.perf_counter() - t0)
        except (BeamInputError, np.linalg.LinAlgError) as exc:  # the averaged model does not apply
            LOGGER.info("no averaged preview for %s: %s", setup.measurement.name, exc)
            return None
        except Exception:  # an optional first look: its failure must not cost the calibration
            LOGGER.warning("the averaged preview of %s failed", setup.measurement.name, exc_info=True)
            return None
        prediction = bands.mean.copy()
        prediction.flags.writeable = False
        return FirstLook(laplace_result, bands, prediction, fit.note)


#: The calibration models of single records (stateless: one each).
PATCH_DRIVEN, FORCE_DRIVEN, FREE_LINEAR, FREE_NONLINEAR = PatchDriven(), ForceDriven(), FreeLinear(), FreeNonlinear()


def calibration_model_for(measurement: Measurement, model: BeamModel) -> CalibrationModel:
    """The calibration model of ``model`` on ``measurement``: the one place the kind of record is told."""
    if measurement.is_free:
        return FREE_NONLINEAR if model.is_nonlinear else FREE_LINEAR
    return PATCH_DRIVEN if measurement.input_kind == "voltage" else FORCE_DRIVEN


def make_setup(measurement: Measurement, spec: CalibrationSpec | None = None, *, engine: Engine | None = None,
               intervals: int = DEFAULT_INTERVALS, knots: str = DEFAULT_KNOTS, **options) -> BeamCalibrationSetup:
    """Validate ``spec`` on the record, build the model and choose its calibration model
    (BeamInputError on any bad choice).

    ``spec`` (or the keywords ``options``, fields of :class:`CalibrationSpec`, which replace its
    values) says what is calibrated: the window (default the spec's share of the record), the
    effects (each effect's :attr:`~beam.physics.effects.effect.Effect.refusals` checked against
    the record's features), the modes (``"auto"`` chosen from the record; without a spec the
    model builder's :data:`~beam.calibration.defaults.DEFAULT_MODES`), the likelihood. ``engine``
    (default: the process's) remembers the free responses' starts. ``intervals`` and ``knots``
    set the Galerkin mesh (:mod:`beam.physics.basis`; default: the patch knots, as
    ``beam simulate`` uses).
    """
    engine = default_engine() if engine is None else engine
    if spec is None:
        options.setdefault("modes", DEFAULT_MODES)
    spec = CalibrationSpec.of(spec, **options)
    if spec.window is None:
        spec = replace(spec, window=spec.default_window(measurement))
    spec = spec.resolve(measurement)
    window = resolve_window(measurement, spec.window)
    check_calibration_record(measurement, window)
    model = BeamModel(measurement.geometry, spec.effects, intervals, knots, input_kind=measurement.input_kind)
    modes = spec.modes
    if not 1 <= modes <= model.size:
        raise BeamInputError(f"modes must be between 1 and {model.size} (the mesh holds {model.size} modes), got {modes}")
    features = measurement.features
    for effect in spec.effects:
        refusal = EFFECTS[effect].refusal(features)
        if refusal is not None:
            raise BeamInputError(refusal)
    scale = true_unit_problem(measurement, spec.effects)  # a force that depends on the amplitude needs its unit
    if scale is not None:
        raise BeamInputError(scale)
    calibration = calibration_model_for(measurement, model)
    forward, indices = calibration.build(measurement, spec, model, engine)
    setup = BeamCalibrationSetup(measurement, spec, model, forward, calibration, indices)
    check_window_holds_a_period(setup)
    return setup


# ---------------------------------------------------------------------------------------------
# the stages


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
    second stage's starts too; default engine: the process's).

    ``spec`` (or the keywords ``options``, fields of :class:`CalibrationSpec`, which replace its
    values) says what is calibrated; it is resolved on the record (:meth:`CalibrationSpec.resolve`).

    The problem's ``initial_guesses`` hook returns the starting points of the MAP search: those
    of the setup's calibration model (:meth:`CalibrationModel.starts`), then the
    :data:`KEPT_GUESSES` best ``extra_guesses``; a warm ``start`` (see
    :func:`beam.calibration.run.calibration_preview`) takes the place of the short-window MAP.

    A record longer than :data:`beam.io.limits.MAX_CALIBRATION_SAMPLES` is decimated first (anti-
    aliased; see :mod:`beam.io.limits`): ``setup.measurement`` is then the decimated record.
    """
    engine = default_engine() if engine is None else engine
    measurement, _ = decimate_measurement(measurement, MAX_CALIBRATION_SAMPLES)
    setup = make_setup(measurement, CalibrationSpec.of(spec, **options).resolve(measurement), engine=engine)
    extra = [dict(g) for g in extra_guesses]
    warm = None if start is None else checked_start(start, setup.physical_names)

    def starts(problem: Problem) -> list[dict[str, float]]:
        warm_start = None if warm is None else clip_to_prior(problem, warm)
        chosen = setup.calibration.starts(problem, setup, engine, warm_start, search)
        return chosen + (best_guesses(problem, extra) if extra else [])

    return setup, build_problem(setup, initial_guesses=starts)


def preview_map(measurement: Measurement, spec: CalibrationSpec, *, extra_guesses: Iterable[dict[str, float]] = (),
                start: Mapping[str, float] | None = None, search: bool = True,
                engine: Engine | None = None) -> tuple[BeamCalibrationSetup, Problem, LaplaceResult, bool]:
    """The MAP + Laplace of :func:`beam.calibration.run.calibration_preview` without its bands:
    ``(setup, problem, laplace, screened)`` (same arguments; the same search, recall and memory of
    the engine)."""
    extra_guesses = tuple(extra_guesses)
    engine = default_engine() if engine is None else engine
    setup, problem = prepare(measurement, spec, extra_guesses=extra_guesses, start=start, search=False, engine=engine)
    cold = start is None and not extra_guesses
    laplace_result = recalled_laplace(engine, problem, setup, cold)
    screened = False
    if laplace_result is None:
        quick = first_stage(engine, problem, setup, cold)
        if not search:
            laplace_result, screened = quick, setup.calibration.has_second_stage(setup)  # else it is the engine's MAP
            remember(engine, setup, quick.map, cold, FIRST_STAGE if screened else MAP)
        else:
            laplace_result = second_stage(engine, problem, setup, quick)
            remember(engine, setup, laplace_result.map, cold)
    return setup, problem, laplace_result, screened


def linear_sub_map(setup: BeamCalibrationSetup, engine: Engine) -> dict[str, float]:
    """The MAP (natural units) of the preview of ``setup``'s model without its nonlinear effects
    (same record, window, modes and likelihood; no bands), remembered by ``engine``: the nested
    start of a nonlinear free decay's calibration and of its averaged preview."""
    linear = tuple(e for e in setup.effects if not EFFECTS[e].nonlinear)
    return preview_map(setup.measurement, setup.spec.for_model(linear), engine=engine)[2].map.values


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
    so that R-hat compares independent chains (the measurements behind it: the design decisions)."""
    return 2 * ENSEMBLES * int(n_parameters)


def preview_fit(problem: Problem, search=None) -> LaplaceResult:
    """MAP + Laplace of a prepared problem by ``search`` (a calibration model's
    :meth:`~CalibrationModel.search`; default the fast search of :mod:`beam.calibration.fit`)
    from the starts of the problem's ``initial_guesses`` hook (see :func:`prepare`).

    Returns
    -------
    LaplaceResult
        ``seconds`` is the wall time of the search and the approximation.
    """
    t0 = time.perf_counter()
    result = laplace(problem, (fast_map if search is None else search)(problem, problem.initial_guesses(problem)))
    result.seconds = time.perf_counter() - t0
    return result


def laplace_at(problem: Problem, found: MapResult, seconds: float = 0.0) -> LaplaceResult:
    """The Laplace approximation at ``found``; ``seconds`` (plus its own time) as its wall time."""
    t0 = time.perf_counter()
    result = laplace(problem, found)
    result.seconds = seconds + time.perf_counter() - t0
    return result


def kept_nested_laplace(engine: Engine, problem: Problem, setup: BeamCalibrationSetup,
                        result: LaplaceResult) -> LaplaceResult:
    """``result``, or the Laplace approximation at a remembered sub-model's optimum embedded in
    the model when the search ended lower (:func:`beam.calibration.starts.kept_nested`): nested
    fits are monotone."""
    t0 = time.perf_counter()
    found = kept_nested(problem, setup, result.map, engine)
    return result if found is result.map else laplace_at(problem, found, result.seconds + time.perf_counter() - t0)


def recalled_laplace(engine: Engine, problem: Problem, setup: BeamCalibrationSetup,
                     cold: bool) -> LaplaceResult | None:
    """For a cold start: the Laplace approximation at the engine's remembered MAP of this very
    model, or None when none is remembered (the same MAP, to the last digit)."""
    if not cold:
        return None
    found = engine.recall(setup)
    return None if found is None else laplace_at(problem, found)


def first_stage(engine: Engine, problem: Problem, setup: BeamCalibrationSetup, cold: bool) -> LaplaceResult:
    """The first stage of a preview (:func:`preview_fit` by the model's search, kept no lower
    than a remembered sub-model's optimum), or for a cold start the engine's remembered
    first-stage MAP of this model (a screening fit's, from the same starts)."""
    found = engine.recall(setup, FIRST_STAGE) if cold else None
    if found is not None:
        return laplace_at(problem, found)
    with reporting(None, "first stage"):  # what the search reports, under the caller's label
        return kept_nested_laplace(engine, problem, setup, preview_fit(problem, setup.calibration.search))


def second_stage(engine: Engine, problem: Problem, setup: BeamCalibrationSetup, quick: LaplaceResult) -> LaplaceResult:
    """The calibration model's second stage from the first stage's ``quick`` result
    (:meth:`CalibrationModel.second_stage`), its search's reports under "second stage" when the
    model has one (:mod:`beam.inference.progress`)."""
    if not setup.calibration.has_second_stage(setup):
        return setup.calibration.second_stage(problem, setup, engine, quick)
    with reporting(None, "second stage"):
        return setup.calibration.second_stage(problem, setup, engine, quick)


def remember(engine: Engine, setup: BeamCalibrationSetup, found: MapResult, cold: bool, kind: str = MAP) -> None:
    """Keep a cold-started calibration's MAP in the engine (for the nested and null starts of
    larger models and later calibrations of this one)."""
    if cold:
        engine.remember(setup, found, kind)


def sample_posterior(problem: Problem, laplace_result: LaplaceResult, spec: CalibrationSpec,
                     every: int = 50) -> Iterator[Progress]:
    """emcee from the Laplace approximation (:class:`beam.inference.EnsembleRun`) to
    ``spec.target_ess`` (or exactly ``spec.steps`` steps), yielding :class:`Progress` every
    ``every`` steps; returns the :class:`PosteriorResult` (the generator's value)."""
    walkers = spec.walkers
    if walkers is not None and walkers < 2 * problem.ndim:
        raise BeamInputError(f"walkers must be at least 2 x {problem.ndim} parameters = {2 * problem.ndim}, got {walkers}")
    run = EnsembleRun(problem, laplace_result, n_walkers=walkers or default_walkers(problem.ndim), seed=spec.seed)
    if spec.steps is not None:
        yield from run.sample(spec.steps, every=every)
    else:
        yield from run.sample_to_ess(spec.target_ess, every=every, max_steps=spec.max_steps)
    return run.result(target_ess=spec.target_ess)


def record_bands(problem: Problem, setup: BeamCalibrationSetup, draws: Mapping[str, np.ndarray]) -> PredictiveBands:
    """Predictive bands of ``draws`` over the whole record (output's unit), by
    :func:`fast_predictive_bands`; NaN before the first sample the model describes
    (:attr:`~beam.calibration.setup.BeamCalibrationSetup.start_indices`: for a free response the
    end of the release's transient on, extrapolated backwards its decaying terms grow without
    bound: adxl_50cm_114759, released at 0.33 s: 1e22 m/s² at t = 0)."""
    time_s = setup.measurement.time_s
    return lead_nan(setup, fast_predictive_bands(problem, draws, time_s[setup.start_indices[1]:]))


def lead_nan(setup: BeamCalibrationSetup, bands: PredictiveBands) -> PredictiveBands:
    """``bands`` from the first sample the model describes on, extended back over the whole record with NaN."""
    time_s = setup.measurement.time_s
    first = time_s.size - bands.time_s.size
    if first == 0:
        return bands
    lead = np.full(first, np.nan)
    return replace(bands, time_s=time_s, **{name: np.concatenate([lead, getattr(bands, name)]) for name in (
        "mean", "credible_lower", "credible_upper", "prediction_lower", "prediction_upper")})


def averaged_drag_preview(measurement: Measurement, window: tuple[float, float], effects, modes: int | None = None,
                          likelihood: str = "iid", engine: Engine | None = None):
    """The averaged model's fit of a free decay's calibration with one nonlinear effect that has an
    averaged form (``quadratic_drag``): the calibration preview of the model without it (the
    linear sub-model, remembered by ``engine``), then the averaged model's MAP and Laplace
    approximation from its optimum (:meth:`Averaged.fit`, the first look of the calibration
    itself). Labelled with the form's note; its intervals are those of the averaged model and do
    not include its approximation error.

    Parameters
    ----------
    measurement : Measurement
        A free decay of a beam with a width.
    window : (float, float)
        Calibration window (s), starting at the free response's start.
    effects : str or sequence of str
        The effects, the averaged one among them (its only nonlinear effect).
    modes : int, optional
        Retained modes (the spec's default choice, ``"auto"``, otherwise).
    likelihood : str
        ``"iid"`` or ``"ar1"``.
    engine : Engine, optional
        Shared with the caller's calibrations (the linear sub-model's preview is remembered).

    Returns
    -------
    AveragedDragFit
    """
    engine = default_engine() if engine is None else engine
    spec = CalibrationSpec.of(None, window=window, effects=effects, likelihood=likelihood, modes=modes)
    setup, problem = prepare(measurement, spec, engine=engine)
    averaged = Averaged.of(setup)
    if averaged is None:
        forms = ", ".join(e for e in EFFECTS if EFFECTS[e].averaged is not None)
        raise BeamInputError(f"the averaged preview is for a free decay with one nonlinear effect that has an averaged "
                             f"form ({forms})")
    return averaged.fit(setup, problem, engine)
