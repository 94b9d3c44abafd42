"""Session sub-state of the "Several records" view: :class:`JointState`.

Param only (no panel import), tested without a server or a browser. Several records of one beam
(bundled lab runs, the shipped real runs, the session's uploads) are chosen together; *Calibrate
jointly* (:meth:`JointState.calibrate`) runs :func:`dashboard.jobs.joint.joint_run` (its run:
``run``), *Diagnose jointly* (:meth:`JointState.diagnose`)
:func:`dashboard.jobs.joint.joint_diagnosis_run` (``diag_run``). Nothing runs on an input
change: a joint calibration costs each record's own calibration first. A failed request sets
its run's ``error`` and keeps the result shown.
"""

from __future__ import annotations

from functools import partial as bind

import param

from beam.calibration.modes import MAX_MODES
from beam.discovery.joint import JointDiagnosis
from beam.calibration import CalibrationSpec
from beam.physics.effects import EFFECTS, modal_damping, sensor_mass
from dashboard.jobs.beam import effect_label, record_key
from dashboard.jobs.joint import JointKey, JointOutcome, available_records, joint_diagnosis_run, joint_run, load_record
from dashboard.runtime import scheduler as sch
from dashboard.state.beam import BeamState
from dashboard.state.editing import editing
from dashboard.state.run import Run, RunOwner, Words

__all__ = ["DEFAULT_EFFECTS", "DEFAULT_RECORDS", "SAMPLING", "JointState"]

#: The records chosen at first: the two real runs of the aluminium strip shipped with the app
#: (the same strip, length and sensor position: the joint intervals are narrower than either's).
DEFAULT_RECORDS = ("adxl_50cm_114655", "adxl_50cm_114759")
#: The model at first: a damping ratio per mode and the sensor's mass (what the real strip needs,
#: docs/joint-calibration.md).
DEFAULT_EFFECTS = (modal_damping.EFFECT.id, sensor_mass.EFFECT.id)
#: Sampling choices as shown: the Laplace preview only, or emcee for that many ensemble steps.
SAMPLING = {"Laplace only (seconds)": 0, "MCMC, 300 steps (~1 min)": 300, "MCMC, 1000 steps (minutes)": 1000}


class JointState(RunOwner, param.Parameterized):
    """Several records of one beam, calibrated and diagnosed together, for one session.

    Parameters
    ----------
    beam : BeamState
        The session's beam calibration state (its uploads are offered here too).
    """

    records = param.ListSelector(default=[], objects=[], label="Records of one beam",
                                 doc="Dataset ids, in the order chosen (record 1, 2, ...).")
    window_s = param.Range(default=(0.0, 2.0), bounds=(0.0, 30.0), label="Calibration window (s), on every record",
                           doc="Every record is calibrated on this part; the rest of each is held out.")
    modes = param.Integer(2, bounds=(1, MAX_MODES), label="Number of modes (1)", doc="Modes kept on every record.")
    effects = param.ListSelector(default=list(DEFAULT_EFFECTS), objects=list(EFFECTS), label="Effects in the model")
    per_record = param.String("", label="Per record (parameter or effect names, comma-separated; e.g. clamp_stiffness)",
                              doc="Physical parameters given a value per record (the others are shared).")
    sampling = param.Selector(default=0, objects=SAMPLING, label="Joint posterior",
                              doc="Laplace approximation at the joint MAP, or MCMC over the joint posterior.")
    seed = param.Integer(0, bounds=(0, None), precedence=-1, label="Seed (sampler)")

    beam = param.ClassSelector(class_=BeamState, constant=True, doc="The session's beam calibration state.")
    run = param.ClassSelector(class_=Run, constant=True, doc="The joint calibration.")
    diag_run = param.ClassSelector(class_=Run, constant=True, doc="The joint diagnosis.")
    result = param.ClassSelector(class_=JointOutcome, default=None, allow_None=True, constant=True,
                                 doc="The joint calibration shown (preview, then final).")
    diagnosis = param.ClassSelector(class_=JointDiagnosis, default=None, allow_None=True, constant=True,
                                    doc="The joint diagnosis shown (partial while candidates are judged).")

    def __init__(self, **params) -> None:
        super().__init__(**params)
        with editing(self):
            self.run = Run("Joint calibration", show=lambda update: self._show(update, "result"))
            self.diag_run = Run("Joint diagnosis", words=Words(kept=" The previous diagnosis is still shown."),
                                show=lambda update: self._show(update, "diagnosis"))
        self.refresh_records()
        if not self.records:
            self.records = [n for n in DEFAULT_RECORDS if n in self.param.records.objects]
        if self.beam is not None:
            self.beam.param.watch(lambda event: self.refresh_records(), "uploads")

    # -- records ---------------------------------------------------------------------------------
    def uploads(self) -> dict:
        return dict(self.beam.uploads) if self.beam is not None else {}

    def record_options(self) -> dict[str, str]:
        """``{label: dataset id}`` of every record offered (bundled, shipped real runs, uploads)."""
        return {label: name for name, label in available_records(self.uploads()).items()}

    def refresh_records(self) -> None:
        """Offer the session's current uploads too (called when one is added)."""
        names = list(available_records(self.uploads()))
        self.param.records.objects = names
        kept = [n for n in self.records if n in names]
        if kept != list(self.records):
            self.records = kept

    @staticmethod
    def effect_options() -> dict[str, str]:
        """``{label with units: effect id}`` for the check-boxes."""
        return {effect_label(e): e for e in EFFECTS}

    def spec(self) -> CalibrationSpec:
        """The :class:`~beam.calibration.CalibrationSpec` of every record (window, effects, modes, the
        joint MCMC's steps and seed)."""
        lo, hi = (round(float(v), 4) for v in self.window_s)
        return CalibrationSpec.of(window=(lo, hi), effects=tuple(e for e in EFFECTS if e in set(self.effects)),
                                  modes=int(self.modes), steps=int(self.sampling) or None, seed=int(self.seed))

    def key(self, candidates: tuple[str, ...] = ()) -> JointKey:
        """The :class:`~dashboard.jobs.joint.JointKey` of the current inputs (``candidates``: those a joint
        diagnosis tries, empty for every one)."""
        return JointKey(tuple(record_key(m) for m in self.measurements()), self.spec(), self.per_record.strip(),
                        tuple(candidates))

    def measurements(self) -> list:
        uploads = self.uploads()
        return [load_record(n, uploads) for n in self.records]

    def _subject(self) -> str:
        return ", ".join(self.beam.record_name(n) if self.beam is not None else n for n in self.records)

    # -- requests --------------------------------------------------------------------------------
    def calibrate(self) -> int:
        """Calibrate the chosen records jointly (each alone first); returns the request id."""
        measurements = self.measurements()
        return self.run.request(bind(joint_run, self.key(), measurements), subject=self._subject(),
                                status=f"calibrating {len(measurements)} records jointly")

    def diagnose(self, candidates: tuple[str, ...] = ()) -> int:
        """Rank the candidate effects (default: every one the records can show) on the chosen
        records jointly; returns the request id."""
        measurements = self.measurements()
        return self.diag_run.request(bind(joint_diagnosis_run, self.key(candidates), measurements),
                                     subject=self._subject(),
                                     status=f"judging the candidate effects on {len(measurements)} records jointly")

    def cancel(self) -> None:
        """Stop both jobs; what is shown stays."""
        for run in (self.run, self.diag_run):
            run.cancel("cancelled; the previous result is kept")

    # -- updates from the scheduler ------------------------------------------------------------
    def _show(self, update: sch.Update, name: str) -> None:
        """A result of a job (``name``: ``result`` or ``diagnosis``); an error keeps the one shown."""
        if update.kind in ("preview", "partial", "final"):
            with editing(self):
                setattr(self, name, update.value)

    def close(self) -> None:
        """Cancel both jobs (the session ends)."""
        for run in (self.run, self.diag_run):
            run.close()
