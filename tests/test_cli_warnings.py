"""No Python warning reaches a user's console (#38 item 9): the command line on real records with
every warning an error (``python -W error``, inherited by any subprocess through
``PYTHONWARNINGS``), as a user runs it.

The records: the shared aluminium strip's real run in every format the readers take
(``assets/real/formats``, MIT-licensed, ``assets/real/README.md``), the run itself calibrated
with the quadratic drag (whose averaged start printed ``RuntimeWarning: overflow encountered in
exp`` from ``beam/inference/priors.py`` on every real record: an unidentified parameter's
interval end of ``exp(z)`` with z beyond the float range), and the run's first 6 s diagnosed
with the strip's width given (every candidate, the drag's preview among them).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
REAL = REPO / "assets" / "real"
STRIP = ["--length", "0.5", "--width", "0.05", "--thickness", "0.002", "--material", "aluminium", "--sensor-at", "0.44"]
#: Reading options a format needs (its file does not say the unit).
OPTIONS = {"adxl_50cm_114655.npy": ["--unit", "m/s^2"], "adxl_50cm_114655.headerless.lvm": ["--unit", "m/s^2"]}


def run_strict(*argv: str, timeout: float = 600.0) -> subprocess.CompletedProcess:
    """``beam ARGV`` with every warning an error; the worktree's package first on the path."""
    env = dict(os.environ, PYTHONWARNINGS="error", PYTHONPATH=str(REPO))
    return subprocess.run([sys.executable, "-W", "error", "-m", "beam", *argv], cwd=REPO, env=env,
                          capture_output=True, text=True, timeout=timeout)


@pytest.mark.parametrize("name", sorted(p.name for p in (REAL / "formats").iterdir()))
def test_importing_the_real_run_in_every_format_warns_nothing(tmp_path, name):
    done = run_strict("import", str(REAL / "formats" / name), *STRIP, *OPTIONS.get(name, []),
                      "--out", str(tmp_path / "run"))
    assert done.returncode == 0 and done.stderr == "", done.stderr
    assert "record peak (Hz)" in done.stdout


@pytest.mark.slow
def test_calibrating_the_real_run_with_the_drag_warns_nothing(tmp_path):
    done = run_strict("calibrate", str(REAL / "adxl_50cm_114655.csv"), "--width", "0.05", "--thickness", "0.002",
                      "--effects", "air_damping,kelvin_voigt,quadratic_drag", "--window", "0:5", "--steps", "20",
                      "--walkers", "16", "--json")
    assert done.returncode == 0 and done.stderr == "", done.stderr
    assert '"quadratic_drag"' in done.stdout


@pytest.mark.slow
def test_diagnosing_a_real_run_warns_nothing(tmp_path):
    lines = (REAL / "adxl_50cm_114759.csv").read_text().splitlines()
    cut = [lines[0]] + [row for row in lines[1:] if float(row.split(",", 1)[0]) < 6.0]
    (tmp_path / "run.csv").write_text("\n".join(cut) + "\n")
    (tmp_path / "run.toml").write_text((REAL / "adxl_50cm_114759.toml").read_text())
    done = run_strict("diagnose", str(tmp_path / "run.csv"), "--width", "0.05", "--thickness", "0.002", "--json")
    assert done.returncode == 0 and done.stderr == "", done.stderr
    assert '"candidates"' in done.stdout
