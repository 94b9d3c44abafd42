"""``patch_damping``: the bonded patch (its adhesive layer) adds strain-rate damping Δc_I w_xxt on [p_l, p_r].

Its own effect (it was an optional parameter of ``patch_stiffening``, which no control could
add): a record simulated with it is repaired only by a model that has it. Damping on the patch
alone damps each mode by its share of curvature there, unevenly: the fingerprint is the damping
error of mode 2 (log of data / model) outside the range of modes 1 and 3.
"""

from __future__ import annotations

import math

import beam.physics.effects.fingerprint as fpr
from beam.physics.effects.effect import Effect, Fingerprint, ParameterSpec, Term

__all__ = ["COEFFICIENT", "EFFECT"]

COEFFICIENT = ParameterSpec("patch_added_kelvin_voigt_Nm2s", "N m² s", "Δc_I", "strain-rate damping added by the patch",
                            1e-9, 1e-3, nominal_log_sd=1.5)

#: zeta_2 30 % out of line with modes 1 and 3.
THRESHOLD = math.log(1.3)


def score(fp) -> float:
    return abs(fpr.nz(fpr.get(fp, "damping_mode2_out_of_line"))) / THRESHOLD


def explain(fp, value: float) -> str:
    damping_out = fpr.get(fp, "damping_mode2_out_of_line")
    if not math.isfinite(damping_out):
        return "modes 1, 2 and 3 must all be identified with their damping to judge patch damping"
    if value >= 1:
        return (f"the damping of mode 2 does not follow modes 1 and 3: measured against the model, it is "
                f"{math.exp(damping_out):.2f} times the nearer of theirs. Damping added on the patch region damps "
                "the modes unevenly like this")
    return "the damping errors change smoothly with mode number: no sign of damping added on the patch"


EFFECT = Effect(
    "patch_damping",
    "Patch damping",
    "the bonded patch (its adhesive layer) adds strain-rate damping Δc_I w_xxt on [p_l, p_r]",
    (COEFFICIENT,),
    (Term("damping", "stiffness_patch", COEFFICIENT.name),),
    needs=frozenset({"patch"}),
    fingerprint=Fingerprint(THRESHOLD, score, explain),
    catalogue_order=60,
)
