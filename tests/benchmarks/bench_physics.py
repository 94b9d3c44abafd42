"""Benchmark of the physics core (run on demand: ``python tests/benchmarks/bench_physics.py``).

Side by side in one run, on the bundled default model (assets/b1tapih.toml: air damping,
Kelvin–Voigt and patch stiffening, so non-proportional damping), 4 modes, 2,000 samples of the
chirp:

1. one forward response, fast modal path vs scipy.signal.lsim on the full state space of the same
   Galerkin model (target >= 100x);
2. 64 parameter sets in one vectorised call vs one call (target < 20x).

Timings are the best of several repeats (the least disturbed by other work on the machine).
"""

from __future__ import annotations

import sys
import timeit
from pathlib import Path

import numpy as np
import scipy.signal

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from beam.io.config import load_config  # noqa: E402
from beam.physics.model import BeamModel, full_state_space  # noqa: E402


def best_seconds(function, number: int, repeat: int = 7) -> float:
    return min(timeit.repeat(function, number=number, repeat=repeat)) / number


def main() -> None:
    config = load_config(ROOT / "assets" / "b1tapih.toml")
    dt = config.sampling.sample_interval_s
    time_s = np.arange(2000) * dt
    voltage = config.excitation.voltage(time_s)
    model = BeamModel(config.geometry, config.effects, config.intervals, config.knots)
    parameters = dict(config.parameters)
    model.response(parameters, voltage, dt, modes=4)  # compile (numba) and warm the shape cache

    matrices = model.system_matrices(parameters)
    a, b, c = full_state_space(matrices["mass"][0], matrices["damping"][0], matrices["stiffness"][0],
                               matrices["force"][0], model.parts.sensor_values)
    state_space = (a, b[:, None], c[None, :], np.zeros((1, 1)))

    def lsim_only():
        scipy.signal.lsim(state_space, voltage, time_s, interp=False)

    def lsim_from_parameters():
        model.response_full(parameters, voltage, dt)

    def fast():
        model.response(parameters, voltage, dt, modes=4)

    def fast_cold():  # mode shapes solved afresh (a change of the patch's ratios)
        model._shape_cache.clear()
        model.response(parameters, voltage, dt, modes=4)

    rng = np.random.default_rng(0)
    batch = {k: v * rng.uniform(0.9, 1.1, 64) for k, v in parameters.items()}

    def batch_cold():  # every set has its own mode shapes (patch ratios differ)
        model._shape_cache.clear()
        model.response(batch, voltage, dt, modes=4)

    # the calibration default (air_damping + kelvin_voigt: one shared shape for every set)
    base_model = BeamModel(config.geometry, ["air_damping", "kelvin_voigt"], config.intervals, config.knots)
    base_parameters = {k: v for k, v in parameters.items() if k in base_model.parameter_names}
    base_batch = {k: v * rng.uniform(0.9, 1.1, 64) for k, v in base_parameters.items()}
    base_model.response(base_batch, voltage, dt, modes=4)

    def base_single():
        base_model.response(base_parameters, voltage, dt, modes=4)

    def base_batch_call():
        base_model.response(base_batch, voltage, dt, modes=4)

    t_lsim = best_seconds(lsim_only, 5)
    t_lsim_params = best_seconds(lsim_from_parameters, 5)
    t_fast = best_seconds(fast, 500)
    t_cold = best_seconds(fast_cold, 200)
    t_batch = best_seconds(batch_cold, 20)
    t_base = best_seconds(base_single, 500)
    t_base_batch = best_seconds(base_batch_call, 50)

    print(f"default model: {', '.join(config.effects)}; {model.size} Galerkin dofs; 4 modes; 2000 samples (chirp)")
    print(f"{'measurement':58s} {'time':>10s} {'ratio':>9s}  target")
    rows = [
        ("scipy.signal.lsim, full state space (baseline)", t_lsim, "", ""),
        ("lsim incl. building the state space from parameters", t_lsim_params, "", ""),
        ("fast modal response, warm shape cache", t_fast, f"{t_lsim / t_fast:7.0f}x", ">= 100x vs lsim"),
        ("fast modal response, shapes solved afresh", t_cold, f"{t_lsim / t_cold:7.0f}x", "vs lsim"),
        ("64 parameter sets in one call (64 eigen-solves)", t_batch, f"{t_batch / t_cold:7.1f}x", "< 20x one call"),
        ("calibration default model (air+KV), one call", t_base, f"{t_lsim / t_base:7.0f}x", "vs lsim"),
        ("calibration default model, 64 sets in one call", t_base_batch, f"{t_base_batch / t_base:7.1f}x",
         f"vs one call (info: {t_base_batch / 64 * 1e6:.1f} us per set, shared shapes)"),
    ]
    for name, seconds, ratio, target in rows:
        print(f"{name:58s} {seconds * 1e3:8.3f}ms {ratio:>9s}  {target}")


if __name__ == "__main__":
    main()
