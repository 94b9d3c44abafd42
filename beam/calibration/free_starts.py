"""Starting points of the MAP search for records without a patch coupling: free responses (whose
initial state :class:`beam.calibration.free.ProjectedFreeModel` profiles out) and point forces.

With the amplitudes and phases fitted linearly, the only multimodality left is the frequencies':
the spectral match of :mod:`beam.calibration.starts` (EI scaled so the model's modes sit on the
window's spectral peaks) on the record's own spectrum (irregular stamps interpolated to the
median step), for the prior centres and for each point of the screened design over the effect
parameters (:func:`beam.calibration.starts.design_points`), scored by residual RMS in one batched
model call.

**Damped-away starts.** With a damping ratio per mode (``modal_damping``), a mode the model
cannot place (its frequency off the record's peak: a missing mass, a clamp) may be fitted best by
damping it away, its damping ratio at the top of its prior. That optimum sits in another basin
than the spectral starts' (small damping), which no screening by residual RMS can pick; so for
each mode one more start: the best screened start (:func:`damped_away_base`) with that mode's
damping ratio :data:`DAMPED_AWAY` of its log range below the top. The measurements behind this:
the design decisions page.
"""

from __future__ import annotations

from collections.abc import Mapping

import numba
import numpy as np

from beam.calibration.starts import SCALE_GRID, design_points, prior_centres
from beam.errors import BeamInputError
from beam.inference.likelihood import AR1_COEFFICIENT
from beam.physics.effects import EFFECTS, effect_of_parameter
from beam.physics.effects.base import BENDING_STIFFNESS

__all__ = ["DAMPED_AWAY", "damped_away_base", "damped_away_starts", "projected_starting_points", "record_spectrum", "spectral_scales"]

#: Where a damped-away start puts a mode's damping ratio: this fraction of its log prior range
#: below the top (the ``BARELY_ON`` margin of :mod:`beam.calibration.starts`, at the other end).
DAMPED_AWAY = 0.02


def record_spectrum(time_s: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies (Hz) and Hann-windowed periodogram (zero-padded x8) of samples at ``time_s``.

    Irregular stamps are linearly interpolated onto the median step first (a spectrum for
    locating peaks, not a measurement of power); the mean is removed.
    """
    t = np.asarray(time_s, dtype=float)
    y = np.asarray(values, dtype=float)
    step = float(np.median(np.diff(t)))
    count = int(np.floor((t[-1] - t[0]) / step)) + 1
    uniform = t[0] + step * np.arange(count)
    data = np.interp(uniform, t, y) if not np.allclose(np.diff(t), step, rtol=1e-6, atol=0.0) else y[:count]
    data = data - data.mean()
    n_fft = 8 * int(2 ** np.ceil(np.log2(data.size)))
    power = np.abs(np.fft.rfft(data * np.hanning(data.size), n_fft)) ** 2
    return np.fft.rfftfreq(n_fft, step), power


def spectral_scales(frequencies_Hz: np.ndarray, spectrum: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """The best scale factor s of EI for each row of model frequencies (B, m) (Hz): s maximises
    the summed log power of the record at sqrt(s) x the modes below 0.8 x Nyquist (the spectral
    match of :mod:`beam.calibration.starts`)."""
    frequencies, power = spectrum
    nyquist = frequencies[-1]
    model = np.atleast_2d(frequencies_Hz)
    rows, inverse = np.unique(model, axis=0, return_inverse=True)
    if rows.shape[0] < model.shape[0]:  # e.g. a design over damping ratios alone: one row of frequencies
        return spectral_scales(rows, spectrum)[inverse.ravel()]
    floor = power.max() * 1e-12 + 1e-300
    scales = np.ascontiguousarray(SCALE_GRID, dtype=float)
    model = np.ascontiguousarray(model, dtype=float)
    if model.shape[1] <= _PRODUCT_MODES:  # the product of the powers, on the scale of the largest
        peak = power.max() + 1e-300
        best = _best_scales(model, np.sqrt(scales), np.ascontiguousarray(power / peak, dtype=float),
                            float(frequencies[1]), float(nyquist), float(floor / peak), True)
    else:
        best = _best_scales(model, np.sqrt(scales), np.ascontiguousarray(power, dtype=float),
                            float(frequencies[1]), float(nyquist), float(floor), False)
    return scales[best]


#: Up to this many modes :func:`spectral_scales` compares products of the powers (each at least
#: 1e-12 of the largest: no underflow), more modes the sums of their logarithms.
_PRODUCT_MODES = 16


@numba.njit(cache=True, nogil=True)
def _best_scales(model, root_scales, power, bin_Hz, nyquist, floor, products):  # pragma: no cover - jitted
    """Index of the best scale for each row of ``model`` (see :func:`spectral_scales`): the summed
    log of the power, linearly interpolated on its uniform grid of step ``bin_Hz``, at
    sqrt(scale) x each mode below 0.8 x Nyquist (log(floor) for a mode scaled beyond 0.95 x
    Nyquist); the first of equal maxima. Compiled: numpy's version, over arrays of
    rows x 1,201 scales x modes, took 20 ms for 190 rows of 4 modes (the design of a preview
    with a sensor or tip mass), this 6 ms (the logarithms).

    With ``products`` the same maximum by the product of the interpolated powers (``power`` and
    ``floor`` divided by the largest power, so that a product of up to :data:`_PRODUCT_MODES`
    factors neither overflows nor underflows): the logarithm is increasing, and the 6 ms of
    logarithms fall to 1.9 ms."""
    rows, modes = model.shape
    last = power.size - 1.0
    log_floor = np.log(floor)
    out = np.empty(rows, dtype=np.int64)
    for r in range(rows):
        best = -np.inf
        best_index = 0
        for i in range(root_scales.size):
            score = 1.0 if products else 0.0
            for j in range(modes):
                f = model[r, j]
                scaled = root_scales[i] * f
                if f > 0 and f < 0.8 * nyquist and scaled < 0.95 * nyquist:
                    position = min(max(scaled / bin_Hz, 0.0), last)
                    index = min(int(position), power.size - 2)
                    fraction = position - index
                    value = power[index] * (1.0 - fraction) + power[index + 1] * fraction + floor
                    if products:
                        score *= value
                    else:
                        score += np.log(value)
                elif products:
                    score *= floor
                else:
                    score += log_floor
            if score > best:
                best = score
                best_index = i
        out[r] = best_index
    return out


def projected_starting_points(problem, setup, warm: Mapping[str, float] | None = None,
                              keep: int = 3) -> list[dict[str, float]]:
    """Starting points of the MAP search for a record without a patch coupling (a free response,
    whose initial state the forward model profiles out, or a point force): a caller's ``warm``
    start, the prior centres with EI matched to the window's spectrum, and the ``keep`` best
    points of the screened design over the effect parameters of
    :func:`beam.calibration.starts.design_points`, each with its own spectral EI, by residual
    RMS in one batched model call (natural units, physical parameters)."""
    measurement = setup.measurement
    mask = setup.fit_mask
    spectrum = record_spectrum(measurement.time_s[mask], measurement.output[mask])
    centres = prior_centres(setup)
    ei = BENDING_STIFFNESS.name
    prior = {name: problem.parameter(name).prior for name in centres}

    def clip(name: str, value):
        return np.clip(value, prior[name].lower * (1 + 1e-9), prior[name].upper * (1 - 1e-9))

    design = design_points(problem, setup)
    size = next(iter(design.values())).size if design else 0
    batch = {name: np.full(size + 1, centres[name]) for name in centres}
    for name, values in design.items():
        batch[name][1:] = values
    reduced, _, _ = setup.model.reduced_system(batch, setup.modes)
    model_frequencies = np.sqrt(np.maximum(reduced["omega2"], 0.0)) / (2 * np.pi)
    batch[ei] = clip(ei, batch[ei] * spectral_scales(model_frequencies, spectrum))
    batch = {name: clip(name, v) for name, v in batch.items()}
    starts = [{name: float(v[0]) for name, v in batch.items()}]
    damped_base = starts[0]
    if size:
        with np.errstate(all="ignore"):
            try:  # the centre (row 0) scored with the design: the damped-away starts' base is the best of all
                rms = np.sqrt(np.mean((problem.data - problem.predict(_screening_values(problem, batch))) ** 2, axis=1))
            except BeamInputError:
                rms = np.full(size + 1, np.inf)
        rms[~np.isfinite(rms)] = np.inf
        for i in np.argsort(rms[1:], kind="stable")[:keep]:
            if np.isfinite(rms[1 + i]):
                starts.append({name: float(v[1 + i]) for name, v in batch.items()})
        if np.any(np.isfinite(rms)):
            damped_base = damped_away_base(starts[0], {name: float(v[int(np.argmin(rms))]) for name, v in batch.items()})
    return ([dict(warm)] if warm is not None else []) + starts + damped_away_starts(problem, damped_base)


def _screening_values(problem, batch: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """``batch`` with the noise parameters the forward model reads: the AR(1) coefficient at 0
    (the screen ranks starts by the plain residual RMS, whatever the likelihood)."""
    size = next(iter(batch.values())).size
    return dict(batch, **{name: np.zeros(size) for name in problem.noise_names if name == AR1_COEFFICIENT})


def _per_mode(name: str) -> bool:
    """Whether ``name`` belongs to a per-mode family (the modal damping ratios)."""
    effect = effect_of_parameter(name) if name in _KNOWN else None
    return effect is not None and EFFECTS[effect].per_mode


_KNOWN = frozenset(name for effect in EFFECTS.values() for name in effect.parameter_names)


def damped_away_base(centre: Mapping[str, float], best: Mapping[str, float]) -> dict[str, float]:
    """The point the damped-away starts are built on (see the module notes): the per-mode damping
    ratios of the spectral ``centre``, every other parameter (EI, a point mass, ...) of the
    ``best`` screened start (the lowest residual RMS, the centre included).

    The frequencies are what the damped-away starts need right: at the centre a point mass sits
    at its log prior centre (0.14 g against the strip's ~4 g), so its modes are the bare beam's
    and a search from there climbs ~6,000 nats over 13-16 lock-step iterations before it can
    tell which mode to damp away. For a model whose design varies only damping ratios (every
    row has the same frequencies, hence the same spectral EI) this is the centre itself.
    """
    return {name: (centre[name] if _per_mode(name) else value) for name, value in best.items()}


def damped_away_starts(problem, start: Mapping[str, float]) -> list[dict[str, float]]:
    """``start`` with one mode damped away, for each per-mode damping ratio of the model (see the
    module notes): that ratio :data:`DAMPED_AWAY` of its log prior range below its upper bound."""
    out = []
    for name in start:
        if not _per_mode(name):
            continue
        prior = problem.parameter(name).prior
        low, high = np.log(prior.lower), np.log(prior.upper)
        out.append(dict(start, **{name: float(np.exp(high - DAMPED_AWAY * (high - low)))}))
    return out


#: Where the nonlinear-free starts put each nonlinear parameter besides its null value: these
#: fractions of its log prior range above the low end (for C_d on 0.01-50: 1.7, 9.1 and 21).
NONLINEAR_FRACTIONS = (0.6, 0.8, 0.9)


def nonlinear_free_starts(problem, setup, linear_optimum: Mapping[str, float],
                          warm: Mapping[str, float] | None = None) -> list[dict[str, float]]:
    """Starting points for a free decay with a nonlinear effect
    (:class:`beam.calibration.free_nonlinear.NonlinearFreeModel`): a caller's ``warm`` start,
    then ``linear_optimum`` (the MAP values of the model without its nonlinear effects, from
    :func:`beam.calibration.run.calibration_preview`) with the nonlinear parameters at their null values — the
    nested start, which makes the fit no worse than that sub-model's — and at
    :data:`NONLINEAR_FRACTIONS` of their log prior ranges (natural units, physical parameters).
    """
    from beam.calibration.free_nonlinear import nonlinear_parameters
    from beam.calibration.nulls import null_value

    base = {name: float(v) for name, v in linear_optimum.items() if name in setup.physical_names}
    names = nonlinear_parameters(setup.physical_names)
    starts = [dict(base, **{name: null_value(problem, name) for name in names})]
    for fraction in NONLINEAR_FRACTIONS:
        point = dict(base)
        for name in names:
            prior = problem.parameter(name).prior
            point[name] = float(np.exp(np.log(prior.lower) + fraction * (np.log(prior.upper) - np.log(prior.lower))))
        starts.append(point)
    return ([dict(warm)] if warm is not None else []) + starts
