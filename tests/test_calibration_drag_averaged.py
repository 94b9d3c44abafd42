"""The averaged (slow-flow) model of the quadratic drag (beam.calibration.free_averaged): the
linear model at C_d = 0, its error against the full integrator, its preview against the full
calibration, and the full calibration started from it."""

from __future__ import annotations

import numpy as np
import pytest
from test_calibration_drag import STRIP, TRUTH, _drag_decay

from beam.calibration import calibration_preview
from beam.calibration.engine import Engine
from beam.calibration.free import ProjectedFreeModel
from beam.calibration.pipeline import averaged_drag_preview
from beam.calibration.free_averaged import AVERAGED_NOTE, AveragedDragModel
from beam.calibration.free_nonlinear import NonlinearFreeModel
from beam.physics.model import BeamModel

DRAG = BeamModel(STRIP, ("modal_damping", "quadratic_drag"), input_kind=None)


def _full_and_averaged(tips_m, duration_s=4.0, values=TRUTH):
    """The full integrator's acceleration (ETDRK4 on the Galerkin modes) of a free decay from
    ``tips_m`` (tip displacement of each mode, m) and the averaged model's from the same state."""
    t = np.arange(0.0, duration_s, 1e-3)
    _, shapes = DRAG.mode_shapes(values, len(tips_m))
    eta = np.array(tips_m) / (DRAG.parts.tip_values @ shapes)
    full = DRAG.free_response(values, t, eta, modes=len(tips_m), output="acceleration")
    free = NonlinearFreeModel(DRAG, len(tips_m), "acceleration", t, full)
    amplitudes = np.append(np.linalg.solve(free.state_matrix(values), np.concatenate([eta, np.zeros(eta.size)])), 0.0)
    return full, AveragedDragModel(free).response(values, amplitudes), free, amplitudes


def test_at_zero_drag_the_averaged_model_is_the_linear_free_response():
    """C_d = 0: every envelope is the exact exponential of the linear model (to round-off)."""
    values = dict(TRUTH, drag_coefficient=0.0)
    _, averaged, free, amplitudes = _full_and_averaged([0.02, 0.0008], 2.0, values)
    linear = ProjectedFreeModel(BeamModel(STRIP, ("modal_damping",), input_kind=None), 2, "acceleration",
                                free.fit_time_s, free.fit_data)
    poles = linear.poles({k: np.array([v]) for k, v in values.items() if k != "drag_coefficient"})
    exact = linear.design(poles, free.fit_time_s)[0] @ amplitudes
    np.testing.assert_allclose(averaged, exact, rtol=0, atol=1e-10 * np.max(np.abs(exact)))


@pytest.mark.parametrize("tips", [[0.02, 0.0], [0.02, 0.0008]])
def test_the_averaged_model_follows_the_full_integrator(tips):
    """Against the full integrator from the same state: within 1 % relative L2 at 2 cm (one mode,
    and two modes where mode 2 carries most of the acceleration and mode 1's velocity damps it:
    the cross term), while the model without the drag is far off; the error is the averaging's
    first-order error, so it doubles with the amplitude (4 cm against 2 cm: 1.6-2.4x)."""
    full, averaged, _, _ = _full_and_averaged(tips)
    error = np.linalg.norm(averaged - full) / np.linalg.norm(full)
    assert error < 0.01
    viscous, _, _, _ = _full_and_averaged(tips, values=dict(TRUTH, drag_coefficient=0.0))
    assert np.linalg.norm(viscous - full) / np.linalg.norm(full) > 10 * error
    full_4, averaged_4, _, _ = _full_and_averaged([2.0 * tip for tip in tips])
    assert 1.6 <= (np.linalg.norm(averaged_4 - full_4) / np.linalg.norm(full_4)) / error <= 2.4


@pytest.mark.slow
def test_the_averaged_preview_is_near_the_full_calibration_which_starts_from_it(monkeypatch):
    """On a simulated drag decay of known truth (0-4 s): the averaged preview's mode-1 damping at
    the window's mean amplitude (zeta_1 + C_d e_1, what the decay measures) within 2 % of the full
    calibration's, C_d and zeta_1 each within 15 % (the averaging's bias slides them along the
    valley where the two damping laws trade) and C_d within 10 % of the truth; the full
    calibration, started from the averaged MAP, reaches the MAP it reaches without it (log
    posterior within 1e-6 relative) in fewer iterations."""
    import beam.calibration.free_nonlinear as free_nonlinear

    record = _drag_decay(seed=8)
    engine = Engine()
    calibration_preview(record, window=(0.0, 4.0), effects="modal_damping", modes=2, engine=engine)
    preview = averaged_drag_preview(record, (0.0, 4.0), "modal_damping,quadratic_drag", modes=2, engine=engine)
    assert preview.note == AVERAGED_NOTE and "averaged" in preview.note
    full = calibration_preview(record, window=(0.0, 4.0), effects="modal_damping,quadratic_drag", modes=2,
                               engine=engine)
    mapped = full.laplace.map.values
    mask = record.time_s <= 4.0
    drag = NonlinearFreeModel(DRAG, 2, "acceleration", record.time_s[mask], record.output[mask])
    start = {k: mapped[k] for k in drag.names}
    lowered = drag.equivalent_starts(dict(start, drag_coefficient=0.0))[0]  # ζ_1 lowered by C_d e_1
    e1 = (start["damping_ratio_mode_1"] - lowered["damping_ratio_mode_1"]) / lowered["drag_coefficient"]
    assert (preview.values["damping_ratio_mode_1"] + preview.values["drag_coefficient"] * e1 == pytest.approx(
        mapped["damping_ratio_mode_1"] + mapped["drag_coefficient"] * e1, rel=0.02))
    for name in ("drag_coefficient", "damping_ratio_mode_1"):
        assert preview.values[name] == pytest.approx(mapped[name], rel=0.15), name
    assert preview.values["drag_coefficient"] == pytest.approx(TRUTH["drag_coefficient"], rel=0.1)
    monkeypatch.setattr(free_nonlinear.NonlinearFreeModel, "_averaged_start", lambda self, *args: None)
    without = calibration_preview(record, window=(0.0, 4.0), effects="modal_damping,quadratic_drag", modes=2,
                                  engine=Engine())
    assert full.laplace.map.log_posterior == pytest.approx(without.laplace.map.log_posterior, rel=1e-6)
    assert full.laplace.map.n_iterations < without.laplace.map.n_iterations


def test_without_viscous_damping_the_averaged_decay_is_the_pure_quadratic_law():
    """zeta -> 0: the closed form's limit a / (1 + b a t) (no viscous decay at all) still follows
    the full integrator within 1 % relative L2 over 4 s of a 2 cm release, and the drag alone
    takes a visible part of the swing (the model without it is far off)."""
    undamped = dict(TRUTH, damping_ratio_mode_1=0.0, damping_ratio_mode_2=0.0)
    full, averaged, _, _ = _full_and_averaged([0.02, 0.0], values=undamped)
    error = np.linalg.norm(averaged - full) / np.linalg.norm(full)
    assert error < 0.01
    free, _, _, _ = _full_and_averaged([0.02, 0.0], values=dict(undamped, drag_coefficient=0.0))
    assert np.linalg.norm(free - full) / np.linalg.norm(full) > 10 * error
