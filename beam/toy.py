"""Toy periodic model with model discrepancy: what an i.i.d.-noise calibration gets wrong.

Truth and model
---------------
The data are ``y(t) = A sin(2π f t + φ) + δ d(t) + ε(t)`` with ``ε ~ N(0, σ²)`` i.i.d.; the
calibrated model is ``A sin(2π f t + φ)``, so ``δ d(t)`` is physics the model misses
(Kennedy & O'Hagan 2001; Brynjarsdóttir & O'Hagan 2014). Discrepancy shapes ``d(t)``:

``harmonic``  ``sin(4π f t + φ)`` — distortion at twice the frequency;
``tone``      ``sin(2π · 1.37 f t)`` — an unmodelled second mode;
``drift``     ``t / T_window`` — a baseline drift reaching 1 at the end of the window.

The model is calibrated on ``[0, T_window]`` and judged on the held-out ``(T_window, horizon]``.

Parameters and priors (data are in an arbitrary "data unit", du)
-----------------------------------------------------------------
``amplitude``       log-uniform on [0.01, 100] du. Restricting ``A > 0`` removes the sign
                    symmetry ``A sin(x + φ) = (-A) sin(x + φ + π)``.
``frequency_Hz``    uniform on [0.2, 5] Hz (well below the 10 Hz Nyquist frequency of the
                    default 20 samples/s).
``phase_rad``       uniform on a 2π-long branch ``[c - π, c + π]``, c = 0 by default, i.e.
                    (-π, π]. The model is 2π-periodic in φ and the prior is uniform on the
                    circle, so the choice of branch does not change the posterior, only where
                    the cut lies; :func:`run_toy` moves the branch (c = π) when the spectral
                    estimate of φ is within π/2 of ±π, so the posterior never straddles the
                    cut. With ``A > 0`` and one branch the posterior is unimodal.
``noise_sd``        log-uniform on [0.001, 10] du; estimated (sampled), not marginalised.
``ar1_coefficient`` (``--likelihood ar1`` only) uniform on (-1, 1), the whole stationary
                    range: the AR(1) correlation between consecutive samples. A smooth
                    discrepancy gives positive values; negative ones are allowed because
                    nothing in the likelihood requires rho >= 0. Sampled in the logit
                    coordinate (:class:`~beam.inference.priors.Uniform`): a smooth discrepancy
                    pushes rho towards 1, where a bounded coordinate would make the joint
                    posterior with ``noise_sd`` a sharply curved ridge (marginal sd ~
                    innovation sd / sqrt(1 - rho²)) that the ensemble explores slowly.

The "truth" of the noise parameters is that of the measurement noise (``noise_sd = σ``,
``ar1_coefficient = 0``): the discrepancy is not noise, which is exactly why an estimated
``noise_sd`` absorbs it.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from beam.errors import BeamInputError
from beam.inference._arviz import import_arviz
from beam.inference.laplace import LaplaceResult, preview
from beam.inference.likelihood import AR1_COEFFICIENT, LIKELIHOODS, NOISE_SD
from beam.inference.predictive import PredictiveBands
from beam.inference.priors import LogUniform, Uniform
from beam.inference.problem import Parameter, Problem
from beam.inference.results import PosteriorResult
from beam.inference.sampling import EnsembleRun

__all__ = [
    "AMPLITUDE_PRIOR",
    "AR1_PRIOR",
    "FREQUENCY_PRIOR_HZ",
    "KINDS",
    "MODEL_PARAMETERS",
    "NOISE_PRIOR",
    "TONE_RATIO",
    "UNITS",
    "ToyData",
    "ToyResult",
    "ToyScenario",
    "calibration_problem",
    "default_sweep_windows",
    "discrepancy_shape",
    "phase_branch_centre",
    "run_toy",
    "simulate",
    "sine_model",
    "spectral_initial_guesses",
    "sweep_windows",
    "toy_problem",
    "wrap_phase",
]

#: Discrepancy kinds.
KINDS = ("harmonic", "tone", "drift")
#: Frequency of the ``tone`` discrepancy relative to the model frequency.
TONE_RATIO = 1.37
#: Physical parameters of the toy model, in order.
MODEL_PARAMETERS = ("amplitude", "frequency_Hz", "phase_rad")
#: Support of the frequency prior, Hz.
FREQUENCY_PRIOR_HZ = (0.2, 5.0)
#: Support of the amplitude prior (log-uniform), du.
AMPLITUDE_PRIOR = (0.01, 100.0)
#: Support of the noise_sd prior (log-uniform), du.
NOISE_PRIOR = (1e-3, 10.0)
#: Support of the ar1_coefficient prior (uniform, logit coordinate).
AR1_PRIOR = (-1.0, 1.0)
#: Longest record accepted (samples), to keep a typo in --horizon from exhausting memory.
MAX_SAMPLES = 200_000

#: Unit of each parameter ("du": the data unit).
UNITS = {"amplitude": "du", "frequency_Hz": "Hz", "phase_rad": "rad", NOISE_SD: "du", AR1_COEFFICIENT: "1"}


@dataclass(frozen=True)
class ToyScenario:
    """One toy experiment (defaults: the reference case of the README).

    Attributes
    ----------
    amplitude : float
        True amplitude ``A`` (du).
    frequency_Hz : float
        True frequency ``f`` (Hz).
    phase_rad : float
        True phase ``φ`` (rad).
    noise_sd : float
        Standard deviation of the i.i.d. measurement noise (du).
    sample_rate_Hz : float
        Sampling rate (samples per second).
    window_s : float
        Calibration window ``[0, window_s]`` (s).
    horizon_s : float
        End of the record; ``(window_s, horizon_s]`` is held out (s).
    discrepancy : float
        Discrepancy amplitude ``δ`` (du); 0 means the model is correct.
    kind : {"harmonic", "tone", "drift"}
        Discrepancy shape.
    likelihood : {"iid", "ar1"}
        Noise model of the calibration.
    seed : int
        Seed of the noise realisation and of the sampler.
    target_ess : float
        Bulk ESS per parameter the MCMC runs to.
    """

    amplitude: float = 1.0
    frequency_Hz: float = 1.0
    phase_rad: float = 0.3
    noise_sd: float = 0.1
    sample_rate_Hz: float = 20.0
    window_s: float = 5.0
    horizon_s: float = 20.0
    discrepancy: float = 0.0
    kind: str = "harmonic"
    likelihood: str = "iid"
    seed: int = 0
    target_ess: float = 1000.0

    def validate(self) -> ToyScenario:
        """Raise :class:`~beam.errors.BeamInputError` (one line) on an invalid scenario."""
        finite = ("amplitude", "frequency_Hz", "phase_rad", "noise_sd", "sample_rate_Hz", "window_s", "horizon_s", "discrepancy", "target_ess")
        for name in finite:
            if not math.isfinite(float(getattr(self, name))):
                raise BeamInputError(f"toy scenario: {name} must be a finite number, got {getattr(self, name)}")
        if self.kind not in KINDS:
            raise BeamInputError(f"unknown discrepancy kind {self.kind!r}; expected one of {', '.join(KINDS)}")
        if self.likelihood not in LIKELIHOODS:
            raise BeamInputError(f"unknown likelihood {self.likelihood!r}; expected one of {', '.join(LIKELIHOODS)}")
        if self.window_s <= 0.0:
            raise BeamInputError(f"calibration window must be positive, got {self.window_s:g} s")
        if self.horizon_s <= self.window_s:
            raise BeamInputError(
                f"calibration window ({self.window_s:g} s) must be shorter than the horizon ({self.horizon_s:g} s)"
            )
        if self.noise_sd < 0.0:
            raise BeamInputError(f"noise sd must not be negative, got {self.noise_sd:g}")
        if not NOISE_PRIOR[0] <= self.noise_sd <= NOISE_PRIOR[1]:
            raise BeamInputError(
                f"noise sd must lie in the noise_sd prior range [{NOISE_PRIOR[0]:g}, {NOISE_PRIOR[1]:g}], got {self.noise_sd:g}"
            )
        if not FREQUENCY_PRIOR_HZ[0] <= self.frequency_Hz <= FREQUENCY_PRIOR_HZ[1]:
            raise BeamInputError(
                f"frequency must lie in the prior range [{FREQUENCY_PRIOR_HZ[0]:g}, {FREQUENCY_PRIOR_HZ[1]:g}] Hz, got {self.frequency_Hz:g}"
            )
        if not AMPLITUDE_PRIOR[0] <= self.amplitude <= AMPLITUDE_PRIOR[1]:
            raise BeamInputError(f"amplitude must lie in the prior range [{AMPLITUDE_PRIOR[0]:g}, {AMPLITUDE_PRIOR[1]:g}], got {self.amplitude:g}")
        if self.sample_rate_Hz <= 2.0 * FREQUENCY_PRIOR_HZ[1]:
            raise BeamInputError(
                f"sample rate {self.sample_rate_Hz:g} Hz must exceed twice the highest prior frequency ({FREQUENCY_PRIOR_HZ[1]:g} Hz)"
            )
        period = 1.0 / self.frequency_Hz
        if self.window_s < period:
            raise BeamInputError(
                f"calibration window ({self.window_s:g} s) is shorter than one period of the {self.frequency_Hz:g} Hz oscillation ({period:g} s)"
            )
        if self.horizon_s * self.sample_rate_Hz > MAX_SAMPLES:
            raise BeamInputError(f"horizon ({self.horizon_s:g} s) gives more than {MAX_SAMPLES} samples")
        if int(self.seed) != self.seed or self.seed < 0:
            raise BeamInputError(f"seed must be a non-negative integer, got {self.seed}")
        if self.target_ess <= 0:
            raise BeamInputError(f"target ESS must be positive, got {self.target_ess:g}")
        return self

    def truth(self, phase_centre_rad: float = 0.0) -> dict[str, float]:
        """True parameter values (phase on the branch centred on ``phase_centre_rad``)."""
        out = {
            "amplitude": float(self.amplitude),
            "frequency_Hz": float(self.frequency_Hz),
            "phase_rad": float(wrap_phase(self.phase_rad, phase_centre_rad)),
            NOISE_SD: float(self.noise_sd),
        }
        if self.likelihood == "ar1":
            out[AR1_COEFFICIENT] = 0.0
        return out


def wrap_phase(phase_rad: float | np.ndarray, centre_rad: float = 0.0):
    """Phase on the branch ``[centre - π, centre + π)`` (values already on it are unchanged)."""
    x = np.asarray(phase_rad, dtype=float)
    lo, hi = centre_rad - math.pi, centre_rad + math.pi
    wrapped = centre_rad + np.mod(x - centre_rad + math.pi, 2.0 * math.pi) - math.pi
    out = np.where((x >= lo) & (x < hi), x, wrapped)
    return float(out) if out.ndim == 0 else out


@dataclass
class ToyData:
    """Simulated record on the full horizon (arrays of shape (n,)).

    Attributes
    ----------
    time_s : ndarray
        Sample times ``k / sample_rate``, ``0 <= t <= horizon`` (s).
    signal : ndarray
        The model part ``A sin(2π f t + φ)`` (du).
    truth : ndarray
        Noise-free truth, ``signal + δ d(t)`` (du).
    data : ndarray
        Observations, ``truth + noise`` (du).
    calibration : ndarray of bool
        True on the calibration window ``t <= window``; the rest is held out.
    """

    time_s: np.ndarray
    signal: np.ndarray
    truth: np.ndarray
    data: np.ndarray
    calibration: np.ndarray

    @property
    def held_out(self) -> np.ndarray:
        """Boolean mask of the held-out samples."""
        return ~self.calibration


def discrepancy_shape(kind: str, time_s: np.ndarray, scenario: ToyScenario) -> np.ndarray:
    """The unscaled discrepancy ``d(t)`` (du per unit δ) of ``kind`` on ``time_s``."""
    t = np.asarray(time_s, dtype=float)
    f, phi = scenario.frequency_Hz, scenario.phase_rad
    if kind == "harmonic":
        return np.sin(4.0 * math.pi * f * t + phi)
    if kind == "tone":
        return np.sin(2.0 * math.pi * TONE_RATIO * f * t)
    if kind == "drift":
        return t / scenario.window_s
    raise BeamInputError(f"unknown discrepancy kind {kind!r}; expected one of {', '.join(KINDS)}")


def simulate(scenario: ToyScenario, *, calibration_window_s: float | None = None) -> ToyData:
    """Simulate the record of a scenario (deterministic for ``scenario.seed``).

    ``calibration_window_s`` overrides the calibration mask only (the truth, including the
    drift normalisation by ``scenario.window_s``, is unchanged), which is what the window
    sweep uses.
    """
    scenario.validate()
    n = math.floor(scenario.horizon_s * scenario.sample_rate_Hz + 1e-9) + 1
    t = np.arange(n) / scenario.sample_rate_Hz
    signal = scenario.amplitude * np.sin(2.0 * math.pi * scenario.frequency_Hz * t + scenario.phase_rad)
    truth = signal + scenario.discrepancy * discrepancy_shape(scenario.kind, t, scenario)
    rng = np.random.default_rng(scenario.seed)
    data = truth + scenario.noise_sd * rng.standard_normal(n)
    window = scenario.window_s if calibration_window_s is None else calibration_window_s
    return ToyData(time_s=t, signal=signal, truth=truth, data=data, calibration=t <= window + 1e-9)


def sine_model(values: Mapping[str, np.ndarray], time_s: np.ndarray) -> np.ndarray:
    """Vectorised model ``A sin(2π f t + φ)``, shape (B, len(time_s)), in du."""
    a = np.asarray(values["amplitude"], dtype=float)[:, None]
    f = np.asarray(values["frequency_Hz"], dtype=float)[:, None]
    phi = np.asarray(values["phase_rad"], dtype=float)[:, None]
    return a * np.sin((2.0 * math.pi) * f * np.asarray(time_s, dtype=float)[None, :] + phi)


def _ls_sine_fit(t: np.ndarray, y: np.ndarray, freqs: np.ndarray):
    """Least-squares ``a sin ωt + b cos ωt`` at each frequency: (a, b, RSS reduction)."""
    w = 2.0 * math.pi * freqs[:, None] * t[None, :]
    s, c = np.sin(w), np.cos(w)
    sy, cy = s @ y, c @ y
    ss, cc, sc = np.einsum("ij,ij->i", s, s), np.einsum("ij,ij->i", c, c), np.einsum("ij,ij->i", s, c)
    det = ss * cc - sc * sc
    det = np.where(det > 1e-12 * ss * cc, det, np.inf)
    a = (cc * sy - sc * cy) / det
    b = (ss * cy - sc * sy) / det
    return a, b, a * sy + b * cy


def spectral_initial_guesses(
    time_s: np.ndarray,
    data: np.ndarray,
    *,
    f_range_Hz: tuple[float, float] = FREQUENCY_PRIOR_HZ,
    n_peaks: int = 3,
    phase_centre_rad: float = 0.0,
) -> list[dict[str, float]]:
    """Starting points from the least-squares (Lomb–Scargle-type) periodogram.

    For every frequency of a grid ten times finer than the Fourier resolution ``1/T`` the
    best ``a sin ωt + b cos ωt`` is fitted by linear least squares; the reduction of the
    residual sum of squares is the profile log likelihood of the frequency. The ``n_peaks``
    highest local maxima are refined by parabolic interpolation and converted to
    ``A = hypot(a, b) > 0`` and ``φ = atan2(b, a)`` on the phase branch. Unlike an FFT peak
    this is exact for windows of only one or two periods.

    Returns
    -------
    list of dict
        ``{"amplitude", "frequency_Hz", "phase_rad"}`` per peak, best first (natural units).
    """
    t = np.asarray(time_s, dtype=float)
    y = np.asarray(data, dtype=float)
    span = max(float(t[-1] - t[0]), 1e-9)
    df = 0.1 / span
    freqs = np.arange(f_range_Hz[0], f_range_Hz[1] + 0.5 * df, df)
    freqs = freqs[freqs <= f_range_Hz[1]]
    _, _, red = _ls_sine_fit(t, y, freqs)
    padded = np.concatenate([[-np.inf], red, [-np.inf]])
    peaks = np.flatnonzero((padded[1:-1] >= padded[:-2]) & (padded[1:-1] >= padded[2:]))
    peaks = peaks[np.argsort(red[peaks])[::-1]][:n_peaks]
    guesses = []
    for k in peaks:
        f = freqs[k]
        if 0 < k < freqs.size - 1:
            y0, y1, y2 = red[k - 1], red[k], red[k + 1]
            curv = y0 - 2.0 * y1 + y2
            if curv < 0.0:
                f = freqs[k] + 0.5 * df * (y0 - y2) / curv
        a, b, _ = _ls_sine_fit(t, y, np.array([f]))
        amp = float(np.clip(math.hypot(a[0], b[0]), AMPLITUDE_PRIOR[0], AMPLITUDE_PRIOR[1]))
        guesses.append(
            {"amplitude": amp, "frequency_Hz": float(f), "phase_rad": float(wrap_phase(math.atan2(b[0], a[0]), phase_centre_rad))}
        )
    return guesses


def phase_branch_centre(time_s: np.ndarray, data: np.ndarray) -> float:
    """Centre of the phase branch: 0, or π when the spectral phase estimate is near ±π."""
    best = spectral_initial_guesses(time_s, data, n_peaks=1)[0]
    return math.pi if abs(best["phase_rad"]) > 0.5 * math.pi else 0.0


def toy_problem(
    time_s: np.ndarray,
    data: np.ndarray,
    *,
    likelihood: str = "iid",
    fixed: Mapping[str, float] | None = None,
    phase_centre_rad: float = 0.0,
) -> Problem:
    """The toy calibration problem on one window of data.

    Parameters
    ----------
    time_s, data : ndarray, shape (n,)
        Calibration samples (uniform grid; seconds and du).
    likelihood : {"iid", "ar1"}
        Noise model.
    fixed : mapping, optional
        Parameters held at known values (e.g. ``{"frequency_Hz": 1, "phase_rad": 0.3}``).
    phase_centre_rad : float
        Centre of the phase branch (see the module docstring).

    Returns
    -------
    Problem
        Priors as in the module docstring; initial guesses from
        :func:`spectral_initial_guesses`.
    """
    fixed = dict(fixed or {})
    params = [
        Parameter("amplitude", LogUniform(*AMPLITUDE_PRIOR), "du", "amplitude A of the sine"),
        Parameter("frequency_Hz", Uniform(*FREQUENCY_PRIOR_HZ), "Hz", "frequency f"),
        Parameter("phase_rad", Uniform(phase_centre_rad - math.pi, phase_centre_rad + math.pi), "rad", "phase φ at t = 0"),
        Parameter(NOISE_SD, LogUniform(*NOISE_PRIOR), "du", "noise standard deviation (estimated)"),
    ]
    if likelihood == "ar1":
        params.append(Parameter(AR1_COEFFICIENT, Uniform(*AR1_PRIOR, coordinate="logit"), "1", "lag-one correlation of the residuals"))
    params = [p for p in params if p.name not in fixed]

    def guesses(problem: Problem) -> list[dict[str, float]]:
        if "frequency_Hz" in problem.fixed:  # linear in the rest: one start is enough
            return [{}]
        return spectral_initial_guesses(problem.time_s, problem.data, phase_centre_rad=phase_centre_rad)

    return Problem(
        parameters=params,
        model=sine_model,
        time_s=time_s,
        data=data,
        likelihood=likelihood,
        fixed=fixed,
        initial_guesses=guesses,
        name="toy sine",
        data_unit="du",
    )


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

    One record is simulated with the scenario's seed (the truth, including the drift
    normalisation by ``scenario.window_s``, is fixed); for each window the model is calibrated
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
