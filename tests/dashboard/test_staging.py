"""Building pages in steps: order, rests between steps, closed sessions, failures (a tornado loop, no browser)."""

from __future__ import annotations

import asyncio
import itertools
import time
from types import SimpleNamespace

import pytest
from bokeh.document import Document
from tornado.ioloop import IOLoop

from dashboard.runtime.staging import BuildQueue, run_steps


class FakeDoc(Document):
    """A bokeh Document as :class:`BuildQueue` sees a served one: a session context (no
    connection), next-tick callbacks on the current loop; holding it is bokeh's own."""

    def __init__(self, *, runs_callbacks: bool = True) -> None:
        super().__init__()
        context = SimpleNamespace(_session=SimpleNamespace(destroyed=False))
        self._session_context = lambda: context
        self.runs_callbacks = runs_callbacks

    def add_next_tick_callback(self, callback) -> None:
        if self.runs_callbacks:
            IOLoop.current().add_callback(callback)

    def close(self) -> None:
        self.session_context._session.destroyed = True


def run(coro_fn, timeout=20.0):
    loop = IOLoop()
    try:
        return loop.run_sync(coro_fn, timeout=timeout)
    finally:
        loop.close()


async def drain(queue: BuildQueue, timeout: float = 10.0) -> None:
    deadline = time.monotonic() + timeout
    while (queue.pending or queue._busy) and time.monotonic() < deadline:
        await asyncio.sleep(0.005)
    assert not queue.pending and not queue._busy, "the queue did not finish"


def test_steps_run_in_order_one_at_a_time_with_rests_between():
    spans: list[tuple[str, float, float]] = []

    def step(name, busy_s=0.04):
        def fn():
            start = time.perf_counter()
            while time.perf_counter() - start < busy_s:  # holds the loop, like building models
                pass
            spans.append((name, start, time.perf_counter()))
        fn.__name__ = name
        return fn

    async def scenario():
        queue = BuildQueue(duty=0.5)
        a, b = FakeDoc(), FakeDoc()
        queue.submit(a, [step("a1"), step("a2"), step("a3")])
        queue.submit(b, [step("b1"), step("b2")])
        probes = []
        while queue.pending or queue._busy:  # other work of the loop, e.g. answering a request
            await asyncio.sleep(0.002)
            probes.append(time.perf_counter())
        return probes

    probes = run(scenario)
    assert [name for name, _, _ in spans] == ["a1", "a2", "a3", "b1", "b2"]  # first come, first served
    for (_, _, end), (_, start, _) in itertools.pairwise(spans):
        assert start - end >= 0.03, "the queue rests about as long as the step took (duty 0.5)"
        assert any(end < t < start for t in probes), "the loop does other work between two steps"


def test_a_closed_session_drops_its_steps_and_the_others_go_on():
    ran: list[str] = []

    async def scenario():
        queue = BuildQueue()
        a, b = FakeDoc(), FakeDoc()
        queue.submit(a, [lambda: ran.append("a1"), lambda: (ran.append("a2"), a.close()), lambda: ran.append("a3")])
        queue.submit(b, [lambda: ran.append("b1")])
        await drain(queue)

    run(scenario)
    assert ran == ["a1", "a2", "b1"]


def test_a_session_whose_callbacks_never_run_is_dropped_after_the_stall_time():
    ran: list[str] = []

    async def scenario():
        queue = BuildQueue(stall_s=0.2)
        gone, alive = FakeDoc(runs_callbacks=False), FakeDoc()
        queue.submit(gone, [lambda: ran.append("gone")])
        queue.submit(alive, [lambda: ran.append("alive")])
        t0 = time.monotonic()
        await drain(queue)
        return time.monotonic() - t0

    took = run(scenario)
    assert ran == ["alive"] and 0.2 <= took < 2.0


def test_a_failing_step_is_logged_and_the_next_ones_run(caplog):
    ran: list[str] = []

    def broken():
        raise RuntimeError("boom")

    async def scenario():
        queue = BuildQueue()
        doc = FakeDoc()
        queue.submit(doc, [broken, lambda: ran.append("after")], on_done=lambda: ran.append("done"))
        await drain(queue)
        return queue

    queue = run(scenario)
    assert ran == ["after", "done"]
    assert "building a piece of the page failed" in caplog.text
    assert len(queue.durations) == 3


def test_without_a_served_document_steps_run_at_once():
    ran: list[int] = []
    run_steps([lambda: ran.append(1), lambda: ran.append(2)], on_done=lambda: ran.append(3))
    assert ran == [1, 2, 3]
    BuildQueue().submit(None, [lambda: ran.append(4)])
    assert ran == [1, 2, 3, 4]


def test_duty_must_be_a_share():
    with pytest.raises(ValueError):
        BuildQueue(duty=0.0)


def test_each_step_runs_with_its_document_held_and_released_after():
    """A step's changes are collected (policy ``collect``) and leave together: see :func:`staging.held`."""
    seen: list = []

    async def scenario():
        queue, doc = BuildQueue(), FakeDoc()
        queue.submit(doc, [lambda: seen.append(doc.callbacks.hold_value)] * 2)
        await drain(queue)
        return doc

    doc = run(scenario)
    assert seen == ["collect", "collect"]
    assert doc.callbacks.hold_value is None
