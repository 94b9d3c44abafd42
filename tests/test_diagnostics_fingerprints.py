"""Fingerprints tell missing effects apart on records simulated with BeamModel."""

from __future__ import annotations

import functools
import json
import re
import math

import numpy as np
import pytest

from beam.physics.effects import CANDIDATE_EFFECTS
from beam.physics.geometry import BeamGeometry
from beam.physics.model import BeamModel
from beam.residuals import (
    ModeMatch,
    analyse_mode,
    compare_modes,
    effect_scores,
    explain,
    fingerprints,
    identify_modes,
    jsonable,
    residual_spectrum,
    residual_whiteness,
)

RATE = 1000.0
GEOMETRY = BeamGeometry(0.4573, 0.093, 0.15, 0.25, 0.27438)
BASE = {"bending_stiffness_Nm2": 0.491, "patch_coupling_NmV": 1.746e-2, "air_damping_Ns_m2": 0.013,
        "kelvin_voigt_Nm2s": 0.649e-5}
DAMPING_EFFECTS = ["air_damping", "kelvin_voigt"]

#: name: (effects added to the truth, truth parameters added or changed, base-model parameters changed)
RECORDS = {
    "tip_mass": (["tip_mass"], {"tip_mass_kg": 0.005}, {}),
    "clamp_compliance": (["clamp_compliance"], {"clamp_stiffness_Nm_rad": 50.0}, {}),
    "kelvin_voigt": ([], {}, {"kelvin_voigt_Nm2s": 0.0}),  # the base model lacks strain-rate damping
    "air_damping": ([], {}, {"air_damping_Ns_m2": 0.0}),
    "patch_stiffening": (["patch_stiffening"], {"patch_added_density_kg_m": 0.433, "patch_added_stiffness_Nm2": 0.793}, {}),
    "none": ([], {}, {}),
}


@functools.cache
def pulse_record(name: str) -> dict[str, float]:
    """A 3-sample 20 V pulse, 3 s at 1 kHz, 1 % noise; fingerprints against the base model."""
    effects, truth_changes, base_changes = RECORDS[name]
    t = np.arange(3000) / RATE
    voltage = np.zeros_like(t)
    voltage[:3] = 20.0
    truth = BeamModel(GEOMETRY, DAMPING_EFFECTS + effects)
    clean = truth.response(dict(BASE, **truth_changes), voltage, 1 / RATE, modes=6)
    data = clean + np.random.default_rng(1).normal(0, 0.01 * clean.std(), t.size)
    base = BeamModel(GEOMETRY, DAMPING_EFFECTS)
    base_parameters = dict(BASE, **base_changes)
    frequencies, damping = base.natural_modes(base_parameters, 6)
    identified = identify_modes(t, data, voltage)
    prediction = base.response(base_parameters, voltage, 1 / RATE, modes=6)
    analysis = analyse_mode(t, data, identified.frequency_Hz[0], voltage)
    return fingerprints(
        compare_modes(identified, frequencies, damping), backbone=analysis.backbone, decay=analysis.decay,
        spectrum=residual_spectrum(t, data, prediction, frequencies), whiteness=residual_whiteness(data - prediction),
    )


@pytest.fixture(scope="module", params=list(RECORDS))
def record(request):
    return request.param, pulse_record(request.param)


def test_the_missing_effect_scores_highest(record):
    name, fp = record
    scores = effect_scores(fp)
    assert list(scores) == list(CANDIDATE_EFFECTS)
    ranked = sorted(scores, key=scores.get, reverse=True)
    if name == "none":
        assert max(scores.values()) < 0.5, scores
        assert fp["ljung_box_p_value"] > 0.01 and fp["residual_power_fraction"] < 1e-3
    else:
        assert ranked[0] == name, scores
        assert scores[name] > 1.4 and scores[ranked[1]] < 0.5 * scores[name], scores
        assert fp["ljung_box_p_value"] < 1e-6
    sentences = explain(fp)
    assert list(sentences) == list(CANDIDATE_EFFECTS) and all(isinstance(s, str) and s for s in sentences.values())
    # a direction is worded once: never "low by +2.6 %" nor "(by -1.0 %"
    assert not any(re.search(r"(low|high|lower|higher|by) [+-−]\d", s) for s in sentences.values()), sentences
    json.dumps(jsonable(fp), allow_nan=False)


def test_fingerprint_numbers_of_the_records():
    tip = pulse_record("tip_mass")
    assert tip["frequency_error_mode1"] == pytest.approx(-0.1766, abs=2e-3)  # the model's own modes with the tip mass
    assert tip["mode1_deficit"] == pytest.approx((1 - 0.1336 + 1 - 0.1080) / 2 / (1 - 0.1766) - 1, abs=2e-3)
    assert "mode 1 is 6.8 % low relative to modes 2–3" in explain(tip)["tip_mass"]
    kelvin_voigt = pulse_record("kelvin_voigt")
    assert kelvin_voigt["damping_exponent_model"] == pytest.approx(-1.0, abs=0.01)  # air alone: zeta ∝ 1/omega
    assert kelvin_voigt["damping_growth_excess"] > 10
    assert kelvin_voigt["damping_law_b_data_s"] > 0 and kelvin_voigt["damping_law_b_model_s"] == pytest.approx(0, abs=1e-9)
    assert "grow with frequency faster than the model allows (ζ3/ζ1 = 2.2" in explain(kelvin_voigt)["kelvin_voigt"]


def test_hardening_spring_is_recognised_from_the_backbone():
    t = np.arange(4000) / RATE
    voltage = np.zeros_like(t)
    voltage[:500] = 0.6 * (1 - np.cos(np.pi * np.arange(500) / 500))
    voltage[500:800] = 1.2
    parameters = dict(BASE, air_damping_Ns_m2=0.1, tip_cubic_stiffness_N_m3=1e7)
    truth = BeamModel(GEOMETRY, DAMPING_EFFECTS + ["tip_cubic_spring"])
    data = truth.response(parameters, voltage, 1 / RATE, modes=4)
    data = data + np.random.default_rng(0).normal(0, 0.01 * data[800:].std(), t.size)
    analysis = analyse_mode(t, data, 6.15, voltage)
    fp = fingerprints([], backbone=analysis.backbone, decay=analysis.decay)
    scores = effect_scores(fp)
    assert max(scores, key=scores.get) == "tip_cubic_spring" and scores["tip_cubic_spring"] > 5
    assert explain(fp)["tip_cubic_spring"].startswith("the mode-1 frequency rises")


def row(mode, f_data, f_model, z_data=0.002, z_model=0.002):
    return ModeMatch(mode, f_data, f_model, z_data, z_model, 100 * (f_data / f_model - 1), 100 * (z_data / z_model - 1))


def test_fingerprints_of_a_constructed_table():
    table = [row(1, 9.0, 10.0, 0.002, 0.002), row(2, 57.0, 60.0, 0.004, 0.002), row(3, 152.0, 160.0, 0.008, 0.004)]
    fp = fingerprints(table)
    assert fp["frequency_error_mode1"] == pytest.approx(-0.1)
    assert fp["frequency_error_mean"] == pytest.approx((-0.1 - 0.05 - 0.05) / 3)
    assert fp["mode1_deficit"] == pytest.approx(0.95 / 0.9 - 1)
    assert fp["mode2_out_of_line"] == 0.0
    assert fp["damping_growth_data"] == pytest.approx(4.0) and fp["damping_growth_model"] == pytest.approx(2.0)
    assert fp["damping_growth_excess"] == pytest.approx(2.0) and fp["damping_growth_mode"] == 3
    assert fp["damping_error_mode2"] == pytest.approx(1.0)
    assert math.isnan(fp["amplitude_frequency_shift"]) and math.isnan(fp["ljung_box_p_value"])
    dip = fingerprints([row(1, 9.5, 10.0), row(2, 50.0, 60.0), row(3, 150.0, 160.0)])
    assert dip["mode2_out_of_line"] == pytest.approx(50 / 60 - 150 / 160)
    assert effect_scores(dip)["patch_stiffening"] == pytest.approx(abs(50 / 60 - 150 / 160) / 0.01)


def test_missing_inputs_give_nan_and_sentences_that_say_so():
    fp = fingerprints([])
    assert all(math.isnan(v) for v in fp.values())
    assert set(effect_scores(fp).values()) == {0.0}
    sentences = explain(fp)
    assert "cannot be judged" in sentences["kelvin_voigt"] and "must" in sentences["tip_mass"]
    assert "no backbone" in sentences["tip_cubic_spring"]
    assert jsonable(fp)["mode1_deficit"] is None


def test_a_driven_record_is_not_told_its_free_decay_was_missing():
    """A backbone is read from a free decay: on a driven record the spring's sentence says the record
    has none, not that one failed to be measured."""
    driven = explain(fingerprints([], free_decay=False))["tip_cubic_spring"]
    assert "driven record" in driven and "no backbone" not in driven
    free = explain(fingerprints([], free_decay=True))["tip_cubic_spring"]
    assert "no backbone of the free decay" in free
    assert fingerprints([], free_decay=True)["free_decay"] == 1.0
