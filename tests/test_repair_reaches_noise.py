"""The repair reaches the noise: on each bundled teaching record, at the dashboard's default window
and modes, the model with the revealed effects (those the record was simulated with, every one of
them addable: the patch's added damping is the catalogue effect ``patch_damping``) predicts the
held-out record to within 1.3 x the true noise, its 95 % prediction band covers 90-98 % of the
held-out samples, and its posterior converges (bulk ESS >= 1000, R-hat <= 1.01).

The truth (effects, noise) is read from ``assets/answers``: the known answer of a simulated record.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from beam.calibration import calibrate
from beam.io.measurement import read_measurement
from beam.io.simulation import read_truth
from dashboard.state.beam import BeamState

ROOT = Path(__file__).resolve().parents[1]
RECORDS = ("lab_run_1", "lab_run_2", "lab_run_3", "lab_run_4", "lab_run_5")
@pytest.mark.parametrize("name", RECORDS)
def test_revealed_effects_reach_the_noise(name):
    measurement = read_measurement(ROOT / "assets" / "measurements" / f"{name}.csv")
    truth = read_truth(ROOT / "assets" / "answers" / f"{name}.truth.toml")
    state = BeamState(dataset=name)  # the dashboard's defaults for this record
    result = calibrate(measurement, window=tuple(state.window_s), effects=truth.effects, modes=int(state.modes))
    diagnostics = result.posterior.diagnostics
    assert diagnostics.ess_min >= 1000 and diagnostics.rhat_max <= 1.01
    assert result.rmse_prediction <= 1.3 * truth.noise_m
    assert 0.90 <= result.coverage95_prediction <= 0.98
