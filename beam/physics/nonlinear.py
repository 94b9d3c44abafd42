"""The hardening tip spring -k3 w(L, t)³, integrated in the retained complex modal coordinates.

In the diagonalised modal coordinates xi (see :func:`beam.physics.modal.complex_modes`)

    xi' = Lambda xi + beta_u V(t) + beta_tip s(xi),   s = -k3 w_tip³,   w_tip = Re(gamma_tip · xi),

the linear part is diagonal. We step it with the fourth-order exponential time-differencing
Runge–Kutta scheme ETDRK4 (Cox & Matthews 2002), whose linear part is exact: with k3 = 0 it
reproduces the exact ZOH response, and it stays stable at the sampling rate however stiff the
retained modes are. The phi-functions are evaluated by their Taylor series near zero (no
cancellation). Each sample interval is split into substeps so that the nonlinear forcing is
resolved: the linear part being exact, only the spring's force -k3 w_tip³ along the motion
needs resolving, so max(Omega, omega_nonlinear) h <= 0.4, where Omega is the force's
amplitude-weighted frequency (from each mode's peak linear tip amplitude and its frequency
hardened by the spring; :func:`choose_substeps`) and omega_nonlinear the frequency of the tip
spring's tangent stiffness at the amplitude of the linear response. A weak spring needs less:
the scheme's error lies in the nonlinear forcing alone and scales as eps (omega h)^4, with eps
the spring's tangent stiffness relative to the first mode's, so the step is coarsened by
eps^(-1/4), to at most 1.5 rad per substep. Accuracy (``tests/test_nonlinear.py``, against
solve_ivp, DOP853, rtol 1e-12, on the retained modes): peak-relative error 2e-8 on a 40 V pulse
and 3e-5 on a strongly hardening chirp, 35x and more below the noise of the bundled records
(7e-4 of the peak); 0.4 rad is the coarsest step that keeps that margin, and a finer one costs
CPU in every spring fit for no visible gain (see the design decisions).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numba
import numpy as np

from beam.physics import modal
from beam.physics.effects.channel import LAW_IWAN_JOINT, LAW_POINT_CUBIC, ChannelArrays
from beam.physics.effects.quadratic_drag import (  # noqa: F401 - the drag's constants, where its integrator was
    AIR_DENSITY_KG_M3,
    DRAG_PANELS,
    DRAG_POINTS,
    drag_quadrature,
)
from beam.physics.modal import ComplexModes, collapse_pairs as _collapse, zoh_factor

#: Largest (modal frequency x substep) the integrator allows.
STEP_RESOLUTION = 0.4
#: How much coarser than STEP_RESOLUTION a weak spring may be stepped (to 1.5 rad per substep).
MAX_COARSENING = 3.75
MAX_SUBSTEPS = 4000


def integrate_tip_cubic(
    system: ComplexModes, cubic_N_m3: np.ndarray, voltage: np.ndarray, sample_interval_s: float,
    substeps: int | np.ndarray | None = None,
    static_gains: np.ndarray | None = None,
) -> np.ndarray:
    """Sensor displacement (B, n) (m) with the cubic tip spring, from rest under a ZOH voltage.

    Parameters
    ----------
    system : ComplexModes
        From ``BeamModel.modal_system``: inputs (voltage, unit tip force), outputs (sensor, tip).
    cubic_N_m3 : (B,) array
        Cubic stiffness k3 (N/m³), >= 0.
    voltage : (n,) array
        Voltage V[k] (V) held over [t_k, t_k+1).
    sample_interval_s : float
        dt (s).
    substeps : int or (B,) array, optional
        Substeps per sample; chosen automatically (see the module notes) when omitted.
    static_gains : (B, 2) or (B, 4) array, optional
        Quasi-static displacement of the discarded modes at the sensor and the tip per volt (m/V),
        added to the output and to the tip displacement the spring acts on (static correction of
        the voltage input); the optional last two columns, per newton of tip force (m/N), do the
        same for the spring's own force (see :func:`_corrected_tip`).
    """
    voltage = np.ascontiguousarray(voltage, dtype=float)
    batch = system.poles.shape[0]
    cubic = np.broadcast_to(np.asarray(cubic_N_m3, dtype=float), (batch,))
    if substeps is None:
        substeps = choose_substeps(system, cubic, voltage, sample_interval_s)
    substeps = np.broadcast_to(np.asarray(substeps, dtype=np.int64), (batch,)).copy()
    static = np.zeros((batch, 4))
    if static_gains is not None:
        gains_given = np.asarray(static_gains, dtype=float)
        static[:, : gains_given.shape[-1]] = np.broadcast_to(gains_given, (batch, gains_given.shape[-1]))
    poles, gains = _one_per_pair(system)
    return _etdrk4_grouped(poles, gains[0], gains[1], gains[2], gains[3],
                           np.ascontiguousarray(cubic), voltage, float(sample_interval_s), substeps, static)


def _one_per_pair(system: ComplexModes) -> tuple[np.ndarray, np.ndarray]:
    """Poles (B, P) and gains (4, B, P) with one pole per conjugate pair.

    The voltage and the spring's force are real, so a conjugate pole's coordinate is the
    conjugate of its partner's and adds the conjugate to every output: each pair is stepped once,
    its output gains doubled (halves the stepping; measured 2x on ``lab_run_4``). Rows with fewer
    kept poles (real poles of an overdamped mode) are padded with zero gains, which stay at rest.
    Gains: voltage input, tip-force input, sensor output, tip output.
    """
    poles = system.poles
    following = np.concatenate([poles[:, 1:], np.zeros((poles.shape[0], 1), complex)], axis=1)
    paired = (poles.imag > 0) & (np.abs(following - np.conj(poles)) <= 1e-12 * np.abs(poles))
    dropped = np.concatenate([np.zeros((poles.shape[0], 1), bool), paired[:, :-1]], axis=1)
    order = np.argsort(dropped, axis=1, kind="stable")  # kept poles first, in their order
    kept = (~np.take_along_axis(dropped, order, axis=1))
    width = int(kept.sum(axis=1).max())
    order, kept = order[:, :width], kept[:, :width]
    factor = np.where(np.take_along_axis(paired, order, axis=1), 2.0, 1.0) * kept
    gains = np.stack([
        np.take_along_axis(system.input_gains[:, 0], order, axis=1) * kept,
        np.take_along_axis(system.input_gains[:, 1], order, axis=1) * kept,
        np.take_along_axis(system.output_gains[:, 0], order, axis=1) * factor,
        np.take_along_axis(system.output_gains[:, 1], order, axis=1) * factor,
    ])
    kept_poles = np.where(kept, np.take_along_axis(poles, order, axis=1), -1.0 + 0j)
    return np.ascontiguousarray(kept_poles), np.ascontiguousarray(gains)


def choose_substeps(system: ComplexModes, cubic: np.ndarray, voltage: np.ndarray, sample_interval_s: float) -> np.ndarray:
    """Substeps per sample for each parameter set (see the module notes).

    The linear part is exact whatever the step, so the step only has to resolve the spring's force
    -k3 w_tip³ along the motion. Its content is estimated from the linear response: each mode's
    (each conjugate pair's) peak tip amplitude c_j and its frequency, hardened by the spring's
    stiffness at that amplitude (harmonic balance), w_j = sqrt(|lambda_j|² + 3/4 k3 A² tip_j²)
    (A the peak linear tip displacement, tip_j the mass-normalised shape's tip value). The force's fourth time derivative, relative to its size, is at most

        Omega^4 = sum_ijk c_i c_j c_k (w_i + w_j + w_k)^4 / (sum_j c_j)^3,

    so Omega is the force's amplitude-weighted frequency (3 w_1 when mode 1 dominates the tip,
    higher when the tip moves in the upper modes too). The step satisfies
    max(Omega, sqrt(3 k3 A² sum tip_j²)) h <= STEP_RESOLUTION, coarsened for a weak spring as in
    the module notes. Sizing by the highest retained mode instead (3 |lambda_max| h <= 0.15) took
    27 substeps per sample on ``lab_run_4`` where this rule takes 3 (peak-relative error against
    the solve_ivp reference of ``tests/test_nonlinear.py`` 2e-11 and 2e-8: both far below the
    record's noise, 7e-4 of the peak).
    """
    modulus = np.abs(system.poles)
    upper, weights = _collapse(np.ascontiguousarray(system.poles),
                               np.ascontiguousarray(system.output_gains[:, 1] * system.input_gains[:, 0]))
    batch, n_slots = upper.shape
    voltage = np.ascontiguousarray(voltage, dtype=float)
    # each pair's own linear tip response (its peak), and the total's peak; unused slots weigh 0
    peaks, amplitude = _pair_peaks(upper, weights, float(sample_interval_s), voltage)
    # squared tip entry of each mass-normalised shape, from the tip-to-tip residue r of its pole:
    # r = tip² / (2 i omega_d), whatever the eigenvector scaling
    tip_residues = system.output_gains[:, 1] * system.input_gains[:, 1]
    upper_half = system.poles.imag > 0
    tip_squared_poles = np.where(upper_half, 2.0 * system.poles.imag * np.abs(tip_residues), 0.0)
    tip_squared = tip_squared_poles.sum(axis=1)
    added = 3.0 * cubic * amplitude**2 * tip_squared  # tangent stiffness of the spring, rad²/s²
    # each mode's frequency hardened at the peak amplitude (harmonic balance: 3/4 k3 A²), rad/s
    _, tip_squared_slots = _collapse(np.ascontiguousarray(system.poles), tip_squared_poles.astype(np.complex128))
    frequency = np.sqrt(np.abs(upper) ** 2 + 0.75 * cubic[:, None] * amplitude[:, None] ** 2 * np.abs(tip_squared_slots) / 2.0)
    total = np.maximum(peaks.sum(axis=1), 1e-300)
    forcing = (_triple_quartic_sum(peaks, frequency) / total**3) ** 0.25
    # with no motion at the tip (no input) the spring does nothing: fall back on the linear modes
    forcing = np.where(peaks.sum(axis=1) > 0, forcing, 3.0 * modulus.min(axis=1))
    critical = np.maximum(forcing, np.sqrt(added))
    # the error is in the nonlinear forcing only (the linear part is exact): a weak spring, whose
    # relative stiffening eps is small, tolerates a coarser step, error ~ eps (omega h)^4
    lowest = np.where(modulus > 0, modulus, np.inf).min(axis=1)
    relative = added / np.maximum(lowest**2, 1e-300)
    resolution = STEP_RESOLUTION * np.clip(relative ** -0.25, 1.0, MAX_COARSENING)
    return np.clip(np.ceil(critical * sample_interval_s / resolution), 1, MAX_SUBSTEPS).astype(np.int64)


def _triple_quartic_sum(weights: np.ndarray, frequencies: np.ndarray) -> np.ndarray:
    """sum_ijk c_i c_j c_k (w_i + w_j + w_k)^4 per row of (B, P) weights c and frequencies w.

    By the multinomial theorem, from the moments S_a = sum_i c_i w_i^a (a = 0..4):
    sum over a + b + c = 4 of 4! / (a! b! c!) S_a S_b S_c, in O(P) per row instead of the
    (B, P, P, P) tensor (whose float power took ~0.4 s of the two spring fits of a diagnosis of
    ``lab_run_1``). Every term is >= 0 for c, w >= 0: no cancellation, the same sum to round-off
    (tests/test_nonlinear.py)."""
    powers = np.ones_like(frequencies)
    moments = []
    for _ in range(5):
        moments.append(np.sum(weights * powers, axis=1))
        powers = powers * frequencies
    total = np.zeros(weights.shape[0])
    for a in range(5):
        for b in range(5 - a):
            c = 4 - a - b
            total = total + (24.0 / (math.factorial(a) * math.factorial(b) * math.factorial(c))) * (
                moments[a] * moments[b] * moments[c])
    return total


@numba.njit(cache=True, nogil=True)
def _pair_peaks(poles, weights, dt, voltage):  # pragma: no cover - jitted
    """Peak |y_j| of each pole's own ZOH response y_j[k] = Re(w_j xi_j[k]) to ``voltage``
    (xi_j[k+1] = z_j xi_j[k] + (z_j - 1)/lambda_j u[k], the recursion of
    :func:`beam.physics.modal._step`) and the peak |sum_j y_j| of their total, (B, P) and (B,).

    The same numbers as stepping every pole as a row of ``_step`` and taking the maxima, without
    storing the (B, P, n) responses: :func:`choose_substeps` took 1.7 s of the 5.6 s spent in
    the spring's integration over a dashboard diagnosis of ``lab_run_1`` that way (a 50 MB array
    per batch), this kernel a few per cent of it.
    """
    batch, n_poles = poles.shape
    n = voltage.shape[0]
    peaks = np.zeros((batch, n_poles))
    amplitude = np.zeros(batch)
    z_re, z_im = np.empty(n_poles), np.empty(n_poles)
    w_re, w_im = np.empty(n_poles), np.empty(n_poles)
    x_re, x_im = np.empty(n_poles), np.empty(n_poles)
    for b in range(batch):
        used = 0
        for j in range(n_poles):
            z = np.exp(poles[b, j] * dt)
            w = weights[b, j] * zoh_factor(poles[b, j], dt)
            z_re[j], z_im[j], w_re[j], w_im[j] = z.real, z.imag, w.real, -w.imag
            x_re[j] = 0.0
            x_im[j] = 0.0
            if weights[b, j] != 0:
                used = j + 1
        top = 0.0
        for k in range(n):
            uk = voltage[k]
            total = 0.0
            for j in range(used):
                a, c = x_re[j], x_im[j]
                term = w_re[j] * a + w_im[j] * c
                total += term
                if abs(term) > peaks[b, j]:
                    peaks[b, j] = abs(term)
                x_re[j] = z_re[j] * a - z_im[j] * c + uk
                x_im[j] = z_re[j] * c + z_im[j] * a
            if abs(total) > top:
                top = abs(total)
        amplitude[b] = top
    return peaks, amplitude


@numba.njit(cache=True, nogil=True)
def _phi123(z):  # pragma: no cover - jitted
    """phi1, phi2, phi3 of a complex z: phi_k(z) = sum_n z^n / (n + k)!."""
    if abs(z) < 0.2:
        p1 = 0j
        p2 = 0j
        p3 = 0j
        term = 1.0 + 0j  # z^n
        fact1 = 1.0  # (n+1)!
        fact2 = 2.0  # (n+2)!
        fact3 = 6.0  # (n+3)!
        for n in range(16):
            p1 += term / fact1
            p2 += term / fact2
            p3 += term / fact3
            term *= z
            fact1 *= n + 2
            fact2 *= n + 3
            fact3 *= n + 4
        return p1, p2, p3
    ez = np.exp(z)
    p1 = (ez - 1.0) / z
    p2 = (ez - 1.0 - z) / (z * z)
    p3 = (ez - 1.0 - z - 0.5 * z * z) / (z * z * z)
    return p1, p2, p3


@numba.njit(cache=True, nogil=True)
def _corrected_tip(w0, k3, flexibility):  # pragma: no cover - jitted
    """The tip displacement w = w0 + g s(w), s = -k3 w³, with the discarded modes' quasi-static
    share g (m/N) of the spring's force: one Newton step from w0.

    The spring's force at the tip excites every mode; the retained ones are integrated, the
    discarded ones answer quasi-statically (their frequencies lie far above the force's), as the
    static correction of the voltage input. g k3 w² is small (the discarded modes' flexibility
    at the tip is a few per mil of the beam's), so one Newton step from w0 solves the cubic
    w + g k3 w³ = w0 to (3 g k3 w²)² relative; from w0 Newton approaches the root monotonically
    (the cubic is convex beyond it), so the step stays between 0 and w0 whatever the amplitude (the
    bare fixed-point step w0 - g k3 w0³ overflowed on the large-amplitude chirp of
    ``tests/test_nonlinear.py``). Measured on ``lab_run_4`` at its true parameters (RMS difference from
    the model with all 43 Galerkin modes / the record's noise, in the window 0-1.2 s and held
    out): 4 modes 2.5 / 8.8 without this correction, 1.4 / 0.03 with it; 6 modes 0.68 / 2.6
    without, 0.29 / 0.006 with; 8 modes 0.23 / 1.0 without, 0.02 / 0.004 with. Cost
    (``tests/benchmarks/bench_nonlinear.py``, 24 sets, 4 modes): forward call 26.5 ms against
    19.9 ms without, on a shared machine.
    """
    gk = flexibility * k3
    square = w0 * w0
    return w0 * (1.0 + 2.0 * gk * square) / (1.0 + 3.0 * gk * square)


@numba.njit(cache=True, nogil=True)
def _etdrk4(poles, beta_u, beta_tip, gamma_sensor, gamma_tip, cubic, voltage, dt, substeps, static):  # pragma: no cover
    """ETDRK4 (Cox & Matthews) substeps, written in terms of the tip displacement at the stages.

    The stages a, b, c of the scheme enter the update only through the spring's force at the tip,
    and each stage is linear in xi, the held voltage and the previous stage forces, so their tip
    displacements are Re(gamma·(e_half xi)), Re(gamma·(e_full xi)) plus per-sample constants:
    three dot products and one update per substep instead of four of each (the same arithmetic
    rearranged; measured 2-3x faster than forming the stages on ``lab_run_4``).
    """
    batch, n_poles = poles.shape
    n = voltage.shape[0]
    out = np.zeros((batch, n))
    e_full = np.empty(n_poles, np.complex128)
    q_half = np.empty(n_poles, np.complex128)
    g_half = np.empty(n_poles, np.complex128)  # gamma_tip e_half
    g_full = np.empty(n_poles, np.complex128)  # gamma_tip e_full
    f_u = np.empty(n_poles, np.complex128)  # (f1 + 4 f2 + f3) beta_u: the held voltage's weight in the update
    f1t = np.empty(n_poles, np.complex128)
    f2t = np.empty(n_poles, np.complex128)
    f3t = np.empty(n_poles, np.complex128)
    drive = np.empty(n_poles, np.complex128)
    xi = np.empty(n_poles, np.complex128)
    for b in range(batch):
        h = dt / substeps[b]
        tip_q = 0.0  # Re gamma·(q_half beta_tip): the tip's response to a stage force, half step
        tip_eq = 0.0  # Re gamma·(e_half q_half beta_tip)
        for j in range(n_poles):
            z = poles[b, j] * h
            e_full[j] = np.exp(z)
            e_half = np.exp(0.5 * z)
            p1h, _, _ = _phi123(0.5 * z)
            q_half[j] = 0.5 * h * p1h
            p1, p2, p3 = _phi123(z)
            f1 = h * (p1 - 3.0 * p2 + 4.0 * p3)
            f2 = h * (p2 - 2.0 * p3)
            f3 = h * (4.0 * p3 - p2)
            f_u[j] = (f1 + 4.0 * f2 + f3) * beta_u[b, j]
            f1t[j] = f1 * beta_tip[b, j]
            f2t[j] = 2.0 * f2 * beta_tip[b, j]
            f3t[j] = f3 * beta_tip[b, j]
            g_half[j] = gamma_tip[b, j] * e_half
            g_full[j] = gamma_tip[b, j] * e_full[j]
            tip_q += (gamma_tip[b, j] * q_half[j] * beta_tip[b, j]).real
            tip_eq += (g_half[j] * q_half[j] * beta_tip[b, j]).real
            xi[j] = 0j
        k3 = cubic[b]
        flexibility = static[b, 3]
        for k in range(n):
            acc = 0.0
            tip_now = 0.0
            for j in range(n_poles):
                acc += (gamma_sensor[b, j] * xi[j]).real
                tip_now += (gamma_tip[b, j] * xi[j]).real
            u = voltage[k]
            tip_static = static[b, 1] * u
            w_k = _corrected_tip(tip_now + tip_static, k3, flexibility)
            out[b, k] = acc + static[b, 0] * u - static[b, 2] * k3 * w_k * w_k * w_k
            tip_u = tip_static  # the held voltage's part of a stage's tip displacement, half step
            tip_eu = tip_static  # … and of the third stage (a half step on from the first)
            for j in range(n_poles):
                qu = q_half[j] * beta_u[b, j] * u
                tip_u += (gamma_tip[b, j] * qu).real
                tip_eu += (g_half[j] * qu).real + (gamma_tip[b, j] * qu).real
                drive[j] = f_u[j] * u
            for _ in range(substeps[b]):
                w_n = tip_static
                w_half = 0.0
                w_full = 0.0
                for j in range(n_poles):
                    x = xi[j]
                    w_n += (gamma_tip[b, j] * x).real
                    w_half += (g_half[j] * x).real
                    w_full += (g_full[j] * x).real
                w_n = _corrected_tip(w_n, k3, flexibility)
                s_n = -k3 * w_n * w_n * w_n
                w_a = _corrected_tip(w_half + tip_u + s_n * tip_q, k3, flexibility)
                s_a = -k3 * w_a * w_a * w_a
                w_b = _corrected_tip(w_half + tip_u + s_a * tip_q, k3, flexibility)
                s_b = -k3 * w_b * w_b * w_b
                w_c = _corrected_tip(w_full + tip_eu + s_n * tip_eq + (2.0 * s_b - s_n) * tip_q, k3, flexibility)
                s_c = -k3 * w_c * w_c * w_c
                s_ab = s_a + s_b
                for j in range(n_poles):
                    xi[j] = e_full[j] * xi[j] + drive[j] + f1t[j] * s_n + f2t[j] * s_ab + f3t[j] * s_c
    return out


@numba.njit(cache=True, nogil=True)
def _stage_coefficients(poles, beta_u, beta_tip, gamma_tip, dt, substeps):  # pragma: no cover - jitted
    """Per-row constants of :func:`_etdrk4` (rows x poles), split into real and imaginary parts
    and laid out (poles, rows) for :func:`_etdrk4_rows`: e_full, g_half, g_full, f_u, f1t, f2t,
    f3t (complex, as 14 real arrays) and the real tip_q, tip_eq, c_u, c_eu per row."""
    batch, n_poles = poles.shape
    cplx = np.empty((7, n_poles, batch), np.complex128)
    real = np.zeros((4, batch))
    for b in range(batch):
        h = dt / substeps[b]
        for j in range(n_poles):
            z = poles[b, j] * h
            e_full = np.exp(z)
            e_half = np.exp(0.5 * z)
            p1h, _, _ = _phi123(0.5 * z)
            q_half = 0.5 * h * p1h
            p1, p2, p3 = _phi123(z)
            f1 = h * (p1 - 3.0 * p2 + 4.0 * p3)
            f2 = h * (p2 - 2.0 * p3)
            f3 = h * (4.0 * p3 - p2)
            g_half = gamma_tip[b, j] * e_half
            cplx[0, j, b] = e_full
            cplx[1, j, b] = g_half
            cplx[2, j, b] = gamma_tip[b, j] * e_full
            cplx[3, j, b] = (f1 + 4.0 * f2 + f3) * beta_u[b, j]
            cplx[4, j, b] = f1 * beta_tip[b, j]
            cplx[5, j, b] = 2.0 * f2 * beta_tip[b, j]
            cplx[6, j, b] = f3 * beta_tip[b, j]
            real[0, b] += (gamma_tip[b, j] * q_half * beta_tip[b, j]).real  # tip_q
            real[1, b] += (g_half * q_half * beta_tip[b, j]).real  # tip_eq
            qu = q_half * beta_u[b, j]
            real[2, b] += (gamma_tip[b, j] * qu).real  # c_u: the held voltage's tip share, half step
            real[3, b] += (g_half * qu).real + (gamma_tip[b, j] * qu).real  # c_eu: ... third stage
    return cplx, real


@numba.njit(cache=True, nogil=True, fastmath={"reassoc", "contract"})
def _etdrk4_rows(cplx, real, gamma_sensor, gamma_tip, cubic, voltage, substeps, static):  # pragma: no cover
    """:func:`_etdrk4` for rows that share their number of substeps, stepped together: every
    loop over the poles runs over all the rows at once (contiguous, SIMD), where the one-row
    kernel's inner loops ran over a few poles. The same arithmetic, regrouped; measured 2.2x
    faster on a 448-row design of ``lab_run_1``'s spring fit (7 modes, 1051 samples; results within 1e-12).
    ``cplx``, ``real`` from :func:`_stage_coefficients`; ``gamma_*`` (poles, rows)."""
    n_poles, rows = cplx.shape[1], cplx.shape[2]
    n = voltage.shape[0]
    out = np.empty((rows, n))
    er, ei = cplx[0].real.copy(), cplx[0].imag.copy()
    ghr, ghi = cplx[1].real.copy(), cplx[1].imag.copy()
    gfr, gfi = cplx[2].real.copy(), cplx[2].imag.copy()
    fur, fui = cplx[3].real.copy(), cplx[3].imag.copy()
    f1r, f1i = cplx[4].real.copy(), cplx[4].imag.copy()
    f2r, f2i = cplx[5].real.copy(), cplx[5].imag.copy()
    f3r, f3i = cplx[6].real.copy(), cplx[6].imag.copy()
    gtr, gti = gamma_tip.real.copy(), gamma_tip.imag.copy()
    gsr, gsi = gamma_sensor.real.copy(), gamma_sensor.imag.copy()
    tip_q, tip_eq, c_u, c_eu = real[0], real[1], real[2], real[3]
    xr = np.zeros((n_poles, rows))
    xi = np.zeros((n_poles, rows))
    w_n, w_half, w_full = np.empty(rows), np.empty(rows), np.empty(rows)
    s_n, s_ab, s_c = np.empty(rows), np.empty(rows), np.empty(rows)
    acc, tip_now = np.empty(rows), np.empty(rows)
    steps = substeps[0]
    for k in range(n):
        u = voltage[k]
        acc[:] = 0.0
        tip_now[:] = 0.0
        for j in range(n_poles):
            for r in range(rows):
                acc[r] += gsr[j, r] * xr[j, r] - gsi[j, r] * xi[j, r]
                tip_now[r] += gtr[j, r] * xr[j, r] - gti[j, r] * xi[j, r]
        for r in range(rows):
            k3 = cubic[r]
            w = _corrected_tip(tip_now[r] + static[r, 1] * u, k3, static[r, 3])
            out[r, k] = acc[r] + static[r, 0] * u - static[r, 2] * k3 * w * w * w
        for _ in range(steps):
            for r in range(rows):
                w_n[r] = static[r, 1] * u
                w_half[r] = 0.0
                w_full[r] = 0.0
            for j in range(n_poles):
                for r in range(rows):
                    a, c = xr[j, r], xi[j, r]
                    w_n[r] += gtr[j, r] * a - gti[j, r] * c
                    w_half[r] += ghr[j, r] * a - ghi[j, r] * c
                    w_full[r] += gfr[j, r] * a - gfi[j, r] * c
            for r in range(rows):
                k3, flex, tip_static = cubic[r], static[r, 3], static[r, 1] * u
                wn = _corrected_tip(w_n[r], k3, flex)
                sn = -k3 * wn * wn * wn
                wa = _corrected_tip(w_half[r] + tip_static + c_u[r] * u + sn * tip_q[r], k3, flex)
                sa = -k3 * wa * wa * wa
                wb = _corrected_tip(w_half[r] + tip_static + c_u[r] * u + sa * tip_q[r], k3, flex)
                sb = -k3 * wb * wb * wb
                wc = _corrected_tip(w_full[r] + tip_static + c_eu[r] * u + sn * tip_eq[r] + (2.0 * sb - sn) * tip_q[r],
                                    k3, flex)
                s_n[r], s_ab[r], s_c[r] = sn, sa + sb, -k3 * wc * wc * wc
            for j in range(n_poles):
                for r in range(rows):
                    a, c = xr[j, r], xi[j, r]
                    xr[j, r] = (er[j, r] * a - ei[j, r] * c + fur[j, r] * u + f1r[j, r] * s_n[r]
                                + f2r[j, r] * s_ab[r] + f3r[j, r] * s_c[r])
                    xi[j, r] = (er[j, r] * c + ei[j, r] * a + fui[j, r] * u + f1i[j, r] * s_n[r]
                                + f2i[j, r] * s_ab[r] + f3i[j, r] * s_c[r])
    return out


def _etdrk4_grouped(poles, beta_u, beta_tip, gamma_sensor, gamma_tip, cubic, voltage, dt, substeps, static):
    """:func:`_etdrk4` with the rows that share a number of substeps stepped together
    (:func:`_etdrk4_rows`); a single row goes to the one-row kernel."""
    if poles.shape[0] == 1:
        return _etdrk4(poles, beta_u, beta_tip, gamma_sensor, gamma_tip, cubic, voltage, dt, substeps, static)
    out = np.empty((poles.shape[0], voltage.shape[0]))
    for count in np.unique(substeps):
        rows = np.flatnonzero(substeps == count)
        cplx, real = _stage_coefficients(poles[rows], beta_u[rows], beta_tip[rows], gamma_tip[rows], dt, substeps[rows])
        out[rows] = _etdrk4_rows(cplx, real, np.ascontiguousarray(gamma_sensor[rows].T),
                                 np.ascontiguousarray(gamma_tip[rows].T), np.ascontiguousarray(cubic[rows]), voltage,
                                 np.ascontiguousarray(substeps[rows]), np.ascontiguousarray(static[rows]))
    return out


# ---------------------------------------------------------------------------------------------
# The general path: the channels of any set of nonlinear effects (a list, :mod:`beam.physics.effects.channel`),
# from rest or from a given state, at uniform or irregular sample times, for any output.


@numba.njit(cache=True, nogil=True)
def _joint_backbone(x, stiffness, slip_rotation, slip_moment):  # pragma: no cover - jitted
    """Loading curve of an Iwan joint: k x (1 - |x| / (2 x_s)) up to the slip rotation
    x_s = 2 M_s / k, M_s sign(x) beyond (N m)."""
    ax = abs(x)
    if ax >= slip_rotation:
        return slip_moment if x > 0.0 else -slip_moment
    return stiffness * x * (1.0 - ax / (2.0 * slip_rotation))


@numba.njit(cache=True, nogil=True)
def _joint_moment(theta, k, moment_s, memory):  # pragma: no cover - jitted
    """An Iwan joint's moment on the beam beyond its linear part, k theta - R(theta) (N m):
    R on the Masing branch from the last reversal (theta_r, R_r) = ``memory[0:2]``,
    R = R_r + 2 B((theta - theta_r) / 2) with B the loading curve (:func:`_joint_backbone`)."""
    theta_s = 2.0 * moment_s / k
    restoring = memory[1] + 2.0 * _joint_backbone(0.5 * (theta - memory[0]), k, theta_s, moment_s)
    return k * theta - restoring


@numba.njit(cache=True, nogil=True)
def _forcing(xi, u, row, beta_u, laws, beta, gamma, coef, static_in, flex, out, forces, memory):  # pragma: no cover
    """The modal forcing beta_u u + sum_c beta_c F_c of the state ``xi`` into ``out``, each
    channel point's force F_c into ``forces`` (see :mod:`beam.physics.effects.channel` for the
    laws): the point cubic -k w³ (w its displacement with the discarded modes' quasi-static share
    of the input and of F itself), the velocity-squared -c |v| v, the Iwan joint's k theta - R(theta)
    on its Masing branch (``memory[c]``). ``gamma[row, c, 0]`` reads the displacement (rotation),
    ``gamma[row, c, 1]`` the velocity (gains already doubled for a conjugate pair)."""
    n_poles = xi.shape[0]
    for j in range(n_poles):
        out[j] = beta_u[row, j] * u
    for c in range(laws.shape[0]):
        law = laws[c]
        force = 0.0
        if law == LAW_POINT_CUBIC:
            k3 = coef[row, c, 0]
            if k3 != 0.0:
                w = static_in[row, c] * u
                for j in range(n_poles):
                    w += (gamma[row, c, 0, j] * xi[j]).real
                w = _corrected_tip(w, k3, flex[row, c])
                force = -k3 * w * w * w
            for j in range(n_poles):
                out[j] += beta[row, c, j] * force
        elif law == LAW_IWAN_JOINT:
            if coef[row, c, 1] > 0.0:
                theta = 0.0
                for j in range(n_poles):
                    theta += (gamma[row, c, 0, j] * xi[j]).real
                force = _joint_moment(theta, coef[row, c, 0], coef[row, c, 1], memory[c])
                for j in range(n_poles):
                    out[j] += beta[row, c, j] * force
        else:  # LAW_VELOCITY_SQUARED
            weight = coef[row, c, 0]
            if weight != 0.0:
                v = 0.0
                for j in range(n_poles):
                    gain = gamma[row, c, 1, j]
                    state = xi[j]
                    v += gain.real * state.real - gain.imag * state.imag
                force = -weight * abs(v) * v
                for j in range(n_poles):
                    gain = beta[row, c, j]
                    out[j] += complex(gain.real * force, gain.imag * force)
        forces[c] = force


@numba.njit(cache=True, nogil=True)
def _step_coefficients(poles, widths):  # pragma: no cover - jitted
    """ETDRK4 coefficients (6, U, P) of each distinct substep h in ``widths`` (U,): E, E_h, Q,
    f1, 2 f2, f3 (see :func:`_etdrk4_general`)."""
    n_poles = poles.shape[0]
    table = np.empty((6, widths.shape[0], n_poles), np.complex128)
    for u in range(widths.shape[0]):
        h = widths[u]
        for j in range(n_poles):
            z = poles[j] * h
            table[0, u, j] = np.exp(z)
            table[1, u, j] = np.exp(0.5 * z)
            p1h, _, _ = _phi123(0.5 * z)
            table[2, u, j] = 0.5 * h * p1h
            p1, p2, p3 = _phi123(z)
            table[3, u, j] = h * (p1 - 3.0 * p2 + 4.0 * p3)
            table[4, u, j] = 2.0 * h * (p2 - 2.0 * p3)
            table[5, u, j] = h * (4.0 * p3 - p2)
    return table




@numba.njit(cache=True, nogil=True)
def _root_state(xi, gains):  # pragma: no cover - jitted
    """(theta, theta', amplitude) of a rotation: Re(gamma . xi) for the rotation and its rate
    (``gains[0]``, ``gains[1]``), and the sum of the kept poles' moduli |gamma_j xi_j| (rad)."""
    theta = 0.0
    rate = 0.0
    amplitude = 0.0
    for j in range(xi.shape[0]):
        theta += (gains[0, j] * xi[j]).real
        rate += (gains[1, j] * xi[j]).real
        amplitude += abs(gains[0, j] * xi[j])
    return theta, rate, amplitude


@numba.njit(cache=True, nogil=True)
def _start_branch(xi, gains, k, moment_s, memory):  # pragma: no cover - jitted
    """The Masing branch a joint is on at the start (``memory``: theta_r, R_r, direction): the
    motion taken as the settled cycle of the rotation's current amplitude A, whose last reversal
    was at -direction A with R = -direction B(A) (a release from rest: the release point itself)."""
    theta, rate, amplitude = _root_state(xi, gains)
    amplitude = max(amplitude, abs(theta))
    direction = 1.0 if rate > 0.0 else (-1.0 if rate < 0.0 else (-1.0 if theta > 0.0 else 1.0))
    memory[0] = -direction * amplitude
    memory[1] = -direction * _joint_backbone(amplitude, k, 2.0 * moment_s / k, moment_s)
    memory[2] = direction


@numba.njit(cache=True, nogil=True)
def _follow_reversal(xi, gains, k, moment_s, memory, theta_before, rate_before, h):  # pragma: no cover - jitted
    """After a substep of ``h`` s: if a joint's rotation rate changed sign, start the new Masing
    branch at the turning point (theta' taken linear over the substep, theta at the root of it)
    with R on the old branch there. Returns the rotation and its rate now."""
    theta, rate, _ = _root_state(xi, gains)
    direction = memory[2]
    if rate * direction < 0.0:
        share = rate_before / (rate_before - rate) if rate_before != rate else 0.0
        turn = theta_before + 0.5 * rate_before * share * h
        memory[1] = turn * k - _joint_moment(turn, k, moment_s, memory)  # R on the old branch
        memory[0] = turn
        memory[2] = -direction
    return theta, rate


@numba.njit(cache=True, nogil=True)
def _etdrk4_general(row, poles, beta_u, laws, beta, gamma_out, gamma, coef, static_u, static_in, flex, static_out,
                    direct, initial, voltage, step_id, counts, table, widths):  # pragma: no cover - jitted
    """ETDRK4 (Cox & Matthews 2002) on xi' = Lambda xi + N(xi, u) for parameter set ``row``.

    Stages a = E_h xi + Q N(xi), b = E_h xi + Q N(a), c = E_h a + Q (2 N(b) - N(xi)),
    xi+ = E xi + f1 N(xi) + 2 f2 (N(a) + N(b)) + f3 N(c) (E = exp(Lambda h), E_h its half step,
    Q = (E_h - 1) / Lambda, f1..f3 the phi-function weights of :func:`_etdrk4`). Sample k is held
    over its interval, split into ``counts[k]`` substeps whose coefficients are
    ``table[:, step_id[k]]`` (:func:`_step_coefficients`; a record's stamps take few distinct
    steps). Output at t_k: Re(gamma_out . xi) + (static_u + direct[0]) u + sum_c (direct[1 + c] +
    static_out[c]) F_c (:func:`_forcing`). An Iwan joint's Masing memory is held fixed over a
    substep and moved to the turning point after the substep in which its rotation reverses
    (:func:`_follow_reversal`); ``widths`` are the substeps (s) of ``step_id``.
    """
    n_poles = poles.shape[1]
    n = voltage.shape[0]
    n_channels = laws.shape[0]
    out = np.zeros(n)
    xi = initial[row].copy()
    sa = np.empty(n_poles, np.complex128)
    sb = np.empty(n_poles, np.complex128)
    sc = np.empty(n_poles, np.complex128)
    n0 = np.empty(n_poles, np.complex128)
    na = np.empty(n_poles, np.complex128)
    nb = np.empty(n_poles, np.complex128)
    nc = np.empty(n_poles, np.complex128)
    forces = np.empty(n_channels)
    b = row
    memory = np.zeros((n_channels, 4))  # each joint's last reversal (theta_r, R_r) and its direction
    thetas = np.zeros(n_channels)
    rates = np.zeros(n_channels)
    rubbing = np.zeros(n_channels, np.bool_)
    for c in range(n_channels):
        if laws[c] == LAW_IWAN_JOINT and coef[b, c, 1] > 0.0:
            rubbing[c] = True
            _start_branch(xi, gamma[b, c], coef[b, c, 0], coef[b, c, 1], memory[c])
            thetas[c], rates[c], _ = _root_state(xi, gamma[b, c])
    for k in range(n):
        u = voltage[k]
        _forcing(xi, u, b, beta_u, laws, beta, gamma, coef, static_in, flex, n0, forces, memory)
        value = (static_u[b] + direct[b, 0]) * u
        for c in range(n_channels):
            value += (direct[b, 1 + c] + static_out[b, c]) * forces[c]
        for j in range(n_poles):
            value += (gamma_out[b, j] * xi[j]).real
        out[k] = value
        if k == n - 1:
            break
        e_full, e_half, q_half = table[0, step_id[k]], table[1, step_id[k]], table[2, step_id[k]]
        f1, f2, f3 = table[3, step_id[k]], table[4, step_id[k]], table[5, step_id[k]]
        h = widths[step_id[k]]
        for sub in range(counts[k]):
            if sub > 0:
                _forcing(xi, u, b, beta_u, laws, beta, gamma, coef, static_in, flex, n0, forces, memory)
            for j in range(n_poles):
                sa[j] = e_half[j] * xi[j] + q_half[j] * n0[j]
            _forcing(sa, u, b, beta_u, laws, beta, gamma, coef, static_in, flex, na, forces, memory)
            for j in range(n_poles):
                sb[j] = e_half[j] * xi[j] + q_half[j] * na[j]
            _forcing(sb, u, b, beta_u, laws, beta, gamma, coef, static_in, flex, nb, forces, memory)
            for j in range(n_poles):
                sc[j] = e_half[j] * sa[j] + q_half[j] * (2.0 * nb[j] - n0[j])
            _forcing(sc, u, b, beta_u, laws, beta, gamma, coef, static_in, flex, nc, forces, memory)
            for j in range(n_poles):
                xi[j] = e_full[j] * xi[j] + f1[j] * n0[j] + f2[j] * (na[j] + nb[j]) + f3[j] * nc[j]
            for c in range(n_channels):
                if rubbing[c]:
                    thetas[c], rates[c] = _follow_reversal(xi, gamma[b, c], coef[b, c, 0], coef[b, c, 1], memory[c],
                                                           thetas[c], rates[c], h)
    return out


#: Largest |lambda_max| h of the general path (rad per substep, lambda_max the highest retained pole).
#: The drag's force |v| v is only once differentiable where v changes sign: against a 0.05 rad
#: step, a tip-force pulse of the 50 cm strip at 1 kHz (the drag 24 % of the response) was off
#: by 1.2e-4 of the peak at 1.5 rad per substep, 5e-7 at 0.4 rad.
GENERAL_RESOLUTION = STEP_RESOLUTION


def integrate_general(
    omega_squared: np.ndarray, reduced_damping: np.ndarray, force: np.ndarray, sensor: np.ndarray,
    channels: Sequence[ChannelArrays], voltage: np.ndarray, steps_s: np.ndarray, order: int = 0,
    initial: np.ndarray | None = None, static_input: np.ndarray | None = None,
) -> np.ndarray:
    """Sensor output (B, n) of the retained modes with a list of nonlinear channels.

    The retained modes (mass-normalised undamped shapes) obey

        eta'' + C_r eta' + diag(omega²) eta = f_r u(t) + sum_c sum_p psi_cp F_cp,

    F_cp the force of channel c at its point p by the channel's law, psi_cp = row_p . Phi its modal
    row (:mod:`beam.physics.effects.channel`: a point cubic spring, the Gauss points of a
    distributed drag, an Iwan joint on the root's rotation). They are diagonalised (first-order
    form, one coordinate per conjugate pair) and stepped by ETDRK4 (:func:`_etdrk4_general`),
    whose linear part is exact; the channels' points are stacked, one law code each.

    Parameters
    ----------
    omega_squared : (B, m)  omega² (rad²/s²).
    reduced_damping : (B, m, m)  C_r (1/s).
    force, sensor : (B, m)  the input's modal force per unit input and the sensor's displacement row.
    channels : sequence of ChannelArrays  the nonlinear channels (law, modal rows (B, P, m),
        coefficients (B, P, 2), static shares (B, P, 3) or None); empty: the linear modes.
    voltage : (n,)  input held over each interval (V or N; zeros for a free response).
    steps_s : (n - 1,)  t_k+1 - t_k (s), uniform or not.
    order : {0, 1, 2}  displacement (m), velocity (m/s) or acceleration (m/s²) at the sensor.
    initial : (B, 2m), optional  (eta, eta') at t_0; rest when omitted.
    static_input : (B,), optional  the discarded modes' quasi-static displacement at the sensor
        per unit input (displacement only); the channels' own shares are in their ``static``.
    """
    omega2 = np.asarray(omega_squared, dtype=float)
    batch, m = omega2.shape
    poles, vectors = modal.modal_decomposition(omega2, np.asarray(reduced_damping, dtype=float))
    inverse = np.linalg.inv(vectors)
    upper = vectors[:, :m, :]  # displacement part of each eigenvector, (B, m, 2m)
    scale = np.max(np.abs(poles), axis=1, keepdims=True)
    keep = poles.imag >= -1e-12 * scale  # one of each conjugate pair, and real poles
    factor = np.where(poles.imag > 1e-12 * scale, 2.0, 1.0)
    width = int(keep.sum(axis=1).max())
    order_idx = np.argsort(~keep, axis=1, kind="stable")[:, :width]
    kept = np.take_along_axis(keep, order_idx, axis=1)

    def take(array: np.ndarray) -> np.ndarray:  # (..., 2m) -> (..., width), kept poles first
        index = order_idx.reshape((batch,) + (1,) * (array.ndim - 2) + (width,))
        return np.take_along_axis(array, np.broadcast_to(index, array.shape[:-1] + (width,)), axis=-1)

    def inputs(rows: np.ndarray) -> np.ndarray:  # modal forces (B, ..., m) -> gains (B, ..., width)
        return take(np.einsum("bjm,b...m->b...j", inverse[:, :, m:], rows)) * kept.reshape((batch,) + (1,) * (rows.ndim - 2) + (width,))

    def outputs(rows: np.ndarray, power: int) -> np.ndarray:  # displacement rows -> doubled gains of the derivative
        gains = np.einsum("b...m,bmj->b...j", rows, upper) * (factor * poles**power).reshape((batch,) + (1,) * (rows.ndim - 2) + (2 * m,))
        return take(gains) * kept.reshape((batch,) + (1,) * (rows.ndim - 2) + (width,))

    kept_poles = np.where(kept, take(poles), -1.0 + 0j)
    laws = np.array([c.law for c in channels for _ in range(np.shape(c.rows)[1])], dtype=np.int64)
    count = laws.size
    rows = np.zeros((batch, count, m))
    coef = np.zeros((batch, count, 2))
    static = np.zeros((batch, count, 3))
    start = 0
    for channel in channels:
        points = np.shape(channel.rows)[1]
        rows[:, start:start + points] = channel.rows
        coef[:, start:start + points] = channel.coefficients
        if channel.static is not None and order == 0:
            static[:, start:start + points] = channel.static
        start += points
    sensor = np.asarray(sensor, dtype=float)
    force = np.asarray(force, dtype=float)
    direct = np.zeros((batch, 1 + count))
    if order == 2:  # the retained modes' acceleration feels the modal force at once
        direct[:, 0] = np.einsum("bm,bm->b", sensor, force)
        direct[:, 1:] = np.einsum("bm,bcm->bc", sensor, rows)
    static_u = np.zeros(batch)
    if static_input is not None and order == 0:
        static_u = np.broadcast_to(np.asarray(static_input, dtype=float), (batch,)).copy()
    begin = np.zeros((batch, width), complex)
    if initial is not None:
        state = np.broadcast_to(np.asarray(initial, dtype=float), (batch, 2 * m))
        begin = take(np.einsum("bjk,bk->bj", inverse, state)) * kept
    critical = np.abs(kept_poles).max(axis=1)
    gamma = np.zeros((batch, count, 2, width), complex)
    if count:
        gamma[:, :, 0] = outputs(rows, 0)
        gamma[:, :, 1] = outputs(rows, 1)
    args = (
        np.ascontiguousarray(kept_poles), inputs(force[:, None, :])[:, 0], laws,
        np.ascontiguousarray(inputs(rows)) if count else np.zeros((batch, 0, width), complex),
        np.ascontiguousarray(outputs(sensor[:, None, :], order)[:, 0]), gamma, coef, static_u,
        np.ascontiguousarray(static[:, :, 0]), np.ascontiguousarray(static[:, :, 1]),
        np.ascontiguousarray(static[:, :, 2]), direct, np.ascontiguousarray(begin),
        np.ascontiguousarray(voltage, dtype=float),
    )
    steps = np.asarray(steps_s, dtype=float)
    out = np.empty((batch, steps.size + 1))
    for row in range(batch):
        counts = np.maximum(1, np.ceil(critical[row] * steps / GENERAL_RESOLUTION)).astype(np.int64)
        widths, step_id = np.unique(steps / counts, return_inverse=True)
        table = _step_coefficients(args[0][row], widths)
        out[row] = _etdrk4_general(row, *args, step_id.reshape(-1).astype(np.int64), counts, table, widths)
    return out
