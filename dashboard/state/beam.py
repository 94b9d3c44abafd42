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
from beam.physics.effects import EFFECTS, modal_damping
from dashboard.jobs.beam import (
    CalibrationKey,
    bundled_datasets,
    calibration_run,
    effect_label,
    is_real,
    load_bundled,
    load_upload,
    read_answer,
)
from dashboard.jobs.diagnosis import Diagnosis, diagnosis_run
from dashboard.outputs.beam import output_units
from dashboard.outputs.toy import user_message
from dashboard.runtime import scheduler as sch
from dashboard.state.editing import editing

__all__ = ["DATASET_DEFAULTS", "DEFAULT_DATASET", "NO_ANSWER", "BeamState", "DiagnosisState", "ladder_rung"]

DEFAULT_DATASET = "lab_run_1"
#: Likelihood choices as shown to the user.
LIKELIHOODS = {"i.i.d. Gaussian": "iid", "AR(1) correlated": "ar1"}
STAGES = ("idle", "queued", "preview", "sampling", "final", "error")
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


class _Runs(param.Parameterized):
    """Outputs shared by the two sub-states: stage, status, progress, error, request ids."""

    stage = param.Selector(default="idle", objects=list(STAGES), constant=True, doc="Where the latest request is.")
    status = param.String("", constant=True, doc="One-line status for the user.")
    progress = param.Number(0.0, bounds=(0.0, 1.0), constant=True, doc="Fraction of the job done.")
    error = param.String("", constant=True, doc="Readable message of the latest failure, or ''.")
    requested = param.Integer(0, constant=True, doc="Id of the latest request.")
    shown = param.Integer(0, constant=True, doc="Id of the request the shown result belongs to.")

    def __init__(self, **params) -> None:
        super().__init__(**params)
        self._slot: sch.RunSlot | None = None
        self._timings: dict[int, dict[str, float]] = {}

    def attach(self, slot: sch.RunSlot) -> None:
        """Give the state its run slot (done by :class:`~dashboard.state.session.SessionState`)."""
        self._slot = slot

    def timings(self, request: int) -> dict[str, float]:
        """Seconds from request to each published stage, e.g. ``{"preview": 0.3, "final": 2.1}``."""
        return dict(self._timings.get(request, {}))

    def _timed(self, update: sch.Update) -> None:
        self._timings.setdefault(update.request, {}).setdefault(update.kind, update.elapsed_s)
        if len(self._timings) > 50:
            self._timings.pop(min(self._timings))

    def _fail(self, message: str, kept: bool) -> None:
        with editing(self):
            self.param.update(stage="error", error=message, progress=0.0,
                              status="failed." + (" The previous result is still shown." if kept else ""))


class BeamState(_Runs):
    """Inputs and results of the beam calibration view for one session.

    Changing an input requests a new calibration (debounced; a newer request cancels the
    older): the preview (MAP + Laplace) is published first, then MCMC progress, then the final
    posterior.
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
        self._keys: dict[int, CalibrationKey] = {}
        self._known: dict[tuple, list] = {}  # (dataset, window, modes, likelihood) -> [(effects, MapResult)]
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
        """``"lab_run_1 — title"`` of a bundled dataset, ``"upload: name — title"`` of an upload."""
        if name in self.uploads:
            return f"upload: {self.uploads[name].name} — {self.uploads[name].title}"
        return bundled_datasets().get(name, name)

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
            self._fail(user_message(sch.readable_error(exc)), self.result is not None)
            return
        with editing(self):
            self.measurement = m
        self._set_window(m)
        self._apply_defaults(self.dataset, previous)
        self.request()

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
            with editing(self):
                self.param.update(error=f"upload rejected: {message}",
                                  status="upload rejected; the previous dataset and result are kept.")
            return False
        self.add_upload(m)
        return True

    def add_upload(self, measurement: Measurement) -> str:
        """Select a measurement read elsewhere (e.g. the "Your record" view) as a new upload and
        calibrate it; returns its dataset id."""
        name = f"upload-{len(self.uploads) + 1}-{measurement.name}"
        with editing(self):
            self.uploads = {**self.uploads, name: measurement}
            self.error = ""
        self.param.dataset.objects = [*self.param.dataset.objects, name]
        self.dataset = name
        return name

    # -- inputs -> requests ----------------------------------------------------------------------
    def key(self) -> CalibrationKey:
        """The :class:`~dashboard.jobs.beam.CalibrationKey` of the current inputs."""
        lo, hi = (round(float(v), 4) for v in self.window_s)
        effects = tuple(e for e in EFFECTS if e in set(self.effects))
        return CalibrationKey(self.dataset, (lo, hi), effects, int(self.modes), str(self.likelihood), int(self.seed),
                              float(self.target_ess))

    @param.depends(*_INPUTS, watch=True)
    def _inputs_changed(self) -> None:
        if not self._quiet:
            self.request()

    def known_maps(self, key: CalibrationKey | None = None) -> tuple:
        """MAPs the diagnoses and the final calibrations found on the record, window, modes and
        likelihood of ``key`` (default the current inputs): what a calibration or diagnosis of one
        of those models starts from (a teacher who ticked an effect before opening the diagnosis:
        that candidate's fit is not searched again)."""
        key = key or self.key()
        return tuple(self._known.get((key.dataset, key.window, key.modes, key.likelihood), ()))

    def remember(self, key: CalibrationKey, maps: tuple) -> None:
        """Keep a diagnosis's MAPs (:attr:`dashboard.jobs.diagnosis.Diagnosis.known_maps`) of ``key``'s
        record, window, modes and likelihood (the last :data:`KNOWN_CONTEXTS` contexts)."""
        context = (key.dataset, key.window, key.modes, key.likelihood)
        seen = {effects: found for effects, found in self._known.pop(context, ())}
        seen.update({effects: found for effects, found in maps})
        self._known[context] = list(seen.items())
        while len(self._known) > KNOWN_CONTEXTS:
            self._known.pop(next(iter(self._known)))

    def request(self, *, debounce: bool = True) -> int:
        """Calibrate with the current inputs (preview, MCMC, final); returns the request id."""
        key = self.key()
        rid = self._slot.request(bind(calibration_run, key, self.measurement, known=self.known_maps(key)),
                                 debounce_s=None if debounce else 0.0)
        self._keys[rid] = key
        if len(self._keys) > 50:
            self._keys.pop(min(self._keys))
        with editing(self):
            self.param.update(requested=rid, stage="queued", progress=0.0, status="new inputs: calibrating")
        return rid

    def add_effect(self, effect: str) -> None:
        """Put ``effect`` into the model (re-calibrates; a no-op request if it is there already)."""
        if effect not in EFFECTS:
            raise ValueError(f"unknown effect {effect!r}")
        if effect in self.effects:
            self.request(debounce=False)
        else:
            self.effects = [e for e in EFFECTS if e in set(self.effects) | {effect}]

    def on_run_update(self, update: sch.Update) -> None:
        """The run slot's callback: show an update of this state's latest request."""
        self._timed(update)
        if update.kind == "error":
            self._fail(user_message(update.message), self.result is not None)
            return
        with editing(self):
            if update.kind == "progress":
                self.param.update(stage="sampling", progress=update.fraction or 0.0, status=update.message)
            elif update.kind in ("preview", "partial"):
                self.param.update(stage="preview", error="", result=update.value, shown=update.request,
                                  progress=0.0, status=update.message)
            else:
                key = self._keys.get(update.request)
                if key is not None:  # its MAP (cold-started: the engine's) for a later diagnosis's candidates
                    self.remember(key, (known_map(update.value),))
                self.param.update(stage="final", error="", result=update.value, final=update.value,
                                  final_key=key, shown=update.request, progress=1.0,
                                  status=f"{update.message}: ready in {update.elapsed_s:.2f} s")

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

    @staticmethod
    def effect_options() -> dict[str, str]:
        """``{label with units: effect id}`` for the check-boxes."""
        return {effect_label(e): e for e in EFFECTS}


class DiagnosisState(_Runs):
    """Diagnosis of the beam view's current model, the error ladder and the revealed answer.

    Parameters
    ----------
    beam : BeamState
        The calibration state whose dataset, window, modes and effects are diagnosed, and
        whose effect set :meth:`add` extends.
    """

    beam = param.ClassSelector(class_=BeamState, constant=True)
    diagnosis = param.ClassSelector(class_=Diagnosis, default=None, allow_None=True, constant=True,
                                    doc="Diagnosis shown (residuals and ranking so far).")
    ladder = param.List([], constant=True, doc="Rungs of the error ladder (dicts of ladder_rung).")
    adding = param.String("", constant=True, doc="Effect being added (waiting for its final posterior), or ''.")
    answer = param.Dict(None, allow_None=True, constant=True, doc="Revealed truth of a bundled dataset.")

    def __init__(self, **params) -> None:
        super().__init__(**params)
        self._ladder_key: tuple | None = None
        self.beam.param.watch(self._beam_final, "final")
        self.beam.param.watch(self._dataset_changed, "dataset")
        self.beam.param.watch(self._beam_failed, "error")
        self.beam.param.watch(self._beam_requested, "requested")
        self._running: tuple | None = None  # (dataset, window, effects, modes) of the diagnosis being computed

    def _beam_failed(self, event) -> None:
        if event.new and self.adding:  # the re-calibration with the added effect failed: no rung
            with editing(self):
                self.param.update(adding="", status=f"adding failed: {event.new}")

    def _dataset_changed(self, event) -> None:
        with editing(self):
            self.param.update(answer=None, adding="")

    def _beam_requested(self, event) -> None:
        """The beam view's model changed while a diagnosis of the former one runs: stop it (its
        fits hold both worker processes), say so and keep what it had shown."""
        k = self.beam.key()
        if self._running is None or self.stage not in ("queued", "preview", "sampling") or \
                self._running == (k.dataset, k.window, k.effects, k.modes):
            return
        self._slot.cancel()
        self._running = None
        with editing(self):
            self.param.update(stage="idle", progress=0.0,
                              status="stopped: the beam view's model changed (press Diagnose for the new one)")

    def request(self) -> int:
        """Diagnose the beam view's current dataset, window, modes and effects; returns the request id."""
        key = self.beam.key()
        rid = self._slot.request(bind(diagnosis_run, key, self.beam.measurement, known=self.beam.known_maps(key)),
                                 debounce_s=0.0)
        self._running = (key.dataset, key.window, key.effects, key.modes)
        with editing(self):
            self.param.update(requested=rid, stage="queued", progress=0.0, status="diagnosing the current model")
        return rid

    def is_current(self) -> bool:
        """Whether the diagnosis shown is of the beam view's current dataset, window, modes and effects."""
        d, k = self.diagnosis, self.beam.key()
        return d is not None and (d.key.dataset, d.key.window, d.key.effects, d.key.modes) == (
            k.dataset, k.window, k.effects, k.modes)

    def on_run_update(self, update: sch.Update) -> None:
        """The run slot's callback: show an update of this state's latest request."""
        self._timed(update)
        if update.kind == "error":
            self._fail(user_message(update.message), self.diagnosis is not None)
            return
        with editing(self):
            if update.kind == "progress":
                self.param.update(stage="sampling", progress=update.fraction or 0.0, status=update.message)
            elif update.kind in ("preview", "partial"):
                self.param.update(stage="preview", error="", diagnosis=update.value, shown=update.request,
                                  progress=update.fraction or 0.0, status=update.message)
            else:
                self.beam.remember(update.value.key, update.value.known_maps)
                self.param.update(stage="final", error="", diagnosis=update.value, shown=update.request,
                                  progress=1.0, status=f"{update.message}: ready in {update.elapsed_s:.1f} s",
                                  ladder=self._ladder_for(update.value), adding="")

    def _ladder_for(self, diagnosis) -> list[dict]:
        """The ladder kept when ``diagnosis`` is of its top rung's model (the re-diagnosis after
        :meth:`add`), else a new ladder from ``diagnosis``'s model."""
        k = diagnosis.key
        if self.ladder and self._ladder_key == (k.dataset, k.window, k.modes) and \
                self.ladder[-1]["effects"] == ", ".join(k.effects):
            return list(self.ladder)
        self._ladder_key = (k.dataset, k.window, k.modes)
        return [self._base_rung(diagnosis)]

    def _base_rung(self, diagnosis) -> dict:
        final, key = self.beam.final, self.beam.final_key
        same = key is not None and (key.dataset, key.window, key.effects, key.modes) == (
            diagnosis.key.dataset, diagnosis.key.window, diagnosis.key.effects, diagnosis.key.modes)
        return ladder_rung(final if same else diagnosis.base, None, 0)

    # -- the ladder ------------------------------------------------------------------------------
    def add(self, effect: str) -> None:
        """Add ``effect`` to the beam view's model: re-calibrate (full MCMC) and append a ladder rung."""
        with editing(self):
            self.param.update(adding=effect, status=f"adding {effect}: re-calibrating with full MCMC")
        self.beam.add_effect(effect)

    def _beam_final(self, event) -> None:
        key = self.beam.final_key
        if not self.adding or key is None or self.diagnosis is None or self.adding not in key.effects:
            return
        d = self.diagnosis.key
        if (key.dataset, key.window, key.modes) != (d.dataset, d.window, d.modes):
            return
        rungs = [r for r in self.ladder if r["effects"] != ", ".join(key.effects)]
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
                self.status = NO_ANSWER
        return answer

