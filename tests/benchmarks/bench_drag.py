"""Benchmark of the quadratic drag's forward model (run on demand: ``python tests/benchmarks/bench_drag.py [record.csv]``).

The 50 cm aluminium strip's free decay (20 s at ~4 kHz, irregular stamps; the bundled
``assets/real/adxl_50cm_114655.csv`` by default, width 50 mm): one free response of the sensor's
acceleration at every stamp, 4 modes, for ``modal_damping`` + ``sensor_mass`` (the linear
model, exact modal exponentials) and for the same plus ``quadratic_drag`` (ETDRK4 with the drag
by quadrature at 16 Gauss points), one parameter set and a batch of 32 (as a calibration's
design evaluates them); the ratio to the linear model in the same run. Timings are the best of
several repeats (the least disturbed by other work on the machine).
"""

from __future__ import annotations

import dataclasses
import sys
import timeit
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from beam.io.measurement import read_measurement  # noqa: E402
from beam.physics.model import BeamModel  # noqa: E402

BASE = ["modal_damping", "sensor_mass"]
#: Near the MAP of the strip's first run calibrated on 0-5 s with the drag.
PARAMETERS = {"bending_stiffness_Nm2": 2.136, "sensor_mass_kg": 0.00403, "damping_ratio_mode_1": 0.0013,
              "damping_ratio_mode_2": 0.0044, "damping_ratio_mode_3": 0.015, "damping_ratio_mode_4": 0.03}


def best_seconds(function, number: int = 1, repeat: int = 5) -> float:
    return min(timeit.repeat(function, number=number, repeat=repeat)) / number


def main() -> None:
    path = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "assets" / "real" / "adxl_50cm_114655.csv"
    record = read_measurement(path)
    geometry = dataclasses.replace(record.geometry, width_m=0.05)
    time = record.time_s
    linear = BeamModel(geometry, BASE, input_kind=None)
    drag = BeamModel(geometry, BASE + ["quadratic_drag"], input_kind=None)
    _, shapes = linear.mode_shapes(PARAMETERS, 4)
    eta = np.array([0.02, 0.001, 0.0, 0.0]) / (linear.parts.tip_values @ shapes)
    with_drag = dict(PARAMETERS, drag_coefficient=15.0)
    rng = np.random.default_rng(0)
    batch = {k: v * (1 + 0.01 * rng.standard_normal(32)) for k, v in with_drag.items()}
    batch_linear = {k: v for k, v in batch.items() if k != "drag_coefficient"}
    for model, values in ((linear, PARAMETERS), (drag, with_drag)):  # compile
        model.free_response(values, time[:100], eta, modes=4, output="acceleration")

    print(f"{path.name}: {time.size} samples over {time[-1] - time[0]:.1f} s, 4 modes, acceleration")
    for label, lin_values, drag_values, count in (("1 set", PARAMETERS, with_drag, 1),
                                                   ("32 sets", batch_linear, batch, 32)):
        t_linear = best_seconds(lambda: linear.free_response(lin_values, time, eta, modes=4, output="acceleration"))
        t_drag = best_seconds(lambda: drag.free_response(drag_values, time, eta, modes=4, output="acceleration"))
        print(f"  {label}: linear {t_linear * 1e3:.1f} ms, with the drag {t_drag * 1e3:.1f} ms "
              f"({t_drag / count * 1e3:.1f} ms per set), ratio {t_drag / t_linear:.0f}x")


if __name__ == "__main__":
    main()
