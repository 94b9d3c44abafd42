"""The diagnosis job of the beam views: the fits of :func:`beam.discovery.report.diagnose` on the
pool's worker processes, published as they end.

Pure Python on top of the public ``beam`` API (no UI import).

:func:`diagnosis_run`
    ``progress`` (base calibration), ``partial`` :class:`Diagnosis` after the residual report and
    after every ranked candidate, ``progress`` while the climb ranks the candidates left on top
    of the best, ``final``. Cached for the bundled datasets.
:func:`diagnosis_stages`
    The computation (no cache). The fits go through one :class:`~dashboard.runtime.scheduler.OffloadQueue`
    (:class:`DiagnosisFits`): the candidates first, the slowest first; when a process would be
    left idle while the last candidates end, it starts the climb's fits on top of the candidate
    leading so far (a **speculative climb**). They are the very calls the climb makes once the
    ranking is complete, so its rungs take them as they are; a fit on top of a candidate that
    does not stay first is dropped (it cost a process that had nothing else to do).
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field

from beam.calibration import CalibrationResult, calibration_preview, known_map, remember_maps
from beam.discovery.ranking import (
    FIT_ERRORS,
    Candidate,
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
from beam.io.measurement import Measurement
from beam.physics.effects import EFFECTS
from beam.residuals import effect_scores
from beam.residuals.noise import record_noise_floor
from dashboard.jobs.beam import DIAGNOSES, CalibrationKey, bundled_datasets
from dashboard.jobs.warm import warm_up
from dashboard.runtime import scheduler as sch

__all__ = ["Diagnosis", "DiagnosisFits", "candidate_fit", "diagnosis_run", "diagnosis_stages"]


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
    #: for **Add** and the next diagnosis (see :func:`dashboard.jobs.beam.calibration_run`'s ``known``).
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
                                error_label="calibration-window RMSE" if free else "held-out RMSE", then=self.climbed,
                                window_notes=self.window_notes)


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


class DiagnosisFits:
    """The diagnosis's fits and residual checks on one :class:`~dashboard.runtime.scheduler.OffloadQueue`,
    each computed once, whoever asks first (the candidates' ranking, the speculative climb, the
    climb's rungs).

    Each fit's process is told the MAPs found so far (:attr:`known`: the base's, then every fit's
    as it ends), among them the sub-models of the climb's fits: their nested starts are what one
    process would have computed (:func:`beam.calibration.remember_maps`), so a fit's result does
    not depend on which of the two asked for it.
    """

    def __init__(self, measurement: Measurement, base: CalibrationResult, known: Iterable) -> None:
        self.measurement, self.window, self.modes = measurement, base.setup.window, base.setup.modes
        self.base_effects = tuple(base.setup.effects)
        self.known = list(known)
        self.queue = sch.OffloadQueue()
        self.results: dict[tuple, object] = {}
        #: Process CPU (s) of each candidate's fit (base + that effect), by effect.
        self.cpu_s: dict[str, float] = {}
        self._asked: set[tuple] = set()

    def fit(self, effects: tuple[str, ...], *, first: bool = False, screen: bool = False) -> None:
        """Ask for the preview of ``effects`` (nothing if asked already); ``screen``: its
        screening fit (the engine's first stage, see :func:`beam.discovery.report.climb_on`)."""
        key = ("screen" if screen else "fit", tuple(effects))
        if key not in self._asked:
            self._asked.add(key)
            self.queue.submit(key, candidate_fit, self.measurement, self.window, tuple(effects), self.modes,
                              tuple(self.known), not screen, first=first)

    def asked(self, effects: tuple[str, ...], *, screen: bool = False) -> bool:
        return ("screen" if screen else "fit", tuple(effects)) in self._asked

    def next(self) -> tuple[tuple, object]:
        """``(key, value)`` of the next call to end (:meth:`~dashboard.runtime.scheduler.OffloadQueue.next`)."""
        key, value = self.queue.next()
        if key[0] in ("fit", "screen"):
            if isinstance(value, BaseException):  # the process failed (not the fit): ranked last
                value = (value, None, math.nan)
            result, _, cpu_s = value
            added = set(key[1]) - set(self.base_effects)
            if len(added) == 1 and key[0] == "fit":
                self.cpu_s[added.pop()] = cpu_s
            if not isinstance(result, BaseException):
                self.known.append(known_map(result))  # a screening fit's: its first stage's
        self.results[key] = value
        return key, value

    def wait(self, keys: list[tuple]) -> list:
        """The values of ``keys`` (each asked for already), waiting for those not ended."""
        while any(k not in self.results for k in keys):
            self.next()
        return [self.results[k] for k in keys]

    def remaining(self, result: CalibrationResult, floor, *, wait: bool = True) -> Remaining | None:
        """:func:`beam.discovery.report.remaining_error` of ``result`` (in a worker: it may run the
        model); ``wait=False`` only asks for it."""
        key = ("remaining", tuple(result.setup.effects))
        if key not in self._asked:
            self._asked.add(key)
            self.queue.submit(key, remaining_stage, result, floor, first=True)
        if not wait:
            return None
        (value,) = self.wait([key])
        if isinstance(value, BaseException):
            raise value
        return value

    def cost(self, effects: tuple[str, ...]) -> float:
        """Expected cost of fitting ``effects``: the CPU of the candidates' fits of the effects it
        adds to the diagnosis's base (a nonlinear one not measured yet: first of all)."""
        total = 0.0
        for e in set(effects) - set(self.base_effects):
            measured = self.cpu_s.get(e)
            total += math.inf if measured is None and EFFECTS[e].nonlinear else (measured or 1.0)
        return total

    def fitter(self, effect_sets: list[tuple[str, ...]], *, screen: bool = False) -> list[CalibrationResult | Exception]:
        """A :data:`beam.discovery.ranking.Fitter` on the queue: each set asked for (the costliest
        first) unless asked already, then all waited for; ``screen``: their screening fits."""
        for effects in sorted(effect_sets, key=lambda s: -self.cost(s)):
            self.fit(effects, screen=screen)
        values = self.wait([("screen" if screen else "fit", tuple(s)) for s in effect_sets])
        return [value[0] for value in values]

    def screener(self, effect_sets: list[tuple[str, ...]]) -> list[CalibrationResult | Exception]:
        """:meth:`fitter` of screening fits (the climb's candidates)."""
        return self.fitter(effect_sets, screen=True)

    def close(self) -> None:
        self.queue.close()


def diagnosis_stages(key: CalibrationKey, measurement: Measurement, known: tuple = ()) -> Iterator[sch.Stage[Diagnosis]]:
    """The computation of :func:`diagnosis_run` (no cache), as :func:`beam.discovery.report.diagnose`
    computes it: the base fit and its residual report in one worker process, then the candidates'
    fits spread over the pool's worker processes (the slowest, the nonlinear spring, first), then
    the climb on top of the best, its fits spread the same way (:class:`DiagnosisFits`).

    **Speculative climb**: while the last candidates' fits run, a process with nothing left to
    do starts the climb's fits on top of the candidate leading so far (only those whose own
    candidate has ended: its MAP is a sub-model's, and the fit must not search for it again),
    and the residual check of that leader. If the leader stays first and what remains of its
    misfit is outside the catalogue, the climb takes those fits as they are; otherwise they are
    dropped.
    """
    yield sch.progress(0.02, "calibrating the current model (preview)")
    base, residuals = sch.final_value(sch.offload(diagnosis_base, key, measurement, known))
    names = list(candidate_effects(base.setup.effects, measurement))  # fits the record: sensor_mass for an accelerometer
    diagnosis = Diagnosis(key, base, residuals, [], list(names))
    yield sch.partial(diagnosis, 0.25, f"ranking {len(names)} candidate effects")
    effects_of = {e: with_effect(base.setup.effects, e) for e in names}
    fits_plan = DiagnosisFits(measurement, base, [*known, known_map(base)])
    floor = record_noise_floor(base.setup.measurement)  # the record as calibrated: the beam view's floor
    scores = effect_scores(residuals.fingerprints)
    for e in sorted(names, key=lambda e: (not EFFECTS[e].nonlinear, -scores.get(e, 0.0))):
        fits_plan.fit(effects_of[e])  # the slowest fit first, then the likeliest leader (its fingerprint)
    fits: dict[str, CalibrationResult | Exception] = {}
    frequencies: dict = {}
    explain = explainer(residuals)
    ranking = None
    try:
        while len(fits) < len(names):
            done_key, value = fits_plan.next()
            effect = next((e for e in names if done_key == ("fit", effects_of[e])), None)
            if effect is None or effect in fits:  # a speculative fit or a residual check: kept for the climb
                if ranking is not None:
                    _speculate(fits_plan, measurement, ranking, fits, names, floor)  # its process is free again
                continue
            fits[effect], freqs = value[0], value[1]
            if freqs is not None:
                frequencies[effect] = freqs
            done = [e for e in names if e in fits]
            ranking = rank_fits(base, done, {e: fits[e] for e in done}, explain)
            diagnosis = Diagnosis(key, base, residuals, ranking.candidates, [e for e in names if e not in fits],
                                  frequencies_Hz=dict(frequencies))
            yield sch.partial(diagnosis, 0.25 + 0.6 * len(done) / max(len(names), 1),
                              f"ranked {len(done)} of {len(names)} candidates")
            if len(fits) < len(names):
                _speculate(fits_plan, measurement, ranking, fits, names, floor)
        best = fits.get(diagnosis.missing) if diagnosis.missing is not None else base
        diagnosis.remaining = fits_plan.remaining(best, floor)
        if diagnosis.missing is not None and diagnosis.remaining.outside_catalogue:
            yield sch.progress(0.9, f"ranking the candidates on top of {diagnosis.missing}")
            climbed, diagnosis.remaining = climb_on(measurement, best, diagnosis.remaining, floor,
                                                    fitter=fits_plan.fitter, screen=fits_plan.screener,
                                                    remaining_of=lambda result: fits_plan.remaining(result, floor))
            diagnosis.climbed = [effect for effect, _ in climbed]
            diagnosis.climbed_rmse = diagnosis.errors(climbed[-1][1]) if climbed else math.nan
    except BeamInputError:
        pass
    finally:
        fits_plan.close()
    diagnosis.known_maps = tuple(fits_plan.known)
    yield sch.final(diagnosis, "diagnosis")


def _speculate(fits_plan: DiagnosisFits, measurement: Measurement, ranking: Ranking,
               fits: dict[str, CalibrationResult | Exception], names: list[str], floor) -> None:
    """Fill the processes the candidates left idle with the climb's fits on top of the leader so
    far (see :func:`diagnosis_stages`): its residual check first, then its fits, the costliest
    first, each only once the candidate it adds has ended."""
    queue = fits_plan.queue
    if queue.capacity < 2 or queue.idle() == 0 or ranking.missing is None:
        return
    free = queue.idle()
    leader = fits[ranking.missing]
    top = tuple(leader.setup.effects)
    fits_plan.remaining(leader, floor, wait=False)  # a few hundredths of a second, ahead of the fits
    ready = [with_effect(top, e) for e in candidate_effects(top, measurement) if e not in names or e in fits]
    for effects in sorted((s for s in ready if not fits_plan.asked(s, screen=True)), key=lambda s: -fits_plan.cost(s))[:free]:
        fits_plan.fit(effects, screen=True)


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
                  known: tuple = (), search: bool = True) -> Iterator[sch.Stage[tuple]]:
    """One candidate's preview (in a worker process): ``(result or the exception of a failed fit,
    its MAP natural frequencies in Hz or None, the fit's process CPU in s)``. ``known``: MAPs found
    elsewhere (:func:`beam.calibration.known_map`) for the nested starts; ``search=False``: a
    screening fit (:func:`beam.calibration.calibration_preview`)."""
    t0 = time.process_time()
    remember_maps(measurement, window=window, modes=modes, maps=known)
    try:
        result = calibration_preview(measurement, window=window, effects=effects, modes=modes, search=search)
    except FIT_ERRORS as exc:  # a failed fit: ranked last
        yield sch.final((exc, None, time.process_time() - t0))
        return
    result.map_prediction()  # computed here, carried to the server with the result
    yield sch.final((result, map_frequencies(result), time.process_time() - t0))
