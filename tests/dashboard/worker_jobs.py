"""Generator functions for the worker-process tests (importable by the spawned workers).

Each yields :class:`dashboard.runtime.scheduler.Stage` items, like the real jobs' computations.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

from beam.errors import BeamInputError
from dashboard.runtime import scheduler as sch


def counting(n: int, tag, *, pause_s: float = 0.0, marker: str | None = None):
    """``preview`` with this process's id, ``progress`` per count, ``final`` with ``tag`` itself.

    With ``marker``, the files ``marker + '.count'`` (the counts done) and ``marker + '.closed'``
    (this process's id) are written when the generator is closed (how a test sees that a cancelled
    run stopped in the worker, and where).
    """
    counted = 0
    try:
        yield sch.preview({"pid": os.getpid(), "tag": tag})
        for i in range(n):
            time.sleep(pause_s)
            counted = i + 1
            yield sch.progress((i + 1) / n, f"{i + 1} of {n}")
        yield sch.final({"pid": os.getpid(), "tag": tag})
    finally:
        if marker is not None:
            Path(marker + ".count").write_text(str(counted))
            Path(marker + ".closed").write_text(str(os.getpid()))


def failing(kind: str):
    """Raises a user error, an internal error, or one that does not pickle, after one stage."""
    yield sch.preview(os.getpid())
    if kind == "user":
        raise BeamInputError("window (--window 12 s) must be shorter than the horizon")
    if kind == "bug":
        raise ZeroDivisionError("division by zero")

    class Local(Exception):  # a class defined here cannot be pickled
        pass

    raise Local("a local exception type")


def dying():
    """The worker process exits in the middle of the run."""
    yield sch.preview(os.getpid())
    os._exit(3)


def offloaded(fn, *args, **kwargs):
    """A job that hands ``fn`` to a worker process (what the dashboard's jobs do)."""
    return lambda: sch.offload(fn, *args, **kwargs)


def mapped(fn, calls):
    """A job that spreads ``fn`` over the pool's worker processes (:func:`dashboard.runtime.scheduler.offload_map`)
    and finishes with ``[(index, value), ...]`` in completion order."""
    def job():
        out = []
        for i, value in sch.offload_map(fn, calls):
            out.append((i, value))
            yield sch.partial(list(out))
        yield sch.final(out)
    return job


def queued(marker: str):
    """A job on an :class:`~dashboard.runtime.scheduler.OffloadQueue` with two processes: a long
    and a short call, then one that waits and one that jumps the queue (``first``); once three
    have ended, a blocking call takes the free process and a last one, still waiting, is dropped
    by ``close``. Finishes with the keys in completion order and ``idle()`` along the way."""
    def job():
        q = sch.OffloadQueue()
        idle = [q.idle()]
        q.submit("long", counting, 4, "long", pause_s=0.5)
        q.submit("short", counting, 2, "short", pause_s=0.1)
        idle.append(q.idle())
        q.submit("waits", counting, 1, "waits")
        q.submit("urgent", counting, 1, "urgent", first=True)
        order = [q.next()[0] for _ in range(3)]
        q.submit("blocker", counting, 2, "blocker", pause_s=0.3)
        q.submit("dropped", counting, 1, "dropped", marker=marker)
        q.close()  # "dropped" waits for a process: it never runs
        while q.outstanding():
            order.append(q.next()[0])
        yield sch.final({"order": order, "idle": idle, "capacity": q.capacity})
    return job


def told_while_waiting():
    """A job on an :class:`~dashboard.runtime.scheduler.OffloadQueue`: one call that reports four
    counts, its reports gathered while it runs (:meth:`~dashboard.runtime.scheduler.OffloadQueue.reports`
    until :meth:`~dashboard.runtime.scheduler.OffloadQueue.ended`). Finishes with the reports and the value."""
    def job():
        q = sch.OffloadQueue()
        q.submit("told", counting, 4, "told", pause_s=0.3)
        told = []
        while not q.ended():
            told += [(key, stage.kind, stage.message) for key, stage in q.reports()]
        told += [(key, stage.kind, stage.message) for key, stage in q.reports(0.0)]  # said just before it ended
        key, value = q.next()
        yield sch.final({"told": told, "key": key, "tag": value["tag"], "after": q.reports(0.0)})
    return job
