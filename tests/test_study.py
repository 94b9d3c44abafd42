"""``beam study`` end to end: the same numbers as ``beam calibrate``, a failed cell among good ones,
the tables, resume, several records, and the same table through a real Dask scheduler.

Kept cheap: two bundled records, windows of 0.5 and 1 s, 3 modes, 100 ensemble steps.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from beam.cli.main import main

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
OPTIONS = ["--modes", "3", "--steps", "100"]
STUDY = ["lab_run_1", "lab_run_2", "--windows", "0:0.5,0:1,5:6", *OPTIONS]  # 5-6 s lies past both records' ends
#: Keys of a cell that ``beam calibrate --json`` has too (study key -> calibrate key).
SHARED = {"window": "window_s", "effects": "effects", "likelihood": "likelihood", "rmse_calibration": "rmse_calibration",
          "rmse_prediction": "rmse_prediction", "coverage95_prediction": "coverage95_prediction",
          "parameters": "parameters", "ess_min": "ess_min", "rhat_max": "rhat_max"}


def environment() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k != "DASK_SCHEDULER_ADDRESS"}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])])
    return env


def study(args: list[str], cwd: Path) -> tuple[int, dict, str]:
    """Run ``beam study ARGS --json`` in a fresh process; returns status, the JSON, stderr."""
    proc = subprocess.run([sys.executable, "-m", "beam", "study", *args, "--json"], cwd=cwd, env=environment(),
                          capture_output=True, text=True, timeout=900)
    assert proc.stdout, proc.stderr
    return proc.returncode, json.loads(proc.stdout), proc.stderr


def close(a, b, rel=1e-9):
    """Equal numbers to ``rel`` (same process-independent computation), recursively through dicts and lists."""
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(close(a[k], b[k], rel) for k in a)
    if isinstance(a, list):
        return len(a) == len(b) and all(close(x, y, rel) for x, y in zip(a, b))
    if isinstance(a, float) and isinstance(b, float):
        return a == pytest.approx(b, rel=rel, abs=0.0)
    return a == b


def without_seconds(rows):
    return [{k: v for k, v in row.items() if k != "seconds"} for row in rows]


@pytest.fixture(scope="module")
def local(tmp_path_factory):
    """The study on a local cluster of two workers: (folder, status, JSON, stderr)."""
    folder = tmp_path_factory.mktemp("study-local")
    status, document, err = study([*STUDY, "--workers", "2", "--out", "run/s", "--report", "s.html"], folder)
    return folder, status, document, err


def test_every_cell_is_what_beam_calibrate_gives(local):
    _, _, document, _ = local
    cells = [c for c in document["cells"] if c["record"] == "lab_run_1" and c["error"] is None]
    assert [c["window"] for c in cells] == [[0.0, 0.5], [0.0, 1.0]]
    for cell in cells:
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            assert main(["calibrate", "lab_run_1", "--window", "{}:{}".format(*cell["window"]), *OPTIONS, "--json"]) == 0
        expected = json.loads(out.getvalue())
        for key, calibrate_key in SHARED.items():
            assert close(cell[key], expected[calibrate_key]), key
        assert list(cell) == ["record", "window", "effects", "likelihood", "rmse_calibration", "rmse_prediction",
                              "coverage95_prediction", "parameters", "ess_min", "rhat_max", "seconds", "error"]
        assert cell["seconds"] > 0


def test_a_failed_cell_is_reported_and_the_others_go_on(local):
    _, status, document, err = local
    failed = [c for c in document["cells"] if c["error"] is not None]
    assert status == 1
    assert [(c["record"], c["window"]) for c in failed] == [("lab_run_1", [5.0, 6.0]), ("lab_run_2", [5.0, 6.0])]
    assert all("outside the record" in c["error"] and c["rmse_prediction"] is None for c in failed)
    good = [c for c in document["cells"] if c["error"] is None]
    assert len(good) == 4 and all(0 < c["rmse_prediction"] < 0.01 and 0 <= c["coverage95_prediction"] <= 1 for c in good)
    assert len([line for line in err.splitlines() if line.startswith("[")]) == 6  # one progress line per cell


def test_the_tables_hold_the_cells_and_the_summary_across_records(local):
    folder, _, document, _ = local
    table = pd.read_csv(folder / "run" / "s.csv", keep_default_na=False, na_values=[""])
    assert list(table["record"]) == [c["record"] for c in document["cells"]]
    for row, cell in zip(table.itertuples(), document["cells"]):
        assert [row.window_start_s, row.window_end_s] == cell["window"]
        if cell["error"] is None:
            assert row.rmse_prediction == cell["rmse_prediction"]
            assert row.bending_stiffness_Nm2_q975 == cell["parameters"]["bending_stiffness_Nm2"]["q975"]
            assert 0 < row.width95_prediction < 0.05  # the band's width on the held-out part (m)
        else:
            assert row.error == cell["error"] and np.isnan(row.rmse_prediction)
    # across records: the median over records of each cell's RMSE over its record's best window
    summary = pd.read_csv(folder / "run" / "s.summary.csv")
    good = [c for c in document["cells"] if c["error"] is None]
    best = {r: min(c["rmse_prediction"] for c in good if c["record"] == r) for r in ("lab_run_1", "lab_run_2")}
    for index, window in enumerate([[0.0, 0.5], [0.0, 1.0]]):
        ratios = [c["rmse_prediction"] / best[c["record"]] for c in good if c["window"] == window]
        row = summary[summary["window_index"] == index].iloc[0]
        assert row["records"] == 2 and row["failed"] == 0
        assert row["rmse_prediction_relative_median"] == pytest.approx(np.median(ratios), rel=1e-12)
        assert row["coverage95_prediction_mean"] == pytest.approx(
            np.mean([c["coverage95_prediction"] for c in good if c["window"] == window]), rel=1e-12)
    assert summary[summary["window_index"] == 2].iloc[0]["failed"] == 2


def test_the_netcdf_holds_each_cells_posterior_draws(local):
    from beam.inference.results import load_inference_data

    folder, _, document, _ = local
    posterior = load_inference_data(folder / "run" / "s.nc").posterior
    assert posterior["bending_stiffness_Nm2"].dims == ("chain", "draw", "cell")
    assert list(posterior["record"].values) == [c["record"] for c in document["cells"]]
    for j, cell in enumerate(document["cells"]):
        draws = posterior["bending_stiffness_Nm2"].values[0, :, j]
        if cell["error"] is not None:
            assert np.isnan(draws).all()
            continue
        stats = cell["parameters"]["bending_stiffness_Nm2"]
        # 1,000 of the cell's draws: their mean within 0.25 posterior sd of the mean of all draws
        assert abs(np.mean(draws) - stats["mean"]) < 0.25 * stats["sd"]
        assert stats["q025"] < np.median(draws) < stats["q975"]


def test_the_report_draws_the_study(local):
    folder, _, _, _ = local
    text = (folder / "s.html").read_text(encoding="utf-8")
    assert text.count("<svg") >= 4  # error and coverage for each record (+ parameters)
    assert "lab_run_1: error on the held-out record" in text and "lab_run_2" in text
    assert "<script" not in text


def test_a_second_run_reuses_the_stored_cells(local, tmp_path):
    """Resume: the stored cells are taken as they are (same files, same stamps), only new cells run."""
    folder, _, first, _ = local
    stored = {p.name: p.stat().st_mtime_ns for p in (folder / "run" / "s.cells").iterdir()}
    assert len(stored) == 8  # the four good cells (.json + .npz); failed cells are not stored
    before = pd.read_csv(folder / "run" / "s.csv")
    status, second, err = study([*STUDY[:3], "0:0.5,0:1,5:6,0:0.75", *OPTIONS, "--workers", "1", "--out", "run/s"],
                                folder)
    assert status == 1
    assert without_seconds(second["cells"][:3]) == without_seconds(first["cells"][:3])
    assert [c["seconds"] for c in second["cells"][:2]] == [c["seconds"] for c in first["cells"][:2]]  # not re-run
    after = pd.read_csv(folder / "run" / "s.csv")
    lab1 = after[after["record"] == "lab_run_1"]
    assert list(lab1["reused"]) == [True, True, False, False]  # 0-0.5, 0-1 stored; 5-6 failed again; 0-0.75 new
    assert list(lab1["computed_utc"][:2]) == list(before["computed_utc"][:2])
    assert {p: (folder / "run" / "s.cells" / p).stat().st_mtime_ns for p in stored} == stored
    assert len(list((folder / "run" / "s.cells").iterdir())) == 8 + 4  # + 0-0.75 of both records
    assert "reused" in err


def _start(args: list[str], cwd: Path, log) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "dask", *args], cwd=cwd, env=environment(), stdout=log,
                            stderr=subprocess.STDOUT, start_new_session=True)


def _stop(proc: subprocess.Popen) -> None:
    """Stop a process group started by :func:`_start` (SIGTERM, then SIGKILL after 20 s)."""
    if proc.poll() is not None:
        return
    os.killpg(proc.pid, signal.SIGTERM)
    try:
        proc.wait(timeout=20)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=20)


@pytest.fixture
def scheduler(tmp_path):
    """A ``dask scheduler`` and two ``dask worker --nthreads 1`` on 127.0.0.1 (free ports), torn down after."""
    from distributed import Client

    file = tmp_path / "scheduler.json"
    log = open(tmp_path / "dask.log", "w")
    procs = []
    try:
        procs.append(_start(["scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                             "--scheduler-file", str(file)], tmp_path, log))
        deadline = time.monotonic() + 120
        while not file.exists() and time.monotonic() < deadline and procs[0].poll() is None:
            time.sleep(0.2)
        assert file.exists(), (tmp_path / "dask.log").read_text()
        address = json.loads(file.read_text())["address"]
        for _ in range(2):
            procs.append(_start(["worker", "--scheduler-file", str(file), "--nthreads", "1", "--host", "127.0.0.1",
                                 "--no-dashboard"], tmp_path, log))
        with Client(address, timeout=60) as client:
            client.wait_for_workers(2, timeout=180)
        yield address
    finally:
        for proc in reversed(procs):
            _stop(proc)
        log.close()


def test_a_real_scheduler_gives_the_same_table(local, scheduler, tmp_path):
    _, local_status, document, _ = local
    status, remote, _ = study([*STUDY, "--scheduler", scheduler, "--out", "remote/s"], tmp_path)
    assert status == local_status
    assert len(remote["cells"]) == len(document["cells"])
    for a, b in zip(remote["cells"], document["cells"]):
        assert close(without_seconds([a]), without_seconds([b]))
    assert len(list((tmp_path / "remote" / "s.cells").iterdir())) == 8
