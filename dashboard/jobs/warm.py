"""Warming up a worker process or the server before the first run (imports, compiled kernels).

:func:`warm_up`
    Imports the sampler's libraries once per process (ArviZ takes seconds); jobs call it
    before they sample.
:func:`schedule_warm_up`
    At app start: starts the pool's worker processes, or warms up on one of its threads.
"""

from __future__ import annotations

import threading

__all__ = ["is_warm", "schedule_warm_up", "warm_up"]

_warm_lock = threading.Lock()
_schedule_lock = threading.Lock()  # not _warm_lock: that one is held for seconds by the import
_warmed = False
_warm_scheduled = False


def is_warm() -> bool:
    """Whether this process has imported the sampler's libraries already."""
    return _warmed


def warm_up() -> None:
    """Import the sampler's libraries (ArviZ takes seconds the first time); idempotent.

    Blocks while another thread imports them. Jobs call it before they sample: ``beam``
    looks ArviZ up in ``sys.modules`` first, and a module another thread is still importing
    is there half-initialised (measured: ``partially initialized module 'arviz' has no
    attribute 'ess'`` when a worker's warm-up thread and its first calibration met).
    """
    global _warmed
    with _warm_lock:
        if not _warmed:
            import emcee  # noqa: F401

            from beam.inference import import_arviz  # as beam imports it (without a UI toolkit)

            import_arviz()
            _warmed = True


def schedule_warm_up(pool) -> None:
    """Warm up once at app start, so the first MCMC need not wait (never blocks).

    Starts ``pool``'s worker processes (each warms itself up), or, for a pool without
    processes, runs :func:`warm_up` on one of its threads.
    """
    global _warm_scheduled
    if getattr(pool, "workers", None) is not None:
        pool.start_processes()
        return
    with _schedule_lock:
        if _warmed or _warm_scheduled:
            return
        _warm_scheduled = True
    pool.schedule(warm_up)
