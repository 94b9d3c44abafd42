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
    ("missing column", "time_s,voltage_V\n0,1\n0.001,2\n", ["line 1", "missing column displacement_m"]),
    ("extra column", HEADER + ",force_N\n0,1,2,3\n", ["line 1", "unexpected column 'force_N'"]),
    ("wrong order", "voltage_V,time_s,displacement_m\n" + ROWS, ["line 1", "wrong order"]),
    ("repeated column", "time_s,voltage_V,voltage_V\n" + ROWS, ["line 1", "missing column displacement_m"]),
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
    ("missing sample", HEADER + "\n" + "".join(f"{k / 1000!r},0,0\n" for k in range(20) if k != 7),
     ["line 9", "time step 0.002 s", "uniformly spaced"]),
    # every step within 1 % of the median, but the steps grow: the time stamps drift off the grid
    ("drifting step", HEADER + "\n" + "".join(f"{0.001 * (k + 5e-5 * k * (k - 1))!r},0,0\n" for k in range(100)),
     ["line 5:", "off the uniform grid"]),  # |t_3 - 3 dt| = 1.44e-5 s > 1 % of dt = 1.0049e-3 s
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
    ("unknown key", _sidecar(("length_m = 0.4573", "length_m = 0.4573\nwidth_m = 0.02")),
     ["[beam] width_m: unknown key"]),
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
