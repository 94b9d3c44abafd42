"""What the reader decides, as data, on records a class brings (#39 items 2-4, 9-10; #38 items 6, 10).

Each record is made here to a lab's or an app's layout (:mod:`tests.record_files`): a phone
export in g (Physics Toolbox Sensor Suite), a CSV in m/s² whose time column is in ms, a
strain-gauge LVM in microstrain, an Arduino log of ADC counts, MATLAB v5 and v7.3 files holding
two records (a steel and an aluminium strip). The signals are damped sinusoids written in the
file's unit; every check compares what is read with what was written (the file's own numbers),
and every decision with the reason the file gives for it.
"""

from __future__ import annotations

import pickle
import re

import h5py
import numpy as np
import pytest
import scipy.io

from beam.errors import BeamInputError
from beam.io.readers import COMMAND_LINE, Finding, Hint, Phrasing, ReadingError, read_raw, read_record
from beam.io.readers.units import SIGNAL_UNITS, STANDARD_GRAVITY, column_meaning
from tests.record_files import write_lvm, write_physics_toolbox

RATE = 400.0


def _decay(t: np.ndarray, amplitude: float, frequency: float, rate: float = 0.3) -> np.ndarray:
    return amplitude * np.exp(-rate * t) * np.sin(2 * np.pi * frequency * t)


def _finding(record, topic: str) -> Finding:
    (found,) = [f for f in record.findings if f.topic == topic]
    return found


@pytest.fixture
def records(tmp_path):
    """The class's records, each with the signal in SI as written (before the file's unit)."""
    rng = np.random.default_rng(39)
    t = np.arange(0, 6, 1 / RATE)
    acc = _decay(t, 156.7, 6.0) + 0.05 * rng.normal(size=t.size)  # ±16 g: the phone of #39
    files = {}
    files["phone_g"] = (write_physics_toolbox(tmp_path / "phone.csv", t, {"x": 0 * t, "y": 1 + 0 * t,
                                                                         "z": acc / STANDARD_GRAVITY}, unit="g"), acc)
    ms = tmp_path / "ms.csv"
    rows = "".join(f"{a!r},{b!r}\n" for a, b in zip((t * 1000).tolist(), acc.tolist()))
    ms.write_text("Time (ms),Acceleration (m/s^2)\n" + rows)
    files["ms"] = (ms, acc)
    ts = np.arange(0, 4, 1 / 2000)
    eps = _decay(ts, 150.0, 20.0, 0.4)  # µε at the root of a steel bar
    files["gauge"] = (write_lvm(tmp_path / "gauge.lvm", [(1 / 2000, ["Strain gauge 1"], ["µε"], np.c_[eps])]), eps * 1e-6)
    counts = np.round(512 + 200 * np.exp(-0.3 * t) * np.sin(2 * np.pi * 7 * t))
    arduino = tmp_path / "arduino.csv"
    arduino.write_text("Quantisation level,Time\n" + "".join(f"{int(c)},{x:.4f}\n" for c, x in zip(counts, t)))
    files["arduino"] = (arduino, counts)
    return files


def test_each_file_is_read_in_its_own_unit_with_every_choice_and_its_reason(records):
    phone, acc = records["phone_g"]
    record = read_record(phone)
    # six decimals of g written: the file's peak, within its rounding
    assert np.max(np.abs(record.output)) == pytest.approx(np.max(np.abs(acc)), abs=0.5e-6 * STANDARD_GRAVITY)
    unit = _finding(record, "unit")
    assert (unit.chosen, unit.option, unit.given) == ("g", "unit", False)
    assert "Physics Toolbox Sensor Suite" in unit.why and "g" in unit.why
    signal = _finding(record, "signal")
    assert (signal.chosen, signal.why, signal.option) == ("gFz", "the most vibration power", "column")
    assert "assumed" in _finding(record, "time").why  # "time" has no unit: seconds, said so

    ms, acc = records["ms"]
    record = read_record(ms)
    np.testing.assert_array_equal(record.output, acc)
    assert record.rate_Hz == pytest.approx(RATE, rel=1e-9) and record.duration_s == pytest.approx(6 - 1 / RATE)
    time = _finding(record, "time")
    assert time.chosen == "column 'Time (ms)'" and time.why.startswith("in ms, from its name")

    gauge, strain = records["gauge"]
    record = read_record(gauge)
    assert record.output_column == "strain"
    np.testing.assert_allclose(record.output, strain, rtol=0, atol=0.5e-6 * 1e-6 * 1.0001)  # six decimals of µε
    assert (_finding(record, "unit").chosen, _finding(record, "unit").why) == ("µε", "from the file's unit field")


def test_no_raw_index_or_app_name_is_ever_a_unit():
    assert column_meaning("Acc[1]").unit is None and column_meaning("Acc[1]").quantity == "acceleration"
    assert column_meaning("data[2]").unit is None
    assert column_meaning("gFz").unit == "g" and column_meaning("micros").unit == "us"
    assert column_meaning("acc (counts)").arbitrary and column_meaning("acc (counts)").quantity == "acceleration"


def test_a_matrix_without_units_lists_its_columns_as_columns_not_units(tmp_path):
    t = np.arange(0, 2, 1 / RATE)
    scipy.io.savemat(tmp_path / "m.mat", {"Acc": np.c_[t, _decay(t, 2.0, 6.0)]})
    with pytest.raises(ReadingError) as refused:
        read_record(tmp_path / "m.mat")
    assert "Acc[2] (acceleration)" in refused.value.columns[1] and "in 1" not in " ".join(refused.value.columns)
    assert refused.value.hint == Hint("unit", refused.value.hint.values)
    assert {"microstrain", "strain"} <= set(refused.value.hint.values) and "arbitrary" in str(refused.value)


def test_strain_units_are_listed_wherever_units_are(tmp_path):
    assert {"microstrain", "strain"} <= set(SIGNAL_UNITS)
    path = tmp_path / "x.csv"
    path.write_text("t,a\n" + "".join(f"{k / 100},{np.sin(k)}\n" for k in range(200)))
    with pytest.raises(ReadingError, match="--unit 'furlongs': unknown unit; expected one of .*microstrain, strain"):
        read_record(path, unit="furlongs")
    with pytest.raises(ReadingError, match=r"give it with --unit \(g, .*microstrain, strain; arbitrary"):
        read_record(path)


def test_a_signal_of_unknown_scale_is_read_as_arbitrary_units(records):
    arduino, counts = records["arduino"]
    with pytest.raises(ReadingError) as refused:  # nothing says what 'Quantisation level' measures, nor its unit
        read_record(arduino)
    assert refused.value.hint.kind == "unit_and_quantity"
    again = pickle.loads(pickle.dumps(refused.value))  # from a worker process, whole
    assert str(again) == str(refused.value) and again.columns == refused.value.columns
    message = str(refused.value)
    assert message.startswith(f"{arduino}: column 'Quantisation level' has no unit the reader knows; give it with --unit")
    assert "arbitrary-acceleration" in message and "ADC counts" in message
    with pytest.raises(ReadingError, match="does not say what the sensor measures; say what .* --unit arbitrary-"):
        read_record(arduino, unit="counts")
    record = read_record(arduino, unit="arbitrary-acceleration")
    assert record.arbitrary_units and record.output_column == "acceleration_m_s2"
    np.testing.assert_array_equal(record.output, counts)  # the values as the file holds them
    unit = _finding(record, "unit")
    assert unit.given and "scale unknown" in unit.why


def test_a_file_holding_two_records_lists_both_and_reads_the_one_chosen(tmp_path):
    t_steel, t_alu = np.arange(0, 3, 1e-3), np.arange(0, 4, 1e-3)
    steel, alu = _decay(t_steel, 5.0, 11.0, 0.5), _decay(t_alu, 8.0, 6.0)
    scipy.io.savemat(tmp_path / "two.mat", {"steel": {"t": t_steel, "acc_g": steel / STANDARD_GRAVITY},
                                            "aluminium": {"t": t_alu, "acc_g": alu / STANDARD_GRAVITY}})
    with h5py.File(tmp_path / "two73.mat", "w", userblock_size=512) as handle:  # MATLAB 7.3: structs are groups
        for name, t, a in (("steel", t_steel, steel), ("aluminium", t_alu, alu)):
            group = handle.create_group(name)
            group.create_dataset("t", data=t.reshape(1, -1))
            group.create_dataset("acc_g", data=(a / STANDARD_GRAVITY).reshape(1, -1))
            text = group.create_dataset("units", data=np.frombuffer(b"g\0", dtype=np.uint8).astype(np.uint16))
            text.attrs["MATLAB_class"] = b"char"  # text, not data
    with open(tmp_path / "two73.mat", "r+b") as handle:
        handle.write(b"MATLAB 7.3 MAT-file, Platform: GLNXA64".ljust(116, b" ") + b"\x00" * 8 + b"\x00\x02IM")
    for name in ("two.mat", "two73.mat"):
        path = tmp_path / name
        assert sorted(b.label for b in read_raw(path).blocks) == ["aluminium", "steel"]
        default = read_record(path)
        chosen = _finding(default, "record")
        assert (chosen.chosen, chosen.why, chosen.option) == ("aluminium", "the longest", "record")
        assert "steel" in chosen.found and "aluminium" in chosen.found
        np.testing.assert_allclose(default.output, alu, rtol=1e-12)
        other = read_record(path, record="steel")
        np.testing.assert_allclose(other.output, steel, rtol=1e-12)
        assert _finding(other, "record").given and other.records == default.records
        np.testing.assert_allclose(other.time_s, t_steel, atol=1e-12)
        with pytest.raises(ReadingError, match=r"--record 'copper': no such record; the file holds"):
            read_record(path, record="copper")
    t = np.arange(0, 2, 1e-3)
    np.savez(tmp_path / "one.npz", t=t, acc_g=_decay(t, 1.0, 6.0))
    with pytest.raises(ReadingError, match="--record 'steel': the file holds one record"):
        read_record(tmp_path / "one.npz", record="steel")


def test_arrays_of_different_lengths_are_records_of_their_own(tmp_path):
    t1, t2 = np.arange(0, 2, 1e-3), np.arange(0, 3, 1e-3)
    np.savez(tmp_path / "runs.npz", t1=t1, acc1_g=_decay(t1, 1.0, 6.0), t2=t2, acc2_g=_decay(t2, 2.0, 6.0),
             gains=np.arange(5.0))
    raw = read_raw(tmp_path / "runs.npz")
    assert [b.label for b in raw.blocks] == ["t1, acc1_g", "t2, acc2_g"]
    assert any("gains (5 values)" in note for note in raw.notes)  # too short to be a record: said
    np.testing.assert_allclose(read_record(tmp_path / "runs.npz", record="1").output,
                               _decay(t1, 1.0, 6.0) * STANDARD_GRAVITY, rtol=1e-12)


def test_stamps_without_a_unit_that_cannot_be_seconds_are_refused_with_the_time_unit(tmp_path):
    t = np.arange(0, 6, 1 / RATE)
    path = tmp_path / "log.csv"  # milliseconds with decimals: read as seconds it would be 0.4 samples per second
    path.write_text("time,acc_m_s2\n" + "".join(f"{a:.3f},{b!r}\n" for a, b in zip(t * 1000, _decay(t, 2, 6).tolist())))
    with pytest.raises(ReadingError, match=r"too slow for a vibrating strip: milliseconds\?; give --time-unit ms\|us"):
        read_record(path)
    assert read_record(path, time_unit="ms").rate_Hz == pytest.approx(RATE, rel=1e-6)


def test_a_front_end_says_the_findings_and_hints_in_its_own_words(records):
    """The same error and findings phrased by the command line and by a page that names its controls."""
    page = Phrasing(options={"unit": "Signal's unit", "column": "Signal column", "time_unit": "Time column's unit"},
                    hints={"unit_and_quantity": "choose it as the Signal's unit under Reading options ({listed})",
                           "time_unit": "choose {values} as the Time column's unit under Reading options"},
                    given="your choice", change="; another: {option}", separator=" or ", units_shown=True)
    arduino, _ = records["arduino"]
    with pytest.raises(ReadingError) as refused:
        read_record(arduino)
    said = refused.value.phrased(page, path_text="arduino.csv")
    assert said.startswith("arduino.csv: column 'Quantisation level' has no unit the reader knows; choose it as the "
                           "Signal's unit under Reading options (g, m/s², ")
    assert "µε (microstrain)" in said and "--" not in said
    record = read_record(records["phone_g"][0])
    lines = [page.finding(f, change=True) for f in record.findings]
    assert "signal: gFz: the most vibration power" in lines[1] and lines[1].endswith("; another: Signal column")
    cli = [COMMAND_LINE.finding(f, change=True) for f in record.findings]
    assert cli[1].endswith("; another with --column")
    for text in lines + cli:  # never a unit made of a column's index or of an app's name
        assert not re.search(r"in (\d+|gf[xyz])\)", text)


def test_a_file_that_is_no_record_is_named_and_never_echoed(tmp_path):
    png = tmp_path / "shot.png"
    png.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(range(256)))
    with pytest.raises(BeamInputError) as refused:
        read_record(png)
    assert "binary content (a PNG image), not a record" in str(refused.value) and "PNG'" not in str(refused.value)


def test_an_hdf5_file_of_several_runs_lists_them(tmp_path):
    """A lab's own HDF5 (h5py, row-major): a group per run, its sampling rate an attribute."""
    t = np.arange(0, 2, 1e-3)
    with h5py.File(tmp_path / "runs.h5", "w") as handle:
        for k in (1, 2):
            group = handle.create_group(f"run{k}")
            group.create_dataset("acc_m_s2", data=_decay(t, float(k), 6.0))
            group.attrs["fs"] = 1000.0
    first = read_record(tmp_path / "runs.h5")
    assert first.format == "HDF5" and first.records == ["run1", "run2"]
    assert _finding(first, "record").why == "the first of the longest"
    second = read_record(tmp_path / "runs.h5", record="run2")
    np.testing.assert_allclose(second.output, _decay(t, 2.0, 6.0), rtol=1e-15)
    assert second.rate_Hz == pytest.approx(1000.0, rel=1e-9) and "sampling rate 1000 Hz" in second.notes[0]
