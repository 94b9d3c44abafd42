"""``clamp_friction``: frictional microslip where the clamp grips the strip.

The root is held by a rotational joint of stick stiffness k_f (``clamp_friction_stiffness_Nm_rad``)
whose contact slips progressively as the root moment grows, until the whole contact slips at the
moment M_s (``clamp_slip_moment_Nm``). The joint is Iwan's parallel array of Jenkins elements with
a uniform density of slip strengths (Iwan 1966, J. Appl. Mech. 33, 893–900; Segalman 2005,
J. Appl. Mech. 72, 752–760): its loading curve is M(theta) = k_f theta (1 - |theta| / (2
theta_s)) for |theta| <= theta_s = 2 M_s / k_f and M_s beyond, and it unloads and reloads along
Masing's branches M = M_r + 2 M((theta - theta_r) / 2) from the last reversal (theta_r, M_r)
(Masing 1926). In microslip (|theta| < theta_s) the cycle of amplitude A has the mean stiffness
k_f - (k_f / 2 theta_s) A (half the sum of its branches) and dissipates (4 / 3) (k_f / 2 theta_s)
A³: the frequency of every mode falls, and its damping ratio grows, linearly with the amplitude,
the damping ratio 4 / 3 pi (0.42) times the relative frequency drop
(``docs/physics-clamp-friction.md``). The linear part k_f theta replaces the rigid clamp (the
basis keeps the root rotation, as ``clamp_compliance``); the softening, the hysteresis and the
slip are its channel (:data:`~beam.physics.effects.channel.LAW_IWAN_JOINT` on the root's
rotation), integrated with the drag's ETDRK4 scheme (:func:`beam.physics.nonlinear.integrate_general`).
Both parameters vanish at the top of their ranges (a rigid joint that never slips), where the
model nests the model without it.

**Plausible values** (:data:`PLAUSIBLE_SOURCE`), in units of the strip's EI / L
(``plausible_scale = "EI/L"``): the stick stiffness as a compliant clamp's, from 3 EI / L to rigid
(:mod:`beam.physics.effects.clamp_compliance`); the slip moment from 1e-4 to 1 EI / L. A swing
whose tip moves by d has the root moment 3 EI d / L² of the static cantilever, 3 d / L in these
units: 3e-3 for a 0.5 mm swing of a 50 cm strip, 0.3 for a 5 cm one. A contact that slips at a
hundredth of the smallest of them holds nothing (the root is a hinge), one that slips only above
EI / L never slips in a lab's swing. The shared 50 cm runs: 0.07–0.09 N m, 0.015–0.02 EI / L.

Calibrated on free decays only (its joint's history is taken from the swing at the window's
start). Not a ranking candidate: the diagnosis's note on a held-out phase lag names it where the
record's own frequency rises as the swing dies (its calibration takes minutes, the ranking fits
every candidate).
"""

from __future__ import annotations

import math

import beam.physics.effects.base as base
from beam.physics.effects.channel import LAW_IWAN_JOINT, Channel
from beam.physics.effects.effect import Effect, ParameterSpec, Refusal, StartHints, Term

__all__ = ["EFFECT", "FRICTION_SLIP_RATIOS", "FRICTION_STIFFNESS_RATIOS", "PLAUSIBLE_SOURCE", "SLIP", "STICK",
           "friction_starts"]

PLAUSIBLE_SOURCE = ("the stick stiffness: a compliant clamp's (beam.physics.effects.clamp_compliance); the slip "
                    "moment: the static cantilever's root moment 3 EI d / L² for a lab swing of tip amplitude d "
                    "(L/1000 to L/10: 3e-3 to 0.3 EI / L), a hundredth of the smallest to three times the largest")
STICK = ParameterSpec("clamp_friction_stiffness_Nm_rad", "N m/rad", "k_f", "stick stiffness of the clamp's frictional joint",
                      0.01, 1e6, absent_at="high", plausible=(3.0, math.inf), plausible_source=PLAUSIBLE_SOURCE,
                      plausible_scale="EI/L")
SLIP = ParameterSpec("clamp_slip_moment_Nm", "N m", "M_s", "root moment at which the whole clamp contact slips", 1e-4, 1e4,
                     absent_at="high", plausible=(1e-4, 1.0), plausible_source=PLAUSIBLE_SOURCE, plausible_scale="EI/L")

#: The friction's starts (:func:`friction_starts`): the joint's stick stiffness k_f in units of the
#: strip's EI / L (a clamp far stiffer than the strip's root, which still lowers f1 by 0.1-3 %) ...
FRICTION_STIFFNESS_RATIOS = (100.0, 300.0, 1000.0, 3000.0)
#: ... and the root rotation's amplitude at the window's start in units of the slip rotation
#: theta_s = 2 M_s / k_f (microslip to whole slip over a swing).
FRICTION_SLIP_RATIOS = (0.5, 1.0, 2.0)


def root_row(model):
    """The root's rotation row (1, n): w'(0) = row . q."""
    import numpy as np

    return model.parts.basis.evaluate(np.zeros(1), 1)


def coefficients(model, values):
    """(k_f, M_s) (B, 1, 2) (N m/rad, N m)."""
    import numpy as np

    return np.stack([np.asarray(values[STICK.name], dtype=float), np.asarray(values[SLIP.name], dtype=float)],
                    axis=1)[:, None, :]


def friction_starts(model, one, state, duration_s):
    """Starts with the clamp friction on, from a sub-model's optimum ``one`` (natural units, the
    friction at its null values: a rigid joint that never slips) and its modal state ``state`` at
    the window's start.

    For each stick stiffness k_f of :data:`FRICTION_STIFFNESS_RATIOS` (times EI / L), EI is raised
    so that the compliant root keeps the sub-model's f1 (one correction, f1² ∝ EI), and for each
    ratio q of :data:`FRICTION_SLIP_RATIOS` the slip moment is set so that the root's rotation at
    the window's start, |r_1| A_1 (r_1 the root rotation per unit mode-1 coordinate, A_1 the
    sub-model's mode-1 amplitude there), is q slip rotations: M_s = k_f |r_1| A_1 / 2 q. The
    joint's softening and loss are of order (theta / theta_s) times its share of the mode's strain
    energy, so the grid spans a drift of f1 from negligible to several times what a strip's decay
    shows. Empty when ``one`` lacks a parameter of it.
    """
    import numpy as np

    ei = base.BENDING_STIFFNESS.name
    if not all(n in one for n in (STICK.name, SLIP.name, ei)):
        return []
    m = state.size // 2
    names = model.parameter_names_for(m)
    omega2, _ = model.mode_shapes({n: one[n] for n in names}, m)
    if not (np.all(np.isfinite(state)) and omega2[0] > 0.0):
        return []
    mode_1 = math.hypot(state[0], state[m] / math.sqrt(omega2[0]))
    stiffness = one[ei]
    root = root_row(model)[0]
    starts = []
    for ratio in FRICTION_STIFFNESS_RATIOS:
        trial = dict(one, **{STICK.name: ratio * stiffness / model.geometry.length_m})
        softened, _ = model.mode_shapes({n: trial[n] for n in names}, m)
        trial[ei] = stiffness * float(omega2[0] / softened[0])
        _, shapes = model.mode_shapes({n: trial[n] for n in names}, m)
        rotation = abs(float(root @ shapes[:, 0])) * mode_1  # rad at the window's start
        if not (math.isfinite(rotation) and rotation > 0.0):
            continue
        for slip in FRICTION_SLIP_RATIOS:
            moment = trial[STICK.name] * rotation / (2.0 * slip)
            starts.append(dict(trial, **{SLIP.name: float(moment)}))
    return starts


EFFECT = Effect(
    "clamp_friction",
    "Clamp friction",
    "the clamp grips the strip by friction: a root joint of stick stiffness k_f that slips progressively "
    "(Iwan microslip, Masing hysteresis) and wholly at the moment M_s",
    (STICK, SLIP),
    (Term("stiffness", "stiffness_clamp", STICK.name),),
    channel=Channel("clamp_friction", LAW_IWAN_JOINT, (STICK.name, SLIP.name), SLIP.name, root_row, coefficients,
                    on_when_given=True),
    frees_root_rotation=True,
    missing_effect_candidate=False,
    needs=frozenset({"free", "rising_frequency"}),
    refusals=(Refusal(frozenset({"free"}), "clamp_friction is calibrated on free decays only (a record without input): "
                      "its joint's history is taken from the swing at the window's start"),),
    hints=StartHints(free_decay=friction_starts),
    catalogue_order=90,
)
