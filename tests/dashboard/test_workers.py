"""Worker processes behind the run scheduler: stages, identity of arguments, cancellation, errors, crashes."""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
import pytest
import recorder
from worker_jobs import counting, dying, failing, mapped, offloaded, queued, told_while_waiting

from beam.toy import ToyScenario
from dashboard.jobs.toy import toy_run, toy_stages
from dashboard.runtime import scheduler as sch
from dashboard.runtime.workers import WorkerError


def make_slot(pool, **kw):
    return recorder.make_slot(pool, debounce_s=0.0, progress_interval_s=0.0, **kw)


@pytest.fixture(scope="module")
def proc_pool():
    """Two threads, each with a worker process (spawned once for the module)."""
    pool = sch.RunPool(max_workers=2, idle_timeout_s=0.5, processes=True, name="test-proc")
    pool.start_processes()
    yield pool
    pool.shutdown(wait=True)


def test_offloaded_stages_arrive_in_order_from_another_process(proc_pool):
    slot, rec = make_slot(proc_pool)
    rid = slot.request(offloaded(counting, 5, "a"))
    assert slot.wait(60)
    kinds = [u.kind for u in rec.of(rid)]
    assert kinds == ["preview"] + ["progress"] * 5 + ["final"]
    worker_pid = rec.of(rid)[0].value["pid"]
    assert worker_pid != os.getpid() and worker_pid in proc_pool.process_ids
    assert [u.fraction for u in rec.of(rid) if u.kind == "progress"] == [0.2, 0.4, 0.6, 0.8, 1.0]


def test_arguments_come_back_as_the_same_objects(proc_pool):
    tag = {"dataset": "lab_run_1", "window": (0.0, 1.4)}
    slot, rec = make_slot(proc_pool)
    slot.request(offloaded(counting, 1, tag))
    assert slot.wait(60)
    final = rec.updates[-1].value
    assert final["tag"] is tag  # an argument is sent back as a reference to the caller's object
    assert rec.updates[0].value["tag"] is tag


def test_newer_request_stops_the_worker_generator_and_the_worker_is_reused(proc_pool, tmp_path):
    slot, rec = make_slot(proc_pool)
    marker = str(tmp_path / "old")
    first = slot.request(offloaded(counting, 4000, "old", pause_s=0.01, marker=marker))
    deadline = time.monotonic() + 60
    while not any(u.kind == "progress" for u in rec.of(first)) and time.monotonic() < deadline:
        time.sleep(0.01)
    second = slot.request(offloaded(counting, 2, "new"))
    assert slot.wait(60)
    deadline = time.monotonic() + 60
    while not os.path.exists(marker + ".closed") and time.monotonic() < deadline:
        time.sleep(0.01)
    assert os.path.exists(marker + ".closed"), "the old generator must be closed in the worker"
    # stopped where it was, not run to its end: closed before its last count
    assert int(Path(marker + ".count").read_text()) < 4000
    assert "final" not in [u.kind for u in rec.of(first)]
    assert rec.of(second)[-1].kind == "final" and rec.stale == []
    assert int(Path(marker + ".closed").read_text()) in proc_pool.process_ids  # the worker lives on


@pytest.mark.parametrize(("kind", "expected"), [
    ("user", "window (--window 12 s) must be shorter than the horizon"),
    ("bug", "internal error (ZeroDivisionError: division by zero)"),
    ("local", "internal error (WorkerError: Local: a local exception type)"),
])
def test_errors_in_the_worker_become_readable_messages(proc_pool, kind, expected):
    slot, rec = make_slot(proc_pool)
    rid = slot.request(offloaded(failing, kind))
    assert slot.wait(60)
    updates = rec.of(rid)
    assert [u.kind for u in updates] == ["preview", "error"]
    assert updates[-1].message.startswith(expected)


def test_a_worker_that_dies_is_reported_and_replaced(proc_pool):
    slot, rec = make_slot(proc_pool)
    rid = slot.request(offloaded(dying))
    assert slot.wait(60)
    dead = rec.of(rid)[0].value
    assert rec.of(rid)[-1].kind == "error" and "worker process stopped" in rec.of(rid)[-1].message
    again = slot.request(offloaded(counting, 1, "after"))
    assert slot.wait(120)
    assert rec.of(again)[-1].kind == "final"
    assert dead not in proc_pool.process_ids and len(proc_pool.process_ids) == 2


def test_the_toy_job_gives_the_same_result_in_a_worker(proc_pool):
    scenario = ToyScenario(window_s=4.0, target_ess=200.0, seed=3)
    slot, rec = make_slot(proc_pool)
    slot.request(lambda: toy_run(scenario, use_cache=False))
    assert slot.wait(120)
    remote = rec.updates[-1].value
    local = next(s for s in toy_stages(scenario) if s.kind == "final").value
    assert remote.scenario is scenario
    np.testing.assert_array_equal(remote.bands.prediction_upper, local.bands.prediction_upper)
    assert remote.summary == local.summary
    assert np.allclose(remote.problem.predict({k: np.atleast_1d(v) for k, v in remote.laplace.map.values.items()},
                                              remote.data.time_s), local.problem.predict(
        {k: np.atleast_1d(v) for k, v in local.laplace.map.values.items()}, local.data.time_s))
    with pytest.raises(WorkerError):  # the MAP starting points (a closure) stayed in the worker
        remote.problem.initial_guesses(remote.problem)


def test_offload_without_worker_processes_runs_on_the_thread(pool):
    slot, rec = make_slot(pool)
    slot.request(offloaded(counting, 2, "inline"))
    assert slot.wait(30)
    assert rec.updates[0].value["pid"] == os.getpid() and rec.updates[-1].kind == "final"


def test_shutdown_stops_the_worker_processes():
    pool = sch.RunPool(max_workers=1, idle_timeout_s=0.2, processes=True)
    slot, _ = make_slot(pool)
    slot.request(offloaded(counting, 1, "x"))
    assert slot.wait(60)
    (pid,) = pool.process_ids
    pool.shutdown(wait=True)
    assert pool.process_ids == []
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)


def test_a_stop_that_arrives_during_a_run_ends_the_worker_after_it():
    """The worker reads its pipe for cancellations between stages; a ``stop`` read there cancels
    the run and then ends the process (it used to be taken for a cancel only, and the worker
    then waited on its pipe until shutdown terminated it)."""
    from dashboard.runtime.workers import WorkerProcess

    worker = WorkerProcess("beam-worker-test")
    try:
        stages = worker.run(counting, (200, "long"), {"pause_s": 0.02})
        first = next(stages)
        assert first.kind == "preview"
        worker._conn.send(("stop",))  # what stop() sends, here while the run goes on
        rest = list(stages)  # the run ends early: the worker stopped its generator
        assert len(rest) < 199 and all(s.kind == "progress" for s in rest)
        worker._process.join(10)
        assert not worker._process.is_alive() and worker._process.exitcode == 0  # left on its own
    finally:
        worker.stop(timeout=2)


def test_offload_map_runs_the_calls_on_both_processes_at_once(proc_pool):
    slot, rec = make_slot(proc_pool)
    calls = [((3, f"t{i}"), {"pause_s": 0.2}) for i in range(4)]
    rid = slot.request(mapped(counting, calls))
    assert slot.wait(60)
    out = rec.of(rid)[-1].value
    assert sorted(i for i, _ in out) == [0, 1, 2, 3]
    assert all(value["tag"] == f"t{i}" for i, value in out)  # each index with its own call's value
    assert {value["pid"] for _, value in out} == set(proc_pool.process_ids)  # both processes took calls


def test_offload_map_hands_back_a_call_s_error_as_its_value(proc_pool):
    slot, rec = make_slot(proc_pool)
    rid = slot.request(mapped(failing, [(("user",), {}), ((), {"kind": "bug"})]))
    assert slot.wait(60)
    values = dict(rec.of(rid)[-1].value)
    assert "shorter than the horizon" in str(values[0]) and isinstance(values[1], ZeroDivisionError)


def test_offload_map_stops_every_call_when_the_job_is_cancelled(proc_pool, tmp_path):
    slot, rec = make_slot(proc_pool)
    markers = [str(tmp_path / f"m{i}") for i in range(2)]
    first = slot.request(mapped(counting, [((400, i), {"pause_s": 0.01, "marker": markers[i]}) for i in range(2)]))
    time.sleep(1.0)
    t0 = time.monotonic()
    second = slot.request(offloaded(counting, 1, "new"))
    assert slot.wait(60)
    while not all(os.path.exists(m + ".closed") for m in markers) and time.monotonic() - t0 < 5:
        time.sleep(0.01)
    assert all(os.path.exists(m + ".closed") for m in markers), "both mapped calls must stop in their workers"
    assert "final" not in [u.kind for u in rec.of(first)]
    assert rec.of(second)[-1].kind == "final"


def test_a_run_asked_for_during_offload_map_takes_the_next_free_process(proc_pool):
    """Four mapped calls of ~3 s on the two processes; an ordinary run asked for while the first
    two run gets the first process that frees, before the mapped calls three and four."""
    events: list[str] = []
    lock = __import__("threading").Lock()

    def note(tag):
        def on_update(update):
            if update.kind in ("partial", "final"):
                with lock:
                    events.append(f"{tag}:{update.kind}:{len(update.value) if tag == 'map' else 'x'}")
        return on_update

    mapped_slot = sch.RunSlot(note("map"), pool=proc_pool, debounce_s=0.0, progress_interval_s=0.0)
    other_slot = sch.RunSlot(note("other"), pool=proc_pool, debounce_s=0.0, progress_interval_s=0.0)
    mapped_slot.request(mapped(counting, [((100, i), {"pause_s": 0.03}) for i in range(4)]))
    time.sleep(0.5)  # the first two calls are running on both processes
    other_slot.request(offloaded(counting, 1, "other"))
    deadline = time.monotonic() + 10
    while proc_pool.workers._waiting < 1 and time.monotonic() < deadline:  # the other run waits for a process
        time.sleep(0.01)
    with lock:
        assert proc_pool.workers._waiting == 1 and not events, events  # ... while the first two calls run
    assert mapped_slot.wait(60) and other_slot.wait(60)
    other_at = events.index("other:final:x")
    mapped_done_before = [e for e in events[:other_at] if e.startswith("map:partial")]
    assert len(mapped_done_before) <= 2, events  # it waited for one running call, not for the four


def test_plain_arguments_equal_to_an_argument_index_come_back_whole(proc_pool):
    """An int argument equal to another argument's index (counting(1, 0): n = 1, tag = 0) used to
    make the stage pickler recurse without end, and the worker died."""
    slot, rec = make_slot(proc_pool)
    rid = slot.request(offloaded(counting, 1, 0))
    assert slot.wait(60)
    assert rec.of(rid)[-1].kind == "final" and rec.of(rid)[-1].value["tag"] == 0


def test_offload_queue_takes_calls_while_others_run_and_close_drops_the_waiting(proc_pool, tmp_path):
    marker = str(tmp_path / "dropped")
    slot, rec = make_slot(proc_pool)
    rid = slot.request(queued(marker))
    assert slot.wait(60)
    out = rec.of(rid)[-1].value
    assert out["capacity"] == 2 and out["idle"] == [2, 0]  # two processes, both taken by the first two calls
    order = out["order"]
    assert order[:3] == ["short", "urgent", "waits"], order  # "urgent" took the process "short" freed
    assert sorted(order[3:]) == ["blocker", "long"], order
    assert not os.path.exists(marker + ".closed")  # "dropped" never started


def test_offload_queue_passes_on_what_a_running_call_reports(proc_pool):
    """What a call on a worker process reports while it runs reaches the job that waits for it
    (the diagnosis's fits tell the status line what they fit)."""
    slot, rec = make_slot(proc_pool)
    rid = slot.request(told_while_waiting())
    assert slot.wait(60)
    out = rec.of(rid)[-1].value
    assert out["key"] == "told" and out["tag"] == "told" and out["after"] == []
    messages = [m for key, kind, m in out["told"] if key == "told" and kind == "progress"]
    assert len(messages) == len(out["told"])
    assert messages == ["1 of 4", "2 of 4", "3 of 4", "4 of 4"]  # every report, in the order the call said them
