"""Benchmark of a free-decay calibration of a real record (run on demand:
``python tests/benchmarks/bench_real.py [RECORD ...]``).

The bundled strip record ``assets/real/adxl_50cm_114655`` (20 s, ~3.9 kHz irregular stamps,
77,533 samples, decimated to ~19,400 by :func:`beam.calibration.records.decimate_measurement`),
acceleration, free decay, 4 modes, window 0-2 s; for each model ``modal_damping``,
``modal_damping,sensor_mass`` and ``modal_damping,tip_mass``:

1. **Preview** (MAP + Laplace + 400-draw bands over the whole record): median of five. Target
   <= 0.2 s.
   With ``modal_damping,sensor_mass`` also the default window (the first 30 %, 0-6 s), for
   reference.
2. **Posterior**: the preview, then emcee until every parameter has bulk ESS >= 1000 and R-hat
   <= 1.01 (window 0-2 s). Target <= 5 s.

Imports (arviz included) and numba compilation are done before timing. Timings on the shared
machine are noisy: the load average is printed, and the process CPU time next to the wall time
(one BLAS thread: the CPU time is what an idle machine would take).
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
from beam.inference._arviz import import_arviz
from beam.io.measurement import read_measurement

MODELS = ("modal_damping", "modal_damping,sensor_mass", "modal_damping,tip_mass")
PREVIEW_TARGET_S = 0.2
PREVIEW_RUNS = 5
POSTERIOR_TARGET_S = 5.0


def timed(function):
    """(result, wall seconds, CPU seconds) of ``function()``."""
    wall, cpu = time.perf_counter(), time.process_time()
    result = function()
    return result, time.perf_counter() - wall, time.process_time() - cpu


def main(records: list[str]) -> None:
    import_arviz()
    for name in records:
        record = read_measurement(ROOT / "assets" / "real" / f"{name}.csv")
        for effects in MODELS:
            print(f"{name}, {effects}; load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
            calibration_preview(record, window=(0.0, 2.0), effects=effects)  # warm: compilation
            runs = [timed(lambda: calibration_preview(record, window=(0.0, 2.0), effects=effects)) for _ in range(PREVIEW_RUNS)]
            result = runs[0][0]
            wall = statistics.median(r[1] for r in runs)
            cpu = statistics.median(r[2] for r in runs)
            print(f"  preview ({int(result.setup.fit_mask.sum())} samples, bands over {result.setup.measurement.time_s.size}):"
                  f" median {wall:.3f} s wall, {cpu:.3f} s CPU (target {PREVIEW_TARGET_S} s)")
            if effects == "modal_damping,sensor_mass":  # the default window (first 30 %), for reference
                runs = [timed(lambda: calibration_preview(record, effects=effects)) for _ in range(PREVIEW_RUNS)]
                print(f"  preview, default window {runs[0][0].setup.window[0]:g}-{runs[0][0].setup.window[1]:.2f} s:"
                      f" median {statistics.median(r[1] for r in runs):.3f} s wall,"
                      f" {statistics.median(r[2] for r in runs):.3f} s CPU (no target)")
            result, wall, cpu = timed(lambda: calibrate(record, window=(0.0, 2.0), effects=effects))
            d = result.posterior.diagnostics
            mass = {k: v for k, v in result.summary().items() if k in ("sensor_mass_kg", "tip_mass_kg")}
            print(f"  posterior: {wall:.2f} s wall, {cpu:.2f} s CPU (target {POSTERIOR_TARGET_S} s), ESS min "
                  f"{d.ess_min:.0f}, R-hat max {d.rhat_max:.4f}"
                  + "".join(f", {k} {v['mean'] * 1e3:.3f} ± {v['sd'] * 1e3:.3f} g" for k, v in mass.items()))


if __name__ == "__main__":
    main(sys.argv[1:] or ["adxl_50cm_114655"])
