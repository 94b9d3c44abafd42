"""Starting points for the beam MAP that survive the multimodality of oscillation fitting.

An oscillator fitted from a frequency a few percent off on a long window converges to a wrong
local optimum (each cycle of phase error is a new basin). Each source of starts is one small
strategy object (:class:`~beam.calibration.starts.base.StartStrategy`):

- :class:`~beam.calibration.starts.nested.NestedStarts`: the sub-models' optima, the dropped
  effect barely on;
- :class:`~beam.calibration.starts.null.NullStarts`: every sub-model's optimum the engine
  remembers, the new parameters at their null values (with the guard
  :func:`~beam.calibration.starts.null.kept_nested`, nested fits are monotone);
- :class:`~beam.calibration.starts.spectral.SpectralStarts`: EI matched to the window's
  spectral peaks, k_p by least squares;
- :class:`~beam.calibration.starts.design.ScreenedDesign`: the best points of a Sobol design over
  the effect parameters;
- :class:`~beam.calibration.starts.search.SearchedDesign` (second stage): the stratified design
  over EI and the mode-changing parameters, searched by a short race, and the damped-away
  starts of modal damping;

and :class:`~beam.calibration.starts.spectral.ShortWindowStart` refines the non-nested ones on the
first third of the window. :func:`starting_points` composes them in that order (the one start
strategy of every driven calibration); the second stage is
:func:`~beam.calibration.starts.search.searched_map`. The starts depend only on the record,
window, modes, effects, likelihood and the optima the engine holds. Why each exists, with the
measurements behind it: the design decisions page.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from beam.calibration.setup import BeamCalibrationSetup
from beam.calibration.starts.base import (
    BARELY_ON,
    BASE_NAMES,
    DAMPED_AWAY,
    SCALE_GRID,
    StartStrategy,
    barely_on,
    clip_inside_prior,
    model_setup,
    prior_centres,
)
from beam.calibration.starts.design import (
    DESIGN_KEPT,
    DESIGN_POINTS,
    STRATA,
    ScreenedDesign,
    design_points,
    screened_design,
    searched_design,
    stratified_design,
)
from beam.calibration.starts.nested import NestedStarts, nested_starts
from beam.calibration.starts.null import NullStarts, kept_nested, null_starts, null_value
from beam.calibration.starts.ridge import WALK_STEPS, ridge_neighbours, ridge_walk
from beam.calibration.starts.search import (
    SEARCH_GAIN_NATS,
    SearchedDesign,
    adds_damping_to_a_searched_submodel,
    damped_away_starts,
    has_second_stage,
    searched_map,
    searched_starts,
)
from beam.calibration.starts.spectral import (
    ShortWindowStart,
    SpectralStarts,
    equivalent_linear_omega2,
    least_squares_coupling,
    spectral_guesses,
    window_spectrum,
)
from beam.inference import Problem

__all__ = [
    "BARELY_ON", "BASE_NAMES", "DAMPED_AWAY", "DEFAULT_STRATEGIES", "DESIGN_KEPT", "DESIGN_POINTS", "SCALE_GRID",
    "SEARCH_GAIN_NATS", "STRATA", "WALK_STEPS", "NestedStarts", "NullStarts", "ScreenedDesign", "SearchedDesign", "ShortWindowStart",
    "SpectralStarts", "StartStrategy", "adds_damping_to_a_searched_submodel", "barely_on", "clip_inside_prior",
    "damped_away_starts", "design_points", "equivalent_linear_omega2", "has_second_stage",
    "kept_nested", "least_squares_coupling", "model_setup", "nested_starts", "null_starts", "null_value", "prior_centres", "ridge_neighbours", "ridge_walk", "screened_design",
    "searched_design", "searched_map", "searched_starts", "spectral_guesses", "starting_points", "stratified_design",
    "window_spectrum",
]

#: The start strategies of every driven calibration, in the order their starts are tried.
DEFAULT_STRATEGIES: tuple[StartStrategy, ...] = (NestedStarts(), NullStarts(), SpectralStarts(), ScreenedDesign(),
                                                  SearchedDesign())


def starting_points(problem: Problem, setup: BeamCalibrationSetup, warm: Mapping[str, float] | None = None,
                    search: bool = True, *, engine,
                    strategies: Sequence[StartStrategy] | None = None) -> list[dict[str, float]]:
    """The starts of a driven calibration (natural units, physical parameters): the short-window
    MAP (or a caller's ``warm`` start in its place), then each strategy's starts in order; the
    second-stage strategies (``stage == "search"``) only with ``search``.

    Parameters
    ----------
    engine : Engine
        Whose memory the nested and null starts read (:class:`beam.calibration.engine.Engine`).
    strategies : sequence of StartStrategy, optional
        Default ``engine.strategies``.
    """
    strategies = engine.strategies if strategies is None else strategies
    by_strategy = [(s, s(problem, setup, engine)) for s in strategies if search or s.stage == "quick"]
    # the nested starts first, then the others (which the short window refines)
    nested = [start for s, starts in by_strategy if s.nested for start in starts]
    others = [start for s, starts in by_strategy if not s.nested for start in starts]
    if warm is not None:
        return [dict(warm)] + nested + others
    return ShortWindowStart()(setup, others) + nested + others
