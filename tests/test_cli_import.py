"""``beam import`` and the record/beam flags of ``beam calibrate`` and ``beam diagnose``."""

from __future__ import annotations

import contextlib
import io
import re

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


def _arduino_counts(tmp_path):
    """An Arduino's analogRead of an accelerometer on a plucked strip: ADC counts, no unit, a
    'Quantisation level' column before the time (an oscilloscope app's layout)."""
    t = np.arange(0, 5, 1 / 500)
    counts = np.round(512 + 200 * np.exp(-0.3 * t) * np.sin(2 * np.pi * 7 * t))
    path = tmp_path / "arduino.csv"
    path.write_text("Quantisation level,Time\n" + "".join(f"{int(c)},{x:.4f}\n" for c, x in zip(counts, t)))
    return path, counts


def test_a_file_in_another_layout_gets_the_readers_finding_and_hint_first(tmp_path):
    path, _ = _arduino_counts(tmp_path)
    status, _, err = _run(["import", str(path), *GEOMETRY_FLAGS])
    assert status == 2 and err.count("\n") == 1
    first = err.removeprefix(f"error: {path}: ")
    assert first.startswith("read as another format: column 'Quantisation level' has no unit the reader knows; "
                            "give it with --unit"), err
    assert "arbitrary-acceleration" in first and "ADC counts" in first
    assert first.index("give it with --unit") < first.index("header must be exactly")  # the project's rule comes last


def test_counts_are_read_as_arbitrary_units_and_the_amplitude_effects_refuse_them(tmp_path):
    path, counts = _arduino_counts(tmp_path)
    status, out, err = _run(["import", str(path), *GEOMETRY_FLAGS, "--unit", "arbitrary-acceleration",
                             "--out", str(tmp_path / "counts")])
    assert status == 0, err
    assert "arbitrary units: the values as the file holds them, their scale unknown" in out and " a.u., " in out
    imported = read_measurement(tmp_path / "counts.csv")  # the sidecar keeps [sensor] unit = "arbitrary"
    assert imported.arbitrary_units and imported.output_unit == "a.u."
    np.testing.assert_array_equal(imported.output, counts)
    for effect in ("quadratic_drag", "clamp_friction", "tip_cubic_spring"):
        status, _, err = _run(["calibrate", str(tmp_path / "counts.csv"), "--effects", f"air_damping,{effect}"])
        assert status == 2 and err.count("\n") == 1
        assert f"error: {effect} needs the signal in its true unit: its force depends on the amplitude" in err
    status, _, err = _run(["diagnose", str(tmp_path / "counts.csv"), "--base", "quadratic_drag"])
    assert status == 2 and "needs the signal in its true unit" in err


def test_a_file_of_two_records_names_the_one_used_and_reaches_the_other(tmp_path):
    import scipy.io

    t_steel, t_alu = np.arange(0, 3, 1e-3), np.arange(0, 4, 1e-3)
    steel = 5.0 * np.exp(-0.5 * t_steel) * np.sin(2 * np.pi * 11 * t_steel)
    alu = 8.0 * np.exp(-0.3 * t_alu) * np.sin(2 * np.pi * 6 * t_alu)
    scipy.io.savemat(tmp_path / "strips.mat", {"steel": {"t": t_steel, "acc_g": steel / 9.80665},
                                               "aluminium": {"t": t_alu, "acc_g": alu / 9.80665}})
    status, out, err = _run(["import", str(tmp_path / "strips.mat"), *GEOMETRY_FLAGS, "--out", str(tmp_path / "a")])
    assert status == 0, err
    assert "record: aluminium: the longest (2 records in the file: 1: steel" in out and "another with --record" in out
    status, out, err = _run(["import", str(tmp_path / "strips.mat"), *GEOMETRY_FLAGS, "--record", "steel",
                             "--out", str(tmp_path / "s")])
    assert status == 0, err
    assert "record: steel: chosen with --record" in out
    np.testing.assert_allclose(read_measurement(tmp_path / "s.csv").output, steel, rtol=1e-12)


def test_a_strain_gauge_record_is_summarised_in_microstrain(tmp_path):
    from tests.record_files import write_lvm

    t = np.arange(0, 4, 1 / 2000)
    eps = 150.0 * np.exp(-0.4 * t) * np.sin(2 * np.pi * 20 * t)
    path = write_lvm(tmp_path / "gauge.lvm", [(1 / 2000, ["Strain gauge 1"], ["µε"], np.c_[eps])])
    status, out, err = _run(["import", str(path), "--length", "0.419", "--width", "0.025", "--thickness", "0.0048",
                             "--material", "steel", "--sensor-at", "0.03", "--out", str(tmp_path / "g")])
    assert status == 0, err
    assert "unit: µε: from the file's unit field" in out
    line = next(row for row in out.splitlines() if row.startswith("output strain:"))
    low, high = (float(v) for v in re.findall(r"(-?[\d.]+) to (-?[\d.]+) µε", line)[0])
    assert low == pytest.approx(eps.min(), rel=5e-4) and high == pytest.approx(eps.max(), rel=5e-4)  # 4 digits printed
    np.testing.assert_allclose(read_measurement(tmp_path / "g.csv").output, eps * 1e-6, rtol=0, atol=1e-12)
