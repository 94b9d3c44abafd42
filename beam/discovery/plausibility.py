"""Whether a calibrated effect is physically this effect: its parameters against their priors, the
values the literature finds, and what the user stated.

A candidate that fits the data with a parameter no such effect has is **not this effect**: the
fit used the effect's freedom to absorb something else. Each parameter of the candidate's own
(its :class:`~beam.physics.effects.effect.ParameterSpec`) is checked at the fit's MAP, in order:

1. **at a prior bound** (:attr:`beam.inference.MapResult.at_bound`): at the end where the effect
   vanishes (``absent_at``), the fit switched the effect off; at the other end, the data push it
   beyond every value the prior allows;
2. **against what the record states** (its ``[nominal]`` value, e.g. the sensor's weighed mass):
   more than :data:`STATED_SIGMAS` of the statement's log standard deviation away, and at least a
   factor :data:`STATED_MIN_FACTOR` (a weighed board still carries its cable and glue);
3. otherwise **against the plausible range** of its spec (``plausible``, counted in
   ``plausible_scale``: natural units, or the strip's EI / L, EI / L⁵ or rho L at the fit's EI and
   the record's stated length and density), whose sources are in the effect's module docstring.

:func:`implausible_parameters` returns the findings, each with its reason in words; an empty list
means the effect's values are plausible. :func:`bound_notes` says which *other* parameters of a
fit (the base's damping, say) sit on a bound, so that no "converged" claim stands beside them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from beam.calibration import CalibrationResult
from beam.physics.effects import EFFECTS, parameter_spec
from beam.physics.effects.base import BENDING_STIFFNESS

__all__ = ["Finding", "STATED_MIN_FACTOR", "STATED_SIGMAS", "bound_notes", "implausible_parameters",
           "plausible_range", "stated_range"]

#: A calibrated value more than this many of the statement's log sd from a stated value is not it ...
STATED_SIGMAS = 3.0
#: ... and never closer than this factor (a weighed mass is not known to 2 % once glued and wired).
STATED_MIN_FACTOR = 1.5


@dataclass(frozen=True)
class Finding:
    """One parameter of a fit that is not this effect's.

    Attributes
    ----------
    parameter : str
        Its public name.
    value : float
        Its MAP (natural units).
    kind : {"absent", "bound", "stated", "range"}
        Switched off (at the end where the effect vanishes), at the prior's other bound, against
        the stated value, outside the plausible range.
    reason : str
        One clause in words, with the numbers (e.g. ``"C_d = 42.7, outside 2–20 (…)"``).
    """

    parameter: str
    value: float
    kind: str
    reason: str

    def to_json(self) -> dict:
        return {"parameter": self.parameter, "value": self.value, "kind": self.kind, "reason": self.reason}


def _number(value: float) -> str:
    return f"{value:.3g}"


def _scale(kind: str | None, fit: CalibrationResult) -> float:
    """The unit of a :attr:`~beam.physics.effects.effect.ParameterSpec.plausible_scale` on this fit."""
    if kind is None:
        return 1.0
    geometry = fit.setup.measurement.geometry
    length = float(geometry.length_m)
    stiffness = float(fit.laplace.map.values.get(BENDING_STIFFNESS.name, math.nan))
    if kind == "EI/L":
        return stiffness / length
    if kind == "EI/L^5":
        return stiffness / length**5
    if kind == "rho L":
        return float(geometry.linear_density_kg_m) * length
    raise ValueError(f"unknown plausible scale {kind!r}")


#: How each scale is named in words.
_SCALE_WORDS = {"EI/L": "EI / L", "EI/L^5": "EI / L⁵", "rho L": "the strip's own mass ρL"}


def plausible_range(name: str, fit: CalibrationResult) -> tuple[float, float] | None:
    """The plausible range (natural units) of parameter ``name`` on ``fit``'s strip, None when its
    spec gives none."""
    spec = parameter_spec(name)
    if spec.plausible is None:
        return None
    unit = _scale(spec.plausible_scale, fit)
    return spec.plausible[0] * unit, spec.plausible[1] * unit


def stated_range(name: str, fit: CalibrationResult) -> tuple[float, float, float] | None:
    """``(stated, low, high)`` for a parameter the record states (``[nominal]``), None otherwise."""
    m = fit.setup.measurement
    stated = m.nominal.get(name)
    if stated is None or not stated > 0:
        return None
    spec = parameter_spec(name)
    spread = m.nominal_spread.get(name, spec.nominal_log_sd or 0.0)
    factor = max(math.exp(STATED_SIGMAS * float(spread)), STATED_MIN_FACTOR)
    return float(stated), float(stated) / factor, float(stated) * factor


def implausible_parameters(effect: str, fit: CalibrationResult) -> list[Finding]:
    """The parameters of ``effect`` (one of the fit's effects) that are not this effect's (module
    notes), each with its reason; empty when its values are plausible."""
    spec_of = EFFECTS[effect]
    values = fit.laplace.map.values
    at_bound = set(fit.laplace.map.at_bound)
    priors = {p.name: p.prior for p in fit.problem.parameters}
    findings = []
    for name in spec_of.required_parameter_names_for(fit.setup.modes):
        if name not in values:
            continue
        spec = spec_of.parameter(name)
        value = float(values[name])
        unit = "" if spec.unit == "1" else f" {spec.unit}"
        shown = f"{spec.symbol} = {_number(value)}{unit}"
        prior = priors.get(name)
        if name in at_bound and prior is not None:
            upper = abs(value - prior.upper) <= abs(value - prior.lower)
            absent = (spec.absent_at == "high") == upper if spec.absent_at in ("low", "high") else False
            bound = prior.upper if upper else prior.lower
            if absent:
                findings.append(Finding(name, value, "absent", f"{shown} sits where the effect vanishes (the end of "
                                        f"its prior, {_number(bound)}{unit}): the fit switched it off"))
            else:
                findings.append(Finding(name, value, "bound", f"{shown} sits at the {'upper' if upper else 'lower'} "
                                        f"bound of its prior ({_number(bound)}{unit}): the data push it beyond "
                                        "every value such an effect is given"))
            continue
        stated = stated_range(name, fit)
        if stated is not None:
            said, low, high = stated
            if not low <= value <= high:
                ratio = value / said
                findings.append(Finding(name, value, "stated", f"{shown} is {_number(ratio)} times the {_number(said)}"
                                        f"{unit} the record states (at most a factor {_number(high / said)} "
                                        "either way)"))
            continue
        plausible = plausible_range(name, fit)
        if plausible is not None and not plausible[0] <= value <= plausible[1]:
            findings.append(Finding(name, value, "range", f"{shown} is outside {_range_words(spec, plausible)}"))
    return findings


def _range_words(spec, plausible: tuple[float, float]) -> str:
    """``"2–20 (…what the literature finds)"`` in natural units, with the scaled range when it has one."""
    low, high = plausible
    unit = "" if spec.unit == "1" else f" {spec.unit}"
    if math.isinf(high):
        text = f"the plausible {_number(low)}{unit} and above"
    elif low <= 0.0:
        text = f"the plausible range (up to {_number(high)}{unit})"
    else:
        text = f"the plausible {_number(low)}–{_number(high)}{unit}"
    if spec.plausible_scale is not None:
        lo, hi = spec.plausible
        scale = _SCALE_WORDS[spec.plausible_scale]
        scaled = (f"{_number(lo)} {scale} and above" if math.isinf(hi) else
                  (f"at most {scale}" if hi == 1.0 else f"up to {_number(hi)} {scale}") if lo <= 0.0 else
                  f"{_number(lo)}–{_number(hi)} {scale}")
        text += f": {scaled} on this strip"
    return text


def bound_notes(fit: CalibrationResult) -> list[str]:
    """One clause per physical parameter of ``fit`` at a prior bound that is not at the end where
    its effect vanishes (:attr:`beam.calibration.CalibrationResult.pressed_parameters`: a damping the
    prior cannot make large enough, say): such a fit has not found the record's value of it,
    whatever its convergence diagnostics say."""
    values = fit.laplace.map.values
    out = []
    for name in fit.pressed_parameters:
        spec = parameter_spec(name)
        value, prior = float(values[name]), fit.problem.parameter(name).prior
        upper = abs(value - prior.upper) <= abs(value - prior.lower)
        out.append(f"{name} = {_number(value)} {spec.unit} sits at the {'upper' if upper else 'lower'} bound of its prior "
                   f"({_number(prior.upper if upper else prior.lower)} {spec.unit})")
    return out
