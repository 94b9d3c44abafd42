"""The run scheduler: ordering, debounce, cancellation, storms, errors, threads (no browser)."""

from __future__ import annotations

import random
import threading
import time
import types

import pytest
from recorder import make_slot

from beam.errors import BeamInputError
from dashboard.runtime import scheduler as sch


def sleepy_job(log: dict, tag, *, chunks=5, chunk_s=0.02, fail_at=None):
    """A job like the sampler's: preview, progress per chunk, partial, final; records start/stop."""
    def job():
        log.setdefault("started", []).append(tag)
        try:
            time.sleep(chunk_s)
            yield sch.preview(("preview", tag))
            for i in range(chunks):
                time.sleep(chunk_s)
                if fail_at == i:
                    raise BeamInputError(f"window (--window 12 s) must be shorter than the horizon ({tag})")
                log.setdefault("chunks", []).append((tag, i))
                yield sch.progress((i + 1) / chunks, f"chunk {i + 1}")
                if i == chunks // 2:
                    yield sch.partial(("partial", tag), (i + 1) / chunks)
            yield sch.final(("final", tag))
        finally:
            log.setdefault("closed", []).append(tag)
    return job


def test_stages_are_published_in_order(pool):
    slot, rec = make_slot(pool, debounce_s=0.0, progress_interval_s=0.0)
    rid = slot.request(sleepy_job({}, "a"))
    assert slot.wait(5)
    kinds = rec.kinds(rid)
    assert kinds[0] == "preview" and kinds[-1] == "final"
    assert kinds.count("progress") == 5 and kinds.count("partial") == 1
    assert kinds.index("partial") < kinds.index("final")
    elapsed = [u.elapsed_s for u in rec.updates]
    assert elapsed == sorted(elapsed)
    assert rec.updates[-1].value == ("final", "a") and rec.updates[-1].fraction == 1.0


def test_request_returns_at_once_while_the_pool_is_busy(pool):
    """A request returns while both pool threads are held by jobs that cannot finish yet."""
    gate = threading.Event()
    log: dict = {}

    def blocked(tag):
        def job():
            log.setdefault("started", []).append(tag)
            gate.wait(10)
            yield sch.final(tag)
        return job

    slots = [make_slot(pool, debounce_s=0.0)[0] for _ in range(3)]
    for i, s in enumerate(slots[:2]):
        s.request(blocked(i))
    deadline = time.monotonic() + 5
    while len(log.get("started", [])) < 2 and time.monotonic() < deadline:
        time.sleep(0.002)
    assert sorted(log["started"]) == [0, 1]  # both threads are busy
    slots[2].request(blocked("third"))  # returns although no thread is free ...
    assert not gate.is_set() and "third" not in log["started"]  # ... before anything could run it
    gate.set()
    for s in slots:
        assert s.wait(5)
        s.close()
    assert log["started"][-1] == "third"


def test_newer_request_cancels_the_running_one_between_chunks(pool):
    slot, rec = make_slot(pool, debounce_s=0.0, progress_interval_s=0.0)
    log: dict = {}
    first = slot.request(sleepy_job(log, "old", chunks=100, chunk_s=0.02))
    deadline = time.monotonic() + 5
    while "preview" not in rec.kinds(first) and time.monotonic() < deadline:
        time.sleep(0.005)
    chunks_before = len(log.get("chunks", []))
    second = slot.request(sleepy_job(log, "new"))
    assert slot.wait(5)
    # the old job stopped at its next stage: it finished at most the chunk it was in
    old_chunks = [c for c in log["chunks"] if c[0] == "old"]
    assert len(old_chunks) - chunks_before <= 1
    assert log["closed"][0] == "old" and log["started"] == ["old", "new"]
    assert rec.kinds(second)[-1] == "final"
    assert "final" not in rec.kinds(first)
    assert rec.stale == []


def test_cancelled_job_never_publishes_even_when_dispatch_is_delayed(pool):
    queue: list = []
    slot, rec = make_slot(pool, debounce_s=0.0, dispatch=queue.append, progress_interval_s=0.0)
    first = slot.request(sleepy_job({}, "old", chunks=2, chunk_s=0.01))
    assert slot.wait(5)
    assert len(queue) >= 4  # published by the worker but not yet delivered (the "event loop" is busy)
    second = slot.request(sleepy_job({}, "new", chunks=2, chunk_s=0.01))
    assert slot.wait(5)
    for fn in queue:  # the event loop catches up
        fn()
    assert rec.kinds(first) == []
    assert rec.kinds(second)[-1] == "final"
    assert slot.dropped > 0


def test_debounce_runs_the_first_and_the_last_of_a_burst(pool):
    slot, rec = make_slot(pool, debounce_s=0.15)
    log: dict = {}
    for i in range(5):
        slot.request(sleepy_job(log, i, chunks=20))
        time.sleep(0.03)
    assert slot.wait(5)
    assert log["started"] == [0, 4]  # leading edge at once, then the trailing edge of the burst
    assert rec.kinds(5)[-1] == "final" and "final" not in rec.kinds(1)


def test_isolated_request_starts_without_debounce_delay(pool, monkeypatch):
    """Leading edge after a quiet spell, trailing edge within a burst, on a clock the test sets.

    The slot reads its request times from ``time.perf_counter``, which is replaced by a clock
    that moves only when the test says so; the debounce (30 s) is far longer than the test.
    """
    clock = {"now": 1000.0}
    monkeypatch.setattr(sch, "time", types.SimpleNamespace(perf_counter=lambda: clock["now"], monotonic=time.monotonic,
                                                           sleep=time.sleep))
    slot, _ = make_slot(pool, debounce_s=30.0)
    other, _ = make_slot(pool, debounce_s=0.0)
    started: list = []

    def job(tag):
        def run():
            started.append(tag)
            yield sch.final(tag)
        return run

    slot.request(job("first"))  # nothing before it: starts at once, not 30 s later
    assert slot.wait(5) and started == ["first"]
    clock["now"] += 31.0  # a quiet spell longer than the debounce
    slot.request(job("after quiet"))
    assert slot.wait(5) and started == ["first", "after quiet"]
    clock["now"] += 1.0  # within the debounce of the previous request: waits for quiet
    slot.request(job("in burst"))
    other.request(job("elsewhere"))  # a free thread runs another slot's job meanwhile
    assert other.wait(5)
    assert started == ["first", "after quiet", "elsewhere"]  # the burst's request is still waiting
    slot.close()
    other.close()


def test_storm_of_20_requests_in_2_s_shows_only_the_latest(pool):
    baseline = threading.active_count()
    slot, rec = make_slot(pool, debounce_s=0.15, progress_interval_s=0.0)
    log: dict = {}
    rng = random.Random(7)
    peak = 0
    for i in range(20):
        slot.request(sleepy_job(log, i, chunks=4, chunk_s=0.03))
        time.sleep(rng.uniform(0.0, 0.2))  # some requests outlive the debounce and start running
        peak = max(peak, threading.active_count())
    assert slot.wait(5)
    # a request never waits for the running job: some job started during the storm was stopped
    # before its last chunk by the next request (the storm overlapped running jobs)
    done = {tag for tag, chunk in log.get("chunks", []) if chunk == 3}
    assert any(tag not in done for tag in log["started"][:-1]), log
    assert rec.stale == [], "an update of a superseded request was shown"
    assert rec.updates[-1].kind == "final" and rec.updates[-1].value == ("final", 19)
    finals = [u.value for u in rec.updates if u.kind == "final"]
    assert finals == sorted(finals), "results must never go back to an older request"
    assert len(log["started"]) < 20, "debounce should skip requests superseded while waiting"
    assert sorted(log["closed"]) == sorted(log["started"]), "every started job must be closed"
    assert peak <= baseline + pool.max_workers
    deadline = time.monotonic() + 3
    while threading.active_count() > baseline and time.monotonic() < deadline:
        time.sleep(0.02)
    assert threading.active_count() == baseline, "idle workers must exit"


def test_error_is_published_as_a_readable_message(pool):
    slot, rec = make_slot(pool, debounce_s=0.0)
    rid = slot.request(sleepy_job({}, "bad", fail_at=1))
    assert slot.wait(5)
    assert rec.kinds(rid)[0] == "preview" and rec.kinds(rid)[-1] == "error"
    message = rec.updates[-1].message
    assert message.startswith("window (--window 12 s) must be shorter than the horizon")
    assert "Traceback" not in message


def test_readable_error_distinguishes_user_errors_from_bugs():
    assert sch.readable_error(BeamInputError("noise sd must not be negative")) == "noise sd must not be negative"
    text = sch.readable_error(ZeroDivisionError("division by zero"))
    assert text.startswith("internal error (ZeroDivisionError: division by zero)") and "server log" in text


def test_job_that_fails_before_yielding_reports_an_error(pool):
    slot, rec = make_slot(pool, debounce_s=0.0)

    def job():
        raise BeamInputError("unknown discrepancy kind 'sawtooth'")

    slot.request(job)
    assert slot.wait(5)
    assert [(u.kind, u.message) for u in rec.updates] == [("error", "unknown discrepancy kind 'sawtooth'")]


def test_at_most_max_workers_jobs_run_at_once(pool):
    running, peak, lock = [0], [0], threading.Lock()

    def job():
        with lock:
            running[0] += 1
            peak[0] = max(peak[0], running[0])
        try:
            time.sleep(0.1)
            yield sch.final(None)
        finally:
            with lock:
                running[0] -= 1

    slots = [make_slot(pool, debounce_s=0.0)[0] for _ in range(5)]
    for s in slots:
        s.request(job)
    assert all(s.wait(5) for s in slots)
    assert peak[0] == 2


def test_progress_updates_are_throttled(pool, monkeypatch):
    """200 progress stages 1 ms apart on a clock the job moves (the slot reads ``time.perf_counter``):
    a 0.1 s throttle publishes a few, whatever the machine's load."""
    clock = {"now": 1000.0}
    monkeypatch.setattr(sch, "time", types.SimpleNamespace(perf_counter=lambda: clock["now"], monotonic=time.monotonic,
                                                           sleep=time.sleep))
    slot, rec = make_slot(pool, debounce_s=0.0, progress_interval_s=0.1)

    def job():
        for i in range(200):
            clock["now"] += 0.001
            yield sch.progress(i / 200)
        yield sch.final("done")

    slot.request(job)
    assert slot.wait(5)
    assert 1 <= rec.kinds().count("progress") <= 5
    assert rec.kinds()[-1] == "final"


def test_closed_slot_cancels_and_refuses(pool):
    slot, rec = make_slot(pool, debounce_s=0.0)
    log: dict = {}
    slot.request(sleepy_job(log, "x", chunks=50, chunk_s=0.01))
    time.sleep(0.05)
    slot.close()
    assert slot.wait(2)
    assert "final" not in rec.kinds()
    with pytest.raises(RuntimeError):
        slot.request(sleepy_job(log, "y"))


def test_cancel_before_start_never_runs(pool):
    slot, rec = make_slot(pool, debounce_s=0.5)
    log: dict = {}
    slot.request(sleepy_job(log, "never"), debounce_s=0.5)
    slot.cancel()
    assert slot.wait(0.1), "a request cancelled before it started is finished at once"
    time.sleep(0.6)
    assert "started" not in log and rec.updates == []


def test_unknown_stage_kind_is_an_error(pool):
    slot, rec = make_slot(pool, debounce_s=0.0)
    slot.request(lambda: iter([sch.Stage("bogus")]))
    assert slot.wait(5)
    assert rec.kinds() == ["error"] and "bogus" in rec.updates[0].message


def test_shutdown_joins_workers_and_refuses_new_work():
    baseline = threading.active_count()
    p = sch.RunPool(max_workers=2, idle_timeout_s=30.0)
    done = threading.Event()
    p.schedule(done.set)
    assert done.wait(2)
    assert threading.active_count() == baseline + 1
    p.shutdown(wait=True)
    assert threading.active_count() == baseline
    with pytest.raises(RuntimeError):
        p.schedule(lambda: None)


def test_shutdown_finishes_waiting_requests():
    p = sch.RunPool(max_workers=1, idle_timeout_s=0.2)
    slot, rec = make_slot(p, debounce_s=10.0)
    slot.request(sleepy_job({}, "waiting"), debounce_s=10.0)
    p.shutdown(wait=True)
    assert slot.wait(0.5) and rec.updates == []


def test_shared_pool_is_one_per_process():
    assert sch.shared_pool() is sch.shared_pool()
    assert sch.shared_pool().max_workers >= 1
