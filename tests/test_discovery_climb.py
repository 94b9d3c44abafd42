"""The climb of the diagnosis screens its candidates (the engine's first stage) and fits only the
rung it adds by both stages: a screening fit is marked and never remembered as the model's MAP,
and the climb adds what a climb with both stages for every candidate adds, with the same rung."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import beam.residuals as dx
from beam.calibration import CalibrationSpec, calibration_preview, known_map, remember_maps
from beam.calibration.run import FIRST_STAGE
from beam.calibration import starts
from beam.calibration.engine import default_engine, forget_maps
from beam.discovery.ranking import thread_fitter
from beam.discovery.report import climb_on, remaining_error
from beam.io.measurement import read_measurement

RECORD = Path(__file__).resolve().parents[1] / "assets" / "measurements" / "lab_run_1.csv"
BASE = ("air_damping", "kelvin_voigt")
WINDOW = (0.0, 1.05)


def test_a_screening_fit_is_marked_and_not_remembered_unless_it_is_the_engines_map():
    record = read_measurement(RECORD)
    forget_maps()
    two_stage = (*BASE, "patch_stiffening", "tip_mass")  # two mode-changing effects: a second stage
    screened = calibration_preview(record, window=WINDOW, effects=two_stage, modes=4, search=False)
    assert screened.screened
    assert default_engine().recall(screened.setup) is None  # not the model's MAP
    assert known_map(screened)[0] == (FIRST_STAGE, *screened.setup.effects)
    full = calibration_preview(record, window=WINDOW, effects=two_stage, modes=4)
    assert not full.screened
    # the second stage keeps the first stage's MAP unless it gains (searched_map): never lower
    assert full.laplace.map.log_posterior >= screened.laplace.map.log_posterior - 1e-9
    # the second stage started from the remembered first stage ends where both stages from nothing end
    forget_maps()
    cold = calibration_preview(record, window=WINDOW, effects=two_stage, modes=4)
    assert default_engine().recall(cold.setup, FIRST_STAGE) is None
    assert cold.laplace.map.values == full.laplace.map.values
    # handed to another process with the other MAPs: a first-stage MAP is not taken for the model's
    forget_maps()
    remember_maps(record, window=WINDOW, modes=4, maps=[known_map(screened)])
    assert default_engine().recall(screened.setup) is None
    assert default_engine().recall(screened.setup, FIRST_STAGE).values == screened.laplace.map.values

    # damping added to a mode-changing sub-model has no second stage: its screening fit is the
    # engine's MAP, remembered, and the preview that follows recalls it
    forget_maps()
    damped = (*BASE, "patch_stiffening", "patch_damping")
    first = calibration_preview(record, window=WINDOW, effects=damped, modes=4, search=False)
    assert not first.screened and not starts.has_second_stage(first.setup)
    again = calibration_preview(record, window=WINDOW, effects=damped, modes=4)
    assert again.laplace.map is default_engine().recall(again.setup)
    assert again.laplace.map.values == first.laplace.map.values


@pytest.mark.slow
def test_the_screened_climb_adds_what_the_full_climb_adds_with_the_same_rung():
    """lab_run_1 (patch stiffening and patch damping hidden), 7 modes: on top of patch stiffening
    the climb adds patch damping, screened or not, and its rung is the same MAP."""
    record = read_measurement(RECORD)
    forget_maps()
    leader = calibration_preview(record, window=WINDOW, effects=(*BASE, "patch_stiffening"), modes=7)
    setup = leader.setup
    floor = dx.noise_floor(setup.measurement.time_s, setup.measurement.output)
    remaining = remaining_error(leader, floor)
    assert remaining.outside_catalogue  # a climb is needed
    screened, left_screened = climb_on(record, leader, remaining, floor)
    full, left_full = climb_on(record, leader, remaining, floor,
                               screen=thread_fitter(record, CalibrationSpec(window=WINDOW, modes=7), search=True))
    assert [e for e, _ in screened] == [e for e, _ in full] == ["patch_damping"]
    for (_, a), (_, b) in zip(screened, full):
        assert not a.screened
        assert np.isclose(a.laplace.map.log_posterior, b.laplace.map.log_posterior, rtol=0, atol=1e-6)
    assert left_screened.outside_catalogue == left_full.outside_catalogue
