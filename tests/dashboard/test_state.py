"""Session state and toy jobs against the real ``beam`` library (no browser, no server)."""

from __future__ import annotations

import threading
import time
from dataclasses import replace

import pytest

from beam.toy import ToyScenario, run_toy
from dashboard.jobs import toy as toy_jobs
from dashboard.outputs.toy import compare_table
from dashboard.runtime.caches import LRU
from dashboard.state.session import SessionState

FAST = 300.0  # target ESS for the tests (the app uses 1000)


@pytest.fixture
def session(pool):
    s = SessionState(pool=pool, debounce_s=0.05, toy_inputs={"target_ess": FAST, "horizon_s": 15.0})
    yield s
    s.close()
    s.wait(10)


def settle(session, timeout=30.0):
    assert session.wait(timeout), "runs did not finish"


def test_first_request_shows_preview_then_final_then_sweep(session):
    toy = session.toy
    rid = toy.request(debounce=False)
    settle(session)
    times = toy.timings(rid)
    assert times["preview"] < times["final"]
    assert toy.stage == "final" and toy.error == "" and toy.shown == rid
    assert toy.result is toy.final and toy.result.posterior is not None
    assert toy.result.extra["stage"] == "final"
    assert len(toy.sweep) == 14 and toy.sweep[0]["window_s"] == 1.0
    assert toy.progress == 1.0


def test_input_change_runs_the_new_scenario(session):
    toy = session.toy
    toy.window_s = 8.0
    assert toy.stage == "queued"
    settle(session)
    assert toy.result.scenario.window_s == 8.0
    assert toy.shown == toy.requested


def test_error_keeps_the_previous_result_and_clears_on_success(session):
    toy = session.toy
    toy.request(debounce=False)
    settle(session)
    previous = toy.result
    toy.param.update(horizon_s=10.0, window_s=12.0)  # window beyond the horizon
    settle(session)
    assert toy.stage == "error"
    assert toy.error == "calibration window (12 s) must be shorter than the horizon (10 s)"
    assert toy.result is previous
    assert "previous result" in toy.status
    toy.window_s = 6.0
    settle(session)
    assert toy.error == "" and toy.stage == "final" and toy.result.scenario.window_s == 6.0


def test_storm_of_20_input_changes_in_2_s_ends_on_the_last(session):
    toy = session.toy
    shown_windows = []
    toy.param.watch(lambda e: shown_windows.append(e.new.scenario.window_s) if e.new is not None else None, "result")
    windows = [1.0 + 0.5 * i for i in range(20)]
    for w in windows:
        toy.window_s = w
        time.sleep(0.1)
    settle(session)
    assert toy.result.scenario.window_s == windows[-1]
    assert toy.stage == "final" and toy.shown == toy.requested
    assert len(shown_windows) < 20 * 3, "superseded runs must not keep publishing"
    assert shown_windows[-1] == windows[-1]


def test_pin_keeps_a_result_for_comparison(session):
    toy = session.toy
    toy.request(debounce=False)
    settle(session)
    toy.pin()
    pinned = toy.pinned
    toy.discrepancy = 0.3
    settle(session)
    assert toy.pinned is pinned and toy.result is not pinned
    table = compare_table(toy.result, toy.pinned)
    assert list(table.columns) == ["Pinned", "Current", "Truth"]
    assert "Held-out RMSE (du)" in table.index and "Frequency f (Hz)" in table.index
    toy.unpin()
    assert toy.pinned is None


def test_close_cancels_runs(session, pool):
    toy = session.toy
    toy.request(debounce=False)
    session.close()
    assert session.wait(10)
    with pytest.raises(RuntimeError):
        toy.request()


def test_toy_run_reproduces_run_toy():
    scenario = ToyScenario(discrepancy=0.3, kind="tone", target_ess=FAST, seed=3)
    stages = list(toy_jobs.toy_run(scenario, use_cache=False))
    kinds = [s.kind for s in stages]
    assert kinds[0] == "preview" and kinds[-1] == "final" and "progress" in kinds
    assert stages[0].value.posterior is None and stages[0].value.extra["stage"] == "preview"
    final = stages[-1].value
    reference = run_toy(scenario)
    assert final.summary == reference.summary
    assert final.posterior.diagnostics.n_steps == reference.posterior.diagnostics.n_steps
    assert final.coverage95_prediction == reference.coverage95_prediction
    fractions = [s.fraction for s in stages if s.kind == "progress"]
    assert fractions == sorted(fractions) and all(0.0 <= f <= 1.0 for f in fractions)


def test_cached_result_is_published_at_once():
    scenario = ToyScenario(target_ess=FAST, seed=4)
    first = list(toy_jobs.toy_run(scenario))[-1].value
    again = list(toy_jobs.toy_run(scenario))
    assert [s.kind for s in again] == ["final"] and again[0].value is first


def test_sweep_key_ignores_what_the_sweep_does_not_depend_on():
    base = ToyScenario(discrepancy=0.3)
    assert toy_jobs.sweep_key(replace(base, window_s=9.0)) == toy_jobs.sweep_key(base)
    assert toy_jobs.sweep_key(replace(base, target_ess=50.0)) == toy_jobs.sweep_key(base)
    drift = replace(base, kind="drift")
    assert toy_jobs.sweep_key(replace(drift, window_s=9.0)) != toy_jobs.sweep_key(drift)
    assert toy_jobs.sweep_key(replace(base, likelihood="ar1")) != toy_jobs.sweep_key(base)


def test_sweep_job_streams_one_window_at_a_time():
    scenario = ToyScenario(horizon_s=10.0, discrepancy=0.2, seed=5)
    stages = list(toy_jobs.toy_sweep(scenario, use_cache=False))
    partials = [s for s in stages if s.kind == "partial"]
    assert [len(s.value) for s in partials] == list(range(1, 10))
    assert stages[-1].kind == "final" and [r["window_s"] for r in stages[-1].value] == [float(w) for w in range(1, 10)]


def test_lru_evicts_the_oldest():
    cache = LRU(2)
    cache.put("a", 1)
    cache.put("b", 2)
    assert cache.get("a") == 1
    cache.put("c", 3)
    assert cache.get("b") is None and cache.get("a") == 1 and len(cache) == 2


def test_no_worker_thread_outlives_the_session(pool):
    baseline = threading.active_count()
    s = SessionState(pool=pool, debounce_s=0.0, toy_inputs={"target_ess": FAST, "horizon_s": 15.0})
    s.toy.request(debounce=False)
    assert s.wait(30)
    s.close()
    deadline = time.monotonic() + 3
    while threading.active_count() > baseline and time.monotonic() < deadline:
        time.sleep(0.02)
    assert threading.active_count() == baseline
