"""``air_damping``: a viscous force gamma w_t per unit length, proportional to the local velocity.

Its damping ratio falls with frequency, zeta_k = gamma / (2 rho omega_k): a record whose damping
ratios fall faster with frequency than the model's lacks it (the fingerprint).
"""

from __future__ import annotations

import math

import beam.physics.effects.fingerprint as fpr
from beam.physics.effects.effect import Effect, Fingerprint, ParameterSpec, Term

__all__ = ["EFFECT", "RATE"]

RATE = ParameterSpec("air_damping_Ns_m2", "N s/m²", "γ", "viscous (air) damping per unit length", 1e-6, 1.0,
                     nominal_log_sd=1.5)

#: The measured zeta_k / zeta_1 falls 1.5 x more than the model's.
THRESHOLD = math.log(1.5)


def score(fp) -> float:
    return max(-fpr.log_growth(fp), 0.0) / THRESHOLD


def explain(fp, value: float) -> str:
    return fpr.damping_law_words(fp, value, verb="fall", law="velocity-proportional (air) damping, ζ ∝ 1/ω",
                                 absent="air damping", judged="air damping")


EFFECT = Effect(
    "air_damping",
    "Air damping",
    "viscous force gamma w_t proportional to the local velocity",
    (RATE,),
    (Term("damping", "mass_beam", RATE.name),),
    fingerprint=Fingerprint(THRESHOLD, score, explain),
    catalogue_order=10,
)
