"""The order in which a study's cells are sent to the workers: longest expected first.

With more cells than workers the study ends when its last cell ends; sending the cells in
decreasing expected time (longest processing time first) lets the short ones fill the workers at
the end instead of a long one running alone. :func:`expected_cost` is an a-priori model of a
cell's compute time from what is known before it runs; :func:`rescaled_costs` corrects it with
the seconds that stored cells of the same study actually took (a resumed study).

The model (relative units; only the order and the ratios between cells matter)::

    cost = walkers x (steps + PREVIEW_STEPS) x (STEP_OVERHEAD + samples x modes)

- ``samples``: the record's samples in the window; ``modes``: the cell's modes (``auto`` is only
  known once the window's spectrum is read: :data:`AUTO_MODES`); ``walkers``: the engine's
  default for the cell's parameter count (:func:`beam.calibration.run.default_walkers`).
- ``STEP_OVERHEAD``: the per-walker cost of a step that does not grow with the data (the
  ensemble's moves, the proposal, the likelihood's set-up), in sample x mode units.
- ``steps``: :data:`BASE_STEPS` for the i.i.d. likelihood; for AR(1) times
  :func:`ar1_step_factor` of the window's length in periods of the nominal fundamental. On a window
  of a few periods the AR(1) noise can take up part of the response (coefficient near 1), damping
  is then weakly identified and the sampler needs many more steps to reach the target ESS. Whether
  that happens depends on the record's model discrepancy, which is not known before the cell runs;
  the factor is the expected one.

The figures behind the constants are on the decisions page.
"""

from __future__ import annotations

import statistics
from collections.abc import Iterable, Mapping
from functools import lru_cache

import numpy as np

from beam.io.measurement import Measurement
from beam.study.cells import StudyCell

__all__ = ["AR1_EXTRA", "AR1_PERIODS", "AUTO_MODES", "BASE_STEPS", "PREVIEW_STEPS", "STEP_OVERHEAD",
           "ar1_step_factor", "expected_cost", "rescaled_costs", "submission_order"]

#: Modes assumed for ``modes="auto"`` (the engine retained 3-7 on lab records of a few seconds).
AUTO_MODES = 6
#: Per-walker step cost that does not grow with samples x modes, in sample x mode units (measured: a step
#: of 48 walkers took ~7 ms at 350 samples x 3 modes and ~17 ms at 1,750 x 7 on one core).
STEP_OVERHEAD = 8500.0
#: Ensemble steps of an i.i.d. cell sampling to the target ESS (the engine's first chunk and a
#: second one; 132-552 measured).
BASE_STEPS = 300.0
#: The MAP search and Laplace preview before sampling, in step equivalents.
PREVIEW_STEPS = 60.0
#: Largest expected extra steps of an AR(1) cell over an i.i.d. one (factor - 1, short windows). Measured on
#: windows of about 2 periods: 0.8x, 11x and 150x (step cap) the i.i.d. steps on three records; 6 ranks such
#: windows first without claiming the worst case.
AR1_EXTRA = 5.0
#: Window length (periods of the nominal fundamental) at which the AR(1) extra has halved.
AR1_PERIODS = 5.0


def ar1_step_factor(periods: float) -> float:
    """Expected ensemble steps of an AR(1) cell over an i.i.d. one, for a window of ``periods``
    periods of the nominal fundamental (dimensionless, > 0): from ``1 + AR1_EXTRA`` on a window of
    a period or two down to 1 on a long window (``1 + AR1_EXTRA / (1 + (periods / AR1_PERIODS)**4)``)."""
    return 1.0 + AR1_EXTRA / (1.0 + (max(float(periods), 0.0) / AR1_PERIODS) ** 4)


@lru_cache(maxsize=256)
def _model_facts(geometry, effects: tuple[str, ...], input_kind, nominal_items: tuple, modes: int) -> tuple[int, float]:
    """(model parameters, nominal fundamental in Hz; NaN if it cannot be computed) of a record's model."""
    from beam.calibration.setup import prior_centre
    from beam.physics.model import BeamModel

    model = BeamModel(geometry, effects, input_kind=input_kind)
    names = model.parameter_names_for(min(modes, model.size))
    nominal = dict(nominal_items)
    try:
        frequencies, _ = model.natural_modes({name: prior_centre(name, nominal) for name in names}, 1)
        fundamental = float(frequencies[0])
    except Exception:  # noqa: BLE001 - a model without nominal values: no period count, the long-window factor
        fundamental = float("nan")
    return len(names), fundamental


def expected_cost(cell: StudyCell, record: Measurement) -> float:
    """A-priori compute cost of ``cell`` on ``record`` (relative units, > 0): see the module notes.

    Parameters
    ----------
    cell : StudyCell
        The cell (window in s, effects, likelihood, modes, steps, walkers).
    record : Measurement
        Its record.

    Returns
    -------
    float
        Proportional to the expected seconds; only comparisons between cells are meaningful.
    """
    from beam.calibration.run import default_walkers

    t = np.asarray(record.time_s, dtype=float)
    start, end = cell.window
    samples = int(np.count_nonzero((t >= start - 1e-12) & (t <= end + 1e-12)))
    modes = cell.modes if isinstance(cell.modes, int) and not isinstance(cell.modes, bool) else AUTO_MODES
    nominal = getattr(record, "prior_nominal", None) or {}
    try:
        n_model, fundamental = _model_facts(record.geometry, tuple(cell.effects), record.input_kind,
                                            tuple(sorted(nominal.items())), int(modes))
    except Exception:  # noqa: BLE001 - a cell the engine will reject: it fails fast, any cost will do
        n_model, fundamental = 2 + len(cell.effects), float("nan")
    n_parameters = n_model + 1 + (cell.likelihood == "ar1")  # + the noise sd (+ the AR(1) coefficient)
    walkers = cell.walkers or default_walkers(n_parameters)
    if cell.steps is not None:
        steps = float(cell.steps)
    else:
        steps = BASE_STEPS
        if cell.likelihood == "ar1":
            periods = (end - start) * fundamental if np.isfinite(fundamental) else np.inf
            steps *= ar1_step_factor(periods)
    return float(walkers * (steps + PREVIEW_STEPS) * (STEP_OVERHEAD + max(samples, 1) * modes))


def rescaled_costs(costs: Mapping[StudyCell, float],
                   recorded: Iterable[tuple[StudyCell, float, float]]) -> dict[StudyCell, float]:
    """``costs`` corrected by the seconds stored cells took: each likelihood's costs times the
    median ratio of measured seconds to expected cost over the stored cells of that likelihood.

    Parameters
    ----------
    costs : mapping of StudyCell to float
        Expected costs (:func:`expected_cost`) of the cells to run.
    recorded : iterable of (StudyCell, expected cost, seconds)
        Stored cells: their expected cost and the compute seconds they took (s, > 0).

    Returns
    -------
    dict
        The cells' costs, in seconds where a ratio is known. A likelihood without stored cells
        takes the median ratio of all stored cells; without any, ``costs`` unchanged.
    """
    ratios: dict[str, list[float]] = {}
    for cell, cost, seconds in recorded:
        if cost > 0 and seconds is not None and seconds > 0:
            ratios.setdefault(cell.likelihood, []).append(seconds / cost)
    if not ratios:
        return dict(costs)
    overall = statistics.median(r for group in ratios.values() for r in group)
    scale = {likelihood: statistics.median(group) for likelihood, group in ratios.items()}
    return {cell: cost * scale.get(cell.likelihood, overall) for cell, cost in costs.items()}


def submission_order(costs: Mapping[StudyCell, float]) -> list[StudyCell]:
    """The cells, highest cost first (ties: in the given order)."""
    cells = list(costs)
    return [cells[i] for i in sorted(range(len(cells)), key=lambda i: -costs[cells[i]])]
