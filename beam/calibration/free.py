"""Free responses in a calibration: the unknown initial state profiled out and integrated out.

A free response (no input; the beam already moving at the first sample) is linear in its
initial state: at the sensor it is ``X(theta) a`` with the free-response basis of the retained
modes (two columns per mode, exp(sigma_j tau) cos(omega_j tau) and exp(sigma_j tau) sin(omega_j tau),
tau = t - t_ref, t_ref the first calibration sample; :meth:`beam.physics.model.BeamModel.free_response_basis`)
plus, for a velocity or acceleration record, a column of ones for the sensor's **offset** (an
accelerometer reads a constant bias; a displacement record has its zero where the beam rests,
which the free response already contains). So for given physical parameters theta the
k = 2m (+1) linear coefficients need no search:

* **Profile (variable projection)** — the prediction of :class:`ProjectedFreeModel` at theta
  is X(theta) a_hat(theta), a_hat the least-squares fit of the calibration data (generalised least
  squares with the AR(1) whitening for ``likelihood="ar1"``). The MAP search, the Laplace
  approximation, the sampler and the bands see a model of theta alone; the linear coefficients
  at the MAP (amplitudes, offset in the output's unit) are reported by :meth:`ProjectedFreeModel.linear_fit`.
* **Marginalisation** — in the posterior the coefficients are integrated out analytically:
  :meth:`ProjectedFreeModel.log_likelihood_correction` turns the profile likelihood into
  log ∫ p(y | theta, a) p(a) da under the prior a ~ N(0, A² I), A = :data:`AMPLITUDE_PRIOR_SCALE`
  x max |y| (flat on the scale of the data). With G = X̃ᵀX̃ (eigenvalues g_i, eigenvectors v_i),
  c = X̃ᵀỹ, d_i = v_iᵀ c, lambda = sigma²/A² (X̃, ỹ whitened to unit noise):

      correction = -½ Σ_i log(1 + g_i / lambda) - (1 / 2 sigma²) Σ_i d_i² lambda / (g_i (g_i + lambda)),

  exact (matrix determinant lemma and Woodbury), and for A -> inf the flat-prior result
  -½ log det(G / sigma²) + k/2 log 2 pi + k log(density of the prior at 0). It depends on sigma
  (the noise sd): a model with k coefficients fitted has k fewer degrees of freedom, and the
  marginal posterior of sigma centres on RSS/(n - k), not RSS/n. Why not a truly flat
  (improper) prior: the integral over a coefficient whose column the data barely see (a
  mode damped to nothing within the window) grows without bound as its column shrinks, so the
  marginal likelihood would reward damping an unexcited mode to the prior's edge. The prior's
  constant is the same for every model of a record and window with the same modes, so Laplace
  evidences of such models compare exactly (as the missing-effect ranking does).

tests/test_calibration_free.py checks the correction against brute-force Monte Carlo
integration over the amplitudes on a small case, and the profile fit against a simulated decay
with known initial state, offset and sensor mass.
"""

from __future__ import annotations

import functools
import math
import threading
from collections.abc import Mapping
from typing import NamedTuple

import numba
import numpy as np

from beam.errors import BeamInputError
from beam.inference import AR1_COEFFICIENT, NOISE_SD
from beam.inference.likelihood import whiten
from beam.physics import modal
from beam.physics.effects.base import BENDING_STIFFNESS
from beam.physics.model import BeamModel

__all__ = ["AMPLITUDE_PRIOR_SCALE", "OFFSET_NAME", "ProjectedFreeModel", "StartMemo", "free_basis_at", "free_prediction_at", "free_rows_at",
           "has_offset", "retained_poles", "stamp_grid"]

#: The prior sd of each linear coefficient, in units of max |data| of the calibration window.
AMPLITUDE_PRIOR_SCALE = 10.0
#: Parameter sets fitted together in :meth:`ProjectedFreeModel.fit`: the design of 32 sets on a
#: 2 s window at ~1 kHz (32 x 1,859 x 9 doubles, 4 MB) stays in cache; 400 sets at once (54 MB)
#: took 1.9 times as long per set.
FIT_CHUNK = 32
#: Name of the sensor's offset in reports (in the output's unit).
OFFSET_NAME = "output_offset"
#: Poles with |Im| below this fraction of |lambda| are real (an overdamped mode).
_REAL_POLE = 1e-9


def has_offset(output_kind: str) -> bool:
    """Whether a free response of this output gets a constant offset column (velocity, acceleration)."""
    return output_kind != "displacement"


#: Quanta tried for the time stamps (s): a logger writes its stamps with finitely many decimals.
STAMP_QUANTA = tuple(10.0 ** -d for d in range(2, 10))
#: A decaying term of the free response is left out where its envelope has fallen below this
#: fraction of its value at the reference time (:func:`_table_kernel`): a perturbation of the
#: order of round-off.
_NEGLIGIBLE = 1e-13
_LOG_NEGLIGIBLE = math.log(_NEGLIGIBLE)
#: Entries of a power table between exact anchors (:func:`_fill_powers`).
_ANCHOR_EVERY = 512
#: Most table entries per level (the two-level table below): larger spans use the direct kernel.
MAX_TABLE = 1 << 15


def stamp_grid(tau: np.ndarray) -> tuple[float, np.ndarray] | None:
    """The coarsest quantum q of :data:`STAMP_QUANTA` on which every tau - min(tau) lies
    (within 1e-4 q), and the integers N = (tau - min(tau)) / q; None when there is none with
    at most :data:`MAX_TABLE` ² steps over the span."""
    shifted = tau - tau.min()
    span = float(shifted.max()) if shifted.size else 0.0
    for q in STAMP_QUANTA:
        if span / q >= MAX_TABLE**2:
            return None
        steps = shifted / q
        index = np.rint(steps)
        if np.all(np.abs(steps - index) <= 1e-4):
            return q, index.astype(np.int64)
    return None


def free_basis_at(poles: np.ndarray, time_s: np.ndarray, reference_s: float) -> np.ndarray:
    """Real free-response columns (B, n, 2m) at times ``time_s`` (s), tau = t - ``reference_s``.

    The columns of :func:`beam.physics.modal.free_basis` for poles ordered as
    :func:`beam.physics.modal.modal_decomposition` gives them (conjugate pairs adjacent, Im > 0
    first): exp(sigma tau) cos(omega tau), exp(sigma tau) sin(omega tau) per pair, exp(lambda tau)
    per real pole, at any reference time. A view of :func:`free_rows_at` (stored column by column).
    """
    return np.swapaxes(free_rows_at(poles, time_s, reference_s), 1, 2)


def free_rows_at(poles: np.ndarray, time_s: np.ndarray, reference_s: float, extra_rows: int = 0) -> np.ndarray:
    """The columns of :func:`free_basis_at` as rows, (B, 2m + ``extra_rows``, n), C-contiguous;
    the ``extra_rows`` last rows are ones (the offset's column).

    Compiled, three ways (the same numbers to ~1e-13):

    * increasing stamps on a grid of a decimal quantum q (what a logger writes,
      :func:`stamp_grid`): a chain along the stamps, exp(lambda tau_k) = exp(lambda tau_(k-1))
      R[d_k] with R = exp(lambda q d) for each distinct step d (two small power tables give
      them), four chains at once and an exact anchor every 128 samples
      (:func:`_chain_kernel`). A record's steps take a few hundred distinct values (355 in
      the strip's 2 s window, 690 in its 20 s), far fewer than the tables below hold
      (2 x 1,414 and 2 x 4,472 entries): the design of 32 sets on the 2 s window 0.59 ->
      0.36 ms, the 400 draws' prediction over the 20 s 34 -> 21 ms (CPU);
    * other stamps on such a grid: tau = tau_min + (N_hi S + N_lo) q, so exp(lambda tau) is
      the product of two table entries built by recurrence (S ~ sqrt(span / q) entries each):
      one complex product per pole pair and sample. Measured on the 20 s strip record (q = 1
      µs, 19,400 samples, 400 draws, 4 modes): 0.1 s against 1.5 s for the direct kernel and 4
      s for numpy's complex exp;
    * otherwise directly: one exp and one sin/cos pair per pole pair and sample.

    Rows, not columns: each basis function is written contiguously (the design of 28 sets on
    1,859 samples took 45 µs per set column-interleaved, 33 µs so).
    """
    tau = np.ascontiguousarray(np.asarray(time_s, dtype=float) - float(reference_s))
    return _rows(poles, tau, _layout(tau), extra_rows)


def _table_grid(tau: np.ndarray) -> tuple[float, np.ndarray, np.ndarray, int] | None:
    """The two-level table's layout for ``tau`` (s): quantum q (s), high and low index of each
    sample, table size; None off a :func:`stamp_grid`."""
    grid = stamp_grid(tau)
    if grid is None:
        return None
    return _table_layout(*grid)


def _table_layout(q: float, index: np.ndarray) -> tuple[float, np.ndarray, np.ndarray, int]:
    """:func:`_table_grid` of grid indices ``index`` of quantum ``q`` (s)."""
    size = int(np.ceil(np.sqrt(index.max() + 1.0)))
    return q, index // size, index % size, size


class ChainLayout(NamedTuple):
    """Layout of :func:`_chain_kernel` for stamps on a grid of quantum ``q`` (s), in increasing
    order: grid index of each sample, the index of each step (``index[k + 1] - index[k]``) among
    the distinct steps, and each distinct step split as ``step_high * lo_size + step_low``."""

    q: float
    index: np.ndarray
    step_id: np.ndarray
    step_high: np.ndarray
    step_low: np.ndarray
    lo_size: int
    hi_size: int


def _layout(tau: np.ndarray) -> ChainLayout | tuple[float, np.ndarray, np.ndarray, int] | None:
    """The compiled path's layout for ``tau`` (s): a :class:`ChainLayout` for non-decreasing
    stamps on a grid (at least two), the two-level table's (:func:`_table_grid`) for other
    stamps on a grid, None off a grid (the direct kernel)."""
    grid = stamp_grid(tau)
    if grid is None:
        return None
    q, index = grid
    steps = np.diff(index)
    if index.size < 2 or np.any(steps < 0):
        return _table_layout(q, index)
    distinct, step_id = np.unique(steps, return_inverse=True)
    lo_size = int(np.ceil(np.sqrt(distinct[-1] + 1.0)))
    return ChainLayout(q, index, step_id.reshape(-1).astype(np.int64), distinct // lo_size, distinct % lo_size,
                       lo_size, int(distinct[-1] // lo_size) + 1)


def _rows(poles: np.ndarray, tau: np.ndarray, grid: ChainLayout | tuple[float, np.ndarray, np.ndarray, int] | None,
          extra_rows: int) -> np.ndarray:
    """:func:`free_rows_at` at ``tau`` (s, from the reference) with its :func:`_table_grid`
    already found (a fit calls it for the same times at every parameter set: ~60 µs a call,
    2-4 ms of a preview and ~0.2 s of a posterior on the strip record)."""
    p = np.ascontiguousarray(poles, dtype=complex)
    out = np.empty((p.shape[0], p.shape[1] + int(extra_rows), tau.size))
    out[:, p.shape[1]:, :] = 1.0
    if grid is None:
        _basis_kernel(p.real.copy(), p.imag.copy(), tau, out)
    elif isinstance(grid, ChainLayout):
        _chain_kernel(p, np.zeros((p.shape[0], p.shape[1] + 1)), grid.index, grid.step_id, grid.step_high,
                      grid.step_low, grid.lo_size, grid.hi_size, float(tau.min()), grid.q, False, True, out,
                      np.empty((0, 0)))
    else:
        q, high, low, size = grid
        _table_kernel(p, np.zeros((p.shape[0], p.shape[1] + 1)), high, low, float(tau.min()), q, size,
                      False, True, out, np.empty((0, 0)))
    return out


def free_prediction_at(poles: np.ndarray, amplitudes: np.ndarray, time_s: np.ndarray, reference_s: float,
                       offset: bool) -> np.ndarray:
    """``free_basis_at(poles, time_s, reference_s) @ amplitudes`` (+ the offset, the last
    amplitude, when ``offset``) for each set, (B, n), without forming the basis (compiled, as
    :func:`free_basis_at`)."""
    tau = np.ascontiguousarray(np.asarray(time_s, dtype=float) - float(reference_s))
    p = np.ascontiguousarray(poles, dtype=complex)
    a = np.ascontiguousarray(amplitudes, dtype=float)
    out = np.empty((p.shape[0], tau.size))
    grid = _layout(tau)
    if grid is None:
        _prediction_kernel(p.real.copy(), p.imag.copy(), a, tau, bool(offset), out)
    elif isinstance(grid, ChainLayout):
        _chain_kernel(p, a, grid.index, grid.step_id, grid.step_high, grid.step_low, grid.lo_size, grid.hi_size,
                      float(tau.min()), grid.q, bool(offset), False, np.empty((0, 0, 0)), out)
    else:
        q, high, low, size = grid
        _table_kernel(p, a, high, low, float(tau.min()), q, size, bool(offset), False, np.empty((0, 0, 0)), out)
    return out


@numba.njit(cache=True, nogil=True)
def _fill_powers(table, pole, origin, step, scale):  # pragma: no cover - jitted
    """table[i] = scale exp(pole (origin + i step)) by four interleaved recurrences (independent
    products: four times the throughput of one chain), each entry at most
    ``_ANCHOR_EVERY / 4 - 1`` products from an exact anchor (re-anchored at the first four entries of
    every block of :data:`_ANCHOR_EVERY`)."""
    ratio = np.exp(pole * (4.0 * step))
    n = table.size
    for start in range(0, n, _ANCHOR_EVERY):
        stop = min(start + _ANCHOR_EVERY, n)
        for i in range(start, min(start + 4, stop)):
            table[i] = scale * np.exp(pole * (origin + step * i))
        for i in range(start + 4, stop):
            table[i] = table[i - 4] * ratio


@numba.njit(cache=True, nogil=True)
def _table_kernel(poles, amplitudes, high, low, tau_min, q, size, offset, basis, out_basis, out):  # pragma: no cover
    """exp(lambda tau_k) = H[high_k] L[low_k], H[i] = exp(lambda (tau_min + i S q)), L[i] = exp(lambda i q),
    both by recurrence (:func:`_fill_powers`); fills the basis (``basis``) or the prediction,
    for which H is filled multiplied by (c - i d): c Re z + d Im z = Re(z (c - i d)).

    A decaying term is left out (0 in the basis) from the first table row H[i] at which its
    envelope exp(sigma tau) is below :data:`_NEGLIGIBLE` of its value at max(tau_min, 0): of its
    value at the reference (where the amplitudes are fitted; samples before it, e.g. before the
    release of a record that starts at rest, keep every term), or of its largest when every
    sample follows the reference. On the strip record, modes 3-4 of the 20 s prediction die
    within the first 0.1-2 s and mode 4 of the 2 s window within 0.1 s, so their tables and
    lookups stop there.
    """
    batch, count = poles.shape
    n = high.size
    lo_table = np.empty(size, dtype=np.complex128)
    hi_table = np.empty(size, dtype=np.complex128)
    step = q * size
    for b in range(batch):
        if not basis:
            base = amplitudes[b, count] if offset else 0.0
            for k in range(n):
                out[b, k] = base
        j = 0
        while j < count:
            pole = poles[b, j]
            pair = _is_pair(pole.real, pole.imag) and j + 1 < count
            rows = size  # H rows in use: those of tau - tau_min < log(_NEGLIGIBLE) / sigma
            if pole.real < 0.0:
                reach = (max(tau_min, 0.0) - tau_min + _LOG_NEGLIGIBLE / pole.real) / step
                if reach < size:
                    rows = int(reach) + 1
            _fill_powers(lo_table, pole, 0.0, q, 1.0 + 0.0j)
            if basis:
                _fill_powers(hi_table[:rows], pole, tau_min, step, 1.0 + 0.0j)
                for k in range(n):
                    if high[k] < rows:
                        z = hi_table[high[k]] * lo_table[low[k]]
                    else:
                        z = 0.0j
                    out_basis[b, j, k] = z.real
                    if pair:
                        out_basis[b, j + 1, k] = z.imag
            else:
                weight = complex(amplitudes[b, j], -amplitudes[b, j + 1] if pair else 0.0)
                _fill_powers(hi_table[:rows], pole, tau_min, step, weight)
                for k in range(n):
                    if high[k] < rows:
                        h = hi_table[high[k]]
                        lo = lo_table[low[k]]
                        out[b, k] += h.real * lo.real - h.imag * lo.imag
            j += 2 if pair else 1


#: Samples between exact anchors of a chain in :func:`_chain_kernel`.
_CHAIN_ANCHOR_EVERY = 128


@numba.njit(cache=True, nogil=True)
def _chain_kernel(poles, amplitudes, index, step_id, step_high, step_low, lo_size, hi_size, tau_min, q, offset,
                  basis, out_basis, out):  # pragma: no cover - jitted
    """exp(lambda tau_k) along non-decreasing stamps as a chain, z_k = z_(k-1) R[step_id_(k-1)],
    R = exp(lambda q d) for each distinct step d of the stamps (H[d_high] L[d_low] from two
    small power tables, :func:`_fill_powers`), with an exact anchor every
    :data:`_CHAIN_ANCHOR_EVERY` samples; fills the basis or the prediction as
    :func:`_table_kernel` does (the amplitude folded into the anchors for a prediction), and
    leaves a decaying term out by the same rule (every sample whose grid index is beyond the
    reach of :data:`_NEGLIGIBLE`, here to the sample rather than to the table row).

    Four chains (one term of four consecutive sets) run in one loop, so that their complex
    products overlap (one chain waits on each of its products), their rows and cuts held in
    locals (written through a helper taking the arrays, the loop took 8x as long).
    """
    batch, count = poles.shape
    n = index.size
    rows = out_basis.shape[1]
    out_rows = out_basis.reshape(batch * rows, n) if basis else np.empty((1, 1))  # (set, row) flattened
    terms = np.zeros(batch, dtype=np.int64)
    term_j = np.empty((batch, count), dtype=np.int64)
    for b in range(batch):
        j = 0
        while j < count:
            pole = poles[b, j]
            pair = _is_pair(pole.real, pole.imag) and j + 1 < count
            term_j[b, terms[b]] = j
            terms[b] += 1
            j += 2 if pair else 1
        if not basis:
            base = amplitudes[b, count] if offset else 0.0
            for k in range(n):
                out[b, k] = base
    lo_table = np.empty(lo_size, dtype=np.complex128)
    hi_table = np.empty(hi_size, dtype=np.complex128)
    ratios = np.zeros((4, step_high.size), dtype=np.complex128)
    chain_b = np.zeros(4, dtype=np.int64)
    chain_j = np.zeros(4, dtype=np.int64)
    chain_pair = np.zeros(4, dtype=np.bool_)
    chain_cut = np.zeros(4, dtype=np.int64)
    chain_pole = np.zeros(4, dtype=np.complex128)
    chain_weight = np.zeros(4, dtype=np.complex128)
    origin = max(tau_min, 0.0) - tau_min  # where a term's envelope is measured (s from tau_min)
    last = index[n - 1]
    most = 0
    for b in range(batch):
        most = max(most, terms[b])
    for t in range(most):
        b = 0
        while b < batch:
            g = 0
            while g < 4 and b < batch:
                if t < terms[b]:
                    j = term_j[b, t]
                    pole = poles[b, j]
                    pair = _is_pair(pole.real, pole.imag) and j + 1 < count
                    chain_b[g], chain_j[g], chain_pair[g], chain_pole[g] = b, j, pair, pole
                    if basis:
                        chain_weight[g] = 1.0 + 0.0j
                    else:
                        chain_weight[g] = complex(amplitudes[b, j], -amplitudes[b, j + 1] if pair else 0.0)
                    cut = n
                    if pole.real < 0.0:
                        reach = (origin + _LOG_NEGLIGIBLE / pole.real) / q  # grid steps from tau_min
                        if reach < last:
                            cut = np.searchsorted(index, np.int64(math.floor(max(reach, -1.0))), side="right")
                    chain_cut[g] = cut
                    if cut > 1:
                        _fill_powers(lo_table, pole, 0.0, q, 1.0 + 0.0j)
                        _fill_powers(hi_table, pole, 0.0, q * lo_size, 1.0 + 0.0j)
                        for u in range(step_high.size):
                            ratios[g, u] = hi_table[step_high[u]] * lo_table[step_low[u]]
                    g += 1
                b += 1
            for h in range(g, 4):
                chain_cut[h] = 0
                chain_pole[h] = 0.0j
                chain_weight[h] = 0.0j
            stop = max(max(chain_cut[0], chain_cut[1]), max(chain_cut[2], chain_cut[3]))
            c0, c1, c2, c3 = chain_cut[0], chain_cut[1], chain_cut[2], chain_cut[3]
            r0, r1, r2, r3 = (chain_b[0] * rows + chain_j[0], chain_b[1] * rows + chain_j[1],
                              chain_b[2] * rows + chain_j[2], chain_b[3] * rows + chain_j[3])
            # the imaginary part's row; a real pole's is its own row, written first, then overwritten
            i0 = r0 + 1 if chain_pair[0] else r0
            i1 = r1 + 1 if chain_pair[1] else r1
            i2 = r2 + 1 if chain_pair[2] else r2
            i3 = r3 + 1 if chain_pair[3] else r3
            b0, b1, b2, b3 = chain_b[0], chain_b[1], chain_b[2], chain_b[3]
            z0 = z1 = z2 = z3 = 0.0j
            for k in range(stop):
                if k % _CHAIN_ANCHOR_EVERY == 0:
                    at = tau_min + q * index[k]
                    z0 = chain_weight[0] * np.exp(chain_pole[0] * at) if k < c0 else 0.0j
                    z1 = chain_weight[1] * np.exp(chain_pole[1] * at) if k < c1 else 0.0j
                    z2 = chain_weight[2] * np.exp(chain_pole[2] * at) if k < c2 else 0.0j
                    z3 = chain_weight[3] * np.exp(chain_pole[3] * at) if k < c3 else 0.0j
                else:
                    u = step_id[k - 1]
                    z0 *= ratios[0, u]
                    z1 *= ratios[1, u]
                    z2 *= ratios[2, u]
                    z3 *= ratios[3, u]
                if basis:
                    if k < c0:
                        out_rows[i0, k] = z0.imag
                        out_rows[r0, k] = z0.real
                    if k < c1:
                        out_rows[i1, k] = z1.imag
                        out_rows[r1, k] = z1.real
                    if k < c2:
                        out_rows[i2, k] = z2.imag
                        out_rows[r2, k] = z2.real
                    if k < c3:
                        out_rows[i3, k] = z3.imag
                        out_rows[r3, k] = z3.real
                else:
                    if k < c0:
                        out[b0, k] += z0.real
                    if k < c1:
                        out[b1, k] += z1.real
                    if k < c2:
                        out[b2, k] += z2.real
                    if k < c3:
                        out[b3, k] += z3.real
            if basis:  # a term left out is 0 after its cut
                for h in range(g):
                    for k in range(chain_cut[h], n):
                        out_basis[chain_b[h], chain_j[h], k] = 0.0
                        if chain_pair[h]:
                            out_basis[chain_b[h], chain_j[h] + 1, k] = 0.0


@numba.njit(cache=True, nogil=True)
def _is_pair(sigma, omega):  # pragma: no cover - jitted
    return omega > _REAL_POLE * max(np.hypot(sigma, omega), 1e-300)


@numba.njit(cache=True, nogil=True, fastmath={"reassoc", "contract"})
def _basis_kernel(sigma, omega, tau, out):  # pragma: no cover - jitted
    batch, count = sigma.shape
    for b in range(batch):
        j = 0
        while j < count:
            s, w = sigma[b, j], omega[b, j]
            if _is_pair(s, w) and j + 1 < count:
                for k in range(tau.size):
                    e = np.exp(s * tau[k])
                    out[b, j, k] = e * np.cos(w * tau[k])
                    out[b, j + 1, k] = e * np.sin(w * tau[k])
                j += 2
            else:
                for k in range(tau.size):
                    out[b, j, k] = np.exp(s * tau[k])
                j += 1


@numba.njit(cache=True, nogil=True, fastmath={"reassoc", "contract"})
def _prediction_kernel(sigma, omega, amplitudes, tau, offset, out):  # pragma: no cover - jitted
    batch, count = sigma.shape
    for b in range(batch):
        base = amplitudes[b, count] if offset else 0.0
        for k in range(tau.size):
            out[b, k] = base
        j = 0
        while j < count:
            s, w = sigma[b, j], omega[b, j]
            if _is_pair(s, w) and j + 1 < count:
                c, d = amplitudes[b, j], amplitudes[b, j + 1]
                for k in range(tau.size):
                    out[b, k] += np.exp(s * tau[k]) * (c * np.cos(w * tau[k]) + d * np.sin(w * tau[k]))
                j += 2
            else:
                c = amplitudes[b, j]
                for k in range(tau.size):
                    out[b, k] += c * np.exp(s * tau[k])
                j += 1


def retained_poles(omega_squared: np.ndarray, reduced_damping: np.ndarray) -> np.ndarray:
    """Poles (B, 2m) of the retained first-order system, ordered as :func:`beam.physics.modal.modal_decomposition`.

    With a diagonal reduced damping (modal damping, or any damping whose retained modes do not
    couple) each mode's pair is -c/2 ± sqrt(c²/4 - omega²) in closed form (as
    :func:`beam.physics.modal.complex_modes` uses) instead of a dense eigen-solve of the 2m x 2m
    system per parameter set (400 band draws of the strip's sensor-mass model: ~17 ms of
    ``numpy.linalg.eig`` saved); otherwise the dense solve.

    Parameters
    ----------
    omega_squared : (B, m) undamped omega² (rad²/s²).
    reduced_damping : (B, m, m) reduced damping (1/s).
    """
    omega2 = np.asarray(omega_squared, dtype=float)
    damping = np.asarray(reduced_damping, dtype=float)
    diagonal = np.einsum("bii->bi", damping)
    if np.count_nonzero(damping) != np.count_nonzero(diagonal):
        return modal.modal_decomposition(omega2, damping)[0]
    batch, m = omega2.shape
    half = 0.5 * diagonal
    root = np.sqrt((half * half - omega2).astype(complex))
    upper, lower = -half + root, -half - root
    # an underdamped pair: Im > 0 first (as LAPACK's dgeev); real poles: ordered by the sort below
    first = np.where(upper.imag >= lower.imag, upper, lower)
    second = np.where(upper.imag >= lower.imag, lower, upper)
    underdamped = root.imag > 0
    first = np.where(underdamped, first, upper.real + 0j)
    second = np.where(underdamped, np.conj(first), lower.real + 0j)
    poles = np.stack([first, second], axis=-1).reshape(batch, 2 * m)
    order = np.lexsort((-poles.imag, poles.real, np.round(np.abs(poles.imag), 9)), axis=-1)
    return np.take_along_axis(poles, order, axis=-1)


#: Gram matrices whose smallest eigenvalue may lie below this fraction of the largest take the
#: eigen-decomposition (their pseudo-inverse drops those directions); the others a Cholesky solve.
GRAM_FLOOR = 1e-13


def _gram_eigen(gram: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Eigenvalues g (B, k), eigenvectors V (B, k, k), coefficients Vᵀc / g (0 where dropped)
    and the mask of the kept eigenvalues (g > GRAM_FLOOR max g) of a stack of Gram matrices."""
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        g, vectors = np.linalg.eigh(gram)
        d = np.einsum("bij,bi->bj", vectors, c)
        floor = GRAM_FLOOR * np.max(np.abs(g), axis=1, keepdims=True) + 1e-300
        usable = g > floor
        coefficients = np.where(usable, d / np.where(usable, g, 1.0), 0.0)
    return g, vectors, coefficients, usable


def gram_solve(gram: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The least-squares amplitudes (B, k) G⁺ c of a stack of Gram matrices G (B, k, k), and
    the mask (B,) of the matrices proved positive definite with no direction dropped.

    Cholesky factors L of the whole stack (numpy, batched) and their inverses give
    a = L⁻ᵀ L⁻¹ c; since lambda_min(G) >= 1 / |L⁻¹|_F² and lambda_max(G) <= trace(G), a matrix
    with 1 / |L⁻¹|_F² > GRAM_FLOOR trace(G) has no direction the pseudo-inverse would drop, so
    this is G⁺ c. The others (a failed factorisation, or a bound that does not prove it)
    take the eigen-decomposition's pseudo-inverse (:func:`_gram_eigen`). Measured (CPU, one
    BLAS thread, 9 x 9): 59 µs for 32 matrices (the fit's chunk) against 184 µs for
    ``numpy.linalg.eigh``; in the strip's preview the eigen-decompositions were ~20 ms of
    ~0.23 s CPU under load.
    """
    batch = gram.shape[0]
    amplitudes = np.empty_like(c)
    todo = np.ones(batch, dtype=bool)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        try:
            inverse = np.linalg.inv(np.linalg.cholesky(gram))
        except np.linalg.LinAlgError:
            inverse = None
        if inverse is not None:
            bound = 1.0 / np.einsum("bij,bij->b", inverse, inverse)
            trace = np.einsum("bii->b", gram)
            todo = ~(np.isfinite(bound) & (bound > GRAM_FLOOR * trace))
            w = np.einsum("bij,bj->bi", inverse, c)
            amplitudes = np.einsum("bji,bj->bi", inverse, w)
    if np.any(todo):
        _, vectors, coefficients, _ = _gram_eigen(gram[todo], c[todo])
        amplitudes[todo] = np.einsum("bij,bj->bi", vectors, coefficients)
    return amplitudes, ~todo


class ProjectedFreeModel:
    """Forward model of a free response with its linear coefficients profiled out.

    Parameters
    ----------
    model : BeamModel
        A model without input (``input_kind=None``).
    modes : int
        Retained modes m.
    output_kind : {"displacement", "velocity", "acceleration"}
        What the sensor measures (an offset column for velocity and acceleration).
    fit_time_s, fit_data : (n,) arrays
        The calibration samples (s, output's unit) the coefficients are fitted to; the first
        time is the reference t_ref of the columns.
    likelihood : {"iid", "ar1"}
        Noise model (ordinary or generalised least squares).

    Notes
    -----
    ``model(values, time_s)`` (the :class:`beam.inference.Problem` contract) returns
    X(theta, time_s) a_hat(theta) for every parameter set; the fit of the last parameter sets is
    cached, so the correction and predictions at other times reuse it.
    """

    def __init__(self, model: BeamModel, modes: int, output_kind: str, fit_time_s: np.ndarray, fit_data: np.ndarray,
                 likelihood: str = "iid") -> None:
        if model.input_kind is not None:
            raise BeamInputError("ProjectedFreeModel needs a model without input (a free response)")
        self.model = model
        self.modes = int(modes)
        self.output_kind = output_kind
        self.offset = has_offset(output_kind)
        self.fit_time_s = np.ascontiguousarray(fit_time_s, dtype=float)
        self.fit_data = np.ascontiguousarray(fit_data, dtype=float)
        if self.fit_time_s.size != self.fit_data.size or self.fit_time_s.size < 2:
            raise BeamInputError("a free-response fit needs at least two samples with one time each")
        self.likelihood = likelihood
        self.reference_s = float(self.fit_time_s[0])
        self._fit_tau = np.ascontiguousarray(self.fit_time_s - self.reference_s)
        self._fit_grid = _layout(self._fit_tau)
        self.names = model.parameter_names_for(self.modes)
        self.columns = 2 * self.modes + (1 if self.offset else 0)
        peak = float(np.max(np.abs(self.fit_data)))
        self.prior_sd = AMPLITUDE_PRIOR_SCALE * (peak if peak > 0 else 1.0)
        self._cache: tuple | None = None

    # ------------------------------------------------------------------ columns
    def poles(self, values: Mapping[str, np.ndarray]) -> np.ndarray:
        """Retained poles (B, 2m) (1/s) of each parameter set."""
        parameters = {name: np.atleast_1d(np.asarray(values[name], dtype=float)) for name in self.names}
        reduced, _, _ = self.model.reduced_system(parameters, self.modes)
        return retained_poles(reduced["omega2"], reduced["damping"])

    def design(self, poles: np.ndarray, time_s: np.ndarray) -> np.ndarray:
        """The columns (B, n, k) at ``time_s``: the free-response basis, then the offset's ones."""
        return np.swapaxes(free_rows_at(poles, time_s, self.reference_s, 1 if self.offset else 0), 1, 2)

    def _whiten(self, rows: np.ndarray, rho: np.ndarray | None) -> np.ndarray:
        """Rows (B, n) whitened to unit noise for the AR(1) likelihood (unchanged for i.i.d.)."""
        if rho is None:
            return rows
        return whiten("ar1", rows, {NOISE_SD: np.ones(rows.shape[0]), AR1_COEFFICIENT: rho})

    # ------------------------------------------------------------------ fit
    def _key(self, values: Mapping[str, np.ndarray]) -> tuple[bytes, np.ndarray | None]:
        arrays = [np.atleast_1d(np.asarray(values[name], dtype=float)) for name in self.names]
        rho = None
        if self.likelihood == "ar1":
            rho = np.atleast_1d(np.asarray(values[AR1_COEFFICIENT], dtype=float))
            arrays.append(rho)
        arrays = np.broadcast_arrays(*arrays)
        return np.stack(arrays).tobytes(), (None if rho is None else np.broadcast_to(rho, arrays[0].shape))

    def fit(self, values: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """The least-squares coefficients at each parameter set (cached for the last call).

        Returns
        -------
        dict with ``poles`` (B, 2m), ``amplitudes`` (B, k) (the last one the offset, output's unit),
        ``fitted`` (B, n) (X a_hat on the calibration times), ``gram`` (B, k, k) X̃ᵀX̃ and ``c``
        (B, k) X̃ᵀỹ, ``certified`` (B,) (see :func:`gram_solve`). The eigen-decomposition of the Gram matrices (``g``, ``d2g``, ``vectors``:
        see :meth:`spectral`) is added when the correction or the linear fit asks for it.
        """
        key, rho = self._key(values)
        if self._cache is not None and self._cache[0] == key:
            return self._cache[1]
        distinct, inverse = self._distinct_sets(values, rho)
        if distinct is not None:  # repeated sets (only the noise differs): each distinct one fitted once
            unique = self.fit(distinct)
            result = {name: array[inverse] for name, array in unique.items()}
            self._cache = (key, result)
            return result
        poles = self.poles(values)
        parts = [self._fit_rows(poles[i : i + FIT_CHUNK], None if rho is None else rho[i : i + FIT_CHUNK])
                 for i in range(0, poles.shape[0], FIT_CHUNK)]
        amplitudes, fitted, gram, c, certified = (np.concatenate(p) for p in zip(*parts))
        result = {"poles": poles, "amplitudes": amplitudes, "fitted": fitted, "gram": gram, "c": c,
                  "certified": certified}
        self._cache = (key, result)
        return result

    def _distinct_sets(self, values: Mapping[str, np.ndarray],
                       rho: np.ndarray | None) -> tuple[dict[str, np.ndarray] | None, np.ndarray | None]:
        """The distinct parameter sets of ``values`` (the model's names, and the AR(1)
        coefficient for that likelihood) and the index of each set among them; (None, None)
        when every set is distinct.

        The fit depends on these alone, not on the noise sd: the Newton polish's
        finite-difference stencil (:func:`beam.inference.optimize.fd_derivatives`) moves the
        noise sd alone in 2 + 4 (d - 1) of its 1 + 2 d² points (26 of 99 for the strip's
        sensor-mass model, d = 7), each the fit of a set already in the call.
        """
        arrays = np.broadcast_arrays(*[np.atleast_1d(np.asarray(values[name], dtype=float)) for name in self.names],
                                     *(() if rho is None else (rho,)))
        table = np.stack(arrays, axis=-1).reshape(-1, len(arrays))
        if table.shape[0] < 2 or not np.all(np.isfinite(table)):
            return None, None
        _, first, inverse = np.unique(table, axis=0, return_index=True, return_inverse=True)
        if first.size == table.shape[0]:
            return None, None
        distinct = {name: table[first, i] for i, name in enumerate(self.names)}
        if rho is not None:
            distinct[AR1_COEFFICIENT] = table[first, -1]
        return distinct, inverse.reshape(-1)

    @staticmethod
    def spectral(fit: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``g`` (B, k) eigenvalues of X̃ᵀX̃ (those below 1e-13 of the largest set to 0),
        ``d2g`` (B, k): d_i² / g_i with d = Vᵀ X̃ᵀỹ (see the module notes), and the eigenvectors
        V (B, k, k) of a :meth:`fit` (computed once, then kept in it)."""
        if "g" not in fit:
            g, vectors, coefficients, usable = _gram_eigen(fit["gram"], fit["c"])
            with np.errstate(invalid="ignore", over="ignore"):
                fit["d2g"] = np.where(usable, coefficients * coefficients * np.where(usable, g, 0.0), 0.0)
            fit["g"], fit["vectors"] = np.where(usable, g, 0.0), vectors
        return fit["g"], fit["d2g"], fit["vectors"]

    def _fit_rows(self, poles: np.ndarray, rho: np.ndarray | None) -> tuple[np.ndarray, ...]:
        """Amplitudes, fitted values, Gram matrices and X̃ᵀỹ (see :meth:`fit`) of poles (b, 2m)."""
        rows = _rows(poles, self._fit_tau, self._fit_grid, 1 if self.offset else 0)  # (b, k, n), free_rows_at
        batch, k, n = rows.shape
        y = np.broadcast_to(self.fit_data, (batch, n))
        if rho is not None:
            rows_w = self._whiten(rows.reshape(batch * k, n), np.repeat(rho, k)).reshape(batch, k, n)
            yw = self._whiten(np.array(y), rho)
        else:
            rows_w, yw = rows, y
        gram = np.matmul(rows_w, np.swapaxes(rows_w, 1, 2))
        c = np.matmul(rows_w, yw[:, :, None])[:, :, 0]
        amplitudes, certified = gram_solve(gram, c)
        fitted = np.matmul(amplitudes[:, None, :], rows)[:, 0, :]
        return amplitudes, fitted, gram, c, certified

    def __call__(self, values: Mapping[str, np.ndarray], time_s: np.ndarray) -> np.ndarray:
        fit = self.fit(values)
        times = np.asarray(time_s, dtype=float)
        if times is self.fit_time_s or (times.shape == self.fit_time_s.shape and np.array_equal(times, self.fit_time_s)):
            return fit["fitted"]
        return free_prediction_at(fit["poles"], fit["amplitudes"], times, self.reference_s, self.offset)

    def log_likelihood_correction(self, values: Mapping[str, np.ndarray]) -> np.ndarray:
        """log ∫ p(y | theta, a) N(a; 0, A² I) da - log p(y | theta, a_hat) for each set (B,), nats.

        With G = X̃ᵀX̃ and lam = (sd / A)²: -½ log det(I + G / lam) - ½ lam â ᵀ(G + lam I)⁻¹ X̃ᵀỹ / sd²
        (the eigen-form of the module notes, since G⁻¹ - (G + lam I)⁻¹ = lam G⁻¹ (G + lam I)⁻¹):
        one batched Cholesky of G + lam I where :func:`gram_solve` proved G definite with no
        direction dropped (59 µs for 32 sets of 9 columns, CPU, against 184 µs for the
        eigen-decomposition), the eigen-decomposition's sums over the kept directions otherwise.
        """
        fit = self.fit(values)
        sd = np.atleast_1d(np.asarray(values[NOISE_SD], dtype=float))[:, None]
        lam = (sd / self.prior_sd) ** 2
        batch = fit["amplitudes"].shape[0]
        lam = np.broadcast_to(lam, (batch, 1))
        sd2 = np.broadcast_to(sd[:, 0] ** 2, (batch,))
        log_det, shrink = np.empty(batch), np.empty(batch)
        certified = fit["certified"] & np.isfinite(lam[:, 0]) & (lam[:, 0] > 0.0)
        if np.any(certified):  # Cholesky of G + lam I (see the docstring)
            gram, c, a, lam_c = fit["gram"][certified], fit["c"][certified], fit["amplitudes"][certified], lam[certified]
            k = gram.shape[-1]
            try:
                with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
                    factor = np.linalg.cholesky(gram + lam_c[:, :, None] * np.eye(k))
                    inverse = np.linalg.inv(factor)
                    log_det[certified] = (2.0 * np.sum(np.log(np.einsum("bii->bi", factor)), axis=1)
                                          - k * np.log(lam_c[:, 0]))
                    shrink[certified] = lam_c[:, 0] * np.einsum("bi,bi->b", np.einsum("bij,bj->bi", inverse, a),
                                                                np.einsum("bij,bj->bi", inverse, c)) / sd2[certified]
            except np.linalg.LinAlgError:  # not reached for a definite G and lam > 0: the eigen sums decide
                certified = np.zeros_like(certified)
        rest = ~certified
        if np.any(rest):
            fit_rest = {"gram": fit["gram"][rest], "c": fit["c"][rest]}
            g, d2g, _ = self.spectral(fit_rest)
            with np.errstate(invalid="ignore", divide="ignore"):
                log_det[rest] = np.sum(np.log1p(g / lam[rest]), axis=1)
                shrink[rest] = np.sum(d2g * lam[rest] / (g + lam[rest]), axis=1) / sd2[rest]
        return -0.5 * log_det - 0.5 * shrink

    def linear_fit(self, values: Mapping[str, float]) -> dict[str, object]:
        """The linear coefficients at one parameter set: amplitudes (2m,), the offset (output's
        unit, 0 for a displacement record) and its conditional posterior sd given theta and the
        noise sd in ``values`` (0 when ``values`` has no noise sd)."""
        one = {name: np.atleast_1d(float(np.asarray(values[name]).ravel()[0])) for name in self.names}
        if self.likelihood == "ar1":
            one[AR1_COEFFICIENT] = np.atleast_1d(float(np.asarray(values[AR1_COEFFICIENT]).ravel()[0]))
        fit = self.fit(one)
        amplitudes = fit["amplitudes"][0]
        out: dict[str, object] = {"amplitudes": amplitudes[: 2 * self.modes].tolist(), OFFSET_NAME: 0.0,
                                  f"{OFFSET_NAME}_sd": 0.0}
        if self.offset:
            out[OFFSET_NAME] = float(amplitudes[-1])
            if NOISE_SD in values:
                sd = float(np.asarray(values[NOISE_SD]).ravel()[0])
                g, _, vectors = self.spectral(fit)
                g, vectors = g[0], vectors[0]
                lam = (sd / self.prior_sd) ** 2
                variance = sd * sd * np.sum(vectors[-1, :] ** 2 / (g + lam))
                out[f"{OFFSET_NAME}_sd"] = float(math.sqrt(variance))
        return out


#: Samples at the start of a record that tell whether the beam is still at rest.
REST_LEAD_SAMPLES = 20
#: A record starts at rest when its first REST_LEAD_SAMPLES vary by less than this fraction of
#: its largest excursion from the median; the release is then the first sample that moves by more
#: than REST_DEPARTURE of that excursion, moved back to where the motion left the lead-in's noise.
REST_FRACTION = 0.05
REST_DEPARTURE = 0.05
#: Departure from the resting level, in noise sd of the lead-in, that counts as motion.
REST_NOISE_SIGMAS = 8.0


def release_index(output: np.ndarray) -> int:
    """Index of the first sample of the free response in a record without input.

    A free response starts moving at the first sample. A record that begins with the beam held
    at rest (a quiet lead-in before the hand lets go, as two of the five strip records do,
    ~0.3 s) is not a free response until the release: its first sample is found as described
    at :data:`REST_FRACTION` (0 when the record moves from its first sample).
    """
    y = np.asarray(output, dtype=float)
    if y.size < 4 * REST_LEAD_SAMPLES:
        return 0
    excursion = float(np.max(np.abs(y - np.median(y))))
    lead = y[:REST_LEAD_SAMPLES]
    if excursion <= 0 or np.ptp(lead) >= REST_FRACTION * excursion:
        return 0
    level = float(np.median(lead))
    noise = max(float(np.std(np.diff(lead))) / np.sqrt(2.0), 1e-12 * excursion)
    moving = np.flatnonzero(np.abs(y - level) > REST_DEPARTURE * excursion)
    if moving.size == 0:
        return 0
    first = int(moving[0])
    quiet = np.flatnonzero(np.abs(y[:first] - level) <= REST_NOISE_SIGMAS * noise)
    return int(quiet[-1]) + 1 if quiet.size else first


#: The free response of the retained modes is taken to start where the record's content above
#: their band (see :func:`free_response_start`) has fallen to this fraction of the content in
#: the band (RMS over a sliding window) and stays below it for one period of the lowest mode.
TRANSIENT_FRACTION = 0.05
#: The out-of-band RMS is taken over this many periods of the band edge.
TRANSIENT_EDGE_PERIODS = 4.0
#: The band edge must lie below this fraction of the record's Nyquist frequency (median step)
#: for the out-of-band content to be measurable; otherwise the release is the start.
TRANSIENT_NYQUIST_FRACTION = 0.8
#: Only the first this many periods of the lowest mode after the release are searched for the
#: end of the release's transient: a later excursion is not the release's.
TRANSIENT_SEARCH_PERIODS = 20.0


def free_response_start(time_s: np.ndarray, output: np.ndarray, band_edge_Hz: float | None,
                        lowest_period_s: float) -> tuple[int, int]:
    """Indices of the release and of the first sample of the free response of the retained modes.

    A hand that lets the beam go (or a tap that sets it moving) is in contact for a while:
    while it is, and while the modes it rang above the retained ones (a release snap rings the
    whole beam) have not died out, the record is not the free response of the retained modes.
    The record is interpolated (linearly) to a uniform grid at its median step from its first
    sample; its content above ``band_edge_Hz`` (zero-phase Butterworth high-pass of order 6)
    and the rest (offset removed) are compared through their sliding RMS, the first over
    :data:`TRANSIENT_EDGE_PERIODS` periods of the band edge, the second over one
    ``lowest_period_s``. The free response starts at the first stamp from the release on
    (:func:`release_index`) after which the ratio stays below :data:`TRANSIENT_FRACTION` for
    one ``lowest_period_s`` (searched over :data:`TRANSIENT_SEARCH_PERIODS` periods; the
    release itself when no such stretch is found, when the ratio is below it from the release
    on, or when the band edge is not below :data:`TRANSIENT_NYQUIST_FRACTION` of the record's
    Nyquist frequency).

    Parameters
    ----------
    time_s : numpy.ndarray
        Strictly increasing time stamps (s).
    output : numpy.ndarray
        The record's output (any unit).
    band_edge_Hz : float or None
        Upper edge of the retained modes' band (Hz), between the highest retained mode and the
        next; None: no edge (the start is the release).
    lowest_period_s : float
        Period of the lowest retained mode (s).

    Returns
    -------
    release : int
        Index of the release (:func:`release_index`).
    start : int
        Index of the first sample of the free response (>= ``release``).
    """
    from scipy import signal
    from scipy.ndimage import uniform_filter1d

    t = np.asarray(time_s, dtype=float)
    y = np.asarray(output, dtype=float)
    release = release_index(y)
    if band_edge_Hz is None or t.size < 8 or not np.isfinite(band_edge_Hz) or lowest_period_s <= 0:
        return release, release
    step_s = float(np.median(np.diff(t)))
    if not band_edge_Hz < TRANSIENT_NYQUIST_FRACTION * 0.5 / step_s:
        return release, release
    period = int(math.ceil(lowest_period_s / step_s))
    search_end_s = t[release] + (TRANSIENT_SEARCH_PERIODS + 2.0) * lowest_period_s
    count = int((min(t[-1], search_end_s) - t[0]) / step_s) + 1
    if count < 4 * period:
        return release, release
    grid = t[0] + step_s * np.arange(count)
    values = np.interp(grid, t, y)
    sos = signal.butter(6, band_edge_Hz, "highpass", fs=1.0 / step_s, output="sos")
    high = signal.sosfiltfilt(sos, values)
    low = values - high
    low -= np.median(low[grid >= t[release]])
    edge = max(3, int(math.ceil(TRANSIENT_EDGE_PERIODS / (band_edge_Hz * step_s))))
    # a running mean of squares can round a hair below zero where the signal is ~0: clip before the root
    high_rms = np.sqrt(np.maximum(uniform_filter1d(high * high, edge, mode="nearest"), 0.0))
    low_rms = np.sqrt(np.maximum(uniform_filter1d(low * low, period, mode="nearest"), 0.0))
    above = high_rms > TRANSIENT_FRACTION * low_rms
    first = int(np.searchsorted(grid, t[release]))
    last = min(count - period, first + int(TRANSIENT_SEARCH_PERIODS * period))
    if not above[first]:
        return release, release
    # runs of "below" long enough: the first grid index k >= first with above[k:k + period] all False
    exceed = np.flatnonzero(above[first : last + period])
    gaps = np.diff(exceed)
    long = np.flatnonzero(gaps > period)
    if long.size:
        end = first + int(exceed[long[0]]) + 1
    elif exceed[-1] + first < last:
        end = first + int(exceed[-1]) + 1
    else:
        return release, release
    start = int(np.searchsorted(t, grid[end]))
    return release, max(release, min(start, t.size - 1))


@functools.lru_cache(maxsize=64)
def _bare_frequencies(geometry, stiffness_Nm2: float, count: int, input_kind: str) -> tuple[float, ...]:
    """The first ``count`` natural frequencies (Hz) of the bare beam (no effect) at the bending stiffness ``stiffness_Nm2``."""
    model = BeamModel(geometry, (), input_kind=input_kind)
    count = min(count, model.size)
    frequencies, _ = model.natural_modes({BENDING_STIFFNESS.name: stiffness_Nm2}, count)
    return tuple(float(f) for f in frequencies)


def retained_band(measurement, modes: int) -> tuple[float | None, float]:
    """(upper edge of the band of ``modes`` retained modes (Hz), period of the lowest (s)) of a record's beam.

    From the bare beam of the record's geometry at its nominal bending stiffness (the centre of
    the default prior range without one) — the same for every effect a record is calibrated
    with, so that every model of a record is compared on the same samples. The edge is the
    geometric mean of the frequencies of the highest retained mode and the next (None when the
    mesh has no next mode).
    """
    name = BENDING_STIFFNESS.name
    spec = BENDING_STIFFNESS
    stiffness = float(measurement.nominal.get(name, math.sqrt(spec.prior_low * spec.prior_high)))
    frequencies = _bare_frequencies(measurement.geometry, stiffness, int(modes) + 1, measurement.input_kind)
    edge = math.sqrt(frequencies[modes - 1] * frequencies[modes]) if len(frequencies) > modes else None
    return edge, 1.0 / frequencies[0]


class StartMemo:
    """The free-response starts found last (:func:`free_start_indices`), for the last ``size``
    records: copies of the stamps and output, the band edge and period, and the result (an
    :class:`~beam.calibration.engine.Engine` holds one; thread-safe)."""

    def __init__(self, size: int = 4) -> None:
        self.size = int(size)
        self._entries: list[tuple[np.ndarray, np.ndarray, float | None, float, tuple[int, int]]] = []
        self._lock = threading.Lock()

    def find(self, t: np.ndarray, y: np.ndarray, edge: float | None, period_s: float) -> tuple[int, int] | None:
        with self._lock:
            for time_s, output, memo_edge, memo_period, found in self._entries:
                if (memo_edge == edge and memo_period == period_s and time_s.shape == t.shape
                        and np.array_equal(time_s, t) and np.array_equal(output, y)):
                    return found
        return None

    def keep(self, t: np.ndarray, y: np.ndarray, edge: float | None, period_s: float, found: tuple[int, int]) -> None:
        with self._lock:
            self._entries.insert(0, (t.copy(), y.copy(), edge, period_s, found))
            del self._entries[self.size:]

    def clear(self) -> None:
        with self._lock:
            self._entries.clear()


def free_start_indices(measurement, modes: int, memo: StartMemo | None = None) -> tuple[int, int]:
    """(release, first sample of the free response) of a free record fitted with ``modes`` modes
    (:func:`free_response_start` with the band of :func:`retained_band`).

    With a ``memo`` (the engine's, :meth:`beam.calibration.engine.Engine.free_start_indices`)
    remembered for its last records (stamps and output compared in full, ~30 µs): a preview asked
    twice (its setup and the window's check, ~2 ms each on the strip's 20 s record), and every
    model of a record in a diagnosis, the same question.
    """
    edge, period_s = retained_band(measurement, modes)
    t = np.asarray(measurement.time_s, dtype=float)
    y = np.asarray(measurement.output, dtype=float)
    found = None if memo is None else memo.find(t, y, edge, period_s)
    if found is None:
        found = free_response_start(t, y, edge, period_s)
        if memo is not None:
            memo.keep(t, y, edge, period_s, found)
    return found
