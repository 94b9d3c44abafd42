"""The calibration with the clamp friction on real free decays (run on demand:
``python tests/benchmarks/bench_clamp_friction.py [record.csv ...] [--width 0.05] [--window 5]``).

For each record (the shared 50 cm strip runs beside the clone, else the bundled ones in
``assets/real``; width from the command line when the sidecar has none): the record's own
short-time spectral drift of f1 over its free response (:func:`beam.residuals.envelope.spectral_drift`,
negative: the frequency rises as the swing dies), then the calibration preview on 0-W s of
``modal_damping`` + ``sensor_mass`` + ``quadratic_drag`` and of the same plus ``clamp_friction``
(its nested start is the first model's optimum, remembered by the engine), each timed in CPU;
the held-out RMSE after W s (``rmse_prediction``), the gain, the MAP log posteriors (nested: the
friction's never lower), k_f, M_s and their 95 % intervals, and the ratio of the two CPU times.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_drag_calibration import strip_records  # noqa: E402

from beam.calibration import calibration_preview  # noqa: E402
from beam.calibration.engine import Engine  # noqa: E402

BASE = "modal_damping,sensor_mass,quadratic_drag"


def main() -> None:
    args, records = strip_records()
    print("record  base_heldout  friction_heldout  gain  lp_base  lp_friction  k_f  k_f_95%  M_s  M_s_95%  "
          "base_cpu_s  friction_cpu_s  cpu_ratio  load")
    gains = []
    for path, record in records:
        engine = Engine()
        cpu = time.process_time()
        base = calibration_preview(record, window=(0.0, args.window), effects=BASE, engine=engine)
        base_cpu = time.process_time() - cpu
        cpu = time.process_time()
        friction = calibration_preview(record, window=(0.0, args.window), effects=BASE + ",clamp_friction", engine=engine)
        friction_cpu = time.process_time() - cpu
        gain = base.rmse_prediction / friction.rmse_prediction
        gains.append(gain)
        values, summary = friction.laplace.map.values, friction.summary()
        k, m = summary["clamp_friction_stiffness_Nm_rad"], summary["clamp_slip_moment_Nm"]
        print(f"{path.stem}  {base.rmse_prediction:.4f}  {friction.rmse_prediction:.4f}  {gain:.2f}  "
              f"{base.laplace.map.log_posterior:.1f}  {friction.laplace.map.log_posterior:.1f}  "
              f"{values['clamp_friction_stiffness_Nm_rad']:.0f}  {k['q025']:.0f}-{k['q975']:.0f}  "
              f"{values['clamp_slip_moment_Nm']:.4f}  {m['q025']:.4f}-{m['q975']:.4f}  {base_cpu:.1f}  "
              f"{friction_cpu:.1f}  {friction_cpu / base_cpu:.1f}  {os.getloadavg()[0]:.1f}", flush=True)
    print(f"gain >= 1.3 on {sum(g >= 1.3 for g in gains)} of {len(gains)} runs, below 1 on {sum(g < 1 for g in gains)}")


if __name__ == "__main__":
    main()
