"""The diagnosis's first look at a free decay: every candidate ranked on the averaged forms.

On a free decay the diagnosis (:func:`beam.discovery.stream.diagnosis_stream`) ranks every
applicable candidate — the linear ones as shifts of the modes, ``quadratic_drag``,
``clamp_friction`` and ``tip_cubic_spring`` by their describing functions — on the record's own
backbone and damping curves (:func:`beam.calibration.slowflow.score_candidates`), streams that
ranking and its verdict, and only then confirms the leaders with the full time-domain fits,
whose figures replace the averaged ones as they end. Each candidate says which it is
(:attr:`beam.discovery.ranking.Candidate.source`: ``"averaged"`` or ``"full"``).

The averaged ranking is judged by the one rule (:func:`beam.discovery.judgement.judge_numbers`,
the same thresholds) on the curves' figures:

1. the **evidence**: the Laplace log evidence of the curves' fit, base + candidate against the
   base (nats);
2. the **error it is judged on**: the rms z-score of the window's identified blocks with the
   identification's own standard errors (``window_rms_z``; 1 when the model follows the curves
   to their errors). A base already at most :data:`~beam.discovery.judgement.AT_NOISE_RATIO` of
   them (its curves followed to their errors) is "at the noise": the evidence decides;
3. the **prediction after the window**: the rms z-score of the blocks after the window
   (``heldout_rms_z_identified``), not worse by more than :data:`~beam.discovery.judgement.HELD_OUT_WORSE`;
4. **plausible** parameters (:func:`beam.discovery.plausibility.implausible_parameters` on the
   curves' MAP: at a prior bound, against a stated value, outside the literature's range).

Units: evidence in nats, errors in z-scores (dimensionless), times in s.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from types import SimpleNamespace

from beam.calibration import CalibrationResult, CalibrationSpec
from beam.discovery.judgement import MATERIAL_LOG_EVIDENCE, effect_kind, elsewhere, judge_numbers, order_key
from beam.discovery.plausibility import implausible_parameters
from beam.discovery.ranking import Candidate, Ranking, candidate_effects, record_features
from beam.errors import BeamInputError
from beam.io.measurement import Measurement
from beam.physics.effects import EFFECTS, effect_needs

__all__ = ["AVERAGED", "CURVE_ERROR", "CurveRequest", "FULL", "averaged_candidates", "averaged_ranking",
           "averaged_verdict", "confirmed", "merged_ranking"]

#: The two sources of a candidate's figures.
AVERAGED, FULL = "averaged", "full"
#: What the errors of the averaged judgement are, in words.
CURVE_ERROR = "error on the backbone and damping curves (rms z)"
CURVE_HELD_OUT = "error on the curves after the window (rms z)"
#: Needs of a nonlinear effect's full (driven) calibration that its averaged form on a free decay does not have.
_DRIVEN_NEEDS = frozenset({"input", "uniform", "displacement", "rising_frequency"})


def averaged_candidates(base: Iterable[str], measurement: Measurement) -> tuple[str, ...]:
    """The candidates a free decay is ranked on by the averaged forms, in catalogue order: those
    the full diagnosis offers (:func:`beam.discovery.ranking.candidate_effects`) and every
    nonlinear effect with an averaged form whose needs the record has, but for those of its
    driven or spectral offer (``clamp_friction`` without a rising frequency, ``tip_cubic_spring``
    on a free decay: the curves show them or not). Empty for a record that is no free decay or
    whose unit is arbitrary (no amplitude-dependent force without the scale)."""
    features = set(measurement.features)
    if "free" not in features or getattr(measurement, "arbitrary_units", False):
        return ()
    present = set(base)
    offered = set(candidate_effects(base, measurement))
    for name, effect in EFFECTS.items():
        if effect.nonlinear and effect.averaged is not None and name not in present:
            if effect_needs(name) - _DRIVEN_NEEDS <= features:
                offered.add(name)
    return tuple(e for e in EFFECTS if e in offered)


@dataclass(frozen=True)
class CurveRequest:
    """Every candidate scored on the record's curves by the averaged forms
    (:func:`beam.calibration.slowflow.score_candidates`), on the base's resolved window.

    Attributes
    ----------
    spec : CalibrationSpec
        The base's resolved spec (effects, window).
    candidates : tuple of str
        The candidates (:func:`averaged_candidates`).
    """

    spec: CalibrationSpec
    candidates: tuple[str, ...]

    @property
    def effects(self) -> tuple[str, ...]:
        return tuple(self.spec.effects)

    @property
    def label(self) -> str:
        """What the request computes, in words."""
        return (f"ranking {len(self.candidates)} candidates on the record's backbone and damping curves "
                "(averaged forms)")

    def run(self, measurement: Measurement, engine=None) -> list:
        """The :class:`~beam.calibration.slowflow.SlowFlowScore` list (base first), or the
        exception when the curves cannot be scored (no resolved mode, too few blocks): the
        diagnosis then goes on with the full fits alone."""
        from beam.calibration.slowflow import score_candidates
        try:
            return score_candidates(measurement, self.spec.effects, self.candidates, window=tuple(self.spec.window))
        except (BeamInputError, ValueError, ArithmeticError) as exc:
            return exc


@dataclass(frozen=True)
class _CurveFit:
    """A curves' fit seen as the plausibility check reads a calibration (its MAP, bounds, priors,
    modes and record): :func:`beam.discovery.plausibility.implausible_parameters` on the
    averaged MAP."""

    laplace: SimpleNamespace
    problem: SimpleNamespace
    setup: SimpleNamespace = field(repr=False)

    @classmethod
    def of(cls, score, base: CalibrationResult) -> _CurveFit:
        from beam.calibration.setup import parameter_prior

        m = base.setup.measurement
        parameters = [SimpleNamespace(name=n, prior=parameter_prior(n, m.prior_nominal, m.nominal_spread))
                      for n in score.values]
        return cls(SimpleNamespace(map=SimpleNamespace(values=dict(score.values), at_bound=tuple(score.at_bound))),
                   SimpleNamespace(parameters=parameters), SimpleNamespace(measurement=m, modes=base.setup.modes))


def _summary(value: float, interval) -> dict[str, float]:
    """A parameter of the curves' fit in the full candidates' currency (``mean``, ``sd``, ``q025``,
    ``q975``, as a posterior summary): the Laplace approximation's optimum as its mean, its 95 %
    interval as the quantiles and a quarter of that interval (1.96 sd a side) as its sd."""
    lo, hi = (float(v) for v in interval)
    return {"mean": float(value), "sd": (hi - lo) / (2 * 1.959964), "q025": lo, "q975": hi}


def averaged_ranking(base: CalibrationResult, scores: list, explain: dict[str, str] | None = None) -> Ranking:
    """The :class:`~beam.discovery.ranking.Ranking` of the averaged ``scores`` (base first, as
    :func:`~beam.calibration.slowflow.score_candidates` returns them) against ``base`` (the
    base's full preview: the ranking's base), each candidate judged by the one rule on the
    curves' figures (module notes), ``source`` ``"averaged"``; ``explain``: the fingerprint
    sentence of each effect (the residual report's)."""
    first, rest = scores[0], scores[1:]
    judgements, parameters = {}, {}
    for s in rest:
        gain = float(s.log_evidence - first.log_evidence)
        findings = implausible_parameters(s.candidate, _CurveFit.of(s, base)) if gain >= MATERIAL_LOG_EVIDENCE else []
        judgements[s.candidate] = judge_numbers(
            s.candidate, gain, (first.window_rms_z, s.window_rms_z),
            (first.heldout_rms_z_identified, s.heldout_rms_z_identified),
            judged_label=CURVE_ERROR, held_out_label=CURVE_HELD_OUT, findings=findings, noise=1.0)
        parameters[s.candidate] = {n: _summary(s.values[n], s.intervals[n])
                                   for n in EFFECTS[s.candidate].required_parameter_names_for(base.setup.modes)
                                   if n in s.values}
    if any(j.status == "implausible" for j in judgements.values()):
        kinds = {effect_kind(e) for e, j in judgements.items() if j.status == "implausible"}
        spectral = any("rising_frequency" in effect_needs(e) for e in EFFECTS if effect_kind(e) in kinds)
        judgements = elsewhere(judgements, record_features(base.setup.measurement, spectral=spectral),
                               base.setup.effects)
    words = explain or {}
    ranked = []
    for s in rest:
        j = judgements[s.candidate]
        sentence = words.get(s.candidate) or EFFECTS[s.candidate].physics
        if j.status != "missing" and j.status != "not_material":
            sentence = f"{j.reason()}. {sentence}"
        ranked.append(Candidate(s.candidate, j.delta_log_evidence, math.nan, math.nan, math.nan, j.material,
                                f"on the curves (averaged forms): {sentence}", parameters[s.candidate], j,
                                source=AVERAGED))
    ranked.sort(key=lambda c: order_key(c.judgement))
    return Ranking(base, ranked)


def confirmed(ranking: Ranking, linear: Iterable[str], most: int = 3) -> list[str]:
    """The candidates the full fits confirm, in the averaged order: every linear one the full
    diagnosis offers (``linear``: a preview each, a fraction of a second to a few seconds), and
    the nonlinear ones named missing on the curves, at most ``most`` of them (each full fit
    integrates the decay: seconds to minutes; one the curves do not call for keeps its averaged
    figures)."""
    linear = list(linear)
    nonlinear = [c.effect for c in ranking.candidates if EFFECTS[c.effect].nonlinear and c.material][:most]
    order = [c.effect for c in ranking.candidates]
    chosen = set(linear) | set(nonlinear)
    return [e for e in order if e in chosen] + [e for e in linear if e not in order]


def merged_ranking(base: CalibrationResult, averaged: Ranking | None, full: Ranking) -> Ranking:
    """``full`` (the candidates whose full fits have ended) with every other candidate of
    ``averaged`` after them, as it was ranked on the curves: listed by status
    (:func:`~beam.discovery.judgement.order_key`), a full fit before an averaged one of the same
    status (their evidences are of other data and not compared), then by evidence."""
    if averaged is None:
        return full
    have = {c.effect for c in full.candidates}
    rest = [c for c in averaged.candidates if c.effect not in have]
    status = {c.effect: order_key(c.judgement)[0] for c in [*full.candidates, *rest]}
    merged = sorted([*full.candidates, *rest],
                    key=lambda c: (status[c.effect], c.source != FULL, order_key(c.judgement)[1]))
    out = Ranking(base, merged, dict(full.results))
    out.frequencies_Hz = dict(full.frequencies_Hz)
    return out


def averaged_verdict(ranking: Ranking, unit: str = "") -> str:
    """The averaged ranking's verdict in one sentence: what is missing on the curves, with its
    evidence and the curves' error before and after, or that nothing is; and that the full fits
    are confirming it."""
    best = next((c for c in ranking.candidates if c.material), None)
    if best is None:
        return ("nothing in the catalogue is missing on the record's backbone and damping curves (averaged "
                "forms); the full fits are confirming it")
    j = best.judgement
    return (f"missing (averaged forms): {best.effect} (+{best.delta_log_evidence:.0f} nats on the backbone and "
            f"damping curves; their rms z-score {j.judged_before:.3g} -> {j.judged_after:.3g}); the full fit is "
            "confirming it")
