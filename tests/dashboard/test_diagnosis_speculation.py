"""The dashboard's diagnosis on two worker processes: the climb's fits start while the last
candidates' fits end (speculative climb), and what the climb reports is what the previews of
those models give on their own (one engine)."""

from __future__ import annotations

import numpy as np
import pytest
import recorder

from beam.calibration import CalibrationSpec, calibration_preview
from beam.discovery import FitRequest
from dashboard.jobs import diagnosis as jobs
from dashboard.jobs.beam import CalibrationKey, load_bundled, record_key
from dashboard.runtime import scheduler as sch

BASE = ("air_damping", "kelvin_voigt")


@pytest.fixture(scope="module")
def proc_pool():
    pool = sch.RunPool(max_workers=2, idle_timeout_s=5.0, processes=True, name="test-diagnosis")
    pool.start_processes()
    yield pool
    pool.shutdown(wait=True)


def test_the_climb_starts_before_the_ranking_ends_and_keeps_its_answer(proc_pool, monkeypatch):
    """lab_run_1, 0-1.05 s, 7 modes: patch stiffening is missing, then patch damping on top of it
    (README, "Diagnosing missing physics"). Five candidates on two processes: when the fourth
    ends, one process has nothing left to rank and takes a climb fit on top of the leader."""
    asked: list[tuple[tuple[str, ...], int]] = []  # (effects, candidates' fits ended when asked)
    ended: list = []
    submit, next_ = jobs.DiagnosisFits.submit, jobs.DiagnosisFits.next

    def candidate(request) -> bool:
        return isinstance(request, FitRequest) and request.search and len(request.effects) == len(BASE) + 1

    def recording_submit(self, request, **kw):
        if isinstance(request, FitRequest) and not self.asked(request):
            asked.append((tuple(request.effects), sum(1 for r in ended if candidate(r))))
        return submit(self, request, **kw)

    def recording_next(self):
        request, value = next_(self)
        ended.append(request)
        return request, value

    monkeypatch.setattr(jobs.DiagnosisFits, "submit", recording_submit)
    monkeypatch.setattr(jobs.DiagnosisFits, "next", recording_next)
    measurement = load_bundled("lab_run_1")
    key = CalibrationKey(record_key(measurement), CalibrationSpec(window=(0.0, 1.05), effects=BASE, modes=7, likelihood="iid"))
    slot, rec = recorder.make_slot(proc_pool, debounce_s=0.0, progress_interval_s=0.0)
    rid = slot.request(lambda: jobs.diagnosis_run(key, measurement, use_cache=False))
    assert slot.wait(300)
    diagnosis = rec.of(rid)[-1].value
    assert rec.of(rid)[-1].kind == "final"
    assert diagnosis.missing == "patch_stiffening" and diagnosis.climbed == ["patch_damping"], diagnosis.verdict
    # the verdict's noise floor is the beam view's (one floor per record)
    from dashboard.outputs.beam import noise_floor_m
    assert diagnosis.remaining.noise_floor.sd == noise_floor_m(diagnosis.base.setup.measurement)

    n_candidates = len(diagnosis.candidates)
    climb = [(effects, n) for effects, n in asked if len(effects) == len(BASE) + 2]
    assert {effects for effects, _ in climb} == {
        tuple(e for e in jobs.EFFECTS if e in {*BASE, "patch_stiffening", c})
        for c in ("tip_mass", "clamp_compliance", "patch_damping", "tip_cubic_spring")}
    assert any(n < n_candidates for _, n in climb), asked  # asked while a candidate's fit still ran

    # the rung the climb reports is the preview of that model, computed here from nothing
    rung = (*BASE, "patch_stiffening", "patch_damping")
    maps = {tuple(effects): found for effects, found in diagnosis.known_maps}
    direct = calibration_preview(measurement, window=key.spec.window, effects=rung, modes=key.spec.modes)
    assert np.isclose(maps[rung].log_posterior, direct.laplace.map.log_posterior, rtol=0, atol=1e-6)
    for name, value in direct.laplace.map.values.items():
        assert np.isclose(maps[rung].values[name], value, rtol=1e-6, atol=0.0), name
