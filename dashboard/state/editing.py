"""One lock for every change of the session states' constant parameters.

``param.edit_constant(obj)`` makes the object's parameters writable for the duration of a
``with`` block and constant again at its end; two threads editing one state at once (a request
from the caller's thread while a run's update is delivered on a pool thread, as when the states
are driven without a server: tests and scripts) made one of them fail with "Constant parameter
'stage' cannot be modified", and the slot then dropped every later update of that run (a
diagnosis left "queued"). Under a server every change
happens on the document's thread and the lock is uncontended.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager

import param

__all__ = ["editing"]

_LOCK = threading.RLock()


@contextmanager
def editing(obj: param.Parameterized) -> Iterator[None]:
    """``param.edit_constant(obj)`` under the states' one re-entrant lock."""
    with _LOCK, param.edit_constant(obj):
        yield
