"""``clamp_compliance``: a rotational spring k_theta at the root instead of a rigid clamp,
EI w''(0) = k_theta w'(0) (the basis keeps the root rotation).

Every mode falls by a similar fraction (to first order a root spring lowers all omega² by the
same 4 EI / (k_theta L)): the fingerprint is a mean frequency error ē < 0 with mode 1's deficit r
small against |ē|. A lower EI does the same, so after EI is calibrated this pattern fades; a
small tip mass lowers the modes in nearly the same pattern, and the two separate only when r is a
clear share of |ē|.

**Plausible values** (:data:`PLAUSIBLE_SOURCE`), in units of the strip's EI / L
(``plausible_scale = "EI/L"``, kappa = k_theta L / EI): from 3 to rigid. The root-spring
cantilever's characteristic equation (Blevins 1979, *Formulas for natural frequency and mode
shape*, table 8-1) puts f1 35 % below the rigid clamp's at kappa = 3, 26 % at 5, 4 % at 50 and
0.2 % at 1000: a vice or a bolted clamp on a lab strip sits at kappa of tens to thousands (the
shared 50 cm runs: about 50, 233 N m/rad on EI 2.2 N m²), and a joint softer than kappa = 3 is a
hinge the strip visibly rocks in.
"""

from __future__ import annotations

import math

import beam.physics.effects.fingerprint as fpr
from beam.physics.effects.effect import Effect, Fingerprint, ParameterSpec, Term

__all__ = ["EFFECT", "PLAUSIBLE_SOURCE", "STIFFNESS"]

PLAUSIBLE_SOURCE = ("the root-spring cantilever's characteristic equation (Blevins 1979, Formulas for natural "
                    "frequency and mode shape, table 8-1): f1 35 % below the rigid clamp's at k_theta L / EI = 3, "
                    "4 % at 50; a vice or a bolted clamp on a lab strip sits at tens to thousands")
STIFFNESS = ParameterSpec("clamp_stiffness_Nm_rad", "N m/rad", "k_θ", "rotational stiffness of the clamp", 0.01, 1e6,
                          absent_at="high", nominal_log_sd=1.5, plausible=(3.0, math.inf),
                          plausible_source=PLAUSIBLE_SOURCE, plausible_scale="EI/L")

#: All modes two percent low.
THRESHOLD = 0.02


def score(fp) -> float:
    return fpr.lowering(fp) * fpr.uniform(fp) / THRESHOLD


def explain(fp, value: float) -> str:
    deficit, mean_error = fpr.get(fp, "mode1_deficit"), fpr.get(fp, "frequency_error_mean")
    if not math.isfinite(deficit):
        return f"mode 1 and mode 2 or 3 must both be identified to judge the clamp ({fpr.errors_text(fp)})"
    if value >= 1:
        return (f"all modes are low by a similar fraction (measured against the model: "
                f"{fpr.difference_words(100 * mean_error)} on average, mode 1 only {fpr.pct(deficit, False)} more): "
                "a compliant clamp (or a lower bending stiffness) lowers every mode alike")
    if -mean_error >= THRESHOLD and deficit > 0:
        return (f"the modes are {fpr.pct(-mean_error, False)} low on average but not alike (mode 1 a further "
                f"{fpr.pct(deficit, False)} low relative to modes 2–3): the pattern fits a tip mass better than a "
                "compliant clamp")
    return (f"the modes are not lowered alike (measured against the model: {fpr.difference_words(100 * mean_error)} on "
            f"average, mode 1 {fpr.low(deficit)} relative to modes 2–3): no sign of a compliant clamp")


EFFECT = Effect(
    "clamp_compliance",
    "Compliant clamp",
    "rotational spring at the root instead of a rigid clamp: EI w''(0) = k_theta w'(0)",
    (STIFFNESS,),
    (Term("stiffness", "stiffness_clamp", STIFFNESS.name),),
    frees_root_rotation=True,
    fingerprint=Fingerprint(THRESHOLD, score, explain),
    catalogue_order=40,
)
