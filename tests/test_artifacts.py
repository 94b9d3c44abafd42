"""Artifacts real labs record (beam.io.artifacts), checked on records made with the project's simulator
(tests/artifact_records.py) with the artifact injected, against the artifact's own truth:

* mains hum at 50 and 60 Hz with harmonics (off the nominal by a grid's drift) is found at the
  injected frequencies (within a bin 1 / T), subtracted to a hundredth of its size, and no longer
  among the record's spectral peaks, its identified modes or its anchor; a beam mode at 60 Hz
  with no hum stays a mode; a driven record's 60 Hz drive is not hum;
* spikes (single samples, a two-sample glitch) are flagged exactly, interpolated, and left out of
  the likelihood; clean records (simulated, bundled) have none;
* a saturated converter's rail values are flagged exactly;
* a calibration says all of it in its warnings.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from beam.calibration import calibration_preview
from beam.io.anchor import lowest_strong_peak, spectral_peaks
from beam.io.artifacts import clean, find_hum, find_spikes, rail_samples
from beam.io.bundled import ASSETS
from beam.io.measurement import read_measurement
from beam.physics.geometry import BeamGeometry
from beam.physics.model import BeamModel
from beam.residuals import identify_modes
from tests.artifact_records import (
    STRIP, STRIP_DESCRIPTION, STRIP_DENSITY, STRIP_TRUTH, mains_hum, plucked_strip, tapped_bar, write_table,
)

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "real-data"


@pytest.mark.parametrize("mains, harmonics, amplitudes", [
    (60.0, (1, 2, 3), (0.15, 0.05, 0.04)),
    (50.0, (1, 3, 5), (0.2, 0.06, 0.03)),
    (60.0, (6, 7, 11), (0.05, 0.04, 0.03)),  # a rectifier's harmonics without the fundamental
])
def test_hum_is_found_subtracted_and_never_taken_for_a_mode(mains, harmonics, amplitudes):
    t, y, clean_signal = plucked_strip(duration_s=4.0, rate_Hz=2000.0)
    hum = mains_hum(mains, harmonics, amplitudes)
    raw = y + hum.evaluate(t)
    found = find_hum(t, raw)
    assert found is not None and found.mains_Hz == mains
    span = t[-1] - t[0]
    assert len(found.lines) == len(hum.lines_Hz)
    for line, f, a in zip(found.lines, hum.lines_Hz, amplitudes):
        assert abs(line.frequency_Hz - f) <= 1 / span
        assert line.amplitude == pytest.approx(a, rel=0.05)
    cleaned, artifacts = clean(t, raw)
    assert artifacts.hum is not None and artifacts.spike_count == 0 and artifacts.rail_count == 0
    # what is left of the hum: a hundredth of it, plus twice the error the noise (sd 0.02) leaves in a
    # Hann-weighted least-squares fit of L lines on N samples: sqrt(3 L / N) sd
    left = cleaned - y
    floor = np.sqrt(3 * len(found.lines) / t.size) * 0.02
    assert np.sqrt(np.mean(left**2)) <= 0.01 * np.sqrt(np.mean(hum.evaluate(t) ** 2)) + 2 * floor
    # no spectral peak, identified mode or anchor at a hum line
    for peaks in (spectral_peaks(t, cleaned, "acceleration", max_peaks=8),):
        for f in hum.lines_Hz:
            assert all(abs(p.frequency_Hz - f) > 1.0 for p in peaks)
    modes = identify_modes(t, cleaned - np.median(cleaned), start_s=0.0)
    for f in hum.lines_Hz:
        assert np.all(np.abs(modes.frequency_Hz - f) > 1.0)
    model_f1 = BeamModel(STRIP, ("air_damping", "kelvin_voigt"), input_kind=None).natural_modes(STRIP_TRUTH, 1)[0][0]
    assert lowest_strong_peak(t, cleaned, "acceleration").frequency_Hz == pytest.approx(model_f1, rel=0.01)


def test_without_the_subtraction_the_hum_is_a_peak_and_a_mode():
    """The reference: the same record with the hum left in shows it where the test above finds none."""
    t, y, _ = plucked_strip(duration_s=4.0, rate_Hz=2000.0)
    hum = mains_hum(60.0, (1, 2, 3), (0.15, 0.05, 0.04))
    raw = y + hum.evaluate(t)
    peaks = spectral_peaks(t, raw, "acceleration", max_peaks=8)
    assert any(abs(p.frequency_Hz - hum.lines_Hz[0]) < 0.5 for p in peaks)
    modes = identify_modes(t, raw - np.median(raw), start_s=0.0)
    assert np.any(np.abs(modes.frequency_Hz - hum.lines_Hz[1]) < 0.5)


def test_a_beam_mode_at_60_hz_without_hum_stays_a_mode():
    """A strip whose mode 1 sits at 60.0 Hz (L from f ~ 1/L², about 0.165 m), released: its decay is no hum."""
    base = BeamModel(STRIP, ("air_damping", "kelvin_voigt"), input_kind=None).natural_modes(STRIP_TRUTH, 1)[0][0]
    length = STRIP.length_m * np.sqrt(base / 60.0)
    geometry = BeamGeometry(length, STRIP_DENSITY, None, None, length - 0.01)
    model = BeamModel(geometry, ("air_damping", "kelvin_voigt"), input_kind=None)
    f1 = model.natural_modes(STRIP_TRUTH, 1)[0][0]
    assert f1 == pytest.approx(60.0, abs=0.05)
    t = np.arange(8000) / 2000.0
    y = model.free_response(STRIP_TRUTH, t, [1.0, 0.0], [0.0, 0.0], modes=2, output="acceleration")
    y = 20 * y / np.abs(y).max() + 0.02 * np.random.default_rng(4).standard_normal(t.size)
    assert find_hum(t, y) is None
    cleaned, artifacts = clean(t, y)
    assert artifacts.hum is None
    np.testing.assert_array_equal(cleaned, y)
    assert lowest_strong_peak(t, cleaned, "acceleration").frequency_Hz == pytest.approx(f1, abs=0.1)


def test_hum_on_irregular_stamps_is_found_at_the_stamps():
    """A logger's stamps as the shared runs have them (steps ±5 %, a stall of 20 steps now and then):
    the lines are measured at the samples' own times."""
    rng = np.random.default_rng(8)
    steps = rng.uniform(0.95, 1.05, 6000)
    steps[rng.choice(6000, 6, replace=False)] = 20.0
    t = np.cumsum(steps) / 1500.0
    model = BeamModel(STRIP, ("air_damping", "kelvin_voigt"), input_kind=None)
    y = model.free_response(STRIP_TRUTH, t - t[0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0], modes=3, output="acceleration")
    y = 20 * y / np.abs(y).max() + 0.02 * rng.standard_normal(t.size)
    hum = mains_hum(50.0, (1, 2), (0.3, 0.15))  # the stalls spread the swing's power: lines above that
    found = find_hum(t, y + hum.evaluate(t))
    assert found is not None and [line.harmonic for line in found.lines] == [1, 2]
    for line, f in zip(found.lines, hum.lines_Hz):
        assert abs(line.frequency_Hz - f) <= 1 / (t[-1] - t[0])


def test_a_drive_at_60_hz_is_no_hum():
    """A driven record's steady response to a 60 Hz input is constant too: the input holds the line."""
    geometry = BeamGeometry(0.3, STRIP_DENSITY, None, None, 0.29, force_position_m=0.3)
    model = BeamModel(geometry, ("air_damping", "kelvin_voigt"), input_kind="force")
    t = np.arange(8000) / 2000.0
    force = 0.05 * np.sin(2 * np.pi * 60.0 * t) + 0.02 * np.sin(2 * np.pi * 120.0 * t)
    y = model.response(STRIP_TRUTH, force, 1 / 2000.0, None, output="acceleration")
    y = y + 1e-3 * np.abs(y).max() * np.random.default_rng(2).standard_normal(t.size)
    assert find_hum(t, y, force) is None


def test_spikes_are_flagged_exactly_and_interpolated():
    t, y, _ = plucked_strip(duration_s=6.0, rate_Hz=1000.0)
    rng = np.random.default_rng(11)
    index = np.sort(rng.choice(np.arange(200, t.size - 200), 12, replace=False))
    raw = y.copy()
    raw[index] += rng.choice([-1, 1], index.size) * rng.uniform(0.3, 10.0, index.size)  # 15x the noise to half the swing
    raw[3000:3002] += 0.8  # a two-sample glitch
    spikes, repaired = find_spikes(t, raw)
    truth = np.zeros(t.size, dtype=bool)
    truth[index] = True
    truth[3000:3002] = True
    np.testing.assert_array_equal(spikes, truth)
    # the interpolation is the signal to within a few noise sd (0.02 m/s²)
    assert np.max(np.abs(repaired - y)) < 5 * 0.02
    # a clean record has none, nor a rail
    assert not find_spikes(t, y)[0].any() and not rail_samples(t, y).any()


@pytest.mark.parametrize("rate_Hz", [400.0, 1000.0, 4000.0])  # >= 10 samples a cycle of the fast mode
def test_a_noiseless_record_has_no_spike_and_a_small_glitch_on_it_is_one(rate_Hz):
    """A simulation without noise: the fourth difference's scale is then the signal's own curvature,
    which turns sharply where a fast mode rides on a slow one (1e-5 of the swing, no spike: the
    decimated record of tests/test_reliability_limits.py read back bit-exact); a glitch of 1 % of
    the swing on the same record is one."""
    t = np.arange(0.0, 4.0, 1 / rate_Hz)
    y = np.exp(-0.4 * t) * np.sin(2 * np.pi * 6.05 * t) + 0.3 * np.exp(-2 * t) * np.sin(2 * np.pi * 37.9 * t)
    assert not find_spikes(t, y)[0].any()
    glitched = y.copy()
    glitched[y.size // 2] += 1e-2 * np.max(np.abs(y))
    assert np.flatnonzero(find_spikes(t, glitched)[0]).tolist() == [y.size // 2]


def test_a_saturated_converter_is_flagged_at_its_rail():
    """A 12-bit converter of range ±15 m/s² on a swing of 20 m/s²: the samples at the rail exactly."""
    t, y, _ = plucked_strip(duration_s=4.0, rate_Hz=1000.0)
    quantum = 30.0 / 4096
    coded = np.round(y / quantum) * quantum
    railed = np.clip(coded, -15.0, 15.0)
    np.testing.assert_array_equal(rail_samples(t, railed), np.abs(coded) >= 15.0)
    assert not rail_samples(t, np.round(0.5 * y / quantum) * quantum).any()  # within range: none


@pytest.mark.parametrize("name", ["lab_run_1", "lab_run_2", "lab_run_3", "lab_run_4", "lab_run_5"])
def test_the_bundled_records_hold_no_artifact(name):
    m = read_measurement(ASSETS / "measurements" / f"{name}.csv")
    assert m.artifacts is not None and m.artifacts.hum is None
    assert m.artifacts.spike_count == 0 and m.artifacts.rail_count == 0 and not m.left_out.any()


@pytest.mark.skipif(not SHARED.is_dir(), reason="the shared development runs are not on this machine")
@pytest.mark.parametrize("run", ["114655", "114732", "114759", "114828", "114909"])
def test_the_shared_runs_have_no_hum_and_few_spikes(run):
    """The real ADXL357 runs: no mains line, no rail; the samples flagged (stale or late-stamped
    readings of the logger) stay below a thousandth of the record."""
    m = read_measurement(SHARED / f"adxl_50cm_{run}.csv")
    assert m.artifacts.hum is None and m.artifacts.rail_count == 0
    assert m.artifacts.spike_count < 1e-3 * m.sample_count


def test_a_calibration_leaves_the_flagged_samples_out_and_says_so(tmp_path):
    """A strain record of the steel bar, read from a lab's CSV, with hum, spikes and a converter
    rail: the flagged samples are not in the likelihood and the warnings name each artifact."""
    t, y, _ = tapped_bar([0.1], [0.02], duration_s=3.0, noise=2e-7)
    hum = mains_hum(60.0, (1, 3), (4e-7, 2e-7))
    raw = y + hum.evaluate(t)
    raw[[2500, 4100]] += 3e-5
    path = write_table(tmp_path / "bar.csv", "time (s),strain (microstrain)", t, raw, scale=1e6, digits=8)
    from tests.artifact_records import BAR_DESCRIPTION

    m = read_measurement(path, beam=BAR_DESCRIPTION)
    assert m.artifacts.hum is not None and m.artifacts.spike_count == 2
    flagged = np.flatnonzero(m.left_out)
    np.testing.assert_allclose(m.time_s[flagged], t[[2500, 4100]], atol=1e-9)
    result = calibration_preview(m, window=(0.0, 1.5))
    assert not np.any(result.setup.fit_mask[flagged])
    warnings = " ".join(result.to_json()["warnings"])
    assert "mains hum (60 Hz) removed" in warnings and "2 spike sample(s)" in warnings


def test_a_phone_strip_read_from_a_text_export_is_cleaned_once(tmp_path):
    """The import's record and the calibration's are one: cleaned by the reader, not twice."""
    t, y, _ = plucked_strip(duration_s=4.0, rate_Hz=500.0)
    hum = mains_hum(50.0, (1, 2), (0.3, 0.1))
    path = write_table(tmp_path / "phone.csv", "time (s),acceleration z (m/s^2)", t, y + hum.evaluate(t))
    m = read_measurement(path, beam=STRIP_DESCRIPTION)
    assert m.artifacts.hum is not None
    floor = np.sqrt(3 * len(m.artifacts.hum.lines) / t.size) * 0.02  # as in the test above
    assert np.sqrt(np.mean((m.output - y) ** 2)) <= 0.01 * np.sqrt(np.mean(hum.evaluate(t) ** 2)) + 2 * floor


def test_the_stiffness_is_anchored_on_the_beam_not_on_the_hum(tmp_path):
    """A short steel bar (15 cm: mode 1 at 110.6 Hz) read by an accelerometer at its tip, with 60 Hz
    hum, described without a material: the stiffness comes from the record's lowest strong peak.
    Weighted as displacement (1 / omega⁴) the hum line is that peak in the raw record (EI 3.4x too
    low); once subtracted, mode 1 anchors the EI of the simulated bar."""
    from tests.artifact_records import BAR_DENSITY, BAR_TRUTH

    geometry = BeamGeometry(0.15, BAR_DENSITY, None, None, 0.15)
    model = BeamModel(geometry, ("air_damping", "kelvin_voigt"), input_kind=None)
    f1 = model.natural_modes(BAR_TRUTH, 1)[0][0]
    t = np.arange(8000) / 4000.0
    y = model.free_response(BAR_TRUTH, t, [1.0, 0.1], [0.0, 0.0], modes=2, output="acceleration")
    y = 20 * y / np.abs(y).max() + 0.02 * np.random.default_rng(3).standard_normal(t.size)
    raw = y + mains_hum(60.0, (1, 2), (0.3, 0.1)).evaluate(t)
    assert lowest_strong_peak(t, raw, "acceleration").frequency_Hz == pytest.approx(60.0, abs=0.1)
    path = write_table(tmp_path / "short.csv", "time (s),acceleration (m/s^2)", t, raw)
    m = read_measurement(path, beam={"beam": {"length_m": 0.15, "linear_density_kg_m": BAR_DENSITY},
                                     "sensor": {"position_m": 0.15}})
    assert "110.6 Hz" in m.nominal_origin["bending_stiffness_Nm2"] and f1 == pytest.approx(110.6, abs=0.05)
    assert m.nominal["bending_stiffness_Nm2"] == pytest.approx(BAR_TRUTH["bending_stiffness_Nm2"], rel=2e-3)
