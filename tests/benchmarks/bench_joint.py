"""Benchmark of the joint calibration (run on demand: ``python tests/benchmarks/bench_joint.py``).

Four free-decay records of one strip (the shared 50 cm runs: ``../shared/real-data`` beside the
clone, or the folder given as the first argument), 0–2 s windows, sensor mass + modal damping,
two modes: the joint calibration of the four against the single calibration of the first, in one
run (fresh engines, so no optimum is remembered; imports and numba compilation done first).

1. **Preview** (MAP + Laplace): :func:`beam.calibration.joint.joint_preview` of the four against
   :func:`beam.calibration.calibration_preview` of one. Target: ratio <= 4.
2. **Posterior**: the same plus :data:`STEPS` emcee steps (default walkers: 2 x 4 ensembles x
   parameters, so the joint ensemble is larger by the records' noise parameters), printed beside.

Timings on the shared machine are noisy: the load average is printed.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy: single-threaded BLAS

import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from beam.calibration import Engine, calibrate, calibration_preview  # noqa: E402
from beam.calibration.joint import joint_calibrate, joint_preview  # noqa: E402
from beam.io.measurement import read_measurement  # noqa: E402

RUNS = ("adxl_50cm_114655", "adxl_50cm_114732", "adxl_50cm_114828", "adxl_50cm_114909")
OPTIONS = dict(window=(0.0, 2.0), effects="sensor_mass,modal_damping", modes=2)
STEPS = 300
TARGET_RATIO = 4.0


def timed(function, *args, **kwargs):
    t0 = time.perf_counter()
    out = function(*args, **kwargs)
    return time.perf_counter() - t0, out


def main() -> int:
    folder = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT.parent / "shared" / "real-data"
    records = [read_measurement(folder / f"{run}.csv") for run in RUNS]
    calibration_preview(records[0], engine=Engine(), **OPTIONS)  # imports, numba compilation
    print(f"load average {os.getloadavg()[0]:.2f}")
    one, single = timed(calibration_preview, records[0], engine=Engine(), **OPTIONS)
    four, joint = timed(joint_preview, records, engine=Engine(), **OPTIONS)
    ratio = four / one
    print(f"preview: one record {one:.2f} s, four jointly {four:.2f} s, ratio {ratio:.2f} (target <= {TARGET_RATIO:g})")
    mass = joint.summary()["sensor_mass_kg"]
    print(f"  joint sensor mass {1e3 * mass['mean']:.4f} g (sd {1e3 * mass['sd']:.4f} g); one record "
          f"{1e3 * single.summary()['sensor_mass_kg']['mean']:.4f} g")
    one_full, _ = timed(calibrate, records[0], engine=Engine(), steps=STEPS, **OPTIONS)
    four_full, _ = timed(joint_calibrate, records, engine=Engine(), steps=STEPS, **OPTIONS)
    print(f"posterior ({STEPS} emcee steps): one record {one_full:.2f} s, four jointly {four_full:.2f} s, "
          f"ratio {four_full / one_full:.2f}")
    print(f"load average {os.getloadavg()[0]:.2f}")
    return 0 if ratio <= TARGET_RATIO else 1


if __name__ == "__main__":
    raise SystemExit(main())
