"""Which effect is missing, judged on several records of one beam together.

Each candidate effect's evidence is **joint**: the Laplace log evidence of the joint calibration
(:func:`beam.calibration.joint.joint_preview`) of base + effect minus that of the base, both on
every record. Beside it, per record:

- ``delta_log_evidence``: what the record says **alone** (its single previews' Laplace evidence,
  the joint search's starts, so at no extra cost);
- ``delta_log_likelihood``: its share of the joint gain, the change of its log likelihood
  between the two joint MAPs (the records' shares plus the change of the log prior and of the
  Occam factor make the joint Δ log evidence).

Each candidate is judged by the one rule of a single record (:func:`judge_joint`, the rule of
:func:`beam.discovery.judgement.judge` on the records' figures: the joint evidence, the judged error
pooled over the records, and no record's prediction after the window worse), and the **joint
ladder** climbs as the single one does: the best candidate named missing is added, the others are
ranked again on top of it (joint fits from the rung's MAP with the effect switched off), and the
climb goes on while a rung is missing (at most :data:`MAX_JOINT_RUNGS`). :meth:`JointDiagnosis.table`
puts the joint figures and each record's in one table, rung by rung.

A record alone may not separate two effects (one visible mode: a mass at the sensor and a mass at
the tip lower f1 alike) where the records together do (they lower f1 differently at another
length): :attr:`JointDiagnosis.separated` names such pairs of effects that change the same thing
(:func:`beam.discovery.judgement.effect_kind`: two frequency effects, never a damping against a
length) and :meth:`JointDiagnosis.verdict` says so, with each record's own f1 beside the two
models'. :meth:`JointDiagnosis.intervals` gives the last rung's shared parameters with their
joint interval and what widens it (the correlations, a record the joint model fits worse than its
own fit does).

An effect that changes the geometry (the effective free length) is not offered on records of
different stated lengths: one free length shared by a 30 cm and a 60 cm record is no strip's (its
joint fit put f1 75 % off), and one per record (``--per-record effective_length``, when asked)
frees every record's f1 by its own parameter.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from beam.calibration import CalibrationResult
from beam.calibration.joint import JointCalibrationResult, joint_preview
from beam.calibration.spec import CalibrationSpec
from beam.discovery.held_out import held_out_error
from beam.discovery.judgement import (
    HELD_OUT_WORSE,
    STATUS_WORDS,
    Judgement,
    effect_kind,
    judge_numbers,
    noise_floor_sd,
    order_key,
)
from beam.discovery.plausibility import implausible_parameters
from beam.discovery.ranking import MATERIAL_LOG_EVIDENCE, candidate_effects, with_effect
from beam.calibration.defaults import DEFAULT_EFFECTS
from beam.errors import BeamInputError
from beam.inference import LaplaceResult, MapResult
from beam.inference.progress import reporting
from beam.physics.effects import BASE_PARAMETERS, EFFECTS, sensor_mass, tip_mass

__all__ = ["JointCandidate", "JointDiagnosis", "JointRung", "MAX_JOINT_RUNGS", "SEPARATING_NATS", "TIED_NATS",
           "alone_separation", "joint_candidates", "joint_diagnose", "joint_order_key", "judge_joint", "map_views",
           "separation_words"]

#: Most effects the joint ladder adds to the base.
MAX_JOINT_RUNGS = 3
#: Two missing candidates of a rung whose joint evidence differs by less than this (nats) are tied:
#: the ladder climbs on both (two paths at most) and keeps the path that ends with the higher joint
#: evidence (:data:`beam.discovery.findings.INDISTINGUISHABLE_LOG_EVIDENCE`'s 3 nats: odds under 20 : 1).
TIED_NATS = 3.0

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
    judgement : Judgement or None
        The one rule's decision on it (:func:`judge_joint`); None: judged by its evidence alone.
    rung : int
        The rung of the joint ladder it was judged on top of (0: the base).
    records_errors : list of dict
        Each record's ``rmse_calibration`` and ``rmse_prediction`` (the MAP's, output's unit) and
        ``held_out_judged`` (the error after the window it is judged on) under its joint fit.
    """

    effect: str
    delta_log_evidence: float | None
    records_delta_log_evidence: list[float] = field(default_factory=list)
    records_delta_log_likelihood: list[float] = field(default_factory=list)
    records_max_log_likelihood: list[float] = field(default_factory=list)
    records_laplace_ok: list[bool] = field(default_factory=list)
    error: str | None = None
    judgement: Judgement | None = None
    rung: int = 0
    records_errors: list[dict] = field(default_factory=list)

    @property
    def material(self) -> bool:
        """Whether it is named missing jointly (its judgement; without one: the joint evidence
        reaches :data:`MATERIAL_LOG_EVIDENCE`)."""
        if self.judgement is not None:
            return self.judgement.material
        return self.delta_log_evidence is not None and self.delta_log_evidence >= MATERIAL_LOG_EVIDENCE

    @property
    def status(self) -> str:
        """Its judgement's status (:data:`beam.discovery.judgement.STATUSES`)."""
        if self.judgement is not None:
            return self.judgement.status
        if self.delta_log_evidence is None:
            return "failed"
        return "missing" if self.material else "not_material"

    def to_json(self) -> dict:
        out = {"effect": self.effect, "delta_log_evidence": self.delta_log_evidence, "material": self.material,
               "status": self.status, "rung": self.rung,
               "records_delta_log_evidence": self.records_delta_log_evidence,
               "records_delta_log_likelihood": self.records_delta_log_likelihood,
               "records_max_log_likelihood": self.records_max_log_likelihood,
               "records_laplace_ok": self.records_laplace_ok, "records_errors": self.records_errors,
               "error": self.error}
        if self.judgement is not None:
            out["reason"] = self.judgement.reason()
        return out


def joint_order_key(c: JointCandidate) -> tuple[int, float]:
    """The one order of candidates (:func:`beam.discovery.judgement.order_key`) for a joint one:
    status first, then the joint evidence."""
    gain = -math.inf if c.delta_log_evidence is None else c.delta_log_evidence
    if c.judgement is not None:
        return order_key(c.judgement)
    return order_key(judge_numbers(c.effect, gain, (math.nan, math.nan), (math.nan, math.nan),
                                   judged_label="", held_out_label=""))


@dataclass
class JointRung:
    """One rung of the joint ladder: the model, the effect it adds (None: the base), its joint fit
    and the candidates ranked on top of it (best first; empty when the climb stopped before)."""

    effects: tuple[str, ...]
    added: str | None
    fit: JointCalibrationResult
    candidates: list[JointCandidate] = field(default_factory=list)
    #: The candidates' joint fits on top of it.
    fits: dict[str, JointCalibrationResult] = field(default_factory=dict, repr=False)


@dataclass
class JointDiagnosis:
    """A joint diagnosis: the base model's joint fit, the candidates judged on it (best first),
    their joint fits, and the joint ladder (``rungs``: the base, then each effect named missing on
    top of the rung below, with the candidates ranked on each; empty for a diagnosis merged from
    one-candidate diagnoses, whose ladder is then the base and its missing candidate)."""

    base: JointCalibrationResult
    candidates: list[JointCandidate]
    fits: dict[str, JointCalibrationResult]
    seconds: float
    suggestion: dict | None = None  # which record to take next (beam.discovery.suggest.next_record)
    rungs: list[JointRung] = field(default_factory=list)
    #: The other path of a tie (:data:`TIED_NATS`): its added effects and how far below the kept
    #: path's last rung its own ends (nats); None when no rung was tied.
    other_path: tuple[tuple[str, ...], float] | None = None

    @property
    def names(self) -> list[str]:
        return [r.setup.measurement.name for r in self.base.records]

    @property
    def missing(self) -> str | None:
        """The best candidate named missing on the base (:func:`judge_joint`), else None."""
        top = self.candidates[0] if self.candidates else None
        return top.effect if top is not None and top.material else None

    @property
    def ladder(self) -> list[JointRung]:
        """The rungs: :attr:`rungs`, or the base and the missing candidate's fit."""
        if self.rungs:
            return self.rungs
        out = [JointRung(tuple(self.base.records[0].setup.effects), None, self.base, list(self.candidates))]
        if self.missing is not None:
            out.append(JointRung(tuple(self.fits[self.missing].records[0].setup.effects), self.missing,
                                 self.fits[self.missing]))
        return out

    @property
    def climbed(self) -> list[str]:
        """Effects the ladder added after the missing one (each named missing on top of the rung below)."""
        return [r.added for r in self.ladder[2:] if r.added is not None]

    @property
    def separated(self) -> list[tuple[str, str]]:
        """Pairs (better, worse) of effects that change the same thing (:func:`effect_kind`): an
        effect the ladder added and one judged beside it on the same rung, which the ladder does not
        add later, that every record alone leaves within :data:`SEPARATING_NATS` of it
        (:func:`alone_separation`) but the records together separate by more."""
        return [(a, b) for _, a, b in self._separated()]

    def _separated(self) -> list[tuple[int, str, str]]:
        """:attr:`separated` with the rung (index in :attr:`ladder`) the two were judged on."""
        ladder = self.ladder
        added = [r.added for r in ladder[1:]]
        out = []
        for k in range(len(ladder) - 1):
            judged = {c.effect: c for c in ladder[k].candidates if c.delta_log_evidence is not None}
            a = judged.get(ladder[k + 1].added)
            if a is None or not a.material:
                continue
            for b in sorted(judged.values(), key=lambda c: -c.delta_log_evidence):
                if b.effect == a.effect or b.effect in added or effect_kind(a.effect) != effect_kind(b.effect):
                    continue
                if b.effect not in self._fits_of(k):
                    continue
                alone = np.abs(alone_separation(a, b))
                if np.all(alone < SEPARATING_NATS) and a.delta_log_evidence - b.delta_log_evidence >= SEPARATING_NATS:
                    out.append((k, a.effect, b.effect))
        return out

    def _fits_of(self, k: int) -> dict[str, JointCalibrationResult]:
        """The joint fits of the candidates judged on rung ``k`` (the base's: :attr:`fits`)."""
        return self.fits if k == 0 or not self.rungs else self.rungs[k].fits

    def measured_f1_Hz(self) -> list[float]:
        """Each record's own first frequency (Hz): the record's identified mode matched to the base
        model's mode 1 (:func:`beam.discovery.findings.residual_report`), NaN where none is."""
        cached = getattr(self, "_measured", None)
        if cached is None:
            cached = [row.get("frequency_data_Hz") if row else None
                      for row in (next((r for r in rec["modes_table"] if r.get("mode") == 1), None)
                                  for rec in self.records_json())]
            cached = [float(v) if v is not None else math.nan for v in cached]
            object.__setattr__(self, "_measured", cached)
        return cached

    def separation(self) -> list[dict]:
        """For each pair of :attr:`separated`: ``better``, ``worse``, the joint
        ``delta_log_evidence`` between them (nats), ``alone`` (each record's own separation,
        :func:`alone_separation`) and ``records``: per record its ``length_m`` and
        ``sensor_position_m``, its own first frequency ``f1_measured_Hz`` (the record's spectrum),
        the first natural frequency of the two joint MAP models (``f1_better_Hz``, ``f1_worse_Hz``)
        and their difference ``f1_difference_pct`` (100 |f_better - f_worse| / f_worse)."""
        out = []
        pairs = self._separated()
        measured = self.measured_f1_Hz() if pairs else []
        for k, better, worse in pairs:
            by_effect = {c.effect: c for c in self.ladder[k].candidates}
            a, b = self.f1_Hz(better, k), self.f1_Hz(worse, k)
            records = []
            for view, fa, fb, fm in zip(map_views(self.base), a, b, measured):
                geometry = view.setup.measurement.geometry
                records.append({"record": view.setup.measurement.name, "length_m": float(geometry.length_m),
                                "sensor_position_m": float(geometry.sensor_position_m),
                                "f1_measured_Hz": fm if math.isfinite(fm) else None,
                                "f1_better_Hz": fa, "f1_worse_Hz": fb, "f1_difference_pct": 100.0 * abs(fa - fb) / fb})
            out.append({"better": better, "worse": worse, "rung": k,
                        "delta_log_evidence": by_effect[better].delta_log_evidence - by_effect[worse].delta_log_evidence,
                        "alone": [float(v) for v in alone_separation(by_effect[better], by_effect[worse])],
                        "records": records})
        return out

    def f1_Hz(self, effect: str | None, rung: int = 0) -> list[float]:
        """Each record's first natural frequency (Hz) under the joint MAP of rung ``rung``'s model +
        ``effect`` (None: the base)."""
        fit = self.base if effect is None else self._fits_of(rung)[effect]
        out = []
        for view in map_views(fit):
            values = {n: float(v) for n, v in view.laplace.map.values.items() if n in view.setup.physical_names}
            out.append(float(view.setup.model.natural_modes(values, 1)[0][0]))
        return out

    def verdict(self) -> str:
        """One paragraph: the effects missing on the joint evidence (the ladder), what the records
        together separate that none separates alone, and the last rung's interval."""
        if self.missing is None:
            top = self.candidates[0] if self.candidates else None
            why = "" if top is None or top.judgement is None or not top.judgement.reason() else (
                f" The best, {top.effect}: {top.judgement.reason()}.")
            return (f"Jointly on {len(self.names)} records no candidate is missing (material joint evidence, "
                    f"Δ log evidence ≥ {MATERIAL_LOG_EVIDENCE:g} nats, with a material fall of the error and no "
                    f"record predicted worse after the window).{why}")
        rungs = self.ladder[1:]
        values = self.ladder[-1].fit.laplace.map.values

        def own(effect):  # the added effect's own parameters at the last rung's joint MAP
            spec = EFFECTS[effect]
            shown = [f"{p.symbol} = {float(values[p.name]):.3g} {p.unit}" for p in spec.parameters if p.name in values]
            return f"; {', '.join(shown)}" if shown else ""

        added = ", then ".join(f"{r.added} ({self._rung_gain(k + 1):+.1f} nats{own(r.added)})" for k, r in enumerate(rungs))
        words = [f"Jointly on {len(self.names)} records the model misses {added}."]
        if self.other_path is not None and self.other_path[0]:
            words.append(f"(A tied rung was climbed both ways: the path {', then '.join(self.other_path[0])} ends "
                         f"{self.other_path[1]:.1f} nats lower.)")
        for pair in self.separation():
            words.append(separation_words(pair))
        words += self.interval_words()
        return " ".join(words)

    def _rung_gain(self, k: int) -> float:
        """The joint Δ log evidence of rung ``k`` over rung ``k - 1`` (nats)."""
        ladder = self.ladder
        return float(ladder[k].fit.laplace.log_evidence - ladder[k - 1].fit.laplace.log_evidence)

    def records_json(self) -> list[dict]:
        """Per record: ``record``, ``modes_table`` (the base model's joint fit against the record's
        identified modes, :func:`beam.discovery.report.residual_report`) and
        ``delta_log_evidence`` (per candidate: the record alone)."""
        cached = getattr(self, "_records_json", None)
        if cached is not None:
            return cached
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
                "rmse_calibration_base": view.rmse_calibration_map,
                "rmse_prediction_base": view.rmse_prediction_map,
            })
        object.__setattr__(self, "_records_json", out)
        return out

    def table(self) -> list[dict]:
        """The joint figures and each record's in one table, rung by rung: for each rung a row
        (``kind`` ``"rung"``: ``effects``, ``added``, its joint ``log_evidence`` and the joint Δ
        over the rung below, ``records``: each record's MAP errors in the window and after it, the
        error after the window it is judged on, and its noise sd under the joint fit), then the
        candidates judged on it (``kind`` ``"candidate"``: ``effect``, ``status``, the joint Δ,
        ``records``: each alone's Δ and its errors under the joint fit), in the one order."""
        rows = []
        for k, rung in enumerate(self.ladder):
            rows.append({"kind": "rung", "rung": k, "effects": list(rung.effects), "added": rung.added,
                         "log_evidence": float(rung.fit.laplace.log_evidence),
                         "delta_log_evidence": None if k == 0 else self._rung_gain(k),
                         "records": _record_errors(rung.fit)})
            for c in rung.candidates:
                alone = c.records_delta_log_evidence or [None] * len(self.names)
                rows.append({"kind": "candidate", "rung": k, "effect": c.effect, "status": c.status,
                             "delta_log_evidence": c.delta_log_evidence,
                             "records": [dict(e, delta_log_evidence_alone=a) for e, a in
                                         zip(c.records_errors or [{}] * len(alone), alone)]})
        return rows

    def intervals(self) -> list[dict]:
        """The last rung's shared physical parameters: ``name``, ``map``, the joint ``sd`` (Laplace,
        natural units, ``relative_sd`` of the log coordinate), each record's ``alone_relative_sd``
        (its own fit of the same model: None where that Laplace is not sound), and what widens the
        joint one: ``correlation_widening`` (marginal sd over the sd with every other parameter
        fixed, 1/sqrt(1 - R²)), ``most_correlated`` (the parameter it trades with, and their
        ``correlation``) and ``noise_ratio`` (each record's noise sd under the joint fit over its
        own fit's: above 1 where the joint model explains a record worse than the record's own)."""
        fit = self.ladder[-1].fit
        problem = fit.problem
        names = list(problem.names)
        cov = np.asarray(fit.laplace.cov, dtype=float)
        sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        with np.errstate(divide="ignore", invalid="ignore"):
            corr = cov / np.outer(sd, sd)
            precision = np.linalg.pinv(cov)
        noise = _noise_ratios(fit)
        out = []
        for name in fit.shared_names:
            i = names.index(name)
            if name not in fit.records[0].setup.physical_names:
                continue
            conditional = 1.0 / math.sqrt(precision[i, i]) if precision[i, i] > 0 else math.nan
            others = [(abs(corr[i, j]), names[j]) for j in range(len(names)) if j != i and np.isfinite(corr[i, j])]
            partner = max(others)[1] if others else None
            alone = []
            for record in fit.records:
                own = list(record.problem.names)
                ok = bool(record.laplace.ok) and name in own
                alone.append(float(math.sqrt(record.laplace.cov[own.index(name), own.index(name)])) if ok else None)
            prior = problem.parameter(name).prior
            value = float(fit.laplace.map.values[name])
            relative = float(sd[i]) if prior.log_coordinate else float(sd[i]) / abs(value)
            out.append({"name": name, "map": value, "sd": value * relative if prior.log_coordinate else float(sd[i]),
                        "relative_sd": relative, "alone_relative_sd": alone,
                        "correlation_widening": float(sd[i] / conditional) if conditional > 0 else None,
                        "most_correlated": partner,
                        "correlation": None if partner is None else float(corr[i, names.index(partner)]),
                        "noise_ratio": noise, "laplace_ok": bool(fit.laplace.ok)})
        return out

    def interval_words(self) -> list[str]:
        """One sentence on the joint interval of EI (the shared parameter every model has) and what
        widens it (:meth:`intervals`)."""
        rows = [r for r in self.intervals() if r["name"] == BASE_PARAMETERS[0].name]
        if not rows:
            return []
        r = rows[0]
        alone = [a for a in r["alone_relative_sd"] if a is not None]
        alone_text = (f"; each record alone, under its own fit of the same model, ±{100 * min(alone):.2g}–"
                      f"{100 * max(alone):.2g} %" if alone else "; no record alone identifies it (a flat ridge)")
        causes = []
        if r["correlation_widening"] is not None and r["correlation_widening"] >= 1.5 and r["most_correlated"]:
            causes.append(f"it trades with {r['most_correlated']} (correlation {r['correlation']:+.2f}), which widens it "
                          f"{r['correlation_widening']:.1f}× over EI with every other parameter held")
        worst = max(range(len(r["noise_ratio"])), key=lambda k: r["noise_ratio"][k]) if r["noise_ratio"] else None
        if worst is not None and r["noise_ratio"][worst] >= 1.5:
            causes.append(f"the joint model fits {self.names[worst]} with a noise sd {r['noise_ratio'][worst]:.1f}× that "
                          "record's own fit's: one beam does not explain it as well as its own fit does, and the i.i.d. "
                          "interval widens with that misfit")
        if not r["laplace_ok"]:
            causes.append("the joint Laplace approximation is not sound here (a repaired Hessian or a bound): a "
                          "profile interval (beam.calibration.joint.profile_interval) is the honest one")
        why = ("; what widens it: " + "; and ".join(causes)) if causes else ""
        return [f"Jointly EI = {r['map']:.4g} N m² ± {100 * r['relative_sd']:.2g} % (1 sd){alone_text}{why}."]

    def to_json(self) -> dict:
        """The summary of ``beam diagnose A B ... --json``."""
        base = self.base
        ladder = [{"added": r.added, "effects": list(r.effects), **_ladder_rung(r.fit)} for r in self.ladder]
        return {
            "measurements": self.names,
            "output_unit": base.records[0].setup.measurement.output_unit,
            "base": list(base.records[0].setup.effects),
            "per_record": list(base.per_record),
            "candidates": [c.to_json() for c in self.candidates],
            "missing": self.missing,
            "climbed": self.climbed,
            "separated": [list(pair) for pair in self.separated],
            "separation": self.separation(),
            "ladder": ladder,
            "table": self.table(),
            "intervals": self.intervals(),
            "verdict": self.verdict(),
            "records": self.records_json(),
            "seconds": self.seconds,
        }


def map_views(fit: JointCalibrationResult) -> tuple[CalibrationResult, ...]:
    """Each record under the joint MAP, for its MAP figures only (its errors in the window and after
    it, :mod:`beam.discovery.held_out`): the record's own setup and problem at the joint MAP's values
    of its parameters, without the predictive bands :meth:`JointCalibrationResult.record_results`
    computes (no coverage, no draws). Kept on the fit."""
    memo = vars(fit)
    if "_map_views" not in memo:
        views = []
        for k, single in enumerate(fit.records):
            names = fit.problem.record_names(k)
            own = single.problem
            values = {n: float(fit.laplace.map.values[names[n]]) for n in own.names}
            z = own.to_internal(values)
            found = MapResult(z=z, values=values, log_posterior=math.nan, gradient=None, hessian=None, hessian_point=z,
                              converged=fit.laplace.map.converged, message="the joint MAP", n_starts=1,
                              at_bound=tuple(n for n in own.names if names[n] in fit.laplace.map.at_bound))
            laplace = LaplaceResult(own, found, z, None, math.nan, False)
            views.append(CalibrationResult(single.setup, own, laplace, None, None, fit.seconds))
        memo["_map_views"] = tuple(views)
    return memo["_map_views"]


def _record_errors(fit: JointCalibrationResult, against: JointCalibrationResult | None = None) -> list[dict]:
    """Each record's MAP errors under ``fit`` (output's unit): ``rmse_calibration``,
    ``rmse_prediction`` (forward from the window) and ``held_out_judged`` (the error after the
    window a candidate is judged on, :func:`beam.discovery.held_out.held_out_error`, compared with
    ``against``'s model when given)."""
    views = map_views(fit)
    others = [None] * len(views) if against is None else map_views(against)
    out = []
    for view, other in zip(views, others):
        judged = held_out_error(view, *(() if other is None else (other,)))
        out.append({"record": view.setup.measurement.name, "rmse_calibration": _finite(view.rmse_calibration_map),
                    "rmse_prediction": _finite(view.rmse_prediction_map), "held_out_judged": _finite(judged)})
    return out


def _finite(value: float) -> float | None:
    return float(value) if value is not None and math.isfinite(value) else None


def _noise_ratios(fit: JointCalibrationResult) -> list[float]:
    """Each record's noise sd at the joint MAP over its own fit's (its own MAP of the same model)."""
    out = []
    for k, record in enumerate(fit.records):
        names = fit.problem.record_names(k)
        own = [n for n in record.problem.noise_names if n in names]
        if not own:
            out.append(math.nan)
            continue
        joint = float(fit.laplace.map.values[names[own[0]]])
        alone = float(record.laplace.map.values[own[0]])
        out.append(joint / alone if alone > 0 else math.nan)
    return out


def judge_joint(effect: str, current: JointCalibrationResult, fit: JointCalibrationResult | Exception) -> Judgement:
    """The one rule (:func:`beam.discovery.judgement.judge`) on several records: the joint Δ log
    evidence; the judged error (each record's calibration window for free decays, its held-out part
    for driven records) and the error after the window (amplitude-aware for a free decay,
    :mod:`beam.discovery.held_out`) pooled over the records (root mean square over every record's
    samples); a candidate that predicts any record worse after the window than the model it is added
    to (by more than :data:`~beam.discovery.judgement.HELD_OUT_WORSE`) fails after the window; its
    parameters plausible on every record's strip."""
    if isinstance(fit, Exception):
        return Judgement(effect, "failed", -math.inf)
    gain = float(fit.laplace.log_evidence - current.laplace.log_evidence)
    before, after = map_views(current), map_views(fit)
    free = before[0].setup.is_free
    judged, held, counts, held_counts, worse, noise = ([0.0, 0.0], [0.0, 0.0], 0, 0, False, 0.0)
    for b, a in zip(before, after):
        n = int(np.count_nonzero(b.setup.fit_mask))
        noise += n * noise_floor_sd(b) ** 2
        pair = (b.rmse_calibration_map, a.rmse_calibration_map) if free else (b.rmse_prediction_map, a.rmse_prediction_map)
        judged = [judged[0] + n * pair[0] ** 2, judged[1] + n * pair[1] ** 2]
        counts += n
        h = (held_out_error(b, a), held_out_error(a, b))
        m = int(np.count_nonzero(b.setup.held_out_mask))
        if all(math.isfinite(v) for v in h) and m:
            held = [held[0] + m * h[0] ** 2, held[1] + m * h[1] ** 2]
            held_counts += m
            worse = worse or h[1] > (1 + HELD_OUT_WORSE) * h[0]
    pooled = lambda pair, n: tuple(math.sqrt(v / n) for v in pair) if n else (math.nan, math.nan)  # noqa: E731
    findings = []
    if gain >= MATERIAL_LOG_EVIDENCE:
        findings = next((f for f in (implausible_parameters(effect, v) for v in after) if f), [])
    free_label = "error after the window (re-anchored on the record's amplitudes)"
    j = judge_numbers(effect, gain, pooled(judged, counts), pooled(held, held_counts),
                      judged_label="calibration-window error" if free else "held-out error",
                      held_out_label=free_label if free and not fit.records[0].setup.model.is_nonlinear
                      else "held-out error", findings=findings, noise=math.sqrt(noise / counts) if counts else math.nan)
    if j.status in ("missing", "not_material") and worse and gain >= MATERIAL_LOG_EVIDENCE:
        j = replace(j, status="fails_after_window")
    return j


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
    records (by free length when they differ, else by name) where the two models' f1 differ most,
    each with the record's own f1 (its spectrum) beside the two models'."""
    better, worse = pair["better"], pair["worse"]
    head = PAIR_WORDS.get((better, worse), f"{better}, not {worse}")
    records = sorted(pair["records"], key=lambda r: -r["f1_difference_pct"])[:2]
    lengths = {round(r["length_m"], 3) for r in pair["records"]}
    label = (lambda r: f"{100.0 * r['length_m']:.0f} cm") if len(lengths) == len(pair["records"]) else (
        lambda r: r["record"])
    where = " and ".join(label(r) for r in records)
    gaps = " and ".join(f"{r['f1_difference_pct']:.2g} %" for r in records)
    own = "; ".join(f"at {label(r)} the record's own f1 is {r['f1_measured_Hz']:.4g} Hz, {better}'s fit "
                    f"{r['f1_better_Hz']:.4g} Hz, {worse}'s {r['f1_worse_Hz']:.4g} Hz"
                    for r in records if r.get("f1_measured_Hz"))
    return (f"{head[0].upper()}{head[1:]}: no record alone separates {better} from {worse} (each within "
            f"{SEPARATING_NATS:g} nats), together they do by {pair['delta_log_evidence']:.1f} nats: at {where} the two "
            f"predict f1 differently by {gaps}{f' ({own})' if own else ''}.")


def _ladder_rung(fit: JointCalibrationResult) -> dict:
    """A rung's figures in the JSON: the joint log evidence and, per record, the MAP's errors (the
    numbers of the table) and the band's coverage."""
    views, banded = map_views(fit), fit.record_results()
    return {"log_evidence": float(fit.laplace.log_evidence),
            "rmse_calibration": [v.rmse_calibration_map for v in views],
            "rmse_prediction": [v.rmse_prediction_map for v in views],
            "coverage95_prediction": [v.coverage95_prediction for v in banded]}


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
    climb: bool = True,
) -> JointDiagnosis:
    """Judge candidate effects on several records of one beam together, and climb the joint ladder.

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
        that only a candidate brings is per record in that candidate's fit only; a parameter that
        changes the geometry is always per record (module notes).
    climb : bool
        Climb the joint ladder (module notes); False: judge the candidates on the base only.
    """
    t0 = time.perf_counter()
    measurements = tuple(measurements)
    spec = CalibrationSpec(window=window, effects=base, modes=modes)
    if candidates is None:
        candidates = joint_candidates(measurements, spec.effects, per_record)
    candidates = tuple(candidates)
    fit = _fitter(measurements, spec, per_record, shared, engine)
    with reporting(None, "fitting the base, all records"):
        base_fit = fit(spec.effects)
    if isinstance(base_fit, Exception):
        raise base_fit
    ranked, fits = _judged(fit, base_fit, spec.effects, candidates, 0)
    first = JointRung(tuple(spec.effects), None, base_fit, ranked, fits)
    paths = [[first]]
    for depth in range(1, MAX_JOINT_RUNGS + 1 if climb else 1):
        grown = []
        for path in paths:
            last = path[-1]
            material = [c for c in last.candidates if c.material]
            if not material:
                grown.append(path)  # the climb of this path has ended
                continue
            tied = [c for c in material[1:2] if material[0].delta_log_evidence - c.delta_log_evidence < TIED_NATS]
            for c in [material[0], *tied]:
                chosen = with_effect(last.effects, c.effect)
                taken = {r.added for r in path} | {c.effect}
                left = [e for e in candidates if e not in taken]
                rung = JointRung(chosen, c.effect, last.fits[c.effect])
                if left and depth < MAX_JOINT_RUNGS:
                    rung.candidates, rung.fits = _judged(fit, rung.fit, chosen, left, depth)
                grown.append([*path, rung])
        paths = sorted(grown, key=lambda p: -float(p[-1].fit.laplace.log_evidence))[:2]
        if all(not any(c.material for c in p[-1].candidates) for p in paths):
            break
    best = paths[0]
    other = None
    if len(paths) > 1 and [r.added for r in paths[1]] != [r.added for r in best]:
        other = (tuple(r.added for r in paths[1][1:]),
                 float(best[-1].fit.laplace.log_evidence - paths[1][-1].fit.laplace.log_evidence))
    return JointDiagnosis(base_fit, ranked, fits, time.perf_counter() - t0, rungs=best, other_path=other)


def joint_candidates(measurements: Sequence, base: Iterable[str], per_record=None) -> list[str]:
    """The candidates every record can show (:func:`beam.discovery.ranking.candidate_effects`),
    without a geometry-changing effect on records of different stated lengths unless its parameter is
    per record (module notes)."""
    base = tuple(base)
    offered = [set(candidate_effects(base, m)) for m in measurements]
    lengths = {round(float(m.geometry.length_m), 6) for m in measurements}
    asked = set(_names_in(per_record, tuple(EFFECTS)) or ())
    return [e for e in candidate_effects(base, measurements[0]) if all(e in o for o in offered)
            and (EFFECTS[e].geometry is None or len(lengths) == 1 or EFFECTS[e].geometry.parameter in asked)]


def _judged(fit, current: JointCalibrationResult, effects: tuple[str, ...], names: Sequence[str],
            rung: int) -> tuple[list[JointCandidate], dict[str, JointCalibrationResult]]:
    """The candidates ``names`` fitted on top of ``current`` (the model ``effects``; each from its
    MAP with the effect switched off, :func:`nested_start`), judged (:func:`judge_joint`) and in the
    one order (:func:`joint_order_key`); and their fits."""
    fits: dict[str, JointCalibrationResult] = {}
    ranked: list[JointCandidate] = []
    current_ll = _record_log_likelihoods(current)
    on = f"the joint ladder's step {rung}" if rung else "the base"
    for i, effect in enumerate(names, 1):
        with reporting(None, f"fitting {effect} on {on}, all records (candidate {i} of {len(names)})"):
            result = fit(with_effect(effects, effect), [nested_start(current, effect)])
        if isinstance(result, Exception):
            ranked.append(JointCandidate(effect, None, error=str(result).splitlines()[0],
                                         judgement=judge_joint(effect, current, result), rung=rung))
            continue
        fits[effect] = result
        ranked.append(JointCandidate(
            effect, float(result.laplace.log_evidence - current.laplace.log_evidence),
            [float(c.laplace.log_evidence - b.laplace.log_evidence) for c, b in zip(result.records, current.records)],
            [float(v) for v in _record_log_likelihoods(result) - current_ll],
            [_max_log_likelihood(c) for c in result.records],
            [bool(c.laplace.ok and b.laplace.ok) for c, b in zip(result.records, current.records)],
            judgement=judge_joint(effect, current, result), rung=rung,
            records_errors=_record_errors(result, current)))
    ranked.sort(key=joint_order_key)
    return ranked, fits


def nested_start(base: JointCalibrationResult, effect: str) -> dict[str, float]:
    """The base model's joint MAP with ``effect``'s parameters at their null values (the end of the
    catalogue's range where the effect vanishes): the model with the effect starts no lower than
    the base's optimum embedded in it."""

    start = {name: float(v) for name, v in base.laplace.map.values.items()}
    for p in EFFECTS[effect].parameters:
        if p.absent_at == "centre":  # vanishes at each record's own value (its stated length): the records' starts
            continue
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
