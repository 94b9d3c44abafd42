"""Voltage excitations applied to the piezo patch.

The voltage is sampled at the measurement times t_k and held constant (zero-order hold) over
[t_k, t_k+1); :meth:`Excitation.voltage` gives those sample values. All signals are zero for
t < 0 and after they end.

=========  ====================================================  ======================================
kind       V(t) while on (0 <= t < end), volts                    keys (end)
=========  ====================================================  ======================================
pulse      A                                                     amplitude_V, width_s (width_s)
burst      A sin(2 pi f t)                                       amplitude_V, frequency_Hz, cycles
                                                                 (cycles / f)
chirp      A sin(2 pi (f0 t + (f1 - f0) t^2 / (2 T)))            amplitude_V, start_Hz, stop_Hz,
                                                                 duration_s (T)
file       the voltage column of a measurement CSV, sample k     file (n samples x its step)
           held over [k dt, (k + 1) dt) of the recording
=========  ====================================================  ======================================

The chirp's instantaneous frequency sweeps linearly from f0 at t = 0 to f1 at t = T.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from beam.errors import BeamInputError, as_finite_float, short_repr

#: Keys each kind needs (all positive finite numbers except ``file``, a path string).
EXCITATION_KEYS: dict[str, tuple[str, ...]] = {
    "pulse": ("amplitude_V", "width_s"),
    "burst": ("amplitude_V", "frequency_Hz", "cycles"),
    "chirp": ("amplitude_V", "start_Hz", "stop_Hz", "duration_s"),
    "file": ("file",),
}

#: Every key an ``[excitation]`` table may hold, besides ``kind``.
ALL_EXCITATION_KEYS: tuple[str, ...] = (
    "amplitude_V", "width_s", "frequency_Hz", "cycles", "start_Hz", "stop_Hz", "duration_s", "file",
)

# A sample time t = k dt may land a hair below k dt in floating point; this (in samples)
# keeps it in bin k when looking up a recorded voltage.
_BIN_TOLERANCE = 1e-9


@dataclass(frozen=True)
class Excitation:
    """A voltage signal V(t) (V) for the piezo patch.

    Parameters
    ----------
    kind : {"pulse", "burst", "chirp", "file"}
        Signal shape (see the module table).
    amplitude_V : float, optional
        Amplitude A (V); required for pulse, burst and chirp.
    width_s : float, optional
        Pulse width (s).
    frequency_Hz : float, optional
        Burst frequency f (Hz).
    cycles : float, optional
        Number of burst cycles (may be fractional); the burst lasts ``cycles / frequency_Hz``.
    start_Hz, stop_Hz : float, optional
        Chirp start and stop frequencies f0, f1 (Hz); a downward sweep (f1 < f0) is allowed.
    duration_s : float, optional
        Chirp duration T (s).
    file : str, optional
        For kind ``file``: where the recorded voltage came from (informative only).
    recorded_voltage_V : numpy.ndarray, optional
        For kind ``file``: the recorded voltage samples (V).
    recorded_sample_interval_s : float, optional
        For kind ``file``: the recording's sampling interval (s).

    Raises
    ------
    BeamInputError
        Unknown kind, a missing key, a key the kind does not use, or a value that is not a
        positive finite number; the message names the key.
    """

    kind: str
    amplitude_V: float | None = None
    width_s: float | None = None
    frequency_Hz: float | None = None
    cycles: float | None = None
    start_Hz: float | None = None
    stop_Hz: float | None = None
    duration_s: float | None = None
    file: str | None = None
    recorded_voltage_V: np.ndarray | None = field(default=None, repr=False, compare=False)
    recorded_sample_interval_s: float | None = None

    def __post_init__(self) -> None:
        if self.kind not in EXCITATION_KEYS:
            raise BeamInputError(
                f"excitation kind: unknown kind {self.kind!r}; expected one of {', '.join(EXCITATION_KEYS)}"
            )
        needed = EXCITATION_KEYS[self.kind]
        for key in ALL_EXCITATION_KEYS:
            value = getattr(self, key)
            if key not in needed:
                if value is not None:
                    raise BeamInputError(
                        f"excitation {key}: not used by a {self.kind!r} excitation (it takes {', '.join(needed)})"
                    )
                continue
            if value is None:
                raise BeamInputError(f"excitation {key}: missing; a {self.kind!r} excitation needs {', '.join(needed)}")
            if key == "file":
                if not isinstance(value, str):
                    raise BeamInputError(f"excitation file: must be a path string, got {value!r}")
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
                raise BeamInputError(f"excitation {key}: must be a number, got {short_repr(value)}")
            number = as_finite_float(value)
            if number is None or number <= 0:
                raise BeamInputError(f"excitation {key}: must be a positive finite number, got {short_repr(value)}")
            object.__setattr__(self, key, number)
        if self.kind == "file":
            self._check_recording()
        elif self.recorded_voltage_V is not None or self.recorded_sample_interval_s is not None:
            raise BeamInputError(f"excitation: a recorded voltage is only used by kind 'file', not {self.kind!r}")

    def _check_recording(self) -> None:
        if self.recorded_voltage_V is None or self.recorded_sample_interval_s is None:
            raise BeamInputError("excitation file: the recorded voltage and its sample interval are required")
        voltage = np.array(self.recorded_voltage_V, dtype=float)
        if voltage.ndim != 1 or voltage.size == 0:
            raise BeamInputError(
                f"excitation file: recorded voltage must be a non-empty 1-D array, got shape {voltage.shape}"
            )
        if not np.all(np.isfinite(voltage)):
            first = int(np.argmin(np.isfinite(voltage)))
            raise BeamInputError(f"excitation file: recorded voltage has a non-finite value at sample {first}")
        step = self.recorded_sample_interval_s
        number = as_finite_float(step)
        if number is None or number <= 0:
            raise BeamInputError(
                f"excitation file: sample interval must be a positive finite number (s), got {short_repr(step)}"
            )
        voltage.setflags(write=False)
        object.__setattr__(self, "recorded_voltage_V", voltage)
        object.__setattr__(self, "recorded_sample_interval_s", number)

    @classmethod
    def from_recording(cls, voltage_V: np.ndarray, sample_interval_s: float, file: str = "") -> Excitation:
        """A ``file`` excitation replaying recorded voltage samples.

        Parameters
        ----------
        voltage_V : numpy.ndarray
            Recorded voltage (V), sample k held over [k dt, (k + 1) dt).
        sample_interval_s : float
            Recording step dt (s).
        file : str
            Where it came from (informative).
        """
        return cls("file", file=file, recorded_voltage_V=voltage_V, recorded_sample_interval_s=sample_interval_s)

    @property
    def end_s(self) -> float:
        """Time (s) from which the voltage is zero for good."""
        if self.kind == "pulse":
            return self.width_s
        if self.kind == "burst":
            return self.cycles / self.frequency_Hz
        if self.kind == "chirp":
            return self.duration_s
        return self.recorded_voltage_V.size * self.recorded_sample_interval_s

    def voltage(self, time_s: np.ndarray | float) -> np.ndarray:
        """Voltage V(t) (V) at the given times: the zero-order-hold sample values.

        Parameters
        ----------
        time_s : array_like
            Times t (s), any shape; for a measurement, t_k = k / rate_Hz.

        Returns
        -------
        numpy.ndarray
            V(t) (V), same shape as ``time_s``; 0 for t < 0 and t >= :attr:`end_s`.
        """
        t = np.asarray(time_s, dtype=float)
        if self.kind == "file":
            return self._recorded_voltage(t)
        on = (t >= 0) & (t < self.end_s)
        if self.kind == "pulse":
            return np.where(on, self.amplitude_V, 0.0)
        with np.errstate(over="ignore", invalid="ignore"):
            if self.kind == "burst":
                phase = self.frequency_Hz * t
            else:
                sweep_rate = (self.stop_Hz - self.start_Hz) / self.duration_s
                phase = self.start_Hz * t + 0.5 * sweep_rate * t * t
            values = np.where(on, self.amplitude_V * np.sin(2.0 * np.pi * phase), 0.0)
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            where = float(np.ravel(t)[bad[0]])
            raise BeamInputError(
                f"excitation {self.describe()}: the phase overflows at t = {where:g} s; "
                "use smaller frequencies or a longer duration"
            )
        return values

    def _recorded_voltage(self, t: np.ndarray) -> np.ndarray:
        samples = self.recorded_voltage_V
        with np.errstate(invalid="ignore"):
            index = np.floor(t / self.recorded_sample_interval_s + _BIN_TOLERANCE)
        inside = (t >= 0) & (index < samples.size)
        safe_index = np.where(inside, index, 0).astype(np.int64)
        return np.where(inside, samples[safe_index], 0.0)

    def to_table(self) -> dict[str, float | str]:
        """The ``[excitation]`` table for a TOML file: kind and its keys."""
        table: dict[str, float | str] = {"kind": self.kind}
        for key in EXCITATION_KEYS[self.kind]:
            table[key] = getattr(self, key)
        return table

    def describe(self) -> str:
        """One human line, e.g. ``chirp 10 V, 2 -> 250 Hz over 1.5 s``."""
        if self.kind == "pulse":
            return f"pulse {self.amplitude_V:g} V for {self.width_s:g} s"
        if self.kind == "burst":
            return f"burst {self.amplitude_V:g} V at {self.frequency_Hz:g} Hz, {self.cycles:g} cycles"
        if self.kind == "chirp":
            return (f"chirp {self.amplitude_V:g} V, {self.start_Hz:g} -> {self.stop_Hz:g} Hz "
                    f"over {self.duration_s:g} s")
        return (f"recorded voltage from {self.file or 'a file'} "
                f"({self.recorded_voltage_V.size} samples at {1 / self.recorded_sample_interval_s:g} Hz)")
