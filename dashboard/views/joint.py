"""The "Several records" view: records of one beam calibrated and diagnosed jointly.

A :class:`pn.viewable.Viewer` over ``session.joint`` (:class:`~dashboard.state.joint.JointState`);
nothing here calls ``beam`` directly. Choose records (bundled lab runs, the shipped real runs,
uploads of this session), the model and the per-record parameters, then

* *Calibrate jointly*: one panel per record (its data, the joint MAP model, the 95 % prediction
  band, the calibration window shaded; :class:`dashboard.plots.joint.RecordPanel`), the shared
  parameters' joint intervals beside each record's own, and per record the RMSE, the coverage
  and the natural frequencies of the joint model;
* *Diagnose jointly*: the candidate effects ranked by their joint evidence, each record's own
  Δ log evidence and its share of the joint gain (the record that decides), and the library's
  verdict.
"""

from __future__ import annotations

import html
import math

import panel as pn

from dashboard.jobs.joint import MATERIAL_LOG_EVIDENCE, MAX_RECORDS, SEPARATING_NATS
from dashboard.outputs.beam import effect_title, output_units, parameter_label, short_label
from dashboard.plots.joint import RecordPanel
from dashboard.state.joint import SAMPLING
from dashboard.state.run import BUSY
from dashboard.views.panes import (
    BUTTON_WRAP,
    HTML,
    Markdown,
    alert_html,
    run_status,
    three_columns,
)
from dashboard.views.tab import TabView

__all__ = ["JOINT_GUIDE", "JointView", "diagnosis_table_html", "interval_text", "records_table_html", "suggestion_html",
           "shared_table_html"]

_STAGE_TEXT = {
    "idle": "Choose two or more records of one beam, then press Calibrate jointly.",
    "queued": "Calibrating jointly…",
    "preview": "Joint preview (MAP + Laplace) shown; MCMC running…",
    "sampling": "Calibrating: each record alone first, then all together…",
    "final": "Joint calibration shown.",
    "error": "Could not calibrate these records jointly.",
}
_DIAG_TEXT = {
    "idle": "Press Diagnose jointly to rank the candidate effects on every record together.",
    "queued": "Diagnosing jointly…",
    "preview": "Candidates judged so far (more coming)…",
    "sampling": "Judging the candidate effects…",
    "final": "Joint diagnosis shown.",
    "error": "Could not diagnose these records jointly.",
}
#: Styles of the result tables (text at the views' size; numbers right-aligned).
TABLE_CSS = ("border-collapse:collapse;font-size:15px;width:100%;")
CELL = "padding:4px 8px;border-bottom:1px solid #dee2e6;text-align:right;"
HEAD = "padding:4px 8px;border-bottom:2px solid #adb5bd;text-align:right;vertical-align:bottom;"
FIRST = "text-align:left;"

JOINT_GUIDE = """**One beam, several records.** Measure the same strip more than once — again, at another free
length, with the sensor elsewhere — and fit **one** beam to all the records: its stiffness EI, the
masses, the clamp and the damping are **shared**; each record keeps its own noise, sensor offset and
start (and whatever you name under *Per record*, e.g. `clamp_stiffness` when the strip was re-clamped).

**Narrower intervals.** Every record adds information about the shared parameters. The table puts the
joint 95 % interval beside each record's own: with the two shipped runs of the 50 cm aluminium strip
(the defaults: 0–2 s, two modes, modal damping + sensor mass, Laplace), the sensor's mass is
4.077–4.091 g jointly against 4.079–4.094 g and 4.066–4.096 g alone. Narrower is not always *right*:
if two records' own intervals do not overlap, they disagree by more than their noise explains —
the model still misses something.

**Which record decides?** *Diagnose jointly* adds each candidate effect to the model and compares the
joint evidence (nats). Each record's column is what it says **alone**; the record with the largest
share of the joint gain decides. Two effects no record separates alone (a mass at the sensor or at
the tip lower f1 alike) may be told apart by records at different lengths: the verdict says so."""


def interval_text(s: dict | None) -> str:
    """``"4.084 (4.077–4.091)"``: the mean and the 95 % interval with enough digits to show the
    interval's width (two significant digits of it); ``"–"`` for None."""
    if s is None:
        return "–"
    mean, lo, hi = s["mean"], s["q025"], s["q975"]
    if not all(math.isfinite(v) for v in (mean, lo, hi)):
        return "–"
    width = abs(hi - lo)
    top = max(abs(mean), abs(lo), abs(hi), 1e-300)
    digits = 3 if width <= 0 else max(3, min(8, int(math.floor(math.log10(top))) - int(math.floor(math.log10(width))) + 2))
    return f"{mean:.{digits}g} ({lo:.{digits}g}–{hi:.{digits}g})"


def interval_html(s: dict | None) -> str:
    """The mean over the 95 % interval's reach from it, in a narrow cell: ``± h`` (h the half-width,
    two significant digits) when the interval is symmetric within a tenth of h, else ``−a +b``;
    the whole interval (:func:`interval_text`) in the tooltip."""
    text = interval_text(s)
    if "(" not in text:
        return text
    mean, lo, hi = s["mean"], s["q025"], s["q975"]
    below, above = mean - lo, hi - mean
    half = 0.5 * (hi - lo)
    reach = (f"± {half:.2g}" if abs(above - below) <= 0.1 * half else f"−{below:.2g} +{above:.2g}")
    return (f'<span title="{html.escape(text)}"><span style="white-space:nowrap">{text.split(" ", 1)[0]}</span><br>'
            f'<span style="white-space:nowrap">{reach}</span></span>')


def _width(s: dict | None) -> float:
    return math.nan if s is None else float(s["q975"] - s["q025"])


def shared_table_html(outcome) -> str:
    """The shared parameters: joint estimate and 95 % interval, each record's own beside it, and
    the joint interval's width over the narrowest record's (below 1: the joint interval is narrower)."""
    if outcome is None:
        return ""
    names = outcome.names
    unit = outcome.joint.records[0].setup.measurement.output_unit
    head = (f'<th style="{HEAD}{FIRST}">Shared parameter (unit)</th><th style="{HEAD}">Jointly, all {len(names)}</th>'
            + "".join(f'<th style="{HEAD}" title="{html.escape(n)}">Record {k + 1} alone</th>' for k, n in enumerate(names))
            + f'<th style="{HEAD}">Joint ÷ narrowest width</th>')
    rows = []
    for row in outcome.shared_rows():
        widths = [w for w in (_width(a) for a in row["alone"]) if math.isfinite(w) and w > 0]
        ratio = _width(row["joint"]) / min(widths) if widths else math.nan
        cells = "".join(f'<td style="{CELL}">{interval_html(a)}</td>' for a in row["alone"])
        rows.append(f'<tr data-name="{row["name"]}"><td style="{CELL}{FIRST}" title="{html.escape(parameter_label(row["name"], unit))}">'
                    f'{html.escape(short_label(row["name"], unit))}</td>'
                    f'<td style="{CELL}font-weight:600;">{interval_html(row["joint"])}</td>{cells}'
                    f'<td style="{CELL}">{"–" if not math.isfinite(ratio) else f"{ratio:.2f}"}</td></tr>')
    return (f'<div style="overflow-x:auto"><table class="joint-shared-table" style="{TABLE_CSS}"><thead><tr>{head}</tr></thead>'
            f'<tbody>{"".join(rows)}</tbody></table></div>'
            f'<p style="font-size:15px;margin:4px 0;">{records_key(names)}. Mean and the reach of the 95 % interval '
            "(hover a cell for the interval) of each parameter; the "
            "joint one uses every record, each record's own only itself (same model, window and modes).</p>")


def records_table_html(outcome) -> str:
    """Per record under the joint calibration (one column each): geometry, window, RMSE in and
    after the window, coverage of the 95 % band after it, the joint model's natural frequencies
    and the record's own parameters (those calibrated per record)."""
    if outcome is None:
        return ""
    u = output_units(outcome.views[0])
    rows: list[tuple[str, list[str]]] = [
        ("Free length (m)", []), ("Sensor position (m from the clamp)", []), ("Calibration window (s)", []),
        (f"RMSE in the window ({u.unit})", []), (f"RMSE held out ({u.unit})", []),
        ("Held-out samples inside the 95 % band (%)", []), ("Natural frequencies, joint model (Hz)", []),
        (f"Noise sd σ ({u.unit})", [])]
    own_names = list(dict.fromkeys(n for r in outcome.records for n in r["parameters"]))
    rows += [(f"Its own {short_label(n, outcome.records[0]['output_unit'])}", []) for n in own_names]
    for view, record in zip(outcome.views, outcome.records):
        g = view.setup.measurement.geometry
        lo, hi = record["window_s"]
        coverage = record["coverage95_prediction"]
        noise = record["noise_sd"]["mean"] if record.get("noise_sd") else math.nan
        values = [f"{g.length_m:.3g}", f"{g.sensor_position_m:.3g}", f"{lo:g}–{hi:g}",
                  _fmt(u.scale * record["rmse_calibration"]), _fmt(u.scale * record["rmse_prediction"]),
                  "–" if not math.isfinite(coverage) else f"{100 * coverage:.1f}",
                  ", ".join(f"{f:.4g}" for f in record["frequencies_Hz"]), _fmt(u.scale * noise)]
        values += [interval_text(record["parameters"].get(n)) for n in own_names]
        for (_, cells), value in zip(rows, values):
            cells.append(value)
    head = f'<th style="{HEAD}{FIRST}">Record</th>' + "".join(
        f'<th style="{HEAD}">{k + 1}. {html.escape(n)}</th>' for k, n in enumerate(outcome.names))
    body = "".join(f'<tr><td style="{CELL}{FIRST}">{html.escape(label)}</td>'
                   + "".join(f'<td style="{CELL}">{html.escape(c)}</td>' for c in cells) + "</tr>"
                   for label, cells in rows)
    return (f'<div style="overflow-x:auto"><table class="joint-records-table" style="{TABLE_CSS}"><thead><tr>{head}</tr></thead>'
            f"<tbody>{body}</tbody></table></div>")


def _fmt(value: float) -> str:
    return "–" if not math.isfinite(value) else f"{value:.3g}"


def records_key(names: list[str]) -> str:
    """``"Record 1: adxl_50cm_114655, record 2: ..."`` (escaped HTML)."""
    return ", ".join(f"{'Record' if k == 0 else 'record'} {k + 1}: {html.escape(n)}" for k, n in enumerate(names))


def deciding_record(candidate) -> int | None:
    """Index of the record with the largest share of ``candidate``'s joint gain (its log-likelihood
    change between the joint fits, nats); None when the candidate gains nothing jointly."""
    shares = candidate.records_delta_log_likelihood
    if not shares or candidate.delta_log_evidence is None or candidate.delta_log_evidence <= 0:
        return None
    return max(range(len(shares)), key=lambda i: shares[i])


def suggestion_html(diagnosis) -> str:
    """Which record to take next (:func:`beam.discovery.suggest.next_record`), once the joint
    diagnosis has ended; '' before."""
    suggestion = None if diagnosis is None else diagnosis.suggestion
    if not suggestion:
        return ""
    return alert_html("warning" if suggestion.get("needed") else "secondary",
                      "<b>Which record to take next:</b> " + html.escape(suggestion["words"]))


def diagnosis_table_html(diagnosis) -> str:
    """The candidates ranked by their joint Δ log evidence, each record's Δ alone, and the record
    that decides (largest share of the joint gain)."""
    if diagnosis is None:
        return ""
    names = diagnosis.names
    head = (f'<th style="{HEAD}{FIRST}">Effect added</th><th style="{HEAD}">Jointly: Δ log evidence (nats)</th>'
            + "".join(f'<th style="{HEAD}" title="{html.escape(n)}">Record {k + 1} alone (nats)</th>'
                      for k, n in enumerate(names))
            + f'<th style="{HEAD}">Decided by record</th>')
    rows = []
    for c in diagnosis.candidates:
        joint = "failed: " + html.escape(c.error or "") if c.delta_log_evidence is None else f"{c.delta_log_evidence:+,.1f}"
        alone = c.records_delta_log_evidence or [math.nan] * len(names)
        weight = "font-weight:600;" if c.material else ""
        decides = deciding_record(c)
        rows.append(f'<tr data-effect="{c.effect}"><td style="{CELL}{FIRST}{weight}">{html.escape(effect_title(c.effect))}</td>'
                    f'<td style="{CELL}{weight}">{joint}</td>'
                    + "".join(f'<td style="{CELL}">{"–" if not math.isfinite(v) else f"{v:+,.1f}"}</td>' for v in alone)
                    + f'<td style="{CELL}">{"–" if decides is None else decides + 1}</td></tr>')
    return (f'<div style="overflow-x:auto"><table class="joint-diagnosis-table" style="{TABLE_CSS}"><thead><tr>{head}</tr>'
            f'</thead><tbody>{"".join(rows)}</tbody></table></div>'
            f'<p style="font-size:15px;margin:4px 0;">{records_key(names)}. Δ log evidence: how much better the model '
            f"explains the data with the effect added (nats); {MATERIAL_LOG_EVIDENCE:g} or more jointly is material (bold). "
            f"A record alone tells two effects apart when their Δ differ by {SEPARATING_NATS:g} nats or more. "
            "Decided by: the record with the largest share of the joint gain.</p>")


class JointView(TabView):
    """Calibrate one beam on several records at once, and rank the missing effects on all of them.

    Parameters
    ----------
    session : SessionState
        The browser session's state.

    Built when its tab is opened; nothing runs before a button is pressed. :attr:`panels` holds
    the per-record figures drawn so far (one per record of the result shown).
    """

    opens_beam = True
    placeholder = "Open this tab to calibrate several records jointly."

    def __init__(self, **params) -> None:
        super().__init__(**params)
        self._joint = self.session.joint
        self.panels: list[RecordPanel] = []

    def frame(self) -> None:
        self._left, self._centre, self._right, row = three_columns("joint")
        self.layout[:] = [row]

    def steps(self) -> list:
        return [self._build_status, self._build_results, self._build_inputs, self._build_side]

    # -- the steps of the build ------------------------------------------------------------------
    def _status(self, run, css: str, texts: dict) -> list:
        st = self._joint

        def data(result, diagnosis):
            return {"records": len(result.names) if result is not None else 0,
                    "panels": len(self.panels), "preview": int(result is None or result.joint.is_preview),
                    "candidates": len(diagnosis.candidates) if diagnosis is not None else 0}

        return run_status(run, css, texts, data=data, depends=(st.param.result, st.param.diagnosis))

    def _build_status(self) -> None:
        self._centre.extend(self._status(self._joint.run, "joint-status", _STAGE_TEXT))

    def _build_results(self) -> None:
        st = self._joint
        p = st.param
        self._shared = HTML(pn.bind(shared_table_html, p.result), sizing_mode="stretch_width", margin=(5, 10),
                            css_classes=["joint-shared"])
        self._records = HTML(pn.bind(records_table_html, p.result), sizing_mode="stretch_width", margin=(5, 10),
                             css_classes=["joint-records"])
        self._panel_column = pn.Column(sizing_mode="stretch_width", css_classes=["joint-panels"])
        self._centre.extend([Markdown("### The shared parameters", margin=(10, 10, 0, 10)), self._shared,
                             Markdown("### Each record under the joint calibration", margin=(10, 10, 0, 10)),
                             self._records, self._panel_column])
        st.param.watch(self._draw_panels, "result")
        self._draw_panels()
        verdict = HTML(pn.bind(lambda d: "" if d is None else alert_html(
            "success" if d.missing is not None else "secondary", html.escape(d.verdict())), p.diagnosis),
            sizing_mode="stretch_width", margin=(5, 10), css_classes=["joint-verdict"])
        table = HTML(pn.bind(diagnosis_table_html, p.diagnosis), sizing_mode="stretch_width", margin=(5, 10),
                     css_classes=["joint-diagnosis"])
        next_record = HTML(pn.bind(suggestion_html, p.diagnosis), sizing_mode="stretch_width", margin=(5, 10),
                           css_classes=["joint-suggestion"])
        self._centre.extend([Markdown("### Which effect is missing, judged on every record", margin=(10, 10, 0, 10)),
                             *self._status(st.diag_run, "joint-diag-status", _DIAG_TEXT), verdict, table,
                             next_record])

    def _draw_panels(self, *_) -> None:
        outcome = self._joint.result
        if outcome is None:
            return
        views = outcome.views
        while len(self.panels) < len(views):
            self.panels.append(RecordPanel(len(self.panels)))
        for k, (panel, view) in enumerate(zip(self.panels, views)):
            g = view.setup.measurement.geometry
            panel.show(view, f"{k + 1}. {view.setup.measurement.name}: L = {g.length_m:.3g} m")
        panes = [pn.pane.Bokeh(panel.figure, sizing_mode="stretch_width", height=300) for panel in self.panels[:len(views)]]
        self._panel_column.objects = panes

    def _build_inputs(self) -> None:
        st = self._joint
        records = pn.widgets.CheckBoxGroup(inline=False, sizing_mode="stretch_width", css_classes=["joint-records-choice"])

        def sync(*_):
            records.options = st.record_options()
            records.value = list(st.records)

        sync()
        st.param.watch(sync, ["records"])
        st.beam.param.watch(sync, ["uploads"])
        records.param.watch(lambda e: setattr(st, "records", list(e.new)) if list(e.new) != list(st.records) else None,
                            "value")
        window = pn.widgets.RangeSlider.from_param(st.param.window_s, name="Calibration window (s)", start=0.0, end=10.0, step=0.05, format="0.00",
                                                   sizing_mode="stretch_width", css_classes=["joint-window"])

        def bounds(*_):
            ends = [float(m.time_s[-1]) for m in st.measurements()] or [10.0]
            window.param.update(end=max(ends))

        bounds()
        st.param.watch(bounds, "records")
        modes = pn.widgets.IntSlider.from_param(st.param.modes, name="Number of modes", sizing_mode="stretch_width",
                                                css_classes=["joint-modes"])
        effects = pn.widgets.CheckBoxGroup(options=st.effect_options(), value=list(st.effects), inline=False,
                                           sizing_mode="stretch_width", css_classes=["joint-effects"])
        effects.param.watch(lambda e: setattr(st, "effects", list(e.new)) if list(e.new) != list(st.effects) else None,
                            "value")
        per_record = pn.widgets.TextInput.from_param(st.param.per_record, sizing_mode="stretch_width",
                                                     placeholder="none: every physical parameter shared",
                                                     css_classes=["joint-per-record"])
        sampling = pn.widgets.Select(label="Joint posterior", options=SAMPLING, value=st.sampling,
                                     sizing_mode="stretch_width", css_classes=["joint-sampling"])
        sampling.param.watch(lambda e: setattr(st, "sampling", e.new), "value")
        calibrate = pn.widgets.Button(label="Calibrate jointly", color="primary", sizing_mode="stretch_width",
                                      css_classes=["joint-calibrate"], stylesheets=BUTTON_WRAP,
                                      disabled=pn.bind(lambda r: not r, st.param.records))
        diagnose = pn.widgets.Button(label="Diagnose jointly", color="primary", sizing_mode="stretch_width",
                                     css_classes=["joint-diagnose"], stylesheets=BUTTON_WRAP,
                                     disabled=pn.bind(lambda r: not r, st.param.records))
        busy = BUSY
        cancel = pn.widgets.Button(label="Cancel", sizing_mode="stretch_width", css_classes=["joint-cancel"],
                                   disabled=pn.bind(lambda a, b: a not in busy and b not in busy,
                                                    st.run.param.stage, st.diag_run.param.stage))
        calibrate.on_click(lambda e: st.calibrate())
        diagnose.on_click(lambda e: st.diagnose())
        cancel.on_click(lambda e: st.cancel())
        self._left.append(pn.Card(
            Markdown(f"**Records of one beam** (up to {MAX_RECORDS}; uploads from the *Beam calibration* and "
                     "*Your record* tabs appear here too)", margin=(0, 10)), records,
            window, Markdown("The same window on every record; the rest of each record is held out.", margin=(0, 10)),
            modes,
            Markdown("**Effects in the model** (besides the beam's stiffness EI)", margin=(5, 10, 0, 10)), effects,
            per_record, sampling, calibrate, diagnose, cancel,
            title="Several records", collapsible=False, sizing_mode="stretch_width"))

    def _build_side(self) -> None:
        self._right.append(pn.Card(Markdown(JOINT_GUIDE, sizing_mode="stretch_width"), title="For the class",
                                   collapsible=True, collapsed=False, sizing_mode="stretch_width",
                                   css_classes=["joint-class-guide"]))
