"""Which effect is missing, judged on several records of one beam together.

Each candidate effect's evidence is **joint**: the Laplace log evidence of the joint calibration
(:func:`beam.calibration.joint.joint_preview`) of base + effect minus that of the base, both on
every record. Beside it, per record:

- ``delta_log_evidence``: what the record says **alone** (its single previews' Laplace evidence,
  the joint search's starts, so at no extra cost);
- ``delta_log_likelihood``: its share of the joint gain, the change of its log likelihood
  between the two joint MAPs (the records' shares plus the change of the log prior and of the
  Occam factor make the joint Δ log evidence).

A record alone may not separate two effects (one visible mode: a mass at the sensor and a mass at
the tip lower f1 alike) where the records together do (they lower f1 differently at another
length): :attr:`JointDiagnosis.separated` names such pairs and :meth:`JointDiagnosis.verdict`
says so, with the two models' predicted f1 of each record.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass, field

import numpy as np

from beam.calibration.joint import JointCalibrationResult, joint_preview
from beam.calibration.spec import CalibrationSpec
from beam.discovery.ranking import MATERIAL_LOG_EVIDENCE, candidate_effects, with_effect
from beam.calibration.defaults import DEFAULT_EFFECTS
from beam.errors import BeamInputError
from beam.physics.effects import BASE_PARAMETERS, EFFECTS, sensor_mass, tip_mass

__all__ = ["JointCandidate", "JointDiagnosis", "SEPARATING_NATS", "alone_separation", "joint_diagnose", "separation_words"]

#: Evidence difference (nats) above which two effects are told apart, below which (|Δ| < 3: odds
#: under 20:1) a record is said not to separate them.
SEPARATING_NATS = 3.0


@dataclass
class JointCandidate:
    """A candidate effect judged on every record.

    Attributes
    ----------
    effect : str
        The effect added to the base model.
    delta_log_evidence : float or None
        Joint Laplace Δ log evidence against the base (nats); None when its fit failed.
    records_delta_log_evidence : list of float
        Each record's Δ log evidence alone (nats).
    records_delta_log_likelihood : list of float
        Each record's log-likelihood change between the joint MAPs (nats).
    records_max_log_likelihood : list of float
        Each record's highest log likelihood alone (its own MAP under base + effect, nats).
    records_laplace_ok : list of bool
        Whether the record's own Laplace approximations (base and base + effect) are sound (a
        positive-definite Hessian, the MAP inside the prior): where not, the record's posterior
        is a flat ridge and its Laplace Occam factor depends on where the search stopped on it.
    error : str or None
        Why the joint fit failed.
    """

    effect: str
    delta_log_evidence: float | None
    records_delta_log_evidence: list[float] = field(default_factory=list)
    records_delta_log_likelihood: list[float] = field(default_factory=list)
    records_max_log_likelihood: list[float] = field(default_factory=list)
    records_laplace_ok: list[bool] = field(default_factory=list)
    error: str | None = None

    @property
    def material(self) -> bool:
        """Whether it improves the joint model materially (:data:`MATERIAL_LOG_EVIDENCE`)."""
        return self.delta_log_evidence is not None and self.delta_log_evidence >= MATERIAL_LOG_EVIDENCE

    def to_json(self) -> dict:
        return {"effect": self.effect, "delta_log_evidence": self.delta_log_evidence, "material": self.material,
                "records_delta_log_evidence": self.records_delta_log_evidence,
                "records_delta_log_likelihood": self.records_delta_log_likelihood,
                "records_max_log_likelihood": self.records_max_log_likelihood,
                "records_laplace_ok": self.records_laplace_ok, "error": self.error}


@dataclass
class JointDiagnosis:
    """A joint diagnosis: the base model's joint fit, the candidates best first, their joint fits."""

    base: JointCalibrationResult
    candidates: list[JointCandidate]
    fits: dict[str, JointCalibrationResult]
    seconds: float
    suggestion: dict | None = None  # which record to take next (beam.discovery.suggest.next_record)

    @property
    def names(self) -> list[str]:
        return [r.setup.measurement.name for r in self.base.records]

    @property
    def missing(self) -> str | None:
        """The best candidate when it improves the joint model materially, else None."""
        top = self.candidates[0] if self.candidates else None
        return top.effect if top is not None and top.material else None

    @property
    def separated(self) -> list[tuple[str, str]]:
        """Pairs (better, worse): a material candidate and one ranked below it that every record
        alone leaves within :data:`SEPARATING_NATS` of it (:func:`alone_separation`) but the
        records together separate by more."""
        out = []
        ranked = [c for c in self.candidates if c.delta_log_evidence is not None]
        for i, a in enumerate(ranked):
            if not a.material:
                continue
            for b in ranked[i + 1:]:
                alone = np.abs(alone_separation(a, b))
                if np.all(alone < SEPARATING_NATS) and a.delta_log_evidence - b.delta_log_evidence >= SEPARATING_NATS:
                    out.append((a.effect, b.effect))
        return out

    def separation(self) -> list[dict]:
        """For each pair of :attr:`separated`: ``better``, ``worse``, the joint
        ``delta_log_evidence`` between them (nats), ``alone`` (each record's own separation,
        :func:`alone_separation`) and ``records``: per record its ``length_m`` and
        ``sensor_position_m`` and the first natural frequency of the two joint MAP models
        (``f1_better_Hz``, ``f1_worse_Hz``) and their difference ``f1_difference_pct``
        (100 |f_better - f_worse| / f_worse)."""
        out = []
        by_effect = {c.effect: c for c in self.candidates}
        for better, worse in self.separated:
            a, b = self.f1_Hz(better), self.f1_Hz(worse)
            records = []
            for view, fa, fb in zip(self.base.record_results(), a, b):
                geometry = view.setup.measurement.geometry
                records.append({"record": view.setup.measurement.name, "length_m": float(geometry.length_m),
                                "sensor_position_m": float(geometry.sensor_position_m),
                                "f1_better_Hz": fa, "f1_worse_Hz": fb, "f1_difference_pct": 100.0 * abs(fa - fb) / fb})
            out.append({"better": better, "worse": worse,
                        "delta_log_evidence": self._delta(better) - self._delta(worse),
                        "alone": [float(v) for v in alone_separation(by_effect[better], by_effect[worse])],
                        "records": records})
        return out

    def f1_Hz(self, effect: str | None) -> list[float]:
        """Each record's first natural frequency (Hz) under the joint MAP of base + ``effect``
        (None: the base)."""
        fit = self.base if effect is None else self.fits[effect]
        out = []
        for view in fit.record_results():
            values = {n: float(v) for n, v in view.laplace.map.values.items() if n in view.setup.physical_names}
            out.append(float(view.setup.model.natural_modes(values, 1)[0][0]))
        return out

    def verdict(self) -> str:
        """One paragraph: the missing effect on the joint evidence, and what the records together
        separate that none separates alone."""
        if self.missing is None:
            return (f"Jointly on {len(self.names)} records no candidate improves the model materially "
                    f"(Δ log evidence < {MATERIAL_LOG_EVIDENCE:g} nats).")
        top = self.candidates[0]
        words = [f"Jointly on {len(self.names)} records the model misses {top.effect} "
                 f"(Δ log evidence {top.delta_log_evidence:+.1f} nats)."]
        for pair in self.separation():
            words.append(separation_words(pair))
        return " ".join(words)

    def _delta(self, effect: str) -> float:
        return next(c.delta_log_evidence for c in self.candidates if c.effect == effect)

    def records_json(self) -> list[dict]:
        """Per record: ``record``, ``modes_table`` (the base model's joint fit against the record's
        identified modes, :func:`beam.discovery.report.residual_report`) and
        ``delta_log_evidence`` (per candidate: the record alone)."""
        from beam.discovery.report import residual_report
        import beam.residuals as dx

        out = []
        for k, view in enumerate(self.base.record_results()):
            try:
                table = [dx.jsonable(asdict(row)) for row in residual_report(view).comparison]
            except BeamInputError:
                table = []
            out.append({
                "record": view.setup.measurement.name,
                "modes_table": table,
                "delta_log_evidence": {c.effect: (c.records_delta_log_evidence[k] if c.records_delta_log_evidence
                                                  else None) for c in self.candidates},
                "delta_log_likelihood": {c.effect: (c.records_delta_log_likelihood[k]
                                                    if c.records_delta_log_likelihood else None)
                                         for c in self.candidates},
                "rmse_calibration_base": view.rmse_calibration,
                "rmse_prediction_base": view.rmse_prediction,
            })
        return out

    def to_json(self) -> dict:
        """The summary of ``beam diagnose A B ... --json``."""
        base = self.base
        ladder = [{"added": None, **_ladder_rung(base)}]
        if self.missing is not None:
            ladder.append({"added": self.missing, **_ladder_rung(self.fits[self.missing])})
        return {
            "measurements": self.names,
            "base": list(base.records[0].setup.effects),
            "per_record": list(base.per_record),
            "candidates": [c.to_json() for c in self.candidates],
            "missing": self.missing,
            "separated": [list(pair) for pair in self.separated],
            "separation": self.separation(),
            "ladder": ladder,
            "verdict": self.verdict(),
            "records": self.records_json(),
            "seconds": self.seconds,
        }


#: How a verdict names the winner of a pair (better, worse); other pairs: "better, not worse".
PAIR_WORDS = {(sensor_mass.EFFECT.id, tip_mass.EFFECT.id): "the mass sits at the sensor, not the tip",
              (tip_mass.EFFECT.id, sensor_mass.EFFECT.id): "the mass sits at the tip, not at the sensor"}


def alone_separation(a: JointCandidate, b: JointCandidate) -> np.ndarray:
    """How far each record alone separates candidates ``a`` and ``b`` (nats, positive for ``a``):
    the difference of their Laplace Δ log evidence where the record's Laplace approximations are
    sound, else the difference of the record's highest log likelihoods under each (a Laplace
    Occam factor on a flat ridge is not a measurement; the data's own preference is)."""
    laplace = np.subtract(a.records_delta_log_evidence, b.records_delta_log_evidence)
    if not (a.records_laplace_ok and b.records_laplace_ok and a.records_max_log_likelihood):
        return laplace
    ok = np.logical_and(a.records_laplace_ok, b.records_laplace_ok)
    likelihood = np.subtract(a.records_max_log_likelihood, b.records_max_log_likelihood)
    return np.where(ok, laplace, likelihood)


def separation_words(pair: dict) -> str:
    """One sentence for an entry of :meth:`JointDiagnosis.separation`: the winner, and the two
    records (by free length when they differ, else by name) where the two models' f1 differ most."""
    better, worse = pair["better"], pair["worse"]
    head = PAIR_WORDS.get((better, worse), f"{better}, not {worse}")
    records = sorted(pair["records"], key=lambda r: -r["f1_difference_pct"])[:2]
    lengths = {round(r["length_m"], 3) for r in pair["records"]}
    label = (lambda r: f"{100.0 * r['length_m']:.0f} cm") if len(lengths) == len(pair["records"]) else (
        lambda r: r["record"])
    where = " and ".join(label(r) for r in records)
    gaps = " and ".join(f"{r['f1_difference_pct']:.2g} %" for r in records)
    return (f"{head[0].upper()}{head[1:]}: no record alone separates {better} from {worse} (each within "
            f"{SEPARATING_NATS:g} nats), together they do by {pair['delta_log_evidence']:.1f} nats: at {where} the two "
            f"predict f1 differently by {gaps}.")


def _ladder_rung(fit: JointCalibrationResult) -> dict:
    views = fit.record_results()
    return {"log_evidence": float(fit.laplace.log_evidence),
            "rmse_calibration": [v.rmse_calibration for v in views],
            "rmse_prediction": [v.rmse_prediction for v in views],
            "coverage95_prediction": [v.coverage95_prediction for v in views]}


def joint_diagnose(
    measurements: Sequence,
    *,
    window: tuple[float, float] | None = None,
    modes: int | str = "auto",
    base: Iterable[str] | str = DEFAULT_EFFECTS,
    candidates: Iterable[str] | None = None,
    per_record: Iterable[str] | str | None = None,
    shared: Iterable[str] | str | None = None,
    engine=None,
) -> JointDiagnosis:
    """Rank candidate effects by their joint Laplace evidence on several records of one beam.

    Parameters
    ----------
    measurements : sequence of Measurement
        The records (each with its own sidecar).
    window, modes : optional
        Calibration window (s) and retained modes of every record (defaults resolved per record).
    base : iterable of str or str
        Effects of the current model.
    candidates : iterable of str, optional
        Effects to try; default the catalogue's candidates every record can show
        (:func:`beam.discovery.ranking.candidate_effects` of each record).
    per_record, shared : optional
        Physical parameters per record (:func:`beam.calibration.joint.resolve_per_record`); a name
        that only a candidate brings is per record in that candidate's fit only.
    """
    t0 = time.perf_counter()
    measurements = tuple(measurements)
    spec = CalibrationSpec(window=window, effects=base, modes=modes)
    if candidates is None:
        offered = [set(candidate_effects(spec.effects, m)) for m in measurements]
        candidates = [e for e in candidate_effects(spec.effects, measurements[0]) if all(e in o for o in offered)]
    candidates = tuple(candidates)
    fit = _fitter(measurements, spec, per_record, shared, engine)
    base_fit = fit(spec.effects)
    if isinstance(base_fit, Exception):
        raise base_fit
    fits: dict[str, JointCalibrationResult] = {}
    ranked: list[JointCandidate] = []
    base_ll = _record_log_likelihoods(base_fit)
    for effect in candidates:
        result = fit(with_effect(spec.effects, effect), [nested_start(base_fit, effect)])
        if isinstance(result, Exception):
            ranked.append(JointCandidate(effect, None, error=str(result).splitlines()[0]))
            continue
        fits[effect] = result
        ranked.append(JointCandidate(
            effect, float(result.laplace.log_evidence - base_fit.laplace.log_evidence),
            [float(c.laplace.log_evidence - b.laplace.log_evidence) for c, b in zip(result.records, base_fit.records)],
            [float(v) for v in _record_log_likelihoods(result) - base_ll],
            [_max_log_likelihood(c) for c in result.records],
            [bool(c.laplace.ok and b.laplace.ok) for c, b in zip(result.records, base_fit.records)]))
    ranked.sort(key=lambda c: -math.inf if c.delta_log_evidence is None else -c.delta_log_evidence)
    return JointDiagnosis(base_fit, ranked, fits, time.perf_counter() - t0)


def nested_start(base: JointCalibrationResult, effect: str) -> dict[str, float]:
    """The base model's joint MAP with ``effect``'s parameters at their null values (the end of the
    catalogue's range where the effect vanishes): the model with the effect starts no lower than
    the base's optimum embedded in it."""

    start = {name: float(v) for name, v in base.laplace.map.values.items()}
    for p in EFFECTS[effect].parameters:
        start[p.name] = p.prior_high if p.absent_at == "high" else p.prior_low
    return start


def _fitter(measurements, spec, per_record, shared, engine):
    def fit(effects, starts=()):
        try:
            physical_names = _names_in(per_record, effects)
            return joint_preview(measurements, spec.with_effects(effects), per_record=physical_names,
                                 shared=shared, engine=engine, starts=starts)
        except (BeamInputError, RuntimeError, FloatingPointError, ValueError, np.linalg.LinAlgError) as exc:
            return exc
    return fit


def _names_in(per_record, effects):
    """The ``per_record`` names that belong to the model with ``effects`` (the others belong to a
    candidate not in it): matched against the catalogue's parameter names."""
    if per_record is None:
        return None
    names = [n for n in (per_record.split(",") if isinstance(per_record, str) else per_record) if n.strip()]
    own = {p.name for p in BASE_PARAMETERS} | {p.name for e in effects for p in EFFECTS[e].parameters}
    kept = [n.strip() for n in names if n.strip() in effects or any(p.startswith(n.strip()) for p in own)]
    return kept


def _max_log_likelihood(record) -> float:
    """A record's log likelihood at its own MAP (nats): the log posterior minus the log prior."""
    z = record.laplace.map.z[None, :]
    return float(record.laplace.map.log_posterior - record.problem.log_prior(z)[0])


def _record_log_likelihoods(fit: JointCalibrationResult) -> np.ndarray:
    problem = fit.problem
    return problem.record_log_likelihoods(problem.from_internal(fit.laplace.map.z[None, :]))[:, 0]
