"""Which record to take next (beam.discovery.suggest): the suggested record, simulated and added,
separates two explanations that the first record could not.

Simulated: the strip of tests/test_joint_calibration.py (0.27 kg/m, EI 2.14 N m², rigid clamp) at
50 cm with the sensor 6 cm from the tip, two modes in the record (400 Hz, 3 s, noise 0.05 m/s²),
a 5 g mass at the sensor or at the tip. With two modes and EI free, EI and either mass match both
frequencies: one record does not separate them. The suggestion is simulated from the truth (a new
seed) and diagnosed jointly with the first record.
"""

from __future__ import annotations

import numpy as np
import pytest

from beam.calibration.joint import joint_preview
from beam.discovery.joint import SEPARATING_NATS, joint_diagnose
from beam.discovery.suggest import next_record, suggest_record
from beam.errors import BeamInputError
from beam.io.measurement import Measurement
from beam.physics.geometry import BeamGeometry
from beam.physics.model import BeamModel

BASE = "modal_damping"
EFFECTS = ("sensor_mass", "tip_mass")
OPTIONS = dict(window=(0.0, 2.0), modes=2)


def truth_of(mass_at: str) -> dict[str, float]:
    return {"bending_stiffness_Nm2": 2.14, f"{mass_at}_kg": 0.005, "damping_ratio_mode_1": 0.005,
            "damping_ratio_mode_2": 0.006}


def strip(length_m: float, sensor_at_m: float, mass_at: str, seed: int) -> Measurement:
    """The free decay (both modes excited) of the strip clamped at ``length_m``, sensor at
    ``sensor_at_m`` from the clamp, accelerometer noise 0.05 m/s², offset 0.43 m/s²."""
    geometry = BeamGeometry(length_m=length_m, linear_density_kg_m=0.27, patch_start_m=None, patch_end_m=None,
                            sensor_position_m=sensor_at_m)
    model = BeamModel(geometry, (mass_at, BASE), input_kind=None)
    t = np.arange(1200) / 400.0
    clean = model.free_response(truth_of(mass_at), t, [6.4e-4, 1.9e-4], [0.0, 0.0], modes=2, output="acceleration")
    y = clean + 0.43 + 0.05 * np.random.default_rng(seed).standard_normal(t.size)
    return Measurement(f"strip_{round(100 * length_m)}cm_{round(100 * sensor_at_m)}cm", "simulated strip", geometry, t,
                       acceleration_m_s2=y, nominal={"bending_stiffness_Nm2": 2.333})


def gap(diagnosis, a: str, b: str) -> float:
    by_effect = {c.effect: c.delta_log_evidence for c in diagnosis.candidates}
    return by_effect[a] - by_effect[b]


@pytest.mark.slow
@pytest.mark.parametrize(("truth", "other"), [("sensor_mass", "tip_mass"), ("tip_mass", "sensor_mass")])
def test_the_suggested_record_separates_what_the_first_could_not(truth, other):
    first = strip(0.5, 0.44, truth, seed=1)
    alone = joint_diagnose([first], base=BASE, candidates=EFFECTS, **OPTIONS)
    assert abs(gap(alone, truth, other)) < SEPARATING_NATS  # two modes, two parameters: both fit
    fits = [alone.fits[e] for e in EFFECTS]
    suggestion = suggest_record(fits, EFFECTS, gap(alone, *EFFECTS), length_range=(0.3, 0.6))
    best = suggestion.best
    # the two models agree on the first record's setting and differ at the suggested one
    f1_first = [alone.f1_Hz(e)[0] for e in EFFECTS]
    assert abs(f1_first[0] - f1_first[1]) / f1_first[1] < 1e-3 < best.f1_difference_pct / 100.0
    assert best.f1_difference_resolutions > 1.0
    # the suggested record, simulated from the truth and added, separates them
    new = strip(best.length_m, best.sensor_position_m, truth, seed=2)
    together = joint_diagnose([first, new], base=BASE, candidates=EFFECTS, **OPTIONS)
    assert gap(together, truth, other) >= 10.0
    assert together.missing == truth


def test_the_frequencies_are_the_models_and_the_ranges_are_checked():
    first = strip(0.5, 0.44, "sensor_mass", seed=1)
    fits = [joint_preview([first], effects=f"{e},{BASE}", **OPTIONS) for e in EFFECTS]
    suggestion = suggest_record(fits, EFFECTS, 0.0, length_range=(0.3, 0.6), positions=False, points=4)
    assert [s.kind for s in suggestion.settings] == ["length"] * 4
    setting = suggestion.settings[0]
    assert setting.length_m == pytest.approx(0.3) and setting.sensor_position_m == pytest.approx(0.24)
    # each model's f1 and f2 at the setting: its MAP on the changed strip (natural_modes, the full eigenproblem)
    for k, effect in enumerate(EFFECTS):
        geometry = BeamGeometry(length_m=0.3, linear_density_kg_m=0.27, patch_start_m=None, patch_end_m=None,
                                sensor_position_m=0.24)
        values = {n: v for n, v in fits[k].laplace.map.values.items() if not n.startswith("noise")}
        f = BeamModel(geometry, (effect, BASE), input_kind=None).natural_modes(values, 2)[0]
        assert (setting.f1_Hz[k], setting.f2_Hz[k]) == pytest.approx(tuple(f[:2]), rel=1e-6)
    assert setting.resolution_Hz == pytest.approx(1.0 / (first.time_s[-1] - first.time_s[0]))
    # two fits that predict alike everywhere: no setting separates them, and the words say so
    same = suggest_record([fits[0], fits[0]], EFFECTS, 0.0, length_range=(0.3, 0.6), points=3)
    assert same.best.f1_difference_pct == 0.0 and same.words().startswith("no setting within the ranges")
    with pytest.raises(BeamInputError, match="past the tip"):
        suggest_record(fits, EFFECTS, 0.0, position_range=(0.2, 0.7), lengths=False)
    with pytest.raises(BeamInputError, match="0 < A < B"):
        suggest_record(fits, EFFECTS, 0.0, length_range=(0.6, 0.3))


def test_from_a_joint_set_of_one_mode_records():
    """Two one-mode records (40 and 50 cm, 5 g at the sensor, compliant clamp; the strips of
    tests/test_joint_separation.py) leave sensor_mass and tip_mass within 3 nats jointly; the
    record the joint fits suggest, simulated and added, separates them."""
    from tests.test_joint_separation import BASE as ONE_MODE_BASE
    from tests.test_joint_separation import records, truth_of as one_mode_truth

    options = dict(window=(0.0, 2.0), modes=1, base=ONE_MODE_BASE, candidates=EFFECTS)
    pair = records("sensor_mass")[1:]
    jointly = joint_diagnose(pair, **options)
    assert abs(gap(jointly, "sensor_mass", "tip_mass")) < SEPARATING_NATS
    suggestion = suggest_record([jointly.fits[e] for e in EFFECTS], EFFECTS, gap(jointly, *EFFECTS),
                                length_range=(0.25, 0.6))
    best = suggestion.best
    geometry = BeamGeometry(length_m=best.length_m, linear_density_kg_m=0.27, patch_start_m=None, patch_end_m=None,
                            sensor_position_m=best.sensor_position_m)
    model = BeamModel(geometry, ("sensor_mass", "clamp_compliance", "modal_damping"), input_kind=None)
    t = np.arange(750) / 250.0
    clean = model.free_response(one_mode_truth("sensor_mass"), t, [6.4e-4, 0.0], [0.0, 0.0], modes=2,
                                output="acceleration")
    new = Measurement("suggested", "simulated strip", geometry, t,
                      acceleration_m_s2=clean + 0.43 + 0.05 * np.random.default_rng(7).standard_normal(t.size),
                      nominal={"bending_stiffness_Nm2": 2.333})
    together = joint_diagnose(pair + [new], **options)
    assert gap(together, "sensor_mass", "tip_mass") >= 10.0
    assert together.missing == "sensor_mass"


def test_no_suggestion_without_a_material_explanation_or_a_close_pair():
    """A suggestion separates two supported explanations: none when the best candidate is not
    material (two damping effects at +3.7 and +3.6 nats) or when the top two are 3 nats apart
    already; the fits are then never needed."""
    def no_fits(a, b):
        raise AssertionError("no fit is needed")

    weak = next_record([("air_damping", 3.7), ("kelvin_voigt", 3.6), ("tip_mass", -1.1)], no_fits)
    assert not weak["needed"] and "materially" in weak["words"]
    apart = next_record([("sensor_mass", 420.0), ("tip_mass", 30.0)], no_fits)
    assert not apart["needed"] and "separated already" in apart["words"]
    lone = next_record([("sensor_mass", 420.0), ("tip_mass", None)], no_fits)
    assert not lone["needed"]
