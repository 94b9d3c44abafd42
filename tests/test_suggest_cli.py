"""``beam diagnose ... --suggest``: where a new record would separate the top two explanations."""

from __future__ import annotations

import json

import pytest

from beam.io.measurement import write_measurement
from tests.test_joint_cli import beam
from tests.test_suggest import strip


@pytest.fixture(scope="module")
def record(tmp_path_factory) -> str:
    """The two-mode 50 cm strip of tests/test_suggest.py (5 g at the sensor), with its sidecar."""
    folder = tmp_path_factory.mktemp("suggest")
    measurement = strip(0.5, 0.44, "sensor_mass", seed=1)
    write_measurement(folder / measurement.name, measurement)
    return str(folder / f"{measurement.name}.csv")


@pytest.mark.slow
def test_diagnose_suggest_json(record):
    done = beam("diagnose", record, "--window", "0:2", "--modes", "2", "--base", "modal_damping", "--suggest",
                "--length-range", "0.3:0.6", "--json")
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout)
    ranked = sorted((c for c in out["candidates"] if c["delta_log_evidence"] is not None),
                    key=lambda c: -c["delta_log_evidence"])
    suggestion = out["suggestion"]
    gap = ranked[0]["delta_log_evidence"] - ranked[1]["delta_log_evidence"]
    assert gap < 3.0 and suggestion["needed"]  # two modes, EI free: the masses fit the record alike
    assert suggestion["effects"] == [ranked[0]["effect"], ranked[1]["effect"]]
    assert 0.3 - 1e-9 <= suggestion["length_m"] <= 0.6 + 1e-9
    assert 0.0 < suggestion["sensor_position_m"] <= suggestion["length_m"]
    assert suggestion["resolution_Hz"] == pytest.approx(1.0 / (1199 / 400.0))  # 1/T of the record
    f1 = suggestion["f1_Hz"]
    assert suggestion["f1_difference_pct"] == pytest.approx(100.0 * abs(f1[0] - f1[1]) / f1[1])
    assert {"f2_Hz", "f2_difference_pct", "words", "kind"} <= set(suggestion)


def test_length_range_needs_suggest(record):
    done = beam("diagnose", record, "--length-range", "0.3:0.6")
    assert done.returncode == 2 and done.stderr.startswith("error:") and "--suggest" in done.stderr
