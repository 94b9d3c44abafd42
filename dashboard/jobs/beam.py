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
    residual report (``partial``), candidates two at a time, then ``final``.

The computations (:func:`calibration_stages`, :func:`diagnosis_stages`) run in a worker
process of the pool (:func:`dashboard.runtime.scheduler.offload`); the jobs around them look up and fill
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

from beam.calibration import CalibrationResult, calibration_preview, calibration_stream
from beam.discovery.ranking import (
    Candidate,
    Ranking,
    candidate_effects,
    rank_candidates,
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
    "warm_worker",
]

REPO = Path(__file__).resolve().parents[2]
ASSETS = REPO / "assets"
#: Largest accepted upload, per file (bytes).
MAX_UPLOAD_BYTES = 20 * 1024 * 1024
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


def load_upload(csv_name: str | None, csv_bytes: bytes | None, toml_name: str | None, toml_bytes: bytes | None) -> Measurement:
    """Check an uploaded measurement (CSV + TOML sidecar) and read it.

    Raises
    ------
    BeamInputError
        A missing or too large file, or any problem :func:`read_measurement` finds (one line).
    """
    if not csv_bytes or not toml_bytes:
        missing = "the CSV data file" if not csv_bytes else "the TOML sidecar"
        raise BeamInputError(f"upload both files of a measurement: {missing} is missing")
    for name, data in ((csv_name, csv_bytes), (toml_name, toml_bytes)):
        if len(data) > MAX_UPLOAD_BYTES:
            raise BeamInputError(f"{name}: {len(data) / 2**20:.1f} MB is more than the "
                                 f"{MAX_UPLOAD_BYTES // 2**20} MB an upload may have")
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
                    use_cache: bool = True) -> Iterator[sch.Stage[CalibrationResult]]:
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
    yield from cached_stages(CALIBRATIONS, key if cacheable else None, calibration_stages, key, measurement, every=every)


def calibration_stages(key: CalibrationKey, measurement: Measurement, *, every: int = 25) -> Iterator[sch.Stage[CalibrationResult]]:
    """The computation of :func:`calibration_run` (in a worker process; no cache)."""
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


def _rank_key(c: Candidate):
    return (not c.material, -c.delta_log_evidence if math.isfinite(c.delta_log_evidence) else math.inf)


def diagnosis_run(key: CalibrationKey, measurement: Measurement, *, use_cache: bool = True) -> Iterator[sch.Stage[Diagnosis]]:
    """The diagnosis of the beam view's model on its window (a scheduler job).

    Yields
    ------
    Stage
        ``progress`` (base calibration), ``partial`` :class:`Diagnosis` with the residual report,
        ``partial`` after every two ranked candidates (cancellation points), ``final``.
    """
    cacheable = use_cache and key.dataset in bundled_datasets()
    dkey = (key.dataset, key.window, key.effects, key.modes)
    cached = DIAGNOSES.get(dkey) if cacheable else None
    if cached is not None:
        yield sch.final(cached, "diagnosis (cached)")
        return
    yield from cached_stages(DIAGNOSES, dkey if cacheable else None, diagnosis_stages, key, measurement)


def diagnosis_stages(key: CalibrationKey, measurement: Measurement) -> Iterator[sch.Stage[Diagnosis]]:
    """The computation of :func:`diagnosis_run` (in a worker process; no cache)."""
    yield sch.progress(0.02, "calibrating the current model (preview)")
    warm_up()  # no half-imported ArviZ under the diagnostics (see dashboard.jobs.toy.warm_up)
    base = calibration_preview(measurement, window=key.window, effects=key.effects, modes=key.modes)
    yield sch.progress(0.1, "residual diagnostics: band, spectrum, whiteness, modes, backbone")
    residuals = residual_report(base)
    names = list(candidate_effects(base.setup.effects, measurement))  # fits the record: sensor_mass for an accelerometer
    diagnosis = Diagnosis(key, base, residuals, [], list(names))
    yield sch.partial(diagnosis, 0.25, f"ranking {len(names)} candidate effects")
    explain = explainer(residuals)
    ranked: list[Candidate] = []
    fits: dict[str, CalibrationResult] = {}
    frequencies: dict = {}
    for i in range(0, len(names), 2):
        chunk = names[i:i + 2]
        ranking = rank_candidates(measurement, base=base.setup.effects, modes=key.modes, base_result=base,
                                  candidates=chunk, explain=explain, workers=2)
        ranked = sorted(ranked + ranking.candidates, key=_rank_key)
        fits.update(ranking.results)
        frequencies.update({effect: map_frequencies(fit) for effect, fit in ranking.results.items()})
        done = min(i + 2, len(names))
        diagnosis = Diagnosis(key, base, residuals, ranked, names[done:], frequencies_Hz=dict(frequencies))
        yield sch.partial(diagnosis, 0.25 + 0.75 * done / max(len(names), 1), f"ranked {done} of {len(names)} candidates")
    try:  # how far the best model reached is from the record's noise (as the command line's verdict)
        best = fits.get(diagnosis.missing) if diagnosis.missing is not None else base
        floor = noise_floor(measurement.time_s, measurement.output)
        diagnosis.remaining = remaining_error(best, floor)
        if diagnosis.missing is not None and diagnosis.remaining.outside_catalogue:
            yield sch.progress(0.95, f"ranking the candidates on top of {diagnosis.missing}")
            climbed, diagnosis.remaining = climb_on(measurement, best, diagnosis.remaining, floor)
            diagnosis.climbed = [effect for effect, _ in climbed]
            diagnosis.climbed_rmse = diagnosis.errors(climbed[-1][1]) if climbed else math.nan
    except BeamInputError:
        pass
    yield sch.final(diagnosis, "diagnosis")


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
