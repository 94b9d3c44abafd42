"""``beam calibrate --json`` on settings that once ended in an internal error.

* A free response (the real strip record) with the AR(1) likelihood: the screen of its starting
  points called the forward model without the AR(1) coefficient (KeyError).
* A window that covers the whole record: nothing is held out, so the prediction's RMSE and
  coverage are undefined; the JSON must say ``null`` (``json.dump(allow_nan=False)`` stopped
  half-way through the object before).
"""

from __future__ import annotations

import io
import json
from contextlib import redirect_stdout

import pytest

from beam.cli.main import main
from beam.io.measurement import read_measurement


def _calibrate_json(*argv: str) -> dict:
    out = io.StringIO()
    with redirect_stdout(out):
        status = main(["calibrate", *argv, "--json"])
    assert status == 0
    return json.loads(out.getvalue())


@pytest.mark.slow
def test_free_response_with_ar1_likelihood():
    summary = _calibrate_json("adxl_50cm_114655", "--likelihood", "ar1", "--window", "0:1", "--modes", "2",
                              "--effects", "modal_damping", "--steps", "40", "--seed", "1")
    assert summary["likelihood"] == "ar1"
    rho = summary["ar1_coefficient"]
    assert -1.0 < rho["mean"] < 1.0
    assert summary["rmse_calibration"] > 0


@pytest.mark.slow
def test_window_over_the_whole_record_has_null_prediction_scores():
    record = read_measurement("assets/measurements/lab_run_1.csv")
    end = float(record.time_s[-1])
    summary = _calibrate_json("lab_run_1", "--window", f"0:{end}", "--modes", "3", "--steps", "30", "--seed", "1")
    assert summary["rmse_prediction"] is None
    assert summary["coverage95_prediction"] is None
    assert summary["rmse_calibration"] > 0
