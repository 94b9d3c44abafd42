"""Benchmark of the beam calibration (run on demand: ``python tests/benchmarks/bench_calibration.py``).

The baseline posterior: the bundled B1TAPIH record (simulated from assets/b1tapih.toml), the
default model (air_damping + kelvin_voigt, 4 modes), the default window (first 30 %, 1,410
samples), emcee until every parameter has bulk ESS >= 1000. Targets on the 2-core machine:
posterior <= 3 s, preview (MAP + Laplace) <= 0.3 s. Also printed: the same sampler's estimated
time with scipy.signal.lsim as the forward model (the number of model evaluations it made times
lsim's cost for one, measured here) and the ratio. Imports and numba compilation are done
before timing (a warm process, as in the dashboard).
"""

from __future__ import annotations

import sys
import time
import timeit
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from beam.calibration import calibrate, prepare  # noqa: E402
from beam.calibration.run import default_walkers  # noqa: E402
from beam.config import load_config  # noqa: E402
from beam.inference import EnsembleRun, preview  # noqa: E402
from beam.model import full_state_space  # noqa: E402
from beam.simulation import simulate  # noqa: E402


def main() -> None:
    config = load_config(ROOT / "assets" / "b1tapih.toml")
    record = simulate(config).measurement("b1tapih")
    calibrate(record, seed=0, max_steps=200)  # warm-up: imports, numba, ArviZ

    setup, problem = prepare(record)
    n_window = int(setup.window_mask.sum())
    previews = []
    for _ in range(5):
        setup, problem = prepare(record)
        t0 = time.perf_counter()
        preview(problem)
        previews.append(time.perf_counter() - t0)
    t_preview = min(previews)

    # the posterior: MAP + Laplace, then emcee until ESS >= 1000 and R-hat <= 1.01 (what the
    # target is about); the predictive bands over the record are timed apart
    setup, problem = prepare(record)
    t0 = time.perf_counter()
    laplace = preview(problem)
    run = EnsembleRun(problem, laplace, n_walkers=default_walkers(problem.ndim), seed=1)
    for _ in run.sample_to_ess(1000.0, every=1000):
        pass
    posterior = run.result(target_ess=1000.0)
    t_posterior = time.perf_counter() - t0
    t0 = time.perf_counter()
    posterior.predict(record.time_s, n_draws=400, seed=1)
    t_bands = time.perf_counter() - t0
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
    print(f"preview (MAP + Laplace)       {t_preview * 1e3:8.1f} ms   target <= 300 ms")
    print(f"posterior to ESS >= 1000      {t_posterior:8.2f} s    target <= 3 s   "
          f"(ESS min {diagnostics.ess_min:.0f}, R-hat max {diagnostics.rhat_max:.4f}, {diagnostics.n_walkers} walkers x "
          f"{diagnostics.n_steps} steps, converged {diagnostics.converged})")
    print(f"predictive bands (400 draws x {record.sample_count} samples) {t_bands * 1e3:6.0f} ms  (not part of the posterior)")
    print(f"model evaluations             {evaluations:8d}")
    print(f"lsim, one evaluation          {t_lsim * 1e3:8.2f} ms")
    print(f"same sampler on lsim (est.)   {t_lsim_total:8.1f} s    ratio {t_lsim_total / t_posterior:.0f}x")


if __name__ == "__main__":
    main()
