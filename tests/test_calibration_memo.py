"""MAPs shared between calibrations (beam.calibration.starts' memo): a model's MAP found once is
the MAP every later calibration of that model reports, in this process or, handed over with
``remember_maps``, in another; a sub-model's MAP is the nested start of the larger models."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from beam.calibration import calibration_preview, known_map, remember_maps
from beam.calibration import starts
from beam.calibration.engine import default_engine, forget_maps
from beam.io.measurement import read_measurement

RECORD = Path(__file__).resolve().parents[1] / "assets" / "measurements" / "lab_run_1.csv"
BASE = ("air_damping", "kelvin_voigt")
WINDOW = (0.0, 1.05)


def forget() -> None:
    forget_maps()


def test_a_map_handed_to_a_fresh_process_is_the_map_it_would_find():
    record = read_measurement(RECORD)
    effects = (*BASE, "tip_mass")
    forget()
    cold = calibration_preview(record, window=WINDOW, effects=effects, modes=4)
    forget()  # as a fresh worker process: nothing remembered
    remember_maps(record, window=WINDOW, modes=4, maps=[known_map(cold)])
    told = calibration_preview(record, window=WINDOW, effects=effects, modes=4)
    assert told.laplace.map.values == cold.laplace.map.values  # the same optimum, to the last digit
    assert told.laplace.log_evidence == cold.laplace.log_evidence
    # and it was recalled, not searched again: the recalled MAP object itself
    assert told.laplace.map is default_engine().recall(told.setup)


def test_a_map_is_remembered_only_for_its_own_record_window_and_modes():
    record = read_measurement(RECORD)
    effects = (*BASE, "tip_mass")
    forget()
    cold = calibration_preview(record, window=WINDOW, effects=effects, modes=4)
    other_window = calibration_preview(record, window=(0.0, 0.9), effects=effects, modes=4)
    assert default_engine().recall(other_window.setup) is other_window.laplace.map
    assert other_window.laplace.map.values != cold.laplace.map.values
    assert default_engine().recall(calibration_preview(record, window=WINDOW, effects=effects, modes=3).setup) is not cold.laplace.map
    # a warm start is never remembered: it may end in another basin than the cold search
    forget()
    calibration_preview(record, window=WINDOW, effects=effects, modes=4, start=cold.laplace.map.values)
    assert default_engine().recall(cold.setup) is None


def test_the_candidates_maps_are_the_nested_starts_of_the_climb():
    """A model with two effects on top of the base nests base + each: with those MAPs remembered
    (the diagnosis's candidates, before its climb) its MAP is the one found without them (the
    sub-models' MAPs are what its own recursive search finds)."""
    record = read_measurement(RECORD)
    forget()
    both = (*BASE, "tip_mass", "patch_damping")
    fresh = calibration_preview(record, window=WINDOW, effects=both, modes=4)
    forget()
    subs = [calibration_preview(record, window=WINDOW, effects=(*BASE, e), modes=4) for e in ("tip_mass", "patch_damping")]
    assert all(default_engine().recall(sub.setup) is sub.laplace.map for sub in subs)
    seeded = calibration_preview(record, window=WINDOW, effects=both, modes=4)
    assert np.isclose(seeded.laplace.map.log_posterior, fresh.laplace.map.log_posterior, rtol=0, atol=1e-3)
