"""The "Your record" flow without a browser: reading any file, the form, the spectrum, the hand-over.

The record is ``assets/real/formats/adxl_50cm_114655.phyphox.csv`` (a real aluminium strip's
record by Enes Demirkaya, MIT licence, re-saved by this project as a phyphox export).
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import panel as pn
import pytest
from bokeh.document import Document
from bokeh.models import ColumnDataSource

from beam.io.anchor import closed_form_mode1_Hz
from beam.io.materials import MATERIALS
from beam.io.measurement import read_measurement
from beam.errors import BeamInputError
from dashboard.jobs.record import read_upload, reduce_spectrum
from dashboard.views.record import RecordView

REPO = Path(__file__).resolve().parents[2]
PHYPHOX = REPO / "assets" / "real" / "formats" / "adxl_50cm_114655.phyphox.csv"
STRIP = {"length_m": 0.5, "width_m": 0.05, "thickness_m": 0.002, "material": "aluminium", "sensor_position_m": 0.44}


def _phyphox_time_s() -> np.ndarray:
    rows = PHYPHOX.read_text().splitlines()[1:]
    return np.array([float(r.split(";")[0].replace(",", ".")) for r in rows])


def test_reduce_spectrum_keeps_every_peak_in_log_spaced_spans():
    f = np.linspace(0.0, 2000.0, 200_001)
    density = 1e-6 / (1 + f) + 1e-2 * np.exp(-0.5 * ((f - 437.21) / 0.02) ** 2)  # a peak 4 bins wide
    low, high = 1.0, 1900.0
    g, db = reduce_spectrum(f, density, low, high, points=500)
    assert 100 < g.size <= 500
    assert np.all(np.diff(g) > 0) and g[0] >= low and g[-1] <= high
    top = int(np.argmax(db))
    inside = (f >= low) & (f <= high)
    assert g[top] == f[inside][np.argmax(density[inside])]
    assert db[top] == pytest.approx(10 * np.log10(density[inside].max()))


def test_read_upload_reads_a_phyphox_export_and_names_a_bad_file():
    read = read_upload("Raw Data.csv", PHYPHOX.read_bytes())
    time_s = _phyphox_time_s()
    assert read.record.output_column == "acceleration_m_s2" and read.signal_unit == "m/s²"
    assert read.record.rate_Hz == pytest.approx(1 / np.median(np.diff(time_s)), rel=1e-9)
    assert read.record.duration_s == pytest.approx(time_s[-1] - time_s[0], abs=1e-9)
    assert read.summary()["file"] == "Raw Data.csv" and "Acceleration z" in read.summary()["signal"]
    assert 100 < read.frequency_Hz.size and read.peaks
    with pytest.raises(BeamInputError, match=r"^notes\.txt: ") as refused:
        read_upload("notes.txt", "my beam was plucked twice\n")
    assert "beam-record-" not in str(refused.value)  # never the temporary folder
    with pytest.raises(BeamInputError, match="empty file"):
        read_upload("empty.csv", b"")


def test_the_form_describes_the_record_and_hands_it_to_the_beam_calibration(session, tmp_path):
    r = session.record
    r.upload("Raw Data.csv", PHYPHOX.read_bytes())
    assert session.wait(60) and r.stage == "read" and r.read.file_name == "Raw Data.csv"
    assert r.described is None and len(r.missing()) == 5 and not r.can_load()
    r.param.update(**STRIP)
    assert session.wait(60) and r.form_error == "" and r.described is not None
    aluminium = MATERIALS["aluminium"]
    b, h = STRIP["width_m"], STRIP["thickness_m"]
    expected = closed_form_mode1_Hz(STRIP["length_m"], aluminium.density_kg_m3 * b * h, aluminium.youngs_modulus_Pa * b * h**3 / 12)
    assert r.described.modes_Hz[0] == pytest.approx(expected, rel=2e-3)
    assert "record peak (Hz)" in r.described.summary

    # the sidecar offered for the CLI reads the same record into the same measurement
    (tmp_path / "Raw Data.csv").write_bytes(PHYPHOX.read_bytes())
    assert r.sidecar_name() == "Raw Data.toml"
    (tmp_path / r.sidecar_name()).write_text(r.sidecar_text())
    assert tomllib.loads(r.sidecar_text())["beam"]["material"] == "aluminium"
    cli = read_measurement(tmp_path / "Raw Data.csv")
    shown = r.described.measurement
    assert cli.geometry == shown.geometry and cli.nominal == shown.nominal
    np.testing.assert_array_equal(cli.output, shown.output)

    # a sensor beyond the tip: a readable message, nothing to load
    r.sensor_position_m = 0.7
    assert session.wait(60) and r.described is None and "0.7" in r.form_error and not r.can_load()
    r.sensor_position_m = 0.44
    assert session.wait(60) and r.described is not None and r.can_load()

    # a bad file keeps the record
    r.upload("notes.txt", b"my beam was plucked twice\n")
    assert session.wait(60) and r.stage == "error" and r.error.startswith("notes.txt")
    assert r.read.file_name == "Raw Data.csv" and r.described is not None

    name = r.load()
    assert name == "upload-1-Raw Data" and session.beam.dataset == name
    assert session.beam.measurement is r.described.measurement
    assert r.load() == name and len(session.beam.uploads) == 1  # loading twice adds nothing


def test_the_view_draws_the_beam_the_spectrum_and_the_modes(session):
    view = RecordView(session=session)
    view.build()
    root = view.__panel__().get_root(Document())
    labels = [w.label for w in view.__panel__().select(pn.widgets.Widget) if getattr(w, "label", None)]
    for label in ("Free length, clamp edge to tip (m)", "Width (m)", "Thickness (m)",
                  "Sensor position (m from the clamp)", "Sensor mass (kg; empty if negligible)"):
        assert label in labels
    assert any(label.startswith("Material") for label in labels)

    def source(name):
        (found,) = [m for m in root.select({"type": ColumnDataSource}) if m.name == name]
        return found.data

    r = session.record
    r.upload("Raw Data.csv", PHYPHOX.read_bytes())
    assert session.wait(60)
    assert len(source("record-spectrum")["frequency_Hz"]) == r.read.frequency_Hz.size
    assert len(source("record-modes")["frequency_Hz"]) == 0
    r.param.update(**STRIP)
    assert session.wait(60)
    assert list(source("record-modes")["frequency_Hz"]) == list(r.described.modes_Hz)
    assert list(source("record-sensor")["x"]) == [0.44]
    assert list(source("record-beam")["right"]) == [0.5]


def test_a_file_that_does_not_say_its_unit_is_read_once_the_option_is_given(session):
    r = session.record
    npy = PHYPHOX.with_name("adxl_50cm_114655.npy")  # time (s) and the acceleration (m/s²), no names
    r.upload(npy.name, npy.read_bytes())
    assert session.wait(60) and r.stage == "error" and r.read is None
    assert "unit under Reading options" in r.error and "--unit" not in r.error
    r.signal_unit = "m/s^2"
    assert session.wait(60) and r.stage == "read" and r.read.file_name == npy.name
    table = np.load(npy)
    np.testing.assert_array_equal(r.read.record.output, table[:, 1])
    r.signal_unit = "g"
    assert session.wait(60) and r.stage == "read"
    np.testing.assert_allclose(r.read.record.output, table[:, 1] * 9.80665, rtol=1e-12)
    assert r.read.record.rate_Hz == pytest.approx(1 / np.median(np.diff(table[:, 0])), rel=1e-9)
