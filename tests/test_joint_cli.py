"""``beam calibrate A B ...`` and ``beam diagnose A B ...``: several records of one beam jointly;
one record keeps the single command's output."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from beam.io.measurement import write_measurement
from tests.test_joint_calibration import TWO_MODES, free_strip

ROOT = Path(__file__).resolve().parent.parent


def beam(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "beam", *args], capture_output=True, text=True, cwd=ROOT,
                          env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"}, timeout=900)


@pytest.fixture(scope="module")
def strips(tmp_path_factory) -> list[str]:
    """Two records of one strip (sensor mass, two modes) at 40 and 50 cm, each with its sidecar."""
    folder = tmp_path_factory.mktemp("strips")
    paths = []
    for k, length in enumerate((0.4, 0.5)):
        record = free_strip(length, TWO_MODES, ("sensor_mass", "modal_damping"), seed=30 + k, second=0.3,
                            rate_Hz=300.0, duration_s=2.5)
        write_measurement(folder / record.name, record)
        paths.append(str(folder / f"{record.name}.csv"))
    return paths


def test_calibrate_several_records_json(strips):
    done = beam("calibrate", *strips, "--window", "0:1.5", "--effects", "sensor_mass,modal_damping", "--modes", "2",
                "--steps", "20", "--per-record", "damping_ratio_mode_2", "--json")
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout)
    assert set(out["parameters"]) == {"bending_stiffness_Nm2", "sensor_mass_kg", "damping_ratio_mode_1"}
    assert [r["record"] for r in out["records"]] == ["strip_40cm", "strip_50cm"]
    for record in out["records"]:
        assert set(record) >= {"record", "parameters", "rmse_calibration", "rmse_prediction", "coverage95_prediction",
                               "frequencies_Hz"}
        assert set(record["parameters"]) == {"damping_ratio_mode_2"}
        assert record["rmse_calibration"] == pytest.approx(0.05, rel=0.2)  # the simulated noise
    # the sensor mass is the truth's within the joint 95 % interval
    mass = out["parameters"]["sensor_mass_kg"]
    assert mass["q025"] < TWO_MODES["sensor_mass_kg"] < mass["q975"]


def test_one_record_keeps_the_single_output(strips):
    done = beam("calibrate", strips[0], "--window", "0:1.5", "--effects", "sensor_mass,modal_damping", "--modes", "2",
                "--steps", "20", "--json")
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout)
    assert "records" not in out and out["measurement"] == "strip_40cm" and "noise_sd" in out


@pytest.mark.parametrize("args", [("--per-record", "clamp_stiffness"), ("--shared", "bending_stiffness")])
def test_joint_flags_need_several_records(strips, args):
    done = beam("calibrate", strips[0], *args)
    assert done.returncode == 2 and done.stderr.startswith("error:") and "several records" in done.stderr


def test_unknown_per_record_name_is_an_input_error(strips):
    done = beam("calibrate", *strips, "--window", "0:1.5", "--effects", "sensor_mass,modal_damping", "--modes", "2",
                "--per-record", "tip_mass", "--steps", "20")
    assert done.returncode == 2 and done.stderr.startswith("error:") and "not a parameter" in done.stderr


def test_diagnose_several_records_json(strips):
    done = beam("diagnose", *strips, "--window", "0:1.5", "--modes", "2", "--base", "modal_damping", "--json")
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout)
    assert out["missing"] == "sensor_mass"
    assert [r["record"] for r in out["records"]] == ["strip_40cm", "strip_50cm"]
    effects = [c["effect"] for c in out["candidates"]]
    for record in out["records"]:
        assert set(record["delta_log_evidence"]) == set(effects)
        assert [row["mode"] for row in record["modes_table"]][:2] == [1, 2]
    assert out["ladder"][-1]["added"] == "sensor_mass"
