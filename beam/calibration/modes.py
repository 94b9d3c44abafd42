"""How many modes to retain: chosen from the record's excited band (the default of every front end,
``modes="auto"`` of :class:`beam.calibration.spec.CalibrationSpec`).

A modal model that keeps too few modes cannot follow what the record excites: the noise sd then
absorbs the truncation error and the diagnosis blames "something outside the catalogue" for a
truncation. :func:`suggest_modes` reads the number from the record itself, in two steps:

1. **The excited band.** The Welch spectrum of the output in the calibration window is compared
   with the record's model-free noise floor (:func:`beam.residuals.noise.noise_floor`, white
   density sd² / f_Nyquist); the band edge is the highest frequency where the spectrum exceeds
   :data:`EXCITED_RATIO` times that density. The nominal model (the record's geometry and nominal
   values, the linear effects asked for) then gives every mode below the edge, plus the next one
   when the edge lies within :data:`CLOSE_FRACTION` of it (a nominal frequency is only known to
   about that), plus :data:`MARGIN_MODES` more.
2. **The truncation error** (driven records with uniform stamps). The nominal model is driven by
   the record's own input with all its Galerkin modes and with n modes; the smallest n whose
   difference in the window stays below :data:`TRUNCATION_FRACTION` of the noise floor is taken
   (an error 0.3 × the noise adds 4 % to the fitted noise sd).

The effects no nominal value sets the frequencies of (:data:`LEFT_OUT`: the nonlinear tip
spring, modal damping) are left out of the nominal model. The larger of the two counts is retained, at most ``max_modes``. A free
response (no input) keeps :data:`~beam.calibration.spec.DEFAULT_MODES` (the damping of many modes
of a free decay is not identified). Cost: one Welch spectrum, one eigenproblem and, for a driven
record, at most ``max_modes + 1`` modal responses. The measurements behind the thresholds: the
design decisions page.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from beam.calibration.setup import prior_centre, resolve_window
from beam.calibration.defaults import DEFAULT_EFFECTS, DEFAULT_MODES
from beam.io.measurement import Measurement
from beam.physics.effects import EFFECTS, parse_effects
from beam.physics.model import BeamModel
from beam.residuals.noise import noise_floor

__all__ = ["CLOSE_FRACTION", "EXCITED_RATIO", "MARGIN_MODES", "MAX_MODES", "TRUNCATION_FRACTION", "ModeChoice",
           "suggest_modes"]

#: Spectrum / white-noise density above which a frequency is excited (see the module notes).
EXCITED_RATIO = 4.0
#: A nominal mode whose frequency is within this fraction above the band edge counts as in the band.
CLOSE_FRACTION = 0.15
#: Modes kept beyond the excited band.
MARGIN_MODES = 1
#: Largest truncation error (RMS in the window, fraction of the noise floor) accepted.
TRUNCATION_FRACTION = 0.3
#: Effects left out of the nominal model (no nominal value sets their frequencies: each effect's
#: :attr:`~beam.physics.effects.effect.Effect.left_out_of_nominal` says why).
LEFT_OUT: tuple[str, ...] = tuple(e for e in EFFECTS if EFFECTS[e].left_out_of_nominal is not None)
#: Most modes suggested (the dashboard's widget bound).
MAX_MODES = 12


@dataclass(frozen=True)
class ModeChoice:
    """The number of modes chosen for a record, and why.

    Attributes
    ----------
    modes : int
        Modes to retain.
    band_edge_Hz : float
        Highest frequency where the window's spectrum stands :data:`EXCITED_RATIO` × above the noise
        (0 when nothing does).
    band_modes : int
        Modes the band asks for (nominal modes below the edge, the close next one, the margin).
    truncation_modes : int or None
        Fewest modes whose truncation error of the nominal model stays below
        :data:`TRUNCATION_FRACTION` × the noise (None: a free or irregular record, not checked).
    nominal_Hz : tuple of float
        The nominal model's frequencies of the first ``max_modes + 1`` modes (Hz).
    noise_sd : float
        The record's noise floor (output unit).
    free : bool
        A free response (the library's default count is kept, see the module notes).
    truncation_errors : tuple of float
        RMS truncation error of the nominal model in the window (output unit) with 1, 2, ...
        modes (driven records with uniform stamps; empty otherwise).
    """

    modes: int
    band_edge_Hz: float
    band_modes: int
    truncation_modes: int | None
    nominal_Hz: tuple[float, ...]
    noise_sd: float
    free: bool = False
    truncation_errors: tuple[float, ...] = ()

    def truncation_error(self, modes: int) -> float | None:
        """RMS truncation error (output unit) of the nominal model in the window with ``modes``
        modes (against all of them); None when not computed (a free or irregular record, or more
        modes than were tried)."""
        if 1 <= modes <= len(self.truncation_errors):
            return self.truncation_errors[modes - 1]
        return None

    @property
    def reason(self) -> str:
        """One sentence: how the number was chosen."""
        text = (f"the record's spectrum stands above its noise up to {self.band_edge_Hz:.0f} Hz "
                f"({self.band_modes} modes with the margin)")
        if self.free:
            return (f"a free response: the library's {self.modes} modes ({text}, but the damping of so many "
                    "modes of a free decay is not identified)")
        if self.truncation_modes is not None:
            text += f"; the nominal model's truncation error falls below {TRUNCATION_FRACTION:g}× the noise with {self.truncation_modes}"
        return text

    def to_json(self) -> dict:
        return {"modes": self.modes, "band_edge_Hz": self.band_edge_Hz, "band_modes": self.band_modes,
                "truncation_modes": self.truncation_modes, "reason": self.reason}


def _excited_edge(frequency_Hz: np.ndarray, psd: np.ndarray, noise_density: float) -> float:
    above = np.nonzero(psd > EXCITED_RATIO * noise_density)[0]
    above = above[frequency_Hz[above] > 0]
    return float(frequency_Hz[above[-1]]) if above.size else 0.0


def suggest_modes(measurement: Measurement, window: tuple[float, float] | None = None,
                  effects: Iterable[str] | str = DEFAULT_EFFECTS, *, max_modes: int = MAX_MODES) -> ModeChoice:
    """The number of modes to retain for ``measurement`` calibrated on ``window`` (see the module notes).

    Parameters
    ----------
    measurement : Measurement
        The record (its geometry and nominal values give the nominal model).
    window : (float, float) or None
        Calibration window (s); default the library's (the first 30 % of the record).
    effects : iterable of str or str
        Effects of the model; those of :data:`LEFT_OUT` are left out of the nominal model (no
        nominal frequencies depend on them).
    max_modes : int
        Most modes suggested.

    Returns
    -------
    ModeChoice

    Raises
    ------
    BeamInputError
        A window outside the record, or a record too short for a noise floor (fewer than 64 samples).
    """
    from scipy import signal  # slow import, only when asked

    window = resolve_window(measurement, window)
    t, y = measurement.time_s, measurement.output
    usable = ~measurement.left_out
    floor = noise_floor(t[usable], y[usable])
    inside = (t >= window[0] - 1e-12) & (t <= window[1] + 1e-12) & usable
    # a window too short for a spectrum: the band is read from the whole record
    data = y[inside] if np.count_nonzero(inside) >= 64 else y[usable]
    fs = 1.0 / measurement.median_interval_s
    frequency, psd = signal.welch(data - np.median(data), fs=fs, nperseg=int(min(256, data.size // 4)), detrend="linear")
    with np.errstate(over="ignore"):  # a record of absurd magnitude: an infinite floor, reported downstream
        edge = _excited_edge(frequency, psd, np.float64(floor.sd) ** 2 / (0.5 * fs))

    linear = [e for e in parse_effects(effects) if e not in LEFT_OUT]
    model = BeamModel(measurement.geometry, linear, input_kind=measurement.input_kind)
    count = int(min(max_modes + 1, model.size))
    centres = {name: prior_centre(name, measurement.prior_nominal) for name in model.parameter_names_for(count)}
    nominal, _ = model.natural_modes(centres, count)
    band = int(np.count_nonzero(nominal < edge))
    if band < nominal.size and nominal[band] <= (1 + CLOSE_FRACTION) * edge:
        band += 1
    band = max(1, band + MARGIN_MODES)

    free = measurement.is_free
    truncation, errors = None, []
    if not free and measurement.uniform and np.count_nonzero(inside) >= 2:
        dt = measurement.sample_interval_s
        stop = int(np.nonzero(t <= window[1] + 1e-12)[0][-1]) + 1
        drive = measurement.input[:stop]
        kind = measurement.output_kind
        reference = model.response(centres, drive, dt, None, output=kind)[inside[:stop]]
        errors = []
        for n in range(1, count + 1):
            error = model.response(centres, drive, dt, n, output=kind)[inside[:stop]] - reference
            errors.append(float(np.sqrt(np.mean(error**2))))
        below = [n for n, e in enumerate(errors, start=1) if e <= TRUNCATION_FRACTION * floor.sd]
        truncation = below[0] if below else count
    if free:  # see the module notes: the band rule is not used for a free response (yet)
        modes = int(min(DEFAULT_MODES, model.size))
    else:
        modes = int(min(max(band, truncation or 0), max_modes, model.size))
    return ModeChoice(modes, edge, band, truncation, tuple(float(f) for f in nominal), float(floor.sd),
                      bool(free), tuple(errors))
