"""The session's status line: what runs now, on every tab, always in view.

:func:`session_status` is one line above the tabs, sticky at the top of the window: while anything
of the session runs (a calibration, a diagnosis, a file being read, a study, ...) it names each
running thing, what it is about (the record's name) and what it does ("sampling: 120 of 400
ensemble steps", the percentage done); when nothing runs, the last thing that ended and how.
Each tab keeps its own status line (stage, details, progress bar); this one is there so that a
student who scrolled down a tab, or left it, still sees that something works — and that nothing
says "complete" while a step of the same request (the calibration an *Add* asked for) still runs.

``data-busy`` holds the number of running things (read by the browser tests).
"""

from __future__ import annotations

import html

from dashboard.state.run import BUSY
from dashboard.views.panes import HTML

__all__ = ["HIDDEN_RUNS", "session_status", "status_text"]

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


def status_text(runs: dict, last: str | None) -> str:
    """The line's HTML: every busy run of ``runs`` ({name: Run}), else the one named ``last`` (the
    latest to change), else a word of welcome."""
    busy = [run for name, run in runs.items() if name not in HIDDEN_RUNS and run.stage in BUSY]
    if busy:
        parts = []
        for run in busy:
            done = f" ({round(100 * run.progress)} %)" if run.progress else ""
            parts.append(f"<b>{html.escape(_what(run))}</b>: {html.escape(_doing(run))}{done}")
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


def session_status(session) -> HTML:
    """The session's status line (module docstring), updated when any of its runs changes."""
    runs = {name: run for name, run in session.runs.items() if name not in HIDDEN_RUNS}
    pane = HTML(status_text(runs, None), sizing_mode="stretch_width", margin=0, styles=STYLE,
                css_classes=["session-status-line"])
    state = {"last": None}

    def watcher(name: str):
        def changed(*_events) -> None:
            state["last"] = name
            text = status_text(runs, name)
            if text != pane.object:
                pane.object = text
        return changed

    for name, run in runs.items():
        run.param.watch(watcher(name), ["stage", "status", "progress", "error"])
    return pane
