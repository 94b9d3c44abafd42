"""``tip_mass``: a point mass m_t at the free end x = L (translation only).

Every mode falls, mode 1 most: its fingerprint is r = mean over k = 2, 3 of
(1 + e_k) / (1 + e_1) − 1 > 0 ("mode 1 low relative to modes 2–3", e_k the frequency error of
mode k), which a rescaled bending stiffness leaves unchanged, so it survives a calibration of EI.

**Plausible values** (:data:`PLAUSIBLE_SOURCE`): a mass at the tip that the record does not state
is at most as heavy as the strip itself, rho L (``plausible_scale = "rho L"``): what sits at a lab
strip's tip unannounced — a tip accelerometer (0.2–10 g), a magnet or a screw (1–20 g) — is a
fraction of a 50 x 2 mm aluminium strip's 135 g at 50 cm, and a heavier one is a deliberate load
whose mass the user knows. A stated tip mass (``[nominal] tip_mass_kg``) decides instead, as a
stated sensor mass does (:mod:`beam.discovery.plausibility`).
"""

from __future__ import annotations

import math

import beam.physics.effects.fingerprint as fpr
from beam.physics.effects.effect import Effect, Fingerprint, ParameterSpec, Term

__all__ = ["EFFECT", "MASS", "PLAUSIBLE_SOURCE"]

PLAUSIBLE_SOURCE = ("what sits at a lab strip's tip unannounced: a miniature accelerometer 0.2-10 g (makers' "
                    "specifications, e.g. PCB Piezotronics 352C23 0.2 g), a magnet or a screw 1-20 g; a heavier load is "
                    "put there on purpose, and its mass is known")
MASS = ParameterSpec("tip_mass_kg", "kg", "m_t", "point mass at the tip", 1e-7, 0.2, nominal_log_sd=1.0,
                     plausible=(0.0, 1.0), plausible_source=PLAUSIBLE_SOURCE, plausible_scale="rho L")

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
