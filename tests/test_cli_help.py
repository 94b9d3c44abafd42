"""``beam --help`` texts and human output: effect titles, bundled names, µm and %, no raw markup."""

from __future__ import annotations

import argparse
import contextlib
import io

import pytest

from beam.cli.arguments import BUNDLED_MEASUREMENTS, measurement_path
from beam.cli.calibrate_command import format_summary, format_window
from beam.cli.main import build_parser
from beam.physics.effects import EFFECTS


def _help(*command: str) -> str:
    out = io.StringIO()
    with contextlib.redirect_stdout(out), pytest.raises(SystemExit):
        build_parser().parse_args([*command, "--help"])
    return out.getvalue()


def _commands() -> list[str]:
    subparsers = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return list(subparsers.choices)


@pytest.mark.parametrize("command", ["calibrate", "diagnose"])
def test_help_lists_every_effect_id_with_its_title(command):
    text = _help(command)
    for name, effect in EFFECTS.items():
        assert any(line.split() [:1] == [name] and effect.title in line for line in text.splitlines()), name


def test_no_help_text_shows_doubled_percent_signs_or_markup():
    for command in [*_commands(), None]:
        text = _help(command) if command else _help()
        assert "%%" not in text and "``" not in text and "**" not in text, command


def test_bundled_measurement_names_resolve_from_any_directory(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert measurement_path("lab_run_1") == str(BUNDLED_MEASUREMENTS / "lab_run_1.csv")
    assert measurement_path("lab_run_1.csv") == str(BUNDLED_MEASUREMENTS / "lab_run_1.csv")
    assert measurement_path("no_such_run") == "no_such_run"  # the reader reports it
    assert measurement_path("sub/lab_run_1") == "sub/lab_run_1"  # a path is taken as given
    (tmp_path / "lab_run_1.csv").write_text("")  # a local file of that name wins
    assert measurement_path("lab_run_1") == "lab_run_1"


def test_human_summary_in_micrometres_and_percent():
    stats = {"mean": 0.2931, "sd": 3e-4, "q025": 0.2925, "q975": 0.2937}
    summary = {"measurement": "lab_run_1", "window_s": [0.0, 1.0497], "modes": 4, "effects": ["air_damping"],
               "likelihood": "iid", "parameters": {"bending_stiffness_Nm2": stats},
               "noise_sd": {"mean": 1.3784e-3, "sd": 3.01e-5, "q025": 1.3277e-3, "q975": 1.4416e-3},
               "rmse_calibration": 1.379e-3, "rmse_prediction": 1.2714e-3, "coverage95_prediction": 0.9931,
               "ess_min": 1200.0, "rhat_max": 1.004, "converged": True, "seconds": 3.0, "warnings": []}
    text = format_summary(summary)
    assert "calibration window 0–1.05 s" in text
    assert "noise_sd_um" in text and "1378.4" in text  # 1.3784 mm in µm
    assert "RMSE, held-out part        1271 µm" in text and "RMSE, calibration window   1379 µm" in text
    assert "inside the 95 % prediction band: 99.3 %" in text
    assert format_window([1.5, 12.25]) == "1.5–12.2 s"
