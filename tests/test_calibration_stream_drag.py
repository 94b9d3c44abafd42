"""The calibration stream of a free decay with the air drag: the averaged (slow-flow) drag
model's preview first, labelled, then the full model's results (beam.calibration.run)."""

from __future__ import annotations

import logging

import numpy as np
import pytest
from test_calibration_drag import TRUTH, _drag_decay

from beam.calibration import calibration_preview, calibration_stream
from beam.calibration.engine import Engine
from beam.calibration.free_averaged import AVERAGED_NOTE, AveragedDragModel
from beam.errors import BeamInputError

WINDOW = (0.0, 4.0)
DRAG = "modal_damping,quadratic_drag"


@pytest.fixture(scope="module")
def record():
    """A simulated accelerometer decay of the 50 mm strip under the drag (C_d = 12), 8 s at 1 kHz."""
    return _drag_decay(seed=8)


@pytest.fixture(scope="module")
def drag_events(record):
    """The first two results of the drag model's stream (a fresh engine)."""
    stream = calibration_stream(record, window=WINDOW, effects=DRAG, modes=2, engine=Engine())
    events = [next(stream), next(stream)]
    stream.close()
    return events


def test_the_first_event_is_the_averaged_preview_labelled_as_such(drag_events):
    first, second = drag_events
    assert first.is_averaged and first.approximation == AVERAGED_NOTE and "averaged" in first.approximation
    assert AVERAGED_NOTE in first.laplace.warnings
    assert first.is_preview and not first.final
    assert second.approximation is None and not second.is_averaged and AVERAGED_NOTE not in second.laplace.warnings


def test_the_averaged_preview_recovers_the_drag_within_its_documented_bias(record, drag_events):
    """C_d's 95 % interval of the averaged preview reaches the truth within the averaged model's
    bias (10 % of C_d on this decay, tests/test_calibration_drag_averaged.py), EI within 0.1 %
    (the frequency, which the drag leaves alone at first order); its bands are drawn from the
    free response's start (NaN before), and the held-out part (4-8 s) is predicted with its
    95 % prediction band holding at least 90 % of the samples, better than the model without the
    drag predicts it."""
    first, _ = drag_events
    summary = first.summary()
    low, high = summary["drag_coefficient"]["q025"], summary["drag_coefficient"]["q975"]
    truth = TRUTH["drag_coefficient"]
    assert low < high
    assert max(low - truth, truth - high, 0.0) <= 0.1 * truth
    assert first.laplace.map.values["bending_stiffness_Nm2"] == pytest.approx(TRUTH["bending_stiffness_Nm2"], rel=1e-3)
    start = first.setup.free_start_indices[1]
    assert np.all(np.isnan(first.bands.mean[:start])) and np.all(np.isfinite(first.bands.mean[start:]))
    assert np.all(first.bands.credible_lower[start:] <= first.bands.mean[start:])
    assert np.all(first.bands.prediction_upper[start:] >= first.bands.credible_upper[start:])
    assert first.coverage95_prediction >= 0.9
    linear = calibration_preview(record, window=WINDOW, effects="modal_damping", modes=2, engine=Engine())
    assert first.rmse_prediction < linear.rmse_prediction


def test_the_averaged_bands_are_the_averaged_models_draws_linearised(drag_events):
    """Second method: Laplace draws of the averaged model's physical parameters pushed through
    its closed-form response (amplitudes and offset re-fitted on the window for each draw, as
    the linearised band assumes): their pointwise sd on the held-out part agrees with the
    linearised credible band's (median ratio within 25 %: 100 draws), and their mean with its centre."""
    from beam.calibration.free import ProjectedFreeModel

    first, _ = drag_events
    problem = first.problem
    physical = [n for n in problem.names if n not in problem.noise_names]
    d = len(physical)
    model = AveragedDragModel(problem.model)
    held_out = first.setup.measurement.time_s > WINDOW[1]
    record_model = AveragedDragModel(problem.model, first.setup.measurement.time_s[held_out])

    def natural(z):
        return {n: float(problem.parameter(n).prior.from_internal(z[i])) for i, n in enumerate(physical)}

    centre = first.laplace.mean[:d]
    linear = ProjectedFreeModel.fit(problem.model, {n: np.array([v]) for n, v in natural(centre).items()})
    amplitudes = _refit_amplitudes(model, natural(centre), linear["amplitudes"][0], 6)
    rng = np.random.default_rng(3)
    chol = np.linalg.cholesky(first.laplace.cov[:d, :d])
    outputs = []
    for _ in range(100):
        one = natural(centre + chol @ rng.standard_normal(d))
        outputs.append(record_model.response(one, _refit_amplitudes(model, one, amplitudes, 3)))
    outputs = np.array(outputs)
    linearised_sd = (first.bands.credible_upper - first.bands.credible_lower)[held_out] / (2 * 1.959963984540054)
    ratio = np.median(outputs.std(axis=0) / linearised_sd)
    assert 0.75 <= ratio <= 1.25
    scale = np.max(np.abs(first.bands.mean[held_out]))
    assert np.max(np.abs(outputs.mean(axis=0) - first.bands.mean[held_out])) < 0.05 * scale


def _refit_amplitudes(model: AveragedDragModel, one: dict, start: np.ndarray, iterations: int) -> np.ndarray:
    """Amplitudes (and offset) of the averaged model at ``one`` by Gauss–Newton on the window."""
    from beam.calibration.free_averaged import jacobian_of

    a = np.array(start, dtype=float)
    y = model.free.fit_data
    for _ in range(iterations):
        r = y - model.response(one, a)
        jac = jacobian_of(lambda v: model.response(one, v), a, np.full(a.size, 1e-6 * np.max(np.abs(a))))
        a = a + np.linalg.lstsq(jac, r, rcond=None)[0]
    return a


def test_the_next_event_is_the_full_models_exact_preview(record, drag_events):
    """After the averaged preview, the stream goes on unchanged: its next result is the full
    model's MAP, the one calibration_preview finds on a fresh engine (to the last digits)."""
    _, second = drag_events
    exact = calibration_preview(record, window=WINDOW, effects=DRAG, modes=2, engine=Engine())
    np.testing.assert_allclose(second.laplace.mean, exact.laplace.mean, rtol=1e-9, atol=1e-12)
    assert second.laplace.map.log_posterior == pytest.approx(exact.laplace.map.log_posterior, rel=1e-12)


def test_a_model_without_the_drag_streams_no_averaged_event(record):
    first = next(calibration_stream(record, window=WINDOW, effects="modal_damping", modes=2, engine=Engine()))
    assert first.approximation is None and not first.is_averaged and AVERAGED_NOTE not in first.laplace.warnings


@pytest.mark.parametrize("error, level", [
    (BeamInputError("the averaged model needs every retained mode underdamped"), logging.INFO),
    (ValueError("an unforeseen failure of the averaged model"), logging.WARNING),
])
def test_a_failing_averaged_preview_is_logged_and_skipped(record, monkeypatch, caplog, error, level):
    """Where the averaged model does not apply (here forced: an overdamped mode) or fails, the
    stream starts with the full model's preview, and the log says why (a failure other than
    the model's limits as a warning)."""
    def refuse(self, problem, sub_values):
        raise error

    monkeypatch.setattr(AveragedDragModel, "fit_nested", refuse)
    with caplog.at_level(logging.INFO, logger="beam.calibration.run"):
        stream = calibration_stream(record, window=WINDOW, effects=DRAG, modes=2, engine=Engine())
        first = next(stream)
        stream.close()
    assert first.approximation is None and "drag_coefficient" in first.laplace.map.values
    logged = [r for r in caplog.records if r.name == "beam.calibration.run" and r.levelno == level]
    assert logged and (str(error) in logged[0].getMessage() or logged[0].exc_info[1] is error)
