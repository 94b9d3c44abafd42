"""Shared readings of the residual fingerprints, for the effects' :class:`~beam.physics.effects.effect.Fingerprint`.

The fingerprints are a flat dict of dimensionless numbers (:func:`beam.residuals.fingerprints.fingerprints`;
NaN where an input is missing). Several effects read the same patterns of the frequency errors
e_k = f_data,k / f_model,k − 1 (a lowering of every mode, mode 1's deficit against modes 2–3, …):
those readings and the wording helpers are here, each effect's own score and sentence in its module.
This module imports no numerical library.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

__all__ = ["MISSING_GROWTH", "NAN", "TIP_SHARE", "alike", "damping_law_words", "deficit", "difference_words",
           "errors_text", "get",
           "growth_ratio", "log_growth", "low", "lowering", "nz", "pct", "raising", "uniform"]

NAN = float("nan")
#: r / |ē| at which a lowering of the modes counts half as uniform (clamp), half as mode-1 (tip mass).
TIP_SHARE = 0.2


def get(fp: Mapping[str, float], key: str) -> float:
    """``fp[key]`` as a float, NaN when absent or None."""
    value = fp.get(key, NAN)
    return float(value) if value is not None else NAN


def nz(value: float) -> float:
    """``value``, 0 where it is not finite."""
    return value if math.isfinite(value) else 0.0


def deficit(fp: Mapping[str, float]) -> float:
    """r: mode 1 low relative to modes 2–3 (``mode1_deficit``), 0 where unknown."""
    return nz(get(fp, "mode1_deficit"))


def lowering(fp: Mapping[str, float]) -> float:
    """How far every mode is low on average (−ē, at least 0)."""
    return max(-nz(get(fp, "frequency_error_mean")), 0.0)


def raising(fp: Mapping[str, float]) -> float:
    """How far every mode is high on average (ē, at least 0)."""
    return max(nz(get(fp, "frequency_error_mean")), 0.0)


def uniform(fp: Mapping[str, float]) -> float:
    """The share (0–1) of a lowering that is uniform rather than mode 1's (by r / |ē| around :data:`TIP_SHARE`)."""
    low_by = lowering(fp)
    share = deficit(fp) / low_by if low_by > 1e-4 else 0.0
    return 1.0 / (1.0 + (abs(share) / TIP_SHARE) ** 4)


def alike(fp: Mapping[str, float]) -> float:
    """The share (0–1) of a raising that is alike for every mode (by r / ē around :data:`TIP_SHARE`)."""
    high_by = raising(fp)
    return 1.0 / (1.0 + (abs(deficit(fp) / high_by if high_by > 1e-4 else 0.0) / TIP_SHARE) ** 4)


def log_growth(fp: Mapping[str, float]) -> float:
    """log of how much faster the measured damping ratios grow with frequency than the model's (0 unknown)."""
    growth = get(fp, "damping_growth_excess")
    return math.log(growth) if math.isfinite(growth) and growth > 0 else 0.0


#: Why the growth of damping with frequency cannot be read.
MISSING_GROWTH = ("fewer than two modes with damping were identified, so how damping varies with frequency is "
                  "unknown")


def growth_ratio(fp: Mapping[str, float]) -> str | None:
    """``"ζ3/ζ1 = 2.1 measured against 1.4 in the model"``, or None when fewer than two modes have a damping."""
    growth_data, growth_model = get(fp, "damping_growth_data"), get(fp, "damping_growth_model")
    if not (math.isfinite(growth_data) and math.isfinite(growth_model)):
        return None
    k = int(get(fp, "damping_growth_mode"))
    return f"ζ{k}/ζ1 = {growth_data:.2g} measured against {growth_model:.2g} in the model"


def damping_law_words(fp: Mapping[str, float], value: float, *, verb: str, law: str, absent: str, judged: str) -> str:
    """The sentence of a damping law that makes the ratios ``verb`` ("grow", "fall") with frequency:
    ``law`` missing (``value >= 1``), no sign of ``absent``, or ``judged`` cannot be judged."""
    ratio = growth_ratio(fp)
    if ratio is None:
        return f"{MISSING_GROWTH}: {judged} cannot be judged from the modes"
    if value >= 1:
        return f"measured damping ratios {verb} with frequency faster than the model allows ({ratio}): {law} is missing or too weak"
    return f"damping does not {verb} with frequency faster than the model allows ({ratio}): no sign of missing {absent}"


def pct(value: float, signed: bool = True) -> str:
    """A fraction as a percentage with one decimal (no "-0.0")."""
    rounded = round(100 * value, 1) + 0.0
    return f"{rounded:+.1f} %" if signed and rounded != 0 else f"{rounded:.1f} %"


def low(value: float) -> str:
    """A deficit worded once, without a sign: ``0.026`` -> ``"2.6 % low"``, ``-0.01`` -> ``"1.0 % high"``, ``1e-5`` -> ``"0.0 % off"``."""
    shown = pct(abs(value), False)
    return f"{shown} off" if shown == "0.0 %" else f"{shown} {'low' if value > 0 else 'high'}"


def difference_words(percent: float, digits: int = 1) -> str:
    """A modes-table difference (:data:`beam.residuals.DIFFERENCE_CONVENTION`) in words, read as "the
    measured value is …": ``17.5`` -> ``"17.5 % higher"``, ``-3`` -> ``"3.0 % lower"``, ``"matches"``
    when it rounds to zero at ``digits`` decimals, ``"–"`` when not finite (nothing measured)."""
    if percent is None or not math.isfinite(percent):
        return "–"
    if round(abs(float(percent)), digits) == 0:
        return "matches"
    return f"{abs(float(percent)):.{digits}f} % {'higher' if percent > 0 else 'lower'}"


def errors_text(fp: Mapping[str, float]) -> str:
    """``"measured against the model: mode 1 2.0 % lower, …"``, or ``"no mode matched"``."""
    errors = [(k, get(fp, f"frequency_error_mode{k}")) for k in (1, 2, 3)]
    measured = [f"mode {k} {difference_words(100 * e)}" for k, e in errors if math.isfinite(e)]
    return f"measured against the model: {', '.join(measured)}" if measured else "no mode matched"
