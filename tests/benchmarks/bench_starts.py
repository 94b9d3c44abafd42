"""Does the one start strategy find the global mode, whatever effects are ticked?

For each record (the bundled ones, then fresh random ones of :func:`tests.simulated_data.random_beam_case`),
each calibration window (three: 20, 30 and 45 % of the record from its start) and each effect set of
up to ``--max-effects`` catalogue effects (the base model is always on), the MAP of the calibration
engine (the MAP search of :func:`beam.calibration.calibration_preview` without its Laplace bands, the starts of
:func:`beam.calibration.starts.starting_points`) is compared with a brute-force reference: the
lock-step search of :mod:`beam.calibration.fit` from the strategy's own starts plus ``--starts``
(default 256) points of a scrambled Sobol design over every physical parameter's log prior range
(k_p by least squares for a linear model), all of them searched, none screened. A case passes when
the engine's log posterior is within 1 nat of the reference's. Prints one row per case and the
table of shares by effect-set size.

    python tests/benchmarks/bench_starts.py [--random 3] [--max-effects 3] [--starts 256] [--linear-only]
                                            [--windows 0.2,0.3,0.45] [--quick]

The full run (8 records x 3 windows x 130 effect sets = 3,120 cases) takes hours on two cores.
``--quick`` is the subset where the misses were: the bundled records, the 20 % window, the linear
effect sets of up to two effects (185 cases, ~20 minutes). ``--sample N`` runs a uniform random
sample of N of the selected cases (seeded): an unbiased estimate of the full share in bounded time.
"""

from __future__ import annotations

import argparse
import itertools
import sys
import time
from pathlib import Path

import numpy as np
from scipy.stats import binomtest, qmc

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from beam.calibration import prepare  # noqa: E402
from beam.calibration.fit import fast_map  # noqa: E402
from beam.calibration.starts import ridge_walk  # noqa: E402
from beam.io.measurement import read_measurement  # noqa: E402
from beam.physics.effects import EFFECTS  # noqa: E402
from tests.simulated_data import HIDDEN_EFFECTS, random_beam_case  # noqa: E402

WINDOW_FRACTIONS = (0.2, 0.3, 0.45)
#: The catalogue effects a user can tick besides the base model.
CATALOGUE = tuple(EFFECTS)
TOLERANCE_NATS = 1.0


def reference_log_posterior(measurement, window, effects, modes, starts: int, seed: int = 0) -> float:
    """Log posterior of the best optimum from the strategy's starts + a Sobol design of ``starts``
    points over every physical parameter (see the module notes)."""
    setup, problem = prepare(measurement, window=window, effects=effects, modes=modes)
    names = list(setup.physical_names)
    logs = np.array([[np.log(problem.parameter(n).prior.lower), np.log(problem.parameter(n).prior.upper)] for n in names])
    unit = qmc.Sobol(len(names), scramble=True, seed=seed).random(starts)
    values = np.exp(logs[:, 0] + unit * (logs[:, 1] - logs[:, 0]))
    batch = {n: values[:, i] for i, n in enumerate(names)}
    if not setup.model.is_nonlinear:  # k_p by least squares: the response is linear in it
        batch["patch_coupling_NmV"] = np.ones(starts)
        with np.errstate(all="ignore"):
            response = problem.predict(batch)
        denominator = np.einsum("ij,ij->i", response, response)
        prior = problem.parameter("patch_coupling_NmV").prior
        batch["patch_coupling_NmV"] = np.clip(np.abs(response @ problem.data) / np.where(denominator > 0, denominator, np.inf),
                                              prior.lower * 1.000001, prior.upper * 0.999999)
    guesses = problem.initial_guesses(problem) + [{n: float(batch[n][i]) for n in names} for i in range(starts)]
    return float(fast_map(problem, guesses).log_posterior)


def engine_log_posterior(measurement, window, effects, modes: int) -> float:
    """Log posterior of the engine's MAP: the search of :func:`beam.calibration.calibration_preview`
    (:func:`~beam.calibration.fit.fast_map` from the problem's starting points, then the walk
    along the ridge of equal frequencies, :func:`beam.calibration.starts.ridge_walk`) without the
    Laplace draws and bands that follow it (a case whose MAP sits where the Laplace Gaussian
    falls outside the prior support would otherwise fail for a reason that is not the start)."""
    setup, problem = prepare(measurement, window=window, effects=effects, modes=modes)
    found = fast_map(problem, problem.initial_guesses(problem))
    found = ridge_walk(problem, setup, found) or found
    return float(found.log_posterior)


def records(n_random: int, linear_only: bool):
    for path in sorted((ROOT / "assets" / "measurements").glob("*.csv")):
        yield path.stem, read_measurement(path)
    rng = np.random.default_rng(2024)
    for i in range(n_random):
        hidden = HIDDEN_EFFECTS[i % len(HIDDEN_EFFECTS)]
        if linear_only and hidden == "tip_cubic_spring":
            hidden = "tip_mass"
        measurement, _, _ = random_beam_case(rng, hidden)
        yield f"random{i}:{hidden}", measurement


def effect_sets(max_effects: int, linear_only: bool):
    for size in range(max_effects + 1):
        for chosen in itertools.combinations(CATALOGUE, size):
            if linear_only and any(EFFECTS[e].nonlinear for e in chosen):
                continue
            yield chosen


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--random", type=int, default=3, help="fresh random records besides the bundled ones")
    parser.add_argument("--max-effects", type=int, default=3)
    parser.add_argument("--starts", type=int, default=256, help="Sobol starts of the reference (a power of two)")
    parser.add_argument("--modes", type=int, default=4)
    parser.add_argument("--linear-only", action="store_true", help="leave out the tip cubic spring (slow)")
    parser.add_argument("--bundled-only", action="store_true")
    parser.add_argument("--records", default="", help="comma-separated record names to keep (default all)")
    parser.add_argument("--windows", default=",".join(str(f) for f in WINDOW_FRACTIONS),
                        help="comma-separated window ends (fractions of the record)")
    parser.add_argument("--quick", action="store_true",
                        help="bundled records, 20 %% window, linear effect sets of up to two effects")
    parser.add_argument("--sample", type=int, default=0,
                        help="run a uniform random sample of this many of the cases (0: all)")
    parser.add_argument("--sample-seed", type=int, default=0)
    args = parser.parse_args(argv)
    if args.quick:
        args.bundled_only, args.linear_only, args.windows = True, True, "0.2"
        args.max_effects = min(args.max_effects, 2)
    fractions = [float(f) for f in args.windows.split(",") if f]
    rows = []
    keep = {r for r in args.records.split(",") if r}
    cases = []
    for name, measurement in records(0 if args.bundled_only else args.random, args.linear_only):
        if keep and name.split(":")[0] not in keep:
            continue
        t = measurement.time_s
        for fraction in fractions:
            window = (float(t[0]), float(t[0] + fraction * (t[-1] - t[0])))
            for effects in effect_sets(args.max_effects, args.linear_only):
                cases.append((name, measurement, fraction, window, effects))
    if args.sample and args.sample < len(cases):
        chosen = np.random.default_rng(args.sample_seed).choice(len(cases), args.sample, replace=False)
        print(f"a uniform random sample of {args.sample} of the {len(cases)} cases (seed {args.sample_seed})")
        cases = [cases[i] for i in chosen]  # in random order: any prefix of the run is a uniform sample too
    for name, measurement, fraction, window, effects in cases:
        t0 = time.perf_counter()
        try:
            engine = engine_log_posterior(measurement, window, effects, args.modes)
            seconds = time.perf_counter() - t0
            reference = max(engine, reference_log_posterior(measurement, window, effects, args.modes, args.starts))
        except Exception as exc:  # noqa: BLE001 - a failed case is reported, not fatal
            print(f"{name:24s} {fraction:4.2f} {'+'.join(effects) or 'base':60s} failed: {exc}", flush=True)
            rows.append((len(effects), False))
            continue
        gap = reference - engine
        ok = gap <= TOLERANCE_NATS
        rows.append((len(effects), ok))
        print(f"{name:24s} {fraction:4.2f} {'+'.join(effects) or 'base':60s} engine {engine:12.2f} "
              f"reference {reference:12.2f} gap {gap:8.2f} {'ok' if ok else 'MISSED'} ({seconds:.2f} s)", flush=True)
    print("\neffects  cases  within 1 nat")
    for size in sorted({s for s, _ in rows}):
        hits = [ok for s, ok in rows if s == size]
        print(f"{size:7d} {len(hits):6d} {100.0 * np.mean(hits):10.1f} %")
    hits = int(sum(ok for _, ok in rows))
    print(f"{'all':>7s} {len(rows):6d} {100.0 * hits / max(len(rows), 1):10.1f} %")
    if rows:
        interval = binomtest(hits, len(rows)).proportion_ci(0.95)
        print(f"95 % interval of the share (Clopper-Pearson): {100 * interval.low:.1f}-{100 * interval.high:.1f} %")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
