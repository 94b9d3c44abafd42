"""Where the model fails and which physical effect is missing: the whole diagnosis of a record.

:func:`diagnose` calibrates the current model (preview), looks at its residuals over the whole
record, ranks the candidate effects (:mod:`beam.discovery.ranking`), climbs the error ladder and
measures what remains against the noise: :func:`beam.discovery.stream.diagnosis_stream` with its
fits on threads. What it finds, and the words of the verdict, are :mod:`beam.discovery.findings`'
(re-exported here).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

import beam.residuals as dx
from beam.calibration import CalibrationResult
from beam.discovery.findings import (
    AT_NOISE_RATIO,
    DiagnosisReport,
    explainer,
    indistinguishable,
    INDISTINGUISHABLE_LOG_EVIDENCE,
    INDISTINGUISHABLE_RMSE,
    INDISTINGUISHABLE_RMSE_CALIBRATION,
    map_frequencies,
    MAX_CLIMB,
    MAX_WINDOW_NOTES,
    OUTSIDE_CATALOGUE_RATIO,
    p_words,
    Remaining,
    remaining_error,
    remaining_words,
    residual_report,
    ResidualReport,
    SAME_FREQUENCY,
    same_modes,
    truncation_modes,
    TRUNCATION_SHARE,
    uniform_view,
    verdict_sentence,
    VerdictFacts,
    VerdictParts,
    window_only_words,
)
from beam.io.measurement import Measurement

__all__ = [
    "AT_NOISE_RATIO",
    "climb_on",
    "diagnose",
    "DiagnosisReport",
    "explainer",
    "indistinguishable",
    "INDISTINGUISHABLE_LOG_EVIDENCE",
    "INDISTINGUISHABLE_RMSE",
    "INDISTINGUISHABLE_RMSE_CALIBRATION",
    "map_frequencies",
    "MAX_CLIMB",
    "MAX_WINDOW_NOTES",
    "OUTSIDE_CATALOGUE_RATIO",
    "p_words",
    "Remaining",
    "remaining_error",
    "remaining_words",
    "residual_report",
    "ResidualReport",
    "SAME_FREQUENCY",
    "same_modes",
    "truncation_modes",
    "TRUNCATION_SHARE",
    "uniform_view",
    "verdict_sentence",
    "VerdictFacts",
    "VerdictParts",
    "window_only_words",
]


def diagnose(
    measurement: Measurement,
    spec=None,
    *,
    window: tuple[float, float] | None = None,
    modes: int | str | None = None,
    base: Iterable[str] | str | None = None,
    likelihood: str | None = None,
    ladder_mcmc: bool = False,
    seed: int | None = None,
    progress: Callable[[str], None] | None = None,
    workers: int = 2,
    engine=None,
    screen: bool = True,
) -> DiagnosisReport:
    """Diagnose a record from the ``base`` model: residuals, ranked candidates, error ladder.

    Drives :func:`beam.discovery.stream.diagnosis_stream` with its fits on ``workers`` threads
    (the compiled kernels release the GIL; two threads gain ~1.2x on two cores) and ``engine``
    (default: the process's).

    ``spec`` (a :class:`~beam.calibration.spec.CalibrationSpec`; default its defaults) says the
    base model (its ``effects``), window, modes, likelihood (of every fit of the diagnosis) and
    seed; the keywords ``window``, ``modes``, ``base`` (its effects), ``likelihood`` and ``seed``
    replace its values when given. ``modes`` defaults to ``"auto"``: chosen from the record's
    excited band (:func:`beam.calibration.modes.suggest_modes`), as the command line and the
    dashboard do. ``progress(text)``, if given, is told each step as it starts, each
    candidate's fit as it ends, with how many are left, and, from inside every fit, what it fits
    and what it is doing ("fitting tip_mass on the base (candidate 3 of 7), first stage, MAP
    search: iteration 4, 6 of 9 starts going"; "error ladder rung 2: + clamp_compliance, MCMC 250
    of 600 steps"), at least once per lock-step iteration, integration or sampler chunk
    (:func:`~beam.discovery.stream.run_request`); it is called from the fitting threads. ``screen``: see
    :func:`~beam.discovery.stream.diagnosis_stream`.
    """
    from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait

    from beam.calibration import CalibrationSpec, default_engine
    from beam.discovery.stream import (WAIT, BaseRequest, CheckRequest, CurveRequest, FitRequest, Step, diagnosis_stream,
                                       run_request)

    say = progress or (lambda text: None)
    engine = default_engine() if engine is None else engine
    given = {"window": window, "effects": base, "modes": modes, "likelihood": likelihood, "seed": seed}
    spec = CalibrationSpec.of(spec, **{key: value for key, value in given.items() if value is not None})
    stream = diagnosis_stream(engine, measurement, spec, ladder_mcmc=ladder_mcmc, screen=screen)
    running: dict = {}
    asked: set = set()
    report = None
    with ThreadPoolExecutor(max_workers=max(1, int(workers))) as pool:
        try:
            event = next(stream)
            while True:
                if event is WAIT:
                    ended, _ = wait(running, return_when=FIRST_COMPLETED)
                    future = next(f for f in running if f in ended)  # the first asked of those ended
                    running.pop(future)
                    event = stream.send(future.result())
                    continue
                if isinstance(event, (BaseRequest, FitRequest, CheckRequest, CurveRequest)) and event not in asked:
                    asked.add(event)
                    running[pool.submit(run_request, event, measurement, engine, progress)] = event
                elif isinstance(event, Step):
                    say(event.text)
                elif isinstance(event, DiagnosisReport):
                    report = event
                event = next(stream)
        except StopIteration:
            pass
        finally:
            stream.close()
    return report


def climb_on(measurement: Measurement, result: CalibrationResult, remaining: Remaining, floor: dx.NoiseFloor, *,
             mcmc: bool = False, seed: int = 0, fitter=None, screen=None,
             remaining_of=None) -> tuple[list[tuple[str, CalibrationResult]], Remaining]:
    """Before calling what remains "outside the catalogue": rank the candidates left on top of
    ``result`` (the last rung, a repaired model), and climb while one materially improves it.

    The ladder adds the candidates that improve the *base* model; a second effect whose share is
    small beside the first one's (the patch's added damping beside its stiffening) shows only once
    the first is in: ranked on top of it, it improves materially.

    Each rung's candidates are **screened**: ranked by screening fits (the engine's first stage,
    :func:`beam.calibration.calibration_preview` with ``search=False``), whose starts hold the MAPs
    of both sub-models (the rung below with the effect barely on; the base with the effect, with
    the rung's effects barely on). Only the best material one is then fitted by both stages (the
    rung is the engine's MAP, as ``beam calibrate`` finds it) and must still improve on the rung
    below. The second stage is most of what a model with two mode-changing effects costs, and on
    top of a repaired model it seldom finds another basin (the measured ladders, screened or not,
    are on the decisions page; ``tests/benchmarks/bench_climb.py``).

    The climb of :func:`beam.discovery.stream.diagnosis_stream`, its fits run by ``fitter`` (both
    stages) and ``screen`` (the screening fits; see :data:`beam.discovery.ranking.Fitter`; default
    threads); ``remaining_of(result)`` is :func:`remaining_error` of a rung against ``floor``.

    Returns
    -------
    (list of (effect, CalibrationResult), Remaining)
        The rungs climbed (at most :data:`MAX_CLIMB`) and the distance of the last one from the noise.
    """
    from beam.discovery.stream import climb_with

    return climb_with(measurement, result, remaining, floor, mcmc=mcmc, seed=seed, fitter=fitter, screen=screen,
                      remaining_of=remaining_of)
