"""Which physical effect is missing: rank candidate effects, then climb the error ladder.

For each effect of the catalogue not in the current model, calibrate base + effect (MAP +
Laplace) on the same window and compare with the current model by

* the **Laplace log evidence** log p(data | model). It is the probability of the data averaged
  over the prior, so it carries the Occam factor of the effect's parameters: an effect the data
  cannot pin down pays for its prior volume. (BIC would ignore the prior; AIC/WAIC need
  posterior samples; the Laplace evidence is available from the preview at no extra cost and is
  accurate for the near-Gaussian posteriors of well-identified beam parameters.) Reported as
  delta_log_evidence = log Z(model + effect) - log Z(model), in nats;
* the **held-out prediction RMSE** of the MAP model (samples outside the calibration window), the
  predictive check (the MAP's point prediction: a parameter pressed against its bound, as an
  absent effect's is, spreads the Laplace draws and would blur the band's mean).

A candidate *materially improves* the model when delta_log_evidence >= 5 nats (odds of about
150:1, "very strong" on the Kass–Raftery scale) **and** it lowers the held-out RMSE by at least
20 %. The best such candidate is reported as missing; when none qualifies, nothing in the catalogue
is missing.

The error ladder (:func:`beam.discovery.stream.error_ladder`) adds the materially improving candidates one at a time, best first, as long as
each materially improves on the rung below (effects can explain the same misfit: once the best
is in, the next may no longer help), re-calibrating at each step with the one calibration engine and start strategy of
:mod:`beam.calibration` (the same MAP as ``beam calibrate`` with that effect set; the steps a user takes in the dashboard are re-calibrated with full
MCMC; the command line uses the preview unless asked for MCMC).
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable, Iterable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np

from beam.calibration import (
    AUTO_MODES,
    DEFAULT_EFFECTS,
    CalibrationResult,
    calibration_preview,
)
from beam.errors import BeamInputError
from beam.io.measurement import Measurement
from beam.physics.effects import CANDIDATE_EFFECTS, EFFECTS, applicable, effect_needs, parse_effects
from beam.residuals.envelope import RISING_DRIFT, decay_frequency_drift

#: Evidence gain (nats) a candidate needs to count as a material improvement.
MATERIAL_LOG_EVIDENCE = 5.0
#: Relative fall of the held-out RMSE a candidate needs to count as a material improvement.
MATERIAL_RMSE_FALL = 0.2


@dataclass(frozen=True)
class Candidate:
    """One candidate effect, calibrated as the current model plus it.

    Attributes
    ----------
    effect : str
        Effect id.
    delta_log_evidence : float
        Laplace log evidence gain over the current model (nats); -inf when its fit failed.
    rmse_prediction : float
        Held-out RMSE of the MAP model with the effect (m).
    rmse_calibration : float
        RMSE in the calibration window (m).
    coverage95_prediction : float
        Held-out coverage of the 95 % prediction band.
    material : bool
        Whether it materially improves the model (see the module notes).
    explanation : str
        One sentence grounded in the fingerprints of the residuals.
    parameters : dict
        Posterior summaries of the effect's own parameters.
    """

    effect: str
    delta_log_evidence: float
    rmse_prediction: float
    rmse_calibration: float
    coverage95_prediction: float
    material: bool
    explanation: str
    parameters: dict

    def to_json(self) -> dict:
        return {
            "effect": self.effect,
            "delta_log_evidence": _finite_or_none(self.delta_log_evidence),
            "rmse_prediction": _finite_or_none(self.rmse_prediction),
            "rmse_calibration": _finite_or_none(self.rmse_calibration),
            "coverage95_prediction": _finite_or_none(self.coverage95_prediction),
            "material": self.material,
            "explanation": self.explanation,
            "parameters": self.parameters,
        }


@dataclass(frozen=True)
class LadderStep:
    """One rung of the error ladder: a model and how well it predicts."""

    effects: tuple[str, ...]
    added: str | None
    rmse_calibration: float
    rmse_prediction: float
    coverage95_prediction: float
    log_evidence: float
    mcmc: bool
    #: The rung's calibration (not in the JSON).
    result: CalibrationResult | None = field(default=None, repr=False, compare=False)

    def to_json(self) -> dict:
        return {
            "effects": list(self.effects),
            "added": self.added,
            "rmse_calibration": _finite_or_none(self.rmse_calibration),
            "rmse_prediction": _finite_or_none(self.rmse_prediction),
            "coverage95_prediction": _finite_or_none(self.coverage95_prediction),
            "log_evidence": _finite_or_none(self.log_evidence),
            "mcmc": self.mcmc,
        }


@dataclass
class Ranking:
    """Candidates ranked against the current model."""

    base: CalibrationResult
    candidates: list[Candidate]
    results: dict[str, CalibrationResult] = field(repr=False, default_factory=dict)
    #: MAP natural frequencies (Hz) of each candidate's fit, all its retained modes: what the
    #: verdict compares when the fits themselves are not at hand (the dashboard receives the
    #: ranking from a worker process without them).
    frequencies_Hz: dict[str, np.ndarray] = field(repr=False, default_factory=dict)

    @property
    def missing(self) -> str | None:
        """The best materially improving candidate, or None when nothing is missing."""
        return next((c.effect for c in self.candidates if c.material), None)


Explainer = Callable[[str, CalibrationResult, CalibrationResult], str]


def record_features(measurement: Measurement, spectral: bool = True) -> frozenset[str]:
    """The features of a record that effects can need (:data:`beam.physics.effects.RECORD_FEATURES`).

    ``spectral=False`` leaves out ``rising_frequency``, the one read from the record's spectra
    (~0.1 s on a 20 s, 4 kHz record), for a caller whose effects do not need it.
    """
    features = set(measurement.features)  # what the record shows without its spectra
    if spectral and "free" in features and decay_frequency_drift(measurement.time_s, measurement.output) < -RISING_DRIFT:
        features.add("rising_frequency")
    return frozenset(features)


def candidate_effects(current: Iterable[str], measurement: Measurement | None = None) -> tuple[str, ...]:
    """Catalogue effects offered as candidates (:data:`beam.physics.effects.CANDIDATE_EFFECTS`) not in the
    current model, in catalogue order.

    With a ``measurement`` the offer fits the record: only effects whose needs
    (:func:`beam.physics.effects.effect_needs`) the record has (:func:`record_features`); and the
    effects offered on records (:attr:`~beam.physics.effects.effect.Effect.offered_on_records`:
    the sensor's mass, where an accelerometer, a contact sensor, loads the beam where it measures;
    a laser's displacement or velocity has none) join where they apply. So: no patch effect
    without a patch, no input effect without an input, the tip's cubic spring (nonlinear) only on
    a driven displacement record on uniform stamps; and no effect whose force depends on the
    amplitude on a record in arbitrary units (:func:`beam.io.measurement.true_unit_problem`).
    """
    present = set(parse_effects(current))
    offered = list(CANDIDATE_EFFECTS)
    if measurement is not None:
        offered += [e for e in EFFECTS if EFFECTS[e].offered_on_records]
        spectral = any("rising_frequency" in effect_needs(e) for e in offered)
        features = record_features(measurement, spectral=spectral)
        offered = [e for e in offered if applicable(e, features)]
        if getattr(measurement, "arbitrary_units", False):  # no amplitude without the scale (true_unit_problem)
            offered = [e for e in offered if not EFFECTS[e].nonlinear]
    return tuple(effect for effect in EFFECTS if effect in offered and effect not in present)


#: ``fitter(effect_sets)``: the preview calibration (:func:`beam.calibration.calibration_preview`) of
#: each effect set on the ranking's record, window and modes, a result or the exception of a failed fit
#: per set, in order. The default fits them in threads; the dashboard spreads them over its worker
#: processes.
Fitter = Callable[[list[tuple[str, ...]]], list["CalibrationResult | Exception"]]

#: Errors of a candidate's fit that rank it last instead of stopping the diagnosis.
FIT_ERRORS = (RuntimeError, FloatingPointError, ValueError, BeamInputError)


def thread_fitter(measurement: Measurement, window: tuple[float, float], modes: int, workers: int = 2,
                  search: bool = True, on_fit: Callable[[tuple[str, ...], int, int], None] | None = None) -> Fitter:
    """The default :data:`Fitter`: previews in ``workers`` threads (the compiled kernels release
    the GIL; the Python between them does not, so two threads gain ~1.2x on two cores);
    ``search=False``: screening fits (:func:`beam.calibration.calibration_preview`).
    ``on_fit(effects, done, total)``, if given, is called (from the fitting thread) as each fit
    of a call ends: its effect set, how many of the call's ``total`` fits have ended."""
    def fit(effects: tuple[str, ...]) -> CalibrationResult | Exception:
        try:
            return calibration_preview(measurement, window=window, effects=effects, modes=modes, search=search)
        except FIT_ERRORS as exc:  # a failed fit: ranked last
            return exc

    def fitter(effect_sets: list[tuple[str, ...]]) -> list[CalibrationResult | Exception]:
        ended, lock = [0], threading.Lock()

        def counted(effects: tuple[str, ...]) -> CalibrationResult | Exception:
            result = fit(effects)
            with lock:
                ended[0] += 1
                on_fit(effects, ended[0], len(effect_sets))
            return result

        with ThreadPoolExecutor(max_workers=max(1, int(workers))) as pool:
            return list(pool.map(fit if on_fit is None else counted, effect_sets))

    return fitter


def with_effect(base: Iterable[str], effect: str) -> tuple[str, ...]:
    """``base`` + ``effect`` in catalogue order (the effect set a candidate's fit calibrates)."""
    chosen = set(base) | {effect}
    return tuple(e for e in EFFECTS if e in chosen)


def rank_candidates(
    measurement: Measurement,
    *,
    base: Iterable[str] | str = DEFAULT_EFFECTS,
    window: tuple[float, float] | None = None,
    modes: int | str = AUTO_MODES,
    candidates: Iterable[str] | None = None,
    explain: Explainer | None = None,
    base_result: CalibrationResult | None = None,
    workers: int = 2,
    fitter: Fitter | None = None,
) -> Ranking:
    """Calibrate the current model and each candidate (preview; by ``fitter``, default
    :func:`thread_fitter` with ``workers`` threads), ranked best first."""
    base = parse_effects(base)
    if base_result is None:
        base_result = calibration_preview(measurement, window=window, effects=base, modes=modes)
    window, modes = base_result.setup.window, base_result.setup.modes  # "auto" resolved once, for every candidate
    names = candidate_effects(base, measurement) if candidates is None else parse_effects(candidates)
    if set(names) & set(base):
        raise BeamInputError(f"candidate {sorted(set(names) & set(base))[0]!r} is already in the model")
    fitter = fitter or thread_fitter(measurement, window, modes, workers)
    fits = dict(zip(names, fitter([with_effect(base, effect) for effect in names])))
    return rank_fits(base_result, names, fits, explain)


def rank_fits(base_result: CalibrationResult, names: Iterable[str],
              fits: dict[str, CalibrationResult | Exception], explain: Explainer | None = None) -> Ranking:
    """The :class:`Ranking` of the candidates ``names`` whose fits are ``fits`` (a calibration,
    or the exception of a failed fit, ranked last) against ``base_result``."""
    modes = base_result.setup.modes
    ranked, results = [], {}
    for effect in names:
        result = fits[effect]
        if isinstance(result, Exception):
            ranked.append(Candidate(effect, -math.inf, math.nan, math.nan, math.nan, False,
                                    f"the fit with {effect} failed ({_one_line(result)})", {}))
            continue
        results[effect] = result
        delta = float(result.laplace.log_evidence - base_result.laplace.log_evidence)
        rmse = result.rmse_prediction_map
        material = improves(base_result, result)
        summary = result.summary()
        own = {name: summary[name] for name in EFFECTS[effect].required_parameter_names_for(modes) if name in summary}
        sentence = explain(effect, base_result, result) if explain else EFFECTS[effect].physics
        ranked.append(Candidate(effect, delta, rmse, result.rmse_calibration,
                                result.coverage95_prediction, material, sentence, own))
    ranked.sort(key=lambda c: rank_key(c, base_result))
    return Ranking(base_result, ranked, results)


def rank_key(c: Candidate, base: CalibrationResult | None = None) -> tuple[bool, bool, float]:
    """Sort key of the ranking: materially improving first (by evidence gain: which one is missing
    does not change), then (given the ``base`` fit) the others whose evidence is not contradicted
    by their held-out error (:func:`window_only`), then by evidence gain, failed fits last."""
    demoted = base is not None and not c.material and window_only(c, base)
    return (not c.material, demoted, -c.delta_log_evidence if math.isfinite(c.delta_log_evidence) else math.inf)


def held_out_change(candidate: Candidate, base: CalibrationResult) -> float:
    """Relative change of the candidate's held-out RMSE against the base model's (0.15: 15 % higher;
    NaN when either is unknown)."""
    before = base.rmse_prediction_map
    if not (math.isfinite(candidate.rmse_prediction) and math.isfinite(before) and before > 0):
        return math.nan
    return float(candidate.rmse_prediction / before - 1.0)


#: Relative rise of the held-out RMSE above which it "rises" (below it the optimiser's noise: the
#: same model refitted moves it by less).
HELD_OUT_RISE = 1e-3


def contradicted(candidate: Candidate, base: CalibrationResult) -> bool:
    """Whether the evidence favours ``candidate`` (a positive gain) while its held-out error rises
    (by more than :data:`HELD_OUT_RISE`) against the base model's: the two disagree, and the evidence
    is then no support for the effect (it sees only the calibration window)."""
    return bool(candidate.delta_log_evidence > 0 and held_out_change(candidate, base) > HELD_OUT_RISE)


def window_only(candidate: Candidate, base: CalibrationResult) -> bool:
    """A large evidence gain (at least :data:`MATERIAL_LOG_EVIDENCE`) that the held-out error
    contradicts (:func:`contradicted`): a base model far from the data lets any added flexibility
    fit the calibration window better. Ranked below the uncontradicted candidates and named by the
    verdict."""
    return bool(candidate.delta_log_evidence >= MATERIAL_LOG_EVIDENCE and contradicted(candidate, base))


def improves(current: CalibrationResult, candidate: CalibrationResult) -> bool:
    """Whether ``candidate`` materially improves on ``current`` (evidence and held-out error).

    For a free decay the error that must fall by :data:`MATERIAL_RMSE_FALL` is the calibration
    window's, not the held-out decay's: with no input, the prediction of the rest of a decay is
    the extrapolation of each mode's damping, and a lightly damped mode at the right frequency
    with a slightly wrong decay scores worse than a wrong model that damps the mode away (on the
    real strip records: the repaired model's calibration RMSE /8, its 2-20 s held-out RMSE x1.1,
    its 2-4 s RMSE unchanged; README, "Real measurements").
    """
    delta = float(candidate.laplace.log_evidence - current.laplace.log_evidence)
    if current.setup.is_free:
        before, after = current.rmse_calibration_map, candidate.rmse_calibration_map
    else:
        before, after = current.rmse_prediction_map, candidate.rmse_prediction_map
    return bool(delta >= MATERIAL_LOG_EVIDENCE and after <= (1 - MATERIAL_RMSE_FALL) * before)


def ladder_step(result: CalibrationResult, added: str | None, mcmc: bool) -> LadderStep:
    """The :class:`LadderStep` of ``result`` (``added``: the effect it adds to the rung below, None
    for the base; ``mcmc``: whether it is a full calibration)."""
    return LadderStep(result.setup.effects, added, result.rmse_calibration, result.rmse_prediction,
                      result.coverage95_prediction, float(result.laplace.log_evidence), mcmc, result)


def _finite_or_none(value: float) -> float | None:
    return float(value) if value is not None and math.isfinite(value) else None


def _one_line(exc: Exception) -> str:
    return " ".join(str(exc).split())[:200]
