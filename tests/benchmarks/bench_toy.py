"""Benchmark of the toy calibration (run on demand: ``python tests/benchmarks/bench_toy.py``).

Not collected by pytest (file name ``bench_*.py``). Prints one table with the median wall
time of each stage over a few repeats and its ratio to the target:

* preview — MAP (multi-start least squares + Newton) and Laplace approximation, target 50 ms;
* posterior — preview, emcee to bulk ESS >= 1000 for every parameter (and R-hat <= 1.01,
  >= 20 autocorrelation times), diagnostics; target 1 s;
* for information: the predictive bands over the 20 s horizon, a full ``run_toy`` and the
  15-window sweep.

Options: ``--repeats N`` (default 5), ``--profile`` (pyinstrument profile of one posterior run).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np


def _median_time(fn, repeats: int) -> tuple[float, object]:
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--profile", action="store_true")
    args = parser.parse_args(argv)

    import arviz  # noqa: F401  (import time is not part of any stage)
    import emcee  # noqa: F401

    from beam.inference import EnsembleRun, preview
    from beam.toy import ToyScenario, run_toy, simulate, sweep_windows, toy_problem

    scenario = ToyScenario()
    data = simulate(scenario)
    cal = data.calibration

    def make_problem():
        return toy_problem(data.time_s[cal], data.data[cal], likelihood=scenario.likelihood)

    def do_preview():
        return preview(make_problem())

    def do_posterior():
        run = EnsembleRun(make_problem(), seed=scenario.seed)
        return run.run_to_ess(1000.0)

    # warm-up (first calls pay for imports and caches)
    do_posterior()

    rows = []
    t_prev, _ = _median_time(do_preview, max(args.repeats, 20))
    rows.append(("preview (MAP + Laplace)", t_prev, 0.050, ""))
    t_post, post = _median_time(do_posterior, args.repeats)
    d = post.diagnostics
    rows.append(
        (
            "posterior to ESS >= 1000",
            t_post,
            1.0,
            (
                f"ess_min={d.ess_min:.0f} rhat_max={d.rhat_max:.4f} steps={d.n_steps} walkers={d.n_walkers} "
                f"tau_max={d.autocorr_time_max:.1f} acc={d.acceptance_fraction:.2f} converged={d.converged}"
            ),
        )
    )
    t_bands, _ = _median_time(lambda: post.predict(data.time_s, n_draws=500, seed=0), args.repeats)
    rows.append(("predictive bands (500 draws, 401 t)", t_bands, None, ""))
    t_run, res = _median_time(lambda: run_toy(scenario), args.repeats)
    rows.append(("run_toy end to end", t_run, None, f"coverage95={res.coverage95_prediction:.3f} rmse={res.rmse_prediction:.3f}"))
    t_sweep, sw = _median_time(lambda: sweep_windows(scenario), max(1, args.repeats // 2))
    rows.append((f"sweep ({len(sw)} windows, Laplace)", t_sweep, None, ""))

    print(f"{'stage':40s} {'median s':>10s} {'target s':>9s} {'ratio':>7s}  notes")
    for name, t, target, note in rows:
        tgt = f"{target:9.3f}" if target else f"{'-':>9s}"
        ratio = f"{t / target:7.2f}" if target else f"{'-':>7s}"
        print(f"{name:40s} {t:10.4f} {tgt} {ratio}  {note}")
    print(f"(python {sys.version.split()[0]}, numpy {np.__version__}, repeats={args.repeats})")

    if args.profile:
        from pyinstrument import Profiler

        profiler = Profiler(interval=0.0005)
        profiler.start()
        do_posterior()
        profiler.stop()
        print(profiler.output_text(unicode=False, color=False))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
