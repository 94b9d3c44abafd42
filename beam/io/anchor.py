"""The record's own spectral peaks, and a nominal bending stiffness anchored on the lowest.

A calibration starts from (and centres its prior on) the nominal bending stiffness. Without
one (no ``[nominal]``, no material), the catalogue's log-uniform range is so wide that the
optimiser may put the record's lowest peak on model mode 2. So when the sidecar gives none,
the nominal EI is the one that puts the record's *lowest strong peak* on mode 1 of the bare
beam of the record's geometry (with the sensor's mass when the sidecar gives it): model
frequencies scale as sqrt(EI) when every mass is fixed, so one eigen-solve of the model at
EI = 1 N m² gives ``EI = (f_peak / f_1(EI = 1))²``. Its prior keeps the calibration's default
width (the anchor says which mode, not how stiff to within a material's spread).

Peaks (:func:`spectral_peaks`): the output is put on a uniform grid at its median step by
linear interpolation (a logger's stalls would otherwise bend every frequency), its Welch PSD
(Hann, segments of the largest power of two <= n / 2, 50 % overlap, mean removed) is searched
for peaks of at least :data:`PEAK_PROMINENCE_DB` prominence above max(1 Hz, 4 / duration),
each located between bins by a parabola through the log-PSD (segments zero-padded 4x). A peak is *strong* when its power
as displacement (the PSD divided by (2 pi f)⁴ for an acceleration, (2 pi f)² for a velocity:
an accelerometer sees high modes much larger than they move) is at least
:data:`STRONG_FRACTION` of the largest peak's. A driven record's lowest strong peak is called
mode 1 only when its input's band (:func:`input_band_low_Hz`) reaches below half the peak's
frequency: a burst at mode 2 says nothing about mode 1, and then nothing is anchored.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.signal

from beam.errors import BeamInputError
from beam.physics.effects import sensor_mass
from beam.physics.effects.base import BENDING_STIFFNESS
from beam.physics.geometry import BeamGeometry

EI = BENDING_STIFFNESS.name

#: beta_1 L of the clamped-free beam (first root of 1 + cos x cosh x = 0).
MODE1_BETA_L = 1.8751040687119611
#: Smallest prominence of a spectral peak (dB).
PEAK_PROMINENCE_DB = 10.0
#: A strong peak's displacement power is at least this fraction of the largest peak's.
STRONG_FRACTION = 1e-2
#: Fewest samples a record needs for its peaks to anchor anything.
MIN_ANCHOR_SAMPLES = 256
#: Fewest cycles of a peak in the record for it to count.
MIN_CYCLES = 8
#: Lowest frequency searched (Hz).
LOW_HZ = 1.0
#: A driven record's input band: where its PSD is at least this fraction of its largest bin.
INPUT_BAND_FRACTION = 1e-2
#: Welch segments are zero-padded to this many times their length (a finer grid for the parabola).
ZERO_PADDING = 4


@dataclass(frozen=True)
class Peak:
    """A spectral peak of a record.

    Attributes
    ----------
    frequency_Hz : float
        Located between bins (Hz).
    prominence_db : float
        Over its surroundings (dB).
    displacement_power : float
        PSD at the peak as displacement (m²/Hz), for comparing peaks of an accelerometer.
    strong : bool
        At least :data:`STRONG_FRACTION` of the largest peak's displacement power.
    """

    frequency_Hz: float
    prominence_db: float
    displacement_power: float
    strong: bool


def uniform_grid(time_s: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, float]:
    """``values`` linearly interpolated on t_0 + k dt, dt the median step; (values, dt)."""
    step = float(np.median(np.diff(time_s)))
    count = int(math.floor((time_s[-1] - time_s[0]) / step)) + 1
    grid = time_s[0] + np.arange(count) * step
    return np.interp(grid, time_s, values), step


def spectral_peaks(time_s: np.ndarray, values: np.ndarray, output_kind: str = "displacement",
                   max_peaks: int = 8) -> list[Peak]:
    """The ``max_peaks`` most prominent spectral peaks, lowest first (module notes); empty for a
    short record. Strength is judged against the largest displacement power of all peaks."""
    spectrum = welch_spectrum(time_s, values)
    if spectrum is None:
        return []
    frequency, density, low, high = spectrum
    floor = max(float(density.max()) * 1e-30, np.finfo(float).tiny)  # > 0: a flat (all-zero) column has no log of 0
    log_psd = 10 * np.log10(np.maximum(density, floor))
    indices, properties = scipy.signal.find_peaks(log_psd, prominence=PEAK_PROMINENCE_DB)
    keep = (frequency[indices] >= low) & (frequency[indices] <= high)
    indices, prominences = indices[keep], properties["prominences"][keep]
    if indices.size == 0:
        return []
    located = np.array([refine_peak(frequency, log_psd, int(i)) for i in indices])
    power = density[indices] / _displacement_weight(located, output_kind)
    order = np.argsort(prominences)[::-1][:max_peaks]
    largest = float(power.max())
    peaks = [Peak(float(located[j]), float(prominences[j]), float(power[j]), bool(power[j] >= STRONG_FRACTION * largest))
             for j in order]
    return sorted(peaks, key=lambda p: p.frequency_Hz)


def welch_spectrum(time_s: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, float] | None:
    """The Welch spectrum the peaks are searched in (module notes): (frequency (Hz), PSD (unit²/Hz),
    lowest and highest frequency searched (Hz)), or None for a record of fewer than
    :data:`MIN_ANCHOR_SAMPLES` samples."""
    time_s = np.asarray(time_s, dtype=float)
    values = np.asarray(values, dtype=float)
    if values.size < MIN_ANCHOR_SAMPLES:
        return None
    signal, step = uniform_grid(time_s, values)
    n = signal.size
    nperseg = int(2 ** int(np.floor(np.log2(max(n / 2, 16)))))
    frequency, density = scipy.signal.welch(signal, fs=1.0 / step, window="hann", nperseg=nperseg,
                                            noverlap=nperseg // 2, nfft=ZERO_PADDING * nperseg, detrend="constant")
    low = max(LOW_HZ, MIN_CYCLES / (n * step), 2 * ZERO_PADDING * (frequency[1] - frequency[0]))
    return frequency, density, low, float(frequency[-1])


def input_band_low_Hz(time_s: np.ndarray, input: np.ndarray) -> float | None:
    """Lowest frequency (Hz) where a driven record's input PSD reaches :data:`INPUT_BAND_FRACTION`
    of its largest bin (None for an input without power)."""
    spectrum = welch_spectrum(time_s, input)
    if spectrum is None:
        return None
    frequency, density, _, _ = spectrum
    if not density.max() > 0:
        return None
    return float(frequency[np.flatnonzero(density >= INPUT_BAND_FRACTION * density.max())[0]])


def _displacement_weight(frequency: np.ndarray, output_kind: str) -> np.ndarray:
    omega = 2 * np.pi * frequency
    return {"acceleration": omega**4, "velocity": omega**2}.get(output_kind, np.ones_like(omega))


def refine_peak(frequency: np.ndarray, log_psd: np.ndarray, i: int) -> float:
    """Vertex of the parabola through the log-PSD at bins i - 1, i, i + 1 (Hz), within half a bin."""
    if i <= 0 or i >= log_psd.size - 1:
        return float(frequency[i])
    left, centre, right = log_psd[i - 1: i + 2]
    curvature = left - 2 * centre + right
    shift = 0.5 * (left - right) / curvature if curvature < 0 else 0.0
    return float(frequency[i] + np.clip(shift, -0.5, 0.5) * (frequency[1] - frequency[0]))


def lowest_strong_peak(time_s: np.ndarray, values: np.ndarray, output_kind: str,
                       input: np.ndarray | None = None) -> Peak | None:
    """The lowest strong peak (module notes), None when there is none, or when a driven record's
    input leaves the band below it unexplored (its power starts above half the peak's
    frequency: a mode 1 below would not show, so the peak cannot be called mode 1)."""
    peak = next((p for p in spectral_peaks(time_s, values, output_kind) if p.strong), None)
    if peak is None or input is None:
        return peak
    low = input_band_low_Hz(time_s, input)
    return peak if low is not None and low <= 0.5 * peak.frequency_Hz else None


def mode1_frequency(geometry: BeamGeometry, bending_stiffness_Nm2: float, sensor_mass_kg: float | None = None,
                    input_kind: str | None = None) -> float:
    """Mode 1 (Hz) of the bare beam of ``geometry`` (plus the sensor's mass) at a bending stiffness."""
    from beam.physics.model import BeamModel

    effects = (sensor_mass.EFFECT.id,) if sensor_mass_kg else ()
    model = BeamModel(geometry, effects, input_kind=None)  # natural modes do not depend on the input
    parameters = {EI: float(bending_stiffness_Nm2)}
    if sensor_mass_kg:
        parameters[sensor_mass.MASS.name] = float(sensor_mass_kg)
    frequencies, _ = model.natural_modes(parameters, 1)
    return float(frequencies[0])


def closed_form_mode1_Hz(length_m: float, linear_density_kg_m: float, bending_stiffness_Nm2: float) -> float:
    """f_1 = (beta_1 L)² / (2 pi L²) sqrt(EI / rho) of the uniform clamped-free beam (Hz)."""
    return MODE1_BETA_L**2 / (2 * math.pi * length_m**2) * math.sqrt(bending_stiffness_Nm2 / linear_density_kg_m)


def anchored_bending_stiffness(geometry: BeamGeometry, peak_Hz: float, sensor_mass_kg: float | None = None,
                               input_kind: str | None = None) -> float:
    """The EI (N m²) that puts mode 1 of the bare beam (with the sensor's mass) at ``peak_Hz``."""
    unit = mode1_frequency(geometry, 1.0, sensor_mass_kg, input_kind)
    return (peak_Hz / unit) ** 2


def anchor_nominal(geometry: BeamGeometry, nominal: dict[str, float], time_s: np.ndarray, output: np.ndarray,
                   output_kind: str, input_kind: str | None = None,
                   input: np.ndarray | None = None) -> tuple[dict[str, float], dict[str, str]]:
    """``nominal`` with the bending stiffness anchored on the record when it has none.

    Returns
    -------
    nominal : dict
        The given values, plus ``bending_stiffness_Nm2`` from the lowest strong peak when it
        was missing and the record has such a peak.
    origin : dict
        ``{"bending_stiffness_Nm2": "..."}`` when anchored, else empty.
    """
    if EI in nominal:
        return dict(nominal), {}
    peak = lowest_strong_peak(time_s, output, output_kind, input)
    if peak is None:
        return dict(nominal), {}
    mass = nominal.get(sensor_mass.MASS.name)
    stiffness = anchored_bending_stiffness(geometry, peak.frequency_Hz, mass, input_kind)
    if not (math.isfinite(stiffness) and stiffness > 0):  # pragma: no cover - a positive peak gives a positive EI
        return dict(nominal), {}
    with_mass = f" with the sensor's {mass:g} kg" if mass else ""
    origin = {EI: f"the record's lowest strong spectral peak ({peak.frequency_Hz:.4g} Hz) on mode 1{with_mass}"}
    return {**nominal, EI: stiffness}, origin


def mode_order_warnings(measurement, model, parameters) -> list[str]:
    """A warning in words when a calibrated model does not put the record's lowest strong peak
    on its mode 1 (empty when it does, or when the record has no strong peak).

    Parameters
    ----------
    measurement : beam.io.measurement.Measurement
        The record.
    model : beam.physics.model.BeamModel
        The calibrated model.
    parameters : mapping
        Its parameter values (the MAP); names the model does not take are ignored.

    The model mode nearest the peak in log frequency is the one the calibration put it on.
    """
    peak = lowest_strong_peak(measurement.time_s, measurement.output, measurement.output_kind, measurement.input)
    if peak is None:
        return []
    accepted = set(model.accepted_parameter_names)
    values = {name: float(value) for name, value in parameters.items() if name in accepted}
    try:
        frequencies, _ = model.natural_modes(values, min(model.size, 6))
    except BeamInputError:  # a model whose frequencies need more than the values given: nothing to say
        return []
    nearest = int(np.argmin(np.abs(np.log(np.maximum(frequencies, 1e-300) / peak.frequency_Hz))))
    if nearest == 0:
        return []
    return [f"the record's lowest strong spectral peak ({peak.frequency_Hz:.4g} Hz) sits on model mode {nearest + 1} "
            f"({frequencies[nearest]:.4g} Hz), not on mode 1 ({frequencies[0]:.4g} Hz): the calibrated stiffness puts "
            "the modes out of order; give the beam's material, width and thickness or [nominal] bending_stiffness_Nm2"]
