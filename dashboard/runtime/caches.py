"""Process-wide result caches shared by all sessions.

:class:`LRU`
    A small thread-safe least-recently-used cache.
:func:`cached_stages`
    The stages of a job computed in a worker process (:func:`dashboard.runtime.scheduler.offload`),
    its final value kept in a cache of the server process.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Hashable, Iterator

from dashboard.runtime import scheduler as sch

__all__ = ["LRU", "cached_stages"]

class LRU:
    """A small thread-safe least-recently-used cache.

    Parameters
    ----------
    size : int
        Entries kept.
    """

    def __init__(self, size: int) -> None:
        self.size = int(size)
        self._data: OrderedDict = OrderedDict()
        self._lock = threading.Lock()

    def get(self, key: Hashable):
        """The cached value or None."""
        with self._lock:
            if key not in self._data:
                return None
            self._data.move_to_end(key)
            return self._data[key]

    def put(self, key: Hashable, value) -> None:
        """Store ``value`` (evicting the oldest entry when full)."""
        with self._lock:
            self._data[key] = value
            self._data.move_to_end(key)
            while len(self._data) > self.size:
                self._data.popitem(last=False)

    def clear(self) -> None:
        """Drop everything."""
        with self._lock:
            self._data.clear()

    def __len__(self) -> int:
        return len(self._data)


def cached_stages(cache: LRU, key: Hashable, fn, *args, **kwargs) -> Iterator[sch.Stage]:
    """The stages of ``fn(*args, **kwargs)`` run by :func:`dashboard.runtime.scheduler.offload`; the final value is cached.

    The cache lives in the server process (shared by all sessions), whichever worker computed
    the value. Closing this generator closes the offloaded run (cancellation).
    """
    stages = sch.offload(fn, *args, **kwargs)
    try:
        for stage in stages:
            if stage.kind == "final" and key is not None:
                cache.put(key, stage.value)
            yield stage
    finally:
        stages.close()
