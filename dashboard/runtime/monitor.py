"""Event-loop lag monitor of the served app (a diagnostic, off unless asked for).

``BEAM_DASHBOARD_LAG_LOG=/path/lag.jsonl panel serve dashboard/app.py`` starts, once per server
process, a watchdog thread that every ``interval_s`` asks the event loop to run a no-op and
times how long that takes (the *lag*: what any request arriving then waits). While the loop
is stalled the watchdog samples the loop thread's Python stack, so each stall longer than
``threshold_s`` is written as one JSON line::

    {"t": 12.3, "lag_s": 0.84, "samples": 41, "top": [["dashboard/views/toy.py:54 __init__", 38], ...],
     "leaf": [["bokeh/core/has_props.py:295 __init__", 9], ...]}

``t`` is seconds since the monitor started, ``top`` counts the frames of this repository
(``dashboard/``, ``beam/``) and a few landmarks of the libraries (Panel's and Bokeh's session
creation, serialisation, websocket handling) over the samples, ``leaf`` the innermost frames.
A summary line (``{"summary": ...}``: count, median, 90 % and max of all the lags measured)
is appended every ``summary_every_s``.

Pure Python plus tornado (no panel import); :func:`install` is idempotent.
"""

from __future__ import annotations

import collections
import gc
import json
import os
import sys
import threading
import time
from pathlib import Path

__all__ = ["ENV", "LagMonitor", "current", "install"]

#: Environment variable naming the JSON-lines file; unset: no monitor.
ENV = "BEAM_DASHBOARD_LAG_LOG"
#: Library frames worth naming in a stall's ``top`` (function names of the session life cycle).
LANDMARKS = (
    "create_session_if_needed", "modify_document", "server_html_page_for_session", "standalone_docs_json",
    "_handle_pull", "to_json", "_get_model", "get_root", "server_doc", "_init_doc", "send_message",
    "_process_events", "_change_event", "_schedule_change", "apply_json_patch", "_trigger_event",
    "_update_model", "_on_load", "serialize", "_execute", "_wrapper",
)

_installed: LagMonitor | None = None
_lock = threading.Lock()


def _where(frame) -> str:
    path = frame.f_code.co_filename
    parts = Path(path).parts
    for anchor in ("dashboard", "beam", "panel", "bokeh", "holoviews", "tornado", "param", "asyncio"):
        if anchor in parts:
            path = "/".join(parts[len(parts) - parts[::-1].index(anchor) - 1:])
            break
    return f"{path}:{frame.f_lineno} {frame.f_code.co_name}"


class LagMonitor:
    """A watchdog thread that times the event loop's answer to a no-op and samples stalls.

    Parameters
    ----------
    loop : tornado.ioloop.IOLoop
        The server's loop (``IOLoop.current()`` on the loop's thread).
    path : str or Path
        JSON-lines output file (appended to).
    interval_s : float
        Time between two probes.
    threshold_s : float
        Stalls longer than this are written with their stack samples.
    sample_s : float
        Time between two stack samples during a stall.
    summary_every_s : float
        Time between two summary lines.
    """

    def __init__(self, loop, path, *, interval_s: float = 0.05, threshold_s: float = 0.1, sample_s: float = 0.01,
                 summary_every_s: float = 10.0) -> None:
        self.loop = loop
        self.path = Path(path)
        self.interval_s, self.threshold_s, self.sample_s = interval_s, threshold_s, sample_s
        self.summary_every_s = summary_every_s
        self.lags: list[float] = []
        self._loop_thread = threading.get_ident()
        self._stop = threading.Event()
        self._t0 = time.monotonic()
        self._thread = threading.Thread(target=self._run, name="beam-lag-monitor", daemon=True)

    def start(self) -> None:
        """Start the watchdog thread (and time the garbage collector's passes)."""
        gc.callbacks.append(self._gc_callback)
        self._thread.start()

    def _gc_callback(self, phase: str, info: dict) -> None:
        if phase == "start":
            self._gc_start = time.perf_counter()
            return
        took = time.perf_counter() - getattr(self, "_gc_start", time.perf_counter())
        if took > 0.02:
            self.note("gc", generation=info.get("generation"), seconds=round(took, 3), collected=info.get("collected"),
                      thread=threading.current_thread().name)

    def stop(self) -> None:
        """Stop the watchdog thread (writes a last summary)."""
        self._stop.set()
        self._thread.join(5)

    def _write(self, record: dict) -> None:
        with self.path.open("a") as f:
            f.write(json.dumps(record) + "\n")

    def note(self, event: str, **fields) -> None:
        """Write an event line (e.g. the time a session took to build)."""
        self._write({"t": round(time.monotonic() - self._t0, 3), "event": event, **fields})

    def summary(self) -> dict:
        """Count, median, 90 % and max of the lags measured so far (seconds)."""
        lags = sorted(self.lags)
        if not lags:
            return {"n": 0}
        return {"n": len(lags), "median": lags[len(lags) // 2], "p90": lags[int(0.9 * len(lags))], "max": lags[-1],
                "over_1s": sum(x > 1.0 for x in lags), "over_0.5s": sum(x > 0.5 for x in lags)}

    def _run(self) -> None:
        last_summary = time.monotonic()
        while not self._stop.is_set():
            answered = threading.Event()
            start = time.monotonic()
            try:
                self.loop.add_callback(answered.set)
            except RuntimeError:  # the loop is closed
                return
            top: collections.Counter = collections.Counter()
            leaf: collections.Counter = collections.Counter()
            samples = 0
            while not answered.wait(self.sample_s):
                if self._stop.is_set():
                    return
                frame = sys._current_frames().get(self._loop_thread)
                if frame is None:
                    continue
                samples += 1
                leaf[_where(frame)] += 1
                seen = set()
                while frame is not None:
                    where = _where(frame)
                    mine = where.startswith(("dashboard/", "beam/")) or frame.f_code.co_name in LANDMARKS
                    if mine and where not in seen:
                        seen.add(where)
                        top[where] += 1
                    frame = frame.f_back
            lag = time.monotonic() - start
            self.lags.append(lag)
            if lag > self.threshold_s:
                self._write({"t": round(start - self._t0, 3), "lag_s": round(lag, 3), "samples": samples,
                             "top": top.most_common(25), "leaf": leaf.most_common(8)})
            if time.monotonic() - last_summary > self.summary_every_s:
                self._write({"t": round(time.monotonic() - self._t0, 3), "summary": self.summary()})
                last_summary = time.monotonic()
            self._stop.wait(self.interval_s)
        self._write({"t": round(time.monotonic() - self._t0, 3), "summary": self.summary()})


def install(path: str | os.PathLike | None = None) -> LagMonitor | None:
    """Start the monitor on the current tornado loop once per process (``path`` default: ``$BEAM_DASHBOARD_LAG_LOG``).

    Returns the monitor, or None when no path is given and the variable is unset. Call it on
    the event loop's thread (e.g. from the app script, which Panel runs there).
    """
    global _installed
    path = path or os.environ.get(ENV)
    if not path:
        return None
    with _lock:
        if _installed is None:
            from tornado.ioloop import IOLoop

            _installed = LagMonitor(IOLoop.current(), path)
            _installed.start()
        return _installed


def current() -> LagMonitor | None:
    """The installed monitor, or None."""
    return _installed
