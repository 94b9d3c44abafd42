"""Session state: one :class:`SessionState` per browser session, the views' only way to ``beam``.

Param only (no panel import), so it is tested without a server or a browser. The app gives it
a ``dispatch`` function that moves updates from worker threads onto the session's event loop
(:func:`dashboard.app.session_dispatch`); without one, updates are applied on the worker
thread, which is what the unit tests use.

Layout
------
:class:`SessionState`
    Owns the run slots (one per activity; all share the process-wide
    :class:`~dashboard.runtime.scheduler.RunPool`) and one sub-state per view: ``toy``
    (:class:`ToyState`), ``beam`` and ``diagnosis`` (:mod:`dashboard.state.beam`).
:class:`ToyState`
    Inputs of the toy scenario (parameters with units in their labels, from which the view
    builds its widgets) and outputs: the result shown (preview, then intermediate MCMC
    results, then the final posterior), the pinned result for comparison, the window sweep,
    status, progress and error message. A failed request sets ``error`` and keeps the previous
    result.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict
from functools import partial as bind

import param

from beam.toy import KINDS, ToyResult, ToyScenario
from dashboard.jobs.toy import sweep_key, toy_run, toy_sweep
from dashboard.outputs.toy import user_message
from dashboard.runtime import scheduler as sch
from dashboard.state.beam import BeamState, DiagnosisState
from dashboard.state.editing import editing
from dashboard.state.study import StudyState
from dashboard.state.record import RecordState
from dashboard.state.joint import JointState

__all__ = ["LANDING_SEED", "LIKELIHOOD_LABELS", "SessionState", "ToyState"]

#: Likelihood choices as shown to the user.
LIKELIHOOD_LABELS = {"i.i.d. Gaussian": "iid", "AR(1) correlated": "ar1"}
STAGES = ("idle", "queued", "preview", "sampling", "final", "error")
#: Seconds between two progress updates of a run: each one redraws a status line and a bar on
#: the server's event loop, so with eight sessions sampling at once 0.2 s meant 40 a second.
PROGRESS_INTERVAL_S = 0.4
#: Seed the toy tab opens with. Criterion (checked by tests/test_toy_lessons.py): of seeds 0–9 of
#: the default scenario (δ = 0, window 5 s, full MCMC), the one whose held-out coverage of the 95 %
#: prediction band is closest to 95 % with every true parameter inside its 95 % interval.
#: Measured: seed 7, coverage 95.7 % (seed 0, the library's default, gave 82.3 % with f outside its
#: interval, the worst of the ten).
LANDING_SEED = 7
_INPUTS = ("window_s", "discrepancy", "kind", "noise_sd", "horizon_s", "likelihood", "seed")


class ToyState(param.Parameterized):
    """Inputs and results of the toy periodic model for one session.

    Changing any input parameter requests a new run (debounced); :meth:`request` does it
    explicitly (e.g. on page load).
    """

    # -- inputs (the defaults are those of :class:`beam.toy.ToyScenario`, but the seed) -------------------------
    window_s = param.Number(5.0, bounds=(1.0, 15.0), step=0.5, label="Calibration window (s)",
                            doc="Calibration on [0, window]; the rest of the record is held out.")
    discrepancy = param.Number(0.0, bounds=(0.0, 1.0), step=0.05, label="Discrepancy amplitude δ (du)",
                               doc="Amplitude of the physics the model misses, in data units.")
    kind = param.Selector(default="harmonic", objects=list(KINDS), label="Discrepancy kind",
                          doc="harmonic: 2f distortion; tone: unmodelled 1.37 f mode; drift: baseline drift δ t / 5 s.")
    noise_sd = param.Selector(default=0.1, objects=[0.02, 0.05, 0.1, 0.2, 0.3, 0.5], label="Noise sd (du)",
                              doc="Standard deviation of the i.i.d. measurement noise.")
    horizon_s = param.Selector(default=20.0, objects=[10.0, 15.0, 20.0, 30.0, 40.0], label="Horizon (s)",
                               doc="End of the record; (window, horizon] is held out.")
    likelihood = param.Selector(default="iid", objects=LIKELIHOOD_LABELS, label="Likelihood (noise model)",
                                doc="Noise model of the calibration: i.i.d. = independent Gaussian noise; AR(1) = each noise "
                                    "value correlated with the previous one (can absorb a smooth misfit).")
    seed = param.Selector(default=LANDING_SEED, objects=list(range(10)), label="Seed (noise realisation)",
                          doc="Seed of the noise and of the sampler.")
    target_ess = param.Number(1000.0, bounds=(100.0, 10000.0), label="Target ESS (per parameter)", precedence=-1)

    # -- outputs ---------------------------------------------------------------------------------
    stage = param.Selector(default="idle", objects=list(STAGES), constant=True, doc="Where the latest request is.")
    status = param.String("", constant=True, doc="One-line status for the user.")
    progress = param.Number(0.0, bounds=(0.0, 1.0), constant=True, doc="Fraction of the MCMC done.")
    error = param.String("", constant=True, doc="Readable message of the latest failed request, or ''.")
    result = param.ClassSelector(class_=ToyResult, default=None, allow_None=True, constant=True,
                                 doc="ToyResult shown: preview, partial or final.")
    final = param.ClassSelector(class_=ToyResult, default=None, allow_None=True, constant=True,
                                doc="Latest final ToyResult (with posterior).")
    pinned = param.ClassSelector(class_=ToyResult, default=None, allow_None=True, constant=True,
                                 doc="ToyResult kept for comparison.")
    sweep = param.List(None, item_type=dict, allow_None=True, constant=True,
                       doc="Window sweep rows (dicts of window, RMSE and coverage) of the shown scenario.")
    sweep_status = param.String("", constant=True)
    requested = param.Integer(0, constant=True, doc="Id of the latest request.")
    shown = param.Integer(0, constant=True, doc="Id of the request the shown result belongs to.")

    def __init__(self, run_slot: sch.RunSlot | None = None, sweep_slot: sch.RunSlot | None = None, **params) -> None:
        super().__init__(**params)
        self._run_slot = run_slot
        self._sweep_slot = sweep_slot
        self._timings: dict[int, dict[str, float]] = {}
        self._sweep_key: ToyScenario | None = None

    def attach(self, run_slot: sch.RunSlot, sweep_slot: sch.RunSlot) -> None:
        """Give the state its run slots (done by :class:`SessionState`)."""
        self._run_slot, self._sweep_slot = run_slot, sweep_slot

    # -- inputs -> requests ----------------------------------------------------------------------
    def scenario(self) -> ToyScenario:
        """The :class:`~beam.toy.ToyScenario` of the current inputs (not validated)."""
        return ToyScenario(
            window_s=float(self.window_s),
            discrepancy=float(self.discrepancy),
            kind=str(self.kind),
            noise_sd=float(self.noise_sd),
            horizon_s=float(self.horizon_s),
            likelihood=str(self.likelihood),
            seed=int(self.seed),
            target_ess=float(self.target_ess),
        )

    @param.depends(*_INPUTS, "target_ess", watch=True)
    def _inputs_changed(self) -> None:
        self.request()

    def request(self, *, debounce: bool = True) -> int:
        """Run the current scenario (preview, MCMC, then the sweep); returns the request id."""
        scenario = self.scenario()
        rid = self._run_slot.request(bind(toy_run, scenario), debounce_s=None if debounce else 0.0)
        with editing(self):
            self.param.update(requested=rid, stage="queued", progress=0.0, status="new inputs: calibrating")
        return rid

    def timings(self, request: int) -> dict[str, float]:
        """Seconds from request to each published stage, e.g. ``{"preview": 0.2, "final": 0.9}``."""
        return dict(self._timings.get(request, {}))

    # -- updates from the scheduler ------------------------------------------------------------
    def on_run_update(self, update: sch.Update) -> None:
        """The run slot's callback: show an update of this state's latest request."""
        times = self._timings.setdefault(update.request, {})
        times.setdefault(update.kind, update.elapsed_s)
        if len(self._timings) > 50:
            self._timings.pop(min(self._timings))
        with editing(self):
            if update.kind == "error":
                kept = " The previous result is still shown." if self.result is not None else ""
                self.param.update(stage="error", error=user_message(update.message), progress=0.0,
                                  status=f"could not run this scenario.{kept}")
            elif update.kind == "progress":
                self.param.update(stage="sampling", progress=update.fraction or 0.0, status=update.message)
            elif update.kind in ("preview", "partial"):
                self.param.update(stage="preview" if update.kind == "preview" else "sampling", error="",
                                  result=update.value, shown=update.request,
                                  progress=update.fraction or 0.0, status=update.message)
            else:  # final
                self.param.update(stage="final", error="", result=update.value, final=update.value,
                                  shown=update.request, progress=1.0,
                                  status=f"{update.message}: ready in {update.elapsed_s:.2f} s")
        if update.kind == "final":
            self._request_sweep(update.value.scenario)

    def _request_sweep(self, scenario: ToyScenario) -> None:
        if self._sweep_key == sweep_key(scenario):
            return
        self._sweep_key = sweep_key(scenario)
        self._sweep_slot.request(bind(toy_sweep, scenario), debounce_s=0.0)
        with editing(self):  # the old sweep belongs to another scenario: do not show it
            self.param.update(sweep=None, sweep_status="computing the window sweep")

    def on_sweep_update(self, update: sch.Update) -> None:
        """The sweep slot's callback: show an update of the sweep."""
        with editing(self):
            if update.kind == "error":
                self.param.update(sweep_status=f"window sweep failed: {user_message(update.message)}")
            elif update.kind == "partial":  # status only: redrawing the sweep per window would load the event loop
                self.param.update(sweep_status=update.message)
            elif update.kind == "final":
                self.param.update(sweep=update.value, sweep_status=update.message)

    # -- compare ---------------------------------------------------------------------------------
    def pin(self) -> None:
        """Keep the shown result for comparison with the next ones."""
        if self.result is not None:
            with editing(self):
                self.pinned = self.result

    def unpin(self) -> None:
        """Drop the pinned result."""
        with editing(self):
            self.pinned = None

    def describe(self) -> dict:
        """Plain summary of inputs and status (for logs and tests)."""
        return {"scenario": asdict(self.scenario()), "stage": self.stage, "status": self.status, "error": self.error,
                "requested": self.requested, "shown": self.shown}


class SessionState(param.Parameterized):
    """Everything one browser session holds; the only object the views use to reach ``beam``.

    Parameters
    ----------
    pool : RunPool, optional
        Where jobs run (default: the process-wide :func:`~dashboard.runtime.scheduler.shared_pool`).
    dispatch : callable, optional
        ``dispatch(fn)`` runs ``fn`` on the session's event loop; default: at once.
    debounce_s : float
        Quiet time after an input change before a run starts.
    toy_inputs : dict, optional
        Initial values of :class:`ToyState` parameters (e.g. ``{"target_ess": 300}``).
    beam_inputs : dict, optional
        Initial values of :class:`~dashboard.state.beam.BeamState` parameters.
    """

    toy = param.ClassSelector(class_=ToyState, constant=True, doc="State of the toy periodic model view.")
    beam = param.ClassSelector(class_=BeamState, constant=True, doc="State of the beam calibration view.")
    diagnosis = param.ClassSelector(class_=DiagnosisState, constant=True, doc="State of the diagnosis view.")

    def __init__(self, *, pool: sch.RunPool | None = None, dispatch: Callable | None = None,
                 debounce_s: float = 0.15, toy_inputs: dict | None = None, beam_inputs: dict | None = None,
                 **params) -> None:
        super().__init__(**params)
        self._pool, self._dispatch, self._debounce = pool, dispatch, debounce_s
        self._slots: dict[str, sch.RunSlot] = {}
        toy = ToyState(**(toy_inputs or {}))
        toy.attach(self.slot("toy", toy.on_run_update), self.slot("toy-sweep", toy.on_sweep_update, debounce_s=0.0))
        beam = BeamState(**(beam_inputs or {}))
        beam.attach(self.slot("beam", beam.on_run_update))
        diagnosis = DiagnosisState(beam=beam)
        diagnosis.attach(self.slot("diagnosis", diagnosis.on_run_update, debounce_s=0.0))
        with editing(self):
            self.param.update(toy=toy, beam=beam, diagnosis=diagnosis)
        self.study = StudyState(beam=beam, dispatch=dispatch)  # the window study (dashboard.state.study)
        self.record = RecordState.attached(self)  # the "Your record" view's state
        self.joint = JointState.attached(self)  # the "Several records" view's state (dashboard.state.joint)
        self.record.joint = self.joint  # a record of several taps is calibrated there, every tap together

    def slot(self, name: str, on_update: Callable[[sch.Update], None], *, debounce_s: float | None = None) -> sch.RunSlot:
        """A new named run slot of this session (one per activity: a new request cancels only its own)."""
        if name in self._slots:
            raise ValueError(f"run slot {name!r} exists already")
        slot = sch.RunSlot(on_update, pool=self._pool, dispatch=self._dispatch,
                           debounce_s=self._debounce if debounce_s is None else debounce_s,
                           progress_interval_s=PROGRESS_INTERVAL_S, name=name)
        self._slots[name] = slot
        return slot

    @property
    def pool(self) -> sch.RunPool:
        """The pool this session's jobs run on."""
        return self._pool if self._pool is not None else sch.shared_pool()

    @property
    def slots(self) -> dict[str, sch.RunSlot]:
        """The session's run slots by name."""
        return dict(self._slots)

    def wait(self, timeout: float = 30.0) -> bool:
        """Block until every slot's latest request has finished (tests and scripts)."""
        return all(slot.wait(timeout) for slot in self._slots.values())

    def close(self) -> None:
        """Cancel every run (call when the session ends)."""
        for slot in self._slots.values():
            slot.close()
