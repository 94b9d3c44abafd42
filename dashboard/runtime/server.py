"""Once per server process: what the app script sets up before its first session.

:func:`prepare` is idempotent and called at the top of every session's app script (Panel
re-runs ``dashboard/app.py`` for each browser session, so a module-level flag there would not
survive). It

* installs the event-loop lag monitor when ``BEAM_DASHBOARD_LAG_LOG`` is set
  (:mod:`dashboard.runtime.monitor`);
* starts the shared pool's worker processes, which warm up while the first page loads
  (:mod:`dashboard.runtime.workers`);
* collects garbage once and freezes what survives (:func:`gc.freeze`): the libraries the
  server imported (panel, bokeh, pandas, numpy, scipy, beam: hundreds of thousands of
  objects) are never freed anyway, and every full collection scanned them again — measured
  0.19–0.28 s of the event loop per collection while eight sessions opened. After the freeze
  a full collection scans only what the sessions made.
"""

from __future__ import annotations

import gc
import threading

from dashboard.runtime import monitor
from dashboard.runtime.scheduler import shared_pool

__all__ = ["prepare"]

_lock = threading.Lock()
_prepared = False


def prepare() -> None:
    """Set up the server process (the first call does the work; later calls return at once)."""
    global _prepared
    with _lock:
        if _prepared:
            return
        _prepared = True
    monitor.install()  # only with BEAM_DASHBOARD_LAG_LOG set (a diagnostic)
    shared_pool().start_processes()
    gc.collect()
    gc.freeze()
