"""What a long fit is doing, told to the ``progress(text)`` callback of whoever asked for it.

The long computations (a MAP search's lock-step iterations, a start continuing alone, the
Laplace step, emcee's chunks) sit many calls below the function that was given a
``progress`` callback (:func:`beam.discovery.report.diagnose`, a dashboard job, ``beam
calibrate``). Rather than pass the callback through every layer, the caller installs it for the
code it runs with :func:`reporting`, and the code deep down calls :func:`report`::

    with reporting(progress, "fitting tip_mass on the base (candidate 3 of 7)"):
        calibration_preview(measurement, spec)
    # progress("fitting tip_mass on the base (candidate 3 of 7), MAP search: iteration 4, 6 of 9 starts going")

Contract: the callback is the only output (no second channel: nothing is printed or queued
here); :func:`report` without a :func:`reporting` around it does nothing and costs one context
lookup (tens of nanoseconds), so numerical code may call it once per iteration. The callback is
held in a :class:`contextvars.ContextVar`: each thread has its own (a fit on another thread is
told only if :func:`reporting` was entered on that thread), and a callback must be safe to call
from the thread that runs the fit. Nested :func:`reporting` blocks join their labels with
``", "`` and tell the outer block's callback.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar

__all__ = ["report", "reporting"]

_CALLBACK: ContextVar[Callable[[str], None] | None] = ContextVar("beam_progress", default=None)


def report(text: str) -> None:
    """Tell the current :func:`reporting` block's callback ``text`` (its label first); nothing
    outside one."""
    callback = _CALLBACK.get()
    if callback is not None:
        callback(text)


@contextmanager
def reporting(progress: Callable[[str], None] | None, label: str = "") -> Iterator[None]:
    """Within the block, :func:`report` tells ``progress`` ``"<label>, <text>"`` (``label`` itself
    is told when the block is entered). ``progress=None``: the enclosing block's callback, if any
    (a step inside a fit: ``reporting(None, "second stage")``); with none, nothing is told."""
    outer = _CALLBACK.get() if progress is None else progress
    if outer is None:
        yield
        return
    told = outer
    if label:
        def told(text: str) -> None:
            outer(f"{label}, {text}" if text else label)
        outer(label)
    token = _CALLBACK.set(told)
    try:
        yield
    finally:
        _CALLBACK.reset(token)
