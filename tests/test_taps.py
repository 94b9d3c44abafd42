"""Every tap of a file (beam.io.taps): a strain record of a steel bar with six hammer taps at different
amplitudes (tests/artifact_records.py, the project's Galerkin model driven by the hammer's force,
every mode), read from a lab's CSV export with mains hum and spikes on it.

Checked against the simulation's own truth: the taps are found at the hammer's onsets, one tap
that starts while the last still rings (its onset hidden, the swing jumping 1.9x) is found as a
disturbance and the decay before it cut; their peaks follow the hammer's impulses; calibrated
together they recover the simulated bar inside the 95 % intervals, which narrow against the
strongest tap alone as the information the taps add: by the strongest's A / sd over sqrt(sum (A /
sd)²) of their amplitudes and noise (information per tap ~ (A / sd)², the same window and damping).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from beam.calibration import calibration_preview
from beam.calibration.joint import joint_preview
from beam.cli.main import main
from beam.io.measurement import read_measurement
from beam.io.taps import find_disturbances, tap_measurements, taps_words
from tests.artifact_records import BAR_DESCRIPTION, BAR_TRUTH, mains_hum, tapped_bar, write_table

ONSETS = (0.2, 6.2, 12.2, 18.2, 24.2, 30.2)
IMPULSES = (0.02, 0.01, 0.04, 0.005, 0.03, 0.014)
BEAM_FLAGS = ["--length", "0.4", "--width", "0.02", "--thickness", "0.003", "--material", "steel", "--sensor-at", "0.03"]


@pytest.fixture(scope="module")
def six_taps(tmp_path_factory):
    t, y, _ = tapped_bar(ONSETS, IMPULSES, duration_s=36.0, noise=2e-7)
    hum = mains_hum(60.0, (1, 2, 3, 5, 7), (3e-7, 1e-7, 1.5e-7, 8e-8, 6e-8))
    raw = y + hum.evaluate(t)
    spikes = np.random.default_rng(5).choice(np.arange(1000, t.size - 1000), 6, replace=False)
    raw[spikes] += 2e-5
    path = write_table(tmp_path_factory.mktemp("taps") / "bar.csv", "time (s),strain (microstrain)", t, raw,
                       scale=1e6, digits=7)
    return path, read_measurement(path, beam=BAR_DESCRIPTION), spikes, t


def test_the_six_taps_are_found_at_the_hammer_onsets(six_taps):
    _, m, spikes, t = six_taps
    assert len(m.taps) == 6 and [tap.index for tap in m.taps] == [1, 2, 3, 4, 5, 6]
    for tap, onset in zip(m.taps, ONSETS):
        assert onset - 2e-3 <= tap.start_s <= onset + 1e-3  # from the impact on (the stamps step 0.5 ms)
    # the strongest is the record itself; its peak and the others' follow the impulses
    assert m.name == "bar" and m.taps[2].measurement is not None and m.taps[2].measurement.name == "bar"
    peaks = np.array([tap.peak for tap in m.taps])
    np.testing.assert_allclose(peaks / peaks[2], np.array(IMPULSES) / IMPULSES[2], rtol=0.1)
    # every tap its own measurement: time from its impact, hum removed, its spikes flagged
    flagged = 0
    for tap in m.taps:
        own = tap.measurement
        assert own.time_s[0] == 0.0 and own.artifacts.hum is not None
        assert own.artifacts.hum.mains_Hz == 60.0 and 60.0 < own.artifacts.hum.lines[0].frequency_Hz < 60.05
        flagged += own.artifacts.spike_count
    inside = sum(any(tap.start_s <= t[i] <= tap.end_s for tap in m.taps) for i in spikes)
    assert flagged == inside
    words = taps_words(m)
    assert words.startswith("6 taps found (peaks ") and "µε" in words and "calibrated together" in words
    assert "--segment K" in words
    assert [tm.name for tm in tap_measurements(m)] == ["bar_tap1", "bar_tap2", "bar", "bar_tap4", "bar_tap5", "bar_tap6"]


def test_a_tap_while_the_bar_still_rings_is_a_disturbance(six_taps):
    """Tap 4 (impulse 0.005) comes while tap 3's swing (0.04) has fallen to ~9 %: its onset is not
    4x the swing before it, but the swing jumps: the decay of tap 3 is cut before it."""
    path, m, _, _ = six_taps
    assert any("the swing jumps" in line and "18.1" in line for line in m.source)
    assert m.taps[2].end_s < ONSETS[3] - 0.1 and m.taps[3].start_s == pytest.approx(ONSETS[3], abs=2e-3)
    t, y, _ = tapped_bar([0.2, 2.0], [0.02, 0.02], duration_s=5.0, noise=2e-7)
    jumps = find_disturbances(t, y, block_s=2 / 15.55)
    assert len(jumps) == 1 and 1.8 <= jumps[0].time_s <= 2.05 and jumps[0].cut_s < 2.0 and jumps[0].ratio >= 1.5
    t, y, _ = tapped_bar([0.2], [0.02], duration_s=5.0, noise=2e-7)
    assert find_disturbances(t, y, block_s=2 / 15.55) == []  # one clean decay: nothing


@pytest.mark.slow
def test_the_taps_calibrated_together_recover_the_bar_and_narrow_its_intervals(six_taps):
    _, m, _, _ = six_taps
    alone = calibration_preview(m)  # the strongest tap
    joint = joint_preview(tap_measurements(m))
    single, together = alone.summary(), joint.summary()
    for name, truth in BAR_TRUTH.items():
        assert together[name]["q025"] <= truth <= together[name]["q975"], name
        assert single[name]["q025"] <= truth <= single[name]["q975"], name
    # information ~ (amplitude / noise sd)², the same window and damping: the intervals narrow by
    # (A / sd) of the strongest over sqrt(sum (A / sd)²) (0.53 here: the strong taps' windows hold
    # the modes above the retained four a little longer, their noise sd 2.4x the weak ones'), within 20 %
    peaks = np.array([tap.peak for tap in m.taps])
    sd = np.array([joint.laplace.map.values[f"noise_sd@{k}"] for k in range(6)])
    snr = peaks / sd
    expected = snr[2] / np.sqrt(np.sum(snr**2))
    for name in BAR_TRUTH:
        ratio = together[name]["sd"] / single[name]["sd"]
        assert ratio == pytest.approx(expected, rel=0.2), name
    assert {"noise_sd@0", "noise_sd@5"} <= set(joint.problem.names)  # each tap its own noise


@pytest.mark.slow
def test_beam_calibrate_takes_every_tap_and_segment_takes_one(six_taps, capsys):
    path, _, _, _ = six_taps
    assert main(["calibrate", str(path), *BEAM_FLAGS, "--steps", "12", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert [r["record"] for r in summary["records"]] == ["bar_tap1", "bar_tap2", "bar", "bar_tap4", "bar_tap5", "bar_tap6"]
    assert [tap["tap"] for tap in summary["taps"]] == [1, 2, 3, 4, 5, 6]
    assert summary["taps"][2]["peak"] == pytest.approx(max(t["peak"] for t in summary["taps"]))
    assert "calibrated together" in summary["taps_words"]
    assert any("mains hum (60 Hz) removed" in w for w in summary["warnings"])
    assert main(["calibrate", str(path), *BEAM_FLAGS, "--steps", "12", "--segment", "2", "--window", "0:1.5"]) == 0
    text = capsys.readouterr().out
    assert text.startswith("bar: calibration window 0–1.5 s") and "taps found" not in text
    assert main(["calibrate", str(path), *BEAM_FLAGS, "--report", "r.html"]) == 2
    assert "give --segment K" in capsys.readouterr().err
    # each tap its own damping, to read against its peak; one tap has nothing to share
    assert main(["calibrate", str(path), *BEAM_FLAGS, "--steps", "12", "--per-record", "air_damping", "--json"]) == 0
    records = json.loads(capsys.readouterr().out)["records"]
    assert all("air_damping_Ns_m2" in r["parameters"] for r in records)
    assert main(["calibrate", str(path), *BEAM_FLAGS, "--segment", "2", "--per-record", "air_damping"]) == 2
    assert "needs several records (DATA DATA ...) or a record of several taps" in capsys.readouterr().err


@pytest.mark.slow
def test_beam_import_lists_the_taps_and_the_artifacts(six_taps, capsys, tmp_path):
    path, _, _, _ = six_taps
    assert main(["import", str(path), *BEAM_FLAGS, "--out", str(tmp_path / "bar")]) == 0
    text = capsys.readouterr().out
    assert "6 taps found" in text and "the files written hold tap 3 alone" in text
    for k in range(1, 7):
        assert f"segment {k}: " in text
    assert "mains hum (60 Hz) removed" in text and "spikes: " in text
    written = read_measurement(tmp_path / "bar.csv")
    assert written.sample_count == read_measurement(path, beam=BAR_DESCRIPTION).sample_count
