"""Benchmark of the beam calibration (run on demand: ``python tests/benchmarks/bench_calibration.py``).

1. **Preview** (:func:`beam.calibration.calibration_preview`: MAP + Laplace + 400-draw bands over
   the whole record), what the dashboard computes on every slider move: each bundled record
   (``assets/measurements``), windows ending at 30, 32, 35 and 40 % of the record, three
   repeats; median per record and over all, wall and CPU time, single-threaded BLAS. Target
   <= 0.12 s median. Beside it the reference path it replaced (:func:`beam.inference.preview`
   — :func:`~beam.inference.find_map` + Laplace — and ``LaplaceResult.predict``, on the same
   problem and starts, one repeat) and the warm-started preview (each window started from the
   previous window's MAP, as the dashboard does on a slider move).
2. **Posterior**: the bundled B1TAPIH record (simulated from assets/b1tapih.toml), the default
   model (air_damping + kelvin_voigt, 4 modes), the default window (first 30 %, 1,410 samples),
   emcee until every parameter has bulk ESS >= 1000. Target on the 2-core machine: <= 3 s.
   Also printed: the same sampler's estimated time with scipy.signal.lsim as the forward model
   (the number of model evaluations it made times lsim's cost for one, measured here) and the
   ratio.

Imports and numba compilation are done before timing (a warm process, as in the dashboard).
Timings on the shared machine are noisy: the load average is printed.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy: single-threaded BLAS

import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import timeit  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from beam.calibration import calibrate, calibration_preview, prepare  # noqa: E402
from beam.calibration.bands import fast_predictive_bands  # noqa: E402
from beam.calibration.run import BAND_DRAWS, default_walkers, preview_fit  # noqa: E402
from beam.inference import EnsembleRun, preview  # noqa: E402
from beam.io.config import load_config  # noqa: E402
from beam.io.measurement import read_measurement  # noqa: E402
from beam.io.simulation import simulate  # noqa: E402
from beam.physics.model import full_state_space  # noqa: E402

#: Window ends (fractions of the record) of the preview benchmark: slider positions.
PREVIEW_WINDOW_ENDS = (0.3, 0.32, 0.35, 0.4)
PREVIEW_REPEATS = 3


def reference_preview(record, window):
    """The preview by the reference path: find_map + Laplace, then LaplaceResult.predict."""
    setup, problem = prepare(record, window=window)
    laplace = preview(problem)
    laplace.predict(setup.measurement.time_s, n_draws=BAND_DRAWS, seed=0)


def timed(function, *args, **kwargs) -> tuple[float, float, object]:
    """Wall and CPU time (s) of one call, and its result."""
    wall, cpu = time.perf_counter(), time.process_time()
    result = function(*args, **kwargs)
    return time.perf_counter() - wall, time.process_time() - cpu, result


def bench_previews() -> None:
    """Preview times on the bundled records: new (cold and warm-started) and reference."""
    records = [read_measurement(path) for path in sorted((ROOT / "assets" / "measurements").glob("*.csv"))]
    print(f"preview (MAP + Laplace + {BAND_DRAWS}-draw bands), windows ending at "
          f"{', '.join(f'{f:.0%}' for f in PREVIEW_WINDOW_ENDS)} of each record; load average {os.getloadavg()[0]:.1f}")
    print(f"{'record':12s} {'new wall':>9s} {'new cpu':>8s} {'warm wall':>10s} {'reference':>10s} {'speed-up':>9s}")
    everything: dict[str, list[float]] = {"wall": [], "cpu": [], "warm": [], "reference": []}
    for record in records:
        end = record.time_s[-1]
        windows = [(0.0, f * end) for f in PREVIEW_WINDOW_ENDS]
        calibration_preview(record, window=windows[0])  # warm-up (numba compilation, caches)
        times: dict[str, list[float]] = {key: [] for key in everything}
        for _ in range(PREVIEW_REPEATS):
            previous = calibration_preview(record, window=(0.0, 0.28 * end))
            for window in windows:
                wall, cpu, _ = timed(calibration_preview, record, window=window)
                times["wall"].append(wall)
                times["cpu"].append(cpu)
                wall, _, previous = timed(calibration_preview, record, window=window, start=previous.laplace.map.values)
                times["warm"].append(wall)
        for window in windows:
            times["reference"].append(timed(reference_preview, record, window)[0])
        median = {key: statistics.median(value) for key, value in times.items()}
        for key, value in times.items():
            everything[key] += value
        print(f"{record.name:12s} {median['wall']:9.3f} {median['cpu']:8.3f} {median['warm']:10.3f} "
              f"{median['reference']:10.3f} {median['reference'] / median['wall']:8.1f}x")
    median = {key: statistics.median(value) for key, value in everything.items()}
    print(f"{'median':12s} {median['wall']:9.3f} {median['cpu']:8.3f} {median['warm']:10.3f} {median['reference']:10.3f} "
          f"{median['reference'] / median['wall']:8.1f}x   target <= 0.12 s (s; load average now {os.getloadavg()[0]:.1f})")


def main() -> None:
    bench_previews()
    print()
    config = load_config(ROOT / "assets" / "b1tapih.toml")
    record = simulate(config).measurement("b1tapih")
    calibrate(record, seed=0, max_steps=200)  # warm-up: imports, numba, ArviZ

    setup, problem = prepare(record)
    n_window = int(setup.window_mask.sum())
    previews = []
    for _ in range(5):
        setup, problem = prepare(record)
        t0 = time.perf_counter()
        preview_fit(problem)
        previews.append(time.perf_counter() - t0)
    t_preview = min(previews)

    # the posterior: MAP + Laplace, then emcee until ESS >= 1000 and R-hat <= 1.01 (what the
    # target is about); the predictive bands over the record are timed apart
    setup, problem = prepare(record)
    t0 = time.perf_counter()
    laplace = preview_fit(problem)
    run = EnsembleRun(problem, laplace, n_walkers=default_walkers(problem.ndim), seed=1)
    for _ in run.sample_to_ess(1000.0, every=1000):
        pass
    posterior = run.result(target_ess=1000.0)
    t_posterior = time.perf_counter() - t0
    t0 = time.perf_counter()
    fast_predictive_bands(problem, posterior.thinned_draws(BAND_DRAWS, 1), record.time_s)
    t_bands = time.perf_counter() - t0
    t0 = time.perf_counter()
    posterior.predict(record.time_s, n_draws=BAND_DRAWS, seed=1)
    t_bands_reference = time.perf_counter() - t0
    diagnostics = posterior.diagnostics
    evaluations = problem.n_model_rows
    result = calibrate(record, seed=1)

    # lsim on the full state space of the same model for one parameter set on the window
    model = setup.model
    parameters = {k: v["mean"] for k, v in result.summary().items() if k in model.parameter_names}
    matrices = model.system_matrices(parameters)
    a, b, c = full_state_space(matrices["mass"][0], matrices["damping"][0], matrices["stiffness"][0],
                               matrices["force"][0], model.parts.sensor_values)
    import scipy.signal

    time_s = record.time_s[:n_window] - record.time_s[0]
    voltage = record.voltage_V[:n_window]
    t_lsim = min(timeit.repeat(lambda: scipy.signal.lsim((a, b[:, None], c[None, :], np.zeros((1, 1))), voltage, time_s, interp=False),
                               number=3, repeat=5)) / 3
    t_lsim_total = evaluations * t_lsim

    print(f"record: {record.sample_count} samples; window {setup.window[0]:g}-{setup.window[1]:g} s ({n_window} samples); "
          f"effects {', '.join(setup.effects)}; {setup.modes} modes")
    print(f"MAP + Laplace (no bands)      {t_preview * 1e3:8.1f} ms")
    print(f"posterior to ESS >= 1000      {t_posterior:8.2f} s    target <= 3 s   "
          f"(ESS min {diagnostics.ess_min:.0f}, R-hat max {diagnostics.rhat_max:.4f}, {diagnostics.n_walkers} walkers x "
          f"{diagnostics.n_steps} steps, converged {diagnostics.converged})")
    print(f"predictive bands (400 draws x {record.sample_count} samples) {t_bands * 1e3:6.0f} ms  (not part of the posterior; "
          f"{t_bands_reference * 1e3:.0f} ms by beam.inference.predictive_bands)")
    print(f"model evaluations             {evaluations:8d}")
    print(f"lsim, one evaluation          {t_lsim * 1e3:8.2f} ms")
    print(f"same sampler on lsim (est.)   {t_lsim_total:8.1f} s    ratio {t_lsim_total / t_posterior:.0f}x")


if __name__ == "__main__":
    main()
