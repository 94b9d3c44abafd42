"""The *Your record* page's reading options, driven through its state (#39 items 2-4, #38 item 10).

One session reads records one after another as a class brings them: a bare NumPy table (its unit
chosen), a phone export in g, a CSV in m/s² with its time in ms, a MATLAB file with a steel and
an aluminium strip, a CSV of columns of different quantities. Each must be read in its own units
(the peak within 1 % of the file's own, written here), with the file's own columns and records
offered, nothing of the previous file's reading kept, and every text in the page's words.

The NumPy table is ``assets/real/formats/adxl_50cm_114655.npy`` (a real aluminium strip's record
by Enes Demirkaya, MIT licence, re-saved by this project).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import panel as pn
import pytest
import scipy.io
from bokeh.document import Document

from beam.io.readers.units import STANDARD_GRAVITY
from dashboard.state.session import SessionState
from dashboard.views.record import RecordView
from tests.record_files import write_physics_toolbox

REPO = Path(__file__).resolve().parents[2]
NPY = REPO / "assets" / "real" / "formats" / "adxl_50cm_114655.npy"
STRIP = {"length_m": 0.5, "width_m": 0.05, "thickness_m": 0.002, "material": "aluminium", "sensor_position_m": 0.44}
RATE = 400.0


@pytest.fixture
def session(pool):
    s = SessionState(pool=pool, debounce_s=0.0)
    yield s
    s.close()
    s.wait(10)


def _decay(t, amplitude, frequency, rate=0.3):
    return amplitude * np.exp(-rate * t) * np.sin(2 * np.pi * frequency * t)


def _page_words(text: str) -> None:
    """A text written for the page: no command-line flag, no index or app name as a unit, no
    option named twice in one sentence."""
    assert not re.search(r"--[a-z]", text), text
    assert not re.search(r"in (\d+|gf[xyz])\)", text), text
    assert "Reading options s " not in text and text.count("under Reading options") <= 2, text


def _read(session, name: str, data: bytes):
    r = session.record
    r.upload(name, data)
    assert session.wait(60)
    return r


def test_each_file_starts_from_its_own_reading(session, tmp_path):
    r = session.record
    # 1. a table that does not say its unit: refused in the page's words, read once the unit is chosen
    _read(session, NPY.name, NPY.read_bytes())
    assert r.stage == "error" and "Signal's unit under Reading options" in r.error
    _page_words(r.error)
    assert r.file_columns == ["1: column 1 (time)", "2: column 2 (unknown quantity)"]  # offered though refused
    r.signal_unit = "m/s^2"
    assert session.wait(60) and r.stage == "read"
    np.testing.assert_array_equal(r.read.record.output, np.load(NPY)[:, 1])
    r.param.update(**STRIP)
    assert session.wait(60) and r.described is not None

    # 2. a phone export in g: the unit chosen for the table is not carried over
    t = np.arange(0, 6, 1 / RATE)
    acc = _decay(t, 156.7, 6.0)  # ±16 g, the phone
    phone = write_physics_toolbox(tmp_path / "phone.csv", t, {"x": 0 * t, "y": 1 + 0 * t, "z": acc / STANDARD_GRAVITY})
    _read(session, phone.name, phone.read_bytes())
    assert r.stage == "read" and r.signal_unit is None and r.read.file_name == "phone.csv"
    peak = float(np.max(np.abs(r.read.record.output)))
    assert peak == pytest.approx(np.max(np.abs(acc)), rel=0.01)
    findings = {title: (text, control) for title, text, control in r.read.summary()["findings"]}
    assert findings["Unit"][0].startswith("g: Physics Toolbox Sensor Suite's g-force meter writes it in g")
    assert findings["Unit"][1] == "Signal's unit under Reading options"
    assert findings["Signal used"][0].startswith("gFz: the most vibration power")
    for text, control in findings.values():
        _page_words(text + " " + control)
    assert "gFz (acceleration in g)" in " ".join(r.file_columns)
    # the beam is kept for the new file, and the page says so until the form is touched
    assert r.beam_kept_from == NPY.name
    r.sensor_position_m = 0.45
    assert r.beam_kept_from == ""

    # 3. a CSV in m/s² with its time in ms
    ms = tmp_path / "ms.csv"
    ms.write_text("Time (ms),Acceleration (m/s^2)\n" + "".join(f"{a!r},{b!r}\n" for a, b in
                                                               zip((t * 1000).tolist(), acc.tolist())))
    _read(session, ms.name, ms.read_bytes())
    assert r.stage == "read" and r.read.record.rate_Hz == pytest.approx(RATE, rel=1e-9)
    assert float(np.max(np.abs(r.read.record.output))) == pytest.approx(np.max(np.abs(acc)), rel=0.01)
    time = next(text for title, text, _ in r.read.summary()["findings"] if title == "Time")
    assert time == "column 'Time (ms)': in ms, from its name"


def test_the_column_menu_offers_the_new_files_columns_even_when_it_is_refused(session, tmp_path):
    r = session.record
    t = np.arange(0, 6, 1 / RATE)
    phone = write_physics_toolbox(tmp_path / "phone.csv", t, {"x": 0 * t, "y": 1 + 0 * t, "z": _decay(t, 1.0, 6.0)})
    _read(session, phone.name, phone.read_bytes())
    r.signal_column = "2"  # gFx of the phone
    assert session.wait(60) and r.read.record.signal.startswith("gFx")
    mixed = tmp_path / "mixed.csv"  # an acceleration and a displacement: the reader cannot compare them
    disp = _decay(t, 2.0, 6.0)
    mixed.write_text("time_s,tip (mm),acc (g)\n" + "".join(f"{a!r},{b!r},{c!r}\n" for a, b, c in
                                                           zip(t.tolist(), disp.tolist(), (disp / 9).tolist())))
    _read(session, mixed.name, mixed.read_bytes())
    assert r.stage == "error" and "choose one as the Signal column under Reading options" in r.error
    _page_words(r.error)
    assert r.signal_column is None  # the phone's column 2 is not this file's
    assert r.file_columns == ["1: time_s (time in s)", "2: tip (mm) (displacement in mm)", "3: acc (g) (acceleration in g)"]
    assert r.read.file_name == "phone.csv" and r.dropped_name == "mixed.csv"  # what is shown is said to be the phone's
    r.signal_column = "2"
    assert session.wait(60) and r.stage == "read" and r.read.file_name == "mixed.csv"
    np.testing.assert_allclose(r.read.record.output, disp * 1e-3, rtol=1e-12)


def test_a_file_of_two_records_offers_both_and_each_ones_columns(session, tmp_path):
    r = session.record
    t_steel, t_alu = np.arange(0, 3, 1e-3), np.arange(0, 4, 1e-3)
    steel, alu = _decay(t_steel, 5.0, 11.0, 0.5), _decay(t_alu, 8.0, 6.0)
    path = tmp_path / "strips.mat"
    scipy.io.savemat(path, {"steel": {"t": t_steel, "strain_ue": steel}, "aluminium": {"t": t_alu, "acc_g": alu}})
    _read(session, path.name, path.read_bytes())
    assert r.stage == "read" and r.file_records == ["steel", "aluminium"]
    record = next(text for title, text, _ in r.read.summary()["findings"] if title == "Record")
    assert record.startswith("aluminium: the longest")
    assert r.file_columns == ["1: t (time)", "2: acc_g (acceleration in g)"]
    r.record_name = "steel"
    assert session.wait(60) and r.stage == "read"
    assert r.file_columns == ["1: t (time)", "2: strain_ue (strain in ue)"]
    assert r.read.record.output_column == "strain"
    np.testing.assert_allclose(r.read.record.output, steel * 1e-6, rtol=1e-12)


def test_the_reading_options_menus_follow_the_file_and_offer_strain(session, tmp_path):
    view = RecordView(session=session)
    view.build()
    view.__panel__().get_root(Document())
    menus = {w.css_classes[0]: w for w in view.__panel__().select(pn.widgets.Select) if w.css_classes}
    units = menus["record-signal-unit"].options
    assert units["µε (microstrain)"] == "microstrain" and units["strain (m/m)"] == "strain"
    assert units["m/s²"] == "m/s^2" and units["arbitrary units of acceleration"] == "arbitrary-acceleration"
    assert not menus["record-record-name"].visible
    t = np.arange(0, 3, 1e-3)
    path = tmp_path / "strips.mat"
    scipy.io.savemat(path, {"a": {"t": t, "acc_g": _decay(t, 1.0, 6.0)}, "b": {"t": t, "disp_mm": _decay(t, 1.0, 6.0)}})
    _read(session, path.name, path.read_bytes())
    assert menus["record-record-name"].visible and list(menus["record-record-name"].options.values()) == ["", "a", "b"]
    assert list(menus["record-signal-column"].options) == ["(the most vibration power)", "2: acc_g (acceleration in g)"]
    menus["record-record-name"].value = "b"
    assert session.wait(60) and session.record.read.record.output_column == "displacement_m"
    assert list(menus["record-signal-column"].options) == ["(the most vibration power)",
                                                            "2: disp_mm (displacement in mm)"]


def test_adc_counts_are_read_as_arbitrary_units_on_the_page(session, tmp_path):
    r = session.record
    t = np.arange(0, 5, 1 / 500)
    counts = np.round(512 + 200 * np.exp(-0.3 * t) * np.sin(2 * np.pi * 7 * t))
    path = tmp_path / "arduino.csv"
    path.write_text("Quantisation level,Time\n" + "".join(f"{int(c)},{x:.4f}\n" for c, x in zip(counts, t)))
    _read(session, path.name, path.read_bytes())
    assert r.stage == "error" and "arbitrary units of acceleration, velocity, displacement or strain" in r.error
    _page_words(r.error)
    r.signal_unit = "arbitrary-acceleration"
    assert session.wait(60) and r.stage == "read"
    np.testing.assert_array_equal(r.read.record.output, counts)
    unit = next(text for title, text, _ in r.read.summary()["findings"] if title == "Unit")
    assert unit.startswith("arbitrary units of acceleration: your choice under Reading options; arbitrary units")
    r.param.update(**STRIP)
    assert session.wait(60) and r.described is not None
    assert r.described.measurement.arbitrary_units and r.described.measurement.output_unit == "a.u."
