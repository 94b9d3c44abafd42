"""Held-out error of the quadratic drag on real free decays (run on demand:
``python tests/benchmarks/bench_drag_heldout.py [record.csv ...] [--width 0.05] [--window 5]``).

For each record (the bundled 50 cm strip runs in ``assets/real`` by default): the project's
calibration preview of ``modal_damping`` + ``sensor_mass`` on the window 0-W s (its MAP and its
held-out RMSE), then two least-squares fits on the released samples of the same window (scipy
``least_squares``: the log of every physical parameter, the modal initial state (eta, eta') and
the sensor's offset) — the same linear model (a check: it lands on the preview's MAP) and the
model with ``quadratic_drag`` added (the strip's width given on the command line: the sidecars
do not state it) — and the RMSE of each on the held-out samples after W s (after the release
when later). The calibration itself does not fit a nonlinear free decay yet (its free
responses profile the initial state as linear coefficients): this is the measurement of what
the physics gains, with a generic optimiser.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from beam.calibration import calibration_preview  # noqa: E402
from beam.calibration.free import free_start_indices  # noqa: E402
from beam.errors import BeamInputError  # noqa: E402
from beam.io.measurement import read_measurement  # noqa: E402
from beam.physics.model import BeamModel  # noqa: E402

MODES = 4
BASE = ["modal_damping", "sensor_mass"]


def _fit(geometry, effects, names, start, state, time_s, data):
    """Least squares over log(parameters), the modal state and the offset; returns (parameters, state)."""
    model = BeamModel(geometry, effects, input_kind=None)
    k = len(names)

    def residuals(x):
        values = {n: float(np.exp(v)) for n, v in zip(names, x[:k])}
        try:
            return _predict(model, values, x[k:], time_s) - data
        except BeamInputError:
            return np.full(data.size, 1e3)

    x0 = np.concatenate([np.log([start[n] for n in names]), state])
    solution = least_squares(residuals, x0, x_scale="jac", max_nfev=60 * (x0.size + 1))
    return model, {n: float(np.exp(v)) for n, v in zip(names, solution.x[:k])}, solution.x[k:]


def _predict(model, values, state, time_s):
    return model.free_response(values, time_s, state[:MODES], state[MODES:2 * MODES], modes=MODES,
                               output="acceleration") + state[-1]


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("records", nargs="*", type=Path)
    parser.add_argument("--width", type=float, default=0.05, help="strip width (m)")
    parser.add_argument("--window", type=float, default=5.0, help="end of the calibration window (s)")
    args = parser.parse_args()
    records = args.records or sorted((ROOT / "assets" / "real").glob("adxl_*.csv"))
    print("record  release_s  preview_heldout  linear_heldout  drag_heldout  gain  C_d  zeta1(lin)  zeta1(drag)  drag_fit_s")
    for path in records:
        record = read_measurement(path)
        geometry = dataclasses.replace(record.geometry, width_m=args.width)
        preview = calibration_preview(record, window=(0.0, args.window), effects=BASE, modes=MODES)
        names = list(BeamModel(geometry, BASE, input_kind=None).parameter_names_for(MODES))
        start_values = {n: float(preview.laplace.map.values[n]) for n in names}
        time_s, data = record.time_s, record.output
        release = time_s[free_start_indices(record, MODES)[1]]
        window = (time_s >= release) & (time_s < args.window)
        moving = time_s >= release
        held = time_s[moving] >= max(args.window, release)
        linear = BeamModel(geometry, BASE, input_kind=None)
        basis = linear.free_response_basis(start_values, time_s[window], MODES)
        amplitudes, *_ = np.linalg.lstsq(np.column_stack([basis, np.ones(basis.shape[0])]), data[window], rcond=None)
        eta, rate = linear.free_state_from_amplitudes(start_values, amplitudes[:-1], MODES, output="acceleration")
        state = np.concatenate([eta, rate, [amplitudes[-1]]])

        def heldout(model, values, fitted_state):
            error = _predict(model, values, fitted_state, time_s[moving]) - data[moving]
            return float(np.sqrt(np.mean(error[held] ** 2)))

        model, values, fitted = _fit(geometry, BASE, names, start_values, state, time_s[window], data[window])
        linear_error = heldout(model, values, fitted)
        clock = time.perf_counter()
        model_d, values_d, fitted_d = _fit(geometry, BASE + ["quadratic_drag"], names + ["drag_coefficient"],
                                           dict(values, drag_coefficient=3.0), fitted, time_s[window], data[window])
        seconds = time.perf_counter() - clock
        drag_error = heldout(model_d, values_d, fitted_d)
        preview_error = float(preview.rmse_prediction)
        print(f"{path.stem}  {release:.3f}  {preview_error:.4f}  {linear_error:.4f}  {drag_error:.4f}  "
              f"{linear_error / drag_error:.2f}  {values_d['drag_coefficient']:.1f}  {values['damping_ratio_mode_1']:.5f}  "
              f"{values_d['damping_ratio_mode_1']:.5f}  {seconds:.0f}", flush=True)


if __name__ == "__main__":
    main()
