"""Jobs of the toy view for the run scheduler: preview, streamed MCMC, window sweep.

Pure Python on top of the public :mod:`beam.toy` and :mod:`beam.inference` functions (no UI
import). Each job is a generator of :class:`~dashboard.runtime.scheduler.Stage` items:

:func:`toy_run`
    ``preview`` (MAP + Laplace, a :class:`~beam.toy.ToyResult` without posterior), then
    ``progress`` every few ensemble steps and ``partial`` results (bands from the chain so
    far) about every ``partial_every_s``, then ``final`` — the same :class:`~beam.toy.ToyResult`
    as :func:`beam.toy.run_toy` (same seed, same sampler chunks).
:func:`toy_sweep`
    The window sweep of :func:`beam.toy.sweep_windows`, one window per ``partial``.

The computations (:func:`toy_stages`, :func:`sweep_stages`) run in a worker process of the
pool (:func:`dashboard.runtime.scheduler.offload`); the jobs around them look up and fill the caches in
the server process. Results are deterministic for a scenario, so finished ones are kept in
small process-wide LRU caches shared by all sessions (a class of students opening the app
computes the default scenario once). ``ToyResult.extra["stage"]`` says which stage a result
comes from.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from dataclasses import replace

from beam.inference.laplace import preview as laplace_preview
from beam.inference.predictive import predictive_bands
from beam.inference.sampling import EnsembleRun
from beam.inference.summaries import summarize_draws
from beam.toy import (
    ToyResult,
    ToyScenario,
    calibration_problem,
    default_sweep_windows,
    simulate,
    sweep_windows,
)
from dashboard.jobs.warm import is_warm, warm_up
from dashboard.runtime import scheduler as sch
from dashboard.runtime.caches import LRU, cached_stages

__all__ = ["RESULTS", "SWEEPS", "sweep_key", "sweep_stages", "toy_run", "toy_stages", "toy_sweep"]

#: Posterior draws behind the bands of a final result (as :func:`beam.toy.run_toy`).
N_BAND_DRAWS = 500
#: Cap on ensemble steps (as :meth:`beam.inference.EnsembleRun.run_to_ess`).
MAX_STEPS = 20000
#: Draws behind the preview bands (as :func:`beam.toy.run_toy`).
N_PREVIEW_DRAWS = 400



#: Final toy results by scenario.
RESULTS = LRU(32)
#: Window sweeps by :func:`sweep_key`.
SWEEPS = LRU(64)



def sweep_key(scenario: ToyScenario) -> ToyScenario:
    """What the sweep depends on: not the MCMC target, and the window only through a drift.

    :func:`beam.toy.sweep_windows` recalibrates on its own windows; the scenario's window only
    normalises the ``drift`` discrepancy (``t / window``).
    """
    window = scenario.window_s if (scenario.kind == "drift" and scenario.discrepancy != 0.0) else 0.0
    return replace(scenario, window_s=window, target_ess=0.0)


def _result(base: dict, stage: str, **fields) -> ToyResult:
    extra = {"stage": stage, **fields.pop("extra", {})}
    return ToyResult(**base, **fields, extra=extra)


def toy_run(
    scenario: ToyScenario,
    *,
    every: int = 25,
    partial_every_s: float = 1.0,
    use_cache: bool = True,
) -> Iterator[sch.Stage[ToyResult]]:
    """Preview, streamed MCMC and final result of a toy scenario (a scheduler job).

    Publishes a cached final result at once when there is one; otherwise the stages of
    :func:`toy_stages`, computed in a worker process, and caches the final result.

    Parameters
    ----------
    scenario : ToyScenario
        Validated here: an invalid one raises :class:`~beam.errors.BeamInputError`, which the
        scheduler publishes as an ``error`` update.
    every, partial_every_s
        See :func:`toy_stages`.
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
    yield from cached_stages(RESULTS, scenario, toy_stages, scenario, every=every, partial_every_s=partial_every_s)


def toy_stages(scenario: ToyScenario, *, every: int = 25, partial_every_s: float = 1.0) -> Iterator[sch.Stage[ToyResult]]:
    """The computation of :func:`toy_run` (in a worker process; no cache).

    Parameters
    ----------
    scenario : ToyScenario
        The scenario (validated).
    every : int
        Ensemble steps between two progress reports (cancellation points).
    partial_every_s : float
        Seconds between two intermediate results during sampling (each one redraws the plots
        on the server's event loop, so not too often; a toy run usually ends before the first).

    Yields
    ------
    Stage
        ``preview``, ``progress`` / ``partial`` items, ``final``.
    """
    scenario.validate()
    t0 = time.perf_counter()
    data = simulate(scenario)
    problem, centre = calibration_problem(scenario, data)
    lap = laplace_preview(problem)
    preview_bands = lap.predict(data.time_s, n_draws=N_PREVIEW_DRAWS, seed=scenario.seed)
    base = {"scenario": scenario, "data": data, "problem": problem, "laplace": lap, "preview_bands": preview_bands,
            "truth": scenario.truth(centre), "phase_centre_rad": centre}
    yield sch.preview(
        _result(base, "preview", posterior=None, bands=preview_bands, draws=lap.draws(500, seed=scenario.seed),
                summary=lap.summary(seed=scenario.seed), seconds=time.perf_counter() - t0),
        "preview (MAP + Laplace)",
    )

    if not is_warm():
        yield sch.progress(0.0, "loading the sampler (first run only)")
    warm_up()  # at once when warm; waits for a warm-up under way
    run = EnsembleRun(problem, lap, seed=scenario.seed)
    done, last_partial = 0.0, time.perf_counter()
    for prog in run.sample_to_ess(scenario.target_ess, every=every, max_steps=MAX_STEPS):
        planned = prog.total  # the steps planned so far (grows when a chunk is added)
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
    yield sch.final(result, "posterior (MCMC)")


def toy_sweep(scenario: ToyScenario, *, use_cache: bool = True) -> Iterator[sch.Stage[list[dict[str, float]]]]:
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
    yield from cached_stages(SWEEPS, key, sweep_stages, scenario)


def sweep_stages(scenario: ToyScenario) -> Iterator[sch.Stage[list[dict[str, float]]]]:
    """The computation of :func:`toy_sweep` (in a worker process; no cache)."""
    windows = default_sweep_windows(scenario)
    rows: list[dict] = []
    for i, w in enumerate(windows, 1):
        rows.extend(sweep_windows(scenario, [w]))
        yield sch.partial(list(rows), i / len(windows), f"window sweep: {i} of {len(windows)} windows")
    yield sch.final(rows, "window sweep")
