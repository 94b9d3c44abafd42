"""The window study's session state (``dashboard.state.study``) without a browser: its default windows,
the cells it lays out, input errors, the job that streams the cells from Dask (a failed cell among good
ones, cells remembered by the server, a stop), and a cell opened in the beam view.

Dask runs in this process (``Client(processes=False)``); the cells are cheap (2 modes, 30 steps).
"""

from __future__ import annotations

import time
from types import SimpleNamespace

import numpy as np
import pytest

from beam.calibration.spec import CalibrationSpec
from beam.study import StudyCell, default_windows, parse_windows, study_cells
from beam.study.cells import record_fingerprint
from beam.study.engine import stream_cells
from dashboard.jobs.beam import load_bundled
from dashboard.runtime import scheduler as sch
from dashboard.state.session import SessionState
from dashboard.state.study import default_windows_spec, study_job


@pytest.fixture(scope="module")
def client():
    from distributed import Client

    from beam.inference._arviz import import_arviz

    import_arviz()  # as connect() does on every worker before its first cell (two threads importing it race)
    c = Client(processes=False, n_workers=1, threads_per_worker=2, dashboard_address=None)
    yield c
    c.close()


@pytest.fixture
def session():
    pool = sch.RunPool(max_workers=1, idle_timeout_s=0.2, name="test-study")
    s = SessionState(pool=pool, debounce_s=0.0)
    yield s
    s.close()
    s.study.close()
    pool.shutdown(wait=False)


@pytest.mark.parametrize("t0, duration", [(0.0, 3.499), (0.0, 19.9993), (1.0, 2.5), (0.0, 0.8)])
def test_default_windows_are_the_clis_family_rounded(t0, duration):
    record = SimpleNamespace(time_s=np.linspace(t0, t0 + duration, 101))
    spec = default_windows_spec(record)
    assert spec.startswith("grow:")
    ours = parse_windows(spec)
    cli = default_windows(t0, t0 + duration)
    assert len(ours) == len(cli) == 6
    for (a0, a1), (b0, b1) in zip(ours, cli):
        assert a0 == b0 == pytest.approx(t0)
        assert a1 == pytest.approx(b1, rel=0.05)  # a tenth of the record, to two significant digits
        assert a1 - a0 <= 0.6 * duration * 1.05  # the rest of the record held out


def test_the_state_lays_out_the_cells_of_beam_study(session):
    st = session.study
    assert st.dataset == "lab_run_1" and st.effect_sets == ["air_damping,kelvin_voigt"]
    st.param.update(windows="0:0.3,0:0.6", likelihoods=["ar1", "iid"],
                    effect_sets=["air_damping,kelvin_voigt,patch_stiffening", "air_damping,kelvin_voigt"])
    m = load_bundled("lab_run_1")
    expected = [(i, StudyCell(record="lab_run_1", record_hash=record_fingerprint(m),
                              spec=CalibrationSpec(window=w, effects=e, likelihood=lk, modes="auto", seed=0)))
                for i, w in enumerate([(0.0, 0.3), (0.0, 0.6)])
                for e in [("air_damping", "kelvin_voigt"), ("air_damping", "kelvin_voigt", "patch_stiffening")]
                for lk in ["iid", "ar1"]]
    assert st.cells() == expected  # the check-boxes' order, not the order they were ticked in


@pytest.mark.parametrize("inputs, words", [
    ({"windows": "0:0.5,0:9"}, "outside the record"),
    ({"windows": "grow:0:0.5"}, "grow:START:STEP:END"),
    ({"effect_sets": []}, "at least one effect set"),
    ({"likelihoods": []}, "at least one likelihood"),
])
def test_wrong_inputs_say_why_and_start_nothing(session, inputs, words):
    st = session.study
    st.param.update(**inputs)
    assert st.start() == 0
    assert words in st.error and st.requested == 0 and st.stage == "idle"


def test_the_job_streams_every_cell_once_a_failed_one_among_them_then_remembers_them(client):
    m = load_bundled("lab_run_2")
    cells = study_cells([("lab_run_2", m)], [(0.0, 0.4), (0.0, 0.8), (5.0, 6.0)], [("air_damping", "kelvin_voigt")],
                        ["iid"], modes=2, steps=30)
    records = {record_fingerprint(m): m}
    stages = list(study_job(records, cells, stop=lambda: False, connect_client=lambda: client))
    partial = [s for s in stages if s.kind == "partial"]
    assert stages[-1].kind == "final" and stages[-1].value == 3
    assert sorted(s.value["position"] for s in partial) == [0, 1, 2]
    assert [s.fraction for s in partial] == pytest.approx([1 / 3, 2 / 3, 1.0])  # in the order they finished
    by_window = {tuple(s.value["cell"].window): s.value for s in partial}
    assert "outside the record" in by_window[(5.0, 6.0)]["row"]["error"]
    for window in [(0.0, 0.4), (0.0, 0.8)]:
        row = by_window[window]["row"]
        assert row["error"] is None and 0 < row["rmse_prediction"] < 0.01 and 0 <= row["coverage95_prediction"] <= 1
        assert by_window[window]["extra"]["modes"] == 2

    def no_cluster():
        raise AssertionError("remembered cells need no cluster")

    again = list(study_job(records, cells[:2], stop=lambda: False, connect_client=no_cluster))
    assert [s.value["row"] for s in again if s.kind == "partial"] == [by_window[(0.0, 0.4)]["row"],
                                                                       by_window[(0.0, 0.8)]["row"]]


def test_a_stop_cancels_the_cells_left_on_the_cluster(client):
    m = load_bundled("lab_run_3")
    cells = [c for _, c in study_cells([("lab_run_3", m)], [(0.0, 0.5), (0.0, 1.0), (0.0, 1.5)],
                                       [("air_damping", "kelvin_voigt")], ["iid"], modes=3, steps=400, seed=7)]
    asked = []

    def stop() -> bool:
        asked.append(time.monotonic())
        return True

    assert list(stream_cells(client, {record_fingerprint(m): m}, cells, stop=stop, poll_s=0.05)) == []
    assert asked, "stop() was asked while no cell was ready"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:  # a running cell ends on its thread; its result is dropped
        left = client.run_on_scheduler(lambda dask_scheduler: len(dask_scheduler.tasks))
        if left == 0:
            break
        time.sleep(0.2)
    assert left == 0


def test_a_cell_opens_in_the_beam_view(session):
    st, beam = session.study, session.beam
    m = load_bundled("lab_run_1")
    cell = StudyCell(record="lab_run_1", record_hash=record_fingerprint(m), spec=CalibrationSpec(
        window=(0.0, 0.6), effects=("air_damping", "kelvin_voigt", "patch_stiffening"), likelihood="ar1", modes="auto",
        seed=0))
    before = beam.requested
    st.open_cell({"position": 0, "index": 1, "cell": cell, "row": {"error": None}, "extra": {"modes": 5}})
    key = beam.key()
    assert (beam.dataset, key.spec.window, key.spec.effects, key.spec.likelihood, key.spec.modes, key.spec.seed) == (
        "lab_run_1", (0.0, 0.6), ("air_damping", "kelvin_voigt", "patch_stiffening"), "ar1", 5, 0)
    assert beam.requested > before and beam.stage == "queued"


def test_updates_fill_the_state_in_order_and_a_failure_keeps_the_cells(session):
    st = session.study
    entry = {"position": 1, "index": 1, "cell": None, "row": {"error": None}, "extra": {}}
    failed = {"position": 0, "index": 0, "cell": None, "row": {"error": "BeamInputError: too short"}, "extra": {}}
    st.run.on_update(sch.Update(1, "partial", entry, 0.5, "1 of 2 cells", 1.0))
    st.run.on_update(sch.Update(1, "partial", failed, 1.0, "2 of 2 cells", 2.0))
    assert st.entries == [entry, failed] and st.stage == "running" and "1 failed" in st.status
    st.run.on_update(sch.Update(1, "error", None, None, "lost the scheduler", 3.0))
    assert st.stage == "error" and st.entries == [entry, failed] and "lost the scheduler" in st.error
