"""``effective_length``: the free length L_eff (m) between the clamp's edge and the tip, instead of
the sidecar's ``[beam] length_m``.

A clamp holds the strip over a jaw of finite depth, and a documented 419 mm bar can vibrate as if
it were shorter. The model is assembled for the length
(:meth:`beam.physics.geometry.BeamGeometry.with_free_length`: the tip, the sensor, the patch and
the force point stay where they are on the strip, i.e. keep their distance from the tip, and the
clamp's edge moves). It adds no term: it changes every part. It vanishes exactly at L_eff = L
(``absent_at = "centre"``), the centre of its prior, which the calibration takes from the
record's stated length: log-normal around it with sigma = :data:`FREE_LENGTH_LOG_SD` (0.1, i.e.
about 10 %, truncated at 4 sigma, so 0.67-1.49 L and always positive). 10 % because a jaw's depth
is a few cm on strips of a few dm, the issue's own example (419 mm vibrating as 365 mm) is 13 %
off, and a frequency, which goes as 1 / L², would pin a much narrower prior against EI's instead
of letting the record's amplitude and mode ratios decide. It competes with ``clamp_compliance``
(both lower every frequency) in the missing-effect ranking; a compliant clamp changes the mode
ratios, a shorter length does not.

Offered only where the sidecar places no patch: on a patch beam the prior's range of lengths
would move the bonded patch into the clamp (the fit then fails). Fingerprint: every mode raised
alike (f ∝ 1 / L²: a shorter free length).
"""

from __future__ import annotations

import math

import beam.physics.effects.fingerprint as fpr
from beam.physics.effects.effect import Effect, Fingerprint, GeometryChange, ParameterSpec

__all__ = ["EFFECT", "FREE_LENGTH_LOG_SD", "LENGTH", "free_length_geometry"]

#: sigma of log L_eff of the prior around the stated length (module notes).
FREE_LENGTH_LOG_SD = 0.1

LENGTH = ParameterSpec("effective_length_m", "m", "L_eff", "free length between the clamp's edge and the tip",
                       0.01, 100.0, absent_at="centre", nominal_log_sd=FREE_LENGTH_LOG_SD)

#: All modes two percent high alike.
THRESHOLD = 0.02


def free_length_geometry(geometry, length_m: float):
    """``geometry`` with the free length ``length_m`` (m): :meth:`~beam.physics.geometry.BeamGeometry.with_free_length`."""
    return geometry.with_free_length(length_m)


def score(fp) -> float:
    return fpr.raising(fp) * fpr.alike(fp) / THRESHOLD


def explain(fp, value: float) -> str:
    deficit, mean_error = fpr.get(fp, "mode1_deficit"), fpr.get(fp, "frequency_error_mean")
    if not math.isfinite(deficit):
        return f"mode 1 and mode 2 or 3 must both be identified to judge the free length ({fpr.errors_text(fp)})"
    if value >= 1:
        return (f"all modes are high by a similar fraction (measured against the model: "
                f"{fpr.difference_words(100 * mean_error)} on average): a strip shorter than stated (the clamp "
                "holding more of it) raises every mode alike, f ∝ 1 / L²")
    return (f"the modes are not raised alike (measured against the model: {fpr.difference_words(100 * mean_error)} on "
            "average): no sign of a free length shorter than the stated one")


EFFECT = Effect(
    "effective_length",
    "Effective free length",
    "the strip vibrates as if its free length were L_eff, not the stated length (the clamp's edge is never exact)",
    (LENGTH,),
    geometry=GeometryChange(LENGTH.name, free_length_geometry),
    needs=frozenset({"no_patch"}),
    fingerprint=Fingerprint(THRESHOLD, score, explain),
    catalogue_order=110,
)
