"""Benchmark of ``beam study`` on Dask (run on demand: ``python tests/benchmarks/bench_study.py [--quick]``).

A 12-cell study of the bundled ``lab_run_1``: the default growing family of windows (six, ending at
10-60 % of the record) x the iid and AR(1) likelihoods, the default effects and modes, sampling to
ESS 1000 (``--quick``: the first two windows, four cells, 3 modes, 100 steps, for a check of the script). It runs twice in
one process on a fresh local cluster each time, with 1 worker and with 2 (nothing reused: a new output
folder each), and prints:

- wall time of the whole study (cluster start and the parent's kernel warm-up included) and of its
  streaming phase (first task submitted to last result received), and the speed-up of 2 workers over 1;
- the effective parallelism, the sum of the cells' compute times over the streaming phase: how many
  workers were busy on average (on a shared machine the load changes between the two runs and moves
  the speed-up; this ratio compares each run with itself);
- each cell's compute time (in the worker: the calibration and its scoring), its rank in the order the
  cells are sent (longest expected first, :mod:`beam.study.schedule`) and when it started with 2 workers;
- the lower bound of each streaming phase (the longest cell, or the cells' sum shared by the workers) and the
  greedy schedule of the measured cell times in the order sent and in the study's order (no overhead);
- the Dask overhead per cell with 1 worker: the streaming phase minus the sum of the cells' compute
  times, per cell, and as a share of the mean cell time (scheduling, transfer of the record and the
  result, the client's bookkeeping); and with 2 workers the idle tail (workers waiting for the last cell).

The machine may be shared: the load average is printed before and after.
"""

from __future__ import annotations

import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from beam.cli.arguments import measurement_path  # noqa: E402
from beam.io.measurement import read_measurement  # noqa: E402
from beam.study.run import run_study, study_cells  # noqa: E402
from beam.study.schedule import expected_cost  # noqa: E402
from beam.study.windows import default_windows  # noqa: E402

#: The issue's targets: the streaming phase with 2 workers at least this many times faster than with 1
#: (a 2-core machine), and the Dask overhead per cell at most this share of a cell's compute time (%).
SPEEDUP_TARGET = 1.7
OVERHEAD_TARGET_PCT = 2.0


def one_run(records, cells, workers: int) -> dict:
    with tempfile.TemporaryDirectory() as folder:
        t0 = time.perf_counter()
        result = run_study(records, cells, out=Path(folder) / "bench", workers=workers)
        wall = time.perf_counter() - t0
    tasks = [e["task"] for e in result.entries]
    failed = [e["row"]["error"] for e in result.entries if e["row"]["error"]]
    if failed:
        raise SystemExit(f"a cell failed: {failed[0]}")
    compute = [t["end"] - t["start"] for t in tasks]
    stream = max(t["received"] for t in tasks) - min(t["submitted"] for t in tasks)
    t0 = min(t["submitted"] for t in tasks)
    return {"workers": workers, "wall": wall, "stream": stream, "compute": compute,
            "seconds": [e["row"]["seconds"] for e in result.entries], "computed": result.computed,
            "start": [t["start"] - t0 for t in tasks]}


def lpt_makespan(times: list[float], workers: int, order: list[int]) -> float:
    """Streaming time of ``workers`` idle-free workers taking the cells in ``order`` (s): the greedy
    list schedule, each cell to the first free worker."""
    free = [0.0] * workers
    for i in order:
        k = free.index(min(free))
        free[k] += times[i]
    return max(free)


def main() -> None:
    quick = "--quick" in sys.argv
    record = read_measurement(measurement_path("lab_run_1"))
    windows = default_windows(float(record.time_s[0]), float(record.time_s[-1]))
    options = dict(modes=3, steps=100) if quick else dict(modes="auto")
    if quick:
        windows = windows[:2]
    cells = study_cells([("lab_run_1", record)], windows, [("air_damping", "kelvin_voigt")], ["iid", "ar1"],
                        seed=0, **options)
    print(f"{len(cells)} cells: lab_run_1, windows {', '.join(f'{a:g}-{b:g} s' for a, b in windows)}, iid and ar1, "
          f"{'3 modes, 100 steps' if quick else 'auto modes, ESS 1000'}")
    print(f"load average before: {os.getloadavg()}, cores: {os.cpu_count()}")
    runs = [one_run([("lab_run_1", record)], cells, workers) for workers in (1, 2)]
    print(f"load average after: {os.getloadavg()}")
    for run in runs:
        c = run["compute"]
        print(f"{run['workers']} worker(s): wall {run['wall']:.1f} s, streaming {run['stream']:.1f} s; "
              f"cell compute median {statistics.median(c):.2f} s (min {min(c):.2f}, max {max(c):.2f}, sum {sum(c):.1f})")
    one, two = runs
    costs = [expected_cost(c, record) for _, c in cells]
    by_cost = sorted(range(len(cells)), key=lambda i: -costs[i])
    print("cells (study order): window, likelihood, expected-cost rank, compute s with 1 worker / with 2 workers, "
          "start after the first submission s (2 workers)")
    for i, (_, c) in enumerate(cells):
        print(f"  {c.window[0]:g}-{c.window[1]:g} s {c.likelihood:>4}: rank {by_cost.index(i) + 1:2d}, "
              f"{one['compute'][i]:6.2f} / {two['compute'][i]:6.2f} s, start {two['start'][i]:6.2f} s")
    for run in runs:
        c = run["compute"]
        bound = max(sum(c) / run["workers"], max(c))
        print(f"{run['workers']} worker(s): lower bound of the streaming phase max(sum / workers, longest cell) "
              f"{bound:.1f} s; greedy schedule of these cell times in the order sent "
              f"{lpt_makespan(c, run['workers'], by_cost):.1f} s, in the study's order "
              f"{lpt_makespan(c, run['workers'], list(range(len(c)))):.1f} s; measured {run['stream']:.1f} s")
    print(f"speed-up 2 vs 1 worker: {one['stream'] / two['stream']:.2f}x streaming phase, "
          f"{one['wall'] / two['wall']:.2f}x whole study (cluster start and warm-up included)")
    print("effective parallelism (sum of the cells' compute times / streaming phase; load changes between the "
          f"runs cancel out): {sum(one['compute']) / one['stream']:.2f} with 1 worker, "
          f"{sum(two['compute']) / two['stream']:.2f} with 2")
    overhead = (one["stream"] - sum(one["compute"])) / len(cells)
    share = 100 * overhead / statistics.mean(one["compute"])
    print(f"Dask overhead per cell (1 worker): {1000 * overhead:.0f} ms = {share:.2f} % of the mean cell time "
          f"({statistics.mean(one['compute']):.2f} s)")
    idle = (2 * two["stream"] - sum(two["compute"])) / len(cells)
    print(f"2 workers: idle or overhead per cell {1000 * idle:.0f} ms "
          f"({100 * idle / statistics.mean(two['compute']):.1f} % of the mean cell time; includes the tail "
          f"where one worker waits for the other's last cell); cells slower by "
          f"{100 * (sum(two['compute']) / sum(one['compute']) - 1):.0f} % with two at once (shared cores, memory)")
    speedup = one["stream"] / two["stream"]
    print(f"targets (issue 28): 2 workers >= {SPEEDUP_TARGET}x faster than 1: {speedup:.2f}x "
          f"({'met' if speedup >= SPEEDUP_TARGET else 'NOT met'}); Dask overhead <= {OVERHEAD_TARGET_PCT:g} % of a cell: "
          f"{share:.2f} % ({'met' if share <= OVERHEAD_TARGET_PCT else 'NOT met'}). Meaningful only on a quiet machine "
          "(load average above).")


if __name__ == "__main__":
    main()
