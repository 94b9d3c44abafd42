"""``tip_mass``: a point mass m_t at the free end x = L (translation only).

Every mode falls, mode 1 most: its fingerprint is r = mean over k = 2, 3 of
(1 + e_k) / (1 + e_1) − 1 > 0 ("mode 1 low relative to modes 2–3", e_k the frequency error of
mode k), which a rescaled bending stiffness leaves unchanged, so it survives a calibration of EI.
"""

from __future__ import annotations

import math

import beam.physics.effects.fingerprint as fpr
from beam.physics.effects.effect import Effect, Fingerprint, ParameterSpec, Term

__all__ = ["EFFECT", "MASS"]

MASS = ParameterSpec("tip_mass_kg", "kg", "m_t", "point mass at the tip", 1e-7, 0.2, nominal_log_sd=1.0)

#: Mode 1 two percent low relative to modes 2–3.
THRESHOLD = 0.02


def score(fp) -> float:
    return max(fpr.deficit(fp), 0.0) / THRESHOLD


def explain(fp, value: float) -> str:
    deficit, errors = fpr.get(fp, "mode1_deficit"), fpr.errors_text(fp)
    if not math.isfinite(deficit):
        return f"mode 1 and mode 2 or 3 must both be identified to judge a tip mass ({errors})"
    if value >= 1:
        return (f"mode 1 is {fpr.pct(deficit, False)} low relative to modes 2–3 ({errors}): "
                "a mass at the tip lowers the first mode most")
    return (f"mode 1 is not clearly low relative to modes 2–3 (it is {fpr.low(deficit)}; {errors}): "
            "no sign of a missing tip mass")


EFFECT = Effect(
    "tip_mass",
    "Tip mass",
    "point mass at the free end x = L (translation only)",
    (MASS,),
    (Term("mass", "mass_tip", MASS.name),),
    fingerprint=Fingerprint(THRESHOLD, score, explain),
    catalogue_order=30,
)
