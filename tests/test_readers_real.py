"""A real record in every format, and the real runs calibrated from geometry alone.

``assets/real/formats`` holds the first 1.5 s of the bundled real run ``adxl_50cm_114655``
re-saved in each format (:func:`tests.record_files.write_real_formats`, MIT-licensed source,
see ``assets/real/README.md``). Each must read back to the project's CSV of that run within
the precision the format prints.

The done-when check of reading real records: a run re-saved as a phyphox export and as
LabVIEW's headerless text, read with only length, width, thickness, material and the sensor's
position (no nominal stiffness), is calibrated (MAP) with mode 1 within 0.5 % of the record's
own spectral peak, estimated independently of the reader's anchor (a zero-padded periodogram
of the calibration window). The shared runs, when present, are checked the same way and with
their sidecar's ``[nominal]`` removed.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from beam.io.bundled import ASSETS
from beam.io.measurement import read_measurement
from beam.io.readers import read_record
from tests.record_files import REAL_EXCERPT_S, REAL_SOURCE, write_headerless_lvm, write_phyphox_csv

FORMATS_DIR = ASSETS / "real" / "formats"
SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "real-data"  # ../shared beside the clone
G = 9.80665
#: The rig's description, in a student's words (assets/real/README.md).
STRIP = {"beam": {"length_m": 0.5, "width_m": 0.05, "thickness_m": 0.002, "material": "aluminium"},
         "sensor": {"position_m": 0.44}}


def _source():
    table = np.loadtxt(ASSETS / "real" / f"{REAL_SOURCE}.csv", delimiter=",", skiprows=1)
    return table[table[:, 0] < REAL_EXCERPT_S]


@pytest.mark.parametrize("name, options, tolerance", [
    (f"{REAL_SOURCE}.phyphox.csv", {}, 1e-9),  # ten significant digits (relative)
    (f"{REAL_SOURCE}.physics_toolbox.csv", {}, 0.5e-6 * G),  # six decimals of g
    (f"{REAL_SOURCE}.lvm", {}, 0.5e-6 * G),
    (f"{REAL_SOURCE}.headerless.lvm", {"unit": "m/s^2"}, 0.5e-6),
    (f"{REAL_SOURCE}.tdms", {}, 1e-12),
    (f"{REAL_SOURCE}.npy", {"unit": "m/s^2"}, 0.0),
    (f"{REAL_SOURCE}.npz", {}, 0.0),
    (f"{REAL_SOURCE}.mat", {}, 1e-12),
    (f"{REAL_SOURCE}.v73.mat", {}, 0.0),
])
def test_the_real_record_reads_back_in_every_format(name, options, tolerance):
    source = _source()
    record = read_record(FORMATS_DIR / name, **options)
    assert record.output_column == "acceleration_m_s2"
    assert record.time_s.size == source.shape[0]
    assert record.segments == []  # one pluck
    np.testing.assert_allclose(record.time_s, source[:, 0] - source[0, 0], rtol=0, atol=1e-9)
    if tolerance == 1e-9:
        np.testing.assert_allclose(record.output, source[:, 1], rtol=tolerance, atol=1e-12)
    else:
        np.testing.assert_allclose(record.output, source[:, 1], rtol=1e-12, atol=tolerance * 1.0001)


def window_peak_Hz(time_s: np.ndarray, values: np.ndarray, window: tuple[float, float], low_Hz: float = 2.0,
                   high_Hz: float = 20.0) -> float:
    """The peak of a zero-padded (x16) Hann periodogram of the window, interpolated on a uniform
    grid at the median step: an estimate independent of the reader's Welch-based anchor."""
    inside = (time_s >= window[0]) & (time_s <= window[1])
    t, y = time_s[inside], values[inside]
    step = float(np.median(np.diff(t)))
    grid = np.arange(t[0], t[-1], step)
    signal = np.interp(grid, t, y)
    signal = (signal - signal.mean()) * np.hanning(signal.size)
    size = 16 * signal.size
    spectrum = np.abs(np.fft.rfft(signal, size))
    frequency = np.fft.rfftfreq(size, step)
    band = (frequency >= low_Hz) & (frequency <= high_Hz)
    return float(frequency[band][np.argmax(spectrum[band])])


def mode1_at_map(measurement) -> tuple[float, tuple[float, float]]:
    """Mode 1 (Hz) of the model at the MAP of a preview calibration, and the window."""
    from beam.calibration import calibration_preview

    result = calibration_preview(measurement, modes="auto")
    values = {name: float(v) for name, v in result.laplace.map.values.items() if name in result.setup.physical_names}
    frequencies, _ = result.setup.model.natural_modes(values, 1)
    return float(frequencies[0]), tuple(result.setup.window)


def _resave(source_csv: Path, folder: Path, kind: str) -> tuple[Path, dict]:
    table = np.loadtxt(source_csv, delimiter=",", skiprows=1)
    t, a = table[:, 0], table[:, 1]
    if kind == "phyphox":
        return write_phyphox_csv(folder / "Raw Data.csv", t, {"z": a}, ";", ",", with_g=True), {}
    return write_headerless_lvm(folder / "run.lvm", t, a / G), {"unit": "g"}


def _check_mode1(path: Path, options: dict, beam):
    measurement = read_measurement(path, beam=beam, **options)
    assert "bending_stiffness_Nm2" in measurement.nominal_origin  # not given: derived or anchored
    mode1, window = mode1_at_map(measurement)
    peak = window_peak_Hz(measurement.time_s, measurement.output, window)
    assert mode1 == pytest.approx(peak, rel=5e-3), (path.name, mode1, peak)


@pytest.mark.parametrize("kind", ["phyphox", "headerless-lvm"])
def test_a_bundled_real_run_resaved_calibrates_mode_1_on_its_peak_from_geometry_alone(tmp_path, kind):
    path, options = _resave(ASSETS / "real" / f"{REAL_SOURCE}.csv", tmp_path, kind)
    _check_mode1(path, options, STRIP)


SHARED_RUNS = sorted(SHARED.glob("adxl_50cm_*.csv")) if SHARED.is_dir() else []


@pytest.mark.slow
@pytest.mark.skipif(not SHARED_RUNS, reason="the shared development runs are not on this machine")
@pytest.mark.parametrize("run", [p.stem for p in SHARED_RUNS])
@pytest.mark.parametrize("kind", ["phyphox", "headerless-lvm", "no-nominal"])
def test_shared_runs_put_mode_1_on_their_peak_without_a_nominal(tmp_path, run, kind):
    source = SHARED / f"{run}.csv"
    if kind == "no-nominal":  # the project's own files, [nominal] removed: the anchor on the lowest peak
        sidecar = (SHARED / f"{run}.toml").read_text()
        (tmp_path / f"{run}.csv").write_bytes(source.read_bytes())
        (tmp_path / f"{run}.toml").write_text(sidecar.split("[nominal]")[0])
        measurement = read_measurement(tmp_path / f"{run}.csv")
        assert "lowest strong spectral peak" in measurement.nominal_origin["bending_stiffness_Nm2"]
        mode1, window = mode1_at_map(measurement)
        assert mode1 == pytest.approx(window_peak_Hz(measurement.time_s, measurement.output, window), rel=5e-3)
        return
    path, options = _resave(source, tmp_path, kind)
    _check_mode1(path, options, STRIP)
