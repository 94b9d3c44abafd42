"""The "Your record" view: drop any readable file, describe the beam, see its spectrum, calibrate.

A :class:`pn.viewable.Viewer` over ``session.record`` (:class:`~dashboard.state.record.RecordState`);
nothing here calls ``beam`` directly. Its pieces are built the first time its tab is shown (the
app makes a hidden tab's page invisible: the view watches its page's ``visible``), so sessions
that never open it pay nothing.

Left: the file (a FileDropper sending :data:`~dashboard.views.beam.UPLOAD_CHUNK_BYTES` pieces,
each one websocket message well under Bokeh's 20 MB limit, so a 50 MB file uploads with its
progress shown), the form (widgets from the state's parameters, units in every label), "Load
and calibrate" and the sidecar's download. Main: the status, what was read, a side view of the
beam with the sensor where it sits, and, once the form is complete, the record's spectrum with
the ideal beam's modes and the summary ``beam import`` prints.
"""

from __future__ import annotations

import html
import io

import numpy as np

import panel as pn

from beam.io.readers.units import display_unit
from beam.physics.effects import sensor_mass
from dashboard.jobs.beam import MAX_UPLOAD_BYTES, upload_size_text
from dashboard.plots.record import BeamSketch, SpectrumPlot
from dashboard.views.beam import UPLOAD_CHUNK_BYTES
from dashboard.views.panes import FLEX_ITEM_INPUTS, FLEX_ITEM_MAIN, HTML, Markdown, alert_html, run_status
from dashboard.views.tab import TabView

__all__ = ["RecordView", "read_html"]

_STAGE_TEXT = {
    "idle": "Drop a record file to start.",
    "reading": "Reading the file…",
    "read": "Record read.",
    "error": "Could not read that file.",
}
#: The tab a loaded record is calibrated in.
BEAM_TAB = "Beam calibration"
#: The tab a record's taps are calibrated together in.
JOINT_TAB = "Several records"
INTRO = ("**Your own record**: a phone taped to a ruler (phyphox, Physics Toolbox), a LabVIEW `.lvm`, an NI "
         "`.tdms`, a MATLAB `.mat`, a NumPy `.npy`/`.npz` or any CSV/text table. Drop the file, say what the beam "
         "is, check that the ideal beam's first mode sits near the record's first peak, then calibrate.")


#: What a menu shows for an input not given (the state's None: a menu's None shows as blank).
NOT_GIVEN = ""


def _select(state, name: str, options: dict, css: str) -> pn.widgets.Select:
    """A menu of ``options`` ({label: value}, :data:`NOT_GIVEN` for None) bound both ways to the
    state's parameter ``name``, labelled with its label."""
    menu = pn.widgets.Select(label=state.param[name].label, options=options, sizing_mode="stretch_width",
                             value=NOT_GIVEN if getattr(state, name) is None else getattr(state, name), css_classes=[css])

    def to_state(event) -> None:
        value = None if event.new == NOT_GIVEN else event.new
        if value != getattr(state, name):
            setattr(state, name, value)

    def to_menu(event) -> None:
        value = NOT_GIVEN if event.new is None else event.new
        if value in menu.options.values() and value != menu.value:
            menu.value = value

    menu.param.watch(to_state, "value")
    state.param.watch(to_menu, name)
    return menu


def _row(label: str, value: str) -> str:
    return f"<tr><th style='text-align:left;padding-right:12px;vertical-align:top'>{html.escape(label)}</th><td>{value}</td></tr>"


def read_html(summary: dict | None, pending: str = "") -> str:
    """What was read (:meth:`dashboard.jobs.record.RecordRead.summary`) as an HTML table: the
    file, its format, every decision of the reader with why and the control under *Reading
    options* that changes it, the channels, rate, duration, plucks and cleaning. ``pending``
    names a file dropped since that is not (yet) read: the table then says it is the previous
    file's."""
    if summary is None:
        return "<div class='record-read'><i>No record yet.</i></div>"
    esc = html.escape
    channels = "<br>".join(esc(c) for c in summary["channels"])
    decisions = [_row(title, f"{'<b>' if title == 'Signal used' else ''}{esc(text)}"
                             f"{'</b>' if title == 'Signal used' else ''}"
                             + (f" <span class='record-change'>(another: {esc(control)})</span>" if control else ""))
                 for title, text, control in summary["findings"]]
    if summary["segments"]:
        segments = "<br>".join(
            f"{k}: {a:.3f}–{b:.3f} s, peak {p:.3g}" + (" <b>(used)</b>" if summary["segment_used"] == k - 1 else "")
            for k, (a, b, p) in enumerate(summary["segments"], start=1))
    else:
        segments = "one (the whole record)"
    if summary.get("taps", 0) > 1:
        segments += (f"<br><b>{summary['taps']} taps: one beam at {summary['taps']} amplitudes, calibrated together</b> "
                     "when loaded (the pluck chosen under Reading options takes one alone)")
    notes = "<br>".join(esc(n) for n in summary["notes"]) or "nothing dropped"
    previous = (f"<p class='record-previous'><b>Still the previous file's record:</b> {esc(pending)} was not read "
                "(see the message above).</p>") if pending and pending != summary["file"] else ""
    artifacts = "<br>".join(esc(n) for n in summary.get("artifacts", [])) or "none found (mains hum, spikes, rail values)"
    rows = [
        _row("File", f"{esc(summary['file'])} ({upload_size_text(summary['size_bytes'])})"),
        _row("Read as", esc(summary["format"])),
        *decisions,
        _row("Channels", channels),
        _row("Rate", f"{summary['rate_Hz']:.6g} Hz"),
        _row("Duration", f"{summary['duration_s']:.3f} s ({summary['samples']:,} samples)"),
        _row("Plucks / segments", segments),
        _row("Cleaning", notes),
        _row("Artifacts", artifacts),
    ]
    return f"{previous}<table class='record-read' style='font-size:inherit;overflow-wrap:anywhere'>{''.join(rows)}</table>"


def loaded_html(name: str, taps: list) -> str:
    """The notice after *Load and calibrate*: where the record went (its taps: calibrated together
    in the "Several records" tab)."""
    if not name:
        return ""
    if taps:
        return alert_html("success", f"<b>{len(taps)} taps</b> of one beam at {len(taps)} amplitudes: loaded into the "
                          "<b>Several records</b> tab and <b>calibrated together</b> there (shared physics; each tap its "
                          "own initial state, offset and noise; it is calibrating now). The strongest tap is in the "
                          f"<b>Beam calibration</b> tab as <b>{html.escape(name)}</b> (the page went to Several records; come back "
                          "here for the next record).")
    return alert_html("success", f"Loaded into the beam calibration as <b>{html.escape(name)}</b>: the <b>Beam "
                      "calibration</b> tab calibrates it now (the page went there; come back here for the next record).")


class RecordView(TabView):
    """Bring your own record: read any file, describe the beam in a student's words, calibrate.

    Parameters
    ----------
    session : SessionState
        The browser session's state.
    """

    placeholder = "Open this tab to bring your own record."
    css_classes = ("record-view",)

    def __init__(self, **params) -> None:
        super().__init__(**params)
        self._record = self.session.record

    def frame(self) -> None:
        self._left = pn.Column(sizing_mode="stretch_width", styles=FLEX_ITEM_INPUTS, css_classes=["record-inputs"])
        self._main = pn.Column(sizing_mode="stretch_width", styles=FLEX_ITEM_MAIN, css_classes=["record-main"])
        self.layout[:] = [pn.FlexBox(self._left, self._main, flex_wrap="wrap", align_items="flex-start",
                                     sizing_mode="stretch_width")]

    def steps(self) -> list:
        return [self._build_status, self._build_file, self._build_form, self._build_plots, self._build_actions]

    # -- steps -------------------------------------------------------------------------------------
    def _build_status(self) -> None:
        r = self._record

        def data(read, described, loaded):
            record = read.record if read is not None else None
            return {"file": html.escape(read.file_name) if read is not None else "",
                    "described": int(described is not None), "modes": len(described.modes_Hz) if described else 0,
                    "loaded": html.escape(loaded),
                    # what was read, in SI units: the signal's largest magnitude, the rate (Hz), the duration (s)
                    "peak": f"{float(np.max(np.abs(record.output))):.6g}" if record is not None else "",
                    "rate": f"{record.rate_Hz:.6g}" if record is not None else "",
                    "duration": f"{record.duration_s:.6g}" if record is not None else "",
                    "signal": html.escape(record.output_column) if record is not None else ""}

        self._main.extend([
            Markdown(INTRO, sizing_mode="stretch_width", margin=(0, 10)),
            *run_status(r.run, "record-status", _STAGE_TEXT, error_css="record-error", data=data, bar=False,
                        depends=(r.param.read, r.param.described, r.param.loaded)),
            pn.Card(HTML(pn.bind(lambda read, _stage: read_html(read.summary() if read is not None else None,
                                                                r.dropped_name),
                                 r.param.read, r.run.param.stage),
                         sizing_mode="stretch_width", css_classes=["record-what"]),
                    title="What was read", collapsible=False, sizing_mode="stretch_width"),
        ])

    def _build_file(self) -> None:
        r = self._record
        seen: dict[str, object] = {}

        def dropped(event) -> None:  # a file finished uploading (a removal triggers this too: ignored)
            for name, data in event.new.items():
                if seen.get(name) is not data:
                    seen.clear()
                    seen[name] = data
                    r.upload(name, data)
                    return

        def new_dropper() -> pn.widgets.FileDropper:
            dropper = pn.widgets.FileDropper(
                multiple=False, max_file_size=str(MAX_UPLOAD_BYTES), chunk_size=UPLOAD_CHUNK_BYTES, previews=[],
                layout="compact", width=None, sizing_mode="stretch_width", margin=(0, 10, 5, 10),
                css_classes=["record-upload"])
            dropper.param.watch(dropped, "value")
            return dropper

        card = pn.Card(
            Markdown(f"Drop or browse **one record file** (at most {upload_size_text(MAX_UPLOAD_BYTES)}); no sidecar "
                     "needed: the form below describes the beam.", margin=(0, 10)),
            new_dropper(), title="1. Your record", collapsible=False, sizing_mode="stretch_width")

        def refused(event) -> None:
            """The upload widget says "Upload complete" once a file has arrived, whatever the reading finds:
            a file refused leaves a fresh widget (the message above says why)."""
            if event.new:
                seen.clear()
                card[1] = new_dropper()

        r.run.param.watch(refused, "error")
        self._left.append(card)
        self._left.append(self._reading_options())

    def _reading_options(self) -> pn.Card:
        """The reading options, collapsed until a file needs one (its error names them). The
        menus offer the file last dropped's own records and columns (``file_records``,
        ``file_columns``), never another file's."""
        r = self._record
        record = _select(r, "record_name", {"(the longest)": NOT_GIVEN}, "record-record-name")
        column = _select(r, "signal_column", {"(the most vibration power)": NOT_GIVEN}, "record-signal-column")

        def records(*_) -> None:
            record.options = {"(the longest)": NOT_GIVEN, **{f"{k}: {name}": name for k, name in
                                                              enumerate(r.file_records, start=1)}}
            record.value = r.record_name if r.record_name in record.options.values() else NOT_GIVEN
            record.visible = bool(r.file_records)

        def channels(*_) -> None:
            column.options = {"(the most vibration power)": NOT_GIVEN,
                              **{c: c.split(":", 1)[0] for c in r.file_columns if ":" in c and "(time" not in c}}
            column.value = r.signal_column if r.signal_column in column.options.values() else NOT_GIVEN

        records()
        channels()
        r.param.watch(records, "file_records")
        r.param.watch(channels, "file_columns")
        unit = _select(r, "signal_unit", {"(from the file)": NOT_GIVEN,
                                          **{display_unit(u): u for u in r.param.signal_unit.objects}},
                       "record-signal-unit")
        time_unit = _select(r, "time_unit", {"(from the file)": NOT_GIVEN, "s": "s", "ms": "ms", "µs": "us"},
                            "record-time-unit")
        rate = pn.widgets.FloatInput.from_param(r.param.rate_Hz, sizing_mode="stretch_width", placeholder="from the file",
                                                css_classes=["record-rate"])
        segment = pn.widgets.IntInput.from_param(r.param.segment, sizing_mode="stretch_width", placeholder="the strongest",
                                                 css_classes=["record-segment"])
        card = pn.Card(Markdown("Only when the file does not say: the error above names the option to give.",
                                margin=(0, 10)),
                       record, column, unit, rate, time_unit, segment, title="Reading options", collapsible=True,
                       collapsed=True, sizing_mode="stretch_width")

        opened_here = []  # opened for an error: closed again once a file is read

        def opened(event) -> None:
            if event.new and "Reading options" in event.new and card.collapsed:
                card.collapsed = False
                opened_here.append(True)

        def read(event) -> None:
            if opened_here and event.new is not None:
                opened_here.clear()
                card.collapsed = True

        r.run.param.watch(opened, "error")
        r.param.watch(read, "read")
        return card

    def _build_form(self) -> None:
        r = self._record
        numbers = {name: pn.widgets.FloatInput.from_param(r.param[name], sizing_mode="stretch_width",
                                                          css_classes=[f"record-{name.replace('_', '-')}"],
                                                          placeholder="empty")
                   for name in ("length_m", "width_m", "thickness_m", "sensor_position_m", sensor_mass.MASS.name)}
        for name, step in (("length_m", 0.01), ("width_m", 0.001), ("thickness_m", 0.0001), ("sensor_position_m", 0.01),
                           (sensor_mass.MASS.name, 0.01)):
            numbers[name].step = step
        material = _select(r, "material", {"(choose)": NOT_GIVEN, **{m: m for m in r.param.material.objects}},
                           "record-material")
        guess = pn.widgets.Checkbox.from_param(r.param.sensor_mass_approximate, sizing_mode="stretch_width")
        missing = Markdown(pn.bind(lambda *_: ("Still to fill: " + "; ".join(r.missing()) + ".") if r.missing()
                                   else "The beam is described.", *(r.param[n] for n in
                                                                   ("length_m", "width_m", "thickness_m", "material",
                                                                    "sensor_position_m"))),
                           margin=(0, 10), css_classes=["record-missing"])
        form_error = HTML(pn.bind(lambda e: alert_html("warning", html.escape(e)) if e else "", r.param.form_error),
                          sizing_mode="stretch_width", margin=(0, 10), css_classes=["record-form-error"])
        kept = HTML(pn.bind(lambda name: alert_html("warning", f"The beam below is the one described for <b>{html.escape(name)}"
                                                    "</b>: check it is this record's (any change confirms it).")
                            if name else "", r.param.beam_kept_from),
                    sizing_mode="stretch_width", margin=(0, 10), css_classes=["record-beam-kept"])
        self._left.append(pn.Card(
            kept, numbers["length_m"], numbers["width_m"], numbers["thickness_m"], material, numbers["sensor_position_m"],
            numbers[sensor_mass.MASS.name], guess, missing, form_error,
            title="2. Your beam", collapsible=False, sizing_mode="stretch_width"))

    def _build_plots(self) -> None:
        r = self._record
        self._sketch = BeamSketch()
        self._spectrum = SpectrumPlot()

        def sketch(*_):
            self._sketch.update(r.length_m, r.sensor_position_m, r.sensor_mass_kg)

        sketch()
        r.param.watch(sketch, ["length_m", "sensor_position_m", sensor_mass.MASS.name])

        def spectrum(*_):
            read = r.read
            if read is not None:
                self._spectrum.show_record(read.frequency_Hz, read.psd_db, read.peaks, read.signal_unit)
            self._spectrum.show_modes(r.described.modes_Hz if r.described is not None else ())

        spectrum()
        r.param.watch(spectrum, ["read", "described"])
        described = pn.bind(lambda d: d is not None, r.param.described)
        waiting = Markdown(pn.bind(lambda read, d: "" if d is not None else
                                   ("The spectrum appears as soon as the beam is described." if read is not None else
                                    "Drop a record, then describe the beam: its spectrum appears here."),
                                   r.param.read, r.param.described), margin=(0, 10), css_classes=["record-waiting"])
        summary = pn.Card(HTML(pn.bind(lambda d: f"<pre style='white-space:pre-wrap;font-size:14px'>"
                                                 f"{html.escape(d.summary)}</pre>" if d is not None else "",
                                       r.param.described), sizing_mode="stretch_width"),
                          title="The summary beam import prints", collapsible=True, collapsed=True,
                          sizing_mode="stretch_width", visible=described)
        self._main.extend([
            pn.pane.Bokeh(self._sketch.figure, sizing_mode="stretch_width", height=170),
            waiting,
            pn.Column(pn.pane.Bokeh(self._spectrum.figure, sizing_mode="stretch_width", height=330),
                      visible=described, sizing_mode="stretch_width", css_classes=["record-spectrum"]),
            summary,
        ])

    def _build_actions(self) -> None:
        r = self._record
        ready = pn.bind(lambda *_: not r.can_load(), r.param.described, r.param.loaded,
                        *(r.param[n] for n in ("length_m", "width_m", "thickness_m", "material", "sensor_position_m",
                                               sensor_mass.MASS.name, "sensor_mass_approximate")))
        load = pn.widgets.Button(label="Load and calibrate", color="primary", sizing_mode="stretch_width",
                                 disabled=ready, css_classes=["record-load"])
        def load_and_show(event) -> None:  # the calibration is shown where it runs: the page goes there
            if r.load() is not None:
                self.open_tab(JOINT_TAB if r.loaded_taps else BEAM_TAB)

        load.on_click(load_and_show)
        sidecar = pn.widgets.FileDownload(
            callback=lambda: io.StringIO(r.sidecar_text()), filename="beam.toml",
            label="Download the sidecar (TOML) for the command line", sizing_mode="stretch_width",
            disabled=pn.bind(lambda d: d is None, r.param.described), css_classes=["record-sidecar"])
        r.param.watch(lambda e: setattr(sidecar, "filename", r.sidecar_name()), "read")
        done = HTML(pn.bind(loaded_html, r.param.loaded, r.param.loaded_taps), sizing_mode="stretch_width",
                    margin=(0, 10), css_classes=["record-loaded"])
        self._left.append(pn.Card(
            load, done, sidecar,
            Markdown("Saved next to the record as its name with `.toml`, `beam calibrate FILE` finds it.",
                     margin=(0, 10)),
            title="3. Calibrate", collapsible=False, sizing_mode="stretch_width"))
