"""Toy scenarios: the truth, its discrepancy and the simulated data (see :mod:`beam.toy`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from beam.errors import BeamInputError
from beam.inference.likelihood import AR1_COEFFICIENT, LIKELIHOODS, NOISE_SD

#: Discrepancy kinds.
KINDS = ("harmonic", "tone", "drift")
#: Frequency of the ``tone`` discrepancy relative to the model frequency.
TONE_RATIO = 1.37
#: Time constant of the ``drift`` discrepancy ``d(t) = t / DRIFT_TIME_S`` (s): a fixed time, not
#: the calibration window, so that moving the window changes what is fitted, never the truth. It
#: equals the default window, where the drift reaches δ as it did when it was ``t / T_window``.
DRIFT_TIME_S = 5.0
#: Physical parameters of the toy model, in order.
MODEL_PARAMETERS = ("amplitude", "frequency_Hz", "phase_rad")
#: Support of the frequency prior, Hz.
FREQUENCY_PRIOR_HZ = (0.2, 5.0)
#: Support of the amplitude prior (log-uniform), du.
AMPLITUDE_PRIOR = (0.01, 100.0)
#: Support of the noise_sd prior (log-uniform), du.
NOISE_PRIOR = (1e-3, 10.0)
#: Support of the ar1_coefficient prior (uniform, logit coordinate).
AR1_PRIOR = (-1.0, 1.0)
#: Longest record accepted (samples), to keep a typo in --horizon from exhausting memory.
MAX_SAMPLES = 200_000

#: Unit of each parameter ("du": the data unit).
UNITS = {"amplitude": "du", "frequency_Hz": "Hz", "phase_rad": "rad", NOISE_SD: "du", AR1_COEFFICIENT: "1"}


@dataclass(frozen=True)
class ToyScenario:
    """One toy experiment (defaults: the reference case of the README).

    Attributes
    ----------
    amplitude : float
        True amplitude ``A`` (du).
    frequency_Hz : float
        True frequency ``f`` (Hz).
    phase_rad : float
        True phase ``φ`` (rad).
    noise_sd : float
        Standard deviation of the i.i.d. measurement noise (du).
    sample_rate_Hz : float
        Sampling rate (samples per second).
    window_s : float
        Calibration window ``[0, window_s]`` (s).
    horizon_s : float
        End of the record; ``(window_s, horizon_s]`` is held out (s).
    discrepancy : float
        Discrepancy amplitude ``δ`` (du); 0 means the model is correct.
    kind : {"harmonic", "tone", "drift"}
        Discrepancy shape.
    likelihood : {"iid", "ar1"}
        Noise model of the calibration.
    seed : int
        Seed of the noise realisation and of the sampler.
    target_ess : float
        Bulk ESS per parameter the MCMC runs to.
    """

    amplitude: float = 1.0
    frequency_Hz: float = 1.0
    phase_rad: float = 0.3
    noise_sd: float = 0.1
    sample_rate_Hz: float = 20.0
    window_s: float = 5.0
    horizon_s: float = 20.0
    discrepancy: float = 0.0
    kind: str = "harmonic"
    likelihood: str = "iid"
    seed: int = 0
    target_ess: float = 1000.0

    def validate(self) -> ToyScenario:
        """Raise :class:`~beam.errors.BeamInputError` (one line) on an invalid scenario."""
        finite = ("amplitude", "frequency_Hz", "phase_rad", "noise_sd", "sample_rate_Hz", "window_s", "horizon_s", "discrepancy", "target_ess")
        for name in finite:
            if not math.isfinite(float(getattr(self, name))):
                raise BeamInputError(f"toy scenario: {name} must be a finite number, got {getattr(self, name)}")
        if self.kind not in KINDS:
            raise BeamInputError(f"unknown discrepancy kind {self.kind!r}; expected one of {', '.join(KINDS)}")
        if self.likelihood not in LIKELIHOODS:
            raise BeamInputError(f"unknown likelihood {self.likelihood!r}; expected one of {', '.join(LIKELIHOODS)}")
        if self.window_s <= 0.0:
            raise BeamInputError(f"calibration window must be positive, got {self.window_s:g} s")
        if self.horizon_s <= self.window_s:
            raise BeamInputError(
                f"calibration window ({self.window_s:g} s) must be shorter than the horizon ({self.horizon_s:g} s)"
            )
        if self.noise_sd < 0.0:
            raise BeamInputError(f"noise sd must not be negative, got {self.noise_sd:g}")
        if not NOISE_PRIOR[0] <= self.noise_sd <= NOISE_PRIOR[1]:
            raise BeamInputError(
                f"noise sd must lie in the noise_sd prior range [{NOISE_PRIOR[0]:g}, {NOISE_PRIOR[1]:g}], got {self.noise_sd:g}"
            )
        if not FREQUENCY_PRIOR_HZ[0] <= self.frequency_Hz <= FREQUENCY_PRIOR_HZ[1]:
            raise BeamInputError(
                f"frequency must lie in the prior range [{FREQUENCY_PRIOR_HZ[0]:g}, {FREQUENCY_PRIOR_HZ[1]:g}] Hz, got {self.frequency_Hz:g}"
            )
        if not AMPLITUDE_PRIOR[0] <= self.amplitude <= AMPLITUDE_PRIOR[1]:
            raise BeamInputError(f"amplitude must lie in the prior range [{AMPLITUDE_PRIOR[0]:g}, {AMPLITUDE_PRIOR[1]:g}], got {self.amplitude:g}")
        if self.sample_rate_Hz <= 2.0 * FREQUENCY_PRIOR_HZ[1]:
            raise BeamInputError(
                f"sample rate {self.sample_rate_Hz:g} Hz must exceed twice the highest prior frequency ({FREQUENCY_PRIOR_HZ[1]:g} Hz)"
            )
        period = 1.0 / self.frequency_Hz
        if self.window_s < period:
            raise BeamInputError(
                f"calibration window ({self.window_s:g} s) is shorter than one period of the {self.frequency_Hz:g} Hz oscillation ({period:g} s)"
            )
        if self.horizon_s * self.sample_rate_Hz > MAX_SAMPLES:
            raise BeamInputError(f"horizon ({self.horizon_s:g} s) gives more than {MAX_SAMPLES} samples")
        if int(self.seed) != self.seed or self.seed < 0:
            raise BeamInputError(f"seed must be a non-negative integer, got {self.seed}")
        if self.target_ess <= 0:
            raise BeamInputError(f"target ESS must be positive, got {self.target_ess:g}")
        return self

    def truth(self, phase_centre_rad: float = 0.0) -> dict[str, float]:
        """True parameter values (phase on the branch centred on ``phase_centre_rad``)."""
        out = {
            "amplitude": float(self.amplitude),
            "frequency_Hz": float(self.frequency_Hz),
            "phase_rad": float(wrap_phase(self.phase_rad, phase_centre_rad)),
            NOISE_SD: float(self.noise_sd),
        }
        if self.likelihood == "ar1":
            out[AR1_COEFFICIENT] = 0.0
        return out


def wrap_phase(phase_rad: float | np.ndarray, centre_rad: float = 0.0):
    """Phase on the branch ``[centre - π, centre + π)`` (values already on it are unchanged)."""
    x = np.asarray(phase_rad, dtype=float)
    lo, hi = centre_rad - math.pi, centre_rad + math.pi
    wrapped = centre_rad + np.mod(x - centre_rad + math.pi, 2.0 * math.pi) - math.pi
    out = np.where((x >= lo) & (x < hi), x, wrapped)
    return float(out) if out.ndim == 0 else out


@dataclass
class ToyData:
    """Simulated record on the full horizon (arrays of shape (n,)).

    Attributes
    ----------
    time_s : ndarray
        Sample times ``k / sample_rate``, ``0 <= t <= horizon`` (s).
    signal : ndarray
        The model part ``A sin(2π f t + φ)`` (du).
    truth : ndarray
        Noise-free truth, ``signal + δ d(t)`` (du).
    data : ndarray
        Observations, ``truth + noise`` (du).
    calibration : ndarray of bool
        True on the calibration window ``t <= window``; the rest is held out.
    """

    time_s: np.ndarray
    signal: np.ndarray
    truth: np.ndarray
    data: np.ndarray
    calibration: np.ndarray

    @property
    def held_out(self) -> np.ndarray:
        """Boolean mask of the held-out samples."""
        return ~self.calibration


def discrepancy_shape(kind: str, time_s: np.ndarray, scenario: ToyScenario) -> np.ndarray:
    """The unscaled discrepancy ``d(t)`` (du per unit δ) of ``kind`` on ``time_s``."""
    t = np.asarray(time_s, dtype=float)
    f, phi = scenario.frequency_Hz, scenario.phase_rad
    if kind == "harmonic":
        return np.sin(4.0 * math.pi * f * t + phi)
    if kind == "tone":
        return np.sin(2.0 * math.pi * TONE_RATIO * f * t)
    if kind == "drift":
        return t / DRIFT_TIME_S
    raise BeamInputError(f"unknown discrepancy kind {kind!r}; expected one of {', '.join(KINDS)}")


def simulate(scenario: ToyScenario, *, calibration_window_s: float | None = None) -> ToyData:
    """Simulate the record of a scenario (deterministic for ``scenario.seed``).

    ``calibration_window_s`` overrides the calibration mask only (the truth does not depend on
    the window), which is what the window sweep uses.
    """
    scenario.validate()
    n = math.floor(scenario.horizon_s * scenario.sample_rate_Hz + 1e-9) + 1
    t = np.arange(n) / scenario.sample_rate_Hz
    signal = scenario.amplitude * np.sin(2.0 * math.pi * scenario.frequency_Hz * t + scenario.phase_rad)
    truth = signal + scenario.discrepancy * discrepancy_shape(scenario.kind, t, scenario)
    rng = np.random.default_rng(scenario.seed)
    data = truth + scenario.noise_sd * rng.standard_normal(n)
    window = scenario.window_s if calibration_window_s is None else calibration_window_s
    return ToyData(time_s=t, signal=signal, truth=truth, data=data, calibration=t <= window + 1e-9)
