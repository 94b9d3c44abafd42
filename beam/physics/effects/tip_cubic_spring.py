"""``tip_cubic_spring``: a hardening spring at the tip, the nonlinear restoring force -k3 w(L, t)³.

Its channel is a point cubic force at the tip (:data:`~beam.physics.effects.channel.LAW_POINT_CUBIC`)
with the discarded modes' quasi-static share of it (the static correction). Alone on a driven
record with uniform stamps it is integrated by the spring's own ETDRK4 kernel in the retained
complex modes (:func:`beam.physics.nonlinear.integrate_tip_cubic`, displacement only); otherwise
by the general one. A diagnosis offers it on a driven displacement record with uniform stamps,
where its solver runs; it is calibrated on free decays too.

**Averaged (slow-flow) form** (:class:`AveragedSpring`, the slot of
:mod:`beam.physics.effects.averaged`): the Duffing backbone. Averaged over a cycle, the force
-k3 (sum_j psi_j eta_j)³ at the tip (psi_j the tip displacement of mode j per unit modal
coordinate) stiffens each mode k by its own amplitude and by every other mode's:

    d omega_k = (3 k3 psi_k² / 8 omega_k) (psi_k² A_k² + 2 sum_(j != k) psi_j² A_j²),

and, conservative, adds no loss of its own (the damping ratio c_k / omega_k(A) falls as the
frequency rises).
Each mode's own term is taken exactly, from Duffing's oscillator eta'' + omega² eta + k3 psi⁴ eta³
(Jacobi's eta = A cn(u, m), m = l / 2 (1 + l), l = k3 psi_k⁴ A_k² / omega_k²): its backbone
omega_k pi sqrt(1 + l) / 2 K(m) = omega_k (1 + 3 l / 8 - 15 l² / 256 ...), and the decay of its
envelope under the viscous damping c_k by the energy balance over one cn cycle,
d ln A_k / dt = -2 c_k <sn² dn²> = -c_k (1 - 5 l / 16 ...), <sn² dn²> = ((1 - m) K + (2m - 1) E) / 3 m K
(a hardening mode decays more slowly: its energy sits partly in the spring, which the damping
does not reach; at a 5 % stiffening over 5 s the first-order law's envelope was 2 % off at the
end and its phase 0.13 rad). The flow is integrated numerically
(:func:`~beam.physics.effects.averaged.slow_flow`). Limits: the cross terms are first order in
k3 A² / omega²; the 3 omega harmonic (l / 32 of the displacement, 9 l / 32 of an acceleration)
is left out; measured against the full integrator in ``docs/decisions.md`` (averaged forms).
On a driven record the spring's harmonic-balance
linearisation at the window's amplitude is the spectral starts' (:func:`equivalent_omega2`).

The frequency of mode 1 rises with the amplitude (a hardening backbone): that is its
fingerprint. The spectral starts of a model with it match the record's peaks to the modes
linearised at the window's amplitude (:func:`equivalent_omega2`).

**Plausible values** (:data:`PLAUSIBLE_SOURCE`), in units of EI / L⁵ (``plausible_scale``; K =
k3 L⁵ / EI): up to 3000. Linearised at a tip amplitude A (harmonic balance, mass-normalised
shapes: phi_1(L)² = 4 / rho L, omega_1² = 12.36 EI / rho L⁴), the spring raises f1 by about
0.12 K (A / L)²: at A = L / 20, 0.03 % for K = 1 (the order of a cantilever's own geometric
hardening), 30 % for K = 1000, 90 % for K = 3000. A hardening beyond that is not a spring at the
tip but contact (a stop, a clamp that closes). lab_run_4's simulated spring: K = 612.
"""

from __future__ import annotations

import math

import beam.physics.effects.fingerprint as fpr
from beam.physics.effects.channel import LAW_POINT_CUBIC, Channel
from beam.physics.effects.effect import Effect, Fingerprint, ParameterSpec, StartHints

__all__ = ["AVERAGED_NOTE", "AveragedSpring", "EFFECT", "PLAUSIBLE_SOURCE", "STIFFNESS", "equivalent_omega2"]

PLAUSIBLE_SOURCE = ("harmonic balance of the tip spring on mode 1 (df1 / f1 = 0.12 k3 L^5 / EI (A / L)^2): at most a 90 % "
                    "hardening at a tip swing of L / 20; a cantilever's own geometric hardening is of order EI / L^5")
STIFFNESS = ParameterSpec("tip_cubic_stiffness_N_m3", "N/m³", "k_3", "cubic stiffness at the tip", 1.0, 1e7,
                          nominal_log_sd=1.5, plausible=(0.0, 3000.0), plausible_source=PLAUSIBLE_SOURCE,
                          plausible_scale="EI/L^5")

#: Mode-1 frequency 0.5 % higher at the largest amplitude.
THRESHOLD = 0.005


#: The label of every result of the averaged model with the tip spring.
AVERAGED_NOTE = ("averaged (slow-flow) approximation of the hardening tip spring: each mode's frequency rises with "
                 "the squared amplitudes (Duffing backbone, cycle-averaged, first order); a preview, not the full "
                 "integration")


class AveragedSpring:
    """The tip spring's averaged (slow-flow) form (module notes; the contract of
    :mod:`beam.physics.effects.averaged`)."""

    note = AVERAGED_NOTE

    def prepare(self, model, values, shapes, omega, sigma, tau, output="displacement"):
        import numpy as np

        psi = model.parts.tip_values @ shapes  # (m,) tip displacement per unit modal coordinate
        omega = np.asarray(omega, dtype=float)
        # coupling[k, j] = d omega_k per A_j²: own 3 k3 psi_k^4 / 8 omega_k, cross twice that with psi_j²
        k3 = float(values[STIFFNESS.name])
        coupling = 3.0 * k3 * (psi**2)[:, None] * (psi**2)[None, :] / (4.0 * omega[:, None])
        np.fill_diagonal(coupling, 0.5 * np.diag(coupling))
        # the other retained modes follow mode k's cubic force quasi-statically: slaved[k, j] = psi_j / (omega_j² - omega_k²)
        gap = omega[None, :] ** 2 - omega[:, None] ** 2
        slaved = np.where(np.abs(gap) > 1e-9 * omega[None, :] ** 2, psi[None, :] / np.where(gap == 0.0, 1.0, gap), 0.0)
        np.fill_diagonal(slaved, 0.0)
        geometry = model.geometry
        sensor = (-0.5 * geometry.thickness_m * model.parts.sensor_curvatures if output == "strain"
                  else model.parts.sensor_values) @ shapes
        with np.errstate(divide="ignore", invalid="ignore"):
            seen = np.where(sensor != 0.0, (slaved @ sensor) / sensor, 0.0)  # (m,) the slaved modes at the sensor
        return {"coupling": coupling, "omega": omega, "sigma": np.asarray(sigma, dtype=float),
                "tau": np.asarray(tau, dtype=float), "softening": -15.0 / 16.0 * k3**2 * psi**6 * (slaved @ psi) / omega,
                "seen": -0.75 * k3 * psi**3 * seen}

    def describing(self, prepared, amplitudes):
        import numpy as np
        from scipy.special import ellipe, ellipk

        a = np.atleast_2d(np.asarray(amplitudes, dtype=float))
        coupling, omega = prepared["coupling"], prepared["omega"]
        own = np.diag(coupling)
        cross = (a**2) @ (coupling - np.diag(own)).T
        # each mode's own Duffing oscillator exactly (Jacobi's cn, module notes): l = k3 psi^4 A² / omega²
        # = (8 / 3) (its first-order shift) / omega, parameter m = l / 2 (1 + l)
        ratio = 8.0 / 3.0 * own[None, :] * a**2 / omega[None, :]
        m = ratio / (2.0 * (1.0 + ratio))
        big_k, big_e = ellipk(m), ellipe(m)
        backbone = omega[None, :] * (np.pi * np.sqrt(1.0 + ratio) / (2.0 * big_k) - 1.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            mean = np.where(m > 1e-8, ((1.0 - m) * big_k + (2.0 * m - 1.0) * big_e) / (3.0 * m * big_k), 0.5 - m / 8.0)
        rate = -prepared["sigma"][None, :] * (2.0 * mean - 1.0)  # c (2 <sn² dn²> - 1): a slower decay
        return backbone + cross + prepared["softening"][None, :] * a**4, rate

    def envelope(self, prepared, amplitudes):
        import numpy as np

        from beam.physics.effects.averaged import slow_flow

        ratio, phase = slow_flow(lambda amps: self.describing(prepared, amps), amplitudes, prepared["sigma"],
                                 prepared["tau"])
        envelopes = np.asarray(amplitudes, dtype=float)[None, :] * np.exp(prepared["sigma"][None, :]
                                                                           * prepared["tau"][:, None]) * ratio
        return ratio * (1.0 + prepared["seen"][None, :] * envelopes**2), phase


def tip_row(model):
    """The tip's displacement row (1, n)."""
    return model.parts.tip_values[None, :]


def coefficients(model, values):
    """k3 (B, 1, 2) (N/m³)."""
    import numpy as np

    k3 = np.asarray(values[STIFFNESS.name], dtype=float)
    return np.stack([k3, np.zeros_like(k3)], axis=-1)[:, None, :]


def driven(system, coefficients, voltage, dt, static_gains):
    """The spring alone on a driven record: :func:`beam.physics.nonlinear.integrate_tip_cubic` of
    the modal system ``system`` (inputs: the record's, a unit tip force; outputs: sensor, tip)."""
    from beam.physics.nonlinear import integrate_tip_cubic

    return integrate_tip_cubic(system, coefficients[:, 0, 0], voltage, dt, static_gains=static_gains)


def equivalent_omega2(reduced, amplitude_m: float, values):
    """Squared natural frequencies (B, m) (rad²/s²) with the spring linearised at the window's
    amplitude (harmonic balance, the first mode dominant): the tip's amplitude A is the window's
    displacement amplitude ``amplitude_m`` (sqrt(2) x its RMS) carried from the sensor to the tip by
    the first mode's shape; the cubic force k3 w³ then adds (3/4) k3 A² phi_1(L)² to the first
    mode and (3/2) k3 A² phi_j(L)² to each other mode (linearised about the first mode's
    oscillation; mass-normalised shapes, ``reduced`` of :meth:`BeamModel.reduced_system`).

    The record's peaks are where the spring puts the modes at that amplitude, not the linear
    frequencies: lab_run_4 (simulated with a 15,000 N/m³ spring), 45 % window, tip mass + spring,
    a 256-start search's optimum has linear frequencies 5.9, 38.7, 111, 222 Hz and these 7.17,
    38.9, 111, 222 Hz, against the record's peaks at 7.2, 38.9, 108 Hz."""
    import numpy as np

    tip, sensor = reduced["tip"], reduced["sensor"]
    with np.errstate(divide="ignore", invalid="ignore"):
        tip_amplitude = amplitude_m * np.abs(tip[:, 0] / sensor[:, 0])
    tip_amplitude = np.where(np.isfinite(tip_amplitude), tip_amplitude, 0.0)
    factor = np.full(tip.shape[1], 1.5)
    factor[0] = 0.75
    k3 = np.broadcast_to(np.asarray(values[STIFFNESS.name], dtype=float), tip_amplitude.shape)
    return reduced["omega2"] + factor[None, :] * (k3 * tip_amplitude ** 2)[:, None] * tip ** 2


def score(fp) -> float:
    shift = fpr.nz(fpr.get(fp, "amplitude_frequency_shift"))
    significant = abs(fpr.nz(fpr.get(fp, "backbone_slope_z"))) > 2
    return max(shift, 0.0) / THRESHOLD if significant else 0.0


def explain(fp, value: float) -> str:
    shift, slope = fpr.get(fp, "amplitude_frequency_shift"), fpr.get(fp, "backbone_slope_Hz_per_m")
    if math.isfinite(shift):
        if value >= 1:
            return (f"the mode-1 frequency rises {fpr.pct(shift, False)} from the smallest to the largest amplitude "
                    f"(backbone slope {slope:.3g} Hz/m): a hardening (cubic) spring")
        return (f"the mode-1 frequency barely depends on amplitude ({fpr.pct(shift)} over the decay): "
                "no sign of a hardening spring")
    if fpr.get(fp, "free_decay") == 0.0:
        return ("a driven record has no free decay whose frequency could be followed as the swing dies: "
                "a hardening spring is judged here by the calibration's evidence alone")
    return ("no backbone of the free decay was measured, or none the record's spectrum confirms: "
            "a hardening spring cannot be judged")


EFFECT = Effect(
    "tip_cubic_spring",
    "Hardening tip spring",
    "nonlinear restoring force -k3 w(L, t)^3 at the tip",
    (STIFFNESS,),
    channel=Channel("tip_cubic_spring", LAW_POINT_CUBIC, (STIFFNESS.name,), STIFFNESS.name, tip_row, coefficients,
                    static_correction=True, driven=driven),
    needs=frozenset({"input", "uniform", "displacement"}),
    fingerprint=Fingerprint(THRESHOLD, score, explain),
    averaged=AveragedSpring(),
    hints=StartHints(spectral=equivalent_omega2),
    left_out_of_nominal="no nominal value sets the frequencies of its hardening",
    catalogue_order=70,
)
