"""Caps on what is read and calibrated, and decimation of over-long records (:mod:`beam.io.limits`)."""

from __future__ import annotations

import numpy as np
import pytest
from simulated_data import GEOMETRY, TRUE_BASE

from beam.calibration.records import (
    check_calibration_record,
    decimate_displacement,
    decimate_measurement,
    decimate_voltage,
    decimation_factor,
)
from beam.errors import BeamInputError
from beam.io.limits import (
    MAX_CALIBRATION_SAMPLES,
    MAX_MEASUREMENT_BYTES,
    MAX_TOML_BYTES,
)
from beam.io.measurement import Measurement, read_measurement, write_measurement
from beam.io.text import load_toml, read_text_file
from beam.physics.excitation import Excitation
from beam.physics.geometry import BeamGeometry
from beam.physics.model import BeamModel

SIDECAR = "[beam]\nlength_m = 0.4573\nlinear_density_kg_m = 0.093\n[patch]\nstart_m = 0.15\nend_m = 0.25\n" \
          "[sensor]\nposition_m = 0.27438\n"


# ---------------------------------------------------------------------------------------------
# file size caps
# ---------------------------------------------------------------------------------------------


def test_the_caps_are_what_the_readme_says():
    assert MAX_MEASUREMENT_BYTES == 64 * 2**20 and MAX_TOML_BYTES == 2**20 and MAX_CALIBRATION_SAMPLES == 20_000


def test_a_measurement_larger_than_the_cap_is_refused_before_parsing(tmp_path):
    path = tmp_path / "huge.csv"
    with path.open("wb") as stream:  # sparse: no time spent writing
        stream.write(b"time_s,voltage_V,displacement_m\n")
        stream.truncate(MAX_MEASUREMENT_BYTES + 1)
    (tmp_path / "huge.toml").write_text(SIDECAR)
    with pytest.raises(BeamInputError, match=r"huge.csv: larger than the 64 MiB allowed for a measurement CSV"):
        read_measurement(path)


def test_a_file_exactly_at_the_cap_is_read(tmp_path):
    path = tmp_path / "edge.txt"
    path.write_bytes(b"x" * 1000)
    assert read_text_file(path, max_bytes=1000) == "x" * 1000
    with pytest.raises(BeamInputError, match="larger than the 999 bytes"):
        read_text_file(path, max_bytes=999)


def test_a_toml_larger_than_its_cap_is_refused(tmp_path):
    path = tmp_path / "run.toml"
    path.write_text(SIDECAR + "# padding\n" * (MAX_TOML_BYTES // 10))
    with pytest.raises(BeamInputError, match="larger than the 1 MiB allowed for a sidecar"):
        load_toml(path, "sidecar")


def test_a_file_read_back_would_refuse_is_not_written(tmp_path, monkeypatch):
    """What write_measurement writes, read_measurement reads: a record over the cap is refused up front."""
    import beam.io.measurement

    monkeypatch.setattr(beam.io.measurement, "MAX_MEASUREMENT_BYTES", 2**20)
    n = 30_000  # ~1.5 MiB at full precision
    time_s = np.arange(n) / 1000.0
    with pytest.raises(BeamInputError, match=r"30,000 samples make 1.3 MiB of CSV, more than the 1 MiB"):
        write_measurement(tmp_path / "big", (time_s, np.sin(time_s), np.cos(time_s)), geometry=GEOMETRY)
    assert list(tmp_path.iterdir()) == []


def test_a_long_file_under_the_cap_reads(tmp_path):
    n = 200_000
    time_s = np.arange(n) / 10_000.0
    written = write_measurement(tmp_path / "long", (time_s, np.sin(time_s), 1e-4 * np.cos(time_s)), geometry=GEOMETRY)
    assert written.csv_path.stat().st_size < MAX_MEASUREMENT_BYTES
    assert read_measurement(written.csv_path).sample_count == n


# ---------------------------------------------------------------------------------------------
# decimation: factor, anti-aliasing, voltage consistent with the zero-order hold
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("n, cap, factor", [(10, 20_000, 1), (20_000, 20_000, 1), (20_001, 20_000, 2),
                                            (1_000_000, 20_000, 50), (1_000_001, 20_000, 51), (7, 2, 4)])
def test_decimation_factor(n, cap, factor):
    assert decimation_factor(n, cap) == factor
    assert -(-n // factor) <= cap


@pytest.mark.parametrize("cap", [0, 1, 2.5, True, -3])
def test_decimation_cap_must_be_an_integer_of_at_least_two(cap):
    with pytest.raises(BeamInputError, match="max_samples"):
        decimation_factor(100, cap)


def _tone(frequency: float, rate: float, n: int) -> np.ndarray:
    return np.sin(2 * np.pi * frequency * np.arange(n) / rate + 0.3)  # the phase: not sampled at its zeros


def _amplitude(signal: np.ndarray, frequency: float, rate: float) -> float:
    """Amplitude of the component at ``frequency`` (least squares on sin and cos, edges dropped)."""
    core = slice(200, signal.size - 200)
    t = np.arange(signal.size)[core] / rate
    basis = np.column_stack([np.sin(2 * np.pi * frequency * t), np.cos(2 * np.pi * frequency * t)])
    coefficients, *_ = np.linalg.lstsq(basis, signal[core], rcond=None)
    return float(np.hypot(*coefficients))


@pytest.mark.parametrize("factor", [2, 4, 13, 50])
def test_a_tone_above_the_new_nyquist_is_attenuated_by_more_than_40_db(factor):
    rate, n = 1000.0 * factor, 4000 * factor
    new_nyquist = 500.0
    for ratio in (1.0, 1.1, 1.5, 1.9):  # the alias lands at (2 - ratio) x the new Nyquist frequency
        decimated = decimate_displacement(_tone(ratio * new_nyquist, rate, n), factor)
        alias = (2 - ratio) * new_nyquist
        if ratio == 1.0:
            level = np.sqrt(2 * np.mean(decimated[200:-200] ** 2))  # at Nyquist the alias is itself
        else:
            level = _amplitude(decimated, alias, 1000.0)
        assert 20 * np.log10(level) < -40, (factor, ratio, level)
        voltage = decimate_voltage(_tone(ratio * new_nyquist, rate, n), factor)
        assert 20 * np.log10(np.sqrt(2 * np.mean(voltage[200:-200] ** 2))) < -40, (factor, ratio)


@pytest.mark.parametrize("factor", [2, 4, 13, 50])
def test_in_band_content_is_kept_within_one_percent(factor):
    rate, n = 1000.0 * factor, 4000 * factor
    for frequency in (5.0, 100.0, 300.0, 400.0):  # up to 0.8 x the new Nyquist frequency
        tone = _tone(frequency, rate, n)
        decimated = decimate_displacement(tone, factor)
        assert decimated.size == -(-n // factor)
        np.testing.assert_allclose(decimated[200:-200], tone[::factor][200:-200], atol=0.01)
        # the held voltage: the block means of the tone itself (the filter leaves the band alone)
        plain_means = np.add.reduceat(tone, np.arange(0, n, factor)) / factor
        np.testing.assert_allclose(decimate_voltage(tone, factor)[200:-200], plain_means[200:-200], atol=0.01)


def test_no_edge_transient_from_an_offset_or_a_record_ending_mid_oscillation():
    rate, factor = 4000.0, 4
    t = np.arange(4000) / rate
    signal = 1e-3 + 2e-4 * np.sin(2 * np.pi * 37.0 * t + 0.3)  # sensor offset, ends mid-cycle
    decimated = decimate_displacement(signal, factor)
    np.testing.assert_allclose(decimated, signal[::factor], atol=2e-4 * 0.005)  # 0.5 % of the amplitude
    held = decimate_voltage(np.full(4001, 5.0), factor)
    np.testing.assert_allclose(held, 5.0, rtol=1e-12)  # a constant voltage stays exactly constant
    assert held.size == 1001  # the last, one-sample block is averaged over what it holds


MODEL = BeamModel(GEOMETRY, ("air_damping", "kelvin_voigt"))


def _relative_model_error(voltage: np.ndarray, rate: float, factor: int, pick: bool = False) -> float:
    """RMS(model(decimated V) - decimated true response) / RMS(response), 4 modes."""
    response = MODEL.response(TRUE_BASE, voltage, 1 / rate)
    target = decimate_displacement(response, factor)
    held = voltage[::factor] if pick else decimate_voltage(voltage, factor)
    predicted = MODEL.response(TRUE_BASE, held, factor / rate)
    return float(np.sqrt(np.mean((predicted - target) ** 2)) / np.sqrt(np.mean(target**2)))


@pytest.mark.parametrize("excitation, chosen, picked", [
    (Excitation("chirp", amplitude_V=10, start_Hz=2, stop_Hz=250, duration_s=1.5), 0.012, 0.07),
    (Excitation("pulse", amplitude_V=10, width_s=0.00525), 0.006, 0.12),
])
def test_block_mean_voltage_keeps_the_model_response(excitation, chosen, picked):
    """Simulated at 4 kHz, decimated by 4: the documented errors (1.0 % / 0.4 % vs 8.4 % / 14.9 %)."""
    rate, factor = 4000.0, 4
    voltage = excitation.voltage(np.arange(16000) / rate)
    assert _relative_model_error(voltage, rate, factor) < chosen
    assert _relative_model_error(voltage, rate, factor, pick=True) > picked


def test_decimate_measurement(tmp_path):
    n = 100_003
    t = 3.25 + np.arange(n) / 20_000.0
    voltage = Excitation("chirp", amplitude_V=10, start_Hz=2, stop_Hz=130, duration_s=1.0).voltage(t - 3.25)
    displacement = MODEL.response(TRUE_BASE, voltage, 1 / 20_000.0)
    record = write_measurement(tmp_path / "fast", (t, voltage, displacement), geometry=GEOMETRY,
                               nominal={"bending_stiffness_Nm2": 0.5})
    same, factor = decimate_measurement(record, n)
    assert same is record and factor == 1
    small, factor = decimate_measurement(record)
    assert factor == 6 and small.sample_count == -(-n // 6) <= MAX_CALIBRATION_SAMPLES
    assert small.time_s.tobytes() == t[::6].tobytes()
    assert small.rate_Hz == pytest.approx(20_000.0 / 6, rel=1e-9)
    assert (small.name, small.title, small.geometry, small.nominal) == (record.name, record.title, record.geometry,
                                                                        record.nominal)
    assert np.all(np.isfinite(small.voltage_V)) and np.all(np.isfinite(small.displacement_m))
    error = np.max(np.abs(small.displacement_m - displacement[::6])) / np.max(np.abs(displacement))
    assert error < 0.01
    rewritten = write_measurement(tmp_path / "small", small)
    assert read_measurement(rewritten.csv_path).displacement_m.tobytes() == small.displacement_m.tobytes()


@pytest.mark.parametrize("n, cap", [(3, 2), (7, 2), (50, 3), (1001, 2), (161, 5)])
def test_tiny_records_shorter_than_the_filter_decimate_to_finite_values(n, cap):
    rng = np.random.default_rng(n)
    record = Measurement("tiny", "tiny", GEOMETRY, np.arange(n) * 1e-3, rng.normal(size=n), rng.normal(size=n))
    small, factor = decimate_measurement(record, cap)
    assert small.sample_count <= cap and factor == decimation_factor(n, cap)
    assert np.all(np.isfinite(small.voltage_V)) and np.all(np.isfinite(small.displacement_m))


# ---------------------------------------------------------------------------------------------
# records the calibration cannot learn from
# ---------------------------------------------------------------------------------------------


def _record(voltage: np.ndarray | float = None, displacement: np.ndarray | float = None) -> Measurement:
    t = np.arange(1000) / 1000.0
    v = np.where(t < 0.05, 5.0, 0.0) if voltage is None else np.broadcast_to(voltage, t.shape)
    d = 1e-4 * np.sin(2 * np.pi * 6 * t) if displacement is None else np.broadcast_to(displacement, t.shape)
    return Measurement("rec", "rec", GEOMETRY, t, v, d)


@pytest.mark.parametrize("record, window, fragment", [
    (_record(voltage=0.0), None, "voltage_V is zero up to the end of the window"),
    (_record(voltage=np.where(np.arange(1000) > 600, 1.0, 0.0)), (0.0, 0.5), "never driven"),
    (_record(voltage=2e4), None, "is the column in volts?"),
    (_record(voltage=1e300), None, "above the 10000 V"),
    (_record(displacement=0.0), None, "displacement_m varies by 0 m"),
    (_record(displacement=3e-3), None, "no motion was recorded"),
    (_record(displacement=1e-300 * np.arange(1000)), None, "no motion was recorded"),
    (_record(displacement=1e300 * np.sin(np.arange(1000))), None, "is the column in metres?"),
    (_record(displacement=np.where(np.arange(1000) < 500, 0.0, 1e-4)), (0.0, 0.4), "no motion"),
])
def test_degenerate_records_are_refused_with_one_line(record, window, fragment):
    with pytest.raises(BeamInputError) as info:
        check_calibration_record(record, window)
    assert fragment in str(info.value) and "\n" not in str(info.value)
    assert str(info.value).startswith("measurement rec: ")


@pytest.mark.parametrize("record", [_record(), _record(voltage=5.0), _record(voltage=-1e4)])
def test_ordinary_records_pass_the_check(record):
    check_calibration_record(record)
    check_calibration_record(record, (0.1, 0.6))


# ---------------------------------------------------------------------------------------------
# the other kinds of record
# ---------------------------------------------------------------------------------------------

BARE = BeamGeometry(0.5, 0.27, None, None, 0.44, 0.5)


def test_an_irregular_forced_record_decimates_without_a_filter():
    """Irregular stamps: the output is subsampled as it is (the model evaluates it at the kept
    stamps), the held force becomes its time-weighted block mean, which keeps its impulse."""
    rng = np.random.default_rng(2)
    n = 1003
    t = np.concatenate([[0.0], np.cumsum(rng.uniform(0.2e-3, 0.3e-3, n - 1))])
    force = rng.normal(size=n)
    acceleration = np.sin(2 * np.pi * 6.05 * t) * 7.0
    record = Measurement("f", "f", BARE, t, force_N=force, acceleration_m_s2=acceleration)
    decimated, factor = decimate_measurement(record, max_samples=250)
    assert factor == 5 and not record.uniform
    np.testing.assert_array_equal(decimated.time_s, t[::5])
    np.testing.assert_array_equal(decimated.acceleration_m_s2, acceleration[::5])
    steps = np.append(np.diff(t), np.median(np.diff(t)))
    coarse = np.append(np.diff(t[::5]), steps[-(n % 5 or 5):].sum())  # the last block holds what is left
    impulse = np.add.reduceat(force * steps, np.arange(0, n, 5))
    np.testing.assert_allclose(decimated.force_N * coarse, impulse, rtol=1e-12)
    assert decimated.input_kind == "force" and decimated.output_kind == "acceleration"


def test_a_uniform_free_record_decimates_its_output_through_the_filter():
    t = np.arange(4000) / 4000.0
    acceleration = np.exp(-t) * np.sin(2 * np.pi * 6.05 * t)
    record = Measurement("a", "a", BARE, t, acceleration_m_s2=acceleration)
    decimated, factor = decimate_measurement(record, max_samples=1000)
    assert factor == 4 and decimated.is_free and decimated.input is None
    np.testing.assert_array_equal(decimated.acceleration_m_s2, decimate_displacement(acceleration, 4))


def test_the_record_check_for_the_other_kinds():
    t = np.arange(100) / 1000.0
    check_calibration_record(Measurement("free", "free", BARE, t, acceleration_m_s2=np.sin(40 * t)))
    with pytest.raises(BeamInputError, match="acceleration_m_s2 is constant in the window"):
        check_calibration_record(Measurement("flat", "flat", BARE, t, acceleration_m_s2=np.full(100, 0.44)))
    with pytest.raises(BeamInputError, match="force_N is zero up to the end of the window"):
        check_calibration_record(Measurement("idle", "idle", BARE, t, force_N=np.zeros(100), velocity_m_s=np.sin(40 * t)))
    check_calibration_record(Measurement("hit", "hit", BARE, t, force_N=np.where(t < 0.01, 1.0, 0.0),
                                         velocity_m_s=np.sin(40 * t)))
