"""The beam view's calibration of a free decay with the air drag: the averaged drag preview is
published first with its label, then the full model's preview and its final (Laplace) result
replace it (the job and the state against the real library; no browser, no server)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the simulated drag decay of the library's tests
from test_calibration_drag import _drag_decay  # noqa: E402

from beam.calibration import CalibrationSpec  # noqa: E402
from beam.calibration.engine import Engine  # noqa: E402
from dashboard.jobs import beam as beam_jobs  # noqa: E402
from dashboard.jobs.beam import AVERAGED_STATUS, LAPLACE_STATUS, CalibrationKey, calibration_stages  # noqa: E402
from dashboard.runtime import scheduler as sch  # noqa: E402
from dashboard.state.beam import BeamState  # noqa: E402
from dashboard.views.beam import convergence_html, stage_text  # noqa: E402


@pytest.fixture(scope="module")
def stages():
    """The job's stages for a simulated decay under the drag (C_d = 12), window 0-4 s, 2 modes, in
    a worker whose engine remembers nothing yet (one that knows this model's MAP shows it at once)."""
    key = CalibrationKey("simulated_drag", CalibrationSpec(window=(0.0, 4.0), effects=("modal_damping", "quadratic_drag"),
                                                          modes=2))
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(beam_jobs, "default_engine", Engine)
        return list(calibration_stages(key, _drag_decay(seed=8)))


def test_the_job_publishes_the_averaged_preview_first_then_the_full_results(stages):
    assert [s.kind for s in stages] == ["preview", "preview", "final"]
    first, preview, final = (s.value for s in stages)
    assert stages[0].message == AVERAGED_STATUS and first.is_averaged
    assert "averaged preview" in AVERAGED_STATUS and "full calibration running" in AVERAGED_STATUS
    assert stages[1].message == "preview (MAP + Laplace)" and preview.approximation is None
    # a nonlinear free decay is not sampled: its Laplace result is the calibration's final one
    assert stages[2].message == LAPLACE_STATUS and final.final and final.posterior is None


def test_the_label_reaches_the_status_and_the_full_result_replaces_it(stages):
    state = BeamState(dataset="lab_run_1")
    updates = [sch.Update(1, s.kind, s.value, s.fraction, s.message, 0.5 * (i + 1)) for i, s in enumerate(stages)]
    state.run.on_update(updates[0])
    assert state.stage == "preview" and state.result is stages[0].value
    assert state.status == AVERAGED_STATUS
    assert stage_text(state.stage, state.result).startswith("Averaged preview (slow-flow approximation of the drag)")
    assert "Averaged preview" in convergence_html(state.result)
    state.run.on_update(updates[1])
    assert state.result is stages[1].value and state.status == "preview (MAP + Laplace)"
    assert stage_text(state.stage, state.result).startswith("Preview (MAP + Laplace)")
    state.run.on_update(updates[2])
    assert state.stage == "final" and state.result is state.final is stages[2].value
    assert state.status.startswith(LAPLACE_STATUS)
    assert stage_text(state.stage, state.result).startswith("Laplace posterior shown")
    assert "not sampled" in convergence_html(state.result)


def test_an_error_after_the_averaged_preview_keeps_it_shown(stages):
    state = BeamState(dataset="lab_run_1")
    state.run.on_update(sch.Update(1, "preview", stages[0].value, 0.0, AVERAGED_STATUS, 0.5))
    state.run.on_update(sch.Update(1, "error", None, None, "BeamInputError: the integration failed", 1.0))
    assert state.stage == "error" and state.result is stages[0].value
    assert "previous result is still shown" in state.status
