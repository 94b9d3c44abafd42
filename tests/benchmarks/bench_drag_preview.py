"""Time to the first event of a calibration with the quadratic drag, against the linear model's
(run on demand: ``python tests/benchmarks/bench_drag_preview.py [record.csv ...] [--width 0.05] [--window 5]``).

What a user waits for before anything is on screen. For each record (the shared 50 cm strip runs
beside the clone, else the bundled ones in ``assets/real``; width from the command line when the
sidecar has none), after one untimed warm-up stream (the compiled kernels' first calls):

- the linear model (``modal_damping`` + ``sensor_mass``) with a fresh engine: the wall and CPU
  time to the first event of :func:`beam.calibration.calibration_stream` (its calibration
  preview), the baseline;
- the same plus ``quadratic_drag`` with a fresh engine (cold): the time to its first event (the
  averaged drag preview, the first look of :func:`beam.calibration.run.calibration_stream`, which includes the linear
  sub-model's preview it starts from) and its ratio to the baseline;
- the same with the linear model's engine (warm: the user ticks the drag after calibrating the
  linear model, whose MAP the engine remembers once its preview's two stages are done): the time to its first event and its ratio to
  the baseline, then the time to the second event (the full model's MAP, which integrates the
  decay), and C_d of both.

The issue's target: the drag's preview within 1 s on the 20 s, 4 kHz records. CPU times are
printed beside the wall times (the machine may be shared), with the 1-minute load average.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from beam.calibration import calibration_preview, calibration_stream  # noqa: E402
from beam.calibration.engine import Engine  # noqa: E402
from bench_drag_calibration import BASE, strip_records  # noqa: E402


def _timed_next(stream):
    """The next event of ``stream`` and the wall and CPU seconds it took."""
    clock, cpu = time.perf_counter(), time.process_time()
    event = next(stream)
    return event, time.perf_counter() - clock, time.process_time() - cpu


def main() -> None:
    args, records = strip_records()
    print("record  duration_s  rate_Hz  linear_s  linear_cpu_s  cold_s  cold_cpu_s  cold_ratio  cold_cpu_ratio  "
          "warm_s  warm_cpu_s  warm_ratio  warm_cpu_ratio  averaged  full_map_s  avg_C_d  full_C_d  load")
    worst = 0.0
    for path, record in records:
        window, drag_effects = (0.0, args.window), BASE + ",quadratic_drag"
        warm_up = calibration_stream(record, window=window, effects=drag_effects, engine=Engine())
        next(warm_up)
        warm_up.close()
        engine = Engine()
        linear = calibration_stream(record, window=window, effects=BASE, engine=engine)
        _, linear_s, linear_cpu = _timed_next(linear)
        linear.close()
        calibration_preview(record, window=window, effects=BASE, engine=engine)  # its MAP, as a finished run leaves it
        cold = calibration_stream(record, window=window, effects=drag_effects, engine=Engine())
        _, cold_s, cold_cpu = _timed_next(cold)
        cold.close()
        drag = calibration_stream(record, window=window, effects=drag_effects, engine=engine)
        first, warm_s, warm_cpu = _timed_next(drag)
        full, full_s, _ = _timed_next(drag)
        drag.close()
        worst = max(worst, cold_s)
        duration = float(record.time_s[-1] - record.time_s[0])
        rate = (record.time_s.size - 1) / duration
        print(f"{path.stem}  {duration:.1f}  {rate:.0f}  {linear_s:.2f}  {linear_cpu:.2f}  {cold_s:.2f}  {cold_cpu:.2f}  "
              f"{cold_s / linear_s:.2f}  {cold_cpu / linear_cpu:.2f}  {warm_s:.2f}  {warm_cpu:.2f}  "
              f"{warm_s / linear_s:.2f}  {warm_cpu / linear_cpu:.2f}  {first.is_averaged}  {warm_s + full_s:.1f}  "
              f"{first.laplace.map.values['drag_coefficient']:.1f}  {full.laplace.map.values['drag_coefficient']:.1f}  "
              f"{os.getloadavg()[0]:.1f}", flush=True)
    print(f"slowest first event with the drag, cold: {worst:.2f} s (target 1 s)")


if __name__ == "__main__":
    main()
