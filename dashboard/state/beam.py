"""Session sub-states of the beam views: :class:`BeamState` (calibration) and :class:`DiagnosisState`.

Param only (no panel import), tested without a server or a browser. Both live on the
:class:`~dashboard.state.session.SessionState` and run their jobs (:mod:`dashboard.jobs.beam`) on their
own run slot: a new request cancels the previous one of the same activity only.

:class:`BeamState`
    Inputs (dataset, calibration window, modes, effects, likelihood; units in the labels) and
    outputs (result shown: preview then final posterior; pinned result; status, progress,
    error). A failed request or a rejected upload sets ``error`` and keeps the previous
    dataset and result.
:class:`DiagnosisState`
    Diagnosis of the beam view's current model (residuals, ranked candidates), the error
    ladder (one rung per effect added with :meth:`DiagnosisState.add`, each a full MCMC
    re-calibration of the beam view, after which the diagnosis re-runs for the new model) and the
    revealed answer of a bundled dataset (a real record has none: :meth:`DiagnosisState.reveal` says so).

A dataset may come with its own default inputs (:data:`DATASET_DEFAULTS`, e.g. the real strip
record: window 0–2 s, modal damping, as ``beam diagnose RECORD --window 0:2 --base modal_damping``).
"""

from __future__ import annotations

from functools import partial as bind

import param

from beam.calibration import (
    DEFAULT_MODES,
    CalibrationResult,
    CalibrationSpec,
    known_map,
)
from beam.calibration.modes import MAX_MODES
from beam.errors import BeamInputError
from beam.io.measurement import Measurement
from beam.discovery.ranking import record_features
from beam.physics.effects import EFFECTS, applicable, modal_damping
from dashboard.jobs.beam import (
    CalibrationKey,
    bundled_datasets,
    record_key,
    calibration_run,
    effect_label,
    is_real,
    load_bundled,
    load_upload,
    read_answer,
)
from dashboard.jobs.diagnosis import Diagnosis, diagnosis_key, diagnosis_run
from dashboard.outputs.beam import output_units
from dashboard.outputs.toy import user_message
from dashboard.runtime import scheduler as sch
from dashboard.state.editing import editing
from dashboard.state.run import Pins, Run, RunOwner, Words

__all__ = ["DATASET_DEFAULTS", "DEFAULT_DATASET", "NO_ANSWER", "BeamState", "DiagnosisState", "ladder_rung"]

DEFAULT_DATASET = "lab_run_1"
#: Likelihood choices as shown to the user.
LIKELIHOODS = {"i.i.d. Gaussian": "iid", "AR(1) correlated": "ar1"}
#: How a calibration's and a diagnosis's runs read (the decimals of the calibration's seconds are
#: the benchmark's, ``tests/benchmarks/bench_dashboard.py``).
CALIBRATION_WORDS = Words(ready="{message}: ready in {seconds:.2f} s")
DIAGNOSIS_WORDS = Words()
_INPUTS = ("window_s", "modes", "effects", "likelihood", "seed", "target_ess")
#: Inputs a dataset starts with when selected, besides the default window (the lab runs: none).
#: The real strip record: a 0–2 s window of the free decay, a damping ratio per mode as the base
#: model and the 4 modes of ``beam diagnose RECORD --window 0:2 --base modal_damping`` (the
#: library's default; README "Real measurements").
#: The number of modes of every dataset is chosen from the record on its default window (and effects), as the
#: library's ``modes="auto"`` (:func:`beam.calibration.suggest_modes`; a free decay keeps 4).
DATASET_DEFAULTS: dict[str, dict] = {
    "adxl_50cm_114655": {"window_s": (0.0, 2.0), "effects": [modal_damping.EFFECT.id]},
}
#: What the diagnosis says when the beam view's model changed under it.
STOPPED = "stopped: the beam view's model changed (press Diagnose for the new one)"
#: What Reveal says for a record without a known answer (a real one or an upload).
NO_ANSWER = ("No known answer: this is a real record (or an upload), not a simulation — nobody knows its "
             "true parameters. Judge the model by the residuals, the held-out error and the evidence.")
#: The library's defaults (:class:`beam.calibration.CalibrationSpec`): the inputs' defaults.
DEFAULTS = CalibrationSpec()
#: Default calibration window: this fraction of the record from its start (the library's).
WINDOW_FRACTION = DEFAULTS.window_fraction
#: Record/window/modes/likelihood contexts whose diagnosis MAPs a session keeps (:meth:`BeamState.remember`).
KNOWN_CONTEXTS = 4


def _default_window(measurement) -> tuple[float, float]:
    """The library's default window (:meth:`CalibrationSpec.default_window`), its end rounded to 10 ms."""
    start, end = DEFAULTS.default_window(measurement)
    return start, round(end, 2)


def ladder_rung(result, added: str | None, index: int) -> dict:
    """A row of the error ladder from a :class:`~beam.calibration.CalibrationResult`: the RMSEs in
    ``unit``, the record's read-out unit (:func:`dashboard.outputs.beam.output_units`: µm, mm/s, m/s²)."""
    u = output_units(result)
    return {
        "rung": index,
        "added": added or "(base model)",
        "effects": ", ".join(result.setup.effects),
        "rmse_calibration": u.scale * result.rmse_calibration,
        "rmse_prediction": u.scale * result.rmse_prediction,
        "unit": u.unit,
        "coverage95_pct": 100.0 * result.coverage95_prediction,
        "log_evidence_laplace": float(result.laplace.log_evidence),
        "mcmc": not result.is_preview,
    }


class BeamState(RunOwner, Pins, param.Parameterized):
    """Inputs and results of the beam calibration view for one session.

    Changing an input requests a new calibration (debounced; a newer request cancels the
    older): the preview (MAP + Laplace) is published first, then MCMC progress, then the final
    posterior. Its run (:attr:`run`, a :class:`~dashboard.state.run.Run`) holds the stage,
    status, progress and error.
    """

    dataset = param.Selector(default=DEFAULT_DATASET, objects=list(bundled_datasets()), label="Dataset",
                             doc="Bundled lab run or an uploaded measurement.")
    window_s = param.Range(default=(0.0, 1.0), bounds=(0.0, 10.0), label="Calibration window (s)",
                           doc="The model is calibrated on this part of the record; the rest is held out.")
    modes = param.Integer(DEFAULT_MODES, bounds=(1, MAX_MODES), label="Number of modes (1)",
                          doc="Modes kept in the modal model (a dataset starts with the number the library's default, "
                          "CalibrationSpec.modes, resolves to on its record).")
    effects = param.ListSelector(default=list(DEFAULTS.effects), objects=list(EFFECTS), label="Effects in the model",
                                 doc="Physical effects added to the bare beam (EI, k_p).")
    likelihood = param.Selector(default=DEFAULTS.likelihood, objects=LIKELIHOODS, label="Likelihood (noise model)")
    seed = param.Integer(DEFAULTS.seed, bounds=(0, None), precedence=-1, label="Seed (sampler)")
    target_ess = param.Number(DEFAULTS.target_ess, bounds=(50.0, 10000.0), precedence=-1,
                              label="Target ESS (per parameter)")

    run = param.ClassSelector(class_=Run, constant=True, doc="The calibration of the current inputs.")
    measurement = param.ClassSelector(class_=Measurement, default=None, allow_None=True, constant=True,
                                      doc="The Measurement of ``dataset``.")
    result = param.ClassSelector(class_=CalibrationResult, default=None, allow_None=True, constant=True,
                                 doc="CalibrationResult shown: preview or final.")
    final = param.ClassSelector(class_=CalibrationResult, default=None, allow_None=True, constant=True,
                                doc="Latest final CalibrationResult (with posterior).")
    final_key = param.ClassSelector(class_=CalibrationKey, default=None, allow_None=True, constant=True,
                                    doc="CalibrationKey of ``final``.")
    pinned = param.ClassSelector(class_=CalibrationResult, default=None, allow_None=True, constant=True,
                                 doc="CalibrationResult kept for comparison.")
    uploads = param.Dict({}, constant=True, doc="Uploaded measurements of this session by dataset id.")

    def __init__(self, **params) -> None:
        super().__init__(**params)
        with editing(self):
            self.run = Run("Calibration", words=CALIBRATION_WORDS, show=self._show)
        self._keys: dict[int, CalibrationKey] = {}
        self._known: dict[tuple, list] = {}  # (record, window, modes, likelihood) -> [(effects, MapResult)]
        self._files: dict[str, str] = {}  # upload id -> the name of the file it came from
        self._quiet = False
        self._previous = self.dataset
        m = self._load(self.dataset)
        with editing(self):
            self.measurement = m
        if "window_s" not in params:
            self._set_window(m)
        self._apply_defaults(self.dataset, None, keep=set(params))

    # -- datasets --------------------------------------------------------------------------------
    def dataset_label(self, name: str) -> str:
        """``"lab_run_1 — title"`` of a bundled dataset, ``"upload: name — title"`` of an upload (its file's
        name instead of a title that only restates it: "Raw Data.csv, described in the dashboard" was cut
        in the menus)."""
        if name in self.uploads:
            m, file_name = self.uploads[name], self._files.get(name)
            title = file_name if file_name and m.title.startswith(file_name) else m.title
            return f"upload: {m.name} — {title}"
        return bundled_datasets().get(name, name)

    def record_name(self, name: str | None = None) -> str:
        """What the page calls dataset ``name`` (default the current one): a bundled record's name, an
        upload's file name (``"Raw Data.csv"``)."""
        name = self.dataset if name is None else name
        return self._files.get(name) or (self.uploads[name].name if name in self.uploads else name)

    def _load(self, name: str):
        return self.uploads[name] if name in self.uploads else load_bundled(name)

    def _apply_defaults(self, name: str, previous: str | None, keep=()) -> None:
        """Quietly set the inputs of :data:`DATASET_DEFAULTS` for ``name``; leaving such a dataset for one
        without restores the class defaults of the inputs it had set. ``keep``: inputs given explicitly."""
        values = dict(DATASET_DEFAULTS.get(name, {}))
        if not values and previous in DATASET_DEFAULTS:
            values = {k: self.param[k].default for k in DATASET_DEFAULTS[previous] if k != "window_s"}
        if "modes" not in keep:  # the library's default resolved on the record and its default window
            spec = CalibrationSpec.of(DEFAULTS, window=tuple(values.get("window_s", self.window_s)),
                                      effects=values.get("effects", self.effects))
            try:
                values["modes"] = spec.resolve(self.measurement).modes
            except BeamInputError:
                values["modes"] = self.param.modes.default
        values = {k: v for k, v in values.items() if k not in keep}
        if not values:
            return
        self._quiet = True
        try:
            self.param.update(**values)
        finally:
            self._quiet = False

    def _set_window(self, m) -> None:
        t = m.time_s
        self._quiet = True
        try:
            self.param.window_s.bounds = (float(t[0]), float(t[-1]))
            self.window_s = _default_window(m)
        finally:
            self._quiet = False

    @param.depends("dataset", watch=True)
    def _dataset_changed(self) -> None:
        previous, self._previous = self._previous, self.dataset
        try:
            m = self._load(self.dataset)
        except Exception as exc:  # noqa: BLE001 - a bundled file broken on disk: say so, keep the rest
            self._fail(user_message(sch.readable_error(exc)))
            return
        with editing(self):  # the result shown was the previous record's: none until this one's preview
            self.param.update(measurement=m, result=None)
        self._set_window(m)
        left_out = self._keep_applicable(m)
        self._apply_defaults(self.dataset, previous)
        note = f" ({', '.join(left_out)} left out: not on this record)" if left_out else ""
        self.request(status=f"new record: calibrating{note}")

    def _keep_applicable(self, measurement) -> list[str]:
        """Quietly drop the effects of the model that do not apply to ``measurement`` (a patch's on a
        bare strip, an input's on a free decay: the previous record's model would be refused); returns
        the titles of those dropped."""
        features = record_features(measurement, spectral=False)
        kept = [e for e in self.effects if applicable(e, features)]
        if kept == list(self.effects):
            return []
        dropped = [EFFECTS[e].title for e in self.effects if e not in kept]
        self._quiet = True
        try:
            self.effects = kept
        finally:
            self._quiet = False
        return dropped

    def _fail(self, message: str) -> None:
        """A failure outside a run (a dataset that cannot be read): said as a failed request is."""
        w = self.run.words
        self.run.note(stage="error", error=message, status=w.failed + (w.kept if self.result is not None else ""))

    def upload(self, csv_name: str | None, csv_bytes: bytes | str | None, toml_name: str | None,
               toml_bytes: bytes | str | None) -> bool:
        """Check and select an uploaded measurement; False (and ``error`` set) when it is rejected.

        The contents are bytes or (a ``text/*`` file from the upload widget) UTF-8 decoded text;
        see :func:`~dashboard.jobs.beam.load_upload`. A rejected upload keeps the current dataset
        and result.
        """
        try:
            m = load_upload(csv_name, csv_bytes, toml_name, toml_bytes)
        except Exception as exc:  # noqa: BLE001 - any failure to read an upload is shown, never raised
            message = user_message(sch.readable_error(exc))
            self.run.note(error=f"upload rejected: {message}",
                          status="upload rejected; the previous dataset and result are kept.")
            return False
        self.add_upload(m, file_name=csv_name)
        return True

    def add_upload(self, measurement: Measurement, file_name: str | None = None, select: bool = True) -> str:
        """Add a measurement read elsewhere (e.g. the "Your record" view) as a new upload and,
        with ``select``, select and calibrate it; returns its dataset id. ``file_name``: the file
        it was read from (what the page calls it; default the measurement's name)."""
        name = f"upload-{len(self.uploads) + 1}-{measurement.name}"
        if file_name:
            self._files[name] = file_name
        with editing(self):
            self.uploads = {**self.uploads, name: measurement}
        self.run.note(error="")
        self.param.dataset.objects = [*self.param.dataset.objects, name]
        if select:
            self.dataset = name
        return name

    # -- inputs -> requests ----------------------------------------------------------------------
    def spec(self) -> CalibrationSpec:
        """The :class:`~beam.calibration.CalibrationSpec` of the current inputs."""
        lo, hi = (round(float(v), 4) for v in self.window_s)
        return CalibrationSpec.of(window=(lo, hi), effects=tuple(e for e in EFFECTS if e in set(self.effects)),
                                  modes=int(self.modes), likelihood=str(self.likelihood), seed=int(self.seed),
                                  target_ess=float(self.target_ess))

    def key(self) -> CalibrationKey:
        """The :class:`~dashboard.jobs.beam.CalibrationKey` of the current inputs: the record's digest and :meth:`spec`."""
        return CalibrationKey(record_key(self.measurement), self.spec())

    @param.depends(*_INPUTS, watch=True)
    def _inputs_changed(self) -> None:
        if not self._quiet:
            self.request()

    @staticmethod
    def _context(key: CalibrationKey) -> tuple:
        spec = key.spec
        return key.record, spec.window, spec.modes, spec.likelihood

    def known_maps(self, key: CalibrationKey | None = None) -> tuple:
        """MAPs the diagnoses and the final calibrations found on the record, window, modes and
        likelihood of ``key`` (default the current inputs): what a calibration or diagnosis of one
        of those models starts from (a teacher who ticked an effect before opening the diagnosis:
        that candidate's fit is not searched again)."""
        return tuple(self._known.get(self._context(key or self.key()), ()))

    def remember(self, key: CalibrationKey, maps: tuple) -> None:
        """Keep a diagnosis's MAPs (:attr:`dashboard.jobs.diagnosis.Diagnosis.known_maps`) of ``key``'s
        record, window, modes and likelihood (the last :data:`KNOWN_CONTEXTS` contexts)."""
        context = self._context(key)
        seen = {effects: found for effects, found in self._known.pop(context, ())}
        seen.update({effects: found for effects, found in maps})
        self._known[context] = list(seen.items())
        while len(self._known) > KNOWN_CONTEXTS:
            self._known.pop(next(iter(self._known)))

    def is_bundled(self) -> bool:
        """Whether the current dataset is a bundled one (its results are shared by every session's cache)."""
        return self.dataset in bundled_datasets()

    def request(self, *, debounce: bool = True, status: str = "new inputs: calibrating") -> int:
        """Calibrate with the current inputs (preview, MCMC, final); returns the request id."""
        key = self.key()
        job = bind(calibration_run, key, self.measurement, known=self.known_maps(key), use_cache=self.is_bundled())
        rid = self.run.request(job, debounce_s=None if debounce else 0.0, status=status, subject=self.record_name())
        self._keys[rid] = key
        if len(self._keys) > 50:
            self._keys.pop(min(self._keys))
        return rid

    def add_effect(self, effect: str) -> None:
        """Put ``effect`` into the model (re-calibrates; a no-op request if it is there already)."""
        if effect not in EFFECTS:
            raise ValueError(f"unknown effect {effect!r}")
        if effect in self.effects:
            self.request(debounce=False)
        else:
            self.effects = [e for e in EFFECTS if e in set(self.effects) | {effect}]

    def _show(self, update: sch.Update) -> None:
        """The calibration's results: the preview shown, then the final posterior (kept with its key;
        its MAP, cold-started or the engine's, joins the known ones for a later diagnosis's candidates)."""
        if update.kind in ("preview", "partial"):
            with editing(self):
                self.result = update.value
        elif update.kind == "final":
            key = self._keys.get(update.request)
            if key is not None:
                self.remember(key, (known_map(update.value),))
            with editing(self):
                self.param.update(result=update.value, final=update.value, final_key=key)

    def effect_options(self) -> dict[str, str]:
        """``{label with units: effect id}`` for the check-boxes: the effects that apply to the record
        (:func:`beam.physics.effects.applicable`: no patch's effect on a bare strip, no input's on a free
        decay) and those in the model."""
        m = self.measurement
        features = record_features(m, spectral=False) if m is not None else None
        return {effect_label(e): e for e in EFFECTS
                if features is None or e in self.effects or applicable(e, features)}


class DiagnosisState(RunOwner, param.Parameterized):
    """Diagnosis of the beam view's current model, the error ladder and the revealed answer.

    Parameters
    ----------
    beam : BeamState
        The calibration state whose record, window, modes and effects are diagnosed, and
        whose effect set :meth:`add` extends.
    """

    beam = param.ClassSelector(class_=BeamState, constant=True)
    run = param.ClassSelector(class_=Run, constant=True, doc="The diagnosis of the beam view's model.")
    diagnosis = param.ClassSelector(class_=Diagnosis, default=None, allow_None=True, constant=True,
                                    doc="Diagnosis shown (residuals and ranking so far).")
    ladder = param.List([], constant=True, doc="Rungs of the error ladder (dicts of ladder_rung).")
    adding = param.String("", constant=True, doc="Effect being added (waiting for its final posterior), or ''.")
    answer = param.Dict(None, allow_None=True, constant=True, doc="Revealed truth of a bundled dataset.")

    def __init__(self, **params) -> None:
        super().__init__(**params)
        with editing(self):
            self.run = Run("Diagnosis", words=DIAGNOSIS_WORDS, show=self._show)
        self._ladder_key: tuple | None = None
        self.beam.param.watch(self._beam_final, "final")
        self.beam.param.watch(self._dataset_changed, "dataset")
        self.beam.run.param.watch(self._beam_failed, "error")
        self.beam.run.param.watch(self._beam_requested, "requested")
        self._running: CalibrationKey | None = None  # the diagnosis_key of the diagnosis being computed
        self._adding_request: int | None = None  # the beam request that calibrates the effect being added

    def _beam_failed(self, event) -> None:
        if event.new and self.adding:  # the re-calibration with the added effect failed: no rung
            with editing(self):
                self.adding = ""
            self.run.note(stage="error", error=event.new, status=f"adding failed: {event.new}")

    def _dataset_changed(self, event) -> None:
        with editing(self):
            self.answer = None
        self._abandon_add()

    def _abandon_add(self) -> None:
        """An effect being added whose calibration was superseded (another record, window or model):
        no rung, no re-diagnosis; said so."""
        if self.adding:
            with editing(self):
                self.adding = ""
            self.run.note(stage="idle", status=STOPPED)

    def _beam_requested(self, event) -> None:
        """The beam view's model changed while a diagnosis of the former one runs: stop it (its
        fits hold both worker processes), say so and keep what it had shown. The first request
        after :meth:`add` is the added effect's calibration; a later one supersedes it."""
        if self.adding:
            if self._adding_request is None:
                self._adding_request = event.new
            elif event.new != self._adding_request:
                self._abandon_add()
            return
        if self._running is None or self._running == diagnosis_key(self.beam.key()):
            return
        if self.run.cancel(STOPPED):
            self._running = None

    def request(self) -> int:
        """Diagnose the beam view's current record, window, modes and effects; returns the request id."""
        beam = self.beam
        key = beam.key()
        job = bind(diagnosis_run, key, beam.measurement, known=beam.known_maps(key), use_cache=beam.is_bundled())
        rid = self.run.request(job, status="diagnosing the current model", subject=beam.record_name())
        self._running = diagnosis_key(key)
        return rid

    def is_current(self) -> bool:
        """Whether the diagnosis shown is of the beam view's current record, window, modes and effects."""
        d = self.diagnosis
        return d is not None and diagnosis_key(d.key) == diagnosis_key(self.beam.key())

    def _show(self, update: sch.Update) -> None:
        """The diagnosis's partial reports, then the final one (its MAPs kept by the beam state, the ladder
        started or kept, the effect being added done)."""
        if update.kind in ("preview", "partial"):
            with editing(self):
                self.diagnosis = update.value
        elif update.kind == "final":
            self.beam.remember(update.value.key, update.value.known_maps)
            with editing(self):
                self.param.update(diagnosis=update.value, ladder=self._ladder_for(update.value), adding="")
            self._running = None

    def _ladder_for(self, diagnosis) -> list[dict]:
        """The ladder kept when ``diagnosis`` is of its top rung's model (the re-diagnosis after
        :meth:`add`), else a new ladder from ``diagnosis``'s model."""
        k = diagnosis.key
        context = (k.record, k.spec.window, k.spec.modes)
        if self.ladder and self._ladder_key == context and self.ladder[-1]["effects"] == ", ".join(k.spec.effects):
            return list(self.ladder)
        self._ladder_key = context
        return [self._base_rung(diagnosis)]

    def _base_rung(self, diagnosis) -> dict:
        final, key = self.beam.final, self.beam.final_key
        same = key is not None and diagnosis_key(key) == diagnosis_key(diagnosis.key)
        return ladder_rung(final if same else diagnosis.base, None, 0)

    # -- the ladder ------------------------------------------------------------------------------
    def add(self, effect: str) -> None:
        """Add ``effect`` to the beam view's model: re-calibrate (full MCMC), append a ladder rung, then
        diagnose the new model (the run says it waits for the calibration meanwhile: nothing of this
        request is "complete" before the re-diagnosis is)."""
        with editing(self):
            self.adding = effect
        self._adding_request = None
        self.beam.add_effect(effect)
        if self.adding:  # not failed at once
            self.run.note(stage="queued", status=f"adding {effect}: re-calibrating with full MCMC, then diagnosing again")

    def _beam_final(self, event) -> None:
        key = self.beam.final_key
        if not self.adding or key is None or self.diagnosis is None or self.adding not in key.spec.effects:
            return
        d = self.diagnosis.key
        if (key.record, key.spec.window, key.spec.modes) != (d.record, d.spec.window, d.spec.modes):
            return
        rungs = [r for r in self.ladder if r["effects"] != ", ".join(key.spec.effects)]
        added = self.adding
        self.request()  # every view of the diagnosis (residuals, spectra, modes, candidates) for the new model
        with editing(self):
            self.param.update(ladder=rungs + [ladder_rung(event.new, added, len(rungs))], adding="")

    def has_answer(self) -> bool:
        """Whether the current dataset has a known answer (a simulated bundled run; not a real record
        nor an upload)."""
        name = self.beam.dataset
        return name not in self.beam.uploads and not is_real(name)

    def reveal(self) -> dict | None:
        """The hidden effects and true parameters of a bundled dataset (None for an upload or a real
        record: ``status`` then says there is no known answer, :data:`NO_ANSWER`)."""
        answer = read_answer(self.beam.dataset) if self.has_answer() else None
        with editing(self):
            self.answer = answer
        if answer is None:
            self.run.note(status=NO_ANSWER)
        return answer
