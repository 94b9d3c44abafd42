"""The hardening tip spring -k3 w(L, t)³, integrated in the retained complex modal coordinates.

In the diagonalised modal coordinates xi (see :func:`beam.physics.modal.complex_modes`)

    xi' = Lambda xi + beta_u V(t) + beta_tip s(xi),   s = -k3 w_tip³,   w_tip = Re(gamma_tip · xi),

the linear part is diagonal. We step it with the fourth-order exponential time-differencing
Runge–Kutta scheme ETDRK4 (Cox & Matthews 2002), whose linear part is exact: with k3 = 0 it
reproduces the exact ZOH response, and it stays stable at the sampling rate however stiff the
retained modes are. The phi-functions are evaluated by their Taylor series near zero (no
cancellation). Each sample interval is split into substeps so that the nonlinear forcing is
resolved: max(3 omega_resolved, omega_nonlinear) h <= 0.15, where omega_resolved is the highest
retained modal frequency below the Nyquist frequency (the cubic makes third harmonics) and
omega_nonlinear is the frequency of the tip spring's tangent stiffness at the amplitude of the
linear response. A weak spring needs less: the scheme's error lies in the nonlinear forcing
alone (the linear part is exact) and scales as eps (omega h)^4, with eps the spring's tangent
stiffness relative to the first mode's, so the step is coarsened by eps^(-1/4), at most 10x.
"""

from __future__ import annotations

import numba
import numpy as np

from beam.physics.modal import ComplexModes, _collapse, _step

#: Largest (modal frequency x substep) the integrator allows.
STEP_RESOLUTION = 0.15
#: How much coarser than STEP_RESOLUTION a weak spring may be stepped.
MAX_COARSENING = 10.0
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
    static_gains : (B, 2) array, optional
        Quasi-static displacement per volt of the discarded modes at the sensor and the tip (m/V),
        added to the output and to the tip displacement the spring acts on (static correction of
        the voltage input; the spring's own force acts on the retained modes only).
    """
    voltage = np.ascontiguousarray(voltage, dtype=float)
    batch = system.poles.shape[0]
    cubic = np.broadcast_to(np.asarray(cubic_N_m3, dtype=float), (batch,))
    if substeps is None:
        substeps = choose_substeps(system, cubic, voltage, sample_interval_s)
    substeps = np.broadcast_to(np.asarray(substeps, dtype=np.int64), (batch,)).copy()
    static = np.zeros((batch, 2)) if static_gains is None else np.ascontiguousarray(np.broadcast_to(static_gains, (batch, 2)), dtype=float)
    return _etdrk4(
        np.ascontiguousarray(system.poles),
        np.ascontiguousarray(system.input_gains[:, 0]),
        np.ascontiguousarray(system.input_gains[:, 1]),
        np.ascontiguousarray(system.output_gains[:, 0]),
        np.ascontiguousarray(system.output_gains[:, 1]),
        np.ascontiguousarray(cubic), voltage, float(sample_interval_s), substeps, static,
    )


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
    27 substeps per sample on ``lab_run_4`` where this rule takes about 3, with the same accuracy
    against the solve_ivp reference (``tests/test_nonlinear.py``).
    """
    modulus = np.abs(system.poles)
    upper, weights = _collapse(np.ascontiguousarray(system.poles),
                               np.ascontiguousarray(system.output_gains[:, 1] * system.input_gains[:, 0]))
    batch, n_slots = upper.shape
    voltage = np.ascontiguousarray(voltage, dtype=float)
    zero = np.zeros(batch)
    # each pair's own linear tip response (its peak), and the total's peak
    pair_tip = np.stack([_step(upper[:, j:j + 1].copy(), weights[:, j:j + 1].copy(), sample_interval_s, voltage, zero)
                         for j in range(n_slots)], axis=1)  # (B, P, n)
    peaks = np.abs(pair_tip).max(axis=2)  # (B, P); unused slots have weight 0
    amplitude = np.abs(pair_tip.sum(axis=1)).max(axis=1)
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
    sums = frequency[:, :, None, None] + frequency[:, None, :, None] + frequency[:, None, None, :]
    weight = peaks[:, :, None, None] * peaks[:, None, :, None] * peaks[:, None, None, :]
    total = np.maximum(peaks.sum(axis=1), 1e-300)
    forcing = (np.sum(weight * sums**4, axis=(1, 2, 3)) / total**3) ** 0.25
    # with no motion at the tip (no input) the spring does nothing: fall back on the linear modes
    forcing = np.where(peaks.sum(axis=1) > 0, forcing, 3.0 * modulus.min(axis=1))
    critical = np.maximum(forcing, np.sqrt(added))
    # the error is in the nonlinear forcing only (the linear part is exact): a weak spring, whose
    # relative stiffening eps is small, tolerates a coarser step, error ~ eps (omega h)^4
    lowest = np.where(modulus > 0, modulus, np.inf).min(axis=1)
    relative = added / np.maximum(lowest**2, 1e-300)
    resolution = STEP_RESOLUTION * np.clip(relative ** -0.25, 1.0, MAX_COARSENING)
    return np.clip(np.ceil(critical * sample_interval_s / resolution), 1, MAX_SUBSTEPS).astype(np.int64)


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
def _etdrk4(poles, beta_u, beta_tip, gamma_sensor, gamma_tip, cubic, voltage, dt, substeps, static):  # pragma: no cover
    batch, n_poles = poles.shape
    n = voltage.shape[0]
    out = np.zeros((batch, n))
    e_full = np.empty(n_poles, np.complex128)
    e_half = np.empty(n_poles, np.complex128)
    q_half = np.empty(n_poles, np.complex128)
    f1 = np.empty(n_poles, np.complex128)
    f2 = np.empty(n_poles, np.complex128)
    f3 = np.empty(n_poles, np.complex128)
    xi = np.empty(n_poles, np.complex128)
    a = np.empty(n_poles, np.complex128)
    bb = np.empty(n_poles, np.complex128)
    c = np.empty(n_poles, np.complex128)
    for b in range(batch):
        h = dt / substeps[b]
        for j in range(n_poles):
            z = poles[b, j] * h
            e_full[j] = np.exp(z)
            e_half[j] = np.exp(0.5 * z)
            p1h, _, _ = _phi123(0.5 * z)
            q_half[j] = 0.5 * h * p1h
            p1, p2, p3 = _phi123(z)
            f1[j] = h * (p1 - 3.0 * p2 + 4.0 * p3)
            f2[j] = h * (p2 - 2.0 * p3)
            f3[j] = h * (4.0 * p3 - p2)
            xi[j] = 0j
        k3 = cubic[b]
        for k in range(n):
            acc = 0.0
            for j in range(n_poles):
                acc += (gamma_sensor[b, j] * xi[j]).real
            u = voltage[k]
            out[b, k] = acc + static[b, 0] * u
            tip_static = static[b, 1] * u
            for _ in range(substeps[b]):
                s_n = _tip_force(gamma_tip[b], xi, k3, tip_static)
                for j in range(n_poles):
                    a[j] = e_half[j] * xi[j] + q_half[j] * (beta_u[b, j] * u + beta_tip[b, j] * s_n)
                s_a = _tip_force(gamma_tip[b], a, k3, tip_static)
                for j in range(n_poles):
                    bb[j] = e_half[j] * xi[j] + q_half[j] * (beta_u[b, j] * u + beta_tip[b, j] * s_a)
                s_b = _tip_force(gamma_tip[b], bb, k3, tip_static)
                for j in range(n_poles):
                    c[j] = e_half[j] * a[j] + q_half[j] * (beta_u[b, j] * u + beta_tip[b, j] * (2.0 * s_b - s_n))
                s_c = _tip_force(gamma_tip[b], c, k3, tip_static)
                for j in range(n_poles):
                    forcing_u = beta_u[b, j] * u
                    xi[j] = (
                        e_full[j] * xi[j]
                        + f1[j] * (forcing_u + beta_tip[b, j] * s_n)
                        + 2.0 * f2[j] * (2.0 * forcing_u + beta_tip[b, j] * (s_a + s_b))
                        + f3[j] * (forcing_u + beta_tip[b, j] * s_c)
                    )
    return out


@numba.njit(cache=True, nogil=True)
def _tip_force(gamma_tip, state, k3, w_static):  # pragma: no cover - jitted
    w = w_static
    for j in range(state.shape[0]):
        w += (gamma_tip[j] * state[j]).real
    return -k3 * w * w * w
