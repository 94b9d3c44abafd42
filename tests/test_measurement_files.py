"""Measurement files: exact round trips, tolerated formatting, and one clear error per bad file."""

from __future__ import annotations

import os
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import beam.io.text
from beam.errors import BeamInputError
from beam.io.measurement import Measurement, read_measurement, write_measurement
from beam.physics.geometry import BeamGeometry

GEOMETRY = BeamGeometry(0.4573, 0.093, 0.15, 0.25, 0.27438)
HEADER = "time_s,voltage_V,displacement_m"
SIDECAR = """title = "bench test"
[beam]
length_m = 0.4573
linear_density_kg_m = 0.093
[patch]
start_m = 0.15
end_m = 0.25
[sensor]
position_m = 0.27438
"""
ROWS = "0.0,0.0,0.0\n0.001,1.0,1e-6\n0.002,2.0,2e-6\n0.003,3.0,3e-6\n"


def _write_pair(directory: Path, csv_text: str | bytes | None = HEADER + "\n" + ROWS,
                toml_text: str | bytes | None = SIDECAR, name: str = "run") -> Path:
    for suffix, content in ((".csv", csv_text), (".toml", toml_text)):
        if content is None:
            continue
        path = directory / f"{name}{suffix}"
        path.write_bytes(content if isinstance(content, bytes) else content.encode("utf-8"))
    return directory / f"{name}.csv"


# ---------------------------------------------------------------------------------------------
# round trips and what is tolerated
# ---------------------------------------------------------------------------------------------


def test_round_trip_is_bit_exact(tmp_path):
    rng = np.random.default_rng(3)
    n = 500
    time_s = 12.5 + np.arange(n) / 2048.0
    voltage = rng.normal(size=n) * 10 ** rng.uniform(-300, 300, size=n)
    displacement = rng.normal(size=n) * 1e-3
    displacement[:3] = [0.0, -0.0, 5e-324]  # signed zero and a subnormal survive too
    nominal = {"bending_stiffness_Nm2": 0.491, "kelvin_voigt_Nm2s": 0.1 + 0.2}
    written = write_measurement(tmp_path / "out" / "run", (time_s, voltage, displacement), geometry=GEOMETRY,
                                title='Beam "B1" — 1 µm', nominal=nominal)
    assert written.csv_path == tmp_path / "out" / "run.csv" and written.toml_path.exists()
    read = read_measurement(tmp_path / "out" / "run.toml")
    for column, expected in (("time_s", time_s), ("voltage_V", voltage), ("displacement_m", displacement)):
        np.testing.assert_array_equal(getattr(read, column), expected)
        assert getattr(read, column).tobytes() == expected.tobytes(), column
    assert read.title == 'Beam "B1" — 1 µm'
    assert read.geometry == GEOMETRY
    assert read.nominal == nominal
    assert read.name == "run"
    assert read.sample_count == n
    assert read.sample_interval_s == pytest.approx(1 / 2048.0, rel=1e-12)
    assert read.rate_Hz == pytest.approx(2048.0, rel=1e-12)
    assert read.duration_s == pytest.approx(n / 2048.0, rel=1e-12)
    assert read.time_s[0] == 12.5  # time is kept as given, not shifted to 0


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    values=st.lists(st.tuples(st.floats(allow_nan=False, allow_infinity=False),
                              st.floats(allow_nan=False, allow_infinity=False)), min_size=2, max_size=40),
    rate=st.floats(1.0, 1e6),
)
def test_round_trip_of_any_finite_floats(tmp_path, values, rate):
    voltage, displacement = (np.array(column) for column in zip(*values))
    time_s = np.arange(len(values)) / rate
    write_measurement(tmp_path / "h", (time_s, voltage, displacement), geometry=GEOMETRY)
    read = read_measurement(tmp_path / "h.csv")
    assert read.voltage_V.tobytes() == voltage.tobytes()
    assert read.displacement_m.tobytes() == displacement.tobytes()
    assert read.time_s.tobytes() == time_s.tobytes()


def test_round_trip_of_a_measurement_object(tmp_path):
    first = write_measurement(tmp_path / "a", {"time_s": np.arange(4) * 0.5, "voltage_V": np.ones(4),
                                               "displacement_m": np.zeros(4)}, geometry=GEOMETRY)
    second = write_measurement(tmp_path / "b.csv", read_measurement(first.csv_path))
    assert (tmp_path / "b.toml").read_bytes() == (tmp_path / "a.toml").read_bytes()  # title "a" is kept
    assert (tmp_path / "b.csv").read_bytes() == (tmp_path / "a.csv").read_bytes()
    assert (second.name, second.title) == ("b", "a")


def test_tolerated_formatting(tmp_path):
    """BOM, CRLF, spaces around names and numbers, trailing blank lines, 6-decimal time at 2048 Hz."""
    time_s = np.round(np.arange(50) / 2048.0, 6)
    rows = "".join(f" {t:.6f} , {k}.5 ,{-k}e-6 \r\n" for k, t in enumerate(time_s))
    text = "\ufeff time_s , voltage_V,displacement_m \r\n" + rows + "\r\n  \n"
    read = read_measurement(_write_pair(tmp_path, text.encode("utf-8")))
    np.testing.assert_array_equal(read.time_s, time_s)
    np.testing.assert_array_equal(read.voltage_V, np.arange(50) + 0.5)
    np.testing.assert_array_equal(read.displacement_m, [float(f'{-k}e-6') for k in range(50)])
    assert read.rate_Hz == pytest.approx(2048.0, rel=1e-5)


def test_sidecar_without_title_or_nominal_and_integer_values(tmp_path):
    sidecar = "[beam]\nlength_m = 1\nlinear_density_kg_m = 0.1\n[patch]\nstart_m = 0\nend_m = 0.5\n" \
              "[sensor]\nposition_m = 1\n"
    read = read_measurement(_write_pair(tmp_path, toml_text=sidecar, name="plain"))
    assert read.title == "plain" and read.nominal == {}
    assert read.geometry == BeamGeometry(1.0, 0.1, 0.0, 0.5, 1.0)


def test_accepts_the_prefix_without_suffix(tmp_path):
    _write_pair(tmp_path)
    assert read_measurement(tmp_path / "run").sample_count == 4


def test_a_long_record_round_trips_exactly(tmp_path):
    """A long file (200,000 rows) is read back bit for bit (speed is a benchmark's business)."""
    n = 200_000
    time_s = np.arange(n) / 1000.0
    write_measurement(tmp_path / "big", (time_s, np.sin(time_s), np.cos(time_s) * 1e-3), geometry=GEOMETRY)
    read = read_measurement(tmp_path / "big.csv")
    assert read.sample_count == n
    np.testing.assert_array_equal(read.time_s, time_s)
    np.testing.assert_array_equal(read.displacement_m, np.cos(time_s) * 1e-3)


# ---------------------------------------------------------------------------------------------
# atomic writes
# ---------------------------------------------------------------------------------------------


def test_failed_write_leaves_previous_files_and_no_temporaries(tmp_path, monkeypatch):
    original = write_measurement(tmp_path / "run", (np.arange(3) * 0.1, np.ones(3), np.zeros(3)), geometry=GEOMETRY)
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    calls = []

    def failing_fsync(fd):
        calls.append(fd)
        if len(calls) == 2:  # the CSV is written, the sidecar fails
            raise OSError("disk full")

    monkeypatch.setattr(beam.io.text.os, "fsync", failing_fsync)
    with pytest.raises(OSError, match="disk full"):
        write_measurement(tmp_path / "run", (np.arange(5) * 0.1, np.ones(5), np.ones(5)), geometry=GEOMETRY)
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before
    assert read_measurement(original.csv_path).sample_count == 3


def test_invalid_data_writes_nothing(tmp_path):
    with pytest.raises(BeamInputError, match=r"displacement_m\[1\] = nan is not finite"):
        write_measurement(tmp_path / "run", (np.arange(3) * 0.1, np.ones(3), np.array([0, np.nan, 0])),
                          geometry=GEOMETRY)
    with pytest.raises(BeamInputError, match="sample 2: time_s = 0.1 does not increase"):
        write_measurement(tmp_path / "run", (np.array([0, 0.1, 0.1]), np.ones(3), np.ones(3)), geometry=GEOMETRY)
    with pytest.raises(BeamInputError, match="geometry is required"):
        write_measurement(tmp_path / "run", (np.arange(3) * 0.1, np.ones(3), np.ones(3)))
    assert list(tmp_path.iterdir()) == []


def test_written_files_get_ordinary_permissions(tmp_path):
    old_umask = os.umask(0o022)
    try:
        written = write_measurement(tmp_path / "run", (np.arange(3) * 0.1, np.ones(3), np.zeros(3)), geometry=GEOMETRY)
    finally:
        os.umask(old_umask)
    assert written.csv_path.stat().st_mode & 0o777 == 0o644
    assert tomllib.loads(written.toml_path.read_text())["sensor"] == {"position_m": 0.27438}


# ---------------------------------------------------------------------------------------------
# one clear error per malformed file
# ---------------------------------------------------------------------------------------------

BAD_CSV = [
    # (id, CSV content, fragments the message must contain)
    ("empty", "", ["empty file"]),
    ("blank", " \n\n", ["empty file"]),
    ("header only", HEADER + "\n", ["header only"]),
    ("one row", HEADER + "\n0.0,1.0,0.0\n", ["line 2", "the only data row", "at least 2"]),
    ("wrong names", "t,v,d\n" + ROWS, ["line 1", "header must be exactly"]),
    ("missing column", "time_s,voltage_V\n0,1\n0.001,2\n", ["line 1", "missing column: an output"]),
    ("extra column", HEADER + ",force_N\n0,1,2,3\n", ["line 1", "two input columns voltage_V and force_N"]),
    ("unknown column", HEADER + ",temperature_C\n0,1,2,3\n", ["line 1", "unexpected column 'temperature_C'"]),
    ("wrong order", "voltage_V,time_s,displacement_m\n" + ROWS, ["line 1", "wrong order"]),
    ("repeated column", "time_s,voltage_V,voltage_V\n" + ROWS, ["line 1", "column voltage_V is repeated"]),
    ("no header", ROWS, ["line 1", "header is missing"]),
    ("semicolons", HEADER.replace(",", ";") + "\n0;1;2\n", ["line 1", "separated by commas"]),
    ("short row", HEADER + "\n0.0,0.0,0.0\n0.001,1.0\n0.002,2.0,2e-6\n", ["line 3", "2 cell(s), expected 3"]),
    ("long row", HEADER + "\n0.0,0.0,0.0\n0.001,1.0,0.0\n0.002,2.0,2e-6,7\n", ["line 4", "4 cell(s)"]),
    ("text cell", HEADER + "\n0.0,0.0,0.0\n0.001,abc,0.0\n", ["line 3", "voltage_V = 'abc' is not a number"]),
    ("empty cell", HEADER + "\n0.0,0.0,0.0\n0.001,1.0,\n", ["line 3", "displacement_m = '' is not a number"]),
    ("decimal comma", HEADER + "\n0.0,0.0,0.0\n0.001,\"1,5\",0.0\n", ["line 3", "cell(s)"]),
    ("quoted number", HEADER + "\n0.0,0.0,0.0\n0.001,\"1.5\",0.0\n", ["line 3", "voltage_V = '\"1.5\"'"]),
    ("nan", HEADER + "\n0.0,0.0,0.0\n0.001,1.0,nan\n", ["line 3", "displacement_m = 'nan' is not finite"]),
    ("inf", HEADER + "\n0.0,0.0,0.0\n0.001,-inf,0.0\n0.002,0,0\n", ["line 3", "voltage_V = '-inf' is not finite"]),
    ("blank line inside", HEADER + "\n0.0,0.0,0.0\n\n0.001,1.0,0.0\n", ["line 3", "empty row"]),
    ("time goes back", HEADER + "\n0.0,0,0\n0.002,0,0\n0.001,0,0\n0.003,0,0\n",
     ["line 4", "time_s = 0.001 does not increase"]),
    ("repeated time", HEADER + "\n0.0,0,0\n0.001,0,0\n0.001,0,0\n", ["line 4", "does not increase"]),
    # irregular stamps are read (see test_irregular_time_is_read), but a step of more than 100
    # median steps is a hole in the record
    ("gap", HEADER + "\n" + "".join(f"{k / 1000 + (0.2 if k > 7 else 0.0)!r},0,0\n" for k in range(20)),
     ["line 10", "time step 0.201 s", "201 times the record's median step", "a hole in the record"]),
    ("not utf-8", (HEADER + "\n0.0,0,0\n0.001,0,0 \xb5m\n").encode("latin-1"), ["line 3", "not UTF-8"]),
    ("binary", b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR", ["binary content"]),
]


@pytest.mark.parametrize("content, fragments", [case[1:] for case in BAD_CSV], ids=[case[0] for case in BAD_CSV])
def test_malformed_csv_gives_one_line_naming_file_and_row(tmp_path, content, fragments):
    path = _write_pair(tmp_path, content)
    with pytest.raises(BeamInputError) as info:
        read_measurement(path)
    message = str(info.value)
    assert message.startswith(f"{path}: "), message
    assert "\n" not in message
    for fragment in fragments:
        assert fragment in message, message


def _sidecar(replace: tuple[str, str] | None = None, append: str = "") -> str:
    text = SIDECAR if replace is None else SIDECAR.replace(*replace)
    assert replace is None or text != SIDECAR
    return text + append


BAD_SIDECAR = [
    ("syntax error", _sidecar(("length_m = 0.4573", "length_m = 0.45 m")), ["TOML syntax error", "line 3"]),
    ("missing table", _sidecar(("[sensor]\nposition_m = 0.27438\n", "")), ["[sensor]: missing table"]),
    ("missing key", _sidecar(("length_m = 0.4573\n", "")), ["[beam] length_m: missing key"]),
    ("string value", _sidecar(("length_m = 0.4573", 'length_m = "0.4573"')),
     ["[beam] length_m: must be a number, got string '0.4573'"]),
    ("boolean value", _sidecar(("end_m = 0.25", "end_m = true")), ["[patch] end_m: must be a number, got boolean"]),
    ("array value", _sidecar(("position_m = 0.27438", "position_m = [0.27438]")),
     ["[sensor] position_m: must be a number, got array"]),
    ("negative length", _sidecar(("length_m = 0.4573", "length_m = -0.4573")), ["[beam] length_m: must be > 0"]),
    ("zero density", _sidecar(("linear_density_kg_m = 0.093", "linear_density_kg_m = 0")),
     ["[beam] linear_density_kg_m: must be > 0"]),
    ("nan density", _sidecar(("linear_density_kg_m = 0.093", "linear_density_kg_m = nan")),
     ["[beam] linear_density_kg_m: must be finite"]),
    ("patch beyond the tip", _sidecar(("end_m = 0.25", "end_m = 0.5")), ["[patch]: patch must satisfy", "end_m = 0.5"]),
    ("patch reversed", _sidecar(("start_m = 0.15", "start_m = 0.3")), ["patch must satisfy"]),
    ("negative patch start", _sidecar(("start_m = 0.15", "start_m = -0.1")), ["[patch] start_m: must be >= 0"]),
    ("sensor beyond the tip", _sidecar(("position_m = 0.27438", "position_m = 0.6")), ["[sensor]: sensor position_m must lie in (0, 0.4573]"]),
    ("sensor at the clamp", _sidecar(("position_m = 0.27438", "position_m = 0.0")), ["sensor position_m"]),
    ("unknown table", _sidecar(append="[parameters]\nbending_stiffness_Nm2 = 0.5\n"), ["[parameters]: unknown table"]),
    ("unknown key", _sidecar(("length_m = 0.4573", "length_m = 0.4573\nwidht_m = 0.02")),
     ["[beam] widht_m: unknown key (did you mean 'width_m'?)"]),
    ("unknown top-level key", "titel = 'x'\n" + SIDECAR.split("\n", 1)[1], ["titel: unknown key"]),
    ("title not a string", _sidecar(('title = "bench test"', "title = 3")), ["title: must be a string"]),
    ("table given as value", "beam = 5\n" + SIDECAR.split("\n", 1)[1].replace("[beam]\n", "[beam_]\n"),
     ["beam: must be a table [beam]"]),
    ("unknown nominal name", _sidecar(append="[nominal]\nbending_stiffnes_Nm2 = 0.5\n"),
     ["[nominal] bending_stiffnes_Nm2: unknown parameter (did you mean 'bending_stiffness_Nm2'?)"]),
    ("negative nominal", _sidecar(append="[nominal]\nair_damping_Ns_m2 = -0.01\n"),
     ["[nominal] air_damping_Ns_m2: must be a positive finite number"]),
    ("string nominal", _sidecar(append="[nominal]\ntip_mass_kg = '1 g'\n"), ["[nominal] tip_mass_kg: must be a number"]),
    ("not utf-8", SIDECAR.replace("bench", "b\xe9nch").encode("latin-1"), ["line 1", "not UTF-8"]),
]


@pytest.mark.parametrize("content, fragments", [case[1:] for case in BAD_SIDECAR], ids=[case[0] for case in BAD_SIDECAR])
def test_malformed_sidecar_gives_one_line_naming_file_and_key(tmp_path, content, fragments):
    path = _write_pair(tmp_path, toml_text=content)
    with pytest.raises(BeamInputError) as info:
        read_measurement(path)
    message = str(info.value)
    assert message.startswith(f"{tmp_path / 'run.toml'}: "), message
    assert "\n" not in message
    for fragment in fragments:
        assert fragment in message, message


@pytest.mark.parametrize(
    "csv_text, toml_text, given, fragment",
    [
        (HEADER + "\n" + ROWS, None, "run.csv", "sidecar run.toml not found"),
        (None, SIDECAR, "run.toml", "data file run.csv not found"),
        (None, None, "run.csv", "not found"),
        (HEADER + "\n" + ROWS, SIDECAR, "run.truth.toml", "true-parameter file"),
    ],
)
def test_missing_files_are_named(tmp_path, csv_text, toml_text, given, fragment):
    _write_pair(tmp_path, csv_text, toml_text)
    with pytest.raises(BeamInputError, match=fragment) as info:
        read_measurement(tmp_path / given)
    assert str(tmp_path) in str(info.value)


def test_directory_in_place_of_the_csv(tmp_path):
    (tmp_path / "run.csv").mkdir()
    (tmp_path / "run.toml").write_text(SIDECAR)
    with pytest.raises(BeamInputError, match="run.csv: is a directory"):
        read_measurement(tmp_path / "run.toml")


def test_measurement_validates_nominal_and_lengths():
    arrays = dict(time_s=np.arange(3) * 0.1, voltage_V=np.ones(3), displacement_m=np.zeros(3))
    with pytest.raises(BeamInputError, match="columns differ in length"):
        Measurement("m", "m", GEOMETRY, **{**arrays, "voltage_V": np.ones(4)})
    with pytest.raises(BeamInputError, match="unknown parameter"):
        Measurement("m", "m", GEOMETRY, **arrays, nominal={"EI": 1.0})
    measurement = Measurement("m", "m", GEOMETRY, **arrays)
    with pytest.raises(ValueError):  # arrays are read-only: a Measurement is a value
        measurement.time_s[0] = 1.0


# ---------------------------------------------------------------------------------------------
# irregular time stamps
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "times, uniform",
    [
        ([k / 1000 for k in range(20) if k != 7], False),  # a missing sample: a step of 2 ms
        ([0.001 * (k + 5e-5 * k * (k - 1)) for k in range(100)], False),  # steps grow: the stamps drift off the grid
        ([round(k / 2048, 6) for k in range(50)], True),  # 6 decimals: within 1 % of the grid, uniform
    ],
    ids=["missing sample", "drifting step", "rounded stamps"],
)
def test_irregular_time_is_read_and_only_a_uniform_record_has_an_interval(tmp_path, times, uniform):
    text = HEADER + "\n" + "".join(f"{t!r},0,{k * 1e-6!r}\n" for k, t in enumerate(times))
    read = read_measurement(_write_pair(tmp_path, text))
    np.testing.assert_array_equal(read.time_s, times)
    assert read.uniform is uniform
    steps = np.diff(times)
    assert read.median_interval_s == pytest.approx(np.median(steps), rel=1e-12)
    if uniform:
        assert read.sample_interval_s == pytest.approx((times[-1] - times[0]) / (len(times) - 1), rel=1e-12)
    else:
        with pytest.raises(BeamInputError, match="irregular .* no single sampling interval"):
            read.sample_interval_s  # noqa: B018 - the property raises
        assert read.rate_Hz == pytest.approx(1 / np.median(steps), rel=1e-12)
        assert read.duration_s == pytest.approx(times[-1] - times[0] + np.median(steps), rel=1e-12)


def test_the_gap_limit_is_100_median_steps(tmp_path):
    """A step of exactly 100 median steps is read; a hair more is a hole."""
    base = [k * 0.25e-3 for k in range(40)]
    for extra, ok in ((99 * 0.25e-3, True), (99.01 * 0.25e-3, False)):
        times = base[:20] + [t + extra for t in base[20:]]
        text = "time_s,acceleration_m_s2\n" + "".join(f"{t!r},{float(np.sin(k))!r}\n" for k, t in enumerate(times))
        path = _write_pair(tmp_path, text, FREE_SIDECAR)
        if ok:
            assert read_measurement(path).max_interval_s == pytest.approx(100 * 0.25e-3)
        else:
            with pytest.raises(BeamInputError, match="line 22: time step .* more than the 100 allowed"):
                read_measurement(path)


# ---------------------------------------------------------------------------------------------
# the other kinds of record: point force, free response, velocity and acceleration
# ---------------------------------------------------------------------------------------------

FREE_SIDECAR = """[beam]
length_m = 0.5
linear_density_kg_m = 0.27
[sensor]
position_m = 0.44
"""
FORCE_SIDECAR = FREE_SIDECAR + "[force]\nposition_m = 0.5\n"


@pytest.mark.parametrize("input_column", [None, "voltage_V", "force_N"])
@pytest.mark.parametrize("output_column", ["displacement_m", "velocity_m_s", "acceleration_m_s2"])
def test_every_kind_round_trips_bit_exact(tmp_path, input_column, output_column):
    rng = np.random.default_rng(7)
    n = 300
    time_s = 3.0 + np.cumsum(rng.uniform(0.2e-3, 0.3e-3, n))  # irregular stamps
    geometry = BeamGeometry(0.5, 0.27, None, None, 0.44)
    if input_column == "voltage_V":
        geometry = BeamGeometry(0.5, 0.27, 0.01, 0.06, 0.44)
    elif input_column == "force_N":
        geometry = BeamGeometry(0.5, 0.27, None, None, 0.44, force_position_m=0.3)
    data = {"time_s": time_s, output_column: rng.normal(size=n) * 3.0}
    if input_column:
        data[input_column] = rng.normal(size=n)
    written = write_measurement(tmp_path / "k", data, geometry=geometry, sensor_range=40.0)
    first_line = (tmp_path / "k.csv").read_text().split("\n", 1)[0]
    assert first_line == ",".join(["time_s"] + ([input_column] if input_column else []) + [output_column])
    read = read_measurement(tmp_path / "k.csv")
    assert read.geometry == geometry and read.sensor_range == 40.0 and read.uniform is False
    assert read.input_column == input_column and read.output_column == output_column
    assert read.input_kind == {None: None, "voltage_V": "voltage", "force_N": "force"}[input_column]
    assert read.output_kind == output_column.split("_")[0]
    assert read.is_free is (input_column is None)
    assert read.output.tobytes() == data[output_column].tobytes()
    assert read.time_s.tobytes() == time_s.tobytes()
    if input_column:
        assert read.input.tobytes() == data[input_column].tobytes()
    else:
        assert read.input is None and read.input_unit is None
    assert read.clipped_count == 0 and written.columns == read.columns
    second = write_measurement(tmp_path / "again", read)
    assert (tmp_path / "again.csv").read_bytes() == (tmp_path / "k.csv").read_bytes()
    assert second.sensor_range == 40.0


def test_the_classic_names_still_work_for_the_classic_record(tmp_path):
    read = read_measurement(_write_pair(tmp_path))
    assert read.columns == ("time_s", "voltage_V", "displacement_m")
    assert read.input is read.voltage_V and read.output is read.displacement_m
    assert (read.input_kind, read.output_kind, read.input_unit, read.output_unit) == ("voltage", "displacement", "V", "m")
    assert read.force_N is None and read.velocity_m_s is None and read.acceleration_m_s2 is None
    assert read.sensor_range is None and read.uniform


def test_a_free_record_needs_no_patch_and_a_patch_is_allowed(tmp_path):
    rows = "".join(f"{k * 1e-3!r},{float(np.cos(k))!r}\n" for k in range(10))
    free = read_measurement(_write_pair(tmp_path, "time_s,acceleration_m_s2\n" + rows, FREE_SIDECAR))
    assert not free.geometry.has_patch and free.is_free
    with_patch = read_measurement(_write_pair(tmp_path, "time_s,velocity_m_s\n" + rows, SIDECAR, name="p"))
    assert with_patch.geometry.has_patch and with_patch.output_kind == "velocity"


BAD_NEW_KINDS = [
    # (id, CSV text, sidecar text, fragments)
    ("acceleration in g", "time_s,acceleration_g\n0,1\n0.001,2\n", FREE_SIDECAR,
     ["run.csv: line 1", "unexpected column 'acceleration_g': acceleration is read in m/s² as acceleration_m_s2"]),
    ("force in kN", "time_s,force_kN,displacement_m\n0,1,2\n0.001,2,3\n", FORCE_SIDECAR,
     ["line 1", "force is read in N as force_N"]),
    ("velocity in mm/s", "time_s,velocity_mm_s\n0,1\n0.001,2\n", FREE_SIDECAR, ["line 1", "as velocity_m_s"]),
    ("two outputs", "time_s,displacement_m,acceleration_m_s2\n0,1,2\n0.001,2,3\n", FREE_SIDECAR,
     ["line 1", "two output columns displacement_m and acceleration_m_s2"]),
    ("two inputs", "time_s,voltage_V,force_N,displacement_m\n0,1,2,3\n0.001,2,3,4\n", FORCE_SIDECAR,
     ["line 1", "two input columns voltage_V and force_N"]),
    ("output before input", "time_s,acceleration_m_s2,force_N\n0,1,2\n0.001,2,3\n", FORCE_SIDECAR,
     ["line 1", "force_N must come before the output column acceleration_m_s2"]),
    ("time only", "time_s\n0\n0.001\n", FREE_SIDECAR, ["line 1", "missing column: an output"]),
    ("force without position", "time_s,force_N,acceleration_m_s2\n0,1,2\n0.001,2,3\n", FREE_SIDECAR,
     ["run.toml: [force]: missing table (a force_N input needs it)"]),
    ("voltage without patch", "time_s,voltage_V,acceleration_m_s2\n0,1,2\n0.001,2,3\n", FREE_SIDECAR,
     ["run.toml: [patch]: missing table (a voltage_V input needs it)"]),
    ("force position beyond the tip", "time_s,force_N,acceleration_m_s2\n0,1,2\n0.001,2,3\n",
     FREE_SIDECAR + "[force]\nposition_m = 0.7\n", ["run.toml: [force]: force position_m must lie in (0, 0.5]"]),
    ("force position key misspelt", "time_s,force_N,acceleration_m_s2\n0,1,2\n0.001,2,3\n",
     FREE_SIDECAR + "[force]\nposition = 0.3\n", ["run.toml: [force] position: unknown key"]),
    ("negative range", "time_s,acceleration_m_s2\n0,1\n0.001,2\n", FREE_SIDECAR + "range = -98.1\n",
     ["run.toml: [sensor] range: must be > 0"]),
    ("range as a string", "time_s,acceleration_m_s2\n0,1\n0.001,2\n", FREE_SIDECAR + "range = '10 g'\n",
     ["run.toml: [sensor] range: must be a number"]),
    ("time goes back", "time_s,acceleration_m_s2\n0,1\n0.002,2\n0.001,3\n", FREE_SIDECAR,
     ["run.csv: line 4", "does not increase"]),
    ("repeated time", "time_s,force_N,velocity_m_s\n0,0,1\n0.001,0,2\n0.001,0,3\n", FORCE_SIDECAR,
     ["run.csv: line 4", "does not increase"]),
    ("gap", "time_s,acceleration_m_s2\n" + "".join(f"{k * 1e-3 + (1.0 if k > 4 else 0)!r},{k % 3}\n" for k in range(10)),
     FREE_SIDECAR, ["run.csv: line 7", "a hole in the record"]),
    ("clipped everywhere", "time_s,acceleration_m_s2\n" + "".join(f"{k * 1e-3!r},{(-1) ** (k // 4) * 9.0!r}\n"
                                                                   for k in range(40)),
     FREE_SIDECAR, ["run.csv: ", "of 40 samples of acceleration_m_s2 are clipped", "more than half"]),
    ("at the range", "time_s,acceleration_m_s2\n" + "".join(f"{k * 1e-3!r},{float(98.1 * np.sin(k))!r}\n" for k in range(40)),
     FREE_SIDECAR + "range = 50.0\n", ["run.csv: ", "clipped (at the sensor's range 50 m/s²", "more than half"]),
]


@pytest.mark.parametrize("csv_text, toml_text, fragments", [c[1:] for c in BAD_NEW_KINDS], ids=[c[0] for c in BAD_NEW_KINDS])
def test_bad_records_of_the_new_kinds_give_one_line(tmp_path, csv_text, toml_text, fragments):
    path = _write_pair(tmp_path, csv_text, toml_text)
    with pytest.raises(BeamInputError) as info:
        read_measurement(path)
    message = str(info.value)
    assert "\n" not in message and message.startswith(str(tmp_path)), message
    for fragment in fragments:
        assert fragment in message, message


def test_clipping_is_marked_and_counted():
    """Runs of 3+ samples at the extreme inside the record, and samples at the sensor's range."""
    t = np.arange(200) * 1e-3
    y = 30 * np.sin(2 * np.pi * 7 * t)
    y = np.clip(y, -25.0, 25.0)  # a saturated sensor: flat tops at +-25 for several samples each
    flat = np.abs(y) == 25.0
    measurement = Measurement("c", "c", BeamGeometry(0.5, 0.27, None, None, 0.44), t, acceleration_m_s2=y)
    np.testing.assert_array_equal(measurement.clipped, flat)
    assert measurement.clipped_count == int(flat.sum()) > 0
    # with the range given, samples reaching it count even when not repeated
    single = np.sin(2 * np.pi * 7 * t) * 30
    with_range = Measurement("c", "c", BeamGeometry(0.5, 0.27, None, None, 0.44), t, velocity_m_s=single,
                             sensor_range=29.99)
    np.testing.assert_array_equal(with_range.clipped, np.abs(single) >= 29.99 * (1 - 1e-3))
    # a record at rest at its start and a held deflection at its end are not clipped
    step = np.where(t < 0.1, 0.0, 1e-4)
    assert Measurement("s", "s", GEOMETRY, t, np.ones(200), step).clipped_count == 0
    assert Measurement("s", "s", GEOMETRY, t, np.ones(200), np.zeros(200)).clipped_count == 0


def test_measurement_checks_the_geometry_of_its_input():
    t = np.arange(4) * 0.1
    bare = BeamGeometry(0.5, 0.27, None, None, 0.44)
    with pytest.raises(BeamInputError, match="voltage_V input needs the patch"):
        Measurement("m", "m", bare, t, voltage_V=np.ones(4), displacement_m=np.arange(4.0))
    with pytest.raises(BeamInputError, match="force_N input needs the force's position"):
        Measurement("m", "m", bare, t, force_N=np.ones(4), acceleration_m_s2=np.arange(4.0))
    with pytest.raises(BeamInputError, match="two input columns"):
        Measurement("m", "m", GEOMETRY, t, voltage_V=np.ones(4), force_N=np.ones(4), displacement_m=np.arange(4.0))
    with pytest.raises(BeamInputError, match="exactly one output column .* got none"):
        Measurement("m", "m", GEOMETRY, t, voltage_V=np.ones(4))
    with pytest.raises(BeamInputError, match="got displacement_m, velocity_m_s"):
        Measurement("m", "m", GEOMETRY, t, displacement_m=np.ones(4), velocity_m_s=np.ones(4))


def test_write_refuses_data_without_an_output(tmp_path):
    with pytest.raises(BeamInputError, match="no output column"):
        write_measurement(tmp_path / "x", {"time_s": np.arange(3.0), "force_N": np.ones(3)}, geometry=GEOMETRY)
    assert list(tmp_path.iterdir()) == []


def test_the_real_free_decay_records_read(tmp_path):
    """The bundled real records (assets/real): free, irregular, acceleration, nothing clipped."""
    files = sorted((Path(__file__).resolve().parents[1] / "assets" / "real").glob("*.csv"))
    assert len(files) == 2
    read = read_measurement(files[0])
    assert read.is_free and read.output_kind == "acceleration" and not read.uniform
    assert read.median_interval_s == pytest.approx(0.25e-3, rel=1e-6)
    assert 0.005 < read.max_interval_s < 0.01 and read.clipped_count == 0
    assert read.geometry.sensor_position_m == 0.44 and not read.geometry.has_patch
