"""One rule for naming an effect missing (#38 items 1, 3, 8): the rule on its numbers, the
amplitude-aware prediction after the window of a free decay, plausible parameters against what the
record states, and the command a student types next keeping the base's damping."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from beam.discovery.judgement import (
    HELD_OUT_WORSE,
    STATUSES,
    Judgement,
    judge_numbers,
    order_key,
)
from beam.discovery.plausibility import Finding
from tests import stand_ins as si


def _judged(gain, judged, held, findings=()):
    return judge_numbers("quadratic_drag", gain, judged, held, judged_label="calibration-window error",
                         held_out_label="error after the window", findings=findings)


def test_the_rule_names_missing_only_with_evidence_a_fall_and_a_prediction_not_worse():
    # the 30 cm phone strip of the issue: +N nats, the window's error down, the rest of the decay 6.1 % worse
    phone = _judged(300.0, (2.0, 1.2), (2.2, 2.2 * 1.061))
    assert phone.status == "fails_after_window" and not phone.material and not phone.supports
    assert "6.1 % higher" in phone.reason() and "not borne out" in phone.reason()
    # a rise below the tolerance is not worse; a material gain with a material fall is missing
    assert _judged(300.0, (2.0, 1.2), (2.2, 2.2 * (1 + 0.5 * HELD_OUT_WORSE))).status == "missing"
    assert _judged(4.9, (2.0, 1.2), (2.2, 1.0)).status == "not_material"  # evidence short of 5 nats
    weak = _judged(300.0, (2.0, 1.7), (2.2, 2.0))  # the window's error falls 15 %: too little
    assert weak.status == "not_material" and "falls only 15 %" in weak.reason()
    implausible = _judged(300.0, (2.0, 1.2), (2.2, 1.0), [Finding("drag_coefficient", 42.7, "bound", "C_d = 42.7 …")])
    assert implausible.status == "implausible" and "not quadratic_drag" in implausible.reason()
    assert _judged(-math.inf, (2.0, math.nan), (2.2, math.nan)).status == "failed"
    # no held-out part: nothing after the window contradicts it
    assert _judged(300.0, (2.0, 1.2), (math.nan, math.nan)).status == "missing"


def test_one_order_missing_first_then_by_status_and_evidence():
    made = [Judgement("a", "not_material", -7.7), Judgement("b", "fails_after_window", 139.0),
            Judgement("c", "missing", 12.0), Judgement("d", "missing", 500.0), Judgement("e", "failed", -math.inf),
            Judgement("f", "implausible", 644.0), Judgement("g", "not_material", 3.0)]
    ordered = [j.effect for j in sorted(made, key=order_key)]
    assert ordered == ["d", "c", "g", "a", "f", "b", "e"]
    assert [STATUSES.index(j.status) for j in sorted(made, key=order_key)] == sorted(
        STATUSES.index(j.status) for j in made)


def test_adding_to_the_default_keeps_its_damping():
    """``--effects +quadratic_drag`` is the default's damping and the drag (the issue: the drag alone
    predicted 5.31 m/s² where the base had 2.2); a plain list is taken as written."""
    from beam.calibration.defaults import DEFAULT_EFFECTS
    from beam.cli.main import build_parser

    parser = build_parser()
    args = parser.parse_args(["calibrate", "lab_run_1", "--effects", "+quadratic_drag"])
    assert args.effects.split(",") == [*DEFAULT_EFFECTS, "quadratic_drag"]
    assert parser.parse_args(["calibrate", "lab_run_1", "--effects", "quadratic_drag"]).effects == "quadratic_drag"
    assert parser.parse_args(["diagnose", "lab_run_1", "--base", "+tip_mass"]).base.split(",") == [*DEFAULT_EFFECTS,
                                                                                                     "tip_mass"]


@pytest.fixture(scope="module")
def strip_40():
    return si.joint_strip(0.4, seed=1)


def _preview(record, effects):
    from beam.calibration import calibration_preview

    return calibration_preview(record, window=(0.0, 2.0), effects=effects, modes=2)


def test_the_reanchored_prediction_is_at_the_noise_for_the_true_model_and_matches_a_second_method(strip_40):
    """The true model's error after the window, re-anchored block by block, is the record's noise
    (0.05 m/s²); a model without the mass and the clamp stays above it; the same number by a second
    method: damped sinusoids at the MAP's natural frequencies and damping ratios, fitted per block."""
    from beam.discovery.held_out import BLOCK_PERIODS, reanchored_rmse

    true = _preview(strip_40, ",".join(si.JOINT_EFFECTS))
    assert reanchored_rmse(true) == pytest.approx(0.05, rel=0.15)
    bare = _preview(strip_40, "modal_damping")
    assert reanchored_rmse(bare) > 1.5 * reanchored_rmse(true)
    # a second method: the block fit written out from the modal frequencies and damping ratios
    values = {k: float(v) for k, v in true.laplace.map.values.items() if k in true.setup.physical_names}
    f, zeta = true.setup.model.natural_modes(values, 2)
    m = true.setup.measurement
    mask = true.setup.held_out_mask & (m.time_s > true.setup.window[1])
    t, y = m.time_s[mask], m.output[mask]
    block = BLOCK_PERIODS / f[0]
    squares = 0.0
    cuts = [0]
    for i in range(1, t.size):
        if t[i] - t[cuts[-1]] >= block:
            cuts.append(i)
    if t[-1] - t[cuts[-1]] < 0.5 * block and len(cuts) > 1:
        cuts.pop()
    cuts.append(t.size)
    for a, b in zip(cuts[:-1], cuts[1:]):
        tau = t[a:b] - t[a]
        columns = [np.ones_like(tau)]
        for fk, zk in zip(f, zeta):
            w = 2 * np.pi * fk
            envelope = np.exp(-zk * w * tau)
            wd = w * np.sqrt(1 - zk**2)
            columns += [envelope * np.cos(wd * tau), envelope * np.sin(wd * tau)]
        design = np.column_stack(columns)
        coefficients, *_ = np.linalg.lstsq(design, y[a:b], rcond=None)
        squares += float(np.sum((y[a:b] - design @ coefficients) ** 2))
    assert reanchored_rmse(true) == pytest.approx(math.sqrt(squares / t.size), rel=1e-3)


def test_a_mass_far_from_the_stated_one_is_not_the_sensor(strip_40):
    """The same record, the sensor's mass stated as about 4 g (the truth) or about 1.2 g (log sd 0.35,
    an approximate statement: the prior lets the data move it): the fit's 4 g is the sensor in the
    first case and, at 3.3 times the statement (beyond its 2.9 = e^(3 x 0.35)), not the sensor in the
    second."""
    from dataclasses import replace

    from beam.discovery.plausibility import implausible_parameters, plausible_range

    rigid = si.joint_strip(0.4, seed=1, truth=dict(si.JOINT_TRUTH, clamp_stiffness_Nm_rad=1e6))  # f1, f2 pin EI and m
    for stated, expected in ((0.004, []), (0.0012, ["stated"])):
        record = replace(rigid, nominal={**rigid.nominal, "sensor_mass_kg": stated},
                         nominal_spread={"sensor_mass_kg": 0.35})
        fit = _preview(record, "sensor_mass,modal_damping")
        assert fit.laplace.map.values["sensor_mass_kg"] == pytest.approx(0.004, rel=0.1)
        findings = implausible_parameters("sensor_mass", fit)
        assert [f.kind for f in findings] == expected, findings
        if expected:
            assert "the record states" in findings[0].reason
    # the clamp of the compliant strip: 233 N m/rad on EI / L = 5.5 N m/rad is kappa = 42, inside the
    # plausible 3 EI / L and above
    fit = _preview(strip_40, ",".join(si.JOINT_EFFECTS))
    low, high = plausible_range("clamp_stiffness_Nm_rad", fit)
    assert low == pytest.approx(3.0 * fit.laplace.map.values["bending_stiffness_Nm2"] / 0.4) and math.isinf(high)
    assert fit.laplace.map.values["clamp_stiffness_Nm_rad"] > low
    assert implausible_parameters("clamp_compliance", fit) == []


def test_the_readable_report_names_the_repaired_model_in_full():
    from beam.cli.diagnose_command import format_report

    summary = {"measurement": "rec", "window_s": [0.0, 6.0], "modes": 4, "base": ["air_damping", "kelvin_voigt"],
               "rmse_prediction_base": 2.2, "coverage95_prediction_base": 0.9, "output_unit": "m/s²",
               "modes_table": [], "ladder": [], "verdict": "v", "notes": [], "seconds": 1.0,
               "candidates": [{"effect": "quadratic_drag", "delta_log_evidence": 300.0, "rmse_prediction": 2.3,
                               "material": False, "explanation": "e", "status": "fails_after_window"},
                              {"effect": "sensor_mass", "delta_log_evidence": 8000.0, "rmse_prediction": 2.1,
                               "material": True, "explanation": "e", "status": "missing"}],
               "repair": {"effects": ["air_damping", "kelvin_voigt", "sensor_mass"],
                          "command": "beam calibrate rec --window 0:6 --modes 4 --effects air_damping,kelvin_voigt,sensor_mass"}}
    text = format_report(summary)
    assert "to calibrate the repaired model: beam calibrate rec --window 0:6 --modes 4 --effects " \
           "air_damping,kelvin_voigt,sensor_mass" in text
    assert "fits the window, fails after it" in text and "missing first" in text


def test_a_base_whose_damping_sits_on_its_bound_is_not_converged():
    """A steel bar whose clamp slips (strain gauge near the root): the base's air damping needs more
    than its prior allows; the calibration names it and does not call itself converged."""
    from beam.calibration import calibration_preview
    from beam.discovery.plausibility import bound_notes

    bar = si.steel_bar(0.0048, duration_s=3.0)
    base = calibration_preview(bar, modes=2)
    assert "air_damping_Ns_m2" in base.pressed_parameters
    assert any("air_damping_Ns_m2" in note and "upper bound" in note for note in bound_notes(base))
    summary = base.to_json()
    assert summary["converged"] is False and any("air_damping_Ns_m2 sits at a bound" in w for w in summary["warnings"])


@pytest.mark.slow
def test_drag_on_a_stiff_steel_bar_is_not_the_air_and_points_to_the_clamp():
    """The 4.8 mm steel bar: its damping grows with the swing (the clamp slips), which the drag can
    only follow with a C_d beyond every flat strip's; the judgement says "not this effect" and names
    clamp_friction, which the record's own rising frequency calls for. Checked against the physics:
    air at C_d = 20 gives the bar's mode 1 an equivalent damping ratio of 6e-4 at its release swing,
    less at every later one (the cycle-averaged drag, (4 / 3 pi) kappa_1 A_1), under a fourth of the
    record's own mean 4e-3 (its RMS falling 2.6x in 2 s)."""
    from beam.discovery.ranking import rank_candidates
    from beam.physics.effects import quadratic_drag as drag

    bar = si.steel_bar(0.0048, duration_s=3.0)
    ranking = rank_candidates(bar, candidates=["quadratic_drag"], modes=2, window=(0.0, 1.2))
    (candidate,) = ranking.candidates
    judgement = candidate.judgement
    assert judgement.status == "implausible", judgement
    assert "clamp_friction" in judgement.alternatives
    fit = ranking.results["quadratic_drag"]
    assert fit.laplace.map.values["drag_coefficient"] > drag.COEFFICIENT.plausible[1]
    # the air's share at a plausible C_d, from the cycle-averaged drag on mode 1 (an independent sum)
    model = fit.setup.model
    values = {n: float(v) for n, v in fit.laplace.map.values.items() if n in fit.setup.physical_names}
    omega2, shapes = model.mode_shapes(values, 2)
    nodes, weights = drag.drag_quadrature(bar.geometry.length_m)
    psi = model.parts.basis.evaluate(nodes, 0) @ shapes[:, 0]
    kappa = 0.5 * drag.AIR_DENSITY_KG_M3 * bar.geometry.width_m * np.sum(weights * np.abs(psi) ** 3)
    tip_m = 0.015 * bar.geometry.length_m
    amplitude = tip_m / float(model.parts.tip_values @ shapes[:, 0])  # mode 1's modal amplitude at release
    zeta_air = 4.0 / (3.0 * np.pi) * kappa * amplitude * drag.COEFFICIENT.plausible[1]
    assert 1e-5 < zeta_air < 1e-3
    # the record's own damping: its RMS in the first and last thirds, mode 1's decay between them
    third = bar.output.size // 3
    fall = np.std(bar.output[:third]) / np.std(bar.output[-third:])
    zeta_record = np.log(fall) / (np.sqrt(omega2[0]) * (bar.time_s[-1] - bar.time_s[0]) * 2 / 3)
    assert zeta_record > 4 * zeta_air


def test_odds_for_the_effect_only_beside_an_effect_named_missing():
    """The dashboard's row reads the candidate's judgement: "+8 388 nats, not named missing" beside
    a fingerprint's "no sign of a missing tip mass", never odds for the effect (#38 item 8)."""
    pytest.importorskip("panel")
    from types import SimpleNamespace

    from beam.discovery.ranking import Candidate
    from dashboard.outputs.beam import output_units
    from dashboard.views.diagnosis import DiagnosisView

    base = SimpleNamespace(rmse_prediction_map=0.6, rmse_calibration_map=0.66,
                           setup=SimpleNamespace(is_free=True, measurement=SimpleNamespace(output_kind="acceleration")))
    diagnosis = SimpleNamespace(base=base)
    words = "mode 1 is not clearly low relative to modes 2–3: no sign of a missing tip mass"
    for status, gain in (("not_material", 8388.0), ("fails_after_window", 139.0), ("implausible", 644.0),
                         ("missing", 8729.0)):
        judgement = Judgement("tip_mass", status, gain, "calibration-window error", 0.66, 0.15,
                              "error after the window (re-anchored on the record's amplitudes)", 0.24, 0.241)
        c = Candidate("tip_mass", gain, 0.6, 0.15, 0.3, judgement.material, words, {}, judgement)
        text = DiagnosisView._candidate_text(c, diagnosis, output_units(None))
        assert bool(re.search(r"odds[^.;<]*for the effect", text)) == (status == "missing"), (status, text)
        assert "re-anchored on the record's amplitudes" in text  # the error after the window it is judged on
