"""``patch_stiffening``: the bonded patch adds density Δrho and bending stiffness ΔEI on [p_l, p_r].

Local mass and stiffness shift the modes unevenly: the fingerprint is the frequency error of
mode 2 outside the range of modes 1 and 3 (for the beams here mode 2 falls most).
"""

from __future__ import annotations

import math

import beam.physics.effects.fingerprint as fpr
from beam.physics.effects.effect import Effect, Fingerprint, ParameterSpec, Term

__all__ = ["DENSITY", "EFFECT", "STIFFNESS"]

DENSITY = ParameterSpec("patch_added_density_kg_m", "kg/m", "Δρ", "density added by the patch", 1e-6, 5.0,
                        nominal_log_sd=0.5)
STIFFNESS = ParameterSpec("patch_added_stiffness_Nm2", "N m²", "ΔEI", "bending stiffness added by the patch", 1e-6,
                          10.0, nominal_log_sd=0.5)

#: Mode 2 one percent out of line with modes 1 and 3.
THRESHOLD = 0.01


def score(fp) -> float:
    return abs(fpr.nz(fpr.get(fp, "mode2_out_of_line"))) / THRESHOLD


def explain(fp, value: float) -> str:
    out_of_line, errors = fpr.get(fp, "mode2_out_of_line"), fpr.errors_text(fp)
    if not math.isfinite(out_of_line):
        return f"modes 1, 2 and 3 must all be identified to judge patch stiffening ({errors})"
    if value >= 1:
        return (f"{errors[0].upper()}{errors[1:]}: mode 2 does not follow modes 1 and 3, it sits "
                f"{100 * abs(out_of_line):.1f} percentage points {'below' if out_of_line < 0 else 'above'} the nearer of "
                "them. Added mass and stiffness on the patch region shift the modes unevenly like this")
    return f"the frequency errors change smoothly with mode number ({errors}): no sign of a stiffer, heavier patch"


EFFECT = Effect(
    "patch_stiffening",
    "Patch stiffening",
    "the bonded patch adds density and bending stiffness on [p_l, p_r]",
    (DENSITY, STIFFNESS),
    (Term("mass", "mass_patch", DENSITY.name), Term("stiffness", "stiffness_patch", STIFFNESS.name)),
    needs_patch=True,
    fingerprint=Fingerprint(THRESHOLD, score, explain),
    catalogue_order=50,
)
