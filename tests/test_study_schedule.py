"""The order of a study's cells on the workers (``beam.study.schedule``): longest expected first, the
a-priori cost model's structure, the correction by stored cells' seconds, and the submission order on
a real (in-process) Dask cluster."""

from __future__ import annotations

import pytest

from beam.calibration import calibrate
from beam.study import study_cells
from beam.study.cells import record_fingerprint
from beam.study.engine import stream_cells
from beam.study.schedule import (AR1_EXTRA, PREVIEW_STEPS, STEP_OVERHEAD, ar1_step_factor, expected_cost,
                                 rescaled_costs, submission_order)
from dashboard.jobs.beam import load_bundled

EFFECTS = [("air_damping", "kelvin_voigt")]


@pytest.fixture(scope="module")
def lab1():
    return load_bundled("lab_run_1")


def test_ar1_costs_more_steps_on_a_window_of_few_periods_and_the_same_on_a_long_one():
    factors = [ar1_step_factor(p) for p in (0.5, 2, 5, 10, 40, 1000)]
    assert factors == sorted(factors, reverse=True)
    assert factors[0] == pytest.approx(1 + AR1_EXTRA, rel=1e-3)
    assert ar1_step_factor(5.0) == pytest.approx(1 + AR1_EXTRA / 2)  # the extra halves at AR1_PERIODS
    assert factors[-1] == pytest.approx(1.0, abs=1e-6)


def test_the_default_study_of_lab_run_1_sends_the_short_ar1_windows_first(lab1):
    """The cell that took 10x the median (AR(1) on the shortest window: 6,234 ensemble steps with seed 0,
    against 132-552 for the i.i.d. cells) is sent first; among i.i.d. cells, the longer windows first."""
    cells = [c for _, c in study_cells([("lab_run_1", lab1)], None, EFFECTS, ["iid", "ar1"])]
    order = submission_order({c: expected_cost(c, lab1) for c in cells})
    shortest = min(c.window[1] for c in cells)
    assert (order[0].likelihood, order[0].window[1]) == ("ar1", shortest)
    iid = [c.window[1] for c in order if c.likelihood == "iid"]
    assert iid == sorted(iid, reverse=True)


def test_with_given_steps_the_cost_is_the_evaluations_times_the_work_per_evaluation(lab1):
    """Fixed steps: no likelihood factor; the cost grows with the window's samples x modes as the model
    says (the record's sample count, and the walkers the engine uses for that cell's parameters)."""
    cells = {c.likelihood + str(c.window): c for _, c in study_cells([("lab_run_1", lab1)], [(0.0, 0.5), (0.0, 1.5)],
                                                                       EFFECTS, ["iid", "ar1"], modes=3, steps=200)}
    assert len(cells) == 4
    t = lab1.time_s
    for key, cell in cells.items():
        samples = int(((t >= cell.window[0]) & (t <= cell.window[1])).sum())
        options = {**cell.calibration_options(), "steps": 10}
        walkers = calibrate(lab1, **options).posterior.diagnostics.n_walkers  # the engine's own ensemble
        want = walkers * (200 + PREVIEW_STEPS) * (STEP_OVERHEAD + 3 * samples)
        assert expected_cost(cell, lab1) == pytest.approx(want), key


def test_stored_seconds_rescale_each_likelihood():
    """Stored AR(1) cells took 4 s per expected unit, i.i.d. ones 1 s: the pending cells' costs become
    seconds with those ratios (medians), and the order follows."""
    lab = load_bundled("lab_run_2")
    cells = [c for _, c in study_cells([("lab_run_2", lab)], [(0.0, 0.5), (0.0, 1.0), (0.0, 2.0)], EFFECTS,
                                       ["iid", "ar1"], modes=3, steps=100)]
    stored, pending = cells[:4], cells[4:]  # 0-0.5 and 0-1 stored; 0-2 pending
    cost = {c: expected_cost(c, lab) for c in cells}
    recorded = [(c, cost[c], cost[c] * (4.0 if c.likelihood == "ar1" else 1.0)) for c in stored]
    recorded.append((stored[0], cost[stored[0]], None))  # a cell without seconds is ignored
    scaled = rescaled_costs({c: cost[c] for c in pending}, recorded)
    iid, ar1 = pending
    assert scaled[iid] == pytest.approx(cost[iid]) and scaled[ar1] == pytest.approx(4.0 * cost[ar1])
    assert submission_order(scaled)[0] is ar1
    only_iid = rescaled_costs({ar1: cost[ar1]}, [r for r in recorded if r[0].likelihood == "iid" and r[2]])
    assert only_iid[ar1] == pytest.approx(cost[ar1])  # a likelihood without stored cells: the median of all (1 here)
    assert rescaled_costs({ar1: 7.0}, []) == {ar1: 7.0}


def test_submission_order_is_highest_first_and_stable_on_ties():
    cells = [c for _, c in study_cells([("lab_run_2", load_bundled("lab_run_2"))], [(0, 0.5), (0, 1), (0, 1.5)],
                                       EFFECTS, ["iid"], modes=2, steps=10)]
    assert submission_order({cells[0]: 1.0, cells[1]: 3.0, cells[2]: 1.0}) == [cells[1], cells[0], cells[2]]


def test_the_cluster_starts_the_cells_in_the_order_of_their_costs():
    """One worker thread: the cells start in decreasing given cost, whatever the study's order, and
    every cell comes back once."""
    from distributed import Client

    from beam.inference._arviz import import_arviz

    import_arviz()
    m = load_bundled("lab_run_2")
    cells = [c for _, c in study_cells([("lab_run_2", m)], [(0.0, 0.3), (0.0, 0.4), (0.0, 0.5), (0.0, 0.6)],
                                       EFFECTS, ["iid"], modes=2, steps=10)]
    costs = {cells[0]: 2.0, cells[1]: 4.0, cells[2]: 1.0, cells[3]: 3.0}
    with Client(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=None) as client:
        out = list(stream_cells(client, {record_fingerprint(m): m}, cells, costs=costs))
    assert sorted(c.window for c, _ in out) == sorted(c.window for c in cells)
    assert all(o["row"]["error"] is None for _, o in out)
    started = [c for c, o in sorted(out, key=lambda co: co[1]["task"]["start"])]
    assert started == [cells[1], cells[3], cells[0], cells[2]]
