"""The session's status line: what runs now, on every tab, always in view.

:func:`session_status` is one line above the tabs, sticky at the top of the window: while anything
of the session runs (a calibration, a diagnosis, a file being read, a study, ...) it names each
running thing, what it is about (the record's name) and what it does ("sampling: 120 of 400
ensemble steps", the percentage done); when nothing runs, the last thing that ended and how.
Each tab keeps its own status line (stage, details, progress bar); this one is there so that a
student who scrolled down a tab, or left it, still sees that something works — and that nothing
says "complete" while a step of the same request (the calibration an *Add* asked for) still runs.

While anything runs, the line also counts each running thing's seconds ("… · 34 s"), and a
periodic callback of the session redraws it every :data:`REFRESH_MS` (with the latest step the
job reported: "fitting tip_mass on the base (candidate 3 of 7), first stage, MAP search:
iteration 4, 6 of 9 starts going"), so that the line never stands still while the session works,
even through one long fit. The callback exists only while something runs (removed when the
last run ends, and when the session ends): an idle session costs nothing.

``data-busy`` holds the number of running things (read by the browser tests).
"""

from __future__ import annotations

import html
import time

from dashboard.state.run import BUSY
from dashboard.views.panes import HTML

__all__ = ["HIDDEN_RUNS", "REFRESH_MS", "StatusTicker", "busy_runs", "session_status", "status_text"]

#: Milliseconds between two redraws of the line while anything runs (the elapsed seconds).
REFRESH_MS = 1000

#: Runs not named on the line (describing a beam takes a few milliseconds).
HIDDEN_RUNS = ("record-beam",)
#: The line's style: sticky at the top of the window, above the page, wrapping when long.
STYLE = {"position": "sticky", "top": "0", "z-index": "20", "background": "#f6f8fa",
         "border-bottom": "1px solid #d0d7de", "padding": "2px 10px", "overflow-wrap": "anywhere"}


def _what(run) -> str:
    """``"Calibration of lab_run_1"``; a label with ``{}`` takes the subject there (``"Reading {}"``)."""
    if "{}" in run.label:
        return run.label.format(run.subject or "the file").strip()
    return f"{run.label} of {run.subject}" if run.subject else run.label


def _doing(run) -> str:
    """The run's status without a repeat of its label ("Window sweep: window sweep: 3 of 15 windows")."""
    status = run.status
    if status.lower().startswith(run.label.lower()):
        status = status[len(run.label):].lstrip(" :")
    return status


def busy_runs(runs: dict) -> list:
    """The runs of ``runs`` ({name: Run}) the line names as running."""
    return [run for name, run in runs.items() if name not in HIDDEN_RUNS and run.stage in BUSY]


def status_text(runs: dict, last: str | None, now: float | None = None) -> str:
    """The line's HTML: every busy run of ``runs`` ({name: Run}) with its seconds since it became
    busy at ``now`` (:func:`time.monotonic`; default now), else the one named ``last`` (the latest
    to change), else a word of welcome."""
    busy = busy_runs(runs)
    if busy:
        now = time.monotonic() if now is None else now
        parts = []
        for run in busy:
            done = f" ({round(100 * run.progress)} %)" if run.progress else ""
            since = getattr(run, "since", None)
            seconds = f" · {max(now - since, 0.0):.0f} s" if since is not None else ""
            parts.append(f"<b>{html.escape(_what(run))}</b>: {html.escape(_doing(run))}{done}{seconds}")
        text, kind = "Working — " + " · ".join(parts), "busy"
    elif last is not None and last in runs and runs[last].stage != "idle":
        run = runs[last]
        if run.stage == "error":
            text, kind = f"<b>{html.escape(_what(run))}</b> failed: {html.escape(run.error)}", "error"
        else:
            text, kind = f"<b>{html.escape(_what(run))}</b>: {html.escape(_doing(run))}", "done"
    else:
        text, kind = "Nothing running.", "idle"
    return (f'<div class="session-status" data-busy="{len(busy)}" data-kind="{kind}" '
            f'style="font-size:15px;line-height:1.35;">{text}</div>')


class StatusTicker:
    """The line's redraw while anything runs: a periodic callback made by ``add(callback,
    period_ms)`` when a run becomes busy, stopped (its ``stop()``) once none is, or at
    :meth:`close` (the session's end). ``add`` is Panel's
    :meth:`pn.state.add_periodic_callback` in the app; a test gives its own."""

    def __init__(self, redraw, add, period_ms: int = REFRESH_MS) -> None:
        self.redraw, self.add, self.period_ms = redraw, add, int(period_ms)
        self.callback = None
        self.closed = False

    def update(self, busy: bool) -> None:
        """Start the callback when ``busy`` and none runs; stop it when not."""
        if busy and self.callback is None and not self.closed and self.add is not None:
            self.callback = self.add(self.redraw, period=self.period_ms)
        elif not busy and self.callback is not None:
            callback, self.callback = self.callback, None
            try:
                callback.stop()
            except ValueError:  # the session's document removed it already (its end)
                pass

    def close(self) -> None:
        """Stop the callback for good (the session ended)."""
        self.closed = True
        self.update(False)


def session_status(session, add_periodic_callback=None) -> HTML:
    """The session's status line (module docstring), updated when any of its runs changes and,
    while one runs, every :data:`REFRESH_MS` by ``add_periodic_callback(callback, period=ms)``
    (default: Panel's, in a server session; none outside one)."""
    runs = {name: run for name, run in session.runs.items() if name not in HIDDEN_RUNS}
    pane = HTML(status_text(runs, None), sizing_mode="stretch_width", margin=0, styles=STYLE,
                css_classes=["session-status-line"])
    state = {"last": None}

    def redraw() -> None:
        text = status_text(runs, state["last"])
        if text != pane.object:
            pane.object = text
        ticker.update(bool(busy_runs(runs)))

    served = False
    if add_periodic_callback is None:
        import panel as pn

        doc = pn.state.curdoc
        served = doc is not None and doc.session_context is not None
        add_periodic_callback = pn.state.add_periodic_callback if served else None
    ticker = StatusTicker(redraw, add_periodic_callback)
    pane.ticker = ticker  # for tests
    if served:
        pn.state.on_session_destroyed(lambda context: ticker.close())

    def watcher(name: str):
        def changed(*_events) -> None:
            state["last"] = name
            redraw()
        return changed

    for name, run in runs.items():
        run.param.watch(watcher(name), ["stage", "status", "progress", "error"])
    return pane
