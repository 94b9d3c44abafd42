"""Jobs of the toy view for the run scheduler: preview, streamed MCMC, window sweep.

Pure Python on top of the public :mod:`beam.toy` and :mod:`beam.inference` functions (no UI
import). Each job is a generator of :class:`~dashboard.scheduler.Stage` items:

:func:`toy_run`
    ``preview`` (MAP + Laplace, a :class:`~beam.toy.ToyResult` without posterior), then
    ``progress`` every few ensemble steps and ``partial`` results (bands from the chain so
    far) about every ``partial_every_s``, then ``final`` — the same :class:`~beam.toy.ToyResult`
    as :func:`beam.toy.run_toy` (same seed, same sampler chunks).
:func:`toy_sweep`
    The window sweep of :func:`beam.toy.sweep_windows`, one window per ``partial``.

Results are deterministic for a scenario, so finished ones are kept in small process-wide
LRU caches shared by all sessions (a class of students opening the app computes the default
scenario once). ``ToyResult.extra["stage"]`` says which stage a result comes from.
"""

from __future__ import annotations

import math
import threading
import time
from collections import OrderedDict
from collections.abc import Hashable, Iterator
from dataclasses import replace

import numpy as np

from beam.inference.diagnostics import MIN_AUTOCORR_TIMES, RHAT_MAX, autocorr_time, ess_bulk, rhat
from beam.inference.laplace import preview as laplace_preview
from beam.inference.predictive import predictive_bands
from beam.inference.sampling import BURN_AUTOCORR_TIMES, EnsembleRun
from beam.inference.summaries import summarize_draws
from beam.toy import ToyResult, ToyScenario, default_sweep_windows, phase_branch_centre, simulate, sweep_windows, toy_problem
from dashboard import scheduler as sch

__all__ = ["LRU", "RESULTS", "SWEEPS", "schedule_warm_up", "stream_to_ess", "sweep_key", "toy_run", "toy_sweep", "warm_up"]

#: Posterior draws behind the bands of a final result (as :func:`beam.toy.run_toy`).
N_BAND_DRAWS = 500
#: Draws behind the preview bands (as :func:`beam.toy.run_toy`).
N_PREVIEW_DRAWS = 400


class LRU:
    """A small thread-safe least-recently-used cache.

    Parameters
    ----------
    size : int
        Entries kept.
    """

    def __init__(self, size: int) -> None:
        self.size = int(size)
        self._data: OrderedDict = OrderedDict()
        self._lock = threading.Lock()

    def get(self, key: Hashable):
        """The cached value or None."""
        with self._lock:
            if key not in self._data:
                return None
            self._data.move_to_end(key)
            return self._data[key]

    def put(self, key: Hashable, value) -> None:
        """Store ``value`` (evicting the oldest entry when full)."""
        with self._lock:
            self._data[key] = value
            self._data.move_to_end(key)
            while len(self._data) > self.size:
                self._data.popitem(last=False)

    def clear(self) -> None:
        """Drop everything."""
        with self._lock:
            self._data.clear()

    def __len__(self) -> int:
        return len(self._data)


#: Final toy results by scenario.
RESULTS = LRU(32)
#: Window sweeps by :func:`sweep_key`.
SWEEPS = LRU(64)

_warm_lock = threading.Lock()
_warmed = False
_warm_scheduled = False


def warm_up() -> None:
    """Import the sampler's libraries (ArviZ takes seconds the first time); idempotent."""
    global _warmed
    with _warm_lock:
        if not _warmed:
            import arviz  # noqa: F401
            import emcee  # noqa: F401

            _warmed = True


def schedule_warm_up(pool) -> None:
    """Run :func:`warm_up` once on ``pool`` (at app start, so the first MCMC need not wait)."""
    global _warm_scheduled
    with _warm_lock:
        if _warmed or _warm_scheduled:
            return
        _warm_scheduled = True
    pool.schedule(warm_up)


def sweep_key(scenario: ToyScenario) -> ToyScenario:
    """What the sweep depends on: not the MCMC target, and the window only through a drift.

    :func:`beam.toy.sweep_windows` recalibrates on its own windows; the scenario's window only
    normalises the ``drift`` discrepancy (``t / window``).
    """
    window = scenario.window_s if (scenario.kind == "drift" and scenario.discrepancy != 0.0) else 0.0
    return replace(scenario, window_s=window, target_ess=0.0)


def stream_to_ess(run: EnsembleRun, target_ess: float, *, every: int = 25, max_steps: int = 20000):
    """:meth:`EnsembleRun.run_to_ess` as a generator of ``(Progress, planned_total_steps)``.

    The same chunk plan as ``run_to_ess`` (so the same draws for a seed): an initial chunk
    sized for the target ESS with a guessed autocorrelation time, then chunks sized from
    the measured ESS, chain length in autocorrelation times and R-hat until all pass or
    ``max_steps``. Yields every ``every`` steps and at the end of every chunk.
    """
    tau_guess = 4.0
    need = max(1.2 * target_ess * tau_guess / run.n_walkers, 1.1 * 0.9 * tau_guess / (RHAT_MAX - 1.0))
    steps = min(math.ceil(need + BURN_AUTOCORR_TIMES * tau_guess), max_steps - run.n_steps)
    while steps > 0:
        planned = run.n_steps + steps
        for prog in run.sample(steps, every=max(1, min(every, steps))):
            yield prog, planned
        n_burn = run.burn_in()
        chain = run.chain()[n_burn:]
        tau = autocorr_time(chain)
        ess = ess_bulk(chain)
        rh = None
        kept, tau_max, ess_min = chain.shape[0], float(np.max(tau)), float(np.min(ess))
        grow = 1.0
        if ess_min < target_ess:
            grow = 1.1 * target_ess / max(ess_min, 1.0)
        if kept < MIN_AUTOCORR_TIMES * tau_max:
            grow = max(grow, 1.05 * MIN_AUTOCORR_TIMES * tau_max / kept)
        if grow == 1.0:
            rh = rhat(chain)
            rh_max = float(np.max(rh))
            if rh_max > RHAT_MAX:
                grow = max(1.2, (rh_max - 1.0) / (0.8 * (RHAT_MAX - 1.0)))
        run._cache[(run.n_steps, n_burn)] = (tau, ess, rh)  # reused by run.result(), as in run_to_ess
        if grow == 1.0:
            return
        want_total = math.ceil(kept * grow + BURN_AUTOCORR_TIMES * tau_max)
        steps = int(min(max(want_total - run.n_steps, 20), max_steps - run.n_steps))


def _result(base: dict, stage: str, **fields) -> ToyResult:
    extra = {"stage": stage, **fields.pop("extra", {})}
    return ToyResult(**base, **fields, extra=extra)


def toy_run(
    scenario: ToyScenario,
    *,
    every: int = 25,
    partial_every_s: float = 1.0,
    use_cache: bool = True,
) -> Iterator[sch.Stage]:
    """Preview, streamed MCMC and final result of a toy scenario (a scheduler job).

    Parameters
    ----------
    scenario : ToyScenario
        Validated here: an invalid one raises :class:`~beam.errors.BeamInputError`, which the
        scheduler publishes as an ``error`` update.
    every : int
        Ensemble steps between two progress reports (cancellation points).
    partial_every_s : float
        Seconds between two intermediate results during sampling (each one redraws the plots
        on the server's event loop, so not too often; a toy run usually ends before the first).
    use_cache : bool
        Publish a cached final result at once when there is one.

    Yields
    ------
    Stage
        ``preview``, ``progress`` / ``partial`` items, ``final``.
    """
    scenario.validate()
    cached = RESULTS.get(scenario) if use_cache else None
    if cached is not None:
        yield sch.final(cached, "posterior (cached)")
        return
    t0 = time.perf_counter()
    data = simulate(scenario)
    t, y = data.time_s[data.calibration], data.data[data.calibration]
    centre = phase_branch_centre(t, y)
    problem = toy_problem(t, y, likelihood=scenario.likelihood, phase_centre_rad=centre)
    lap = laplace_preview(problem)
    preview_bands = lap.predict(data.time_s, n_draws=N_PREVIEW_DRAWS, seed=scenario.seed)
    base = {"scenario": scenario, "data": data, "problem": problem, "laplace": lap, "preview_bands": preview_bands,
            "truth": scenario.truth(centre), "phase_centre_rad": centre}
    yield sch.preview(
        _result(base, "preview", posterior=None, bands=preview_bands, draws=lap.draws(500, seed=scenario.seed),
                summary=lap.summary(seed=scenario.seed), seconds=time.perf_counter() - t0),
        "preview (MAP + Laplace)",
    )

    if not _warmed:
        yield sch.progress(0.0, "loading the sampler (first run only)")
        warm_up()
    run = EnsembleRun(problem, lap, seed=scenario.seed)
    done, last_partial = 0.0, time.perf_counter()
    for prog, planned in stream_to_ess(run, scenario.target_ess, every=every):
        done = max(done, min(prog.step / planned, 0.99))
        message = f"sampling: {prog.step} of {planned} ensemble steps"
        yield sch.progress(done, message)
        if time.perf_counter() - last_partial >= partial_every_s and run.n_steps >= 40:
            chain = run.chain()[run.n_steps // 2 :]
            draws = problem.from_internal(chain.reshape(-1, chain.shape[-1])[-N_PREVIEW_DRAWS:], include_fixed=False)
            bands = predictive_bands(problem, draws, data.time_s)
            yield sch.partial(
                _result(base, "partial", posterior=None, bands=bands, draws=draws, summary=summarize_draws(draws),
                        seconds=time.perf_counter() - t0, extra={"steps": run.n_steps}),
                done,
                message,
            )
            last_partial = time.perf_counter()
    posterior = run.result(target_ess=scenario.target_ess)
    result = _result(
        base,
        "final",
        posterior=posterior,
        bands=posterior.predict(data.time_s, n_draws=N_BAND_DRAWS, seed=scenario.seed),
        draws=posterior.thinned_draws(500, seed=scenario.seed),
        summary=posterior.summary(),
        seconds=time.perf_counter() - t0,
    )
    RESULTS.put(scenario, result)
    yield sch.final(result, "posterior (MCMC)")


def toy_sweep(scenario: ToyScenario, *, use_cache: bool = True) -> Iterator[sch.Stage]:
    """The window sweep of a scenario, one window per ``partial`` stage (a scheduler job).

    Yields
    ------
    Stage
        ``partial`` with the rows so far after each window, then ``final`` with all rows
        (list of dict as returned by :func:`beam.toy.sweep_windows`).
    """
    scenario.validate()
    key = sweep_key(scenario)
    cached = SWEEPS.get(key) if use_cache else None
    if cached is not None:
        yield sch.final(cached, "window sweep (cached)")
        return
    windows = default_sweep_windows(scenario)
    rows: list[dict] = []
    for i, w in enumerate(windows, 1):
        rows.extend(sweep_windows(scenario, [w]))
        yield sch.partial(list(rows), i / len(windows), f"window sweep: {i} of {len(windows)} windows")
    SWEEPS.put(key, rows)
    yield sch.final(rows, "window sweep")
