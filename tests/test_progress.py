"""Progress that never freezes (#40 item 5): what a long fit is doing reaches the ``progress(text)``
callback from inside the fit, named by what is fitted; the command line's progress line counts
its seconds even through one long step."""

from __future__ import annotations

import io
import re
import threading
from pathlib import Path

import pytest

from beam.calibration import CalibrationSpec, Engine, calibrate
from beam.cli.progress_line import TerminalProgress
from beam.discovery import diagnose
from beam.inference.progress import report, reporting
from beam.io.measurement import read_measurement

RECORD = Path(__file__).resolve().parents[1] / "assets" / "measurements" / "lab_run_2.csv"  # hides a tip mass
WINDOW, MODES = (0.0, 0.6), 2


class FakeClock:
    """Seconds that move only when told."""

    def __init__(self, t: float = 100.0) -> None:
        self.t = t

    def __call__(self) -> float:
        return self.t


# -- the channel --------------------------------------------------------------------------------

def test_report_reaches_the_callback_under_nested_labels_and_nothing_outside():
    told: list[str] = []
    report("nobody listens")  # outside any block: nothing, no error
    with reporting(told.append, "fitting tip_mass on the base (candidate 3 of 7)"):
        report("MAP search: iteration 1")
        with reporting(None, "second stage"):
            report("MAP search: iteration 2")
        report("after the stage")
    report("nobody listens again")
    with reporting(None, "no outer block"):  # nothing to tell
        report("lost")
    assert told == ["fitting tip_mass on the base (candidate 3 of 7)",
                    "fitting tip_mass on the base (candidate 3 of 7), MAP search: iteration 1",
                    "fitting tip_mass on the base (candidate 3 of 7), second stage",
                    "fitting tip_mass on the base (candidate 3 of 7), second stage, MAP search: iteration 2",
                    "fitting tip_mass on the base (candidate 3 of 7), after the stage"]


def test_each_thread_tells_its_own_callback():
    told: dict[str, list[str]] = {"a": [], "b": []}
    barrier = threading.Barrier(2)

    def fit(name: str) -> None:
        with reporting(told[name].append, name):
            barrier.wait()  # both blocks open at once
            for i in range(3):
                report(str(i))
            barrier.wait()

    threads = [threading.Thread(target=fit, args=(n,)) for n in told]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert told == {n: [n, f"{n}, 0", f"{n}, 1", f"{n}, 2"] for n in told}


# -- the terminal line ----------------------------------------------------------------------------

def pieces(text: str) -> list[str]:
    """What was drawn, piece by piece (a redraw starts with a carriage return)."""
    return [p for p in text.split("\r") if p]


def test_the_line_counts_its_seconds_through_a_long_step_and_close_erases_it():
    clock, out = FakeClock(), io.StringIO()
    line = TerminalProgress(out, clock=clock, tick_s=None)
    line.tick()  # nothing drawn yet: nothing to redraw
    assert out.getvalue() == ""
    line("fitting tip_mass on the base (candidate 1 of 5)")
    clock.t += 0.2
    line.tick()  # the same second: nothing
    for _ in range(3):
        clock.t += 1.0
        line.tick()
    drawn = pieces(out.getvalue())
    assert drawn == ["\x1b[K[   0 s] fitting tip_mass on the base (candidate 1 of 5)",
                     "[   1 s]", "[   2 s]", "[   3 s]"]  # the time field alone: the step stays on screen
    line("error ladder")
    line.close()
    assert pieces(out.getvalue())[-2:] == ["\x1b[K[   3 s] error ladder", "\x1b[K"]
    clock.t += 5.0
    line.tick()  # closed: nothing more
    assert pieces(out.getvalue())[-1] == "\x1b[K"


def test_a_wider_time_field_redraws_the_whole_line():
    clock, out = FakeClock(), io.StringIO()
    line = TerminalProgress(out, clock=clock, tick_s=None)
    clock.t += 9999.0
    line("MCMC 100 of 600 steps")
    clock.t += 1.0
    line.tick()
    assert pieces(out.getvalue()) == ["\x1b[K[9999 s] MCMC 100 of 600 steps", "\x1b[K[10000 s] MCMC 100 of 600 steps"]


def test_the_ticker_thread_redraws_until_closed():
    class Stepping(FakeClock):
        def __call__(self) -> float:  # one second later at each reading
            self.t += 1.0
            return self.t

    out = io.StringIO()
    line = TerminalProgress(out, clock=Stepping(), tick_s=0.001)
    line("a long step")
    ticker = next(t for t in threading.enumerate() if t.name == "beam-progress-ticker")
    done = threading.Event()
    for _ in range(5000):  # until the ticker has redrawn the time at least twice (no fixed sleep)
        if sum(re.fullmatch(r"\[\s*\d+ s\]", p) is not None for p in pieces(out.getvalue())) >= 2:
            done.set()
            break
        done.wait(0.001)
    assert done.is_set(), out.getvalue()
    line.close()
    assert not ticker.is_alive()
    assert out.getvalue().endswith("\r\x1b[K")


# -- the diagnosis and the calibration tell what they fit ---------------------------------------------

@pytest.fixture(scope="module")
def record():
    return read_measurement(RECORD)


@pytest.mark.slow
def test_a_diagnosis_announces_every_stage_and_names_what_each_fit_fits(record):
    told: list[str] = []
    lock = threading.Lock()

    def progress(text: str) -> None:
        with lock:
            told.append(text)

    report_ = diagnose(record, window=WINDOW, modes=MODES, engine=Engine(), progress=progress)
    names = [c.effect for c in report_.candidates]
    assert report_.missing == "tip_mass"
    # every long stage is announced, in order
    stages = ["calibrating the current model (preview) and its residual diagnostics",
              "fitting the candidate effects: ranking", "error ladder"]
    at = [next(i for i, t in enumerate(told) if t.startswith(s)) for s in stages]
    assert at == sorted(at), told[:5]
    # each candidate's fit is named as it starts, then tells what it does from inside, under its name
    for i, effect in enumerate(sorted(names, key=names.index), 1):
        label = next((t for t in told if re.fullmatch(rf"fitting {effect} on the base \(candidate \d+ of {len(names)}\)", t)),
                     None)
        assert label is not None, (effect, told)
        inside = [t for t in told if t.startswith(label + ", ")]
        assert any("MAP search: iteration" in t for t in inside), (effect, inside[:5])
    base_inside = [t for t in told if t.startswith("calibrating the current model (preview), ")]
    assert any("MAP search" in t or "Newton polish" in t for t in base_inside), told[:10]
    # a message from inside a fit always says which fit it is
    stream_steps = re.compile(r"(calibrating the current model \(preview\) and|fitting the candidate effects|"
                              r"candidate \S+ fitted|error ladder$|ranking the candidates on top)")
    for text in told:
        if not stream_steps.match(text):
            assert re.match(r"(calibrating the current model \(preview\)|fitting \S+ on the base|ahead: fitting|"
                            r"error ladder rung \d+: \+ \S+|(screening )?on top of the ladder|measuring )", text), text


@pytest.mark.slow
def test_the_sampler_reports_every_chunk_so_the_messages_grow_with_its_steps(record):
    counts = {}
    for steps in (100, 300):
        told: list[str] = []
        spec = CalibrationSpec(window=WINDOW, modes=MODES, effects=("air_damping", "kelvin_voigt", "tip_mass"),
                               steps=steps, seed=3)
        with reporting(told.append, "calibrating tip_mass"):
            calibrate(record, spec)
        mcmc = [t for t in told if "MCMC" in t]
        assert mcmc[-1] == f"calibrating tip_mass, MCMC {steps} of {steps} steps", mcmc
        assert [int(re.search(r"MCMC (\d+) of", t).group(1)) for t in mcmc] == list(range(50, steps + 1, 50))
        counts[steps] = len(mcmc)
    assert counts[300] == 3 * counts[100]


@pytest.mark.slow
def test_the_mcmc_ladder_names_each_rung_while_it_samples(record):
    told: list[str] = []
    spec = CalibrationSpec(window=WINDOW, modes=MODES, seed=1)
    diagnosis = diagnose(record, spec, ladder_mcmc=True, engine=Engine(), progress=told.append)
    assert diagnosis.missing == "tip_mass"
    for rung, label in ((1, "the base"), (2, "+ tip_mass")):
        pattern = re.compile(rf"error ladder rung {rung}: {re.escape(label)}, MCMC (\d+) of (\d+) steps")
        steps = [tuple(map(int, m.groups())) for m in map(pattern.fullmatch, told) if m]
        assert len(steps) >= 2, [t for t in told if "rung" in t]
        assert [s for s, _ in steps] == sorted({s for s, _ in steps})  # every chunk once, in order
        assert all(s <= total for s, total in steps) and steps[-1][0] == steps[-1][1]  # its last chunk ends the run
        total_steps = steps[-1][0]
        assert len(steps) >= total_steps // 50  # at least one message per 50 steps sampled


def test_a_long_line_keeps_what_is_fitted_and_what_it_does():
    from beam.cli.progress_line import fitted

    line = ("[  12 s] joint diagnosis of 3 records, fitting tip_mass on the base of every record together "
            "(candidate 2 of 5), record 1 of 3 (ruler_30cm) alone, first stage, MAP search: iteration 4, 6 of 9 starts going")
    short = fitted(line, 79)
    head, tail = short.split("…")
    assert len(short) == 79 and line.startswith(head) and line.endswith(tail)  # its start and its end
    assert len(head) > len(tail) > 25 and short.endswith("6 of 9 starts going")
    assert fitted("[   1 s] error ladder", 79) == "[   1 s] error ladder"
