"""The second stage of every driven MAP (:func:`searched_map`): the searched stratified design
(:class:`SearchedDesign`, with the damped-away starts of modal damping) together with the first
stage's MAP, then the walk along the ridge. The first stage's MAP stands unless beaten by
:data:`SEARCH_GAIN_NATS`."""

from __future__ import annotations

import numpy as np

from beam.calibration.fit import fast_map
from beam.calibration.setup import BeamCalibrationSetup, build_problem
from beam.calibration.spec import DEFAULT_EFFECTS
from beam.calibration.starts.base import (
    DAMPED_AWAY,
    SEARCH_GAIN_NATS,
    StartStrategy,
    barely_on,
    clip_inside_prior,
    damping_only,
    effect_names,
    log_range,
    model_setup,
    pure_damping_parameter,
)
from beam.calibration.starts.design import searched_design, stratified_design
from beam.calibration.starts.ridge import ridge_walk
from beam.calibration.starts.spectral import spectral_guesses
from beam.inference import MapResult, Problem
from beam.physics.effects import modal_damping
from beam.physics.effects.base import PATCH_COUPLING

__all__ = ["SEARCH_GAIN_NATS", "SearchedDesign", "adds_damping_to_a_searched_submodel", "damped_away_starts",
           "has_second_stage", "searched_map", "searched_starts"]




def searched_starts(problem: Problem, setup: BeamCalibrationSetup) -> list[dict[str, float]]:
    """The ends of the searched stratified design (step 6 of the module notes; empty for a model
    whose effects only damp), then, with modal damping, the damped-away starts
    (:func:`damped_away_starts`, step 8)."""
    strata = stratified_design(problem, setup)
    return (searched_design(problem, strata) if strata else []) + damped_away_starts(problem, setup)


def damped_away_starts(problem: Problem, setup: BeamCalibrationSetup) -> list[dict[str, float]]:
    """Starts of a driven model with modal damping that damp its upper modes away (step 8 of the
    module notes): for each count ``k`` of kept modes below the retained ``M``, the MAP of the
    model without modal damping on its first ``k`` modes only (its searched stratified design
    and spectral starts, one lock-step search), with the damping ratios of modes ``k+1..M``
    :data:`DAMPED_AWAY` of their log range from the top and those of modes ``1..k`` barely on.

    With modal damping the model nests the model of its other effects with fewer modes (a mode
    damped at the prior's top adds almost nothing), and a fit that need not follow the upper
    modes can put the lower ones elsewhere: the random clamp record of the global-mode sample,
    20 % window, tip mass + patch stiffening + modal damping (4 modes), whose best optimum damps
    modes 3-4 away under a 12 g tip mass and a stiff patch, 91 nats above the engine's MAP
    without these starts, which followed all four modes with a 1.3 g tip mass and no patch; the
    2-mode fit reaches it, the 1- and 3-mode fits do not, and the upper modes' frequencies do
    not say which ``k`` (the engine's MAP put modes 3-4 within 1 % of the record's peaks), so
    every ``k`` is tried. Damped-away copies of the design points of the full model reach it
    only when searched to convergence (7 of 284 points), not through the race. Cost: one
    searched design of a smaller model per ``k`` (0.7-0.9 s each on that record, 4 modes)."""
    modal = modal_damping.EFFECT.id
    if modal not in setup.effects or PATCH_COUPLING.name not in setup.physical_names or setup.modes < 2:
        return []
    others = tuple(e for e in setup.effects if e != modal)
    ratios = [n for n in setup.physical_names if modal_damping.ratio_mode(n) is not None]
    out = []
    for kept in range(1, setup.modes):
        sub = model_setup(setup, others, kept)
        sub_problem = build_problem(sub)
        found = fast_map(sub_problem, spectral_guesses(sub_problem, sub) + searched_starts(sub_problem, sub))
        guess = {name: float(found.values[name]) for name in sub.physical_names}
        for name in ratios:
            low, high = log_range(problem, name)
            away = modal_damping.ratio_mode(name) > kept
            guess[name] = float(np.exp(high - DAMPED_AWAY * (high - low))) if away else barely_on(problem, name)
        out.append(clip_inside_prior(problem, guess))
    return out


def searched_map(problem: Problem, setup: BeamCalibrationSetup, quick: MapResult, strategies=None,
                 engine=None) -> MapResult | None:
    """The second stage of every beam MAP: the search from the second-stage ``strategies``' starts
    (default :class:`SearchedDesign`: :func:`searched_starts`) together with the quick stage's MAP
    ``quick``, then the walk along
    the ridge of equal frequencies from the better of the two (:func:`ridge_walk`); the MAP
    reached when it beats ``quick`` by :data:`SEARCH_GAIN_NATS`, else None (``quick`` stands, to
    the last digit).

    None at once for a model that adds a pure damping effect (not the default damping) to one
    that changes the modes: the quick stage started it from that sub-model's MAP
    (:func:`nested_starts`), whose own searched design stratified the same mode-changing
    parameters; the damping moves no basin. Measured: lab_run_1's revealed model (patch
    stiffening + patch damping) 3.8 s cold, of which the redundant searched design took ~0.8 s.
    """
    if adds_damping_to_a_searched_submodel(setup):
        return None
    best = quick
    strategies = (SearchedDesign(),) if strategies is None else strategies
    extra = [start for strategy in strategies for start in strategy(problem, setup, engine)]
    if extra:
        current = {name: float(v) for name, v in quick.values.items() if name in setup.physical_names}
        found = fast_map(problem, [current] + extra)
        if found.log_posterior > quick.log_posterior + SEARCH_GAIN_NATS:
            best = found
    best = ridge_walk(problem, setup, best) or best
    return best if best is not quick else None


def has_second_stage(setup: BeamCalibrationSetup) -> bool:
    """Whether :func:`searched_map` can move the quick stage's MAP of this model: a driven model
    (a free response's starts are projected, see :mod:`beam.calibration.free_starts`) with an effect
    that changes the modes, not one that only adds damping to such a sub-model."""
    if PATCH_COUPLING.name not in setup.physical_names or adds_damping_to_a_searched_submodel(setup):
        return False
    return any(not pure_damping_parameter(name) for name in effect_names(setup))


def adds_damping_to_a_searched_submodel(setup: BeamCalibrationSetup) -> bool:
    """Whether the model has a pure damping effect besides the default damping and an effect that
    changes the modes (then :func:`nested_starts` starts it from the two-stage MAP of the model
    without that damping effect)."""
    extra_damping = any(damping_only(e) and e not in DEFAULT_EFFECTS for e in setup.effects)
    return extra_damping and not all(damping_only(e) for e in setup.effects)


class SearchedDesign(StartStrategy):
    """The searched stratified design and the damped-away starts (:func:`searched_starts`): the
    second stage's starts (none for a model that adds a pure damping effect to a mode-changing one,
    :func:`adds_damping_to_a_searched_submodel`)."""

    name = "searched design"
    stage = "search"

    def __call__(self, problem, setup, engine):
        return [] if adds_damping_to_a_searched_submodel(setup) else searched_starts(problem, setup)
