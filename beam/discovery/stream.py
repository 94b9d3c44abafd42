"""The diagnosis as a generator: :func:`diagnosis_stream` says which fits it needs, its caller runs them.

The diagnosis of a record (:func:`beam.discovery.report.diagnose`) is a sequence of
calibrations: the base model's preview and its residual report, one preview per candidate
effect, the rungs of the error ladder, the climb's fits on top of the last rung, and a residual
check of each rung against the noise floor. :func:`diagnosis_stream` decides which of them are
needed next; *where* they run is its driver's business: :func:`~beam.discovery.report.diagnose`
runs them on threads, the dashboard on its worker processes, a study could run them on Dask.

**The protocol.** The generator yields, in order of need:

a request (:class:`BaseRequest`, :class:`CurveRequest`, :class:`FitRequest`, :class:`CheckRequest`)
    A computation to start. The driver starts it (unless it started it already: a request is
    hashable and equal requests are the same computation) and resumes the generator with
    ``send(None)``. Every request computes :meth:`run`; :func:`run_request` runs one and wraps its
    value in :class:`Done`.
:data:`WAIT`
    The generator needs a value: the driver resumes it with ``send(done)``, the :class:`Done` of
    one started request that has ended (any one: completion order).
:class:`Speculation`
    Fits the diagnosis will probably need (the climb's, on top of the candidate leading so far).
    A driver with an idle worker may start them; one without ignores them (``send(None)``).
:class:`Step`
    What the diagnosis is doing (text, fraction done) and, with ``report`` set, the partial
    :class:`~beam.discovery.findings.DiagnosisReport` so far (``pending`` candidates not ranked yet).
:class:`~beam.discovery.findings.DiagnosisReport`
    The last item: the complete report.

**A free decay is ranked on the averaged forms first** (:mod:`beam.discovery.averaged`): after
the base, one :class:`CurveRequest` scores every applicable candidate (the linear ones, and
``quadratic_drag``, ``clamp_friction``, ``tip_cubic_spring`` by their describing functions) on
the record's backbone and damping curves, and a :class:`Step` carries that complete ranking and
its verdict (``report.source == "averaged"``) before any full fit is asked for. The full fits
then confirm the linear candidates and the nonlinear ones the curves name missing; each full
figure replaces the averaged one as its fit ends (``Candidate.source``), and a nonlinear
candidate the curves do not call for keeps its averaged figures in the complete report.

Every fit result the generator receives is kept in its ``engine``
(:meth:`beam.calibration.Engine.merge`): a driver that runs fits in other processes sends
:meth:`~beam.calibration.Engine.export` with each request, so every fit starts from the optima
one process would have known (the nested starts), whichever process runs it.

Contract: for the same record and spec the complete report does not depend on the driver nor
on the order in which fits end (a speculative fit is asked for only once the sub-models whose
optima its starts use have been fitted).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Generator, Iterable
from dataclasses import dataclass, field, replace
from typing import Any, NamedTuple

from beam.calibration import CalibrationResult, CalibrationSpec, Engine, calibrate, calibration_preview, default_engine
from beam.discovery.findings import (
    MAX_CLIMB,
    DiagnosisReport,
    explainer,
    map_frequencies,
    remaining_error,
    residual_report,
)
from beam.discovery.ranking import (
    FIT_ERRORS,
    Ranking,
    candidate_effects,
    improves,
    ladder_step,
    rank_fits,
    thread_fitter,
    with_effect,
)
from beam.discovery.averaged import (
    AVERAGED,
    CurveRequest,
    averaged_candidates,
    averaged_ranking,
    averaged_verdict,
    confirmed,
    merged_ranking,
)
from beam.discovery.held_out import remember_held_out
from beam.errors import BeamInputError
from beam.inference.progress import report, reporting
from beam.io.measurement import Measurement
from beam.physics.effects import EFFECTS
from beam.residuals import effect_scores
from beam.residuals.noise import record_noise_floor

__all__ = [
    "WAIT",
    "climb_with",
    "error_ladder",
    "BaseRequest",
    "CheckRequest",
    "CurveRequest",
    "Done",
    "FitRequest",
    "Speculation",
    "Step",
    "diagnosis_stream",
    "drive",
    "run_request",
]


class _Wait:
    def __repr__(self) -> str:
        return "WAIT"


#: Yielded when the generator needs the :class:`Done` of a started request.
WAIT = _Wait()


@dataclass(frozen=True)
class BaseRequest:
    """The base model's preview and its residual report (:func:`beam.discovery.findings.residual_report`).

    ``spec``: the diagnosis's spec (its effects are the base model; window and modes may be unresolved).
    """

    spec: CalibrationSpec

    @property
    def label(self) -> str:
        """What the request fits, in words (the label of its progress reports)."""
        return "calibrating the current model (preview)"

    def run(self, measurement: Measurement, engine: Engine | None = None) -> tuple:
        """``(CalibrationResult, ResidualReport)``; a bad record or spec raises :class:`~beam.errors.BeamInputError`."""
        base = calibration_preview(measurement, self.spec, engine=engine)
        report("the MAP's prediction over the record and its held-out error")
        base.map_prediction()  # computed where the fit runs, carried with the result
        remember_held_out(base)  # the amplitude-aware held-out error of a free decay, likewise
        return base, residual_report(base)


@dataclass(frozen=True)
class FitRequest:
    """One calibration of a model the diagnosis needs.

    Attributes
    ----------
    spec : CalibrationSpec
        Resolved spec of the model (window, effects, modes, likelihood; the seed of an MCMC fit).
    search : bool
        False: a screening fit (the engine's first stage only; see :func:`beam.calibration.calibration_preview`).
    mcmc : bool
        A full calibration (:func:`beam.calibration.calibrate`) instead of a preview.
    what : str
        What the fit is for, in words ("fitting tip_mass on the base (candidate 3 of 7)"): the
        label of its progress reports (:attr:`label`). Not part of the request's identity: equal
        requests are the same computation, whoever asked first names it.
    """

    spec: CalibrationSpec
    search: bool = True
    mcmc: bool = False
    what: str = field(default="", compare=False)

    @property
    def effects(self) -> tuple[str, ...]:
        return self.spec.effects

    @property
    def label(self) -> str:
        """``what``, else the model fitted and how ("fitting modal_damping + tip_mass, MCMC")."""
        how = "MCMC" if self.mcmc else ("both stages" if self.search else "screening fit")
        return self.what or f"fitting {' + '.join(self.effects) or 'the ideal beam'} ({how})"

    def run(self, measurement: Measurement, engine: Engine | None = None) -> CalibrationResult | Exception:
        """The calibration, or the exception of a failed fit (:data:`~beam.discovery.ranking.FIT_ERRORS`:
        ranked last, never raised)."""
        try:
            if self.mcmc:
                result = calibrate(measurement, self.spec, engine=engine)
            else:
                result = calibration_preview(measurement, self.spec, search=self.search, engine=engine)
        except FIT_ERRORS as exc:
            return exc
        report("the MAP's prediction over the record and its held-out error")
        result.map_prediction()  # computed where the fit runs, carried with the result
        remember_held_out(result)  # the amplitude-aware held-out error of a free decay, likewise
        return result


@dataclass(frozen=True)
class CheckRequest:
    """How far a rung is from the noise floor (:func:`beam.discovery.findings.remaining_error`); equal
    requests are those of the same model (``effects``)."""

    effects: tuple[str, ...]
    result: CalibrationResult = field(compare=False, repr=False)
    floor: Any = field(compare=False, repr=False)

    @classmethod
    def of(cls, result: CalibrationResult, floor) -> CheckRequest:
        return cls(tuple(result.setup.effects), result, floor)

    @property
    def label(self) -> str:
        """What the request computes, in words."""
        return f"measuring {' + '.join(self.effects)} against the noise floor"

    def run(self, measurement: Measurement | None = None, engine: Engine | None = None):
        """The :class:`~beam.discovery.findings.Remaining` of the rung."""
        return remaining_error(self.result, self.floor)


Request = BaseRequest | FitRequest | CheckRequest | CurveRequest


class Done(NamedTuple):
    """A request that has ended: its value (an exception of a failed fit included), the process
    CPU it took (s; NaN when unknown) and, for a fit, its MAP natural frequencies (Hz)."""

    request: Request
    value: Any
    cpu_s: float = math.nan
    frequencies_Hz: Any = None


@dataclass(frozen=True)
class Speculation:
    """Requests the diagnosis will probably need: ``check`` (the leader's residual check) first,
    then ``fits`` (screening fits on top of the leader), the costliest first."""

    check: CheckRequest
    fits: tuple[FitRequest, ...]


@dataclass(frozen=True)
class Step:
    """What the diagnosis is doing: ``text``, ``fraction`` done (None: unchanged) and (a partial
    result) ``report``."""

    text: str
    fraction: float | None
    report: Any = None


def run_request(request: Request, measurement: Measurement, engine: Engine | None = None,
                progress: Callable[[str], None] | None = None) -> Done:
    """Run ``request`` here (on ``engine``, default the process's) and time its process CPU; a fit's
    MAP natural frequencies are computed here too (what the verdict compares). An exception is the
    value: the stream raises it where the diagnosis cannot go on without it.

    ``progress(text)``, if given, is told the request's :attr:`label` as it starts and then what
    its fit is doing, under that label, from inside the fit (every lock-step iteration of a MAP
    search, every start that continues alone, every integration of a nonlinear search, every
    sampler chunk: :mod:`beam.inference.progress`), on the thread that runs it."""
    t0 = time.process_time()
    try:
        with reporting(progress, request.label):
            value = request.run(measurement, engine)
    except Exception as exc:  # noqa: BLE001 - handed to the stream (a failed fit is ranked last)
        value = exc
    frequencies = None
    if isinstance(request, FitRequest) and isinstance(value, CalibrationResult):
        try:
            frequencies = map_frequencies(value)
        except (BeamInputError, ValueError, KeyError):
            frequencies = None
    return Done(request, value, time.process_time() - t0, frequencies)


class _Fits:
    """The generator's record of what has ended, and the wait for given requests."""

    def __init__(self, engine: Engine, measurement: Measurement, spec: CalibrationSpec, *, mcmc: bool, seed: int,
                 screen: bool = True) -> None:
        self.engine, self.measurement, self.spec = engine, measurement, spec
        self.mcmc, self.seed, self.screen = mcmc, seed, screen
        self.done: dict[Request, Done] = {}
        #: Process CPU (s) of each candidate's fit of the base, by effect (what a fit costs).
        self.cpu_s: dict[str, float] = {}
        self.base_effects: tuple[str, ...] = ()

    def model(self, effects: Iterable[str], *, search: bool = True, mcmc: bool = False, what: str = "") -> FitRequest:
        """The request of ``effects`` on the diagnosis's resolved window, modes and likelihood
        (a preview with the spec's default seed; an MCMC fit with the diagnosis's seed); ``what``
        it is for, in words (:attr:`FitRequest.what`)."""
        spec = self.spec.for_model(effects)
        return FitRequest(replace(spec, seed=self.seed) if mcmc else spec, search=search, mcmc=mcmc, what=what)

    def receive(self, done: Done) -> None:
        if not isinstance(done, Done):
            done = Done(*done)
        value = done.value
        if isinstance(value, BaseException) and not (isinstance(done.request, FitRequest)
                                                     and isinstance(value, FIT_ERRORS)):
            if not isinstance(done.request, (CheckRequest, CurveRequest)):
                raise value  # the base fit, or a fit that failed for another reason than its model
        self.done[done.request] = done
        if isinstance(done.request, BaseRequest):
            value = value[0]
        if isinstance(value, CalibrationResult):
            self.engine.merge([self.engine.memory_of(value)])
        if isinstance(done.request, FitRequest) and not done.request.mcmc:
            added = set(done.request.effects) - set(self.base_effects)
            if len(added) == 1 and done.request.search and len(done.request.effects) == len(self.base_effects) + 1:
                self.cpu_s[added.pop()] = done.cpu_s

    def cost(self, effects: Iterable[str]) -> float:
        """Expected cost of fitting ``effects``: the CPU of the candidates' fits of the effects it
        adds to the base (a nonlinear one not measured yet: first of all)."""
        total = 0.0
        for e in set(effects) - set(self.base_effects):
            measured = self.cpu_s.get(e)
            if measured is None or not math.isfinite(measured):
                total += math.inf if EFFECTS[e].nonlinear else 1.0
            else:
                total += measured
        return total

    def wait(self, requests: list[Request], label: str | None = None, added_to: Iterable[str] = ()
             ) -> Generator[Any, Any, list]:
        """Ask for ``requests`` (the costliest fits first) and wait until each has ended; their
        values, in order. ``label``: a :class:`Step` as each ends (``"<label> <effect> fitted (i of n, k left)"``)."""
        order = sorted(requests, key=lambda r: -self.cost(r.effects) if isinstance(r, FitRequest) else math.inf)
        for request in order:
            if request not in self.done:
                yield request
        total, ended = len(requests), sum(r in self.done for r in requests)
        while any(r not in self.done for r in requests):
            done = yield WAIT
            self.receive(done)
            request = done[0]
            if label is not None and request in requests:
                ended += 1
                added = " + ".join(e for e in request.effects if e not in set(added_to))
                yield Step(f"{label} {added} fitted ({ended} of {total}, {total - ended} left)", None)
        return [self.done[r].value for r in requests]


def _rungs(fits: _Fits, ranking: Ranking, max_steps: int = 3) -> Generator[Any, Any, list]:
    """The error ladder (:func:`error_ladder`): base, then the materially
    improving candidates one at a time, best first, while each improves on the rung below."""
    base = ranking.base
    if fits.mcmc:
        (first,) = yield from fits.wait([fits.model(base.setup.effects, mcmc=True, what="error ladder rung 1: the base")])
        steps = [ladder_step(_raised(first), None, True)]
    else:
        steps = [ladder_step(base, None, False)]
    effects = list(base.setup.effects)
    previous = base
    for candidate in [c for c in ranking.candidates if c.material and c.source != AVERAGED][:max_steps]:
        chosen = tuple(e for e in EFFECTS if e in set(effects) | {candidate.effect})
        what = f"error ladder rung {len(steps) + 1}: + {candidate.effect}"
        if fits.mcmc:
            (result,) = yield from fits.wait([fits.model(chosen, mcmc=True, what=what)])
        elif len(effects) == len(base.setup.effects):
            result = ranking.results[candidate.effect]
        else:
            (result,) = yield from fits.wait([fits.model(chosen, what=what)])
        result = _raised(result)
        if len(effects) > len(base.setup.effects) and not improves(previous, result):
            break  # on top of the rungs below, this effect no longer helps: the climb ends here
        effects.append(candidate.effect)
        steps.append(ladder_step(result, candidate.effect, fits.mcmc))
        previous = result
    return steps


def error_ladder(measurement: Measurement, ranking: Ranking, *, mcmc: bool = False, seed: int = 0,
                 max_steps: int = 3, engine: Engine | None = None) -> list:
    """base -> + best -> + next best ...: the materially improving candidates of ``ranking`` added
    one at a time (at most ``max_steps``), each while it improves on the rung below; the rungs'
    fits here, one after the other."""
    engine = default_engine() if engine is None else engine
    fits = _Fits(engine, measurement, CalibrationSpec.of_setup(ranking.base.setup), mcmc=mcmc, seed=seed)
    fits.base_effects = tuple(ranking.base.setup.effects)
    return drive(_rungs(fits, ranking, max_steps),
                 lambda requests: [run_request(r, measurement, engine) for r in requests])


def climb_with(measurement: Measurement, result: CalibrationResult, remaining, floor, *, mcmc: bool = False,
               seed: int = 0, fitter=None, screen=None, remaining_of=None) -> tuple[list, Any]:
    """The climb of :func:`diagnosis_stream` on top of ``result`` (see
    :func:`beam.discovery.report.climb_on`), its fits run by the :data:`~beam.discovery.ranking.Fitter`
    ``fitter`` (both stages) and ``screen`` (screening fits), default threads."""
    spec = CalibrationSpec.of_setup(result.setup)
    fitter = fitter or thread_fitter(measurement, spec)
    screen = screen or thread_fitter(measurement, spec, search=False)
    engine = default_engine()
    fits = _Fits(engine, measurement, CalibrationSpec.of_setup(result.setup), mcmc=mcmc, seed=seed)
    fits.base_effects = tuple(result.setup.effects)

    def run(requests: list) -> list:
        done = {}
        for search, fit in ((True, fitter), (False, screen)):
            batch = [r for r in requests if not isinstance(r, CheckRequest) and not r.mcmc and r.search == search]
            if batch:
                done.update({r: Done(r, value) for r, value in zip(batch, fit([r.effects for r in batch]))})
        for r in requests:
            if isinstance(r, CheckRequest):
                done[r] = Done(r, r.run() if remaining_of is None else remaining_of(r.result))
            elif r.mcmc:
                done[r] = run_request(r, measurement, engine)
        return [done[r] for r in requests]

    return drive(_climb(fits, result, remaining, floor), run)


def _raised(value):
    if isinstance(value, BaseException):
        raise value
    return value


def _climb(fits: _Fits, result: CalibrationResult, remaining, floor) -> Generator[Any, Any, tuple[list, Any]]:
    """:func:`beam.discovery.report.climb_on` as requests: rank the candidates left on top of
    ``result`` by screening fits, fit the best material one by both stages, climb while it improves."""
    climbed: list[tuple[str, CalibrationResult]] = []
    last = result
    while remaining.outside_catalogue and len(climbed) < MAX_CLIMB:
        names = candidate_effects(last.setup.effects, fits.measurement)
        label = "screening on top of the ladder:" if fits.screen else "on top of the ladder:"
        on = " + ".join(e for e in last.setup.effects if e not in set(fits.base_effects)) or "the base"
        requests = [fits.model(with_effect(last.setup.effects, e), search=not fits.screen,
                               what=f"{label} fitting {e} on top of {on} (candidate {i} of {len(names)})")
                    for i, e in enumerate(names, 1)]
        values = yield from fits.wait(requests, label, last.setup.effects)
        ranking = rank_fits(last, names, dict(zip(names, values)))
        best = next((c for c in ranking.candidates if c.material), None)
        if best is None:
            break
        step = ranking.results[best.effect]
        if step.screened:  # the rung itself: both stages of the engine
            (step,) = yield from fits.wait([fits.model(with_effect(last.setup.effects, best.effect),
                                                       what=f"on top of the ladder: + {best.effect}, both stages")],
                                           "on top of the ladder:", last.setup.effects)
            if isinstance(step, Exception):
                break
        if not improves(last, step):
            break
        if fits.mcmc:
            (step,) = yield from fits.wait([fits.model(step.setup.effects, mcmc=True,
                                                       what=f"on top of the ladder: + {best.effect}")])
            step = _raised(step)
        climbed.append((best.effect, step))
        (remaining,) = yield from fits.wait([CheckRequest.of(step, floor)])
        remaining = _raised(remaining)
        last = step
    return climbed, remaining


def diagnosis_stream(engine: Engine | None, measurement: Measurement, spec: CalibrationSpec | None = None, *,
                     ladder_mcmc: bool = False, screen: bool = True) -> Generator[Any, Any, None]:
    """The diagnosis of ``measurement`` from ``spec``'s model, as a generator (see the module notes
    for the protocol): residuals, ranked candidates, error ladder, climb, distance to the noise.

    Parameters
    ----------
    engine : Engine or None
        Where the optima of the fits received are kept (default: the process's,
        :func:`beam.calibration.default_engine`).
    measurement : Measurement
        The record.
    spec : CalibrationSpec, optional
        The base model (``effects``), window and modes (``"auto"``: chosen from the record) and,
        for ``ladder_mcmc``, the seed of the rungs' MCMC. The previews use the spec's window,
        modes and likelihood with the default seed.
    ladder_mcmc : bool
        Calibrate every rung of the ladder (and of the climb) by full MCMC.
    screen : bool
        Rank the climb's candidates by screening fits (False: by both stages of the engine).

    Yields
    ------
    request, WAIT, Speculation, Step, DiagnosisReport
        See the module notes; the last item is the complete :class:`~beam.discovery.findings.DiagnosisReport`.
    """
    engine = default_engine() if engine is None else engine
    spec = CalibrationSpec.of(spec)
    t0 = time.perf_counter()
    yield Step("calibrating the current model (preview) and its residual diagnostics: band, spectrum, whiteness, "
               "modes", 0.02)
    first = BaseRequest(spec.for_model(spec.effects))  # a preview: the default seed
    yield first
    while True:
        done = yield WAIT
        done = done if isinstance(done, Done) else Done(*done)
        if done.request == first:
            break
    base, residuals = _raised(done.value)
    fits = _Fits(engine, measurement, CalibrationSpec.of_setup(base.setup), mcmc=ladder_mcmc, seed=spec.seed,
                 screen=screen)
    fits.base_effects = tuple(base.setup.effects)
    fits.receive(done)

    names = list(candidate_effects(base.setup.effects, measurement))  # fits the record: sensor_mass for an accelerometer
    explain = explainer(residuals)

    def report(ranking: Ranking, pending: list[str], ladder=None, remaining=None, complete: bool = False,
               source: str = "full"):
        if ladder is None:
            ladder = [ladder_step(base, None, False)]
            if not pending and ranking.missing is not None and ranking.missing in ranking.results:
                ladder.append(ladder_step(ranking.results[ranking.missing], ranking.missing, False))
        return DiagnosisReport(measurement, residuals, ranking, ladder, time.perf_counter() - t0, remaining,
                               pending=list(pending), complete=complete, source=source, averaged_verdict=said)

    # a free decay: every applicable candidate ranked on the record's own curves first (averaged
    # forms, about a second a candidate), that ranking and its verdict streamed; the full fits then
    # confirm the linear candidates and the nonlinear ones leading on the curves
    averaged, said = None, None
    offered = averaged_candidates(base.setup.effects, measurement) if base.setup.is_free else ()
    if offered:
        curves = CurveRequest(CalibrationSpec.of_setup(base.setup), tuple(offered))
        yield Step(f"{curves.label}", 0.1)
        (scores,) = yield from fits.wait([curves])
        if isinstance(scores, BaseException):
            residuals.notes.append(f"no ranking on the averaged forms: {' '.join(str(scores).split())[:200]}")
        else:
            averaged = averaged_ranking(base, scores, residuals.explanations)
            said = averaged_verdict(averaged)
            names = confirmed(averaged, [e for e in names if not EFFECTS[e].nonlinear])
            yield Step(f"ranked on the averaged forms ({len(offered)} candidates); confirming "
                       f"{len(names)} by full fits", 0.25, report(averaged, [], source=AVERAGED))

    ranking = merged_ranking(base, averaged, Ranking(base, []))
    yield Step(f"fitting the candidate effects: ranking {len(names)}", 0.25, report(ranking, names))
    requests = {e: fits.model(with_effect(base.setup.effects, e),
                              what=f"fitting {e} on the base (candidate {i} of {len(names)})")
                for i, e in enumerate(names, 1)}
    scores = effect_scores(residuals.fingerprints)
    for e in sorted(names, key=lambda e: (not EFFECTS[e].nonlinear, -scores.get(e, 0.0))):
        yield requests[e]  # the slowest fit first, then the likeliest leader (its fingerprint)
    ended: dict[str, Any] = {}
    frequencies: dict = {}
    floor = None
    full = Ranking(base, [])
    try:
        floor = record_noise_floor(base.setup.measurement)  # as calibrated: the one floor shown everywhere
    except BeamInputError as exc:
        floor_error = exc
    while len(ended) < len(names):
        done = yield WAIT
        fits.receive(done)
        done = fits.done[done[0]]
        effect = next((e for e in names if done.request == requests[e]), None)
        if effect is not None and effect not in ended:
            ended[effect] = done.value
            if done.frequencies_Hz is not None:
                frequencies[effect] = done.frequencies_Hz
            ranked = [e for e in names if e in ended]
            full = rank_fits(base, ranked, {e: ended[e] for e in ranked}, explain)
            full.frequencies_Hz = dict(frequencies)
            ranking = merged_ranking(base, averaged, full)
            added = " + ".join(e for e in done.request.effects if e not in set(base.setup.effects))
            yield Step(f"candidate {added} fitted ({len(ranked)} of {len(names)}, {len(names) - len(ranked)} left)",
                       0.25 + 0.6 * len(ranked) / max(len(names), 1),
                       report(ranking, [e for e in names if e not in ended]))
        if full.candidates and len(ended) < len(names) and full.missing is not None and floor is not None:
            leader = full.results[full.missing]
            top = tuple(leader.setup.effects)
            ready = [with_effect(top, e) for e in candidate_effects(top, measurement) if e not in names or e in ended]
            yield Speculation(CheckRequest.of(leader, floor),
                              tuple(fits.model(s, search=not screen,
                                               what=f"ahead: fitting {' + '.join(e for e in s if e not in top)} "
                                                    f"on top of {full.missing}")
                                    for s in sorted(ready, key=lambda s: -fits.cost(s))))

    yield Step("error ladder" + (" (MCMC at every rung)" if ladder_mcmc else ""), 0.85)
    ladder = yield from _rungs(fits, ranking)
    remaining = None
    try:
        if floor is None:
            raise floor_error
        (remaining,) = yield from fits.wait([CheckRequest.of(ladder[-1].result, floor)])
        remaining = _raised(remaining)
        if len(ladder) > 1 and remaining.outside_catalogue:  # something was added, and more may be missing on top
            yield Step(f"ranking the candidates on top of {ladder[-1].added}", 0.9)
            climbed, remaining = yield from _climb(fits, ladder[-1].result, remaining, floor)
            ladder = [*ladder, *(ladder_step(result, effect, ladder_mcmc) for effect, result in climbed)]
    except BeamInputError as exc:
        residuals.notes.append(f"no noise floor: {exc}")
    yield report(ranking, [], ladder, remaining, complete=True)


def drive(stream: Generator, run: Callable[[list], list], *,
          on_step: Callable[[Step], None] | None = None) -> Any:
    """Drive ``stream`` here: at each :data:`WAIT`, ``run(requests)`` computes every request asked
    for and not computed yet (a list of :class:`Done`, in order; it may run them at once).
    Speculations are ignored. The simplest driver, and the one of the pieces run on their own
    (:func:`beam.discovery.report.climb_on`). Returns the generator's return value, or its last item."""
    asked: list = []
    ready: list = []
    seen: set = set()
    last = None
    try:
        event = next(stream)
        while True:
            if event is WAIT:
                if not ready:
                    batch, asked[:] = list(asked), []
                    ready.extend(run(batch))
                event = stream.send(ready.pop(0))
                continue
            if isinstance(event, (BaseRequest, FitRequest, CheckRequest, CurveRequest)):
                if event not in seen:
                    seen.add(event)
                    asked.append(event)
            elif isinstance(event, Step):
                if on_step is not None:
                    on_step(event)
            elif not isinstance(event, Speculation):
                last = event
            event = next(stream)
    except StopIteration as stop:
        return stop.value if stop.value is not None else last
