"""Session sub-state of the "Window study" view: a calibration-window study run on Dask, cell by cell.

Param only (no panel import), tested without a server or a browser. :class:`StudyState` holds
the inputs (dataset, windows in ``beam study --windows`` syntax, effect sets, likelihoods) and the
cells finished so far; :meth:`StudyState.run` lays the cells out with the library
(:func:`beam.study.study_cells`, the cells of ``beam study``) and runs them with
:func:`beam.study.engine.stream_cells` on the server's one Dask client (:func:`shared_client`:
the scheduler named by ``DASK_SCHEDULER_ADDRESS`` when the server was started, else a local
cluster, started by the first study and shared by every session). Each finished cell is
published through the session's dispatch, on the event loop, as it comes back.

The job that waits for the cells runs on a thread of :func:`study_pool` (not on the shared pool
of the interactive jobs: a study waits minutes, and would hold one of its threads all that
time). Cells already computed by this server process (same record content, options and seed)
are shown at once (:data:`MAX_REMEMBERED`).
"""

from __future__ import annotations

import atexit
import threading
from collections import OrderedDict
from collections.abc import Callable, Iterator
from functools import partial as bind

import param

from beam.calibration import CalibrationSpec
from beam.errors import BeamInputError
from beam.io.measurement import Measurement
from beam.physics.effects import EFFECTS, parse_effects
from beam.study import StudyCell, parse_effect_sets, parse_windows, study_cells
from beam.study.cells import record_fingerprint
from beam.study.engine import connect, disconnect, scheduler_address, stream_cells
from dashboard.jobs.beam import bundled_datasets, effect_label, load_bundled
from dashboard.outputs.toy import user_message
from dashboard.runtime import scheduler as sch
from dashboard.state.beam import DATASET_DEFAULTS, BeamState
from dashboard.state.editing import editing
from dashboard.state.run import Run, RunOwner, Words

__all__ = ["LIKELIHOOD_LABELS", "MAX_REMEMBERED", "StudyState", "default_windows_spec", "shared_client",
           "study_pool"]

#: Likelihoods as the check-boxes show them.
LIKELIHOOD_LABELS = {"i.i.d. Gaussian": "iid", "AR(1) correlated": "ar1"}
#: How a study's run reads.
STUDY_WORDS = Words(progress="running", partial="running", ready="{message} in {seconds:.0f} s",
                    failed="the study stopped; the cells finished are still shown", kept="")
#: Finished cells this server process keeps (about 60 kB each): a study run again shows them at once.
MAX_REMEMBERED = 2000
#: Threads of :func:`study_pool`: studies of this many sessions wait for their cells at once (the
#: cells themselves queue on the Dask cluster).
STUDY_THREADS = 8
#: The default windows: this many, from the record's start, each ``0.1`` of the record longer.
DEFAULT_COUNT = 6

_client = None
_client_lock = threading.Lock()
_pool: sch.RunPool | None = None
_pool_lock = threading.Lock()
_remembered: OrderedDict[StudyCell, dict] = OrderedDict()
_remembered_lock = threading.Lock()


def study_pool() -> sch.RunPool:
    """The process-wide thread pool the study jobs wait on (threads only: the work is on Dask)."""
    global _pool
    with _pool_lock:
        if _pool is None:
            _pool = sch.RunPool(max_workers=STUDY_THREADS, name="beam-study")
        return _pool


def shared_client():
    """The server's Dask client, connected on first use (blocking: call it off the event loop).

    The scheduler of ``DASK_SCHEDULER_ADDRESS`` when set, else a local cluster of one
    single-threaded worker process per core (:func:`beam.study.engine.connect`); closed when the
    server process exits. A client whose scheduler went away is replaced on the next call.
    """
    global _client
    with _client_lock:
        if _client is not None and _client.status not in ("running", "connecting"):
            disconnect(_client)
            _client = None
        if _client is None:
            _client = connect(scheduler_address(None))
            atexit.register(disconnect, _client)
        return _client


def _remember(cell: StudyCell, outcome: dict) -> None:
    if outcome["row"].get("error"):
        return  # a failed cell is tried again
    with _remembered_lock:
        _remembered[cell] = {k: outcome[k] for k in ("row", "extra")}
        while len(_remembered) > MAX_REMEMBERED:
            _remembered.popitem(last=False)


def _recalled(cell: StudyCell) -> dict | None:
    with _remembered_lock:
        hit = _remembered.get(cell)
        return None if hit is None else {**hit, "task": {}, "draws": {}}


def default_windows_spec(measurement: Measurement) -> str:
    """A growing family from the record's start, as ``beam study --windows`` reads it: :data:`DEFAULT_COUNT`
    windows, each a tenth of the record (rounded to two significant digits, s) longer than the last,
    so every window leaves at least 40 % of the record held out (the CLI's default family, rounded)."""
    t = measurement.time_s
    start, duration = float(t[0]), float(t[-1] - t[0])
    step = float(f"{duration / 10:.2g}")
    end = start + DEFAULT_COUNT * step
    return f"grow:{start:g}:{step:g}:{float(f'{end:.6g}'):g}"


def study_job(records: dict[str, Measurement], cells: list[tuple[int, StudyCell]], stop: Callable[[], bool],
              connect_client: Callable[[], object] = shared_client) -> Iterator[sch.Stage]:
    """The cells of a study, each as a ``partial`` stage as it finishes, then ``final``.

    ``records`` maps a record's fingerprint to it. A ``partial`` stage's value is an entry
    ``{"position", "index", "cell", "row", "extra"}`` (``position`` in ``cells``, ``index`` the
    window's position; ``row`` the ``beam study --json`` cell, with its ``error`` when it failed).
    Cells remembered by this process come first; ``stop()`` true ends the study (its unfinished
    cells are cancelled on the cluster).
    """
    total, done = len(cells), 0
    positions = {cell: p for p, (_, cell) in enumerate(cells)}
    todo = []
    for position, (index, cell) in enumerate(cells):
        hit = _recalled(cell)
        if hit is None:
            todo.append(cell)
            continue
        done += 1
        yield sch.partial({"position": position, "index": index, "cell": cell, **hit}, done / total,
                          f"{done} of {total} cells (computed before)")
    if todo:
        yield sch.progress(done / total, "connecting to the Dask cluster (the first study starts its workers)")
        client = connect_client()
        for cell, outcome in stream_cells(client, records, todo, stop=stop):
            _remember(cell, outcome)
            done += 1
            position = positions[cell]
            yield sch.partial({"position": position, "index": cells[position][0], "cell": cell,
                               "row": outcome["row"], "extra": outcome["extra"]}, done / total,
                              f"{done} of {total} cells")
    yield sch.final(total, f"{total} cells")


def _set_text(effects) -> str:
    """An effect set as ``beam study --effects`` reads it (ids in catalogue order, comma-separated)."""
    return ",".join(e for e in EFFECTS if e in set(effects))


class StudyState(RunOwner, param.Parameterized):
    """Inputs and cells of the "Window study" view for one session.

    Parameters
    ----------
    beam : BeamState
        The beam calibration state: its datasets (bundled and uploaded) are the study's, and
        :meth:`open_cell` sets its inputs to a cell's.

    Its run (:attr:`run`) gets its slot from the session, on :func:`study_pool`.
    """

    dataset = param.Selector(default=None, objects=list(bundled_datasets()), label="Dataset",
                             doc="The record studied: a bundled run or an upload of the beam view.")
    windows = param.String("", label="Calibration windows (s)",
                           doc="As beam study --windows: a list 0:0.5,0:1,1:2, a growing family grow:START:STEP:END "
                               "or a sliding one slide:LENGTH:START:STEP:END.")
    effect_sets = param.ListSelector(default=[], objects=[], label="Effect sets",
                                     doc="Each set is one line per likelihood: the dataset's default model, and it with "
                                         "one more effect the record may need.")
    likelihoods = param.ListSelector(default=["iid", "ar1"], objects=LIKELIHOOD_LABELS, label="Likelihoods")

    beam = param.ClassSelector(class_=BeamState, constant=True)
    run = param.ClassSelector(class_=Run, constant=True, doc="The latest study (its progress: the fraction of cells done).")
    total = param.Integer(0, constant=True, doc="Cells of the latest study.")
    entries = param.List([], constant=True, doc="Finished cells of the latest study, in the order they finished "
                                                "(the partial values of study_job).")
    layout = param.List([], constant=True, doc="The latest study's cells in table order: (window index, StudyCell).")

    def __init__(self, **params) -> None:
        super().__init__(**params)
        with editing(self):
            self.run = Run("Window study", words=STUDY_WORDS, show=self._show)
        self._quiet = False
        self._sync_datasets()
        self.beam.param.watch(self._sync_datasets, "uploads")
        self._dataset_changed()

    # -- inputs ----------------------------------------------------------------------------------
    def dataset_label(self, name: str) -> str:
        """The beam view's label of a dataset."""
        return self.beam.dataset_label(name)

    def _sync_datasets(self, *_) -> None:
        objects = list(self.beam.param.dataset.objects)
        self.param.dataset.objects = objects
        if self.dataset not in objects:
            self.dataset = self.beam.dataset

    def measurement(self, name: str | None = None) -> Measurement:
        """The record of dataset ``name`` (default the current one)."""
        name = name or self.dataset
        return self.beam.uploads[name] if name in self.beam.uploads else load_bundled(name)

    def base_effects(self, name: str | None = None) -> tuple[str, ...]:
        """The default model of a dataset (the beam view's: :data:`~dashboard.state.beam.DATASET_DEFAULTS`)."""
        effects = DATASET_DEFAULTS.get(name or self.dataset, {}).get("effects", CalibrationSpec().effects)
        return parse_effects(effects)

    def effect_set_options(self) -> dict[str, str]:
        """``{label: set}`` of the check-boxes: the default model, then it with each effect the record
        may miss (:func:`beam.discovery.ranking.candidate_effects`: the ones its set-up allows)."""
        from beam.discovery.ranking import candidate_effects

        base = self.base_effects()
        words = ", ".join(effect_label(e).split(" (")[0] for e in base) or "bare beam"
        options = {f"default model ({words})": _set_text(base)}
        try:
            extra = candidate_effects(base, self.measurement())
        except BeamInputError:
            extra = ()
        for effect in extra:
            options[f"+ {effect_label(effect)}"] = _set_text((*base, effect))
        return options

    @param.depends("dataset", watch=True)
    def _dataset_changed(self) -> None:
        if self.dataset is None:
            return
        try:
            m = self.measurement()
        except Exception as exc:  # noqa: BLE001 - a broken file: say so, keep the rest
            self.run.note(error=user_message(sch.readable_error(exc)))
            return
        options = self.effect_set_options()
        self.param.effect_sets.objects = list(options.values())
        self.param.update(windows=default_windows_spec(m), effect_sets=[next(iter(options.values()))])

    # -- runs ------------------------------------------------------------------------------------
    def cells(self) -> list[tuple[int, StudyCell]]:
        """The cells of the current inputs (``beam study``'s, seed and target ESS of the beam view).

        Raises
        ------
        BeamInputError
            A malformed window specification or effect set, a window outside the record, no
            effect set or likelihood chosen.
        """
        m = self.measurement()
        windows = parse_windows(self.windows)
        t0, t1 = float(m.time_s[0]), float(m.time_s[-1])
        outside = [w for w in windows if w[0] < t0 or w[1] > t1]
        if outside:
            raise BeamInputError(f"window {outside[0][0]:g}–{outside[0][1]:g} s is outside the record "
                                 f"({t0:g}–{t1:g} s)")
        if not self.effect_sets:
            raise BeamInputError("choose at least one effect set")
        if not self.likelihoods:
            raise BeamInputError("choose at least one likelihood")
        sets = parse_effect_sets(";".join(s for s in self.param.effect_sets.objects if s in self.effect_sets))
        likelihoods = [v for v in LIKELIHOOD_LABELS.values() if v in self.likelihoods]
        return study_cells([(self.dataset, m)], windows, sets, likelihoods, seed=int(self.beam.seed))

    def start(self) -> int:
        """Start a study of the current inputs (it replaces the running one); returns its id, 0 when the
        inputs are wrong (``error`` says why; the cells shown are kept)."""
        try:
            cells = self.cells()
        except BeamInputError as exc:
            self.run.note(error=str(exc), status="check the inputs: the study did not start")
            return 0
        m = self.measurement()
        records = {record_fingerprint(m): m}
        holder: dict[str, int] = {}
        slot = self.run.slot

        def stop() -> bool:
            rid = holder.get("rid")
            return rid is not None and (slot.latest != rid or not slot.busy)

        with editing(self):
            self.param.update(total=len(cells), entries=[], layout=cells)
        rid = self.run.request(bind(study_job, records, cells, stop), status=f"{len(cells)} cells queued",
                               subject=self.beam.record_name(self.dataset))
        holder["rid"] = rid
        return rid

    def cancel(self) -> None:
        """Stop the running study: its cells not finished are cancelled on the cluster (a cell already
        calibrating runs to its end there, unseen); the finished ones stay shown."""
        self.run.cancel(f"cancelled after {len(self.entries)} of {self.total} cells", stage="cancelled")

    def close(self) -> None:
        """Cancel and refuse further studies (the session ended)."""
        self.run.close()

    def wait(self, timeout: float | None = None) -> bool:
        """Block until the latest study has finished (tests and scripts)."""
        return self.run.wait(timeout)

    def _show(self, update: sch.Update) -> dict | None:
        """A finished cell (or the end) of the latest study; the status counts the failed cells."""
        failed = sum(1 for e in self.entries if e["row"]["error"])
        if update.kind == "partial":
            failed += bool(update.value["row"]["error"])
            with editing(self):
                self.entries = [*self.entries, update.value]
            return {"status": update.message + (f", {failed} failed" if failed else "")}
        if update.kind == "final":
            return {"status": f"{update.message} in {update.elapsed_s:.0f} s"
                              + (f", {failed} failed (see their errors)" if failed else "")}
        return None

    # -- a cell in the beam view -----------------------------------------------------------------
    def open_cell(self, entry: dict) -> None:
        """Set the beam view's dataset, window, effects, likelihood and modes to a finished cell's and
        calibrate it there (the same calibration: same engine, options and seed)."""
        cell, beam = entry["cell"], self.beam
        if beam.dataset != self.dataset:
            beam.dataset = self.dataset
        values = {"window_s": tuple(cell.window), "effects": list(cell.effects), "likelihood": cell.likelihood}
        modes = entry.get("extra", {}).get("modes")
        if modes is not None:
            values["modes"] = int(modes)
        beam.param.update(**values)
        beam.request(debounce=False)

    def describe(self) -> dict:
        """Plain summary of inputs and status (for logs and tests)."""
        return {"dataset": self.dataset, "windows": self.windows, "effect_sets": list(self.effect_sets),
                "likelihoods": list(self.likelihoods), **self.run.describe(), "done": len(self.entries),
                "total": self.total}
