"""The "Diagnosis" view: where the beam model fails, which effect is missing, and the error ladder.

A :class:`pn.viewable.Viewer` over ``session.diagnosis``
(:class:`~dashboard.state.beam.DiagnosisState`), which diagnoses the beam view's current dataset,
window, modes and effects. Each ranked candidate has an **Add** button: it puts the effect into
the beam view's model, which re-calibrates with full MCMC, and the result becomes a new rung of
the error ladder.
"""

from __future__ import annotations

import html
import math

import pandas as pd
import panel as pn

from beam.discovery.averaged import AVERAGED, FULL
from beam.discovery.judgement import ORDER_WORDS, STATUS_WORDS
from beam.discovery.ranking import judgement_of
from beam.discovery.report import p_words
from beam.residuals import difference_words
from dashboard.outputs import beam as bs
from dashboard.outputs.beam import (
    effect_title,
    evidence_words,
    fmt_pct,
    fmt_value,
    parameter_label,
)
from dashboard.plots.diagnosis import DiagnosisPlots
from dashboard.state.beam import NO_ANSWER
from dashboard.state.run import BUSY
from dashboard.views.panes import (
    BUTTON_WRAP,
    FLEX_ITEM_GUIDE,
    FLEX_ITEM_MAIN,
    HTML,
    DataFrame,
    Markdown,
    alert_html,
    diagnosis_download,
    run_status,
)
from dashboard.views.tab import TabView
from dashboard.views.texts import DIAGNOSIS_GUIDE

__all__ = ["DiagnosisView", "ladder_table", "modes_table"]

_STAGE_TEXT = {
    "idle": "Open this tab to diagnose the beam view's model.",
    "queued": "Diagnosing…",
    "preview": "Residual diagnostics shown; ranking the candidate effects…",
    "sampling": "Diagnosing…",
    "final": "Diagnosis complete.",
    "error": "Could not diagnose this model.",
}


def modes_table(diagnosis) -> pd.DataFrame:
    """Identified (data) against model modes: frequencies (Hz), damping ratios (%), and how the
    measured value differs from the model's in words, by the one sign convention of the command
    line and the JSON (:data:`beam.residuals.DIFFERENCE_CONVENTION`: "17.5 % higher" is
    ``frequency_error_pct`` = +17.5, the measured frequency above the model's)."""
    if diagnosis is None or not diagnosis.residuals.comparison:
        return pd.DataFrame({"note": ["no modal identification on this record (no free decay)"]})

    def f(v, scale=1.0, fmt="{:.4g}"):
        return fmt.format(v * scale) if math.isfinite(v) else "–"

    return pd.DataFrame([{
        "mode": m.mode, "measured f (Hz)": f(m.frequency_data_Hz), "model f (Hz)": f(m.frequency_model_Hz),
        "measured f vs model": (difference_words(m.frequency_error_pct, 1) if m.matched or not m.note
                                else m.note if not m.resolved else f"not seen: {m.note}"),
        "measured damping ζ (%)": f(m.damping_data, 100, "{:.2g}"),
        "model ζ (%)": f(m.damping_model, 100, "{:.2g}"), "measured ζ vs model": difference_words(m.damping_error_pct, 0),
    } for m in diagnosis.residuals.comparison]).set_index("mode")


def ladder_table(rungs: list[dict]) -> pd.DataFrame:
    """The error ladder as a table with units."""
    if not rungs:
        return pd.DataFrame()
    unit = rungs[-1]["unit"]  # one record per ladder: one unit
    return pd.DataFrame([{
        "step": r["rung"], "added": "(starting model)" if r["rung"] == 0 else effect_title(r["added"]),
        f"held-out error ({unit})": fmt_value(r["rmse_prediction"]), "in the 95 % band (%)": fmt_pct(r["coverage95_pct"]),
        "posterior": "full (MCMC)" if r["mcmc"] else "preview",
    } for r in rungs]).set_index("step")


class DiagnosisView(TabView):
    """Residual diagnostics, ranked missing-physics candidates with Add buttons, error ladder.

    Parameters
    ----------
    session : SessionState
        The browser session's state.

    Built when its tab is first opened (as the beam view), or ahead by :meth:`prebuild`.
    Attributes read by the tests: :attr:`plots` (the diagnosis figures) and :attr:`candidates`
    (the column of candidate effects with their Add buttons).
    """

    opens_beam = True
    placeholder = "Open this tab to diagnose the beam view's model."

    def __init__(self, **params) -> None:
        super().__init__(**params)
        self._diag = self.session.diagnosis
        self.plots: DiagnosisPlots | None = None
        self.candidates: pn.Column | None = None

    def prebuild(self) -> None:
        """Build the page before the tab is opened, without diagnosing (the app calls it once the
        beam view's first calibration is final: the server is idle then)."""
        self.build()

    def frame(self) -> None:
        self.layout[0].object = "**Diagnosing…** (the residuals come first)"
        self._main = pn.Column(sizing_mode="stretch_width", min_height=600, styles=FLEX_ITEM_MAIN,
                               css_classes=["diag-main"])
        self._side = pn.Column(sizing_mode="stretch_width", styles=FLEX_ITEM_GUIDE, css_classes=["diag-guide"])
        self._page = pn.FlexBox(self._main, self._side, flex_wrap="wrap", align_items="flex-start",
                                sizing_mode="stretch_width")

    def steps(self) -> list:
        # The pieces are made in steps off the page and put on it at once, with the diagnosis's
        # first stage (its residual report, 2-4 s after the request) when it is on its way: each
        # piece added to the shown page, and each first drawing of the five plots and the
        # candidates' rows on a page already shown, made the browser lay out and repaint the
        # whole page and every plot there (0.3-1.7 s of chromium's CPU each; JavaScript profile
        # of a diagnosis of lab_run_1, on the two cores the diagnosis's worker processes need).
        return [self._build_figures, self._build_head,
                lambda: [step() for step in (self._build_ladder, self._build_residuals, self._build_side)],
                self._attach_when_ready]

    def start(self) -> None:
        """Diagnose the beam view's model when the tab is opened and the diagnosis shown is not of it
        (the first time, and after the student moved on to another record or model), unless one is
        on its way (running, or waiting for an effect being added)."""
        d = self._diag
        if d.requested == 0 or (not d.is_current() and not d.run.busy and not d.adding):
            d.request()

    def _attach_when_ready(self) -> None:
        """Put the built page in place now if there is something to show, else when there is.

        Not before: a page added to the document is built, laid out and painted by the browser at
        once, and again when the diagnosis fills it. Added hidden (bokeh ``visible``) and shown
        later, it cost more, not less: showing it laid out and painted every plot anew (renderer
        main-thread CPU over a diagnosis of lab_run_1 2.7-2.9 -> 4.3 s)."""
        d = self._diag
        if self._ready():
            self.layout[:] = [self._page]
            return

        def attach(*_events) -> None:
            if self.layout.objects[0] is not self._page and self._ready():
                d.param.unwatch(watcher)
                d.run.param.unwatch(run_watcher)
                self.layout[:] = [self._page]

        watcher = d.param.watch(attach, ["diagnosis"])
        run_watcher = d.run.param.watch(attach, ["stage"])

    def _ready(self) -> bool:
        """Whether the page has something to show: a diagnosis, or its error, or the news that it was
        stopped (not when the page was built ahead of the first request, see :meth:`prebuild`)."""
        d = self._diag
        return d.diagnosis is not None or (d.requested > 0 and d.stage not in ("queued", "sampling"))

    # -- the steps of the build ------------------------------------------------------------------
    def _build_figures(self) -> None:  # the plots alone (shown by the following steps)
        d = self._diag
        self.plots = DiagnosisPlots()
        self.plots.update(d.diagnosis)
        self.plots.update_ladder(d.ladder)
        d.param.watch(lambda e: self.plots.update(e.new), "diagnosis")
        d.param.watch(lambda e: self.plots.update_ladder(e.new), "ladder")
        noise = lambda answer: None if answer is None else answer.get("noise_m")
        self.plots.show_true_noise(noise(d.answer))
        d.param.watch(lambda e: self.plots.show_true_noise(noise(e.new)), "answer")

    def _build_head(self) -> None:
        d, beam = self._diag, self.session.beam
        self.candidates = pn.Column(sizing_mode="stretch_width", css_classes=["diag-candidates"])
        d.param.watch(self._show_candidates, ["diagnosis", "adding"])
        beam.param.watch(self._show_candidates, "effects")
        beam.run.param.watch(self._show_candidates, "requested")  # another record or model: the Add buttons go grey
        run = pn.widgets.Button(label="Diagnose the current model", color="primary", css_classes=["diag-run"])
        run.on_click(lambda e: d.request())
        depends = (d.param.diagnosis, d.run.param.shown_subject, beam.run.param.requested)
        stale = HTML(pn.bind(self._stale, *depends, d.run.param.stage), sizing_mode="stretch_width", margin=(0, 10),
                     css_classes=["diag-stale"])
        verdict = Markdown(pn.bind(self._verdict, *depends, d.param.ladder), css_classes=["diag-verdict"], sizing_mode="stretch_width",
                           styles={"font-size": "13pt"})
        self._show_candidates()
        findings = pn.Column(verdict, Markdown(f"### Candidate effects (best first: {ORDER_WORDS})", margin=(0, 10)), self.candidates,
                             sizing_mode="stretch_width", css_classes=["diag-findings"])
        # another record's or model's findings are greyed (Add disabled: _show_candidates)
        d.param.watch(lambda e: self._grey(findings), "diagnosis")
        beam.run.param.watch(lambda e: self._grey(findings), "requested")
        self._grey(findings)
        self._main.extend([*self._status(), pn.Row(run, sizing_mode="stretch_width"), stale, findings])

    def _grey(self, findings: pn.Column) -> None:
        """The findings shown at full strength when they are the current record's and model's, greyed when not."""
        current = self._diag.diagnosis is None or self._diag.is_current()
        styles = {"opacity": "1" if current else "0.5"}  # (an emptied style is not taken off in the browser)
        if findings.styles != styles:
            findings.styles = styles

    def _verdict(self, diagnosis, record: str, _requested, ladder=None) -> str:
        """The verdict, under a line naming the record and model it is about (partial or final)."""
        if diagnosis is None:
            return ""
        spec = diagnosis.key.spec
        window = f"window {spec.window[0]:g}–{spec.window[1]:g} s" if spec.window else "default window"
        model = ", ".join(effect_title(e) for e in spec.effects) or "the bare beam"
        head = f"**Diagnosis of {record or 'this record'}** ({window}, {spec.modes} modes; model: {model})"
        return f"{head}\n\n{bs.verdict_text(diagnosis, ladder)}"

    @staticmethod
    def _plot(dmap, **kw) -> pn.pane.HoloViews:
        # not linked: Panel links the axes of panes whose dimensions share a name, and the spectrum's
        # frequency axis (0-500 Hz) became the backbone's frequency axis (its points on the edge)
        return pn.pane.HoloViews(dmap, sizing_mode="stretch_width", height=280, backend="bokeh", linked_axes=False,
                                 **kw)

    @staticmethod
    def _pair(*items, basis_px: int = 380) -> pn.FlexBox:
        """Two panes side by side when each has ``basis_px`` of room, one above the other when not."""
        for item in items:
            item.styles = {"flex": f"1 1 {basis_px}px", "min-width": "0"}
        return pn.FlexBox(*items, flex_wrap="wrap", align_items="flex-start", sizing_mode="stretch_width")

    def _build_ladder(self) -> None:
        table = DataFrame(pn.bind(ladder_table, self._diag.param.ladder), escape=True,
                                  sizing_mode="stretch_width", css_classes=["diag-ladder-table"])
        self._main.extend([
            Markdown("### Error ladder: one step per effect added", margin=(0, 10)),
            self._pair(table, self._plot(self.plots.ladder))])

    def _build_residuals(self) -> None:
        """Where the model fails: the residual over time, the spectra with the autocorrelation, and
        the modes with the backbone, one tab each (only the open one is drawn: ``dynamic``).

        Why tabs: each pair of plots drawn with the page cost the browser 0.3-0.5 s and the server
        0.2-0.3 s of CPU while the diagnosis's fits ran on the same two cores (diagnosis of
        lab_run_1 at 7 modes, `/proc`, two runs each: complete 7.2-7.9 s with both pairs, 6.7-7.1 s
        without either one); a tab is drawn when it is opened."""
        p, d = self.plots, self._diag
        whiteness = Markdown(pn.bind(_whiteness_text, d.param.diagnosis), margin=(0, 10), sizing_mode="stretch_width",
                             css_classes=["diag-whiteness"])
        spectra = self._pair(self._plot(p.spectrum), pn.Column(self._plot(p.acf), whiteness, sizing_mode="stretch_width"))
        modes = self._pair(
            pn.Column(Markdown("**Modes: measured in the free decay vs the model** (“higher”, “lower”: the measured "
                               "value against the model's)"),
                      DataFrame(pn.bind(modes_table, d.param.diagnosis), escape=True,
                                sizing_mode="stretch_width", css_classes=["diag-modes-table"]),
                      sizing_mode="stretch_width"),
            pn.Column(self._plot(p.backbone), Markdown(pn.bind(_backbone_text, d.param.diagnosis),
                                                       margin=(0, 10), sizing_mode="stretch_width"),
                      sizing_mode="stretch_width"), basis_px=560)  # the modes table has seven columns
        tabs = pn.Tabs(("Residual over time", self._plot(p.residual)), ("Spectra and whiteness", spectra),
                       ("Modes and backbone", modes), dynamic=True, sizing_mode="stretch_width",
                       css_classes=["diag-residual-tabs"])
        self._main.extend([Markdown("### Where the model fails", margin=(0, 10)), tabs])

    def _build_side(self) -> None:
        self._side.extend([pn.Card(Markdown(DIAGNOSIS_GUIDE, sizing_mode="stretch_width"), title="For the class",
                                   collapsible=True, collapsed=False, sizing_mode="stretch_width",
                                   css_classes=["diag-class-guide"]), self._reveal(), diagnosis_download(self._diag)])

    def _stale(self, diagnosis, record: str, _requested, stage: str) -> str:
        """A notice over findings that are not of the beam view's record and model (empty when they are)."""
        d = self._diag
        if diagnosis is None or d.is_current():
            return ""
        now = self.session.beam.record_name()
        what = (f"not of <b>{html.escape(now)}</b>, the record the <i>Beam calibration</i> tab shows now"
                if now != record else "not of the window, modes or effects the <i>Beam calibration</i> tab has now")
        then = ("The diagnosis of the current model is on its way: its first results replace these."
                if stage in BUSY else "Press <b>Diagnose the current model</b> (or open this tab again) to diagnose it.")
        return alert_html("warning", f"This diagnosis is of <b>{html.escape(record)}</b>, {what}: its verdict and "
                                     f"candidates are greyed and <i>Add</i> is off. {then}")

    def _status(self) -> list:
        d = self._diag

        def data(ladder, adding, diagnosis, record, _requested):
            last = ladder[-1]["rmse_prediction"] if ladder else float("nan")
            return {"ladder_n": len(ladder), "ladder_rmse": f"{last:.6g}",
                    "ladder_unit": ladder[-1]["unit"] if ladder else "", "adding": adding,
                    "record": html.escape(record), "current": int(diagnosis is not None and d.is_current())}

        def text(stage, ladder, adding, *_):
            if adding and stage in BUSY:
                return f"Adding {effect_title(adding)}: re-calibrating the model, then diagnosing it again…"
            return _STAGE_TEXT.get(stage, stage)

        return run_status(d.run, "diag-status", _STAGE_TEXT, error_css="diag-error", data=data, text=text,
                          depends=(d.param.ladder, d.param.adding, d.param.diagnosis, d.run.param.shown_subject,
                                   self.session.beam.run.param.requested))

    def _show_candidates(self, *_) -> None:
        """The candidates' rows: best first once every candidate is ranked; while they are being
        ranked, one row per candidate in a fixed order, whose text and button state change in place.

        Why: each time the rows were replaced (after every ranked candidate), the browser laid out
        the page again and repainted every plot, ~1 s of chromium's CPU each (JavaScript profile
        of a diagnosis of lab_run_1: 13 of its 15 busy seconds under Panel's ``update_children``),
        on the cores the diagnosis's worker processes share. A text change costs ~1 ms; the rows
        are rebuilt only when the set of candidates changes and once at the end (rank order and
        the green of the material ones, a class change, which re-lays out the page as well).
        """
        d, beam = self._diag, self.session.beam
        diagnosis = d.diagnosis
        if diagnosis is None:
            if self.candidates.objects:  # no change sent for an empty list (the page may be prebuilt and hidden)
                self.candidates[:] = []
            self._rows, self._rows_key = {}, None
            return
        if _ and getattr(_[0], "name", "") in ("adding", "effects", "requested") and d.requested > d.shown:
            return  # a diagnosis of the new model is on its way and replaces the rows: no repaint for this
        u = bs.output_units(diagnosis)
        current = d.is_current()  # another record's or model's candidates cannot be added to this one
        ranked = {c.effect: c for c in diagnosis.candidates}
        names = [c.effect for c in diagnosis.candidates] + list(diagnosis.pending)
        done = not diagnosis.pending
        states = {}
        for effect in names:
            c = ranked.get(effect)
            present = effect in beam.effects
            title = effect_title(effect)
            # the Add buttons are enabled when all are ranked (the rows are remade then): a
            # button's change re-renders it and lays out the whole page (~0.2 s of chromium each)
            states[effect] = (f"Add {title}" if not present else f"{title} is in the model",
                              not done or present or bool(d.adding) or not current,
                              self._candidate_text(c, diagnosis, u) if c is not None else f"**{title}**<br>*being ranked…*")
        rows = getattr(self, "_rows", {})
        # rank order and colours once all are ranked; a fixed order before
        key = (tuple(names), tuple(ranked[e].material for e in names)) if done else frozenset(names)
        buttons_changed = sum((rows[e][1].label, rows[e][1].disabled) != states[e][:2] for e in names if e in rows)
        if key != getattr(self, "_rows_key", None) or buttons_changed > 1:  # remade at once, not button by button
            rows = {e: self._candidate_row(e, ranked.get(e), done, *states[e]) for e in names}
            self._rows, self._rows_key = rows, key
            self.candidates[:] = [row for row, _, _ in rows.values()]
            return
        for effect, (_, button, text) in rows.items():
            label, disabled, words = states[effect]
            if button.label != label:
                button.label = label
            if button.disabled != disabled:
                button.disabled = disabled
            if text.object != words:
                text.object = words

    def _candidate_row(self, effect: str, candidate, done: bool, label: str, disabled: bool, words: str):
        """(row, Add button, text) of one candidate; green when it is material and all are ranked."""
        button = pn.widgets.Button(label=label, width=230, stylesheets=BUTTON_WRAP,
                                   color="success" if done and candidate is not None and candidate.material else "default",
                                   disabled=disabled, css_classes=[f"diag-add-{effect}"])
        button.on_click(lambda e: self._diag.add(effect))
        text = Markdown(words, sizing_mode="stretch_width", margin=(0, 10))
        return pn.Row(button, text, sizing_mode="stretch_width"), button, text

    @staticmethod
    def _candidate_text(c, diagnosis, u) -> str:
        """A candidate's row: the report's decision on it (its judgement: the one rule of
        :func:`beam.discovery.judgement.judge`, never re-derived here), its errors, its evidence
        (worded as odds for the effect only when it is named missing), its explanation and parameters."""
        title = effect_title(c.effect)
        judgement = judgement_of(c, diagnosis.base)
        params = "; ".join(f"{_parameter_words(n, u.si_unit)} = {s['mean']:.3g}" for n, s in c.parameters.items())
        if judgement.supports:
            evidence = evidence_words(c.delta_log_evidence)
        elif judgement.status == "fails_after_window":
            evidence = f"{c.delta_log_evidence:+.1f} nats inside the calibration window only, not borne out on held-out data"
        elif math.isfinite(c.delta_log_evidence):
            evidence = f"{c.delta_log_evidence:+.1f} nats, not named missing ({STATUS_WORDS[judgement.status]})"
        else:
            evidence = "fit failed"
        head = " — missing" if judgement.material else f" — {STATUS_WORDS[judgement.status]}"
        if getattr(c, "source", FULL) == AVERAGED:  # judged on the record's curves: no time-domain error yet
            return (f"**{title}**{head} <small>(averaged form)</small><br>"
                    f"{judgement.judged_label} {judgement.judged_after:.2g}, the starting model's "
                    f"{judgement.judged_before:.2g}; evidence "
                    f"<span title='{bs.GLOSSES['log evidence']}'>{evidence}</span> of the curves"
                    f"<br><small>{c.explanation}{' — ' + params if params else ''}</small>")
        return (f"**{title}**{head}<br>"
                f"{_errors_words(c, diagnosis, u)}, "
                f"{100 * c.coverage95_prediction:.0f} % in the band; evidence "
                f"<span title='{bs.GLOSSES['log evidence']}'>{evidence}</span>"
                f"<br><small>{c.explanation}{' — ' + params if params else ''}</small>")

    def _reveal(self) -> pn.Card:
        d = self._diag
        button = pn.widgets.Button(label="Reveal the hidden effect", color="warning", css_classes=["diag-reveal"],
                                   stylesheets=BUTTON_WRAP,
                                   disabled=pn.bind(lambda name: not d.has_answer(), self.session.beam.param.dataset))
        button.on_click(lambda e: d.reveal())

        def text(answer, dataset):
            if not d.has_answer():
                return NO_ANSWER
            if answer is None:
                return "Bundled datasets only: shows the effects and parameters the record was simulated with."
            params = "<br>".join(f"{parameter_label(k)}: {v:.4g}" for k, v in answer["parameters"].items())
            noise = (f"<br>Sensor noise sd: {fmt_value(1e6 * answer['noise_m'])} µm (green dotted lines on the residual)"
                     if answer.get("noise_m") is not None else "")
            return (f"**Simulated with:** {', '.join(effect_title(e) for e in answer['effects'])}<br>{params}{noise}"
                    "<br>The *Parameters* tab of the beam view sets them beside the posterior.")

        return pn.Card(button, Markdown(pn.bind(text, d.param.answer, self.session.beam.param.dataset),
                                                css_classes=["diag-answer"]),
                       title="Answer (for the teacher)", collapsible=True, collapsed=False)


def _whiteness_text(diagnosis) -> str:
    """The Ljung–Box result in words (under the autocorrelation plot), coherent with the verdict: a
    pattern in a residual at the noise is a note on the noise model (:func:`beam.discovery.report.remaining_words`)."""
    if diagnosis is None:
        return ""
    w = diagnosis.residuals.whiteness
    chance = f"Ljung–Box test: the chance that white noise shows this much pattern is {p_words(w.p_value)}"
    if w.white:
        return f"{chance} (≥ 0.05): the residual looks like **white noise**, as for a right model."
    remaining = getattr(diagnosis, "remaining", None)
    if remaining is not None and remaining.at_noise and not diagnosis.missing:
        return (f"{chance} (< 0.05): a small pattern in a residual already at the sensor's noise — a note about the "
                "noise model (the AR(1) likelihood allows correlated noise), not missing physics.")
    return f"{chance} (< 0.05): the residual is **not white noise** — the misfit has structure the model does not explain."


def _parameter_words(name: str, si_unit: str) -> str:
    """A parameter's label for a student: no "(1)" for a ratio without a unit."""
    label = parameter_label(name, si_unit)
    return label[:-4] + " (no unit)" if label.endswith(" (1)") else label


def _backbone_text(diagnosis) -> str:
    """The backbone verdict in words (under the backbone plot)."""
    if diagnosis is None:
        return ""
    m1 = diagnosis.residuals.mode1
    bb = m1.backbone if m1 is not None else None
    if bb is None:
        return "No backbone on this record (no free decay to measure it on, or no measured mode matches the model's mode 1)."
    if not bb.reliable:
        return f"How the mode-1 frequency changes with amplitude is **unknown** here: {bb.unreliable}."
    shift = 100 * bb.relative_shift
    change = "does not change" if abs(shift) < 0.05 else f"changes by {abs(shift):.2f} % ({'up' if shift > 0 else 'down'})"
    return f"The mode-1 frequency {change} over the amplitudes seen: {bb.verdict}."


def _change(after: float, before: float) -> str:
    """``"(13 % higher than now)"``, ``"(unchanged)"``."""
    words = bs.change_words(after, before)
    return f"({words})" if words in ("unchanged", "–") else f"({words} than now)"


def _errors_words(candidate, diagnosis, u) -> str:
    """The errors a candidate is judged on (its judgement's, :func:`beam.discovery.judgement.judge`),
    in the output's unit: for a free decay the calibration window's, then the error after the window
    (amplitude-aware: re-anchored on the record's amplitudes, or forward for an amplitude-dependent
    force); for a driven record the held-out error."""
    judgement = judgement_of(candidate, diagnosis.base)
    held_before, held_after = u.scale * judgement.held_out_before, u.scale * judgement.held_out_after
    text = f"{judgement.held_out_label} {fmt_value(held_after)} {u.unit} {_change(held_after, held_before)}"
    if diagnosis.base.setup.is_free:
        before, after = u.scale * judgement.judged_before, u.scale * judgement.judged_after
        text = f"{judgement.judged_label} {fmt_value(after)} {u.unit} {_change(after, before)}; {text}"
    return text
