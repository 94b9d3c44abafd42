"""Session sub-state of the "Your record" view: :class:`RecordState`.

Param only (no panel import), tested without a server or a browser. The flow:

1. :meth:`RecordState.upload` reads a dropped file in any format on the ``record-read`` run slot
   (:func:`dashboard.jobs.record.read_job`, off the event loop); ``read`` then holds what was read
   and its spectrum. A file that cannot be read sets ``error`` and keeps the previous record.
   A file that does not say everything (no time column, a column without its unit, several
   channels of different kinds, several records) is read again whenever a reading option
   changes (:data:`READ_OPTIONS`: the record in the file, the signal column, its unit, the
   sampling rate, the time unit, the pluck). Each new file starts from its own reading: every
   reading option is cleared when it is dropped, ``file_records`` and ``file_columns`` list
   its own records and columns (as soon as its columns are read, also when it then needs a
   choice), and the beam described for the previous file is kept but said to be
   (``beam_kept_from``) until the form is touched.
2. The form (the inputs below, units in every label) describes the beam. As soon as every
   required input is filled and a record is read, the ``record-beam`` slot builds the
   measurement and the ideal beam's modes (:func:`dashboard.jobs.record.describe_job`):
   ``described``. A description the library refuses sets ``form_error`` and clears
   ``described``.
3. :meth:`RecordState.load` hands the measurement to the beam calibration
   (:meth:`dashboard.state.beam.BeamState.add_upload`, which selects and calibrates it); a record
   of several taps (:mod:`beam.io.taps`) hands every tap to the "Several records" view as records
   of one beam and calibrates them together there (:meth:`dashboard.state.joint.JointState.calibrate`),
   the strongest to the beam calibration; :meth:`RecordState.sidecar_text` is the TOML sidecar for the CLI.
"""

from __future__ import annotations

from functools import partial as bind

import param

from beam.io.materials import MATERIALS
from beam.io.readers.units import SIGNAL_UNITS
from beam.io.text import dump_toml
from beam.physics.effects import sensor_mass
from dashboard.jobs.record import Described, FileContents, RecordRead, beam_document, describe_job, read_job
from dashboard.outputs.toy import user_message
from dashboard.runtime import scheduler as sch
from dashboard.state.beam import BeamState
from dashboard.state.editing import editing
from dashboard.state.run import Run, RunOwner, Words

__all__ = ["FORM_INPUTS", "READ_OPTIONS", "RecordState"]

#: The inputs that describe the beam (all but the sensor's mass are required).
FORM_INPUTS = ("length_m", "width_m", "thickness_m", "material", "sensor_position_m", sensor_mass.MASS.name,
               "sensor_mass_approximate")
_REQUIRED = ("length_m", "width_m", "thickness_m", "material", "sensor_position_m")
#: The reading options (parameters) and the keywords of :func:`beam.io.readers.read_record` they give.
READ_OPTIONS = {"record_name": "record", "signal_column": "column", "signal_unit": "unit", "rate_Hz": "rate",
                "time_unit": "time_unit", "segment": "segment"}
#: Units offered for a signal column without one (:data:`beam.io.readers.units.SIGNAL_UNITS`: strain
#: and microstrain among them, and arbitrary units for a signal of unknown scale).
OFFERED_UNITS = SIGNAL_UNITS
#: Units of a time column (the readers' ``time_unit``).
TIME_UNITS = ("s", "ms", "us")
#: How reading a file reads (a file refused keeps the record read before).
READ_WORDS = Words(progress="reading", partial="reading", final="read", ready="read in {seconds:.1f} s", failed="",
                   kept="the previous record is kept")


class RecordState(RunOwner, param.Parameterized):
    """A record of the user's own, described in a student's words, for one session.

    Parameters
    ----------
    beam : BeamState
        The session's beam calibration state, which :meth:`load` hands the record to.
    """

    # -- the form ------------------------------------------------------------------------------
    length_m = param.Number(None, allow_None=True, bounds=(0.0, None), inclusive_bounds=(False, True),
                            label="Free length, clamp edge to tip (m)", doc="Free length of the beam (m).")
    width_m = param.Number(None, allow_None=True, bounds=(0.0, None), inclusive_bounds=(False, True),
                           label="Width (m)", doc="Width of the strip (m).")
    thickness_m = param.Number(None, allow_None=True, bounds=(0.0, None), inclusive_bounds=(False, True),
                               label="Thickness (m)", doc="Thickness of the strip (m).")
    material = param.Selector(default=None, objects=list(MATERIALS), allow_None=True,
                              label="Material (gives E in Pa and density in kg/m³)",
                              doc="A material preset (beam/io/materials.py).")
    sensor_position_m = param.Number(None, allow_None=True, bounds=(0.0, None), label="Sensor position (m from the clamp)",
                                     doc="Where the sensor sits, measured from the clamp's edge (m).")
    sensor_mass_kg = param.Number(None, allow_None=True, bounds=(0.0, None), label="Sensor mass (kg; empty if negligible)",
                                  doc="The sensor's mass (kg), a known point mass; empty: not counted.")
    sensor_mass_approximate = param.Boolean(False, label="The mass is a guess (e.g. a phone, not weighed)",
                                            doc="Give sensor_mass a wide prior instead of a fixed value.")

    # -- reading options (a file that does not say) -------------------------------------------
    record_name = param.String(None, allow_None=True, label="Record in the file",
                               doc="For a file holding several records (a MATLAB file's structs): which (None: the longest).")
    signal_column = param.String(None, allow_None=True, label="Signal column",
                                 doc="1-based column of the file to use (None: the one with the most vibration power).")
    signal_unit = param.Selector(default=None, objects=list(OFFERED_UNITS), allow_None=True,
                                 label="Signal's unit (when the file does not say)",
                                 doc="Unit of the signal column, for a column whose name has none.")
    rate_Hz = param.Number(None, allow_None=True, bounds=(0.0, None), inclusive_bounds=(False, True),
                           label="Sampling rate (Hz), for a file without time stamps",
                           doc="Samples per second, when the file has no time column.")
    time_unit = param.Selector(default=None, objects=list(TIME_UNITS), allow_None=True,
                               label="Time column's unit (s, ms or µs)",
                               doc="Unit of the time column when it is not seconds (an Arduino's micros() is µs).")
    segment = param.Integer(None, allow_None=True, bounds=(1, None),
                            label="Pluck to use alone (1 = the first; empty: every tap, calibrated together)",
                            doc="1-based pluck or file segment.")

    # -- outputs -------------------------------------------------------------------------------
    beam = param.ClassSelector(class_=BeamState, constant=True, doc="The session's beam calibration state.")
    run = param.ClassSelector(class_=Run, constant=True, doc="Reading the latest file (its error: why it was refused).")
    beam_run = param.ClassSelector(class_=Run, constant=True, doc="Describing the beam of the record read.")
    read = param.ClassSelector(class_=RecordRead, default=None, allow_None=True, constant=True,
                               doc="The record shown (the latest file read).")
    described = param.ClassSelector(class_=Described, default=None, allow_None=True, constant=True,
                                    doc="The record with its beam, when the form is complete.")
    form_error = param.String("", constant=True, doc="Why the description is refused, or ''.")
    file_records = param.List(default=[], constant=True, doc="The records of the file last dropped, when it holds several.")
    file_columns = param.List(default=[], constant=True,
                              doc="The columns of the file last dropped (of its record in use), as the reader lists "
                                  "them ('2: gFx (acceleration in g)'); empty until they are read.")
    beam_kept_from = param.String("", constant=True,
                                  doc="The file the beam in the form was described for, while a new file is shown "
                                      "with it and the form is not touched; ''.")
    loaded = param.String("", constant=True, doc="Dataset id of the latest record handed to the beam calibration.")
    loaded_taps = param.List([], constant=True, doc="Dataset ids of the latest record's taps handed to the joint "
                             "calibration (empty for a record of one tap).")
    joint = param.Parameter(None, doc="The session's JointState (the \"Several records\" view), which takes a "
                            "record's taps; None: the taps are not handed over.")

    def __init__(self, **params) -> None:
        super().__init__(**params)
        with editing(self):
            self.run = Run("Reading {}", words=READ_WORDS, show=self._show_read)
            self.beam_run = Run("Describing the beam", show=self._show_described)
        self._loaded_from: Described | None = None
        self._file: tuple[str | None, bytes | str | None] | None = None  # the latest file dropped
        self._contents: FileContents | None = None  # its records and columns, once read
        self._record_shown: str | None = None  # the record whose columns file_columns lists
        self._quiet = False

    # -- the file --------------------------------------------------------------------------------
    def upload(self, file_name: str | None, data: bytes | str | None) -> int:
        """Read a dropped file (off the event loop) from its own reading: every reading option
        chosen for the previous file is cleared (the file's own names and units decide, and
        what they decide is shown); returns the request id."""
        described = any(getattr(self, name) is not None for name in _REQUIRED)
        kept = self.read.file_name if self.read is not None and described else ""
        self._file = (file_name, data)
        self._contents = None
        self._quiet = True
        try:
            self.param.update(**{name: None for name in READ_OPTIONS})
        finally:
            self._quiet = False
        with editing(self):
            self.param.update(file_records=[], file_columns=[], beam_kept_from=kept)
        return self._read()

    @property
    def dropped_name(self) -> str:
        """The name of the file dropped last ('' before any)."""
        return (self._file[0] or "") if self._file is not None else ""

    def options(self) -> dict:
        """The reading options given, as keywords of :func:`beam.io.readers.read_record`."""
        values = {keyword: getattr(self, name) for name, keyword in READ_OPTIONS.items()}
        return {keyword: value for keyword, value in values.items() if value is not None}

    @param.depends(*READ_OPTIONS, watch=True)
    def _options_changed(self, *events) -> None:
        if self._file is None or self._quiet:
            return
        if self.record_name != self._record_shown and self._contents is not None:
            # another record of the file: its own columns (a column chosen in the other one is dropped)
            self._quiet = True
            try:
                self.signal_column = None
            finally:
                self._quiet = False
            self._show_contents()
        self._read()

    def _show_contents(self) -> None:
        contents = self._contents
        self._record_shown = self.record_name
        record = self.record_name if self.record_name in contents.records else contents.default_record
        with editing(self):
            self.param.update(file_records=list(contents.records), file_columns=list(contents.columns.get(record, ())))

    def _read(self) -> int:
        file_name, data = self._file
        return self.run.request(bind(read_job, file_name, data, **self.options()), stage="reading",
                                status=f"reading {file_name}", subject=file_name or "")

    def _show_read(self, update: sch.Update) -> dict | None:
        """The file's records and columns as soon as they are read (``partial``); the file read
        (``final``): shown, and its beam described again."""
        if update.kind == "partial":  # the file's records and columns, before any choice
            self._contents = update.value
            self._show_contents()
        elif update.kind == "final":
            with editing(self):
                self.param.update(read=update.value, described=None, form_error="", loaded="")
            self._describe()
        return None

    # -- the form --------------------------------------------------------------------------------
    def missing(self) -> list[str]:
        """Labels of the required inputs not filled yet."""
        return [self.param[name].label for name in _REQUIRED if getattr(self, name) is None]

    def document(self) -> dict | None:
        """The sidecar document of the form (None while a required input is empty)."""
        if self.missing():
            return None
        title = f"{self.read.file_name}, described in the dashboard" if self.read is not None else "my beam"
        return beam_document(title, self.length_m, self.width_m, self.thickness_m, self.material,
                             self.sensor_position_m, self.sensor_mass_kg, self.sensor_mass_approximate)

    def sidecar_text(self) -> str:
        """The sidecar (TOML) of the form, for ``beam calibrate FILE --beam SIDECAR`` (or saved as
        ``STEM.toml`` next to the file); '' while a required input is empty."""
        document = self.document()
        if document is None:
            return ""
        name = self.read.file_name if self.read is not None else "the record"
        return dump_toml(document, header_comment=f"The beam of {name}, as described in the dashboard "
                                                  "(beam calibrate FILE --beam THIS.toml).")

    def sidecar_name(self) -> str:
        """``STEM.toml`` of the record (found next to it by ``beam calibrate FILE``)."""
        if self.read is None:
            return "beam.toml"
        stem = self.read.file_name.rsplit(".", 1)[0] if "." in self.read.file_name else self.read.file_name
        return f"{stem}.toml"

    @param.depends(*FORM_INPUTS, watch=True)
    def _form_changed(self) -> None:
        if self.beam_kept_from:
            with editing(self):
                self.param.update(beam_kept_from="")
        self._describe()

    def _describe(self) -> None:
        document = self.document()
        if document is None or self.read is None:
            self.beam_run.cancel("the form changed")
            with editing(self):
                self.param.update(described=None, form_error="")
            return
        self.beam_run.request(bind(describe_job, self.read, document), debounce_s=None, status="describing the beam")

    def _show_described(self, update: sch.Update) -> None:
        """The beam described (or why the library refuses the description)."""
        with editing(self):
            if update.kind == "error":
                self.param.update(described=None, form_error=user_message(update.message))
            elif update.kind == "final":
                self.param.update(described=update.value, form_error="")

    # -- hand over -------------------------------------------------------------------------------
    def can_load(self) -> bool:
        """Whether :meth:`load` has something new to hand over: a description of the current form
        (not one the form has changed since) not loaded yet."""
        d = self.described
        return d is not None and d is not self._loaded_from and d.document == self.document()

    def load(self) -> str | None:
        """Hand the described record to the beam calibration (selected there and calibrated);
        returns its dataset id (the same again for a record loaded already), None when there is
        nothing to load (:meth:`can_load`)."""
        if not self.can_load():
            return (self.loaded or None) if self._loaded_from is self.described else None
        measurement = self.described.measurement
        file_name = self.read.file_name
        together = len(measurement.taps) > 1 and self.joint is not None and self.segment is None  # no pluck chosen
        taps = measurement.taps if together else ()
        ids, name = [], None
        for tap in taps:
            if tap.measurement.name != measurement.name:
                ids.append(self.beam.add_upload(tap.measurement, file_name=file_name, select=False))
            else:
                ids.append(name := self.beam.add_upload(measurement, file_name=file_name))
        if name is None:
            name = self.beam.add_upload(measurement, file_name=file_name)
        self._loaded_from = self.described
        status = f"loaded into the beam calibration as {name}"
        if ids:
            self.joint.refresh_records()
            self.joint.records = ids
            self.joint.calibrate()
            status = (f"{len(ids)} taps loaded into Several records and calibrated together there; the strongest "
                      f"into the beam calibration as {name}")
        with editing(self):
            self.param.update(loaded=name, loaded_taps=ids)
        self.run.note(status=status)
        return name
