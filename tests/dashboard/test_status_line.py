"""The session's status line while a run is busy: what runs, its latest step and its seconds,
redrawn by a periodic callback that exists only while something runs (#40 item 5)."""

from __future__ import annotations

import re

from dashboard.state.run import Run
from dashboard.views.status import REFRESH_MS, StatusTicker, status_text


def busy_run(label: str, status: str, since: float) -> Run:
    run = Run(label)
    run.note(stage="running", status=status)
    run.since = since
    return run


def test_a_busy_run_shows_its_step_and_its_seconds_and_an_idle_one_none():
    run = busy_run("Diagnosis", "fitting tip_mass on the base (candidate 3 of 7), MAP search: iteration 4", 1000.0)
    text = status_text({"diagnosis": run}, None, now=1034.4)
    assert 'data-busy="1"' in text
    assert re.search(r"<b>Diagnosis</b>: fitting tip_mass on the base \(candidate 3 of 7\), MAP search: "
                     r"iteration 4 · 34 s</div>", text), text
    later = status_text({"diagnosis": run}, None, now=1040.0)
    assert "· 40 s" in later and later != text  # the same step, another second: the line changes
    run.note(stage="final", status="Diagnosis: ready in 40.0 s")
    idle = status_text({"diagnosis": run}, "diagnosis", now=1050.0)
    assert 'data-busy="0"' in idle and " s</div>" not in idle.replace("ready in 40.0 s", "")


def test_a_run_counts_from_its_request():
    run = Run("Reading {}")
    assert run.since is None
    run.note(stage="queued", status="waiting")
    first = run.since
    assert first is not None
    run.note(stage="running", status="reading")  # still busy: the count goes on
    assert run.since == first


class FakeCallback:
    def __init__(self, callback, period):
        self.callback, self.period, self.stopped = callback, period, False

    def stop(self):
        self.stopped = True


def test_the_periodic_redraw_exists_only_while_something_runs():
    made: list[FakeCallback] = []

    def add(callback, period):
        made.append(FakeCallback(callback, period))
        return made[-1]

    ticker = StatusTicker(lambda: None, add)
    ticker.update(False)
    assert made == []  # idle: no callback
    ticker.update(True)
    ticker.update(True)  # one callback, however many runs are busy
    assert len(made) == 1 and made[0].period == REFRESH_MS and REFRESH_MS <= 2000
    ticker.update(False)
    assert made[0].stopped and ticker.callback is None
    ticker.update(True)
    assert len(made) == 2
    ticker.close()  # the session ended
    assert made[1].stopped
    ticker.update(True)
    assert len(made) == 2  # never again
