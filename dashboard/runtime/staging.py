"""Build the sessions' pages in small steps, one at a time across the whole server.

Why: Panel creates the bokeh models of a page on the server's event loop, and that loop also
answers every other browser. Measured with :mod:`dashboard.runtime.monitor` while eight browsers opened
the app, building a whole page in the app script held the loop for 0.6–1.6 s per session (the
toy view's ~180 models: Panel's widgets and panes, the main bokeh figure, the document's
serialisation), so other sessions' requests waited that long. So the app script builds a
skeleton (the template, the tabs, empty columns) and each view hands the rest over as a list of
*steps* — callables that build one piece (the status line, the main plot, the controls, ...)
and put it in place, each a few tens of milliseconds.

:func:`run_steps`
    What a view calls with its steps: queued when the current document is a served session's,
    run at once otherwise.
:func:`held`
    Runs a callback with its document held, so that its changes reach the browser in the order
    they were made (each step, and each update the session dispatches, runs so).
:class:`BuildQueue`
    One per server process (:func:`build_queue`). Steps run one at a time, first come first
    served across sessions, each on its session's document (``doc.add_next_tick_callback``:
    with the document's lock, as any bokeh callback). After a step the queue rests in
    proportion to the step's duration (``duty``: the share of the loop's time building may
    take, default 0.5), so requests that arrive meanwhile are answered between two steps. A
    session that closes while its steps wait drops them. Without a server (tests, a notebook)
    :meth:`BuildQueue.submit` runs the steps at once.
"""

from __future__ import annotations

import logging
import time
from collections import deque
from collections.abc import Callable, Iterable
from functools import partial

from panel.io.document import hold
from panel.io.state import set_curdoc

from dashboard.runtime import monitor

__all__ = ["BuildQueue", "build_queue", "held", "run_steps"]

log = logging.getLogger(__name__)

Step = Callable[[], None]


def _served(doc) -> bool:
    return doc is not None and doc.session_context is not None


def _closed(doc) -> bool:
    session = getattr(doc.session_context, "_session", None)
    return bool(getattr(session, "destroyed", False))


def held(doc, fn: Callable[[], None]) -> None:
    """Run ``fn()`` on ``doc`` (on its event loop) with the document held: the changes it makes are
    collected and reach the browser in the order they were made.

    Why: a callback's changes otherwise take two routes to the browser. Panel sends the changes
    of its panes and layouts at once (``panel.io.document.unlocked``), or, while the websocket
    is busy, queues them for a later write; a change made straight on a bokeh model (a plot's
    ``ColumnDataSource.data``, an axis) is sent by bokeh after the callback returns. Messages
    are serialised in the order the changes were made, and a model is defined only in the first
    message that contains it, so when one route overtakes the other the browser can receive a
    reference to a model before its definition, and BokehJS rejects the whole message
    ("reference p... isn't known"). Measured in chromium over the steps of
    ``tests/browser/test_offline.py``: 66 of the 316 messages of one session arrived out of the
    order they were made; held, 146 messages, none out of order. Held (policy ``collect``: every
    change kept, none merged), a callback's changes leave as one message, written after any
    message Panel still has queued for the document.
    """
    with set_curdoc(doc), hold(doc, policy="collect"):
        fn()


class BuildQueue:
    """Runs page-building steps one at a time on the server's event loop.

    Parameters
    ----------
    duty : float
        Largest share of the loop's time spent in steps while steps wait (0 < duty <= 1):
        after a step of ``d`` seconds the queue rests ``d * (1 - duty) / duty``.
    min_rest_s : float
        Shortest rest between two steps.
    stall_s : float
        A step not started this long after it was scheduled (its session closed) is dropped.
    """

    def __init__(self, duty: float = 0.5, *, min_rest_s: float = 0.005, stall_s: float = 5.0) -> None:
        if not 0.0 < duty <= 1.0:
            raise ValueError(f"duty must be in (0, 1], got {duty}")
        self.duty, self.min_rest_s, self.stall_s = float(duty), float(min_rest_s), float(stall_s)
        self._steps: deque = deque()
        self._busy = False
        self._loop = None
        self._token = 0
        #: Seconds each step took (the last 200), for the lag monitor and tests.
        self.durations: deque = deque(maxlen=200)

    @property
    def pending(self) -> int:
        """Steps waiting."""
        return len(self._steps)

    def submit(self, doc, steps: Iterable[Step], *, on_done: Step | None = None) -> None:
        """Queue ``steps`` (in order) for ``doc``; ``on_done()`` runs after the last one.

        Call it on the event loop's thread (the app script or a callback). Without a served
        document the steps (and ``on_done``) run at once, here.
        """
        steps = list(steps)
        if on_done is not None:
            steps.append(on_done)
        if not _served(doc):
            for step in steps:
                step()
            return
        if self._loop is None:
            from tornado.ioloop import IOLoop

            self._loop = IOLoop.current()
        self._steps.extend((doc, step) for step in steps)
        if not self._busy:
            self._busy = True
            self._loop.add_callback(self._next)

    def _drop(self, doc) -> None:
        self._steps = deque(item for item in self._steps if item[0] is not doc)

    def _next(self) -> None:
        while self._steps:
            doc, step = self._steps[0]
            if _closed(doc):
                self._drop(doc)
                continue
            self._token += 1
            token = self._token
            try:
                doc.add_next_tick_callback(partial(self._run, token, doc, step))
            except Exception:  # noqa: BLE001 - the document is gone
                self._drop(doc)
                continue
            self._loop.call_later(self.stall_s, self._stalled, token, doc)
            return
        self._busy = False

    def _stalled(self, token: int, doc) -> None:
        if token == self._token and self._busy and self._steps and self._steps[0][0] is doc:
            log.debug("build steps of a closed session dropped")
            self._drop(doc)
            self._token += 1
            self._next()

    def _run(self, token: int, doc, step: Step) -> None:
        if token != self._token:  # dropped by _stalled meanwhile
            return
        self._token += 1
        if self._steps and self._steps[0] == (doc, step):
            self._steps.popleft()
        start, cpu = time.perf_counter(), time.thread_time()
        try:
            held(doc, step)
        except Exception:
            log.exception("building a piece of the page failed")
        took = time.perf_counter() - start
        self.durations.append(took)
        watcher = monitor.current()
        if watcher is not None:
            watcher.note("build step", step=getattr(step, "__name__", "step"), seconds=round(took, 3),
                         cpu=round(time.thread_time() - cpu, 3), waiting=len(self._steps))
        rest = max(self.min_rest_s, took * (1.0 - self.duty) / self.duty)
        self._loop.call_later(rest, self._next)


_queue: BuildQueue | None = None


def build_queue() -> BuildQueue:
    """The process-wide :class:`BuildQueue`."""
    global _queue
    if _queue is None:
        _queue = BuildQueue()
    return _queue


def run_steps(steps: Iterable[Step], *, on_done: Step | None = None) -> None:
    """Build ``steps`` on the current document: queued on :func:`build_queue` when it is a served
    session's (call on the event loop's thread), else at once.

    A served page is built only once it is connected (``pn.state.onload``): changes made to the
    document between the first page request and the browser's connection reached the browser
    as patches to models it did not know ("reference ... isn't known"), and the page stayed
    incomplete.
    """
    import panel as pn

    doc, steps = pn.state.curdoc, list(steps)
    if _served(doc) and not pn.state.loaded:
        pn.state.onload(lambda: build_queue().submit(doc, steps, on_done=on_done))
    else:
        build_queue().submit(doc, steps, on_done=on_done)
