"""``kelvin_voigt``: internal strain-rate damping, a moment c_I w_xxt.

Its damping ratio grows with frequency, zeta_k = c_I omega_k / (2 EI): a record whose damping
ratios grow faster with frequency than the model's lacks it (the fingerprint).
"""

from __future__ import annotations

import math

import beam.physics.effects.fingerprint as fpr
from beam.physics.effects.effect import Effect, Fingerprint, ParameterSpec, Term

__all__ = ["COEFFICIENT", "EFFECT"]

COEFFICIENT = ParameterSpec("kelvin_voigt_Nm2s", "N m² s", "c_I", "Kelvin–Voigt strain-rate damping", 1e-9, 1e-3,
                            nominal_log_sd=1.5)

#: The measured zeta_k / zeta_1 grows 1.5 x more than the model's.
THRESHOLD = math.log(1.5)


def score(fp) -> float:
    return max(fpr.log_growth(fp), 0.0) / THRESHOLD


def explain(fp, value: float) -> str:
    return fpr.damping_law_words(fp, value, verb="grow", law="strain-rate (Kelvin–Voigt) damping, ζ ∝ ω",
                                 absent="strain-rate (Kelvin–Voigt) damping", judged="Kelvin–Voigt damping")


EFFECT = Effect(
    "kelvin_voigt",
    "Kelvin–Voigt damping",
    "internal strain-rate damping moment cI w_xxt",
    (COEFFICIENT,),
    (Term("damping", "stiffness_beam", COEFFICIENT.name),),
    fingerprint=Fingerprint(THRESHOLD, score, explain),
    catalogue_order=20,
)
