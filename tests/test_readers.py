"""Readers of the files labs and phones write (:mod:`beam.io.readers`).

Every file is written to its format's published layout (:mod:`tests.record_files`) from known
arrays; what is read back is compared with those arrays to the precision the format prints,
after the unit conversion (exact factors: g_n = 9.80665 m/s², SI prefixes).
"""

from __future__ import annotations

import zipfile

import numpy as np
import pytest
import scipy.io

from beam.errors import BeamInputError
from beam.io.readers import detect_format, read_record
from beam.io.readers.signal import clean_stamps, find_segments
from beam.io.readers.units import STANDARD_GRAVITY, column_meaning
from tests.record_files import (
    PHYPHOX_VARIANTS,
    phyphox_number,
    write_headerless_lvm,
    write_lvm,
    write_mat73,
    write_phyphox_csv,
    write_phyphox_zip,
    write_physics_toolbox,
    write_tdms,
)

RATE = 500.0


def _record(seconds: float = 4.0, rate: float = RATE, seed: int = 0):
    """Time, and three axes: x noise, y gravity with a slow tilt, z a decaying two-mode pluck (m/s²)."""
    rng = np.random.default_rng(seed)
    t = np.arange(0, seconds, 1 / rate)
    z = 3.0 * np.exp(-0.6 * t) * np.sin(2 * np.pi * 7.0 * t) + 0.8 * np.exp(-3 * t) * np.sin(2 * np.pi * 44.0 * t)
    z += 0.02 * rng.normal(size=t.size)
    axes = {"x": 0.05 * rng.normal(size=t.size), "y": 9.81 + 0.01 * np.sin(0.5 * t), "z": z}
    return t, axes


# ---------------------------------------------------------------------------------------------
# units in names
# ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("name, quantity, factor, axis", [
    ("Time (s)", "time", 1.0, None),
    ("Linear Acceleration x (m/s^2)", "acceleration", 1.0, "x"),
    ("Absolute acceleration (m/s^2)", "acceleration", 1.0, "total"),
    ("gFz", "acceleration", STANDARD_GRAVITY, "z"),
    ("TgF", "acceleration", STANDARD_GRAVITY, "total"),
    ("az", "acceleration", 1.0, "z"),
    ("accel_z_g", "acceleration", STANDARD_GRAVITY, "z"),
    ("acc_y [mg]", "acceleration", STANDARD_GRAVITY * 1e-3, "y"),
    ("velocity (mm/s)", "velocity", 1e-3, None),
    ("disp (µm)", "displacement", 1e-6, None),
    ("tip [mm]", "displacement", 1e-3, None),
    ("strain (microstrain)", "strain", 1e-6, None),
    ("ch0 (V)", "voltage", 1.0, None),
    ("Force (N)", "force", 1.0, None),
    ("micros", "time", 1e-6, None),
    ("time_ms", "time", 1e-3, None),
    ("acceleration_m_s2", "acceleration", 1.0, None),
])
def test_a_column_name_says_its_quantity_unit_and_axis(name, quantity, factor, axis):
    meaning = column_meaning(name)
    assert (meaning.quantity, meaning.axis) == (quantity, axis)
    assert meaning.factor == pytest.approx(factor, rel=1e-15)


# ---------------------------------------------------------------------------------------------
# phyphox
# ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("separator, decimal", PHYPHOX_VARIANTS)
def test_all_five_phyphox_variants_read_the_same_numbers(tmp_path, separator, decimal):
    t, axes = _record()
    path = write_phyphox_csv(tmp_path / "Raw Data.csv", t, axes, separator, decimal)
    assert '"Time (s)"' in path.read_text().splitlines()[0]
    record = read_record(path)
    assert record.format.startswith("phyphox CSV")
    assert record.output_column == "acceleration_m_s2"
    assert record.signal.startswith("Linear Acceleration z (m/s^2): the most vibration power")
    # ten significant digits are printed: the values agree to that precision
    np.testing.assert_allclose(record.output, axes["z"], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(record.time_s, t, rtol=0, atol=1e-12)
    assert record.rate_Hz == pytest.approx(RATE, rel=1e-9)


def test_phyphox_number_format_is_its_scientific_ten_digits():
    assert phyphox_number(0.001234567891, ",") == "1,234567891E-3"
    assert phyphox_number(-9.81, ".") == "-9.810000000E0"


def test_phyphox_with_g_axes_and_the_magnitude_only_on_request(tmp_path):
    t, axes = _record()
    path = write_phyphox_csv(tmp_path / "Raw Data.csv", t, axes, ",", ".", with_g=True)
    record = read_record(path)
    assert record.signal.startswith("Acceleration z (m/s^2)")  # never the magnitude by default
    by_axis = read_record(path, axis="y")
    np.testing.assert_allclose(by_axis.output, axes["y"], rtol=1e-9)
    magnitude = read_record(path, column="Absolute acceleration")
    expected = np.sqrt(axes["x"] ** 2 + axes["y"] ** 2 + axes["z"] ** 2)
    np.testing.assert_allclose(magnitude.output, expected, rtol=1e-9)
    by_index = read_record(path, column="2")
    np.testing.assert_allclose(by_index.output, axes["x"], rtol=1e-9, atol=1e-12)


def test_phyphox_missing_values_of_a_shorter_buffer_are_dropped_and_reported(tmp_path):
    t, axes = _record()
    from tests.record_files import phyphox_csv_text

    text = phyphox_csv_text(["Time (s)", "Acceleration z (m/s^2)"], [t, axes["z"][:-5]], ";", ",")
    assert text.rstrip().endswith('""')
    path = tmp_path / "short.csv"
    path.write_text(text)
    record = read_record(path)
    assert record.time_s.size == t.size - 5
    assert any("5 row(s) with a missing value" in note for note in record.notes)


@pytest.mark.parametrize("separator, decimal", [(",", "."), (";", ",")])
def test_phyphox_zip_export_with_meta(tmp_path, separator, decimal):
    t, axes = _record()
    path = write_phyphox_zip(tmp_path / "export.zip", t, axes, separator, decimal)
    with zipfile.ZipFile(path) as archive:
        assert {"Raw Data.csv", "meta/device.csv", "meta/time.csv"} <= set(archive.namelist())
    record = read_record(path)
    assert record.format.startswith("phyphox zip export")
    assert "Raw Data.csv" in record.notes[1] and "meta/device.csv" in record.notes[1]
    np.testing.assert_allclose(record.output, axes["z"], rtol=1e-9, atol=1e-12)


# ---------------------------------------------------------------------------------------------
# Physics Toolbox Sensor Suite
# ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("unit", ["g", "m/s^2"])
@pytest.mark.parametrize("separator", [",", ";"])
def test_physics_toolbox_g_force_and_linear_acceleration(tmp_path, unit, separator):
    t, axes = _record()
    scale = STANDARD_GRAVITY if unit == "g" else 1.0
    written = {k: v / scale for k, v in axes.items()}
    path = write_physics_toolbox(tmp_path / "sensor.csv", t, written, unit="g" if unit == "g" else "m", separator=separator)
    record = read_record(path)
    assert record.format.startswith("Physics Toolbox Sensor Suite CSV")
    assert record.signal.startswith("gFz" if unit == "g" else "az")
    # six decimals printed, in the file's unit
    np.testing.assert_allclose(record.output, axes["z"], rtol=0, atol=0.5e-6 * scale * 1.0001)


def test_physics_toolbox_clock_time_is_read_as_seconds(tmp_path):
    t = np.arange(0, 3, 0.004)  # 250 Hz: whole milliseconds
    _, axes = _record(3.0, 250.0)
    path = write_physics_toolbox(tmp_path / "sensor.csv", t, {k: v / STANDARD_GRAVITY for k, v in axes.items()}, clock=True)
    assert path.read_text().splitlines()[1].startswith("17:23:00:000")
    record = read_record(path)
    np.testing.assert_allclose(record.time_s, t, atol=1e-9)
    assert record.rate_Hz == pytest.approx(250.0, rel=1e-9)


# ---------------------------------------------------------------------------------------------
# LabVIEW
# ---------------------------------------------------------------------------------------------

def test_lvm_with_header_and_two_segments_uses_the_stronger(tmp_path):
    t, axes = _record()
    z_g = axes["z"] / STANDARD_GRAVITY
    path = write_lvm(tmp_path / "run.lvm", [(1 / RATE, ["accel"], ["g"], np.c_[0.3 * z_g]),
                                            (1 / RATE, ["accel"], ["g"], np.c_[z_g])])
    assert detect_format(path) == "lvm"
    record = read_record(path)
    assert record.format.startswith("LabVIEW LVM (2 segment(s)")
    assert record.segment_index == 1 and len(record.segments) == 2
    np.testing.assert_allclose(record.output, axes["z"], atol=0.5e-6 * STANDARD_GRAVITY * 1.0001)
    np.testing.assert_allclose(record.time_s, t, atol=1e-9)
    first = read_record(path, segment=1)
    np.testing.assert_allclose(first.output, 0.3 * axes["z"], atol=0.5e-6 * STANDARD_GRAVITY * 1.0001)


def test_lvm_without_x_column_decimal_comma_and_an_input(tmp_path):
    t, axes = _record()
    voltage = np.sin(2 * np.pi * 3 * t)
    path = write_lvm(tmp_path / "drive.lvm", [(1 / RATE, ["Dev1/ai0", "Dev1/ai1"], ["Volts", "g"],
                                               np.c_[voltage, axes["z"] / STANDARD_GRAVITY])], x_columns="No", decimal=",")
    record = read_record(path)
    assert record.input_column == "voltage_V" and record.output_column == "acceleration_m_s2"
    assert "sampling rate 500 Hz" in record.notes[0]
    np.testing.assert_allclose(record.input, voltage, atol=0.5e-6)
    np.testing.assert_allclose(record.time_s, t, atol=1e-9)


def test_headerless_two_column_lvm_text(tmp_path):
    t, axes = _record()
    path = write_headerless_lvm(tmp_path / "run.lvm", t, axes["z"])
    with pytest.raises(BeamInputError, match=r"run.lvm: column 'column 2' has no unit .* --unit"):
        read_record(path)
    record = read_record(path, unit="m/s^2")
    assert record.format.startswith("headerless LabVIEW text (tab separator")
    np.testing.assert_allclose(record.output, axes["z"], atol=0.5e-6 * 1.0001)
    assert record.rate_Hz == pytest.approx(RATE, rel=1e-6)


# ---------------------------------------------------------------------------------------------
# binary formats
# ---------------------------------------------------------------------------------------------

def test_tdms_group_with_units_and_waveform_timing(tmp_path):
    t, axes = _record()
    path = write_tdms(tmp_path / "run.tdms", "Accelerometer", {
        "Accel X": (axes["x"] / STANDARD_GRAVITY, "g"), "Accel Z": (axes["z"] / STANDARD_GRAVITY, "g")}, 1 / RATE)
    record = read_record(path)
    assert record.format.startswith("NI TDMS") and record.signal.startswith("Accel Z")
    np.testing.assert_allclose(record.output, axes["z"], rtol=1e-12)
    np.testing.assert_allclose(record.time_s, t, atol=1e-9)


def test_mat_v5_struct_and_matrix_and_v73(tmp_path):
    t, axes = _record()
    scipy.io.savemat(tmp_path / "struct.mat", {"rec": {"t": t, "acc_z_g": axes["z"] / STANDARD_GRAVITY}})
    record = read_record(tmp_path / "struct.mat")
    assert record.format == "MATLAB .mat (v5)" and record.signal.startswith("acc_z_g")
    np.testing.assert_allclose(record.output, axes["z"], rtol=1e-12)
    scipy.io.savemat(tmp_path / "matrix.mat", {"data": np.c_[t, axes["z"]]})
    matrix = read_record(tmp_path / "matrix.mat", unit="m/s^2")
    assert "time from column 'data[1]'" in matrix.notes[0]
    np.testing.assert_allclose(matrix.output, axes["z"], rtol=1e-12)
    write_mat73(tmp_path / "v73.mat", {"fs": np.array([RATE]), "accel_mm_s2": axes["z"] * 1e3})
    v73 = read_record(tmp_path / "v73.mat")
    assert v73.format.startswith("MATLAB .mat (v7.3")
    np.testing.assert_allclose(v73.output, axes["z"], rtol=1e-12)
    np.testing.assert_allclose(v73.time_s, t, atol=1e-9)


def test_npy_and_npz(tmp_path):
    t, axes = _record()
    np.save(tmp_path / "x.npy", np.c_[t, axes["z"]])
    record = read_record(tmp_path / "x.npy", unit="g")
    np.testing.assert_allclose(record.output, axes["z"] * STANDARD_GRAVITY, rtol=1e-15)
    np.save(tmp_path / "signal.npy", axes["z"])
    with pytest.raises(BeamInputError, match="no time column and no sampling rate .* --rate HZ"):
        read_record(tmp_path / "signal.npy", unit="m/s^2")
    by_rate = read_record(tmp_path / "signal.npy", unit="m/s^2", rate=RATE)
    np.testing.assert_allclose(by_rate.time_s, t, atol=1e-12)
    np.savez(tmp_path / "x.npz", rate=RATE, accel_x_g=axes["x"] / STANDARD_GRAVITY, accel_z_g=axes["z"] / STANDARD_GRAVITY)
    archive = read_record(tmp_path / "x.npz")
    assert archive.signal.startswith("accel_z_g: the most vibration power")
    np.testing.assert_allclose(archive.output, axes["z"], rtol=1e-12)


# ---------------------------------------------------------------------------------------------
# generic text, the signal, time
# ---------------------------------------------------------------------------------------------

def test_whitespace_table_with_units_in_the_header(tmp_path):
    t, axes = _record()
    path = tmp_path / "laser.txt"
    rows = "\n".join(f"{a:.6f}  {b * 1e6:.3f}" for a, b in zip(t, axes["z"] * 1e-3))
    path.write_text("# laser vibrometer\ntime_s  tip_um\n" + rows + "\n")
    record = read_record(path)
    assert record.output_column == "displacement_m" and "laser vibrometer" in record.notes
    np.testing.assert_allclose(record.output, axes["z"] * 1e-3, atol=0.5e-9 * 1.0001)


def _table(path, header: str, *columns):
    """A comma-separated table: the header line, then the columns row by row."""
    path.write_text(header + "\n" + "\n".join(",".join(str(v) for v in row) for row in zip(*columns)) + "\n")
    return path


def test_microstrain_is_read_as_strain_and_an_unknown_unit_is_refused_with_the_way_out(tmp_path):
    t, axes = _record()
    path = _table(tmp_path / "gauge.csv", "time,strain (microstrain)", t, axes["z"])
    record = read_record(path)  # a strain gauge's record (issue 30.3): SI strain, 1e-6 per microstrain
    assert record.output_column == "strain"
    np.testing.assert_allclose(record.output, axes["z"] * 1e-6, rtol=1e-12)
    _table(path, "time,signal", t, axes["z"])
    with pytest.raises(BeamInputError, match="column 'signal' has no unit the reader knows; give it with --unit"):
        read_record(path)
    assert read_record(path, unit="mm/s").output_column == "velocity_m_s"


def test_columns_of_different_quantities_need_a_choice(tmp_path):
    t, axes = _record()
    path = _table(tmp_path / "both.csv", "t (s),acc (g),disp (mm)", t, axes["z"], axes["z"])
    with pytest.raises(BeamInputError, match="different quantities .* --column"):
        read_record(path)
    assert read_record(path, column="disp").output_column == "displacement_m"


def test_arduino_micros_need_a_time_unit(tmp_path):
    t, axes = _record()
    micros = np.round(t * 1e6).astype(np.int64) + 1_234_567
    path = tmp_path / "arduino.csv"
    path.write_text("stamp,accel_z_g\n" + "\n".join(f"{m},{z:.6f}" for m, z in zip(micros, axes["z"])) + "\n")
    with pytest.raises(BeamInputError, match="not a|time|--rate"):
        read_record(path)  # 'stamp' names no time: the reader asks for a rate
    path.write_text("t,accel_z_g\n" + "\n".join(f"{m},{z:.6f}" for m, z in zip(micros, axes["z"])) + "\n")
    with pytest.raises(BeamInputError, match="whole numbers .* --time-unit ms\\|us"):
        read_record(path)
    record = read_record(path, time_unit="us")
    assert record.rate_Hz == pytest.approx(RATE, rel=1e-9) and record.time_s[0] == 0.0
    assert any("time shifted by -1.234567 s" in note for note in record.notes)


def test_repeated_and_backward_stamps_are_dropped_and_counted():
    t = np.array([0.0, 0.1, 0.2, 0.2, 0.3, 0.25, 0.4, 0.5, np.nan, 0.6])
    y = np.arange(t.size, dtype=float)
    keep, report = clean_stamps(t, y)
    np.testing.assert_array_equal(t[keep], [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    assert report == ("dropped 1 row(s) with a missing value, 1 repeated stamp(s), "
                      "1 stamp(s) going back in time (first at sample 5)")
    keep, report = clean_stamps(np.arange(5.0), np.zeros(5))
    assert keep.all() and report is None


def test_three_taps_are_split_and_the_strongest_is_used(tmp_path):
    rate = 1000.0
    rng = np.random.default_rng(2)
    t = np.arange(0, 12, 1 / rate)
    y = 0.01 * rng.normal(size=t.size)
    onsets = ((1.0, 1.0), (4.5, 3.0), (8.0, 2.0))
    for start, amplitude in onsets:
        after = t >= start
        y[after] += amplitude * np.exp(-1.0 * (t[after] - start)) * np.sin(2 * np.pi * 8 * (t[after] - start))
    segments = find_segments(t, y)
    assert len(segments) == 3
    for segment, (start, _) in zip(segments, onsets):
        # each segment starts within one envelope block (0.25 s: two periods) before its onset
        assert start - 0.5 <= segment.start_s <= start
    np.save(tmp_path / "taps.npy", np.c_[t, y])
    record = read_record(tmp_path / "taps.npy", unit="m/s^2")
    assert record.segment_index == 1 and len(record.segments) == 3
    assert record.duration_s == pytest.approx(segments[1].end_s - segments[1].start_s, abs=2e-3)
    assert np.max(np.abs(record.output)) == pytest.approx(np.max(np.abs(y[(t >= 4.5) & (t < 8.0)])), rel=1e-12)
    third = read_record(tmp_path / "taps.npy", unit="m/s^2", segment=3)
    assert third.segment_index == 2


def test_a_single_decaying_pluck_is_not_split():
    t, axes = _record(10.0)
    assert find_segments(t, axes["z"]) == []


@pytest.mark.parametrize("content, fragments", [
    (b"", ["no data rows"]),
    (b"time,acc (g)\n", ["header only"]),
    (b"\x93NUMPYgarbage", ["not a readable NumPy"]),
    (b"MATLAB 5.0 MAT-file garbage", ["not a readable MATLAB"]),
    (b"TDSmgarbage", ["NI TDMS"]),
    (b"PK\x03\x04garbage", ["not a readable zip"]),
    (b"LabVIEW Measurement\t\nWriter_Version\t2\n***End_of_Header***\n", ["LabVIEW"]),
])
def test_bad_files_name_the_file_and_what_was_expected(tmp_path, content, fragments):
    path = tmp_path / "bad.dat"
    path.write_bytes(content)
    with pytest.raises(BeamInputError) as info:
        read_record(path)
    message = str(info.value)
    assert message.startswith(str(path)) and "\n" not in message
    for fragment in fragments:
        assert fragment in message


def test_a_missing_file_and_an_unknown_format(tmp_path):
    with pytest.raises(BeamInputError, match="nothing.npy: not found"):
        read_record(tmp_path / "nothing.npy")
    (tmp_path / "x.csv").write_text("t,a (g)\n0,1\n0.1,2\n")
    with pytest.raises(BeamInputError, match="--format 'xls': unknown"):
        read_record(tmp_path / "x.csv", format="xls")
