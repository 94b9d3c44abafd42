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

    With ``marker``, the file ``marker + '.closed'`` is written when the generator is closed
    (how a test sees that a cancelled run stopped in the worker).
    """
    try:
        yield sch.preview({"pid": os.getpid(), "tag": tag})
        for i in range(n):
            time.sleep(pause_s)
            yield sch.progress((i + 1) / n, f"{i + 1} of {n}")
        yield sch.final({"pid": os.getpid(), "tag": tag})
    finally:
        if marker is not None:
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
