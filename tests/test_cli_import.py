"""``beam import`` and the record/beam flags of ``beam calibrate`` and ``beam diagnose``."""

from __future__ import annotations

import contextlib
import io

import numpy as np
import pytest

from beam.cli.main import main
from beam.io.anchor import mode1_frequency
from beam.io.measurement import read_measurement
from beam.physics.geometry import BeamGeometry
from tests.record_files import write_phyphox_csv

GEOMETRY_FLAGS = ["--length", "0.5", "--width", "0.05", "--thickness", "0.002", "--material", "aluminium"]


def _run(argv):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main(argv)
    return status, out.getvalue(), err.getvalue()


def _phone_record(tmp_path, f1: float = 6.0):
    t = np.arange(0, 6, 1 / 400)
    rng = np.random.default_rng(1)
    z = 2.0 * np.exp(-0.3 * t) * np.sin(2 * np.pi * f1 * t) + 0.01 * rng.normal(size=t.size)
    return write_phyphox_csv(tmp_path / "Raw Data.csv", t, {"x": 0.02 * rng.normal(size=t.size),
                                                           "y": 9.81 + 0 * t, "z": z}, ";", ","), z


def test_import_writes_the_projects_files_and_prints_what_it_read(tmp_path):
    path, z = _phone_record(tmp_path)
    status, out, err = _run(["import", str(path), *GEOMETRY_FLAGS, "--sensor-mass", "~0.18", "--out",
                             str(tmp_path / "strip")])
    assert status == 0, err
    read = read_measurement(tmp_path / "strip.csv")
    np.testing.assert_allclose(read.output, z, rtol=1e-9, atol=1e-12)
    assert read.geometry.sensor_position_m == 0.5  # the tip by default
    assert read.nominal["sensor_mass_kg"] == 0.18 and read.nominal_spread["sensor_mass_kg"] == 0.35
    for fragment in ("read as phyphox CSV (';' separator, ',' decimal)", "Linear Acceleration z (m/s^2): the most "
                     "vibration power", "record peak (Hz)", "ideal beam mode", "mode 1:", "clipped samples: 0",
                     f"written: {tmp_path / 'strip.csv'}"):
        assert fragment in out, out
    # the ideal beam's mode 1 printed is the bare aluminium strip's with the phone on its tip
    geometry = BeamGeometry(0.5, 2700 * 0.05 * 0.002, None, None, 0.5)
    expected = mode1_frequency(geometry, 69e9 * 0.05 * 0.002**3 / 12, 0.18)
    assert f"mode 1: {expected:8.4g} Hz" in out
    peak_line = next(line for line in out.splitlines() if "mode 1:" in line)
    assert float(peak_line.split()[0]) == pytest.approx(6.0, rel=5e-3)


def test_import_without_a_beam_and_a_wrong_unit_are_one_error_line(tmp_path):
    path, _ = _phone_record(tmp_path)
    status, out, err = _run(["import", str(path)])
    assert status == 2 and err.startswith("error: beam import: describe the beam") and err.count("\n") == 1
    np.save(tmp_path / "x.npy", np.c_[np.arange(100) / 100, np.zeros(100)])
    status, _, err = _run(["import", str(tmp_path / "x.npy"), *GEOMETRY_FLAGS])
    assert status == 2 and "has no unit the reader knows; give it with --unit" in err and err.count("\n") == 1
    table = tmp_path / "rec.csv"
    table.write_text("t,acc (g)\n" + "".join(f"{k / 100},{np.sin(k / 3)}\n" for k in range(300)))
    status, _, err = _run(["import", str(table), *GEOMETRY_FLAGS, "--out", str(tmp_path / "rec")])
    assert status == 2 and "would overwrite the record" in err and err.count("\n") == 1
    assert table.read_text().startswith("t,acc (g)")


def test_calibrate_and_diagnose_take_the_same_flags(tmp_path):
    from beam.cli.main import build_parser

    for command in ("calibrate", "diagnose"):
        args = build_parser().parse_args([command, "x.npy", *GEOMETRY_FLAGS, "--unit", "g", "--rate", "100",
                                          "--sensor-at", "0.44", "--axis", "z"])
        assert (args.beam_length, args.material, args.unit, args.rate, args.sensor_at, args.axis) == (
            0.5, "aluminium", "g", 100.0, 0.44, "z")


def test_calibrate_reads_a_phone_record_described_by_flags(tmp_path):
    path, _ = _phone_record(tmp_path)
    status, out, err = _run(["calibrate", str(path), *GEOMETRY_FLAGS, "--sensor-at", "0.45", "--steps", "30",
                             "--walkers", "16", "--json"])
    assert status == 0, err
    assert '"measurement": "Raw Data"' in out
