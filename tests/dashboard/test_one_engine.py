"""One calibration engine: the command line, the dashboard's state objects and the diagnosis's
candidates reach the same MAP for the same record, window, modes, effects, likelihood and seed."""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import numpy as np

from beam.cli.main import main
from beam.discovery.ranking import rank_candidates
from beam.io.measurement import read_measurement
from dashboard.state.session import SessionState

CSV = Path(__file__).resolve().parents[2] / "assets" / "measurements" / "lab_run_1.csv"
WINDOW = (0.0, 1.05)
BASE = ("air_damping", "kelvin_voigt")
ADDED = "patch_stiffening"


def cli_map(effects: tuple[str, ...]) -> dict[str, float]:
    """The MAP that ``beam calibrate --json`` reports (a short MCMC run: the MAP precedes it)."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        status = main(["calibrate", str(CSV), "--window", f"{WINDOW[0]}:{WINDOW[1]}", "--effects", ",".join(effects),
                       "--modes", "4", "--likelihood", "iid", "--seed", "3", "--steps", "20", "--json"])
    assert status == 0
    return json.loads(out.getvalue())["map"]


def assert_same_map(a: dict[str, float], b: dict[str, float]) -> None:
    assert a.keys() == b.keys()
    for name in a:
        assert np.isclose(a[name], b[name], rtol=1e-6, atol=0.0), (name, a[name], b[name])


def test_cli_dashboard_and_diagnosis_candidates_share_one_map(pool):
    effects = (*BASE, ADDED)
    from_cli = cli_map(effects)

    session = SessionState(pool=pool, debounce_s=0.0, beam_inputs={"target_ess": 50.0})
    try:
        beam = session.beam
        previews = []
        beam.param.watch(lambda e: previews.append(e.new) if e.new.is_preview else None, "result")
        beam.param.update(window_s=WINDOW, effects=list(effects), likelihood="iid", modes=4, seed=3)
        beam.request(debounce=False)
        assert session.wait(120), "the dashboard's calibration did not finish"
        assert beam.error == ""
        shown = previews[-1]
        assert shown.setup.effects == effects and shown.setup.window == WINDOW
        assert_same_map(from_cli, shown.laplace.map.values)
        assert_same_map(from_cli, beam.final.laplace.map.values)  # the final result keeps the preview's MAP
    finally:
        session.close()
        session.wait(30)

    # the diagnosis's candidate (and first ladder rung) base + patch_stiffening
    ranking = rank_candidates(read_measurement(CSV), base=BASE, window=WINDOW, modes=4, candidates=[ADDED])
    assert_same_map(from_cli, ranking.results[ADDED].laplace.map.values)
    # and it is the good optimum: near the noise (15 µm) where the wrong one was 548 µm
    assert ranking.results[ADDED].rmse_prediction_map < 1e-4
