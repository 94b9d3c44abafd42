"""Session state: one :class:`SessionState` per browser session, the views' only way to ``beam``.

Param only (no panel import), so it is tested without a server or a browser. The app gives it
a ``dispatch`` function that moves updates from worker threads onto the session's event loop
(:func:`dashboard.app.session_dispatch`); without one, updates are applied on the worker
thread, which is what the unit tests use.

Layout
------
:class:`SessionState`
    One sub-state per view: ``toy`` (:class:`ToyState`), ``beam`` and ``diagnosis``
    (:mod:`dashboard.state.beam`), ``study``, ``record``, ``joint``. Each activity of theirs that
    runs a job is a :class:`~dashboard.state.run.Run`; the session gives each run its own slot of
    the process-wide :class:`~dashboard.runtime.scheduler.RunPool` (:meth:`SessionState.attach`:
    a new request cancels only its own activity's) and closes them all when the page closes.
:class:`ToyState`
    Inputs of the toy scenario (parameters with units in their labels, from which the view
    builds its widgets) and outputs: the result shown (preview, then intermediate MCMC
    results, then the final posterior), the pinned result for comparison, the window sweep
    (its own run). A failed request sets its run's ``error`` and keeps the previous result.
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
from dashboard.state.joint import JointState
from dashboard.state.record import RecordState
from dashboard.state.run import Pins, Run, RunOwner, Words
from dashboard.state.study import StudyState, study_pool

__all__ = ["LANDING_SEED", "LIKELIHOOD_LABELS", "SessionState", "ToyState"]

#: Likelihood choices as shown to the user.
LIKELIHOOD_LABELS = {"i.i.d. Gaussian": "iid", "AR(1) correlated": "ar1"}
#: Seconds between two progress updates of a run: each one redraws a status line and a bar on
#: the server's event loop, so with eight sessions sampling at once 0.2 s meant 40 a second.
PROGRESS_INTERVAL_S = 0.4
#: Seed the toy tab opens with. Criterion (checked by tests/test_toy_lessons.py): of seeds 0–9 of
#: the default scenario (δ = 0, window 5 s, full MCMC), the one whose held-out coverage of the 95 %
#: prediction band is closest to 95 % with every true parameter inside its 95 % interval.
#: Measured: seed 7, coverage 95.7 % (seed 0, the library's default, gave 82.3 % with f outside its
#: interval, the worst of the ten).
LANDING_SEED = 7
#: How the toy's runs read (a partial result comes while the sampler runs; the decimals of the
#: final's seconds are read by the benchmark, ``tests/benchmarks/bench_dashboard.py``).
TOY_WORDS = Words(partial="sampling", ready="{message}: ready in {seconds:.2f} s", failed="could not run this scenario.")
SWEEP_WORDS = Words(progress="running", partial="running", ready="{message}: done in {seconds:.1f} s",
                    failed="window sweep failed.")
_INPUTS = ("window_s", "discrepancy", "kind", "noise_sd", "horizon_s", "likelihood", "seed")


class ToyState(RunOwner, Pins, param.Parameterized):
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
    run = param.ClassSelector(class_=Run, constant=True, doc="The calibration of the current scenario.")
    sweep_run = param.ClassSelector(class_=Run, constant=True, doc="The window sweep of the shown scenario.")
    result = param.ClassSelector(class_=ToyResult, default=None, allow_None=True, constant=True,
                                 doc="ToyResult shown: preview, partial or final.")
    final = param.ClassSelector(class_=ToyResult, default=None, allow_None=True, constant=True,
                                doc="Latest final ToyResult (with posterior).")
    pinned = param.ClassSelector(class_=ToyResult, default=None, allow_None=True, constant=True,
                                 doc="ToyResult kept for comparison.")
    sweep = param.List(None, item_type=dict, allow_None=True, constant=True,
                       doc="Window sweep rows (dicts of window, RMSE and coverage) of the shown scenario.")

    def __init__(self, **params) -> None:
        super().__init__(**params)
        with editing(self):
            self.run = Run("Toy calibration", words=TOY_WORDS, show=self._show)
            self.sweep_run = Run("Window sweep", words=SWEEP_WORDS, show=self._show_sweep)
        self._sweep_key: ToyScenario | None = None

    @property
    def sweep_status(self) -> str:
        """What the window sweep is doing (its run's status)."""
        return self.sweep_run.status

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
        return self.run.request(bind(toy_run, self.scenario()), debounce_s=None if debounce else 0.0,
                                status="new inputs: calibrating")

    # -- updates from the scheduler ------------------------------------------------------------
    def _show(self, update: sch.Update) -> None:
        """The toy run's results: preview, partial, final (then the sweep of its scenario)."""
        if update.kind in ("preview", "partial", "final"):
            with editing(self):
                self.param.update(result=update.value, **({"final": update.value} if update.kind == "final" else {}))
        if update.kind == "final":
            self._request_sweep(update.value.scenario)

    def _request_sweep(self, scenario: ToyScenario) -> None:
        if self._sweep_key == sweep_key(scenario):
            return
        self._sweep_key = sweep_key(scenario)
        with editing(self):  # the old sweep belongs to another scenario: do not show it
            self.sweep = None
        self.sweep_run.request(bind(toy_sweep, scenario), status="computing the window sweep")

    def _show_sweep(self, update: sch.Update) -> dict | None:
        """The sweep's rows once all windows are done (redrawing the sweep per window would load the
        event loop: the partial stages change the status only)."""
        if update.kind == "final":
            with editing(self):
                self.sweep = update.value
        if update.kind == "error":
            return {"status": f"window sweep failed: {user_message(update.message)}"}
        return None

    def describe(self) -> dict:
        """Plain summary of inputs and status (for logs and tests)."""
        return {"scenario": asdict(self.scenario()), **self.run.describe()}


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
        self._runs: dict[str, Run] = {}
        toy = ToyState(**(toy_inputs or {}))
        beam = BeamState(**(beam_inputs or {}))
        diagnosis = DiagnosisState(beam=beam)
        with editing(self):
            self.param.update(toy=toy, beam=beam, diagnosis=diagnosis)
        self.study = StudyState(beam=beam)  # the window study (dashboard.state.study)
        self.record = RecordState(beam=beam)  # the "Your record" view's state
        self.joint = JointState(beam=beam)  # the "Several records" view's state (dashboard.state.joint)
        self.attach("toy", toy.run)
        self.attach("toy-sweep", toy.sweep_run, debounce_s=0.0)
        self.attach("beam", beam.run)
        self.attach("diagnosis", diagnosis.run, debounce_s=0.0)
        self.attach("study", self.study.run, debounce_s=0.0, pool=study_pool())
        self.attach("record-read", self.record.run, debounce_s=0.0)
        self.attach("record-beam", self.record.beam_run)
        self.attach("joint", self.joint.run, debounce_s=0.0)
        self.attach("joint-diagnosis", self.joint.diag_run, debounce_s=0.0)
        self.record.joint = self.joint  # a record of several taps is calibrated there, every tap together

    def attach(self, name: str, run: Run, *, debounce_s: float | None = None, pool: sch.RunPool | None = None) -> Run:
        """Give ``run`` a new run slot named ``name`` (one per activity: a new request cancels only its
        own), on ``pool`` (default the session's); returns the run."""
        if name in self._runs:
            raise ValueError(f"run slot {name!r} exists already")
        run.attach(sch.RunSlot(run.on_update, pool=pool or self._pool, dispatch=self._dispatch,
                               debounce_s=self._debounce if debounce_s is None else debounce_s,
                               progress_interval_s=PROGRESS_INTERVAL_S, name=name))
        self._runs[name] = run
        return run

    @property
    def pool(self) -> sch.RunPool:
        """The pool this session's jobs run on."""
        return self._pool if self._pool is not None else sch.shared_pool()

    @property
    def runs(self) -> dict[str, Run]:
        """The session's runs by slot name (in the order of the views)."""
        return dict(self._runs)

    @property
    def slots(self) -> dict[str, sch.RunSlot]:
        """The session's run slots by name."""
        return {name: run.slot for name, run in self._runs.items()}

    def wait(self, timeout: float = 30.0) -> bool:
        """Block until every run's latest request has finished (tests and scripts)."""
        return all(run.wait(timeout) for run in self._runs.values())

    def close(self) -> None:
        """Cancel every run and refuse new requests (call when the session ends)."""
        for run in self._runs.values():
            run.close()
