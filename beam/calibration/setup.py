"""The beam as a calibration problem: window, priors, forward model.

Model = base (``bending_stiffness_Nm2``, ``patch_coupling_NmV``) + chosen effects, with a chosen
number of retained modes; rho is fixed from the measurement's sidecar.

Priors
------
A parameter with a ``[nominal]`` value gets a log-normal prior centred (median) on it, truncated
at ±4 sigma; sigma (of log x) depends on how well such a quantity is usually known
(:data:`NOMINAL_LOG_SD`): stiffness and density 0.5 (a factor 1.6 at one sigma), the patch's
coupling 0.7, masses 1.0, damping, clamp stiffness and the cubic spring 1.5 (a factor 4.5).
Without a nominal value the prior is log-uniform over the catalogue's default range
(:class:`beam.physics.effects.ParameterSpec`). The noise sd is log-uniform from 1e-4 to 2 times the RMS
of the data in the window, and the AR(1) coefficient uniform on (-1, 1) (logit coordinate).
The sensor's mass has the masses' 1.0, the modal damping ratios the dampings' 1.5; without
nominal values they are log-uniform over 1e-7-0.2 kg and 1e-5-0.3.

Records
-------
Every kind of record is calibrated: input voltage, point force or none; output displacement,
velocity or acceleration (the data and the noise sd in the output's unit); uniform or irregular
time stamps (:meth:`beam.physics.model.BeamModel.response` or
:meth:`~beam.physics.model.BeamModel.response_at`). Clipped samples, and the spikes and rail
values the reading flagged (:attr:`beam.io.measurement.Measurement.left_out`), are left out of the
likelihood (and of the RMSE). A free response (no input) is fitted by variable projection: its unknown initial state
and the sensor's offset are linear and profiled out (:mod:`beam.calibration.free`); with a
nonlinear effect (the drag, the tip spring) refined by Gauss–Newton from that linear profile
(:mod:`beam.calibration.free_nonlinear`), the window starting at the free response's start.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np

from beam.calibration.free import ProjectedFreeModel, free_start_indices
from beam.calibration.records import check_calibration_record
from beam.calibration import defaults
from beam.calibration.defaults import (  # noqa: F401 - the defaults' one source, re-exported
    AUTO_MODES,
    DEFAULT_EFFECTS,
    DEFAULT_MODES,
    DEFAULT_WINDOW_FRACTION,
)
from beam.errors import BeamInputError
from beam.inference import (
    AR1_COEFFICIENT,
    LIKELIHOODS,
    NOISE_SD,
    LogNormal,
    LogUniform,
    Parameter,
    Problem,
    Uniform,
)
from beam.io.measurement import Measurement
from beam.physics.basis import DEFAULT_INTERVALS, DEFAULT_KNOTS
from beam.physics.effects import EFFECTS, FREE_LENGTH_LOG_SD, PARAMETER_SPECS, parse_effects
from beam.physics.model import BeamModel

#: Fewest samples a calibration window may hold.
MIN_WINDOW_SAMPLES = 20

#: sigma of log x for a prior centred on a nominal value.
NOMINAL_LOG_SD: dict[str, float] = {
    "bending_stiffness_Nm2": 0.5,
    "patch_coupling_NmV": 0.7,
    "air_damping_Ns_m2": 1.5,
    "kelvin_voigt_Nm2s": 1.5,
    "tip_mass_kg": 1.0,
    "clamp_stiffness_Nm_rad": 1.5,
    "patch_added_density_kg_m": 0.5,
    "patch_added_stiffness_Nm2": 0.5,
    "patch_added_kelvin_voigt_Nm2s": 1.5,
    "tip_cubic_stiffness_N_m3": 1.5,
    "sensor_mass_kg": 1.0,
    "drag_coefficient": 1.0,
    "effective_length_m": FREE_LENGTH_LOG_SD,
}
#: sigma of log x for a damping ratio of the ``modal_damping`` family centred on a nominal value.
MODAL_DAMPING_LOG_SD = 1.5
_TRUNCATION_SIGMAS = 4.0


def nominal_log_sd(name: str) -> float:
    """sigma of log x of a parameter's prior around a nominal value (see the module notes)."""
    if name.startswith("damping_ratio_mode_"):
        return MODAL_DAMPING_LOG_SD
    return NOMINAL_LOG_SD[name]


def parameter_prior(name: str, nominal: Mapping[str, float], spreads: Mapping[str, float] | None = None):
    """The prior of a physical parameter (see the module notes); ``spreads`` (the record's
    :attr:`~beam.io.measurement.Measurement.nominal_spread`) overrides sigma of log x where the
    beam's description says how well a value is known."""
    spec = PARAMETER_SPECS[name]
    if name in nominal:
        centre, sd = float(nominal[name]), float((spreads or {}).get(name, nominal_log_sd(name)))
        spread = math.exp(_TRUNCATION_SIGMAS * sd)
        return LogNormal(centre, sd, lower=centre / spread, upper=centre * spread)
    return LogUniform(spec.prior_low, spec.prior_high)


def prior_centre(name: str, nominal: Mapping[str, float]) -> float:
    """Centre of a parameter's prior: the nominal value, or the geometric mean of the range."""
    if name in nominal:
        return float(nominal[name])
    spec = PARAMETER_SPECS[name]
    return math.sqrt(spec.prior_low * spec.prior_high)


def resolve_window(measurement: Measurement, window: tuple[float, float] | None) -> tuple[float, float]:
    """The calibration window [start, end] (s), default the first
    :data:`~beam.calibration.defaults.DEFAULT_WINDOW_FRACTION` of the record.

    Raises BeamInputError when it lies outside the record or holds too few samples.
    """
    t = measurement.time_s
    if window is None:  # the default's value when asked (beam.calibration.defaults)
        start = float(t[0])
        end = float(t[0] + defaults.DEFAULT_WINDOW_FRACTION * (t[-1] - t[0]))
    else:
        start, end = (float(v) for v in window)
    if not (math.isfinite(start) and math.isfinite(end)) or not start < end:
        raise BeamInputError(f"calibration window must have start < end, got {start}:{end}")
    if start < t[0] - 1e-9 or end > t[0] + measurement.duration_s + 1e-9:  # the record covers n dt
        raise BeamInputError(
            f"calibration window {start:g}:{end:g} s lies outside the record ({t[0]:g} to {t[-1]:g} s)"
        )
    inside = int(np.count_nonzero((t >= start - 1e-12) & (t <= end + 1e-12)))
    if inside < MIN_WINDOW_SAMPLES:
        raise BeamInputError(f"calibration window {start:g}:{end:g} s holds {inside} samples; at least {MIN_WINDOW_SAMPLES} are needed")
    return start, end


@dataclass
class BeamForwardModel:
    """Vectorised forward model of a driven record for :class:`beam.inference.Problem`.

    The beam starts at rest at the first sample of the record and is driven by the record's
    input (voltage or point force); ``model(values, time_s)`` returns the sensor's output
    (displacement m, velocity m/s or acceleration m/s², as the record) at the requested
    samples, which must be samples of the record. A uniform record is stepped by
    :meth:`BeamModel.response`, an irregular one by :meth:`BeamModel.response_at` (exactly at
    the recorded stamps). Free responses have :class:`beam.calibration.free.ProjectedFreeModel`.
    """

    model: BeamModel
    measurement: Measurement
    modes: int

    def __post_init__(self) -> None:
        if self.measurement.is_free:
            raise BeamInputError("a free response has no input to drive the model: use ProjectedFreeModel")
        self._names = self.model.parameter_names_for(self.modes)
        self._index_cache: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    def sample_indices(self, time_s: np.ndarray) -> np.ndarray | slice:
        """Record indices of the times ``time_s`` (cached per array object): a slice when they
        are consecutive samples (a window, the whole record), else an index array."""
        cached = self._index_cache.get(id(time_s))
        if cached is not None and cached[0] is time_s:
            return cached[1]
        record = self.measurement.time_s
        times = np.asarray(time_s, dtype=float)
        if self.measurement.uniform:
            t0, dt = record[0], self.measurement.sample_interval_s
            index = np.rint((times - t0) / dt).astype(int)
        else:
            index = np.clip(np.searchsorted(record, times), 0, record.size - 1)
            below = np.clip(index - 1, 0, record.size - 1)
            index = np.where(np.abs(record[below] - times) < np.abs(record[index] - times), below, index)
            step = self.measurement.min_interval_s
            if index.size and np.max(np.abs(record[index] - times)) > 1e-6 * step:
                raise BeamInputError("prediction times must be time stamps of the record")
        if index.size and (index.min() < 0 or index.max() >= record.size):
            raise BeamInputError("prediction times must lie within the record")
        if index.size and np.array_equal(index, np.arange(index[0], index[0] + index.size)):
            index = slice(int(index[0]), int(index[0]) + index.size)
        self._index_cache[id(time_s)] = (time_s, index)
        return index

    def __call__(self, values: Mapping[str, np.ndarray], time_s: np.ndarray) -> np.ndarray:
        index = self.sample_indices(time_s)
        if isinstance(index, slice):
            needed = index.stop
        else:
            needed = int(index.max()) + 1 if index.size else 1
        needed = max(needed, 2)
        parameters = {name: values[name] for name in self._names}
        record = self.measurement
        if record.uniform:
            response = self.model.response(parameters, record.input[:needed], record.sample_interval_s, self.modes,
                                           output=record.output_kind)
        else:
            response = self.model.response_at(parameters, record.input[:needed], record.time_s[:needed], self.modes,
                                              output=record.output_kind)
        response = np.atleast_2d(response)
        if isinstance(index, slice) and index.start == 0 and index.stop == response.shape[1]:
            return response  # the whole computed response: no copy
        return response[:, index]


@dataclass
class BeamCalibrationSetup:
    """What is calibrated and on which data: measurement, window, effects, modes, likelihood."""

    measurement: Measurement
    window: tuple[float, float]
    effects: tuple[str, ...]
    modes: int
    likelihood: str
    model: BeamModel
    forward: BeamForwardModel
    #: How ``modes`` was chosen when asked for ``"auto"`` (:class:`beam.calibration.modes.ModeChoice`, set by
    #: :func:`beam.calibration.run.prepare`), else None.
    mode_choice: object | None = None

    @property
    def window_mask(self) -> np.ndarray:
        """Boolean mask of the record's samples inside the calibration window."""
        t = self.measurement.time_s
        return (t >= self.window[0] - 1e-12) & (t <= self.window[1] + 1e-12)

    @property
    def usable_mask(self) -> np.ndarray:
        """Samples the model is compared with: not clipped and, for a free response, from the
        end of the release's transient on (:attr:`free_start_s`)."""
        usable = ~self.measurement.left_out
        if self.is_free:
            usable = usable & (self.measurement.time_s >= self.free_start_s)
        return usable

    @property
    def free_start_s(self) -> float:
        """First sample of a free response (s): the record's start, or after a quiet lead-in at
        rest and the release's transient (:func:`beam.calibration.free.free_response_start`)."""
        return float(self.measurement.time_s[self.free_start_indices[1]])

    @functools.cached_property
    def free_start_indices(self) -> tuple[int, int]:
        """(release, first sample of the free response) of a free response: the samples in between
        are the release's transient, left out (:func:`beam.calibration.free.free_start_indices`)."""
        return free_start_indices(self.measurement, self.modes)

    @property
    def fit_mask(self) -> np.ndarray:
        """The window's samples that enter the likelihood: clipped samples (and, for a free
        response, those before the end of the release's transient) left out."""
        return self.window_mask & self.usable_mask

    @property
    def held_out_mask(self) -> np.ndarray:
        """Usable samples outside the window: where the prediction is scored."""
        return ~self.window_mask & self.usable_mask

    @property
    def physical_names(self) -> tuple[str, ...]:
        return self.model.parameter_names_for(self.modes)

    @property
    def is_free(self) -> bool:
        """A free response: the initial state (and offset) are profiled out, see :mod:`beam.calibration.free`."""
        return self.measurement.is_free


def make_setup(
    measurement: Measurement,
    *,
    window: tuple[float, float] | None = None,
    effects: Iterable[str] | str = DEFAULT_EFFECTS,
    modes: int = DEFAULT_MODES,
    likelihood: str = defaults.DEFAULT_LIKELIHOOD,
    intervals: int = DEFAULT_INTERVALS,
    knots: str = DEFAULT_KNOTS,
) -> BeamCalibrationSetup:
    """Validate the choices and build the model (BeamInputError on any bad choice).

    ``modes`` is a number here; :func:`beam.calibration.run.prepare` also takes ``"auto"``.

    ``intervals`` and ``knots`` set the Galerkin mesh (:mod:`beam.physics.basis`; default: the patch
    knots, as ``beam simulate`` uses).
    """
    if likelihood not in LIKELIHOODS:
        raise BeamInputError(f"unknown likelihood {likelihood!r}; expected one of {', '.join(LIKELIHOODS)}")
    effects = parse_effects(effects)
    window = resolve_window(measurement, window)
    check_calibration_record(measurement, window)
    model = BeamModel(measurement.geometry, effects, intervals, knots, input_kind=measurement.input_kind)
    if isinstance(modes, bool) or int(modes) != modes or not 1 <= modes <= model.size:
        raise BeamInputError(f"modes must be between 1 and {model.size} (the mesh holds {model.size} modes), got {modes}")
    if "quadratic_drag" in effects and measurement.geometry.width_m is None:
        raise BeamInputError("quadratic_drag needs the strip's width: [beam] width_m and thickness_m in the sidecar, "
                             "or --width and --thickness")
    if "clamp_friction" in effects and not measurement.is_free:
        raise BeamInputError("clamp_friction is calibrated on free decays only (a record without input): its joint's "
                             "history is taken from the swing at the window's start")
    nonlinear = ", ".join(e for e in effects if EFFECTS[e].nonlinear)
    if model.is_nonlinear and not measurement.is_free and (not measurement.uniform or measurement.output_kind != "displacement"):
        raise BeamInputError(
            f"{nonlinear} is calibrated on a free decay, or on a driven record with uniform time stamps and a "
            "displacement output"
        )
    if measurement.is_free:
        released = measurement.time_s >= measurement.time_s[free_start_indices(measurement, int(modes))[1]]
        mask = window_samples(measurement, window) & ~measurement.left_out & released
        if np.count_nonzero(mask) < MIN_WINDOW_SAMPLES:
            raise BeamInputError(
                f"calibration window {window[0]:g}:{window[1]:g} s holds fewer than {MIN_WINDOW_SAMPLES} samples after "
                f"the start of the free response at {measurement.time_s[np.argmax(released)]:g} s (the release of the beam and its "
                f"transient left out)"
            )
        if model.is_nonlinear and np.any(released & ~measurement.left_out & (measurement.time_s < measurement.time_s[mask][0])):
            raise BeamInputError(
                f"{nonlinear} on a free decay is integrated forward from the window's first sample: start the window "
                f"at the start of the free response ({measurement.time_s[np.argmax(released)]:g} s) or earlier"
            )
        forward = free_model_class(model)(model, int(modes), measurement.output_kind, measurement.time_s[mask],
                                          measurement.output[mask], likelihood)
    else:
        forward = BeamForwardModel(model, measurement, int(modes))
    setup = BeamCalibrationSetup(measurement, window, effects, int(modes), likelihood, model, forward)
    _check_window_holds_a_period(setup)
    return setup


def free_model_class(model: BeamModel) -> type:
    """The free-response forward model of ``model``: :class:`ProjectedFreeModel` (the initial
    state profiled exactly), or for a nonlinear effect
    :class:`~beam.calibration.free_nonlinear.NonlinearFreeModel` (refined by Gauss–Newton)."""
    if model.is_nonlinear:
        from beam.calibration.free_nonlinear import NonlinearFreeModel

        return NonlinearFreeModel
    return ProjectedFreeModel


def window_samples(measurement: Measurement, window: tuple[float, float]) -> np.ndarray:
    """Boolean mask of the record's samples inside ``window`` (s)."""
    t = measurement.time_s
    return (t >= window[0] - 1e-12) & (t <= window[1] + 1e-12)


def _check_window_holds_a_period(setup: BeamCalibrationSetup) -> None:
    """The window must last at least one period of the model's first mode at the prior centres."""
    nominal = setup.measurement.prior_nominal
    centres = {name: prior_centre(name, nominal) for name in setup.physical_names}
    frequencies, _ = setup.model.natural_modes(centres, 1)
    duration = setup.window[1] - setup.window[0]
    if frequencies[0] > 0 and duration < 1.0 / frequencies[0]:
        raise BeamInputError(
            f"calibration window {setup.window[0]:g}:{setup.window[1]:g} s is shorter than one period of the first mode "
            f"({1.0 / frequencies[0]:.3g} s at {frequencies[0]:.3g} Hz, prior centre)"
        )


def build_problem(setup: BeamCalibrationSetup, initial_guesses=None) -> Problem:
    """The :class:`beam.inference.Problem` of a setup (data = the window's output, clipped
    samples left out; for a free response the forward model projects on exactly these data)."""
    measurement = setup.measurement
    mask = setup.fit_mask
    data = measurement.output[mask]
    forward = setup.forward
    if setup.is_free and not (forward.fit_time_s.size == data.size
                              and np.array_equal(forward.fit_time_s, measurement.time_s[mask])):
        forward = free_model_class(setup.model)(setup.model, setup.modes, measurement.output_kind,
                                                measurement.time_s[mask], data, setup.likelihood)
    nominal = measurement.prior_nominal
    parameters = [
        Parameter(name, parameter_prior(name, nominal, measurement.nominal_spread), PARAMETER_SPECS[name].unit,
                  PARAMETER_SPECS[name].description)
        for name in setup.physical_names
    ]
    scale = float(np.sqrt(np.mean(data**2))) or 1e-9
    unit = measurement.output_unit
    parameters.append(Parameter(NOISE_SD, LogUniform(1e-4 * scale, 2.0 * scale), unit, "sensor noise sd (estimated)"))
    if setup.likelihood == "ar1":
        parameters.append(Parameter(AR1_COEFFICIENT, Uniform(-1.0, 1.0, coordinate="logit"), "1", "lag-one correlation of the residuals"))
    return Problem(
        parameters=parameters,
        model=forward,
        time_s=forward.fit_time_s if setup.is_free else measurement.time_s[mask].copy(),
        data=data,
        likelihood=setup.likelihood,
        initial_guesses=initial_guesses,
        name=f"beam:{measurement.name}",
        data_unit=unit,
        proportional_to=_proportional_parameter(setup),
    )


def _proportional_parameter(setup: BeamCalibrationSetup) -> str | None:
    """The patch coupling k_p for a linear model driven by the patch voltage: its only input
    enters as k_p V, so the prediction is proportional to k_p (tested for every catalogue
    effect in ``tests/test_calibration_fit.py``); None otherwise (the spring's response is not,
    a free response has no input)."""
    name = "patch_coupling_NmV"
    linear = not setup.model.is_nonlinear and not setup.is_free
    return name if linear and setup.measurement.input_kind == "voltage" and name in setup.physical_names else None
