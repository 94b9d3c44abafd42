"""Null starts (:class:`NullStarts`): the optimum of every smaller model the engine remembers on the
same record, window, modes and likelihood, with the larger model's new parameters at their null
values; and the guard that keeps the best of them when the search ends lower
(:func:`kept_nested`). Together they make nested fits monotone: a model's MAP log posterior is at
least that of each remembered sub-model embedded in it.

**Null values.** Every effect parameter of the catalogue has a log prior on a positive range, so
the exact null (zero; a rigid clamp's infinite stiffness) lies outside the support: the null value
is the prior's bound at the end where the effect vanishes
(:attr:`beam.physics.effects.ParameterSpec.absent_at`), :data:`NULL_MARGIN` inside it. There the
effect is negligible but not exactly absent, and the embedded point's log posterior differs from
the sub-model's by the new parameters' prior log density (a constant, -log log(high/low) for a
log-uniform prior) and by that residual effect.
"""

from __future__ import annotations

import numpy as np

from beam.calibration.setup import BeamCalibrationSetup
from beam.calibration.nulls import NULL_MARGIN, null_value
from beam.calibration.starts.base import StartStrategy
from beam.inference import MapResult, Problem

__all__ = ["NULL_MARGIN", "NULL_STARTS_KEPT", "NullStarts", "kept_nested", "null_starts", "null_value"]

#: Null starts kept (the best by log posterior in the larger model).
NULL_STARTS_KEPT = 2
#: Relative log posterior gain by which an embedded sub-model's optimum must beat the search's end
#: for :func:`kept_nested` to search again from it.
KEPT_TOLERANCE = 1e-9


def _embedded(problem: Problem, found: MapResult, names) -> dict[str, float]:
    """``found`` (a sub-model's optimum) in ``problem``'s parameters ``names``: the new ones at
    :func:`null_value`, the others clipped into their priors' supports."""
    values = {}
    for name in names:
        if name in found.values:
            prior = problem.parameter(name).prior
            values[name] = float(np.clip(found.values[name], prior.lower * (1 + NULL_MARGIN),
                                         prior.upper * (1 - NULL_MARGIN)))
        else:
            values[name] = null_value(problem, name)
    return values


def _embedded_optima(problem: Problem, setup: BeamCalibrationSetup, engine,
                     keep: int) -> tuple[list[dict[str, float]], np.ndarray]:
    """The ``keep`` best embedded sub-model optima (every parameter, noise included) and their log
    posteriors in ``problem``, best first."""
    subs = engine.submodels(setup) if engine is not None else []
    points = [_embedded(problem, found, problem.names) for _, found in subs]
    if not points:
        return [], np.empty(0)
    from beam.calibration.fit import internal_starts

    with np.errstate(all="ignore"):
        scores = problem.log_posterior(internal_starts(problem, points))
    scores = np.where(np.isfinite(scores), scores, -np.inf)
    order = np.argsort(-scores, kind="stable")[:keep]
    return [points[i] for i in order], scores[order]


def null_starts(problem: Problem, setup: BeamCalibrationSetup, engine,
                keep: int = NULL_STARTS_KEPT) -> list[dict[str, float]]:
    """The remembered sub-models' optima (``engine``'s :meth:`~beam.calibration.engine.Engine.submodels`)
    embedded in ``setup``'s model, their new parameters at :func:`null_value`: the ``keep`` with the
    highest log posterior in ``problem`` (natural units, physical parameters)."""
    points, _ = _embedded_optima(problem, setup, engine, keep)
    return [{name: point[name] for name in setup.physical_names} for point in points]


def kept_nested(problem: Problem, setup: BeamCalibrationSetup, found: MapResult, engine) -> MapResult:
    """``found``, or, when an embedded remembered sub-model's optimum (:func:`null_starts`) has a
    higher log posterior, the MAP searched from it alone (the better of the two): a search that
    ended below a sub-model's optimum keeps that optimum."""
    points, scores = _embedded_optima(problem, setup, engine, 1)
    if not points or not scores[0] > found.log_posterior + KEPT_TOLERANCE * abs(found.log_posterior):
        return found
    again = setup.calibration.search(problem, points)  # the model's own search (a free decay's joint least squares)
    return again if again.log_posterior > found.log_posterior else found


class NullStarts(StartStrategy):
    """The remembered sub-models' optima with the new parameters at their null values (:func:`null_starts`)."""

    name = "null"
    nested = True

    def __call__(self, problem, setup, engine):
        return null_starts(problem, setup, engine)
