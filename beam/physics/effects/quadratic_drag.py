"""``quadratic_drag``: air drag on the strip moving broadside, force per unit length
-½ rho_air C_d b |w_t| w_t.

rho_air = :data:`AIR_DENSITY_KG_M3`, b the width from the sidecar's ``[beam] width_m``, w_t the
local transverse velocity: a damping that grows with the amplitude (equivalent viscous coefficient
(8 / 3 pi) ½ rho_air C_d b |w_t|max). Its channel (:data:`~beam.physics.effects.channel.LAW_VELOCITY_SQUARED`)
acts at the Gauss points of :func:`drag_quadrature` along the span, each with the weight
½ rho_air C_d b w_g (kg/m): the distributed drag projected on the retained modes by quadrature,
integrated with the tip spring's ETDRK4 scheme (:func:`beam.physics.nonlinear.integrate_general`).

**Plausible values.** C_d of a flat plate or strip in oscillating flow at Keulegan–Carpenter
numbers KC = 2 pi A / b of order 0.1–10 lies between about 2 and 20, rising as KC falls
(:data:`PLAUSIBLE_SOURCE`). The prior range 0.01–50 reaches below that band so that the effect
vanishes at its low end (a model with it nests the model without it).

**Where.** Offered on free decays, where a damping that grows with the amplitude shows, of a
strip whose width is known; calibrated wherever the width is.

**Averaged (slow-flow) form** (:class:`AveragedDrag`, the slot of :mod:`beam.physics.effects.averaged`).
Each retained mode k rings at its damped frequency omega_d,k with an envelope A_k(t). The mode p
of the largest velocity amplitude (a_k omega_k at the window's start; mode 1 on a released
strip) decays by its own drag, averaged over one cycle of |v| v (the mean of |sin|³, 4 / 3 pi):

    dA_p/dt = -c_p A_p - b_p A_p²,   b_p = (4 / 3 pi) kappa_pp omega_p C_d,
    kappa_jk = ½ rho_air b ∫ |psi_j| psi_k² dx   (psi mass-normalised, A a modal amplitude),

with the closed form (c_k = zeta_k omega_k = -Re(pole_k), tau the time since the window's start)

    A_p(tau) = a_p e^(-c_p tau) / (1 + b_p a_p tau phi(c_p tau)),   phi(x) = (1 - e^(-x)) / x,

which tends to a_p / (1 + b_p a_p tau) as zeta_p -> 0 (phi -> 1). Every other mode k is damped
by mode p's velocity: linearised in v_k, |v| v ≈ 2 |v_p| v_k, whose average over mode p's cycle
(the mean of |sin|, 2 / pi) gives dA_k/dt = -c_k A_k - beta_k A_p(t) A_k, beta_k =
(2 / pi) kappa_pk omega_p C_d, and since ∫ A_p dt = ln(1 + b_p a_p tau phi) / b_p,

    A_k(tau) = a_k e^(-c_k tau) (1 + b_p a_p tau phi(c_p tau))^(-beta_k / b_p).

The phases are the linear model's: at first order the drag does not change the frequency. Limits:
it keeps, of the drag's coupling of the modes through |v| v, the dominant mode's own term and its
damping of the others; it drops the weaker modes' own drag and their drag on the dominant one
(second order in v_k / v_p), the beating of two modes inside |v|, the drag's harmonics (3 omega,
5 omega, ... components of relative order b A / omega) and its second-order frequency shift. It
holds while the envelope changes little over one cycle and one mode dominates the velocity; with
two comparable velocities it is not the drag's averaged model any more (the full integrator is).
Why hand-written: the response is a closed form (no library evaluates it), and it is what makes
the preview cheaper than the ETDRK4 integration it stands for.

**Start hints** (:func:`equivalent_starts`): averaged over a cycle, the drag on mode k of
amplitude A_k acts as a viscous damping ratio zeta_eq,k = (4 / 3 pi) kappa_k A_k,
kappa_k = ½ rho_air C_d b ∫ |psi_k|³ dx (``docs/physics-drag.md``).
"""

from __future__ import annotations

import math

from beam.errors import BeamInputError
import beam.physics.effects.fingerprint as fpr
import beam.physics.effects.modal_damping as modal_damping
from beam.physics.effects.channel import LAW_VELOCITY_SQUARED, Channel
from beam.physics.effects.effect import Effect, Fingerprint, ParameterSpec, Refusal, StartHints

__all__ = ["AIR_DENSITY_KG_M3", "AVERAGED_NOTE", "AveragedDrag", "COEFFICIENT", "DRAG_PANELS", "DRAG_POINTS", "EFFECT",
           "EQUIVALENT_FRACTIONS", "PLAUSIBLE_SOURCE", "drag_quadrature", "equivalent_starts"]

#: Density of air (kg/m³) at 20 °C and 101.325 kPa.
AIR_DENSITY_KG_M3 = 1.204
#: Gauss–Legendre quadrature of the drag along the span: panels of equal length, points per panel.
DRAG_PANELS = 4
DRAG_POINTS = 4
#: Fractions of the sub-model's mode-1 damping ratio that the drag's equivalent viscous damping
#: takes over in the equivalent starts (:func:`equivalent_starts`).
EQUIVALENT_FRACTIONS = (0.5, 0.7, 0.85)

PLAUSIBLE_SOURCE = ("Keulegan & Carpenter 1958, J. Res. Natl. Bur. Stand. 60, 423–440 (plates in an oscillating "
                    "fluid); Graham 1980, J. Fluid Mech. 97, 331–346 (C_d ∝ KC^(-1/3) for sharp-edged bodies at low "
                    "KC); Bidkar et al. 2009, J. Fluid Mech. 634, 269–289 (cantilevered strips at KC of order 1)")
COEFFICIENT = ParameterSpec("drag_coefficient", "1", "C_d", "drag coefficient of the strip in oscillating flow", 0.01,
                            50.0, nominal_log_sd=1.0, plausible=(2.0, 20.0), plausible_source=PLAUSIBLE_SOURCE)

#: The label of every result of the averaged model.
AVERAGED_NOTE = ("averaged (slow-flow) approximation of the quadratic drag: each mode's envelope decays by "
                 "dA/dt = -zeta omega A - b A² (cycle-averaged, the modes' cross terms neglected); a preview, "
                 "not the full integration")
#: Mode-1 decay rate 25 % lower at the end of the decay than at its start.
THRESHOLD = 0.25


def drag_quadrature(length_m: float, panels: int = DRAG_PANELS, points: int = DRAG_POINTS):
    """Gauss–Legendre nodes (m) and weights (m) on [0, L] split into equal panels."""
    import numpy as np

    nodes, weights = np.polynomial.legendre.leggauss(points)
    edges = np.linspace(0.0, float(length_m), panels + 1)
    half = 0.5 * np.diff(edges)[:, None]
    centre = 0.5 * (edges[1:] + edges[:-1])[:, None]
    return (centre + half * nodes[None, :]).ravel(), (half * weights[None, :]).ravel()


def gauss_rows(model):
    """The displacement rows (G, n) at the Gauss points of :func:`drag_quadrature`."""
    nodes, _ = drag_quadrature(model.geometry.length_m)
    return model.parts.basis.evaluate(nodes, 0)


def coefficients(model, values):
    """½ rho_air C_d b w_g (B, G, 2) (kg/m) at each Gauss point."""
    import numpy as np

    width = model.geometry.width_m
    if width is None:
        raise BeamInputError("quadratic_drag needs the strip's width: [beam] width_m in the sidecar")
    _, weights = drag_quadrature(model.geometry.length_m)
    drag = 0.5 * AIR_DENSITY_KG_M3 * width * np.asarray(values[COEFFICIENT.name], dtype=float)[:, None] * weights[None, :]
    return np.stack([drag, np.zeros_like(drag)], axis=-1)


def _kappa_cubed(model, shapes):
    """½ rho_air b ∫ |psi_k|³ dx (m,) per unit C_d, and the shapes at the Gauss points with their weights."""
    import numpy as np

    nodes, weights = drag_quadrature(model.geometry.length_m)
    psi = model.parts.basis.evaluate(nodes, 0) @ shapes  # (G, m)
    return 0.5 * AIR_DENSITY_KG_M3 * model.geometry.width_m * (weights @ np.abs(psi) ** 3), psi, weights


class AveragedDrag:
    """The drag's averaged (slow-flow) form (module notes; the contract of :mod:`beam.physics.effects.averaged`)."""

    note = AVERAGED_NOTE

    def prepare(self, model, values, shapes, omega, sigma, tau, output="displacement"):
        import numpy as np

        if not model.geometry.width_m:
            raise BeamInputError("quadratic_drag needs the strip's width: [beam] width_m in the sidecar")
        kappa, psi, weights = _kappa_cubed(model, shapes)
        b = 4.0 / (3.0 * math.pi) * kappa * omega * values[COEFFICIENT.name]
        # cross[p, k] = beta_k / b_p: mode p's velocity damping mode k, (2 / pi) kappa_pk omega_p over b_p
        kappa_pk = np.einsum("g,gp,gk->pk", weights, np.abs(psi), psi**2)  # (m, m), per ½ rho b C_d
        cross = (2.0 / math.pi) * kappa_pk / ((4.0 / (3.0 * math.pi)) * np.maximum(np.diag(kappa_pk), 1e-300)[:, None])
        x = -sigma[None, :] * tau[:, None]
        phi = np.where(x > 1e-12, -np.expm1(-x) / np.where(x > 1e-12, x, 1.0), 1.0)
        return {"b": b, "omega": omega, "cross": cross, "slow": tau[:, None] * phi}  # tau phi(c tau) (n, m)

    def envelope(self, prepared, amplitudes):
        import numpy as np

        p = int(np.argmax(amplitudes * prepared["omega"]))  # the mode of the largest velocity
        growth = prepared["b"][p] * amplitudes[p] * prepared["slow"][:, p]  # (n,)
        ratio = np.exp(-np.log1p(growth)[:, None] * prepared["cross"][p][None, :])  # A(tau) / (a e^(-c tau)) (n, m)
        ratio[:, p] = 1.0 / (1.0 + growth)
        return ratio, None

    def describing(self, prepared, amplitudes):
        """No frequency shift; mode p's own cycle-averaged drag b_p A_p and its damping of every
        other mode beta_k A_p (module notes), p the mode of the largest velocity in each row."""
        import numpy as np

        a = np.atleast_2d(np.asarray(amplitudes, dtype=float))
        p = np.argmax(a * prepared["omega"][None, :], axis=1)  # (N,)
        b_p, a_p = prepared["b"][p], a[np.arange(a.shape[0]), p]
        rate = (b_p * a_p)[:, None] * prepared["cross"][p]  # beta_k A_p = (beta_k / b_p) b_p A_p
        rate[np.arange(a.shape[0]), p] = b_p * a_p
        return np.zeros_like(a), rate


def equivalent_starts(model, one, state, duration_s):
    """Starts with the drag on, from a sub-model's optimum ``one`` (natural units, the drag at its
    null value), by the slow-flow (averaging) approximation of each mode (module notes).

    For each fraction f of :data:`EQUIVALENT_FRACTIONS`, C_d is chosen so that the drag takes
    over f of the mode-1 damping ratio at its mean amplitude over the window (the sub-model's
    exponential envelope from its initial modal state ``state``), and every modal damping ratio
    is lowered by the drag's equivalent share at its own mean amplitude (to no less than a tenth
    of it): a start near the valley of the posterior where the two damping laws trade off,
    instead of the drag switched on over an unchanged viscous damping. Empty when the model has
    no modal damping ratios or no width.
    """
    import numpy as np

    m = state.size // 2
    ratios = [modal_damping.ratio_name(j + 1) for j in range(m)]
    width = model.geometry.width_m
    if COEFFICIENT.name not in one or ratios[0] not in one or not width:
        return []
    names = model.parameter_names_for(m)
    omega2, shapes = model.mode_shapes({n: one[n] for n in names}, m)
    omega = np.sqrt(np.maximum(omega2, 1e-300))
    kappa, _, _ = _kappa_cubed(model, shapes)  # per unit C_d
    start_amplitude = np.hypot(state[:m], state[m:] / omega)
    decay = np.array([one.get(r, 0.0) for r in ratios]) * omega * duration_s
    mean = start_amplitude * np.where(decay > 1e-9, -np.expm1(-decay) / np.maximum(decay, 1e-300), 1.0)
    per_unit = 4.0 / (3.0 * math.pi) * kappa * mean  # zeta_eq per unit C_d
    if not (np.isfinite(per_unit).all() and per_unit[0] > 0.0):
        return []
    starts = []
    for fraction in EQUIVALENT_FRACTIONS:
        drag = fraction * one[ratios[0]] / per_unit[0]
        start = dict(one, **{COEFFICIENT.name: float(drag)})
        for j, name in enumerate(ratios):
            if name in one:
                start[name] = float(max(one[name] - drag * per_unit[j], 0.1 * one[name]))
        starts.append(start)
    return starts


def score(fp) -> float:
    return max(-fpr.nz(fpr.get(fp, "decay_rate_change")), 0.0) / THRESHOLD


def explain(fp, value: float) -> str:
    change = fpr.get(fp, "decay_rate_change")
    if not math.isfinite(change):
        return "no decay law of mode 1 was measured: a damping that grows with the amplitude cannot be judged"
    if value >= 1:
        return (f"the decay of mode 1 slows as it dies out (its decay rate {fpr.pct(-change, False)} lower at the end "
                "than at the start): a damping that grows with the amplitude, such as air drag")
    return (f"the decay rate of mode 1 barely depends on its amplitude ({fpr.pct(change)} over the decay): "
            "no sign of a damping that grows with the amplitude")


EFFECT = Effect(
    "quadratic_drag",
    "Quadratic air drag",
    "air drag on the strip moving broadside, force per length -½ rho_air C_d b |w_t| w_t (b from [beam] width_m)",
    (COEFFICIENT,),
    channel=Channel("quadratic_drag", LAW_VELOCITY_SQUARED, (COEFFICIENT.name,), COEFFICIENT.name, gauss_rows,
                    coefficients),
    averaged=AveragedDrag(),
    needs=frozenset({"width", "free"}),
    refusals=(Refusal(frozenset({"width"}), "quadratic_drag needs the strip's width: [beam] width_m and thickness_m "
                      "in the sidecar, or --width and --thickness"),),
    fingerprint=Fingerprint(THRESHOLD, score, explain),
    hints=StartHints(free_decay=equivalent_starts),
    catalogue_order=80,
)
