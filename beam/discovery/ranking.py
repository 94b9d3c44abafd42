"""Which physical effect is missing: rank candidate effects, then climb the error ladder.

For each effect of the catalogue not in the current model, calibrate base + effect (MAP +
Laplace) on the same window and compare with the current model by

* the **Laplace log evidence** log p(data | model). It is the probability of the data averaged
  over the prior, so it carries the Occam factor of the effect's parameters: an effect the data
  cannot pin down pays for its prior volume. (BIC would ignore the prior; AIC/WAIC need
  posterior samples; the Laplace evidence is available from the preview at no extra cost and is
  accurate for the near-Gaussian posteriors of well-identified beam parameters.) Reported as
  delta_log_evidence = log Z(model + effect) - log Z(model), in nats;
* the **errors of the MAP model** (its point prediction: a parameter pressed against its bound, as
  an absent effect's is, spreads the Laplace draws and would blur the band's mean): in the window,
  and after it.

Which candidate is missing is decided by one rule, :func:`beam.discovery.judgement.judge`
(material evidence, a material fall of the error it is judged on, a prediction after the window
that is not worse, plausible parameters); every candidate carries its
:class:`~beam.discovery.judgement.Judgement`, and the ranking lists them in its one order
(:func:`beam.discovery.judgement.order_key`). The best candidate named missing is reported; when
none is, nothing in the catalogue is missing.

The error ladder (:func:`beam.discovery.stream.error_ladder`) adds the missing candidates one at
a time, best first, as long as each is still missing on top of the rung below (effects can
explain the same misfit: once the best is in, the next may no longer help), re-calibrating at
each step with the one calibration engine and start strategy of :mod:`beam.calibration` (the
same MAP as ``beam calibrate`` with that effect set; the steps a user takes in the dashboard are
re-calibrated with full MCMC; the command line uses the preview unless asked for MCMC).
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
    CalibrationSpec,
    calibration_preview,
)
from beam.calibration.defaults import DEFAULT_LIKELIHOOD
from beam.discovery.judgement import (
    HELD_OUT_WORSE,
    MATERIAL_LOG_EVIDENCE,
    MATERIAL_RMSE_FALL,
    Judgement,
    effect_kind,
    elsewhere,
    judge,
    judge_numbers,
    order_key,
)
from beam.errors import BeamInputError
from beam.io.measurement import Measurement
from beam.physics.effects import CANDIDATE_EFFECTS, EFFECTS, applicable, effect_needs, parse_effects
from beam.residuals.envelope import RISING_DRIFT, decay_frequency_drift



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
        Whether it is named missing (:attr:`Judgement.material <beam.discovery.judgement.Judgement.material>`).
    explanation : str
        One sentence grounded in the fingerprints of the residuals.
    parameters : dict
        Posterior summaries of the effect's own parameters.
    judgement : Judgement or None
        The one rule's decision (:func:`beam.discovery.judgement.judge`); None for a candidate
        made from numbers alone (then :func:`judgement_of` judges its numbers).
    source : str
        Where its figures come from: ``"full"`` (the time-domain calibration of base + effect)
        or ``"averaged"`` (its averaged form fitted to the record's backbone and damping
        curves, :mod:`beam.discovery.averaged`: the evidence is the curves', the RMSEs and
        coverage are unknown, NaN).
    """

    effect: str
    delta_log_evidence: float
    rmse_prediction: float
    rmse_calibration: float
    coverage95_prediction: float
    material: bool
    explanation: str
    parameters: dict
    judgement: Judgement | None = None
    source: str = "full"

    @property
    def status(self) -> str | None:
        """Its judgement's status (:data:`beam.discovery.judgement.STATUSES`), None without one."""
        return None if self.judgement is None else self.judgement.status

    def to_json(self) -> dict:
        out = {
            "effect": self.effect,
            "delta_log_evidence": _finite_or_none(self.delta_log_evidence),
            "rmse_prediction": _finite_or_none(self.rmse_prediction),
            "rmse_calibration": _finite_or_none(self.rmse_calibration),
            "coverage95_prediction": _finite_or_none(self.coverage95_prediction),
            "material": self.material,
            "explanation": self.explanation,
            "parameters": self.parameters,
            "source": self.source,
        }
        if self.judgement is not None:
            out.update(self.judgement.to_json())
        return out


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
        """Its figures in the JSON: the MAP's errors (the numbers every other line quotes) and the
        band's coverage."""
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
        """The best candidate named missing (:func:`beam.discovery.judgement.judge`), or None."""
        return next((c.effect for c in self.candidates if c.material), None)


Explainer = Callable[[str, CalibrationResult, CalibrationResult], str]


def record_features(measurement: Measurement, spectral: bool = True) -> frozenset[str]:
    """The features of a record that effects can need (:data:`beam.physics.effects.RECORD_FEATURES`).

    ``spectral=False`` leaves out ``rising_frequency``, the one read from the record's spectra
    (~0.1 s on a 20 s, 4 kHz record), for a caller whose effects do not need it.
    """
    features = set(measurement.features)  # what the record shows without its spectra
    if spectral and "free" in features:
        memo = vars(measurement)  # the record is frozen: its drift is read once (every partial ranking asks)
        if "_decay_frequency_drift" not in memo:
            memo["_decay_frequency_drift"] = decay_frequency_drift(measurement.time_s, measurement.output)
        if memo["_decay_frequency_drift"] < -RISING_DRIFT:
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


def thread_fitter(measurement: Measurement, spec: CalibrationSpec, workers: int = 2, search: bool = True,
                  on_fit: Callable[[tuple[str, ...], int, int], None] | None = None) -> Fitter:
    """The default :data:`Fitter`: previews of ``spec`` (its window, modes and likelihood; each
    set's effects) in ``workers`` threads (the compiled kernels release the GIL; the Python
    between them does not, so two threads gain ~1.2x on two cores); ``search=False``: screening
    fits (:func:`beam.calibration.calibration_preview`). ``on_fit(effects, done, total)``, if
    given, is called (from the fitting thread) as each fit of a call ends: its effect set, how
    many of the call's ``total`` fits have ended."""
    def fit(effects: tuple[str, ...]) -> CalibrationResult | Exception:
        try:
            return calibration_preview(measurement, spec.for_model(effects), search=search)
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
    likelihood: str = DEFAULT_LIKELIHOOD,
) -> Ranking:
    """Calibrate the current model and each candidate (preview; by ``fitter``, default
    :func:`thread_fitter` with ``workers`` threads), ranked best first."""
    base = parse_effects(base)
    if base_result is None:
        base_result = calibration_preview(measurement, CalibrationSpec(window=window, effects=base, modes=modes,
                                                                       likelihood=likelihood))
    spec = CalibrationSpec.of_setup(base_result.setup)  # "auto" resolved once, for every candidate
    names = candidate_effects(base, measurement) if candidates is None else parse_effects(candidates)
    if set(names) & set(base):
        raise BeamInputError(f"candidate {sorted(set(names) & set(base))[0]!r} is already in the model")
    fitter = fitter or thread_fitter(measurement, spec, workers)
    fits = dict(zip(names, fitter([with_effect(base, effect) for effect in names])))
    return rank_fits(base_result, names, fits, explain)


def rank_fits(base_result: CalibrationResult, names: Iterable[str],
              fits: dict[str, CalibrationResult | Exception], explain: Explainer | None = None) -> Ranking:
    """The :class:`Ranking` of the candidates ``names`` whose fits are ``fits`` (a calibration,
    or the exception of a failed fit) against ``base_result``: each judged by the one rule
    (:func:`beam.discovery.judgement.judge`), an implausible one told what else can explain the
    data (:func:`beam.discovery.judgement.elsewhere`), in the one order
    (:func:`beam.discovery.judgement.order_key`)."""
    modes = base_result.setup.modes
    names = list(names)
    judgements = {effect: judge(effect, base_result, fits[effect]) for effect in names}
    if any(j.status == "implausible" for j in judgements.values()):
        kinds = {effect_kind(e) for e, j in judgements.items() if j.status == "implausible"}
        spectral = any("rising_frequency" in effect_needs(e) for e in EFFECTS if effect_kind(e) in kinds)
        features = record_features(base_result.setup.measurement, spectral=spectral)
        judgements = elsewhere(judgements, features, base_result.setup.effects)
    ranked, results = [], {}
    for effect in names:
        result, judgement = fits[effect], judgements[effect]
        if isinstance(result, Exception):
            ranked.append(Candidate(effect, -math.inf, math.nan, math.nan, math.nan, False,
                                    f"the fit with {effect} failed ({_one_line(result)})", {}, judgement))
            continue
        results[effect] = result
        summary = result.summary()
        own = {name: summary[name] for name in EFFECTS[effect].required_parameter_names_for(modes) if name in summary}
        sentence = explain(effect, base_result, result) if explain else EFFECTS[effect].physics
        ranked.append(Candidate(effect, judgement.delta_log_evidence, result.rmse_prediction_map,
                                result.rmse_calibration_map, result.coverage95_prediction, judgement.material, sentence,
                                own, judgement))
    ranked.sort(key=lambda c: order_key(c.judgement))
    return Ranking(base_result, ranked, results)


def rank_key(c: Candidate, base: CalibrationResult | None = None) -> tuple[int, float]:
    """Sort key of the ranking: :func:`beam.discovery.judgement.order_key` of the candidate's
    judgement (:func:`judgement_of`; without ``base``, of its own numbers against none)."""
    return order_key(judgement_of(c, base))


def judgement_of(c: Candidate, base: CalibrationResult | None = None) -> Judgement:
    """The candidate's judgement, or for a candidate made from numbers alone (no fit at hand) the
    rule applied to its numbers against ``base``'s (no plausibility check: no parameters at hand)."""
    if c.judgement is not None:
        return c.judgement
    if base is None:
        return judge_numbers(c.effect, c.delta_log_evidence, (math.nan, math.nan), (math.nan, math.nan),
                             judged_label="held-out error", held_out_label="held-out error")
    free = base.setup.is_free
    judged = ((base.rmse_calibration_map, c.rmse_calibration) if free else (base.rmse_prediction_map, c.rmse_prediction))
    return judge_numbers(c.effect, c.delta_log_evidence, judged, (base.rmse_prediction_map, c.rmse_prediction),
                         judged_label="calibration-window error" if free else "held-out error",
                         held_out_label="held-out error")


def held_out_change(candidate: Candidate, base: CalibrationResult) -> float:
    """Relative change of the candidate's judged held-out error against the base model's (0.15:
    15 % higher; NaN when either is unknown): its judgement's (the amplitude-aware prediction of a
    free decay, :mod:`beam.discovery.held_out`), else its held-out RMSE's."""
    return judgement_of(candidate, base).held_out_change


#: Relative rise of the held-out RMSE above which it "rises" (below it the optimiser's noise: the
#: same model refitted moves it by less).
HELD_OUT_RISE = 1e-3


def contradicted(candidate: Candidate, base: CalibrationResult) -> bool:
    """Whether the evidence favours ``candidate`` (a positive gain) while its judged held-out error
    rises (by more than :data:`HELD_OUT_RISE`) against the base model's: the two disagree, and the
    evidence is then no support for the effect (it sees only the calibration window)."""
    return bool(candidate.delta_log_evidence > 0 and held_out_change(candidate, base) > HELD_OUT_RISE)


def window_only(candidate: Candidate, base: CalibrationResult) -> bool:
    """A material evidence gain whose prediction after the window is worse: the judgement
    ``"fails_after_window"`` (:func:`beam.discovery.judgement.judge`). Ranked below the others and
    named by the verdict."""
    return judgement_of(candidate, base).status == "fails_after_window"


def improves(current: CalibrationResult, candidate: CalibrationResult) -> bool:
    """Whether ``candidate`` (``current`` plus one effect) is that effect named missing on top of
    ``current``: :func:`beam.discovery.judgement.judge` (the one rule of the module notes)."""
    added = [e for e in candidate.setup.effects if e not in set(current.setup.effects)]
    if len(added) != 1:
        raise BeamInputError(f"a candidate adds one effect to the model it is judged against, got {added}")
    return judge(added[0], current, candidate).material


def ladder_step(result: CalibrationResult, added: str | None, mcmc: bool) -> LadderStep:
    """The :class:`LadderStep` of ``result`` (``added``: the effect it adds to the rung below, None
    for the base; ``mcmc``: whether it is a full calibration): the MAP's errors, the numbers the
    header, the candidates and the verdict quote; the band's coverage."""
    return LadderStep(result.setup.effects, added, result.rmse_calibration_map, result.rmse_prediction_map,
                      result.coverage95_prediction, float(result.laplace.log_evidence), mcmc, result)


def _finite_or_none(value: float) -> float | None:
    return float(value) if value is not None and math.isfinite(value) else None


def _one_line(exc: Exception) -> str:
    return " ".join(str(exc).split())[:200]
