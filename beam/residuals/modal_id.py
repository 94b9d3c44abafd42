"""Time-domain modal identification of the free decay by the matrix pencil method.

After the excitation stops, the response of a linear beam is a sum of damped sinusoids,

    y[k] = sum_i R_i z_i^k,   z_i = exp(s_i dt),   s_i = −zeta_i omega_i ± j omega_i sqrt(1 − zeta_i²),

so the natural frequency is |s_i| / 2pi (Hz) and the damping ratio −Re(s_i) / |s_i| — the
conventions of :meth:`beam.physics.model.BeamModel.natural_modes`.

The poles z_i are found by the total-least-squares matrix pencil (Hua & Sarkar 1990; Sarkar &
Pereira 1995): the Hankel matrix Y (N − L) x (L + 1) of the record is reduced to its M dominant
right singular vectors V (M chosen from the singular values, or given), and the z_i are the
eigenvalues of pinv(V[:-1]) V[1:]. The singular values and vectors come from the eigenvalues
of the Gram matrix Y^T Y, built in O(N L) by sliding sums: a 10,000-sample record takes a few
tens of milliseconds, without the large BLAS calls that slow down on a busy machine. The residues R_i follow by linear least squares on all N
samples. Poles that are not a physical mode are discarded: growing or heavily damped ones,
those with fewer than two cycles in the decay (near 0 Hz) or near the Nyquist frequency, those
of negligible amplitude, and those whose energy over the decay is within 20 dB of the noise
(a matched-filter SNR; the noise variance is that of data − reconstruction). A mode's amplitude is 2 |R_i| (m): that of its real sinusoid at the start of the
decay.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.linalg
import scipy.optimize
import scipy.signal

from beam.errors import BeamInputError
from beam.physics.effects.fingerprint import difference_words  # noqa: F401 - the words of a modes-table difference, re-exported
from beam.residuals.common import (
    as_signal,
    check_signals,
    integer,
    jsonable,
    positive,
)

__all__ = [
    "DIFFERENCE_CONVENTION",
    "IdentifiedModes",
    "ModeMatch",
    "ModeRow",
    "compare_modes",
    "difference_words",
    "unseen_reason",
    "free_decay_start",
    "identify_modes",
    "matrix_pencil_poles",
]

#: Fewest free-decay samples an identification accepts.
MIN_DECAY_SAMPLES = 64
#: Largest pencil parameter L by default (the eigenproblem is (L + 1) x (L + 1): about 10 ms).
MAX_PENCIL = 300
#: Singular values below this multiple of the noise edge (see :func:`matrix_pencil_poles`) are noise ...
NOISE_FLOOR_FACTOR = 1.5
#: ... and below this fraction of the largest one they are rounding, whatever the noise (the
#: Gram matrix resolves singular values down to about sqrt(machine epsilon) of the largest).
RELATIVE_SINGULAR_VALUE = 1e-7
#: Modes whose energy over the decay is below this multiple of the noise variance are discarded
#: (a matched-filter SNR of 20 dB; a pole fitted to white noise alone holds about 2 ln N).
MIN_MODE_SNR = 100.0


def free_decay_start(
    time_s: np.ndarray,
    voltage_V: np.ndarray | None = None,
    *,
    start_s: float | None = None,
    threshold_V: float = 0.0,
    min_samples: int = MIN_DECAY_SAMPLES,
) -> int:
    """Index of the first sample of the free decay.

    Either the first sample at or after ``start_s``, or the sample after the last one where
    |voltage| > ``threshold_V`` (the voltage is held over each sample interval, so the beam is
    free from the next sample on). A voltage that is never above the threshold gives 0.

    Parameters
    ----------
    time_s : array (n,)
        Sample times (s).
    voltage_V : array (n,), optional
        Piezo voltage (V); needed unless ``start_s`` is given.
    start_s : float, optional
        Start of the free decay (s), overriding the voltage.
    threshold_V : float
        |V| at or below this counts as off (default 0).
    min_samples : int
        Fewest samples the decay must keep.

    Raises
    ------
    BeamInputError
        No free decay (the voltage is on to the end) or fewer than ``min_samples`` left.
    """
    time = as_signal(time_s, "time_s")
    if start_s is not None:
        start_value = float(start_s)
        if not np.isfinite(start_value):
            raise BeamInputError(f"start_s must be finite, got {start_s!r}")
        first = int(np.searchsorted(time, start_value - 1e-9 * max(abs(start_value), 1.0)))
        source = f"start_s = {start_value:g} s"
    elif voltage_V is None:
        raise BeamInputError("give voltage_V (to find where the excitation stops) or start_s")
    else:
        voltage = as_signal(voltage_V, "voltage_V")
        if voltage.size != time.size:
            raise BeamInputError(f"voltage_V has {voltage.size} samples but time_s has {time.size}")
        on = np.flatnonzero(np.abs(voltage) > threshold_V)
        first = 0 if on.size == 0 else int(on[-1]) + 1
        if first >= time.size:
            raise BeamInputError(
                "no free decay: the voltage is on up to the last sample; give start_s or a record that ends in free decay"
            )
        source = f"the excitation stops at {time[first]:g} s"
    left = time.size - first
    if left < min_samples:
        raise BeamInputError(
            f"free decay too short: {source}, leaving {max(left, 0)} samples; at least {min_samples} needed"
        )
    return first


def _hankel_gram(y: np.ndarray, pencil: int) -> np.ndarray:
    """Y^T Y of the Hankel matrix Y[i, j] = y[i + j] (i < N − L, j <= L), in O(N L + L²).

    The first row is a correlation; along each diagonal the entries differ by one product
    added and one removed: G[j, j + d] = G[j − 1, j − 1 + d] + y[M − 1 + j] y[M − 1 + j + d]
    − y[j − 1] y[j − 1 + d], M = N − L.
    """
    m, size = y.size - pencil, pencil + 1
    first = scipy.signal.correlate(y, y[:m], mode="valid")  # first[d] = sum_i y[i] y[i + d], d = 0 ... L
    gram = np.empty((size, size))
    for d in range(size):
        added = y[m : m + pencil - d] * y[m + d : m + pencil]
        removed = y[: pencil - d] * y[d:pencil]
        diagonal = first[d] + np.concatenate([[0.0], np.cumsum(added - removed)])
        index = np.arange(size - d)
        gram[index, index + d] = diagonal
        gram[index + d, index] = diagonal
    return gram


def matrix_pencil_poles(
    y: np.ndarray, order: int | None = None, pencil: int | None = None, max_order: int = 40
) -> tuple[np.ndarray, np.ndarray, int]:
    """Discrete poles z_i of a sum of damped exponentials by the TLS matrix pencil.

    Parameters
    ----------
    y : array (N,)
        Samples y[0 ... N−1].
    order : int, optional
        Number M of poles (singular values kept). Default: the singular values above
        ``NOISE_FLOOR_FACTOR`` x the noise edge (1 + sqrt((L + 1) / (N − L))) x their median
        and above ``RELATIVE_SINGULAR_VALUE`` x the largest, at most ``max_order``.
    pencil : int, optional
        Pencil parameter L (default min(N // 3, MAX_PENCIL)).
    max_order : int
        Largest automatic order.

    Returns
    -------
    poles : ndarray (M,) complex
    singular_values : ndarray (L + 1,)
        Singular values of the Hankel matrix, largest first (for an order plot).
    order : int
        M used.
    """
    y = as_signal(y, "y", min_samples=8)
    n = y.size
    pencil = min(n // 3, MAX_PENCIL) if pencil is None else integer(pencil, "pencil", 2, n - 2)
    gram = _hankel_gram(y, pencil)
    eigenvalues, eigenvectors = scipy.linalg.eigh(gram, check_finite=False)
    singular = np.sqrt(np.maximum(eigenvalues[::-1], 0.0))
    right = eigenvectors[:, ::-1]  # right singular vectors of Y, largest first
    if order is None:
        # white noise alone gives singular values up to about (1 + sqrt(aspect)) x their median
        # (the Marchenko–Pastur edge); keep those clearly above that edge
        edge = (1 + np.sqrt((pencil + 1) / (n - pencil))) * np.median(singular)
        keep = (singular > NOISE_FLOOR_FACTOR * edge) & (singular > RELATIVE_SINGULAR_VALUE * singular[0])
        order = int(min(max(keep.sum(), 1), max_order, pencil))
    else:
        order = integer(order, "order", 1, pencil)
    v = right[:, :order]  # (L + 1) x M: basis of the signal row space
    poles = scipy.linalg.eigvals(np.linalg.pinv(v[:-1]) @ v[1:])
    return poles, singular, order


@dataclass(frozen=True)
class ModeRow:
    """One identified mode: frequency (Hz), damping ratio, amplitude (m) and phase (rad) at the decay start, SNR (dB)."""

    frequency_Hz: float
    damping_ratio: float
    amplitude_m: float
    phase_rad: float
    snr_db: float


@dataclass(frozen=True, eq=False)
class IdentifiedModes:
    """Modes identified from a free decay, sorted by frequency.

    Parameters
    ----------
    frequency_Hz : ndarray
        Natural frequencies |s| / 2pi (Hz).
    damping_ratio : ndarray
        −Re(s) / |s|.
    amplitude_m : ndarray
        Amplitude of each mode's sinusoid at the decay start (m).
    phase_rad : ndarray
        Phase at the decay start (rad): the mode contributes A e^{−zeta omega t} cos(omega_d t + phase).
    snr_db : ndarray
        Energy of the mode over the decay / noise variance (dB): a matched-filter SNR.
    start_s : float
        Time of the first free-decay sample (s).
    n_samples : int
        Free-decay samples used.
    order : int
        Poles kept by the pencil (before discarding non-physical ones).
    singular_values : ndarray
        Hankel singular values relative to the largest (for an order plot).
    fit_rms_m : float
        RMS of data − the fit of all M poles over the decay (m): about the noise if M is enough.
    """

    frequency_Hz: np.ndarray
    damping_ratio: np.ndarray
    amplitude_m: np.ndarray
    phase_rad: np.ndarray
    snr_db: np.ndarray
    start_s: float
    n_samples: int
    order: int
    singular_values: np.ndarray = field(repr=False)
    fit_rms_m: float

    @property
    def rows(self) -> list[ModeRow]:
        """The per-mode table."""
        return [ModeRow(*map(float, values)) for values in zip(
            self.frequency_Hz, self.damping_ratio, self.amplitude_m, self.phase_rad, self.snr_db)]

    def reconstruct(self, time_s: np.ndarray) -> np.ndarray:
        """The identified modes at times ``time_s`` (s): sum of A e^{−zeta omega (t − t0)} cos(omega_d (t − t0) + phase) (m).

        Zero before the decay start t0; for plotting the fit over the data.
        """
        time = np.asarray(time_s, dtype=float)
        t = time - self.start_s
        omega = 2 * np.pi * self.frequency_Hz
        sigma = self.damping_ratio * omega
        omega_d = omega * np.sqrt(1 - self.damping_ratio**2)
        waves = self.amplitude_m * np.exp(-sigma * t[..., None]) * np.cos(omega_d * t[..., None] + self.phase_rad)
        return np.where(t >= 0, waves.sum(axis=-1), 0.0)

    def to_dict(self, arrays: bool = False) -> dict[str, Any]:
        out = jsonable(self, arrays=False)
        out["modes"] = jsonable(self.rows)
        if arrays:
            out["singular_values"] = jsonable(self.singular_values)
        return out


def identify_modes(
    time_s: np.ndarray,
    displacement_m: np.ndarray,
    voltage_V: np.ndarray | None = None,
    *,
    start_s: float | None = None,
    threshold_V: float = 0.0,
    order: int | None = None,
    pencil: int | None = None,
    max_damping_ratio: float = 0.3,
    min_cycles: float = 2.0,
    max_frequency_fraction: float = 0.9,
    min_relative_amplitude: float = 1e-3,
    min_snr: float = MIN_MODE_SNR,
) -> IdentifiedModes:
    """Natural frequencies, damping ratios and amplitudes from the free decay of a record.

    Parameters
    ----------
    time_s : array (n,)
        Uniform sample times (s).
    displacement_m : array (n,)
        Measured displacement (m).
    voltage_V : array (n,), optional
        Piezo voltage (V): the decay starts after the last sample where it is non-zero.
    start_s : float, optional
        Start of the free decay (s), instead of the voltage.
    threshold_V : float
        |V| at or below this counts as off (default 0; raise it for a measured voltage with noise).
    order : int, optional
        Number of poles (twice the modes for a real signal); default chosen from the singular
        values of the Hankel matrix (see :func:`matrix_pencil_poles`).
    pencil : int, optional
        Pencil parameter L; default min(N // 3, 300).
    max_damping_ratio : float
        Poles more damped than this are noise, not modes (default 0.3).
    min_cycles : float
        Modes with fewer cycles than this over the decay are discarded (default 2); so is a
        frequency above ``max_frequency_fraction`` x Nyquist (default 0.9).
    min_relative_amplitude : float
        Modes with amplitude below this fraction of the largest are discarded (default 1e-3).
    min_snr : float
        Modes whose energy over the decay is below this multiple of the noise variance (the
        variance of data − reconstruction) are discarded (default 100, i.e. 20 dB).

    Returns
    -------
    IdentifiedModes

    Raises
    ------
    BeamInputError
        Bad arrays, no free decay or fewer than 64 samples of it, a decay without any mode.
    """
    time, dt, (y_all,) = check_signals(time_s, displacement_m=displacement_m)
    max_damping_ratio = positive(max_damping_ratio, "max_damping_ratio")
    min_relative_amplitude = float(min_relative_amplitude)
    first = free_decay_start(time, voltage_V, start_s=start_s, threshold_V=threshold_V)
    y = y_all[first:]
    n = y.size
    if not np.any(y != y[0]):
        raise BeamInputError("the free decay is constant: there is no mode to identify")
    poles, singular, used_order = matrix_pencil_poles(y, order, pencil)
    # residues on all samples: Vandermonde least squares; each real mode is a conjugate pair
    vandermonde = poles[None, :] ** np.arange(n)[:, None]
    residues = scipy.linalg.lstsq(vandermonde, y.astype(complex), check_finite=False)[0]
    contributions = vandermonde * residues[None, :]
    noise_variance = float(np.mean(np.abs(y - contributions.sum(axis=1)) ** 2))
    # energy of each pole's real sinusoid 2 Re(R z^k) over the decay, in noise variances
    energy = np.sum((2 * contributions.real) ** 2, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        snr = energy / noise_variance if noise_variance > 0 else np.full(energy.shape, np.inf)
        s = np.log(poles.astype(complex)) / dt
        omega_n = np.abs(s)
        zeta = -s.real / omega_n
    frequency = omega_n / (2 * np.pi)
    amplitude = 2 * np.abs(residues)
    nyquist = 0.5 / dt
    physical = (
        (s.imag > 0)
        & (zeta >= 0)
        & (zeta <= max_damping_ratio)
        & (frequency * n * dt >= min_cycles)
        & (frequency <= max_frequency_fraction * nyquist)
        & (snr >= min_snr)
    )
    if physical.any():
        physical &= amplitude >= min_relative_amplitude * amplitude[physical].max()
    if not physical.any():
        raise BeamInputError(
            f"no vibration mode found in the free decay from {time[first]:g} s ({n} samples): "
            "is the beam still ringing after the excitation stops?"
        )
    index = np.flatnonzero(physical)
    index = index[np.argsort(frequency[index])]
    return IdentifiedModes(
        frequency_Hz=frequency[index], damping_ratio=zeta[index], amplitude_m=amplitude[index],
        phase_rad=np.angle(residues[index]), snr_db=10 * np.log10(snr[index]), start_s=float(time[first]),
        n_samples=int(n), order=used_order, singular_values=singular / singular[0],
        fit_rms_m=float(np.sqrt(noise_variance)),
    )


#: The sign convention of the modes table, stated once for the command line, the JSON and the dashboard.
DIFFERENCE_CONVENTION = ("measured relative to the model, 100 (measured / model - 1) %: positive when the "
                         "measured value is higher than the model's")


@dataclass(frozen=True)
class ModeMatch:
    """An identified mode against a model mode (NaN data fields when none matched).

    ``frequency_error_pct`` = 100 (f_data / f_model − 1) %; ``damping_error_pct`` likewise: positive
    when the **measured** value is higher than the model's (:data:`DIFFERENCE_CONVENTION`).
    """

    mode: int
    frequency_data_Hz: float
    frequency_model_Hz: float
    damping_data: float
    damping_model: float
    frequency_error_pct: float
    damping_error_pct: float
    #: Why an unmatched mode was not seen (:func:`unseen_reason`), "" otherwise.
    note: str = ""

    @property
    def matched(self) -> bool:
        return bool(np.isfinite(self.frequency_data_Hz))


def compare_modes(
    identified: IdentifiedModes | tuple[Sequence[float], Sequence[float]],
    model_frequencies_Hz: Sequence[float] | np.ndarray,
    model_damping_ratios: Sequence[float] | np.ndarray,
    *,
    tolerance: float = 0.35,
) -> list[ModeMatch]:
    """Match identified modes to model modes by nearest frequency.

    One-to-one assignment (:func:`scipy.optimize.linear_sum_assignment`) minimising the sum of
    |log(f_data / f_model)|; pairs further apart than ``tolerance`` in log-frequency (default
    0.35, about ±40 %) are not matched.

    Parameters
    ----------
    identified : IdentifiedModes or (frequencies_Hz, damping_ratios)
        Modes from the data.
    model_frequencies_Hz, model_damping_ratios : sequence of float
        Modes of the model, e.g. from :meth:`beam.physics.model.BeamModel.natural_modes`.
    tolerance : float
        Largest |log(f_data / f_model)| of a match.

    Returns
    -------
    list of ModeMatch
        One row per model mode with a positive frequency (mode numbers 1-based, model order).
    """
    if isinstance(identified, IdentifiedModes):
        f_data, z_data = identified.frequency_Hz, identified.damping_ratio
    else:
        f_data, z_data = identified
    f_data = np.atleast_1d(np.asarray(f_data, dtype=float))
    z_data = np.atleast_1d(np.asarray(z_data, dtype=float))
    f_model = np.atleast_1d(np.asarray(model_frequencies_Hz, dtype=float))
    z_model = np.atleast_1d(np.asarray(model_damping_ratios, dtype=float))
    if f_data.shape != z_data.shape or f_model.shape != z_model.shape:
        raise BeamInputError("frequencies and damping ratios must have the same length")
    if not (np.all(np.isfinite(f_model)) and np.all(f_model >= 0) and np.all(np.isfinite(f_data)) and np.all(f_data > 0)):
        raise BeamInputError("mode frequencies must be finite and positive (Hz)")
    tolerance = positive(tolerance, "tolerance")
    valid = np.flatnonzero(f_model > 0)
    assigned: dict[int, int] = {}
    if f_data.size and valid.size:
        cost = np.abs(np.log(f_model[valid][:, None] / f_data[None, :]))
        rows, cols = scipy.optimize.linear_sum_assignment(cost)
        assigned = {int(valid[r]): int(c) for r, c in zip(rows, cols) if cost[r, c] <= tolerance}
    out = []
    nan = float("nan")
    for number, k in enumerate(valid, start=1):
        j = assigned.get(int(k))
        fd, zd = (float(f_data[j]), float(z_data[j])) if j is not None else (nan, nan)
        fm, zm = float(f_model[k]), float(z_model[k])
        out.append(ModeMatch(
            mode=number, frequency_data_Hz=fd, frequency_model_Hz=fm, damping_data=zd, damping_model=zm,
            frequency_error_pct=100 * (fd / fm - 1), damping_error_pct=100 * (zd / zm - 1) if zm > 0 else nan,
        ))
    return out


#: A mode whose shape at the sensor is at most this share of its largest displacement along the
#: beam is "near its node" there (the sensor sees it at a tenth of its size or less).
NODE_SHARE = 0.1


def unseen_reason(x_m: np.ndarray, shape: np.ndarray, sensor_m: float, frequency_Hz: float,
                  nyquist_Hz: float) -> str:
    """Why a model mode may be missing from the record, from the model's own shape of it.

    Parameters
    ----------
    x_m : ndarray, shape (k,)
        Increasing positions along the beam from the clamp (m), the last one the tip (x = L).
    shape : ndarray, shape (k,)
        The mode's displacement shape at ``x_m`` (any scale).
    sensor_m : float
        The sensor's position (m).
    frequency_Hz, nyquist_Hz : float
        The mode's frequency and the record's Nyquist frequency (Hz).

    Returns
    -------
    str
        ``"above the record's Nyquist frequency (… Hz)"``; ``"the sensor sits near its node at
        0.78 L (it sees … % of the mode's largest displacement)"`` when the shape at the sensor is at
        most :data:`NODE_SHARE` of its largest and a node (a sign change away from the clamp) lies
        nearby; otherwise ``"not found in the record (at the sensor it has … % of its largest
        displacement)"``.
    """
    x = np.asarray(x_m, dtype=float)
    phi = np.asarray(shape, dtype=float)
    length = float(x[-1])
    if frequency_Hz >= nyquist_Hz:
        return f"above the record's Nyquist frequency ({nyquist_Hz:.4g} Hz)"
    largest = float(np.max(np.abs(phi)))
    share = abs(float(np.interp(sensor_m, x, phi))) / largest if largest > 0 else 0.0
    inside = x > 1e-6 * length  # the clamp is no node
    crossing = np.flatnonzero(inside[:-1] & (np.sign(phi[:-1]) * np.sign(phi[1:]) < 0))
    nodes = x[crossing] - phi[crossing] * (x[crossing + 1] - x[crossing]) / (phi[crossing + 1] - phi[crossing])
    if share <= NODE_SHARE and nodes.size:
        node = float(nodes[np.argmin(np.abs(nodes - sensor_m))])
        return (f"the sensor (at {sensor_m / length:.2f} L) sits near its node at {node / length:.2f} L: it sees "
                f"{100 * share:.0f} % of the mode's largest displacement")
    return f"not found in the record (at the sensor it has {100 * share:.0f} % of its largest displacement)"
