"""The diagnosis job of the beam views: :func:`beam.discovery.diagnosis_stream` driven on the pool's
worker processes, its partial reports published as they come.

Pure Python on top of the public ``beam`` API (no UI import).

:func:`diagnosis_run`
    ``progress`` (base calibration), ``partial`` :class:`Diagnosis` after the residual report and
    after every ranked candidate, ``progress`` while the climb ranks the candidates left on top
    of the best, ``final``. Cached for the bundled datasets.
:func:`diagnosis_stages`
    The driver (no cache): the base fit in one worker process, the fits the stream asks for on
    one :class:`~dashboard.runtime.scheduler.OffloadQueue` (:class:`DiagnosisFits`), as many at
    once as the pool has processes, and the stream's **speculations** (the climb's fits on top of
    the candidate leading so far) on the processes that would otherwise be idle while the last
    candidates end. What to fit, and when, is the library's decision; where, the driver's.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, fields

from beam.calibration import CalibrationSpec, Engine, default_engine, remember_maps
from beam.calibration.engine import FIRST_STAGE
from beam.discovery import (
    WAIT,
    BaseRequest,
    CheckRequest,
    CurveRequest,
    DiagnosisReport,
    Done,
    FitRequest,
    Speculation,
    Step,
    diagnosis_stream,
    run_request,
)
from beam.io.measurement import Measurement
from beam.physics.effects import EFFECTS  # noqa: F401 - the catalogue the diagnosis ranks (tests read it here)
from dashboard.jobs.beam import DIAGNOSES, CalibrationKey
from dashboard.jobs.told import told_stages
from dashboard.jobs.warm import warm_up
from dashboard.runtime import scheduler as sch

__all__ = ["Diagnosis", "DiagnosisFits", "diagnosis_key", "diagnosis_run", "diagnosis_stages", "request_stages"]


@dataclass
class Diagnosis(DiagnosisReport):
    """What the diagnosis view shows: the library's :class:`~beam.discovery.DiagnosisReport`
    (partial while ``pending``) of the beam view's model, with its key.

    Attributes
    ----------
    key : CalibrationKey
        The record's digest and the spec of the model diagnosed (window, effects: the base model, modes).
    known_maps : tuple
        ``(effects, MapResult)`` of every model the diagnosis calibrated (a screening fit's as
        ``((FIRST_STAGE, *effects), MapResult)``), for **Add** and the next diagnosis (see
        :func:`dashboard.jobs.beam.calibration_run`'s ``known``).
    """

    key: CalibrationKey | None = None
    known_maps: tuple = ()

    @classmethod
    def of(cls, report: DiagnosisReport, key: CalibrationKey, known_maps: tuple = ()) -> Diagnosis:
        return cls(**{f.name: getattr(report, f.name) for f in fields(DiagnosisReport)}, key=key,
                   known_maps=known_maps)


def diagnosis_key(key: CalibrationKey) -> CalibrationKey:
    """What a diagnosis of ``key``'s model depends on: the record, window, effects (the base model) and
    modes (its fits use the spec's defaults for the rest)."""
    spec = key.spec
    return CalibrationKey(key.record, CalibrationSpec(window=spec.window, effects=spec.effects, modes=spec.modes))


def diagnosis_run(key: CalibrationKey, measurement: Measurement, *, use_cache: bool = True,
                  known: tuple = ()) -> Iterator[sch.Stage[Diagnosis]]:
    """The diagnosis of the beam view's model on its window (a scheduler job); ``known``: MAPs an
    earlier diagnosis (or calibration) found on the same record, window, modes and likelihood;
    ``use_cache``: publish a cached diagnosis of the same :func:`diagnosis_key` at once and keep
    this one (the state asks it for the bundled datasets only).

    Yields
    ------
    Stage
        ``progress`` (base calibration), ``partial`` :class:`Diagnosis` with the residual report,
        ``partial`` after every ranked candidate, ``progress`` while the climb ranks the candidates
        left on top of the best, ``final``.
    """
    dkey = diagnosis_key(key)
    cached = DIAGNOSES.get(dkey) if use_cache else None
    if cached is not None:
        yield sch.final(cached, "diagnosis (cached)")
        return
    try:
        for stage in diagnosis_stages(key, measurement, known):
            if stage.kind == "final" and use_cache:
                DIAGNOSES.put(dkey, stage.value)
            yield stage
    except sch.Cancelled:
        return  # a newer request (or a closed page) cancelled it: nothing to publish


def request_stages(request, measurement: Measurement, memory: tuple) -> Iterator[sch.Stage[Done]]:
    """One request of the diagnosis stream in a worker process, on the process's engine told the
    optima the diagnosis has found so far (``memory``: :meth:`beam.calibration.Engine.export`).

    Yields ``progress`` stages (fraction 0: the driver knows the diagnosis's) with what the fit
    says from inside (:func:`beam.discovery.run_request`'s ``progress``; :func:`~dashboard.jobs.told.told_stages`),
    then the ``final`` :class:`~beam.discovery.Done`. Closed early (the diagnosis was cancelled), it
    waits for the fit to end, as before (a fit is not stopped midway).
    """
    engine = default_engine()
    engine.merge(memory)
    if isinstance(request, BaseRequest):
        warm_up()  # no half-imported ArviZ under the diagnostics (see dashboard.jobs.toy.warm_up)
    yield from told_stages(lambda progress: run_request(request, measurement, engine, progress))


class DiagnosisFits:
    """The stream's requests on one :class:`~dashboard.runtime.scheduler.OffloadQueue`, each
    computed once, whoever asks first (the ranking, a speculation, the climb).

    Each request's process is sent the optima the diagnosis has found so far (the stream keeps
    them in :attr:`engine`), so a fit's result does not depend on which process runs it.
    """

    def __init__(self, measurement: Measurement, engine: Engine) -> None:
        self.measurement, self.engine = measurement, engine
        self.queue = sch.OffloadQueue()
        self._asked: set = set()

    def asked(self, request) -> bool:
        return request in self._asked

    def submit(self, request, *, first: bool = False) -> None:
        """Start ``request`` (nothing if asked already); ``first``: ahead of the calls waiting."""
        if request not in self._asked:
            self._asked.add(request)
            self.queue.submit(request, request_stages, request, self.measurement, self.engine.export(), first=first)

    def speculate(self, speculation: Speculation) -> None:
        """Fill the processes nothing else would occupy: the leader's residual check (a few
        hundredths of a second), then as many of the speculative fits as processes were idle."""
        queue = self.queue
        if queue.capacity < 2 or queue.idle() == 0:
            return
        free = queue.idle()
        self.submit(speculation.check, first=True)
        for request in [r for r in speculation.fits if not self.asked(r)][:free]:
            self.submit(request)

    def ended(self) -> bool:
        """Whether :meth:`next` returns without waiting for a process (a request has ended)."""
        return self.queue.ended()

    def reports(self) -> list[str]:
        """What the running requests said since the last call (each message under its request's
        label), waiting a moment for one unless a request has ended."""
        return [stage.message for _, stage in self.queue.reports()]

    def next(self) -> tuple:
        """``(request, Done)`` of the next request to end (a process that failed: its exception as the
        value, which the stream ranks last for a fit and raises for anything else)."""
        request, value = self.queue.next()
        if isinstance(value, BaseException):
            value = Done(request, value)
        return request, value

    def close(self) -> None:
        self.queue.close()


def diagnosis_stages(key: CalibrationKey, measurement: Measurement, known: tuple = ()) -> Iterator[sch.Stage[Diagnosis]]:
    """The computation of :func:`diagnosis_run` (no cache): :func:`beam.discovery.diagnosis_stream`
    with the base fit in one worker process and every other request on :class:`DiagnosisFits`."""
    spec = diagnosis_key(key).spec
    engine = Engine()  # this diagnosis's optima, sent with each request
    if key.spec.likelihood == spec.likelihood:
        remember_maps(measurement, window=spec.window, modes=spec.modes, maps=known, likelihood=spec.likelihood,
                      engine=engine)
    stream = diagnosis_stream(engine, measurement, spec)
    fits = DiagnosisFits(measurement, engine)
    ready: list[Done] = []
    last_fraction = 0.0
    try:
        event = next(stream)
        while True:
            if event is WAIT:
                while not ready and not fits.ended():  # what the running fits say, while they run
                    said = fits.reports()
                    if said:
                        yield sch.progress(last_fraction, said[-1])
                event = stream.send(ready.pop(0) if ready else fits.next()[1])
                continue
            if isinstance(event, BaseRequest):  # a run of its own, as a calibration's: not in the background
                stages = list(ready)
                for stage in sch.offload(request_stages, event, measurement, engine.export()):
                    if stage.kind == "final":
                        ready.append(stage.value)
                    elif stage.kind == "progress":
                        yield sch.progress(last_fraction, stage.message)
                if len(ready) == len(stages):
                    raise sch.Cancelled()  # no final stage: the run was cancelled
            elif isinstance(event, (CheckRequest, CurveRequest)):  # the averaged ranking: first
                fits.submit(event, first=True)
            elif isinstance(event, FitRequest):
                fits.submit(event)
            elif isinstance(event, Speculation):
                fits.speculate(event)
            elif isinstance(event, Step):
                if event.report is not None:
                    last_fraction = event.fraction
                    yield sch.partial(Diagnosis.of(event.report, key), event.fraction, event.text)
                elif event.fraction is not None:
                    last_fraction = max(last_fraction, event.fraction)
                    yield sch.progress(last_fraction, event.text)
            elif isinstance(event, DiagnosisReport):
                yield sch.final(Diagnosis.of(event, key, known_maps(engine)), "diagnosis")
            event = next(stream)
    except StopIteration:
        pass
    finally:
        fits.close()
        stream.close()


def known_maps(engine: Engine) -> tuple:
    """``(effects, MapResult)`` of every optimum ``engine`` holds (a screening fit's as
    ``((FIRST_STAGE, *effects), MapResult)``): what :func:`beam.calibration.remember_maps` takes."""
    return tuple(((FIRST_STAGE, *key[-1]) if kind == FIRST_STAGE else tuple(key[-1]), found)
                 for key, kind, found in engine.export())

