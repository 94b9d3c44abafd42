"""Jobs of the "Several records" view: records of one beam calibrated and diagnosed jointly.

Pure Python on top of the public ``beam`` API (no UI import). The library does the work
(:func:`beam.calibration.joint.joint_preview`, :func:`beam.discovery.joint.joint_diagnose`); these
jobs put it on the pool's worker processes in steps, so that the view shows progress and a new
request (or *Cancel*) stops the old one between two steps.

:func:`joint_run`
    Each record calibrated **alone** first (:func:`beam.calibration.calibration_preview`, one
    record per worker process at a time: its own intervals, shown beside the joint ones, and the
    MAP the joint search starts from), then the joint MAP + Laplace in one process whose engine
    is told the records' optima (:meth:`beam.calibration.Engine.merge`, so nothing is searched
    twice): a ``preview`` :class:`JointOutcome`; with ``steps`` > 0, emcee over the joint
    posterior (``progress`` every few steps) and the ``final`` outcome.
:func:`joint_diagnosis_run`
    One :func:`beam.discovery.joint.joint_diagnose` per candidate effect (the base model and that
    candidate), spread over the worker processes; the candidates are merged into one
    :class:`~beam.discovery.joint.JointDiagnosis` (``partial`` after each, ``final`` at the end).
    The base model's joint fit is deterministic, so every call's base is the same fit.

:func:`available_records`, :func:`load_record`
    The records the view offers: the bundled lab runs, every real record shipped in
    ``assets/real`` (the shared runs of the aluminium strip; ``NAME.csv`` with its ``NAME.toml``),
    and the session's uploads.
"""

from __future__ import annotations

import time
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import lru_cache
from typing import NamedTuple

from beam.calibration import CalibrationResult, CalibrationSpec, calibration_preview, default_engine
from beam.calibration.joint import JointCalibrationResult, joint_preview
from beam.calibration.run import default_walkers
from beam.discovery.joint import SEPARATING_NATS, JointDiagnosis, joint_diagnose, joint_order_key
from beam.discovery.joint import joint_candidates as joint_candidate_effects
from beam.discovery.ranking import MATERIAL_LOG_EVIDENCE
from beam.discovery.suggest import next_record
from beam.errors import BeamInputError
from beam.inference import EnsembleRun
from beam.inference.progress import reporting
from beam.io.measurement import Measurement, read_measurement
from dashboard.jobs.beam import ASSETS, bundled_datasets, load_bundled
from dashboard.jobs.told import told_stages
from dashboard.runtime import scheduler as sch

__all__ = [
    "MATERIAL_LOG_EVIDENCE",
    "MAX_RECORDS",
    "SEPARATING_NATS",
    "JointKey",
    "JointOutcome",
    "available_records",
    "joint_diagnosis_run",
    "joint_run",
    "load_record",
    "shared_runs",
]

#: Records calibrated together at most (each adds its own calibration and a panel).
MAX_RECORDS = 6
#: Ensemble steps between two progress reports of the joint MCMC (the cancellation points).
EVERY = 25


class JointKey(NamedTuple):
    """Everything a joint calibration (or diagnosis) depends on: the records' contents and the spec.

    Attributes
    ----------
    records : tuple of str
        The records' digests (:func:`dashboard.jobs.beam.record_key`), in the order chosen (record K
        of the joint problem is the K-th).
    spec : CalibrationSpec
        The settings of every record: window, effects, modes, seed; ``steps`` the joint MCMC's
        ensemble steps (None: the Laplace preview only).
    per_record : str
        Physical parameters calibrated per record (``beam calibrate --per-record``: names, their
        unambiguous start or effect names, comma-separated; '' none).
    candidates : tuple of str
        Effects a joint diagnosis tries (empty: every candidate all the records can show).
    """

    records: tuple[str, ...]
    spec: CalibrationSpec
    per_record: str = ""
    candidates: tuple[str, ...] = ()

    @property
    def steps(self) -> int:
        """Ensemble steps of the joint MCMC (0: none)."""
        return int(self.spec.steps or 0)


@dataclass
class JointOutcome:
    """What the view shows of a joint calibration.

    Attributes
    ----------
    key : JointKey
        Its inputs.
    joint : JointCalibrationResult
        The library's joint result (its per-record views computed: bands, RMSE, coverage).
    singles : tuple of CalibrationResult
        Each record calibrated alone (Laplace preview), same options.
    records : list of dict
        :meth:`JointCalibrationResult.record_json` of each record.
    """

    key: JointKey
    joint: JointCalibrationResult
    singles: tuple[CalibrationResult, ...]
    records: list[dict] = field(default_factory=list)

    @property
    def names(self) -> list[str]:
        return [r["record"] for r in self.records]

    @property
    def views(self) -> tuple[CalibrationResult, ...]:
        """Each record under the joint posterior (:meth:`JointCalibrationResult.record_results`)."""
        return self.joint.record_results()

    def shared_rows(self) -> list[dict]:
        """One row per shared physical parameter: ``name``, ``joint`` (its summary: mean, sd,
        q025, q975, natural units) and ``alone`` (each record's own summary, None when its model
        lacks it)."""
        summary = self.joint.summary()
        alone = [s.summary() for s in self.singles]
        return [{"name": n, "joint": summary[n], "alone": [a.get(n) for a in alone]} for n in self.joint.shared_names]


# -- records --------------------------------------------------------------------------------------
@lru_cache(maxsize=1)
def shared_runs() -> dict[str, str]:
    """``{name: "name — title"}`` of the real records shipped in ``assets/real`` (each ``NAME.csv``
    with its sidecar ``NAME.toml``), name order."""
    out = {}
    for csv in sorted((ASSETS / "real").glob("*.csv")):
        if csv.with_suffix(".toml").exists():
            try:
                out[csv.stem] = f"{csv.stem} — {read_shared(csv.stem).title}"
            except BeamInputError:  # pragma: no cover - a broken shipped file
                continue
    return out


@lru_cache(maxsize=16)
def read_shared(name: str) -> Measurement:
    """The real record ``assets/real/NAME.csv`` (cached: measurements are read-only)."""
    return read_measurement(ASSETS / "real" / f"{name}.csv")


def available_records(uploads: Mapping[str, Measurement] | None = None) -> dict[str, str]:
    """``{dataset id: label}`` of every record the view offers: bundled lab runs, the shipped real
    records, then the session's uploads (``uploads``: id -> measurement)."""
    out = {name: label for name, label in bundled_datasets().items()}
    out.update({name: label for name, label in shared_runs().items() if name not in out})
    for name, m in (uploads or {}).items():
        out[name] = f"upload: {m.name} — {m.title}"
    return out


def load_record(name: str, uploads: Mapping[str, Measurement] | None = None) -> Measurement:
    """The measurement of dataset id ``name`` (an upload of ``uploads``, a bundled or a shipped real record)."""
    if uploads and name in uploads:
        return uploads[name]
    if name in bundled_datasets():
        return load_bundled(name)
    if name in shared_runs():
        return read_shared(name)
    raise BeamInputError(f"{name}: no such record")


def check_records(measurements: Sequence[Measurement]) -> None:
    """Refuse a selection the view cannot calibrate jointly: none, or more than :data:`MAX_RECORDS`."""
    if len(measurements) < 1:
        raise BeamInputError("choose at least one record (two or more to calibrate jointly)")
    if len(measurements) > MAX_RECORDS:
        raise BeamInputError(f"choose at most {MAX_RECORDS} records ({len(measurements)} chosen)")


# -- calibration ----------------------------------------------------------------------------------
def single_stages(measurement: Measurement, spec: CalibrationSpec) -> Iterator[sch.Stage]:
    """One record calibrated alone (in a worker process): ``final`` (its preview, the optima its
    process's engine holds)."""
    engine = default_engine()
    try:
        result = calibration_preview(measurement, spec, engine=engine)
    except BeamInputError as exc:
        raise BeamInputError(f"{measurement.name}: {exc}") from None
    yield sch.final((result, engine.export()), f"{measurement.name} calibrated alone")


def joint_stages(key: JointKey, measurements: Sequence[Measurement], memory: tuple) -> Iterator[sch.Stage]:
    """The joint calibration in a worker process: ``preview`` (MAP + Laplace), then with
    ``key.steps`` > 0 ``progress`` while emcee samples and ``final``; each value a
    :class:`JointCalibrationResult` whose per-record views are computed."""
    engine = default_engine()
    engine.merge(memory)
    spec = replace(key.spec, steps=None)
    preview = joint_preview(measurements, spec, per_record=key.per_record or None, engine=engine)
    preview.record_results()
    yield sch.preview(preview, "joint preview (MAP + Laplace)")
    if key.steps <= 0:
        return
    t0 = time.perf_counter()
    problem = preview.problem
    run = EnsembleRun(problem, preview.laplace, n_walkers=default_walkers(problem.ndim), seed=spec.seed)
    for event in run.sample(key.steps, every=EVERY):
        yield sch.progress(min(event.step / max(event.total, 1), 0.99),
                           f"joint MCMC: {event.step} of {event.total} ensemble steps")
    posterior = run.result(target_ess=spec.target_ess)
    final = JointCalibrationResult(preview.records, problem, preview.laplace, posterior,
                                   preview.seconds + time.perf_counter() - t0, seed=preview.seed)
    final.record_results()
    yield sch.final(final, "joint posterior (MCMC)")


def joint_run(key: JointKey, measurements: Sequence[Measurement]) -> Iterator[sch.Stage[JointOutcome]]:
    """A joint calibration as a scheduler job (module notes).

    Yields
    ------
    Stage
        ``progress`` while the records are calibrated alone, ``preview`` :class:`JointOutcome`
        (joint MAP + Laplace), ``progress`` while the joint MCMC samples, ``final``. A record the
        library refuses raises :class:`~beam.errors.BeamInputError` naming it (published as ``error``).
    """
    measurements = tuple(measurements)
    check_records(measurements)
    spec = replace(key.spec, steps=None)  # each record alone: its preview
    n = len(measurements)
    yield sch.progress(0.02, f"calibrating each of the {n} records alone first")
    singles: list[CalibrationResult | None] = [None] * n
    memory: list = []
    done = 0
    try:
        for index, value in sch.offload_map(single_stages, [((m, spec), {}) for m in measurements]):
            if isinstance(value, BaseException):
                raise value
            singles[index], found = value
            memory.extend(found)
            done += 1
            yield sch.progress(0.6 * done / n, f"{done} of {n} records calibrated alone")
    except sch.Cancelled:
        return
    yield sch.progress(0.65, "joint MAP: one beam for every record")
    for stage in sch.offload(joint_stages, key, measurements, tuple(memory)):
        if stage.kind in ("preview", "final"):
            outcome = JointOutcome(key, stage.value, tuple(singles),
                                   [stage.value.record_json(k) for k in range(n)])
            yield (sch.final(outcome, stage.message) if key.steps <= 0 or stage.kind == "final"
                   else sch.preview(outcome, stage.message))
        else:
            yield stage


# -- diagnosis ------------------------------------------------------------------------------------
def diagnosis_stages(key: JointKey, measurements: Sequence[Measurement], effect: str) -> Iterator[sch.Stage]:
    """The joint diagnosis of the base model and one candidate ``effect`` (in a worker process):
    ``progress`` with what its fits say (:func:`~dashboard.jobs.told.told_stages`), ``final``."""
    spec = key.spec

    def judged(progress) -> JointDiagnosis:
        with reporting(progress, f"judging {effect} on {len(measurements)} records together"):
            return joint_diagnose(measurements, window=spec.window, modes=spec.modes, base=spec.effects,
                                  candidates=[effect], per_record=key.per_record or None, engine=default_engine(),
                                  climb=False)

    yield from told_stages(judged, message=f"{effect} judged")


def joint_candidates(key: JointKey, measurements: Sequence[Measurement]) -> list[str]:
    """The candidates every record can show (as :func:`beam.discovery.joint.joint_diagnose` picks
    them by default), or ``key.candidates`` when given."""
    if key.candidates:
        return list(key.candidates)
    return joint_candidate_effects(measurements, key.spec.effects, key.per_record or None)


def merged(parts: Sequence[JointDiagnosis], seconds: float) -> JointDiagnosis:
    """One :class:`JointDiagnosis` of several one-candidate diagnoses of the same base model:
    every candidate in the library's one order (:func:`beam.discovery.joint.joint_order_key`: its
    judgement, then its joint Δ log evidence; failed fits last), every fit kept; its ladder the base
    and the missing candidate (the climb on top of it is the command line's)."""
    candidates = [c for d in parts for c in d.candidates]
    candidates.sort(key=joint_order_key)
    fits = {name: fit for d in parts for name, fit in d.fits.items()}
    return replace(parts[0], candidates=candidates, fits=fits, seconds=seconds, rungs=[])


def joint_diagnosis_run(key: JointKey, measurements: Sequence[Measurement]) -> Iterator[sch.Stage[JointDiagnosis]]:
    """The joint diagnosis as a scheduler job (module notes): ``progress``, ``partial`` after each
    candidate, ``final``."""
    measurements = tuple(measurements)
    check_records(measurements)
    t0 = time.perf_counter()
    candidates = joint_candidates(key, measurements)
    if not candidates:
        raise BeamInputError("no candidate effect is left to try on these records with this model")
    yield sch.progress(0.02, f"judging {len(candidates)} candidate effects on {len(measurements)} records together")
    parts: list[JointDiagnosis] = []
    failed: list[BaseException] = []
    calls = sch.OffloadQueue()
    for i, e in enumerate(candidates):
        calls.submit(i, diagnosis_stages, key, measurements, e)
    try:
        for _ in candidates:
            while not calls.ended():  # what the running fits say, while they run
                said = calls.reports()
                if said:
                    yield sch.progress((len(parts) + len(failed)) / len(candidates), said[-1][1].message)
            _, value = calls.next()
            if isinstance(value, BaseException):
                failed.append(value)
                continue
            parts.append(value)
            done = len(parts) + len(failed)
            if done < len(candidates):
                yield sch.partial(merged(parts, time.perf_counter() - t0), done / len(candidates),
                                  f"{done} of {len(candidates)} candidates judged")
    except sch.Cancelled:
        return
    finally:
        calls.close()
    if not parts:
        raise failed[0]
    diagnosis = merged(parts, time.perf_counter() - t0)
    yield sch.partial(diagnosis, 0.97, "where a new record would tell the top two apart")
    try:
        suggestion = next_record([(c.effect, c.delta_log_evidence) for c in diagnosis.candidates],
                                 lambda a, b: [diagnosis.fits[a], diagnosis.fits[b]])
    except BeamInputError as exc:  # no setting to scan on this rig: said, the diagnosis stands
        suggestion = {"needed": False, "words": f"no suggestion: {exc}"}
    yield sch.final(replace(diagnosis, suggestion=suggestion, seconds=time.perf_counter() - t0), "joint diagnosis")
