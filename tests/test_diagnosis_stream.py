"""The diagnosis as a stream: whatever runs its requests and in whatever order they end, the report
is the one :func:`beam.discovery.diagnose` gives (lab_run_2 hides a tip mass)."""

from __future__ import annotations

from pathlib import Path

import pytest

from beam.calibration import CalibrationSpec, Engine
from beam.discovery import (
    WAIT,
    BaseRequest,
    DiagnosisReport,
    Speculation,
    Step,
    diagnose,
    diagnosis_stream,
    run_request,
)
from beam.io.measurement import read_measurement

RECORD = Path(__file__).resolve().parents[1] / "assets" / "measurements" / "lab_run_2.csv"
WINDOW, MODES = (0.0, 0.6), 2


def drive_last_first(measurement, spec):
    """Run the stream's requests here, the *latest* asked first (the reverse of the threads'
    order), speculations included: the partial reports and the final one."""
    engine = Engine()
    stream = diagnosis_stream(engine, measurement, spec)
    asked, partial, started = [], [], set()
    event = next(stream)
    while not isinstance(event, DiagnosisReport):
        if event is WAIT:
            event = stream.send(run_request(asked.pop(), measurement, engine))
            continue
        if isinstance(event, Speculation):
            requests = [event.check, *event.fits]
        elif isinstance(event, Step):
            requests = []
            if event.report is not None:
                partial.append(event.report)
        else:
            requests = [event]
        for request in requests:
            if request not in started:
                started.add(request)
                asked.append(request)
        event = next(stream)
    return partial, event


@pytest.mark.slow
def test_the_stream_driven_in_any_order_gives_the_report_of_diagnose():
    record = read_measurement(RECORD)
    spec = CalibrationSpec(window=WINDOW, modes=MODES)
    partial, streamed = drive_last_first(record, spec)
    threaded = diagnose(record, window=WINDOW, modes=MODES, engine=Engine())

    assert streamed.complete and streamed.missing == threaded.missing == "tip_mass"
    assert streamed.verdict == threaded.verdict
    assert [c.effect for c in streamed.candidates] == [c.effect for c in threaded.candidates]
    for a, b in zip(streamed.candidates, threaded.candidates):
        assert a.delta_log_evidence == pytest.approx(b.delta_log_evidence, rel=1e-9, abs=1e-6)
    assert [(s.added, s.effects) for s in streamed.ladder] == [(s.added, s.effects) for s in threaded.ladder]
    # partial reports: the first names every candidate as pending and says nothing is known yet
    assert partial[0].pending and set(partial[0].pending) == {c.effect for c in threaded.candidates}
    assert partial[0].missing is None and partial[0].verdict.startswith("ranking the candidates")
    assert [len(p.pending) for p in partial] == sorted((len(p.pending) for p in partial), reverse=True)
    assert not partial[-1].pending and partial[-1].missing == "tip_mass" and not partial[-1].complete


def test_a_bad_base_model_stops_the_stream_with_its_error():
    """A request's failure is the stream's to judge: the base fit's is raised from the stream."""
    from beam.errors import BeamInputError

    record = read_measurement(RECORD)
    stream = diagnosis_stream(Engine(), record, CalibrationSpec(window=(0.0, 99.0), modes=MODES))
    assert isinstance(next(stream), Step)
    request = next(stream)
    assert isinstance(request, BaseRequest) and next(stream) is WAIT
    done = run_request(request, record)
    assert isinstance(done.value, BeamInputError)  # run_request hands the failure over as the value
    with pytest.raises(BeamInputError):
        stream.send(done)


def test_the_likelihood_reaches_every_fit_of_a_diagnosis():
    """The spec's likelihood is the base fit's and every candidate's (the stream's requests), and the
    ranking's threaded fitter calibrates with it."""
    from beam.discovery.ranking import thread_fitter
    from beam.discovery.stream import FitRequest

    record = read_measurement(RECORD)
    spec = CalibrationSpec(window=WINDOW, modes=MODES, likelihood="ar1")
    engine = Engine()
    stream = diagnosis_stream(engine, record, spec)
    base, fits = None, []
    event = next(stream)
    while not (fits and event is WAIT):
        if isinstance(event, BaseRequest):
            base = event
        elif isinstance(event, FitRequest):
            fits.append(event)
        if event is WAIT:
            event = stream.send(run_request(base, record, engine))
            continue
        event = next(stream)
    stream.close()
    assert base.spec.likelihood == "ar1" and fits and all(f.spec.likelihood == "ar1" for f in fits)
    (fitted,) = thread_fitter(record, spec)([("air_damping", "kelvin_voigt", "tip_mass")])
    assert fitted.setup.likelihood == "ar1" and "ar1_coefficient" in fitted.laplace.map.values
