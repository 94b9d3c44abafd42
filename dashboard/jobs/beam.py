"""Jobs of the beam views for the run scheduler: datasets, uploads, calibration, diagnosis.

Pure Python on top of the public ``beam`` API (no UI import).

:func:`bundled_datasets`, :func:`load_bundled`, :func:`load_upload`
    The bundled lab runs (``assets/measurements``), the real records offered as teaching cases
    (:data:`REAL_DATASETS`, in ``assets/real``; no known answer) and user uploads (CSV + TOML sidecar,
    checked by writing them to a temporary directory and reading them with
    :func:`beam.io.measurement.read_measurement`).
:func:`calibration_run`
    ``preview`` (MAP + Laplace), ``progress`` while emcee samples, ``final`` — the stages of
    :func:`beam.calibration.calibration_stream`. Leaving the generator cancels the sampler.
:func:`diagnosis_run`
    The diagnosis of :func:`beam.discovery.report.diagnose` in cancellable steps: base preview,
    residual report (``partial``), each candidate as its fit ends, the climb, then ``final``.

The computations run in the worker processes of the pool: a calibration
(:func:`calibration_stages`) in one (:func:`dashboard.runtime.scheduler.offload`), a diagnosis's
fits spread over all of them (:func:`dashboard.runtime.scheduler.offload_map`, see
:func:`diagnosis_stages`); the jobs around them look up and fill
the caches in the server process. Final results are deterministic for their inputs, so they are
kept in small process-wide LRU caches shared by all sessions (bundled datasets only: an upload
is private to a session). :func:`warm_worker` prepares a new worker process (the app hands it to the pool with
:func:`dashboard.runtime.scheduler.set_worker_warm_up`; the runtime imports no job).
"""

from __future__ import annotations

import math
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

from beam.calibration import (
    CalibrationResult,
    calibration_preview,
    calibration_stream,
    known_map,
    remember_maps,
)
from beam.discovery.ranking import (
    FIT_ERRORS,
    Candidate,
    Fitter,
    Ranking,
    candidate_effects,
    rank_fits,
    with_effect,
)
from beam.discovery.report import (
    Remaining,
    ResidualReport,
    VerdictFacts,
    climb_on,
    explainer,
    map_frequencies,
    remaining_error,
    residual_report,
    verdict_sentence,
)
from beam.errors import BeamInputError
from beam.inference import Progress
from beam.io.limits import MAX_MEASUREMENT_BYTES, MAX_TOML_BYTES
from beam.io.measurement import Measurement, read_measurement
from beam.io.simulation import read_truth
from beam.physics.effects import EFFECTS
from beam.residuals.noise import noise_floor
from dashboard.jobs.warm import warm_up
from dashboard.runtime import scheduler as sch
from dashboard.runtime.caches import LRU, cached_stages

__all__ = [
    "ASSETS",
    "CALIBRATIONS",
    "DIAGNOSES",
    "MAX_SIDECAR_UPLOAD_BYTES",
    "MAX_UPLOAD_BYTES",
    "REAL_DATASETS",
    "CalibrationKey",
    "Diagnosis",
    "bundled_datasets",
    "calibration_run",
    "calibration_stages",
    "diagnosis_run",
    "diagnosis_stages",
    "is_real",
    "load_bundled",
    "load_upload",
    "read_answer",
    "upload_size_text",
    "warm_worker",
]

REPO = Path(__file__).resolve().parents[2]
ASSETS = REPO / "assets"
#: Largest accepted upload of a measurement CSV (bytes): the library's limit on what it reads.
MAX_UPLOAD_BYTES = MAX_MEASUREMENT_BYTES
#: Largest accepted upload of a TOML sidecar (bytes): the library's limit on what it reads.
MAX_SIDECAR_UPLOAD_BYTES = MAX_TOML_BYTES
#: Final calibrations by :class:`CalibrationKey` (bundled datasets only).
CALIBRATIONS = LRU(24)
#: Diagnoses by (dataset, window, effects, modes).
DIAGNOSES = LRU(8)


@dataclass(frozen=True)
class CalibrationKey:
    """Everything a calibration depends on; ``dataset`` is a bundled name or an upload id."""

    dataset: str
    window: tuple[float, float]
    effects: tuple[str, ...]
    modes: int
    likelihood: str
    seed: int = 0
    target_ess: float = 1000.0


# -- datasets ---------------------------------------------------------------------------------
#: Real records (``assets/real/NAME.csv``) in the dataset list, with the title shown for them (a
#: teaching question: there is no hidden answer, see ``assets/real/README.md``).
REAL_DATASETS = {
    "adxl_50cm_114655": "Real aluminium strip (accelerometer): the model misses something — what?",
}


def is_real(name: str) -> bool:
    """Whether ``name`` is a bundled real record (no known answer)."""
    return name in REAL_DATASETS


@lru_cache(maxsize=1)
def bundled_datasets() -> dict[str, str]:
    """``{name: "name — title"}`` of the bundled lab runs (name order), then the real records."""
    out = {}
    for csv in sorted((ASSETS / "measurements").glob("*.csv")):
        try:
            out[csv.stem] = f"{csv.stem} — {load_bundled(csv.stem).title}"
        except BeamInputError:  # pragma: no cover - a broken bundled file
            continue
    for name, title in REAL_DATASETS.items():
        if (ASSETS / "real" / f"{name}.csv").exists():
            out[name] = f"{name} — {title}"
    return out


@lru_cache(maxsize=8)
def load_bundled(name: str) -> Measurement:
    """The bundled measurement ``assets/measurements/NAME.csv`` or, for a real record,
    ``assets/real/NAME.csv`` (cached: measurements are read-only)."""
    folder = "real" if is_real(name) else "measurements"
    return read_measurement(ASSETS / folder / f"{name}.csv")


def read_answer(name: str) -> dict | None:
    """The hidden truth of a bundled dataset: ``{"title", "effects", "parameters", "noise_m"}`` or None
    (``noise_m``: the true noise sd in m, None if the truth file has none); None for a real record."""
    if is_real(name):
        return None
    path = ASSETS / "answers" / f"{name}.truth.toml"
    if not path.exists():
        return None
    truth = read_truth(path)
    noise = getattr(truth, "noise_m", None)
    return {"title": getattr(truth, "title", name), "effects": list(truth.effects), "parameters": dict(truth.parameters),
            "noise_m": float(noise) if noise is not None else None}


def upload_size_text(n_bytes: int) -> str:
    """``n_bytes`` in decimal megabytes as the upload widget shows sizes: ``"67.1 MB"``."""
    return f"{n_bytes / 1e6:.1f} MB"


def load_upload(csv_name: str | None, csv_bytes: bytes | str | None, toml_name: str | None,
                toml_bytes: bytes | str | None) -> Measurement:
    """Check an uploaded measurement (CSV + TOML sidecar) and read it.

    Parameters
    ----------
    csv_name, toml_name : str or None
        The files' names as uploaded.
    csv_bytes, toml_bytes : bytes, str or None
        Their contents; text (the upload widget decodes ``text/*`` files as UTF-8) is encoded back
        to UTF-8.

    Raises
    ------
    BeamInputError
        A missing file, one larger than :data:`MAX_UPLOAD_BYTES` (CSV) or
        :data:`MAX_SIDECAR_UPLOAD_BYTES` (TOML), or any problem :func:`read_measurement` finds (one line).
    """
    if not csv_bytes or not toml_bytes:
        missing = "the CSV data file" if not csv_bytes else "the TOML sidecar"
        raise BeamInputError(f"upload both files of a measurement: {missing} is missing")
    csv_bytes = csv_bytes.encode("utf-8") if isinstance(csv_bytes, str) else csv_bytes
    toml_bytes = toml_bytes.encode("utf-8") if isinstance(toml_bytes, str) else toml_bytes
    for name, data, limit in ((csv_name, csv_bytes, MAX_UPLOAD_BYTES), (toml_name, toml_bytes, MAX_SIDECAR_UPLOAD_BYTES)):
        if len(data) > limit:
            raise BeamInputError(f"{name}: {upload_size_text(len(data))} ({len(data):,} bytes) is more than the "
                                 f"{upload_size_text(limit)} ({limit:,} bytes) an upload may have")
    stem = Path(csv_name or "upload").stem or "upload"
    stem = "".join(c if c.isalnum() or c in "-_." else "_" for c in stem)[:80] or "upload"
    with tempfile.TemporaryDirectory(prefix="beam-upload-") as tmp:
        (Path(tmp) / f"{stem}.csv").write_bytes(csv_bytes)
        (Path(tmp) / f"{stem}.toml").write_bytes(toml_bytes)
        try:
            measurement = read_measurement(Path(tmp) / f"{stem}.csv")
        except BeamInputError as exc:  # name the uploaded files, not the temporary paths
            raise BeamInputError(str(exc).replace(f"{tmp}/", "")) from None
        except (UnicodeDecodeError, OSError) as exc:
            raise BeamInputError(f"{csv_name}: cannot read the upload ({type(exc).__name__})") from None
    return measurement


# -- calibration ------------------------------------------------------------------------------
def _stage_message(result: CalibrationResult) -> str:
    return "preview (MAP + Laplace)" if result.is_preview else "posterior (MCMC)"


def calibration_run(key: CalibrationKey, measurement: Measurement, *, every: int = 25,
                    use_cache: bool = True, known: tuple = ()) -> Iterator[sch.Stage[CalibrationResult]]:
    """Preview, streamed MCMC and final calibration (a scheduler job).

    Parameters
    ----------
    key : CalibrationKey
        Inputs (window, effects, modes, likelihood, seed, target ESS).
    measurement : Measurement
        The record ``key.dataset`` names.
    every : int
        Ensemble steps between two progress reports (the cancellation points).
    use_cache : bool
        Publish a cached final result at once when there is one (bundled datasets).
    known : tuple
        MAPs a diagnosis found on this record, window, modes and likelihood
        (:attr:`Diagnosis.known_maps`): the calibration of one of those models starts from its
        MAP instead of searching again (the same MAP, see :func:`beam.calibration.remember_maps`).

    Yields
    ------
    Stage
        ``preview``, ``progress`` items, ``final``; a bad input raises
        :class:`~beam.errors.BeamInputError` (published as ``error``).
    """
    cacheable = use_cache and key.dataset in bundled_datasets()
    cached = CALIBRATIONS.get(key) if cacheable else None
    if cached is not None:
        yield sch.final(cached, "posterior (cached)")
        return
    yield from cached_stages(CALIBRATIONS, key if cacheable else None, calibration_stages, key, measurement, every=every,
                             known=known)


def calibration_stages(key: CalibrationKey, measurement: Measurement, *, every: int = 25,
                       known: tuple = ()) -> Iterator[sch.Stage[CalibrationResult]]:
    """The computation of :func:`calibration_run` (in a worker process; no cache)."""
    if known:
        remember_maps(measurement, window=key.window, modes=key.modes, maps=known, likelihood=key.likelihood)
    stream = calibration_stream(measurement, window=key.window, effects=key.effects, modes=key.modes,
                                likelihood=key.likelihood, seed=key.seed, target_ess=key.target_ess, every=every)
    done = 0.0
    try:
        for event in stream:
            if isinstance(event, Progress):
                done = max(done, min(event.step / max(event.total, 1), 0.99))
                yield sch.progress(done, f"sampling: {event.step} of {event.total} ensemble steps")
            elif event.is_preview:
                yield sch.preview(event, _stage_message(event))
                warm_up()  # the sampler's libraries, before the stream goes on to sample
            else:
                yield sch.final(event, _stage_message(event))
    finally:
        stream.close()  # leaving the loop stops emcee


# -- diagnosis --------------------------------------------------------------------------------
@dataclass
class Diagnosis(VerdictFacts):
    """What the diagnosis view shows: the base fit, its residual report and the ranking so far.

    Attributes
    ----------
    key : CalibrationKey
        Dataset, window, effects (the base model), modes.
    base : CalibrationResult
        Preview calibration of the base model.
    residuals : ResidualReport
        :func:`beam.discovery.report.residual_report` of ``base``.
    candidates : list of Candidate
        Ranked best first (empty until ranked).
    pending : list of str
        Candidates not ranked yet.
    """

    key: CalibrationKey
    base: CalibrationResult
    residuals: ResidualReport
    candidates: list[Candidate] = field(default_factory=list)
    pending: list[str] = field(default_factory=list)
    #: Distance of the best model reached from the noise floor (set when the ranking is complete).
    remaining: Remaining | None = None
    #: Effects found missing on top of the best candidate (:func:`beam.discovery.report.climb_on`), with the
    #: error (:meth:`Diagnosis.errors`) of the last one.
    climbed: list[str] = field(default_factory=list)
    climbed_rmse: float = math.nan
    #: MAP natural frequencies (Hz) of each candidate's fit (:attr:`beam.discovery.ranking.Ranking.frequencies_Hz`).
    frequencies_Hz: dict = field(default_factory=dict)
    #: ``(effects, MapResult)`` of every model the diagnosis calibrated (:func:`beam.calibration.known_map`),
    #: for **Add** and the next diagnosis (see :func:`calibration_run`'s ``known``).
    known_maps: tuple = ()

    @property
    def ranking(self) -> Ranking:
        """The candidates ranked so far, over the base fit."""
        return Ranking(self.base, self.candidates, frequencies_Hz=self.frequencies_Hz)

    @property
    def missing(self) -> str | None:
        """The best materially improving candidate, or None."""
        return self.ranking.missing if not self.pending else None

    def errors(self, result) -> float:
        """The error a verdict quotes for ``result``: the held-out RMSE, or for a free decay the
        calibration window's (by which its candidates are judged)."""
        return result.rmse_calibration_map if self.base.setup.is_free else result.rmse_prediction_map

    @property
    def verdict(self) -> str:
        """One sentence, as :attr:`beam.discovery.report.DiagnosisReport.verdict` (the same function)."""
        if self.pending:
            return f"ranking the candidates: {len(self.pending)} to go"
        best = self.candidates[0] if self.candidates else None
        free = self.base.setup.is_free
        after = self.climbed_rmse if self.climbed else (
            (best.rmse_calibration if free else best.rmse_prediction) if best else math.nan)
        return verdict_sentence(self.missing, best.delta_log_evidence if best else math.nan,
                                self.errors(self.base), after, self.remaining, unit=self.base.setup.measurement.output_unit,
                                alternatives=self.indistinguishable if self.missing else (),
                                partly=self.partly_indistinguishable if self.missing else (),
                                error_label="calibration-window RMSE" if free else "held-out RMSE", then=self.climbed)


def diagnosis_run(key: CalibrationKey, measurement: Measurement, *, use_cache: bool = True,
                  known: tuple = ()) -> Iterator[sch.Stage[Diagnosis]]:
    """The diagnosis of the beam view's model on its window (a scheduler job); ``known``: MAPs an
    earlier diagnosis found on the same record, window, modes and likelihood (after **Add**, the
    new model and its candidates were the earlier diagnosis's best candidate and climb).

    Yields
    ------
    Stage
        ``progress`` (base calibration), ``partial`` :class:`Diagnosis` with the residual report,
        ``partial`` after every ranked candidate, ``progress`` while the climb ranks the candidates
        left on top of the best, ``final``.
    """
    cacheable = use_cache and key.dataset in bundled_datasets()
    dkey = (key.dataset, key.window, key.effects, key.modes)
    cached = DIAGNOSES.get(dkey) if cacheable else None
    if cached is not None:
        yield sch.final(cached, "diagnosis (cached)")
        return
    try:
        for stage in diagnosis_stages(key, measurement, known):
            if stage.kind == "final" and cacheable:
                DIAGNOSES.put(dkey, stage.value)
            yield stage
    except sch.Cancelled:
        return  # a newer request (or a closed page) cancelled it: nothing to publish


def diagnosis_stages(key: CalibrationKey, measurement: Measurement, known: tuple = ()) -> Iterator[sch.Stage[Diagnosis]]:
    """The computation of :func:`diagnosis_run` (no cache), as :func:`beam.discovery.report.diagnose`
    computes it: the base fit and its residual report in one worker process, then the candidates'
    fits spread over the pool's worker processes (:func:`dashboard.runtime.scheduler.offload_map`;
    the slowest candidate, the nonlinear spring, first), then the climb on top of the best, its
    fits spread the same way. Each fit's process is told the MAPs found so far (the base's, the
    candidates'), which are the sub-models of the climb's fits: their nested starts are then what
    one process would have computed (:func:`beam.calibration.remember_maps`)."""
    yield sch.progress(0.02, "calibrating the current model (preview)")
    base, residuals = _final(sch.offload(diagnosis_base, key, measurement, known))
    names = list(candidate_effects(base.setup.effects, measurement))  # fits the record: sensor_mass for an accelerometer
    diagnosis = Diagnosis(key, base, residuals, [], list(names))
    yield sch.partial(diagnosis, 0.25, f"ranking {len(names)} candidate effects")
    window, modes = base.setup.window, base.setup.modes
    known = [*known, known_map(base)]
    order = sorted(names, key=lambda e: not EFFECTS[e].nonlinear)  # the slowest fit first
    calls = [((measurement, window, with_effect(base.setup.effects, e), modes, tuple(known)), {}) for e in order]
    fits: dict[str, CalibrationResult | Exception] = {}
    frequencies: dict = {}
    explain = explainer(residuals)
    try:
        for i, (result, freqs) in sch.offload_map(candidate_fit, calls):
            effect = order[i]
            fits[effect] = result
            if freqs is not None:
                frequencies[effect] = freqs
            done = [e for e in names if e in fits]
            ranking = rank_fits(base, done, {e: fits[e] for e in done}, explain)
            diagnosis = Diagnosis(key, base, residuals, ranking.candidates, [e for e in names if e not in fits],
                                  frequencies_Hz=dict(frequencies))
            yield sch.partial(diagnosis, 0.25 + 0.6 * len(done) / max(len(names), 1),
                              f"ranked {len(done)} of {len(names)} candidates")
        known += [known_map(r) for r in fits.values() if not isinstance(r, Exception)]
        best = fits.get(diagnosis.missing) if diagnosis.missing is not None else base
        floor = noise_floor(measurement.time_s, measurement.output)

        def remaining_of(result: CalibrationResult) -> Remaining:  # in a worker: it may run the model
            return _final(sch.offload(remaining_stage, result, floor))

        diagnosis.remaining = remaining_of(best)
        if diagnosis.missing is not None and diagnosis.remaining.outside_catalogue:
            yield sch.progress(0.9, f"ranking the candidates on top of {diagnosis.missing}")
            fitter = process_fitter(measurement, window, modes, known)
            climbed, diagnosis.remaining = climb_on(measurement, best, diagnosis.remaining, floor, fitter=fitter,
                                                    remaining_of=remaining_of)
            diagnosis.climbed = [effect for effect, _ in climbed]
            diagnosis.climbed_rmse = diagnosis.errors(climbed[-1][1]) if climbed else math.nan
    except BeamInputError:
        pass
    diagnosis.known_maps = tuple(known)
    yield sch.final(diagnosis, "diagnosis")


def remaining_stage(result: CalibrationResult, floor) -> Iterator[sch.Stage[Remaining]]:
    """:func:`beam.discovery.report.remaining_error` of ``result`` (in a worker process)."""
    yield sch.final(remaining_error(result, floor))


def diagnosis_base(key: CalibrationKey, measurement: Measurement,
                   known: tuple = ()) -> Iterator[sch.Stage[tuple[CalibrationResult, ResidualReport]]]:
    """The base model's preview and its residual report (in a worker process)."""
    remember_maps(measurement, window=key.window, modes=key.modes, maps=known, likelihood=key.likelihood)
    warm_up()  # no half-imported ArviZ under the diagnostics (see dashboard.jobs.toy.warm_up)
    base = calibration_preview(measurement, window=key.window, effects=key.effects, modes=key.modes)
    base.map_prediction()  # computed here, carried to the server with the result
    yield sch.progress(0.5, "residual diagnostics: band, spectrum, whiteness, modes, backbone")
    yield sch.final((base, residual_report(base)))


def candidate_fit(measurement: Measurement, window: tuple[float, float], effects: tuple[str, ...], modes: int,
                  known: tuple = ()) -> Iterator[sch.Stage[tuple]]:
    """One candidate's preview (in a worker process): ``(result or the exception of a failed fit,
    its MAP natural frequencies in Hz or None)``. ``known``: MAPs found elsewhere
    (:func:`beam.calibration.known_map`) for the nested starts."""
    remember_maps(measurement, window=window, modes=modes, maps=known)
    try:
        result = calibration_preview(measurement, window=window, effects=effects, modes=modes)
    except FIT_ERRORS as exc:  # a failed fit: ranked last
        yield sch.final((exc, None))
        return
    result.map_prediction()  # computed here, carried to the server with the result
    yield sch.final((result, map_frequencies(result)))


def process_fitter(measurement: Measurement, window: tuple[float, float], modes: int, known: list) -> Fitter:
    """A :data:`beam.discovery.ranking.Fitter` over the pool's worker processes (inside a job)."""
    def fitter(effect_sets: list[tuple[str, ...]]) -> list[CalibrationResult | Exception]:
        order = sorted(range(len(effect_sets)), key=lambda i: not any(EFFECTS[e].nonlinear for e in effect_sets[i]))
        calls = [((measurement, window, effect_sets[i], modes, tuple(known)), {}) for i in order]
        out: list = [None] * len(effect_sets)
        for j, value in sch.offload_map(candidate_fit, calls):
            out[order[j]] = value if isinstance(value, Exception) else value[0]
        known.extend(known_map(r) for r in out if not isinstance(r, Exception))
        return out

    return fitter


def _final(stages: Iterator[sch.Stage]):
    """The value of the final stage of ``stages`` (:class:`~dashboard.runtime.scheduler.Cancelled`
    when there is none: the job was cancelled)."""
    return sch.final_value(stages)


def effect_label(effect: str) -> str:
    """``"Tip mass (tip_mass_kg: kg)"``-style label of a catalogue effect, units included."""
    e = EFFECTS[effect]
    units = ", ".join(f"{p.symbol} in {p.unit}" for p in e.parameters if p.required)
    return f"{e.title} ({units})"


def warm_worker() -> None:
    """Prepare a new worker process (seconds, once): what a preview needs first, then the sampler's libraries."""
    from beam.inference.laplace import preview as laplace_preview
    from beam.toy import ToyScenario, calibration_problem, simulate

    scenario = ToyScenario()
    laplace_preview(calibration_problem(scenario, simulate(scenario))[0])
    m = load_bundled(next(iter(bundled_datasets())))
    calibration_preview(m, window=(float(m.time_s[0]), float(m.time_s[min(400, m.time_s.size - 1)])), modes=2)
    warm_up()  # ArviZ and emcee: the MCMC stage (ArviZ alone takes seconds to import)
