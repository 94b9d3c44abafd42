"""A blocking computation in a worker process, with what it says while it runs sent as stages.

:func:`told_stages` runs ``compute(progress)`` on a thread of the worker process and yields, while
it runs, a ``progress`` stage with the latest text it told ``progress`` (at most one per
:data:`REPORT_S`), then its value as the ``final`` stage. The library's fits tell what they do
through :func:`beam.inference.progress.reporting` (the diagnosis's requests,
:func:`beam.discovery.run_request`; a joint fit); this is how those words cross the pipe as the
stages a job already sends (:mod:`dashboard.runtime.workers`), not a channel of their own.

Pure Python (no UI import).
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable, Iterator
from typing import Any

from dashboard.runtime import scheduler as sch

__all__ = ["REPORT_S", "told_stages"]

#: Seconds between two progress stages of one computation (the latest text of the interval).
REPORT_S = 0.5


def told_stages(compute: Callable[[Callable[[str], None]], Any], *, message: str = "",
                every_s: float = REPORT_S) -> Iterator[sch.Stage]:
    """``progress`` stages (fraction 0: the driver knows the job's) while ``compute(progress)``
    runs on a thread, then ``final`` with its value (``message`` its message); what ``compute``
    raises is raised here. Closed early (the job was cancelled), the generator waits for
    ``compute`` to end: a computation is not stopped midway."""
    told: queue.SimpleQueue = queue.SimpleQueue()
    out: dict[str, Any] = {}

    def run() -> None:
        try:
            out["value"] = compute(told.put)
        except BaseException as exc:  # noqa: BLE001 - raised again on the generator's side
            out["error"] = exc

    thread = threading.Thread(target=run, name="told-computation", daemon=True)
    thread.start()
    try:
        while thread.is_alive():
            thread.join(every_s)
            latest = None
            while not told.empty():
                latest = told.get()
            if latest is not None and thread.is_alive():
                yield sch.progress(0.0, latest)
    finally:
        thread.join()
    if "error" in out:
        raise out["error"]
    yield sch.final(out["value"], message)
