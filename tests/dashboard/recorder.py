"""A run slot's ``on_update`` for the scheduler and worker tests: records every update and the
stale ones (delivered when a newer request was already the slot's latest)."""

from __future__ import annotations

import threading

from dashboard.runtime import scheduler as sch


class Recorder:
    """on_update that records each update and whether its request was still the latest."""

    def __init__(self) -> None:
        self.updates: list[sch.Update] = []
        self.stale: list[sch.Update] = []
        self.slot: sch.RunSlot | None = None
        self.lock = threading.Lock()

    def __call__(self, update: sch.Update) -> None:
        with self.lock:
            self.updates.append(update)
            if update.request != self.slot.latest:
                self.stale.append(update)

    def kinds(self, request: int | None = None) -> list[str]:
        """Kinds of the updates (of one request, or all)."""
        return [u.kind for u in self.updates if request is None or u.request == request]

    def of(self, request: int) -> list[sch.Update]:
        """The updates of one request."""
        return [u for u in self.updates if u.request == request]


def make_slot(pool: sch.RunPool, **kw) -> tuple[sch.RunSlot, Recorder]:
    """A run slot on ``pool`` whose updates go to a new :class:`Recorder`."""
    rec = Recorder()
    slot = sch.RunSlot(rec, pool=pool, **kw)
    rec.slot = slot
    return slot, rec
