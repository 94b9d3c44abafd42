"""The beam as a calibration problem: window, priors, forward model, the setup's record of them.

:class:`BeamCalibrationSetup` is what :func:`beam.calibration.pipeline.make_setup` makes: the
record, the resolved :class:`~beam.calibration.spec.CalibrationSpec`, the model, its forward model
and the calibration model that calibrates it (chosen once there); :func:`build_problem` turns it
into the inference problem.

Model = base (``bending_stiffness_Nm2``, ``patch_coupling_NmV``) + chosen effects, with a chosen
number of retained modes; rho is fixed from the measurement's sidecar.

Priors
------
A parameter with a ``[nominal]`` value gets a log-normal prior centred (median) on it, truncated
at ±4 sigma; sigma (of log x) depends on how well such a quantity is usually known (each
parameter's :attr:`~beam.physics.effects.effect.ParameterSpec.nominal_log_sd`, collected in
:data:`NOMINAL_LOG_SD`; a record's own spread overrides it): stiffness and density 0.5 (a factor 1.6 at one sigma), the patch's
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

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from beam.calibration import defaults
from beam.calibration.defaults import (  # noqa: F401 - the defaults' one source, re-exported
    AUTO_MODES,
    DEFAULT_EFFECTS,
    DEFAULT_MODES,
    DEFAULT_WINDOW_FRACTION,
)
from beam.calibration.forward import BeamForwardModel  # noqa: F401 - re-exported
from beam.calibration.spec_field import SpecField
from beam.errors import BeamInputError
from beam.inference import (
    AR1_COEFFICIENT,
    NOISE_SD,
    LogNormal,
    LogUniform,
    Parameter,
    Problem,
    Uniform,
)
from beam.io.measurement import Measurement
from beam.physics.effects import BASE_PARAMETERS, EFFECTS, PARAMETER_SPECS
from beam.physics.effects.modal_damping import MODAL_DAMPING_LOG_SD  # noqa: F401 - re-exported
from beam.physics.model import BeamModel

if TYPE_CHECKING:  # the spec's module resolves modes by beam.calibration.modes, which reads this one
    from beam.calibration.spec import CalibrationSpec

#: Fewest samples a calibration window may hold.
MIN_WINDOW_SAMPLES = 20

#: sigma of log x for a prior centred on a nominal value (each parameter's
#: :attr:`~beam.physics.effects.effect.ParameterSpec.nominal_log_sd`; a per-mode family, the
#: modal damping ratios, has :data:`MODAL_DAMPING_LOG_SD` each).
NOMINAL_LOG_SD: dict[str, float] = {
    spec.name: spec.nominal_log_sd
    for spec in BASE_PARAMETERS + tuple(p for e in EFFECTS.values() if not e.per_mode for p in e.parameters)
    if spec.nominal_log_sd is not None
}
_TRUNCATION_SIGMAS = 4.0


def nominal_log_sd(name: str) -> float:
    """sigma of log x of a parameter's prior around a nominal value (see the module notes);
    KeyError for a parameter no nominal value is expected of."""
    sd = PARAMETER_SPECS[name].nominal_log_sd
    if sd is None:
        raise KeyError(name)
    return sd


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

    A window may start up to one sample step before the first stamp (``0:2`` on a phone record
    whose first stamp is 0.8 ms): the record is sampled from there. Raises BeamInputError when
    it lies outside the record or holds too few samples.
    """
    t = measurement.time_s
    if window is None:  # the default's value when asked (beam.calibration.defaults)
        start, end = defaults.default_window(float(t[0]), float(t[-1]))
    else:
        start, end = (float(v) for v in window)
    if not (math.isfinite(start) and math.isfinite(end)) or not start < end:
        raise BeamInputError(f"calibration window must have start < end, got {start}:{end}")
    step = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    if start < t[0] - step - 1e-9 or end > t[0] + measurement.duration_s + 1e-9:  # the record covers n dt
        raise BeamInputError(
            f"calibration window {start:g}:{end:g} s lies outside the record ({t[0]:g} to {t[-1]:g} s)"
        )
    inside = int(np.count_nonzero((t >= start - 1e-12) & (t <= end + 1e-12)))
    if inside < MIN_WINDOW_SAMPLES:
        raise BeamInputError(f"calibration window {start:g}:{end:g} s holds {inside} samples; at least {MIN_WINDOW_SAMPLES} are needed")
    return start, end


@dataclass
class BeamCalibrationSetup:
    """What is calibrated and on which data (made by :func:`beam.calibration.pipeline.make_setup`).

    Attributes
    ----------
    measurement : Measurement
        The record (decimated when it was longer than the calibration limit).
    spec : CalibrationSpec
        The resolved spec: window, effects, modes, likelihood (and how ``"auto"`` modes were chosen).
    model : BeamModel
        The beam with the spec's effects.
    forward : object
        The forward model of :class:`~beam.inference.Problem` (the record's own: driven, or with
        a free response's initial state profiled out).
    calibration : CalibrationModel
        How this kind of record and model is calibrated (:class:`beam.calibration.pipeline.CalibrationModel`:
        its starts, search, posterior and bands), chosen once by ``make_setup``.
    start_indices : (int, int)
        (release, first sample of the response the model describes): a free response's release
        and the end of its transient (:func:`beam.calibration.free.free_start_indices`), the
        samples in between left out; (0, 0) for a driven record.
    """

    measurement: Measurement
    spec: CalibrationSpec
    model: BeamModel
    forward: object
    calibration: object
    start_indices: tuple[int, int] = (0, 0)

    #: The resolved spec's window (s), effects, modes (a number), likelihood and how ``"auto"``
    #: modes were chosen (:class:`beam.calibration.modes.ModeChoice`, else None).
    window = SpecField()
    effects = SpecField()
    modes = SpecField()
    likelihood = SpecField()
    mode_choice = SpecField()

    @property
    def window_mask(self) -> np.ndarray:
        """Boolean mask of the record's samples inside the calibration window."""
        return window_samples(self.measurement, self.window)

    @property
    def usable_mask(self) -> np.ndarray:
        """Samples the model is compared with: not clipped and from :attr:`start_indices`' first
        sample on (a free response: after the release's transient)."""
        usable = ~self.measurement.left_out
        if self.start_indices[1]:
            usable = usable & (self.measurement.time_s >= self.free_start_s)
        return usable

    @property
    def free_start_s(self) -> float:
        """First sample the model describes (s): the record's start, or for a free response after a
        quiet lead-in at rest and the release's transient (:func:`beam.calibration.free.free_response_start`)."""
        return float(self.measurement.time_s[self.start_indices[1]])

    @property
    def free_start_indices(self) -> tuple[int, int]:
        """:attr:`start_indices` (the name a free response's callers read)."""
        return self.start_indices

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
        return self.calibration.free


def window_samples(measurement: Measurement, window: tuple[float, float]) -> np.ndarray:
    """Boolean mask of the record's samples inside ``window`` (s)."""
    t = measurement.time_s
    return (t >= window[0] - 1e-12) & (t <= window[1] + 1e-12)


def check_window_holds_a_period(setup: BeamCalibrationSetup) -> None:
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
    """The :class:`beam.inference.Problem` of a setup: data = the window's output (clipped samples
    and, for a free response, those before its start left out), the forward model evaluated on
    exactly these data (the calibration model's ``fit_forward``), one prior per parameter, the
    noise sd's log-uniform from 1e-4 to 2 times the data's RMS (and the AR(1) coefficient's)."""
    measurement = setup.measurement
    mask = setup.fit_mask
    data = measurement.output[mask]
    forward, time_s = setup.calibration.fit_forward(setup, mask)
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
        time_s=time_s,
        data=data,
        likelihood=setup.likelihood,
        initial_guesses=initial_guesses,
        name=f"beam:{measurement.name}",
        data_unit=unit,
        proportional_to=setup.calibration.proportional_parameter(setup),
        likelihood_correction=setup.calibration.likelihood_correction(forward),
    )
