"""Effects offered only where they apply: the catalogue's needs against the records' features."""

from __future__ import annotations

import glob
from dataclasses import replace

import pytest

from beam.discovery.ranking import candidate_effects, record_features
from beam.io.measurement import read_measurement
from beam.physics.effects import EFFECTS, INPUT_TERMS, RECORD_FEATURES, effect_needs

RECORDS = sorted(glob.glob("assets/measurements/lab_run_*.csv")) + sorted(glob.glob("assets/real/*.csv"))
BASE = ("air_damping", "kelvin_voigt")


def _acts_on_patch(effect_id: str) -> bool:
    """From the effect's own terms: any part assembled on the patch region."""
    return any("patch" in term.part for term in EFFECTS[effect_id].terms)


def _driven(effect_id: str) -> bool:
    """From the effect's own terms: any term multiplying the input (a force vector)."""
    forces = {t.part for t in INPUT_TERMS.values() if t is not None}
    return any(term.target == "force" or term.part in forces for term in EFFECTS[effect_id].terms)


def test_needs_are_known_features_and_follow_the_terms():
    for effect_id in EFFECTS:
        needs = effect_needs(effect_id)
        assert needs <= set(RECORD_FEATURES), (effect_id, needs)
        assert ("patch" in needs) == _acts_on_patch(effect_id), effect_id
        if _driven(effect_id):
            assert "input" in needs, effect_id


def _variants(path):
    m = read_measurement(path)
    yield m
    if not m.is_free:  # the same beam ringing on its own: no input column
        m = replace(m, **{m.input_column: None})
        yield m
    if m.geometry.has_patch:  # ... and a strip without a patch (a voltage input needs one)
        yield replace(m, geometry=replace(m.geometry, patch_start_m=None, patch_end_m=None))


@pytest.mark.parametrize("path", RECORDS)
def test_candidates_apply_to_the_record(path):
    for m in _variants(path):
        offered = candidate_effects(BASE, m)
        assert offered, path
        for effect_id in offered:
            if _acts_on_patch(effect_id):
                assert m.geometry.has_patch, (path, effect_id)
            if _driven(effect_id):
                assert not m.is_free, (path, effect_id)
            if effect_id == "tip_cubic_spring":  # its solver: a driven displacement on uniform stamps
                assert not m.is_free and m.uniform and m.output_kind == "displacement", path
            if effect_id == "sensor_mass":
                assert m.output_kind == "acceleration", path
            assert effect_needs(effect_id) <= record_features(m)


def test_the_real_strip_records_get_no_patch_effect():
    for path in glob.glob("assets/real/*.csv"):
        offered = candidate_effects(BASE, read_measurement(path))
        assert "sensor_mass" in offered and not any(_acts_on_patch(e) for e in offered), offered
        assert "patch_damping" not in offered and "patch_stiffening" not in offered


def test_the_bundled_lab_runs_offer_the_patch_effects():
    for path in glob.glob("assets/measurements/lab_run_*.csv"):
        offered = candidate_effects(BASE, read_measurement(path))
        assert {"patch_stiffening", "patch_damping", "tip_mass", "clamp_compliance"} <= set(offered)
