"""Session sub-state of the "Several records" view: :class:`JointState`.

Param only (no panel import), tested without a server or a browser. Several records of one beam
(bundled lab runs, the shipped real runs, the session's uploads) are chosen together; *Calibrate
jointly* (:meth:`JointState.calibrate`) runs :func:`dashboard.jobs.joint.joint_run` on the
``joint`` run slot, *Diagnose jointly* (:meth:`JointState.diagnose`)
:func:`dashboard.jobs.joint.joint_diagnosis_run` on ``joint-diagnosis``. Nothing runs on an input
change: a joint calibration costs each record's own calibration first. A failed request sets
``error`` (``diag_error``) and keeps the result shown.
"""

from __future__ import annotations

from dataclasses import replace
from functools import partial as bind

import param

from beam.calibration.modes import MAX_MODES
from beam.discovery.joint import JointDiagnosis
from beam.physics.effects import EFFECTS, modal_damping, sensor_mass
from dashboard.jobs.beam import effect_label
from dashboard.jobs.joint import JointKey, JointOutcome, available_records, joint_diagnosis_run, joint_run, load_record
from dashboard.outputs.toy import user_message
from dashboard.runtime import scheduler as sch
from dashboard.state.beam import BeamState
from dashboard.state.editing import editing

__all__ = ["DEFAULT_EFFECTS", "DEFAULT_RECORDS", "SAMPLING", "JointState"]

#: The records chosen at first: the two real runs of the aluminium strip shipped with the app
#: (the same strip, length and sensor position: the joint intervals are narrower than either's).
DEFAULT_RECORDS = ("adxl_50cm_114655", "adxl_50cm_114759")
#: The model at first: a damping ratio per mode and the sensor's mass (what the real strip needs,
#: docs/joint-calibration.md).
DEFAULT_EFFECTS = (modal_damping.EFFECT.id, sensor_mass.EFFECT.id)
#: Sampling choices as shown: the Laplace preview only, or emcee for that many ensemble steps.
SAMPLING = {"Laplace only (seconds)": 0, "MCMC, 300 steps (~1 min)": 300, "MCMC, 1000 steps (minutes)": 1000}
STAGES = ("idle", "queued", "preview", "sampling", "final", "error")


class JointState(param.Parameterized):
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
    stage = param.Selector(default="idle", objects=list(STAGES), constant=True)
    status = param.String("", constant=True)
    progress = param.Number(0.0, bounds=(0.0, 1.0), constant=True)
    error = param.String("", constant=True, doc="Why the latest joint calibration failed, or ''.")
    requested = param.Integer(0, constant=True)
    shown = param.Integer(0, constant=True)
    result = param.ClassSelector(class_=JointOutcome, default=None, allow_None=True, constant=True,
                                 doc="The joint calibration shown (preview, then final).")
    diag_stage = param.Selector(default="idle", objects=list(STAGES), constant=True)
    diag_status = param.String("", constant=True)
    diag_progress = param.Number(0.0, bounds=(0.0, 1.0), constant=True)
    diag_error = param.String("", constant=True, doc="Why the latest joint diagnosis failed, or ''.")
    diag_requested = param.Integer(0, constant=True)
    diag_shown = param.Integer(0, constant=True)
    diagnosis = param.ClassSelector(class_=JointDiagnosis, default=None, allow_None=True, constant=True,
                                    doc="The joint diagnosis shown (partial while candidates are judged).")

    def __init__(self, **params) -> None:
        super().__init__(**params)
        self._slot: sch.RunSlot | None = None
        self._diag_slot: sch.RunSlot | None = None
        self.refresh_records()
        if not self.records:
            self.records = [n for n in DEFAULT_RECORDS if n in self.param.records.objects]

    @classmethod
    def attached(cls, session) -> JointState:
        """A state on ``session`` (a :class:`~dashboard.state.session.SessionState`): its beam
        state's uploads, and two run slots, ``joint`` and ``joint-diagnosis``."""
        state = cls(beam=session.beam)
        state._slot = session.slot("joint", state.on_run_update, debounce_s=0.0)
        state._diag_slot = session.slot("joint-diagnosis", state.on_diagnosis_update, debounce_s=0.0)
        session.beam.param.watch(lambda event: state.refresh_records(), "uploads")
        return state

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

    def key(self) -> JointKey:
        """The :class:`~dashboard.jobs.joint.JointKey` of the current inputs."""
        lo, hi = (round(float(v), 4) for v in self.window_s)
        effects = tuple(e for e in EFFECTS if e in set(self.effects))
        return JointKey(tuple(self.records), (lo, hi), effects, int(self.modes), self.per_record.strip(),
                        int(self.sampling), int(self.seed))

    def measurements(self) -> list:
        uploads = self.uploads()
        return [load_record(n, uploads) for n in self.records]

    # -- requests --------------------------------------------------------------------------------
    def calibrate(self) -> int:
        """Calibrate the chosen records jointly (each alone first); returns the request id."""
        key = self.key()
        rid = self._slot.request(bind(joint_run, key, self.measurements()), debounce_s=0.0)
        with editing(self):
            self.param.update(requested=rid, stage="queued", progress=0.0, error="",
                              status=f"calibrating {len(key.datasets)} records jointly")
        return rid

    def diagnose(self, candidates: tuple[str, ...] = ()) -> int:
        """Rank the candidate effects (default: every one the records can show) on the chosen
        records jointly; returns the request id."""
        key = replace(self.key(), candidates=tuple(candidates))
        rid = self._diag_slot.request(bind(joint_diagnosis_run, key, self.measurements()), debounce_s=0.0)
        with editing(self):
            self.param.update(diag_requested=rid, diag_stage="queued", diag_progress=0.0, diag_error="",
                              diag_status=f"judging the candidate effects on {len(key.datasets)} records jointly")
        return rid

    def cancel(self) -> None:
        """Stop both jobs; what is shown stays."""
        for slot, prefix in ((self._slot, ""), (self._diag_slot, "diag_")):
            if getattr(self, f"{prefix}stage") in ("queued", "preview", "sampling"):
                slot.cancel()
                with editing(self):
                    self.param.update(**{f"{prefix}stage": "idle", f"{prefix}progress": 0.0,
                                         f"{prefix}status": "cancelled; the previous result is kept"})

    # -- updates from the scheduler ------------------------------------------------------------
    def on_run_update(self, update: sch.Update) -> None:
        """The ``joint`` slot's callback."""
        self._show(update, "", "result", "result")

    def on_diagnosis_update(self, update: sch.Update) -> None:
        """The ``joint-diagnosis`` slot's callback."""
        self._show(update, "diag_", "diagnosis", "diagnosis")

    def _show(self, update: sch.Update, prefix: str, value_name: str, what: str) -> None:
        """An update of a job: its stage, status, progress and error (parameters named ``prefix`` +
        those) and, for a result, the value (``value_name``); an error keeps the value shown."""
        if update.kind == "error":
            kept = f" The previous {what} is still shown." if getattr(self, value_name) is not None else ""
            values = {"stage": "error", "error": user_message(update.message), "progress": 0.0, "status": f"failed.{kept}"}
        elif update.kind == "progress":
            values = {"stage": "sampling", "progress": update.fraction or 0.0, "status": update.message}
        else:
            final = update.kind == "final"
            values = {"stage": "final" if final else "preview", "error": "", "shown": update.request,
                      "progress": 1.0 if final else update.fraction or 0.0,
                      "status": f"{update.message}: ready in {update.elapsed_s:.1f} s" if final else update.message}
        with editing(self):
            self.param.update(**{prefix + k: v for k, v in values.items()},
                              **({value_name: update.value} if "shown" in values else {}))

    def close(self) -> None:
        """Cancel both jobs (the session ends)."""
        for slot in (self._slot, self._diag_slot):
            if slot is not None:
                slot.cancel()
