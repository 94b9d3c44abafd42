"""Benchmark of the tip cubic spring's forward model (run on demand: ``python tests/benchmarks/bench_nonlinear.py``).

One batched call as the sampler makes it: 24 parameter sets around lab_run_4's truth, its 4,000
samples (1 kHz, 40 V pulse), 4 modes, with the automatic substeps (sized by the spring force's
content, :func:`beam.physics.nonlinear.choose_substeps`) and, side by side, with the 27 substeps
per sample that sizing by 3x the highest kept mode gave on this record; and the peak-relative
difference between the two (both are within 1e-8 of a solve_ivp reference, tests/test_nonlinear.py).
Timings are the best of several repeats (the least disturbed by other work on the machine).
"""

from __future__ import annotations

import sys
import timeit
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from beam.io.measurement import read_measurement  # noqa: E402
from beam.physics.geometry import BeamGeometry  # noqa: E402
from beam.physics.model import BeamModel  # noqa: E402
from beam.physics.nonlinear import choose_substeps, integrate_tip_cubic  # noqa: E402

EFFECTS = ["air_damping", "kelvin_voigt", "tip_cubic_spring"]
OLD_RULE_SUBSTEPS = 27  # ceil(3 |lambda_4| dt / 0.15) on lab_run_4


def best_seconds(function, number: int = 3, repeat: int = 7) -> float:
    return min(timeit.repeat(function, number=number, repeat=repeat)) / number


def main() -> None:
    measurement = read_measurement(ROOT / "assets" / "measurements" / "lab_run_4.csv")
    voltage, dt = measurement.voltage_V, float(measurement.time_s[1] - measurement.time_s[0])
    model = BeamModel(BeamGeometry(0.4573, 0.093, 0.15, 0.25, 0.40), EFFECTS)
    rng = np.random.default_rng(0)
    truth = {"bending_stiffness_Nm2": 0.491, "patch_coupling_NmV": 1.746e-2, "air_damping_Ns_m2": 0.02,
             "kelvin_voigt_Nm2s": 0.649e-5, "tip_cubic_stiffness_N_m3": 1.5e4}
    batch = {k: v * (1 + 0.01 * rng.standard_normal(24)) for k, v in truth.items()}
    system = model.modal_system(batch, modes=4)
    cubic = batch["tip_cubic_stiffness_N_m3"]
    substeps = choose_substeps(system, cubic, voltage, dt)
    model.response(batch, voltage, dt, modes=4)  # compile

    automatic = best_seconds(lambda: model.response(batch, voltage, dt, modes=4))
    fixed = best_seconds(lambda: integrate_tip_cubic(system, cubic, voltage, dt, substeps=OLD_RULE_SUBSTEPS))
    new = integrate_tip_cubic(system, cubic, voltage, dt, substeps=substeps)
    old = integrate_tip_cubic(system, cubic, voltage, dt, substeps=OLD_RULE_SUBSTEPS)
    print(f"lab_run_4, 24 parameter sets, {voltage.size} samples, 4 modes")
    print(f"  automatic substeps {int(substeps.min())}-{int(substeps.max())}: forward call {automatic * 1e3:.1f} ms")
    print(f"  {OLD_RULE_SUBSTEPS} substeps (3x highest kept mode): integration {fixed * 1e3:.1f} ms")
    print(f"  difference between the two: {np.abs(new - old).max() / np.abs(old).max():.1e} of the peak")


if __name__ == "__main__":
    main()
