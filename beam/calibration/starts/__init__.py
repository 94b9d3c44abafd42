"""Starting points for the beam MAP that survive the multimodality of oscillation fitting.

An oscillator fitted from a frequency a few percent off on a long window converges to a wrong
local optimum (each cycle of phase error is a new basin). Each source of starts is one small
strategy object (:class:`~beam.calibration.starts.base.StartStrategy`):

- :class:`~beam.calibration.starts.nested.NestedStarts`: the sub-models' optima, the dropped
  effect barely on;
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
    "SEARCH_GAIN_NATS", "STRATA", "WALK_STEPS", "NestedStarts", "ScreenedDesign", "SearchedDesign", "ShortWindowStart",
    "SpectralStarts", "StartStrategy", "adds_damping_to_a_searched_submodel", "barely_on", "clip_inside_prior",
    "damped_away_starts", "design_points", "equivalent_linear_omega2", "forget_maps", "has_second_stage",
    "least_squares_coupling", "model_setup", "nested_starts", "prior_centres", "ridge_neighbours", "ridge_walk", "screened_design",
    "searched_design", "searched_map", "searched_starts", "spectral_guesses", "starting_points", "stratified_design",
    "window_spectrum",
]

#: The start strategies of every driven calibration, in the order their starts are tried.
DEFAULT_STRATEGIES: tuple[StartStrategy, ...] = (NestedStarts(), SpectralStarts(), ScreenedDesign(), SearchedDesign())


def starting_points(problem: Problem, setup: BeamCalibrationSetup, warm: Mapping[str, float] | None = None,
                    search: bool = True, engine=None,
                    strategies: Sequence[StartStrategy] | None = None) -> list[dict[str, float]]:
    """The starts of a driven calibration (natural units, physical parameters): the short-window
    MAP (or a caller's ``warm`` start in its place), then each strategy's starts in order; the
    second-stage strategies (``stage == "search"``) only with ``search``.

    Parameters
    ----------
    engine : Engine, optional
        Whose memory the nested starts read (default: the process's,
        :func:`beam.calibration.engine.default_engine`).
    strategies : sequence of StartStrategy, optional
        Default ``engine.strategies``.
    """
    from beam.calibration.engine import default_engine

    engine = engine or default_engine()
    strategies = engine.strategies if strategies is None else strategies
    by_strategy = [(s, s(problem, setup, engine)) for s in strategies if search or s.stage == "quick"]
    # the historical order: nested, then the rest (the short window refines the rest)
    nested = [start for s, starts in by_strategy if s.nested for start in starts]
    others = [start for s, starts in by_strategy if not s.nested for start in starts]
    if warm is not None:
        return [dict(warm)] + nested + others
    return ShortWindowStart()(setup, others) + nested + others


def forget_maps(engine=None) -> None:
    """Drop every optimum ``engine`` (default: the process's) remembers (benchmarks that time a
    cold calibration; tests)."""
    from beam.calibration.engine import default_engine

    (engine or default_engine()).forget()
