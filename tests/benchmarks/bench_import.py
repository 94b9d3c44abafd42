"""Benchmark of ``beam import`` on a phone-sized record (run on demand:
``python tests/benchmarks/bench_import.py``).

A 20 s, 4 kHz, three-axis phyphox export (semicolon separator, decimal comma: the variant that
takes pandas' slowest path, ten significant digits, 80,000 rows, ~4.6 MB) of a decaying
two-mode pluck. Timed, median of five after one warm run (imports and numba compilation
done): the *summary* (read, choose the axis, clean the stamps, look for plucks, spectral peaks
and the ideal beam's modes: what ``beam import`` prints before it writes anything), target
<= 2 s; and the whole command (the summary, then PREFIX.csv at full precision and PREFIX.toml
written atomically), for reference.
Baseline in the same run: :func:`pandas.read_csv` of the same file alone (the parse every
reader needs), so the ratio says what the reader adds to reading the text. Wall and process
CPU time are printed with the load average (the machine is shared).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import contextlib
import io
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from beam.cli.import_command import summarise  # noqa: E402
from beam.cli.main import build_parser  # noqa: E402
from beam.cli.main import main as beam_main  # noqa: E402
from tests.record_files import write_phyphox_csv  # noqa: E402

TARGET_S = 2.0
RUNS = 5
RATE_HZ, DURATION_S = 4000.0, 20.0


def timed(function):
    """(wall seconds, CPU seconds) of ``function()``."""
    wall, cpu = time.perf_counter(), time.process_time()
    function()
    return time.perf_counter() - wall, time.process_time() - cpu


def main() -> None:
    import pandas as pd

    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        t = np.arange(0, DURATION_S, 1 / RATE_HZ)
        rng = np.random.default_rng(0)
        z = 3 * np.exp(-0.3 * t) * np.sin(2 * np.pi * 6.0 * t) + np.exp(-2 * t) * np.sin(2 * np.pi * 38 * t)
        axes = {"x": 0.05 * rng.normal(size=t.size), "y": 9.81 + 0.02 * rng.normal(size=t.size),
                "z": z + 0.02 * rng.normal(size=t.size)}
        path = write_phyphox_csv(folder / "Raw Data.csv", t, axes, ";", ",")
        print(f"{path.stat().st_size / 1e6:.1f} MB, {t.size:,} rows; load average {os.getloadavg()[0]:.2f} "
              f"on {os.cpu_count()} cores")
        argv = ["import", str(path), "--length", "0.5", "--width", "0.05", "--thickness", "0.002", "--material",
                "aluminium", "--sensor-at", "0.44", "--out", str(folder / "strip")]

        def run_import():
            with contextlib.redirect_stdout(io.StringIO()):
                assert beam_main(argv) == 0

        def run_summary():
            summarise(build_parser().parse_args(argv))

        def run_parse():
            pd.read_csv(path, sep=";", decimal=",")

        run_import()
        summaries = [timed(run_summary) for _ in range(RUNS)]
        imports = [timed(run_import) for _ in range(RUNS)]
        parses = [timed(run_parse) for _ in range(RUNS)]
        wall = statistics.median(w for w, _ in summaries)
        cpu = statistics.median(c for _, c in summaries)
        base = statistics.median(w for w, _ in parses)
        print(f"summary: median {wall:.3f} s wall, {cpu:.3f} s CPU (target <= {TARGET_S} s): "
              f"{'OK' if wall <= TARGET_S else 'SLOW'}")
        print(f"whole beam import (with the files written): median {statistics.median(w for w, _ in imports):.3f} s "
              f"wall, {statistics.median(c for _, c in imports):.3f} s CPU")
        print(f"baseline pandas.read_csv alone: {base:.3f} s wall; ratio summary / parse {wall / base:.2f}")


if __name__ == "__main__":
    main()
