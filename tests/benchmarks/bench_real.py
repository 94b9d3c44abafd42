"""Benchmark of a free-decay calibration of a real record (run on demand:
``python tests/benchmarks/bench_real.py``).

The bundled strip record ``assets/real/adxl_50cm_114655`` (20 s, ~3.9 kHz irregular stamps,
77,533 samples, decimated to ~19,400 by :func:`beam.calibration.records.decimate_measurement`),
acceleration, free decay; model ``modal_damping,sensor_mass``, 4 modes, window 0-2 s and the
default window (first 30 %).

1. **Preview** (MAP + Laplace + 400-draw bands over the whole record): median of three. Target
   <= 0.2 s.
2. **Posterior**: emcee until every parameter has bulk ESS >= 1000 (window 0-2 s). Target <= 5 s.

Imports and numba compilation are done before timing. Timings on the shared machine are noisy:
the load average is printed.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from beam.calibration import calibrate, calibration_preview
from beam.io.measurement import read_measurement

EFFECTS = "modal_damping,sensor_mass"


def main() -> None:
    record = read_measurement(ROOT / "assets" / "real" / "adxl_50cm_114655.csv")
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    calibration_preview(record, window=(0.0, 2.0), effects=EFFECTS)  # warm: imports and compilation
    for window in ((0.0, 2.0), None):
        times = []
        for _ in range(3):
            t0 = time.perf_counter()
            result = calibration_preview(record, window=window, effects=EFFECTS)
            times.append(time.perf_counter() - t0)
        print(f"preview, window {result.setup.window[0]:g}-{result.setup.window[1]:g} s "
              f"({int(result.setup.fit_mask.sum())} samples): median {statistics.median(times):.3f} s "
              f"(target 0.2 s); fit {result.laplace.seconds:.3f} s")
    t0 = time.perf_counter()
    result = calibrate(record, window=(0.0, 2.0), effects=EFFECTS)
    seconds = time.perf_counter() - t0
    d = result.posterior.diagnostics
    print(f"posterior, window 0-2 s: {seconds:.2f} s (target 5 s), ESS min {d.ess_min:.0f}, R-hat max "
          f"{d.rhat_max:.4f}, sensor_mass_kg {result.summary()['sensor_mass_kg']}")


if __name__ == "__main__":
    main()
