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
(:class:`beam.effects.ParameterSpec`). The noise sd is log-uniform from 1e-4 to 2 times the RMS
of the data in the window, and the AR(1) coefficient uniform on (-1, 1) (logit coordinate).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np

from beam.basis import DEFAULT_INTERVALS, DEFAULT_KNOTS
from beam.effects import PARAMETER_SPECS, parse_effects
from beam.errors import BeamInputError
from beam.limits import check_calibration_record
from beam.inference import AR1_COEFFICIENT, LIKELIHOODS, NOISE_SD, LogNormal, LogUniform, Parameter, Problem, Uniform
from beam.measurement import Measurement
from beam.model import BeamModel

DEFAULT_EFFECTS: tuple[str, ...] = ("air_damping", "kelvin_voigt")
DEFAULT_MODES = 4
#: The default calibration window: the first 30 % of the record.
DEFAULT_WINDOW_FRACTION = 0.3
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
}
_TRUNCATION_SIGMAS = 4.0


def parameter_prior(name: str, nominal: Mapping[str, float]):
    """The prior of a physical parameter (see the module notes)."""
    spec = PARAMETER_SPECS[name]
    if name in nominal:
        centre, sd = float(nominal[name]), NOMINAL_LOG_SD[name]
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
    """The calibration window [start, end] (s), default the first 30 % of the record.

    Raises BeamInputError when it lies outside the record or holds too few samples.
    """
    t = measurement.time_s
    if window is None:
        start = float(t[0])
        end = float(t[0] + DEFAULT_WINDOW_FRACTION * (t[-1] - t[0]))
    else:
        start, end = (float(v) for v in window)
    if not (math.isfinite(start) and math.isfinite(end)) or not start < end:
        raise BeamInputError(f"calibration window must have start < end, got {start}:{end}")
    if start < t[0] - 1e-9 or end > t[-1] + measurement.sample_interval_s + 1e-9:  # the record covers n dt
        raise BeamInputError(
            f"calibration window {start:g}:{end:g} s lies outside the record ({t[0]:g} to {t[-1]:g} s)"
        )
    inside = int(np.count_nonzero((t >= start - 1e-12) & (t <= end + 1e-12)))
    if inside < MIN_WINDOW_SAMPLES:
        raise BeamInputError(f"calibration window {start:g}:{end:g} s holds {inside} samples; at least {MIN_WINDOW_SAMPLES} are needed")
    return start, end


@dataclass
class BeamForwardModel:
    """Vectorised forward model of a measurement for :class:`beam.inference.Problem`.

    The beam starts at rest at the first sample of the record and is driven by the record's
    voltage; ``model(values, time_s)`` returns the displacement (m) at the requested samples,
    which must lie on the record's time grid.
    """

    model: BeamModel
    measurement: Measurement
    modes: int

    def __post_init__(self) -> None:
        self._names = self.model.parameter_names
        self._index_cache: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    def sample_indices(self, time_s: np.ndarray) -> np.ndarray | slice:
        """Record indices of the times ``time_s`` (cached per array object): a slice when they
        are consecutive samples (a window, the whole record), else an index array."""
        cached = self._index_cache.get(id(time_s))
        if cached is not None and cached[0] is time_s:
            return cached[1]
        t0, dt = self.measurement.time_s[0], self.measurement.sample_interval_s
        index = np.rint((np.asarray(time_s, dtype=float) - t0) / dt).astype(int)
        if index.size and (index.min() < 0 or index.max() >= self.measurement.time_s.size):
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
        parameters = {name: values[name] for name in self._names}
        response = np.atleast_2d(self.model.response(
            parameters, self.measurement.voltage_V[: max(needed, 2)], self.measurement.sample_interval_s, self.modes
        ))
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

    @property
    def window_mask(self) -> np.ndarray:
        """Boolean mask of the record's samples inside the calibration window."""
        t = self.measurement.time_s
        return (t >= self.window[0] - 1e-12) & (t <= self.window[1] + 1e-12)

    @property
    def physical_names(self) -> tuple[str, ...]:
        return self.model.parameter_names


def make_setup(
    measurement: Measurement,
    *,
    window: tuple[float, float] | None = None,
    effects: Iterable[str] | str = DEFAULT_EFFECTS,
    modes: int = DEFAULT_MODES,
    likelihood: str = "iid",
    intervals: int = DEFAULT_INTERVALS,
    knots: str = DEFAULT_KNOTS,
) -> BeamCalibrationSetup:
    """Validate the choices and build the model (BeamInputError on any bad choice).

    ``intervals`` and ``knots`` set the Galerkin mesh (:mod:`beam.basis`; default: the patch
    knots, as ``beam simulate`` uses).
    """
    if likelihood not in LIKELIHOODS:
        raise BeamInputError(f"unknown likelihood {likelihood!r}; expected one of {', '.join(LIKELIHOODS)}")
    effects = parse_effects(effects)
    window = resolve_window(measurement, window)
    check_calibration_record(measurement, window)
    model = BeamModel(measurement.geometry, effects, intervals, knots)
    if isinstance(modes, bool) or int(modes) != modes or not 1 <= modes <= model.size:
        raise BeamInputError(f"modes must be between 1 and {model.size} (the mesh holds {model.size} modes), got {modes}")
    setup = BeamCalibrationSetup(
        measurement, window, effects, int(modes), likelihood, model, BeamForwardModel(model, measurement, int(modes))
    )
    _check_window_holds_a_period(setup)
    return setup


def _check_window_holds_a_period(setup: BeamCalibrationSetup) -> None:
    """The window must last at least one period of the model's first mode at the prior centres."""
    nominal = setup.measurement.nominal
    centres = {name: prior_centre(name, nominal) for name in setup.physical_names}
    frequencies, _ = setup.model.natural_modes(centres, 1)
    duration = setup.window[1] - setup.window[0]
    if frequencies[0] > 0 and duration < 1.0 / frequencies[0]:
        raise BeamInputError(
            f"calibration window {setup.window[0]:g}:{setup.window[1]:g} s is shorter than one period of the first mode "
            f"({1.0 / frequencies[0]:.3g} s at {frequencies[0]:.3g} Hz, prior centre)"
        )


def build_problem(setup: BeamCalibrationSetup, initial_guesses=None) -> Problem:
    """The :class:`beam.inference.Problem` of a setup (data = the window's displacement)."""
    measurement = setup.measurement
    mask = setup.window_mask
    data = measurement.displacement_m[mask]
    nominal = measurement.nominal
    parameters = [
        Parameter(name, parameter_prior(name, nominal), PARAMETER_SPECS[name].unit, PARAMETER_SPECS[name].description)
        for name in setup.physical_names
    ]
    scale = float(np.sqrt(np.mean(data**2))) or 1e-9
    parameters.append(Parameter(NOISE_SD, LogUniform(1e-4 * scale, 2.0 * scale), "m", "sensor noise sd (estimated)"))
    if setup.likelihood == "ar1":
        parameters.append(Parameter(AR1_COEFFICIENT, Uniform(-1.0, 1.0, coordinate="logit"), "1", "lag-one correlation of the residuals"))
    return Problem(
        parameters=parameters,
        model=setup.forward,
        time_s=measurement.time_s[mask].copy(),
        data=data,
        likelihood=setup.likelihood,
        initial_guesses=initial_guesses,
        name=f"beam:{measurement.name}",
        data_unit="m",
    )
