"""Calibrating the toy model: one run, and the window sweep (see :mod:`beam.toy`)."""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from beam.errors import BeamInputError
from beam.inference import import_arviz
from beam.inference.laplace import LaplaceResult, preview
from beam.inference.likelihood import NOISE_SD
from beam.inference.predictive import PredictiveBands
from beam.inference.problem import Problem
from beam.inference.results import PosteriorResult
from beam.inference.sampling import EnsembleRun
from beam.toy.problem import phase_branch_centre, toy_problem
from beam.toy.scenario import ToyData, ToyScenario, simulate


@dataclass
class ToyResult:
    """Everything a report or a dashboard needs about one toy run.

    Attributes
    ----------
    scenario : ToyScenario
        The experiment.
    data : ToyData
        Time, noise-free signal and truth, noisy data, calibration mask (full horizon).
    problem : Problem
        The calibration problem (window data only).
    laplace : LaplaceResult
        MAP + Laplace preview.
    posterior : PosteriorResult or None
        MCMC result (None for a preview-only run).
    bands : PredictiveBands
        Posterior predictive on the full horizon grid (``data.time_s``).
    preview_bands : PredictiveBands
        The same from the Laplace preview.
    draws : dict of str to ndarray
        Up to 500 posterior draws (natural units) for plotting sample paths.
    summary : dict
        ``{name: {"mean", "sd", "q025", "q975"}}``.
    truth : dict
        True values of the same parameters.
    phase_centre_rad : float
        Centre of the phase branch used.
    seconds : float
        Wall time of :func:`run_toy` without the sweep and without one-time library imports (s).
    sweep : list of dict or None
        Window sweep (:func:`sweep_windows`), if requested.
    """

    scenario: ToyScenario
    data: ToyData
    problem: Problem
    laplace: LaplaceResult
    posterior: PosteriorResult | None
    bands: PredictiveBands
    preview_bands: PredictiveBands
    draws: dict[str, np.ndarray]
    summary: dict[str, dict[str, float]]
    truth: dict[str, float]
    phase_centre_rad: float
    seconds: float
    sweep: list[dict[str, float]] | None = None
    sweep_seconds: float | None = None
    extra: dict = field(default_factory=dict)

    @property
    def rmse_prediction(self) -> float:
        """RMSE of the posterior mean against held-out data (du)."""
        return self.bands.rmse(self.data.data, self.data.held_out)

    @property
    def coverage95_prediction(self) -> float:
        """Fraction of held-out data inside the 95 % prediction band."""
        return self.bands.coverage(self.data.data, self.data.held_out)

    def to_json(self) -> dict:
        """The JSON report of ``beam toy --json`` (plain Python types)."""
        out: dict = {
            "posterior": self.summary,
            "truth": self.truth,
            "rmse_prediction": self.rmse_prediction,
            "coverage95_prediction": self.coverage95_prediction,
            "rmse_truth": self.bands.rmse(self.data.truth, self.data.held_out),
            "coverage95_credible_truth": self.bands.credible_coverage(self.data.truth, self.data.held_out),
        }
        if self.posterior is not None:
            diag = self.posterior.diagnostics
            out.update(
                ess_min=diag.ess_min,
                rhat_max=diag.rhat_max,
                converged=bool(diag.converged),
                acceptance_fraction=diag.acceptance_fraction,
                autocorr_time_max_steps=diag.autocorr_time_max,
                n_walkers=diag.n_walkers,
                n_steps=diag.n_steps,
                n_burn=diag.n_burn,
                warnings=list(diag.warnings),
            )
        out["seconds"] = self.seconds
        out["preview"] = {
            "posterior": self.laplace.summary(),
            "rmse_prediction": self.preview_bands.rmse(self.data.data, self.data.held_out),
            "coverage95_prediction": self.preview_bands.coverage(self.data.data, self.data.held_out),
            "log_evidence": self.laplace.log_evidence,
            "ok": bool(self.laplace.ok),
            "warnings": list(self.laplace.warnings),
            "seconds": self.laplace.seconds,
        }
        out["scenario"] = asdict(self.scenario)
        out["likelihood"] = self.scenario.likelihood
        out["phase_branch_rad"] = [self.phase_centre_rad - math.pi, self.phase_centre_rad + math.pi]
        if self.sweep is not None:
            out["sweep"] = self.sweep
            out["sweep_seconds"] = self.sweep_seconds
        return out


def calibration_problem(scenario: ToyScenario, data: ToyData) -> tuple[Problem, float]:
    """The problem on the calibration samples of ``data`` and the phase-branch centre used."""
    t = data.time_s[data.calibration]
    y = data.data[data.calibration]
    centre = phase_branch_centre(t, y)
    return toy_problem(t, y, likelihood=scenario.likelihood, phase_centre_rad=centre), centre


def run_toy(
    scenario: ToyScenario,
    *,
    mcmc: bool = True,
    sweep: bool = False,
    sweep_window_list: Sequence[float] | None = None,
    n_band_draws: int = 500,
) -> ToyResult:
    """Simulate, calibrate (MAP, Laplace, emcee to ``scenario.target_ess``) and score a scenario.

    Parameters
    ----------
    scenario : ToyScenario
        The experiment (validated here).
    mcmc : bool
        Run the sampler; if False the Laplace preview stands in for the posterior.
    sweep : bool
        Also run :func:`sweep_windows`.
    sweep_window_list : sequence of float, optional
        Windows of the sweep (default :func:`default_sweep_windows`).
    n_band_draws : int
        Posterior draws behind the predictive bands.

    Returns
    -------
    ToyResult
    """
    import emcee  # noqa: F401  (one-time library imports are not part of ``seconds``)

    import_arviz()

    t0 = time.perf_counter()
    scenario.validate()
    data = simulate(scenario)
    problem, centre = calibration_problem(scenario, data)
    lap = preview(problem)
    preview_bands = lap.predict(data.time_s, n_draws=400, seed=scenario.seed)
    posterior = None
    if mcmc:
        run = EnsembleRun(problem, lap, seed=scenario.seed)
        posterior = run.run_to_ess(scenario.target_ess)
        bands = posterior.predict(data.time_s, n_draws=n_band_draws, seed=scenario.seed)
        summary = posterior.summary()
        draws = posterior.thinned_draws(500, seed=scenario.seed)
    else:
        bands = preview_bands
        summary = lap.summary(seed=scenario.seed)
        draws = lap.draws(500, seed=scenario.seed)
    seconds = time.perf_counter() - t0
    result = ToyResult(
        scenario=scenario,
        data=data,
        problem=problem,
        laplace=lap,
        posterior=posterior,
        bands=bands,
        preview_bands=preview_bands,
        draws=draws,
        summary=summary,
        truth=scenario.truth(centre),
        phase_centre_rad=centre,
        seconds=seconds,
    )
    if sweep:
        t1 = time.perf_counter()
        result.sweep = sweep_windows(scenario, sweep_window_list)
        result.sweep_seconds = time.perf_counter() - t1
    return result


def default_sweep_windows(scenario: ToyScenario) -> list[float]:
    """Whole-second windows from 1 s to 15 s that are valid for the scenario."""
    period = 1.0 / scenario.frequency_Hz
    return [float(w) for w in range(1, 16) if w >= period and w < scenario.horizon_s]


def sweep_windows(scenario: ToyScenario, windows: Sequence[float] | None = None, *, n_draws: int = 400) -> list[dict[str, float]]:
    """Held-out RMSE and 95 % prediction-band coverage against the calibration window.

    One record is simulated with the scenario's seed (the truth does not depend on the
    window); for each window the model is calibrated
    on ``[0, window]`` with the MAP + Laplace preview (no MCMC) and scored on
    ``(window, horizon]``. Deterministic for a given scenario.

    Returns
    -------
    list of dict
        ``{"window_s", "rmse_prediction", "coverage95_prediction", "frequency_Hz_mean",
        "frequency_Hz_sd", "noise_sd_mean"}`` per window (du, Hz).
    """
    scenario.validate()
    windows = default_sweep_windows(scenario) if windows is None else list(windows)
    rows = []
    for w in windows:
        sub = replace(scenario, window_s=float(w))
        try:
            replace(sub, discrepancy=0.0).validate()  # window checks only; truth stays the scenario's
        except BeamInputError as exc:
            raise BeamInputError(f"sweep window {w:g} s: {exc}") from None
        data = simulate(scenario, calibration_window_s=float(w))
        problem, _ = calibration_problem(scenario, data)
        lap = preview(problem)
        held = data.held_out
        bands = lap.predict(data.time_s[held], n_draws=n_draws, seed=scenario.seed)
        summ = lap.summary(n_draws=n_draws, seed=scenario.seed)
        rows.append(
            {
                "window_s": float(w),
                "rmse_prediction": bands.rmse(data.data[held]),
                "coverage95_prediction": bands.coverage(data.data[held]),
                "frequency_Hz_mean": summ["frequency_Hz"]["mean"],
                "frequency_Hz_sd": summ["frequency_Hz"]["sd"],
                "noise_sd_mean": summ[NOISE_SD]["mean"],
            }
        )
    return rows
