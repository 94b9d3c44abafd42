"""``beam diagnose`` as a person at a terminal meets it: progress on a terminal only, help that names
its options, the units ``beam calibrate`` prints, and ``--report FILE.html``."""

from __future__ import annotations

import json
import math
import os
import pty
import re
import select
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from test_handout import assert_self_contained

from beam.cli.diagnose_command import format_report
from beam.cli.main import build_parser
from beam.discovery.handout import ladder_svg
from beam.discovery.report import verdict_sentence

REPO = Path(__file__).resolve().parents[1]
#: A short diagnosis of a bundled run (tip mass hidden): 3 modes on its first 0.8 s.
QUICK = ["diagnose", "lab_run_2", "--modes", "3", "--window", "0:0.8"]


def _help(command: str) -> str:
    parser = build_parser()
    sub = next(a for a in parser._actions if hasattr(a, "choices") and isinstance(a.choices, dict))
    return sub.choices[command].format_help()


@pytest.mark.parametrize("command", ["calibrate", "diagnose"])
def test_the_effect_list_names_an_option_the_command_has(command):
    text = _help(command)
    named = re.findall(r"ids for (--[a-z-]+)", text)
    assert named, text[-400:]
    options = {s for a in build_parser()._subparsers._group_actions[0].choices[command]._actions for s in a.option_strings}
    assert set(named) <= options, (named, sorted(options))
    if command == "diagnose":
        assert named == ["--base"] and "--report" in options


def _summary(unit: str) -> dict:
    """A diagnosis summary in SI units, as ``beam diagnose --json`` gives it."""
    step = {"effects": ["air_damping"], "added": None, "rmse_calibration": 8.38e-4, "rmse_prediction": 1.1520e-3,
            "coverage95_prediction": 0.9987, "log_evidence": 1.0, "mcmc": False}
    return {"measurement": "rec", "window_s": [0.0, 0.8], "modes": 3, "base": ["air_damping"],
            "rmse_prediction_base": 1.1520e-3, "coverage95_prediction_base": 0.9987, "output_unit": unit,
            "modes_table": [],
            "candidates": [{"effect": "tip_mass", "delta_log_evidence": 2194.3, "rmse_prediction": 3.0180e-5,
                            "material": True, "explanation": "a mass at the tip"}],
            "ladder": [step, dict(step, added="tip_mass", rmse_calibration=2.03e-5, rmse_prediction=3.018e-5,
                                  coverage95_prediction=0.907)],
            "verdict": "v", "notes": [], "seconds": 1.0}


def test_the_readable_report_prints_lengths_in_micrometres_and_coverage_in_percent():
    text = format_report(_summary("m"))
    assert "held-out RMSE of the base model 1152 µm" in text  # 1.152e-3 m
    assert "inside its 95 % prediction band: 99.9 %" in text
    assert "30.2 µm" in text and "+2194.3" in text  # the candidate's held-out RMSE, its evidence
    assert "RMSE calibration 20.3 µm, held-out 30.2 µm, held-out inside the 95 % band 90.7 %" in text
    assert not re.search(r"\d[eE][-+]?\d", text), "an exponent in the human report"
    assert " m," not in text and " m " not in text


def test_an_acceleration_record_keeps_its_si_unit_as_calibrate_prints_it():
    from beam.cli.calibrate_command import _in_unit

    summary = _summary("m/s²")
    summary["rmse_prediction_base"] = 1.12
    text = format_report(summary)
    assert f"held-out RMSE of the base model {_in_unit(1.12, 'm/s²')}" in text and "1.12 m/s²" in text
    assert "µm" not in text.split("error ladder")[0]


def test_the_verdict_gives_lengths_in_micrometres():
    sentence = verdict_sentence("tip_mass", 2194.0, 1.1520e-3, 4.66e-5, None)
    assert "1152 -> 46.6 µm" in sentence and "e-0" not in sentence
    assert "1.12 -> 0.14 m/s²" in verdict_sentence("sensor_mass", 3838.0, 1.12, 0.14, None, unit="m/s²")


def test_ladder_bars_are_drawn_on_a_log_axis_ticked_at_decades():
    svg = ladder_svg(["base", "+ tip mass", "+ spring"], [1150.0, 46.5, 15.7], unit="µm", title="t")
    rects = [(float(x), float(w)) for x, w in re.findall(r'<rect x="([\d.]+)" y="[\d.]+" width="([\d.]+)"', svg)]
    ends = np.array([x + w for x, w in rects])
    # a bar ends at log10(value) on a linear pixel scale: equal ratios give equal lengths
    slope = (ends[0] - ends[1]) / math.log10(1150.0 / 46.5)
    assert ends[1] - ends[2] == pytest.approx(slope * math.log10(46.5 / 15.7), abs=0.2)
    ticks = re.findall(r'text-anchor="middle">([\d.e+]+)</text>', svg)
    assert ticks == ["10", "100", "1000", "10000"]
    one = ladder_svg(["base"], [2500.0], unit="µm", title="t")  # a single bar: still whole decades
    assert re.findall(r'text-anchor="middle">([\d.e+]+)</text>', one) == ["1000", "10000"]


@pytest.mark.parametrize("json_out, stdout_tty, stderr_tty, shown", [
    (False, True, True, True), (True, True, True, False), (False, False, True, False), (False, True, False, False)])
def test_progress_only_for_a_person_at_a_terminal(monkeypatch, json_out, stdout_tty, stderr_tty, shown):
    import argparse

    from beam.cli.diagnose_command import wants_progress

    monkeypatch.setattr(sys.stdout, "isatty", lambda: stdout_tty, raising=False)
    monkeypatch.setattr(sys.stderr, "isatty", lambda: stderr_tty, raising=False)
    assert wants_progress(argparse.Namespace(json=json_out)) is shown


def _run_on_terminal(args: list[str], stdout_tty: bool, timeout_s: float = 600.0) -> tuple[int, str, str]:
    """Run ``beam`` with stderr on a pseudo-terminal (and stdout too if ``stdout_tty``); (status, stdout, terminal)."""
    master, slave = pty.openpty()
    env = {**os.environ, "PYTHONPATH": str(REPO), "COLUMNS": "120"}
    proc = subprocess.Popen([sys.executable, "-m", "beam", *args], stdin=subprocess.DEVNULL, stderr=slave,
                            stdout=slave if stdout_tty else subprocess.PIPE, cwd=REPO, env=env)
    os.close(slave)
    seen = bytearray()
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        ready, _, _ = select.select([master], [], [], 0.5)
        if ready:
            try:
                chunk = os.read(master, 65536)
            except OSError:  # the child closed the terminal
                break
            if not chunk:
                break
            seen += chunk
        elif proc.poll() is not None:
            break
    out = proc.stdout.read().decode() if proc.stdout else ""
    status = proc.wait(60)
    os.close(master)
    return status, out, seen.decode(errors="replace")


def test_progress_is_shown_on_a_terminal_and_the_report_is_written(tmp_path):
    report = tmp_path / "diag.html"
    status, _, terminal = _run_on_terminal([*QUICK, "--report", str(report)], stdout_tty=True)
    assert status == 0, terminal[-2000:]
    lines = [part.strip() for part in re.split(r"\r|\x1b\[K|\n", terminal) if part.strip()]
    progress = [line for line in lines if re.match(r"\[\s*\d+ s\] ", line)]
    assert any("calibrating the current model" in line for line in progress), progress
    fitted = [line for line in progress if re.search(r"candidate \S+ fitted \((\d+) of (\d+), (\d+) left\)", line)]
    counts = [tuple(map(int, re.search(r"\((\d+) of (\d+), (\d+) left\)", line).groups())) for line in fitted]
    assert counts, progress
    total = counts[0][1]
    assert sorted(done for done, _, _ in counts) == list(range(1, total + 1))  # every candidate, once
    assert all(left == total - done for done, t, left in counts if t == total)
    assert "error ladder" in terminal and "missing: tip_mass" in terminal  # the report follows on the terminal
    assert f"written: {report}" in terminal and report.exists()


def test_quiet_when_the_output_is_piped_or_json_and_the_html_matches_the_json(tmp_path):
    report = tmp_path / "diag.html"
    status, out, terminal = _run_on_terminal([*QUICK, "--json", "--report", str(report)], stdout_tty=False)
    assert status == 0, terminal[-2000:]
    assert terminal.strip() == ""  # nothing on the terminal: no progress line with --json or a piped stdout
    summary = json.loads(out)
    assert summary["report"] == str(report)
    text = report.read_text(encoding="utf-8")
    assert_self_contained(text)
    assert "Error ladder" in text and "Candidate effects, best first" in text and "Residual of the starting model" in text
    ladder = summary["ladder"]
    for step in ladder:  # the page's ladder rows are the JSON's, in µm (beam.io.handout.micrometres)
        from beam.io.handout import micrometres

        assert micrometres(step["rmse_prediction"]) in text
    for candidate in summary["candidates"]:
        assert f"{candidate['delta_log_evidence']:+.1f}" in text
    assert text.count("<svg") == 3
