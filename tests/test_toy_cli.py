"""``beam toy`` on the command line (subprocess, as a user runs it)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from beam.cli.main import main

KEYS = ("amplitude", "frequency_Hz", "phase_rad", "noise_sd")


def _beam(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "beam", "toy", *args], check=False, capture_output=True, text=True, timeout=300)


def test_json_output_has_the_documented_keys():
    proc = _beam("--json")
    assert proc.returncode == 0, proc.stderr
    report = json.loads(proc.stdout)  # exactly one JSON object on stdout
    assert set(report["posterior"]) == set(KEYS)
    for s in report["posterior"].values():
        assert set(s) == {"mean", "sd", "q025", "q975"}
        assert all(isinstance(v, float) for v in s.values())
    assert report["truth"] == {"amplitude": 1.0, "frequency_Hz": 1.0, "phase_rad": 0.3, "noise_sd": 0.1}
    for key in ("rmse_prediction", "coverage95_prediction", "ess_min", "seconds"):
        assert isinstance(report[key], float), key
    assert report["ess_min"] >= 1000
    assert report["converged"] is True and report["likelihood"] == "iid"
    assert "sweep" not in report


def test_json_sweep_with_ar1(capsys):
    code = main(["toy", "--json", "--sweep", "--likelihood", "ar1", "--window", "3", "--horizon", "8", "--target-ess", "300", "--seed", "2"])
    assert code == 0
    report = json.loads(capsys.readouterr().out)
    assert set(report["posterior"]) == set(KEYS) | {"ar1_coefficient"}
    assert report["truth"]["ar1_coefficient"] == 0.0
    windows = [row["window_s"] for row in report["sweep"]]
    assert windows == [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]  # 1..15 s limited by the 8 s horizon
    for row in report["sweep"]:
        assert {"window_s", "rmse_prediction", "coverage95_prediction"} <= set(row)


BAD = [
    (["--window", "-1"], "must be positive"),
    (["--window", "20"], "shorter than the horizon"),
    (["--window", "0.5"], "shorter than one period"),
    (["--kind", "wobble"], "unknown discrepancy kind"),
    (["--noise", "-0.2"], "must not be negative"),
    (["--likelihood", "gauss"], "unknown likelihood"),
    (["--window", "five"], "not a number"),
    (["--seed", "-4"], "non-negative integer"),
]


@pytest.mark.parametrize("args, fragment", [BAD[0], BAD[3], BAD[6]])
def test_bad_options_exit_2_with_one_error_line(args, fragment):
    proc = _beam(*args)
    assert proc.returncode == 2
    assert proc.stdout == ""
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and fragment in lines[0], proc.stderr


@pytest.mark.parametrize("args, fragment", BAD)
def test_bad_options_in_process(args, fragment, capsys):
    try:
        code = main(["toy", *args])
    except SystemExit as exc:  # argparse usage errors
        code = exc.code
    captured = capsys.readouterr()
    assert code == 2 and captured.out == ""
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and fragment in lines[0], captured.err


def test_table_output_names_units(capsys):
    assert main(["toy", "--target-ess", "300", "--seed", "1"]) == 0
    out = capsys.readouterr().out
    for label in ("amplitude [du]", "frequency_Hz [Hz]", "phase_rad [rad]", "noise_sd [du]", "RMSE", "coverage", "R-hat"):
        assert label in out
