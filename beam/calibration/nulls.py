"""Where an effect vanishes: the null value of a parameter inside its prior's support.

A leaf of :mod:`beam.calibration` (it imports no calibration module), so that both the start
strategies (:mod:`beam.calibration.starts.null`) and the nonlinear free-decay fit
(:mod:`beam.calibration.free_nonlinear`) can put a new parameter at its null value without an
import cycle through the setup.
"""

from __future__ import annotations

from beam.inference import Problem

__all__ = ["NULL_MARGIN", "null_value"]

#: Relative distance of a null value inside its prior's bound (the bound itself is not in the support).
NULL_MARGIN = 1e-9


def null_value(problem: Problem, name: str) -> float:
    """The value (natural units) at which ``name``'s effect vanishes, within its prior's support:
    the bound at its :attr:`~beam.physics.effects.ParameterSpec.absent_at` end, :data:`NULL_MARGIN`
    inside."""
    from beam.physics.effects import parameter_spec

    prior = problem.parameter(name).prior
    if parameter_spec(name).absent_at == "centre":  # exactly absent there (the stated free length)
        return float(prior.from_internal(prior.internal_centre()))
    if parameter_spec(name).absent_at == "low":
        return float(prior.lower * (1 + NULL_MARGIN))
    return float(prior.upper * (1 - NULL_MARGIN))
