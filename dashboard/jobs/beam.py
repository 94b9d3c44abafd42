"""Jobs of the beam views for the run scheduler: datasets, uploads, calibration (the diagnosis:
:mod:`dashboard.jobs.diagnosis`).

Pure Python on top of the public ``beam`` API (no UI import).

:func:`bundled_datasets`, :func:`load_bundled`, :func:`load_upload`
    The bundled lab runs (``assets/measurements``), the real records offered as teaching cases
    (:data:`REAL_DATASETS`, in ``assets/real``; no known answer) and user uploads (CSV + TOML sidecar,
    checked by writing them to a temporary directory and reading them with
    :func:`beam.io.measurement.read_measurement`).
:func:`calibration_run`
    ``preview`` (MAP + Laplace; for a free decay with the air drag first the averaged drag
    model's, :data:`AVERAGED_STATUS`), ``progress`` while emcee samples, ``final`` — the stages of
    :func:`beam.calibration.calibration_stream`. Leaving the generator cancels the sampler.

The computations run in the worker processes of the pool: a calibration
(:func:`calibration_stages`) in one (:func:`dashboard.runtime.scheduler.offload`), a diagnosis's
fits spread over all of them (:mod:`dashboard.jobs.diagnosis`); the jobs around them look up and fill
the caches in the server process. Final results are deterministic for their inputs, so they are
kept in small process-wide LRU caches shared by all sessions (bundled datasets only: an upload
is private to a session). :func:`warm_worker` prepares a new worker process (the app hands it to the pool with
:func:`dashboard.runtime.scheduler.set_worker_warm_up`; the runtime imports no job).
"""

from __future__ import annotations

import tempfile
from collections.abc import Iterator
from functools import lru_cache
from pathlib import Path
from typing import NamedTuple

from beam.calibration import (
    CalibrationResult,
    CalibrationSpec,
    calibration_preview,
    calibration_stream,
    default_engine,
    remember_maps,
)
from beam.calibration.engine import record_digest
from beam.errors import BeamInputError
from beam.inference import Progress
from beam.io.limits import MAX_MEASUREMENT_BYTES, MAX_TOML_BYTES
from beam.io.measurement import Measurement, read_measurement
from beam.io.simulation import read_truth
from beam.physics.effects import EFFECTS
from dashboard.jobs.warm import warm_up
from dashboard.runtime import scheduler as sch
from dashboard.runtime.caches import LRU, cached_stages

__all__ = [
    "ASSETS",
    "AVERAGED_STATUS",
    "CALIBRATIONS",
    "DIAGNOSES",
    "MAX_SIDECAR_UPLOAD_BYTES",
    "MAX_UPLOAD_BYTES",
    "LAPLACE_STATUS",
    "REAL_DATASETS",
    "CalibrationKey",
    "record_key",
    "bundled_datasets",
    "calibration_run",
    "calibration_stages",
    "is_real",
    "load_bundled",
    "load_upload",
    "read_answer",
    "stage_message",
    "upload_size_text",
    "warm_worker",
]

REPO = Path(__file__).resolve().parents[2]
ASSETS = REPO / "assets"
#: Largest accepted upload of a measurement CSV (bytes): the library's limit on what it reads.
MAX_UPLOAD_BYTES = MAX_MEASUREMENT_BYTES
#: Largest accepted upload of a TOML sidecar (bytes): the library's limit on what it reads.
MAX_SIDECAR_UPLOAD_BYTES = MAX_TOML_BYTES
#: Final calibrations by :class:`CalibrationKey` (bundled datasets only: an upload is its session's).
CALIBRATIONS = LRU(24)
#: Diagnoses by :class:`CalibrationKey` of their spec (:func:`dashboard.jobs.diagnosis.diagnosis_key`; bundled only).
DIAGNOSES = LRU(8)


class CalibrationKey(NamedTuple):
    """What a calibration (or a diagnosis) of the dashboard depends on: the record's content and the spec.

    Attributes
    ----------
    record : str
        Digest of the record's content (:func:`record_key`; not its name: the same file uploaded
        twice is one record).
    spec : CalibrationSpec
        The calibration's settings (window, effects, modes, likelihood, seed, target ESS).
    """

    record: str
    spec: CalibrationSpec


def record_key(measurement: Measurement) -> str:
    """The digest a key holds for ``measurement`` (:func:`beam.calibration.engine.record_digest`: its
    samples, kinds, geometry and nominal values), computed once per measurement object."""
    found = _DIGESTS.get(id(measurement))
    if found is not None and found[0] is measurement:
        return found[1]
    digest = record_digest(measurement)
    _DIGESTS[id(measurement)] = (measurement, digest)
    while len(_DIGESTS) > 64:
        _DIGESTS.pop(next(iter(_DIGESTS)))
    return digest


#: id(measurement) -> (measurement, digest), the last few (a 64 MB record's digest takes ~0.1 s).
_DIGESTS: dict[int, tuple[Measurement, str]] = {}


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
#: The status of the averaged drag preview (:attr:`CalibrationResult.approximation`), the first
#: result of a free decay calibrated with the air drag.
AVERAGED_STATUS = "averaged preview (slow-flow approximation of the drag) — full calibration running…"
#: The status of a nonlinear free decay's final result: its Laplace approximation (not sampled).
LAPLACE_STATUS = "Laplace posterior (a nonlinear free decay is not sampled by MCMC)"


def stage_message(result: CalibrationResult) -> str:
    """The status of a calibration's result in words: the averaged preview, the preview, the
    Laplace posterior of a nonlinear free decay or the MCMC posterior."""
    if result.approximation is not None:
        return AVERAGED_STATUS
    if not result.is_preview:
        return "posterior (MCMC)"
    return LAPLACE_STATUS if result.final else "preview (MAP + Laplace)"


def calibration_run(key: CalibrationKey, measurement: Measurement, *, every: int = 25,
                    use_cache: bool = True, known: tuple = ()) -> Iterator[sch.Stage[CalibrationResult]]:
    """Preview, streamed MCMC and final calibration (a scheduler job).

    Parameters
    ----------
    key : CalibrationKey
        The record's digest and the spec (window, effects, modes, likelihood, seed, target ESS).
    measurement : Measurement
        The record ``key.record`` is the digest of.
    every : int
        Ensemble steps between two progress reports (the cancellation points).
    use_cache : bool
        Publish a cached final result at once when there is one, and keep this one (the state
        asks it for the bundled datasets only).
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
    cached = CALIBRATIONS.get(key) if use_cache else None
    if cached is not None:
        yield sch.final(cached, "posterior (cached)")
        return
    yield from cached_stages(CALIBRATIONS, key if use_cache else None, calibration_stages, key, measurement,
                             every=every, known=known)


def calibration_stages(key: CalibrationKey, measurement: Measurement, *, every: int = 25,
                       known: tuple = ()) -> Iterator[sch.Stage[CalibrationResult]]:
    """The computation of :func:`calibration_run` (in a worker process; no cache)."""
    engine = default_engine()  # this worker process's
    spec = key.spec
    if known:
        remember_maps(measurement, window=spec.window, modes=spec.modes, maps=known, likelihood=spec.likelihood,
                      engine=engine)
    stream = calibration_stream(measurement, spec, every=every, engine=engine)
    done = 0.0
    try:
        for event in stream:
            if isinstance(event, Progress):
                done = max(done, min(event.step / max(event.total, 1), 0.99))
                yield sch.progress(done, f"sampling: {event.step} of {event.total} ensemble steps")
            elif not event.final:  # the averaged drag preview (if any), then the model's preview
                event.map_prediction()  # its errors' point prediction, computed here and carried with it
                yield sch.preview(event, stage_message(event))
                if event.approximation is None:
                    warm_up()  # the sampler's libraries, before the stream goes on to sample
            else:  # the posterior, or a nonlinear free decay's Laplace result (not sampled)
                event.map_prediction()
                yield sch.final(event, stage_message(event))
    finally:
        stream.close()  # leaving the loop stops emcee


def effect_label(effect: str) -> str:
    """``"Tip mass (tip_mass_kg: kg)"``-style label of a catalogue effect, units included."""
    e = EFFECTS[effect]
    if e.per_mode:  # "Modal damping (ζ per mode, no unit)", not "ζ_1 in 1"
        return f"{e.title} ({e.parameters[0].symbol.split('_')[0]} per mode{', no unit' if e.parameters[0].unit == '1' else ''})"
    units = ", ".join(f"{p.symbol} in {p.unit}" if p.unit != "1" else f"{p.symbol}, no unit" for p in e.parameters if p.required)
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
