"""One running thing of a session: :class:`Run` owns its latest request's stage, status, progress and error.

Param only (no panel import), tested without a server or a browser. Every activity of a
session that runs a job (a toy calibration, its window sweep, a beam calibration, a diagnosis,
a window study, reading a file, a joint calibration and a joint diagnosis) holds one
:class:`Run`. The run turns the scheduler's updates (:class:`dashboard.runtime.scheduler.Update`)
into its parameters, always the same way:

========== ============================== =========================================== ===================
update     ``stage``                      ``status``                                  ``progress``
========== ============================== =========================================== ===================
request    ``queued`` (or the one given)  what was asked                              0
progress   :attr:`Words.progress`         the job's message                           its fraction
preview    ``preview``                    the job's message                           its fraction
partial    :attr:`Words.partial`          the job's message                           its fraction
final      :attr:`Words.final`            :attr:`Words.ready` (message, seconds)      1
error      ``error``                      :attr:`Words.failed` (+ :attr:`Words.kept`) 0
========== ============================== =========================================== ===================

and hands the update to its owner's ``show`` callback first (under the same lock), which sets
the owner's own results (a preview, a diagnosis, a finished cell) and may return values of the
run's parameters to use instead (a study's final status counts its failed cells). A failed
request keeps what was shown: ``error`` holds the readable message (flags and binary content
removed, :func:`dashboard.outputs.toy.user_message`), ``status`` says that the previous result is still shown.

:class:`RunOwner` gives a state whose main run is ``self.run`` its run's parameters as read-only
attributes (``state.stage`` is ``state.run.stage``).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import param

from dashboard.outputs.toy import user_message
from dashboard.runtime import scheduler as sch
from dashboard.state.editing import editing

__all__ = ["BUSY", "STAGES", "Pins", "Run", "RunOwner", "Words"]

#: Every stage a run can be in (each activity uses its own few: a file is ``reading`` then ``read``,
#: a study ``running``; a calibration shows a ``preview``, then ``sampling``, then ``final``).
STAGES = ("idle", "queued", "reading", "preview", "sampling", "running", "read", "final", "cancelled", "error")
#: Stages of a request that is still working.
BUSY = ("queued", "reading", "preview", "sampling", "running")
#: Largest number of requests whose timings a run keeps.
TIMINGS_KEPT = 50


@dataclass(frozen=True)
class Words:
    """How one run's updates read (see the module's table).

    Attributes
    ----------
    progress, partial, final : str
        The stage of a ``progress`` update, of a ``partial`` result and of the ``final`` one.
    ready : str
        The status of the final result: formatted with ``message`` (the job's) and ``seconds``
        (since the request).
    failed : str
        The status of a failed request ...
    kept : str
        ... followed by this when an earlier result is still shown.
    """

    progress: str = "sampling"
    partial: str = "preview"
    final: str = "final"
    ready: str = "{message}: ready in {seconds:.1f} s"
    failed: str = "failed."
    kept: str = " The previous result is still shown."


class Run(param.Parameterized):
    """The latest request of one activity of a session (see the module docstring).

    Parameters
    ----------
    label : str
        What runs, for the session's status line (``"Calibration"``, ``"Diagnosis"``: "... of SUBJECT";
        a ``{}`` in it takes the subject's place: ``"Reading {}"``).
    words : Words
        How its updates read.
    show : callable, optional
        ``show(update)``: the owner's part of an update (its results), called before the run's
        parameters change; may return a dict of run parameters to use instead of the table's.
    """

    stage = param.Selector(default="idle", objects=list(STAGES), constant=True, doc="Where the latest request is.")
    status = param.String("", constant=True, doc="One line for the user: what the latest request is doing or did.")
    progress = param.Number(0.0, bounds=(0.0, 1.0), constant=True, doc="Fraction of the latest request done.")
    error = param.String("", constant=True, doc="Readable message of the latest failure, or ''.")
    requested = param.Integer(0, constant=True, doc="Id of the latest request (0 before the first).")
    shown = param.Integer(0, constant=True, doc="Id of the request whose result is shown (0: none yet).")
    subject = param.String("", constant=True, doc="What the latest request is about (a record's name), or ''.")
    shown_subject = param.String("", constant=True, doc="What the request whose result is shown is about, or ''.")

    def __init__(self, label: str = "Run", *, words: Words = Words(), show: Callable | None = None, **params) -> None:
        super().__init__(**params)
        self.label = label
        self.words = words
        self._show = show
        self.slot: sch.RunSlot | None = None
        #: :func:`time.monotonic` (s) when the run last became busy (its latest request, or a
        #: :meth:`note` that it waits); None before. The session's status line counts from it.
        self.since: float | None = None
        self._timings: dict[int, dict[str, float]] = {}
        self._subjects: dict[int, str] = {}
        self._ended = 0  # the latest request whose final or error was shown

    def attach(self, slot: sch.RunSlot) -> None:
        """Give the run its scheduler slot (done by :meth:`dashboard.state.session.SessionState.run`)."""
        self.slot = slot

    @property
    def busy(self) -> bool:
        """Whether the latest request is still working."""
        return self.stage in BUSY

    # -- requests --------------------------------------------------------------------------------
    def request(self, job: sch.Job, *, status: str, debounce_s: float | None = 0.0, stage: str = "queued",
                subject: str | None = None) -> int:
        """Run ``job`` (it supersedes the latest request); returns the new request id.

        ``status`` says what was asked, ``subject`` what it is about (a record's name; None: as
        before); ``debounce_s`` as :meth:`dashboard.runtime.scheduler.RunSlot.request` (None: the
        slot's debounce).
        """
        rid = self.slot.request(job, debounce_s=debounce_s)
        self.since = time.monotonic()
        values = {"requested": rid, "stage": stage, "progress": 0.0, "status": status, "error": ""}
        if subject is not None:
            values["subject"] = subject
        self._subjects[rid] = self.subject if subject is None else subject
        if len(self._subjects) > TIMINGS_KEPT:
            self._subjects.pop(min(self._subjects))
        with editing(self):
            self.param.update(**values)
        return rid

    def note(self, *, stage: str | None = None, status: str | None = None, error: str | None = None) -> None:
        """Say what the activity waits for or did without a request of its own (e.g. a diagnosis
        waiting for the calibration it will diagnose)."""
        values = {k: v for k, v in (("stage", stage), ("status", status), ("error", error)) if v is not None}
        if stage in BUSY and not self.busy:
            self.since = time.monotonic()
        with editing(self):
            self.param.update(**values)

    def cancel(self, status: str, *, stage: str = "idle") -> bool:
        """Stop the latest request if it is working (what was shown stays); whether it was."""
        if not self.busy:
            return False
        if self.slot is not None:
            self.slot.cancel()
        with editing(self):
            self.param.update(stage=stage, progress=0.0, status=status)
        return True

    def close(self) -> None:
        """Cancel and refuse further requests (the session ends)."""
        if self.slot is not None:
            self.slot.close()

    def wait(self, timeout: float | None = None) -> bool:
        """Block until the latest request has finished (tests and scripts)."""
        return True if self.slot is None else self.slot.wait(timeout)

    def timings(self, request: int) -> dict[str, float]:
        """Seconds from request to each published stage, e.g. ``{"preview": 0.3, "final": 2.1}``."""
        return dict(self._timings.get(request, {}))

    # -- updates from the scheduler ------------------------------------------------------------
    def on_update(self, update: sch.Update) -> None:
        """The slot's callback: the owner's part of ``update``, then the run's (module table).

        Nothing of a request changes the run after its final or its error: an update of it that
        arrives later (a throttled progress, a preview delivered behind the final) is dropped."""
        if update.request <= self._ended:
            return
        if update.kind in ("final", "error"):
            self._ended = update.request
        self._timings.setdefault(update.request, {}).setdefault(update.kind, update.elapsed_s)
        if len(self._timings) > TIMINGS_KEPT:
            self._timings.pop(min(self._timings))
        w, kind = self.words, update.kind
        if kind == "error":
            values = {"stage": "error", "error": user_message(update.message), "progress": 0.0,
                      "status": w.failed + (w.kept if self.shown else "")}
        elif kind == "progress":
            values = {"stage": w.progress, "progress": update.fraction or 0.0, "status": update.message}
        elif kind == "final":
            values = {"stage": w.final, "error": "", "progress": 1.0,
                      "status": w.ready.format(message=update.message, seconds=update.elapsed_s)}
        else:
            values = {"stage": "preview" if kind == "preview" else w.partial, "error": "",
                      "progress": update.fraction or 0.0, "status": update.message}
        if kind in ("preview", "partial", "final"):
            values.update(shown=update.request, shown_subject=self._subjects.get(update.request, self.subject))
        with editing(self):
            override = self._show(update) if self._show is not None else None
            self.param.update(**{**values, **(override or {})})

    def describe(self) -> dict:
        """Plain summary (for logs and tests)."""
        return {"stage": self.stage, "status": self.status, "error": self.error, "requested": self.requested,
                "shown": self.shown}


def _of_run(name: str) -> property:
    return property(lambda self: getattr(self.run, name), doc=f"The run's ``{name}`` (:class:`Run`).")


class RunOwner:
    """Mixin of a state whose main activity is ``self.run``: its parameters as read-only attributes."""

    stage = _of_run("stage")
    status = _of_run("status")
    progress = _of_run("progress")
    error = _of_run("error")
    requested = _of_run("requested")
    shown = _of_run("shown")

    def timings(self, request: int) -> dict[str, float]:
        """:meth:`Run.timings` of the main run."""
        return self.run.timings(request)


class Pins:
    """Mixin of a state that shows a ``result`` and keeps one ``pinned`` for comparison (param
    parameters of the state)."""

    def pin(self) -> None:
        """Keep the shown result for comparison with the next ones."""
        if self.result is not None:
            with editing(self):
                self.pinned = self.result

    def unpin(self) -> None:
        """Drop the pinned result."""
        with editing(self):
            self.pinned = None
