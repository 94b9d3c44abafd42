"""Benchmark of ``beam diagnose`` (run on demand: ``python tests/benchmarks/bench_diagnose.py``).

The whole diagnosis (base preview, residual diagnostics, four candidate calibrations in two
threads, error ladder) of each bundled demonstration record, in a warm process. Target: <= 30 s
on the 2-core machine.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from beam.discovery.report import diagnose  # noqa: E402
from beam.io.measurement import read_measurement  # noqa: E402
from beam.io.simulation import read_truth  # noqa: E402


def main() -> None:
    records = sorted((ROOT / "assets" / "measurements").glob("lab_run_*.csv"))
    diagnose(read_measurement(records[-1]))  # warm-up: imports and numba
    print(f"{'record':12s} {'samples':>8s} {'candidates':>10s} {'seconds':>8s}  found (hidden)")
    worst = 0.0
    for path in records:
        record = read_measurement(path)
        truth = read_truth(ROOT / "assets" / "answers" / f"{path.stem}.truth.toml")
        hidden = [e for e in truth.effects if e not in ("air_damping", "kelvin_voigt")] or [None]
        t0 = time.perf_counter()
        report = diagnose(record)
        seconds = time.perf_counter() - t0
        worst = max(worst, seconds)
        print(f"{path.stem:12s} {record.sample_count:8d} {len(report.ranking.candidates):10d} {seconds:8.1f}  "
              f"{report.missing} ({hidden[0]})")
    print(f"worst {worst:.1f} s; target <= 30 s")


if __name__ == "__main__":
    main()
