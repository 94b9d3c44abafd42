"""The "Beam calibration" view: dataset and upload, inputs, status, read-outs, plots, compare, downloads.

A :class:`pn.viewable.Viewer` over ``session.beam`` (:class:`~dashboard.state.beam.BeamState`);
nothing here calls ``beam`` directly. The main plot is plain bokeh updated in place
(:mod:`dashboard.plots.beam`); the pair plot reuses :class:`dashboard.plots.corner.CornerPlot`, built
when its tab is first opened and rebuilt when the set of parameters changes.
"""

from __future__ import annotations

import html

import panel as pn

from dashboard.jobs.beam import (
    MAX_SIDECAR_UPLOAD_BYTES,
    MAX_UPLOAD_BYTES,
    upload_size_text,
)
from dashboard.outputs import beam as bs
from dashboard.plots.beam import BeamTimeSeriesPlot
from dashboard.plots.corner import CornerPlot
from dashboard.state.beam import NO_ANSWER
from dashboard.views.panes import (
    BUTTON_WRAP,
    HTML,
    DataFrame,
    Markdown,
    alert_html,
    compare_card,
    corner_grid,
    download_card,
    run_status,
    three_columns,
)
from dashboard.views.tab import TabView
from dashboard.views.texts import beam_guide

__all__ = ["UPLOAD_CHUNK_BYTES", "BeamCalibrationView"]

#: Size of the pieces an upload is sent in (bytes): each is one websocket message, well under the
#: 20 MB Bokeh's server accepts by default (``--websocket-max-message-size``), so files up to the
#: library's 64 MiB pass with the plain ``panel serve`` command; 16 pieces for the largest file.
UPLOAD_CHUNK_BYTES = 4 * 2**20

_STAGE_TEXT = {
    "idle": "Open this tab to calibrate.",
    "queued": "Inputs changed: calibrating…",
    "preview": "Preview (MAP + Laplace) shown; MCMC running…",
    "sampling": "MCMC running…",
    "final": "Posterior (MCMC) shown.",
    "error": "Could not calibrate with these inputs.",
}
#: The status line's text for a result that is not the stage's usual one (by :func:`stage_text`).
_AVERAGED_TEXT = "Averaged preview (slow-flow approximation of the drag) shown; full calibration running…"
_LAPLACE_TEXT = "Laplace posterior shown (a nonlinear free decay is not sampled by MCMC)."


def stage_text(stage: str, result) -> str:
    """The status line's text in bold: the stage's, or what the shown result is when the stage's
    words do not fit it (the averaged drag preview; a nonlinear free decay's Laplace posterior)."""
    if result is not None and stage in ("preview", "final"):
        if result.approximation is not None:
            return _AVERAGED_TEXT
        if stage == "final" and result.is_preview:
            return _LAPLACE_TEXT
    return _STAGE_TEXT.get(stage, stage)


def effects_caption(measurement) -> str:
    """The words over the effect check-boxes: what the bare model already has for this record (the
    patch's drive only when the record has a patch)."""
    patch = measurement is not None and measurement.geometry.has_patch
    return ("**Effects in the model** (besides the beam's stiffness EI" + (" and the patch's drive k_p)" if patch else ")"))


#: Colour of a read-out's number by its judgement (:func:`dashboard.outputs.beam.judged_readouts`).
KIND_COLOURS = {"good": "#1a7f37", "bad": "#c62828", "warn": "#a35200", "none": "#212529"}

def readouts_html(items: list[dict], true_noise_m: float | None = None) -> str:
    """The read-outs as one HTML block: a big number (for a projector), its label, and a line in
    words on what the number means for this model (see :func:`dashboard.outputs.beam.judged_readouts`).

    The boxes wrap onto more rows when the column is narrow (CSS flex-wrap), so no read-out
    overprints its neighbour whatever the window width."""
    boxes = []
    for it in items:
        extra = ""
        if it["key"] == "noise_sd" and true_noise_m is not None:  # simulated (displacement) records only
            extra = f'<div class="truth" style="color:#2ca02c;font-weight:600">true: {bs.fmt_value(1e6 * true_noise_m)} µm</div>'
        boxes.append(
            f'<div class="readout beam-cal-{it["key"].replace("_", "-")}" data-kind="{it["kind"]}" '
            f'title="{html.escape(it["gloss"])}" style="flex:1 1 170px;padding:2px 6px;">'
            f'<div class="label" style="font-size:11pt;color:#444;">{html.escape(it["label"])}</div>'
            f'<div class="number" style="font-size:28pt;line-height:1.15;font-weight:600;color:{KIND_COLOURS[it["kind"]]};'
            f'white-space:nowrap;">{html.escape(it["value"])}<span style="font-size:14pt;font-weight:400;"> '
            f'{html.escape(it["unit"])}</span></div>'
            f'<div class="words" style="font-size:11pt;color:#333;line-height:1.25;">{html.escape(it["words"])}</div>'
            f"{extra}</div>")
    return f'<div class="beam-readouts" style="display:flex;flex-wrap:wrap;gap:6px 12px;">{"".join(boxes)}</div>'


def convergence_html(result) -> str:
    """The convergence notice in words: grey preview, green converged, yellow not."""
    c = bs.convergence(result)
    if result is None:
        return alert_html("secondary", "No result yet.")
    if result.approximation is not None:
        return alert_html("secondary", "Averaged preview: the best fit of the drag's slow-flow approximation (each "
                                       "mode's envelope averaged over a cycle, no integration), with its own error "
                                       "estimate, which leaves out the approximation's error; the full model's fit "
                                       "follows and replaces it.")
    if not c["mcmc"] and result.final:
        return alert_html("secondary", "Laplace posterior: the single best fit (MAP) with a Gaussian error estimate; "
                                       "a free decay with a nonlinear effect is not sampled by MCMC.")
    if not c["mcmc"]:
        return alert_html("secondary", "Preview: the single best fit (MAP) with a quick error estimate; the full "
                                       "posterior (MCMC draws) follows, and is checked then.")
    head = "Converged" if c["converged"] else "<b>Not converged</b> — read the posterior with care"
    warn = html.escape("; " + "; ".join(c["warnings"])) if c["warnings"] else ""
    body = (f"{head}: the chains agree (R-hat {c['rhat_max']:.3f}; 1.01 or less is agreement) and are worth "
            f"{c['ess_min']:,.0f} independent draws (ESS; at least 1,000 wanted){warn}.")
    return alert_html("success" if c["converged"] else "warning", body)


class _Draws:
    """What :class:`CornerPlot` reads from a result: ``draws`` (dict) and ``truth`` (dict)."""

    def __init__(self, result, truth: dict | None = None) -> None:
        self.draws = bs.thinned_draws(result)
        self.truth = {k: v for k, v in (truth or {}).items() if k in self.draws}



def _true_noise(answer: dict | None) -> float | None:
    return None if answer is None else answer.get("noise_m")


class BeamCalibrationView(TabView):
    """Calibrate the cantilever beam model on a measurement and judge it on the held-out record.

    Parameters
    ----------
    session : SessionState
        The browser session's state.

    Built when its tab is first opened (~0.3 s of the event loop saved for the sessions that
    never open it). Attributes read by the tests: :attr:`plot` (the measurement-and-bands
    figure), :attr:`result_tabs` (the tabs below it) and :attr:`corner` (the pair plot, built
    when its tab is first opened).
    """

    placeholder = "Open this tab to load the beam calibration view."

    def __init__(self, **params) -> None:
        super().__init__(**params)
        self._beam = self.session.beam
        self.plot: BeamTimeSeriesPlot | None = None
        self.result_tabs: pn.Tabs | None = None
        self.corner: CornerPlot | None = None

    def frame(self) -> None:
        self._left, self._centre, self._right, row = three_columns("beam")
        # the dataset's menu above the columns: in the 300 px input column its titles were cut
        self._top = pn.Row(sizing_mode="stretch_width", css_classes=["beam-top"])
        self.layout[:] = [self._top, row]

    def steps(self) -> list:
        return [self._build_status, self._build_figure, self._build_plot, self._build_inputs, self._build_side,
                self._build_tabs]

    def start(self) -> None:
        """The first calibration (when the tab is first opened)."""
        if self._beam.requested == 0:
            self._beam.request(debounce=False)

    # -- the steps of the build ------------------------------------------------------------------
    def _build_status(self) -> None:
        self._centre.extend([*self._status(), self._readouts(), self._convergence()])

    def _build_figure(self) -> None:  # the bokeh figure alone (not in the document yet)
        beam = self._beam
        self.plot = BeamTimeSeriesPlot()
        self.plot.show_measurement(beam.measurement)
        self.plot.update(beam.result, beam.pinned)
        beam.param.watch(lambda e: self.plot.update(beam.result, beam.pinned), ["result", "pinned"])
        beam.param.watch(lambda e: self.plot.show_measurement(e.new), "measurement")
        d = self.session.diagnosis
        d.param.watch(lambda e: self.plot.show_true_noise(_true_noise(e.new)), "answer")
        self.plot.show_true_noise(_true_noise(d.answer))

    def _build_plot(self) -> None:
        self._centre.append(pn.pane.Bokeh(self.plot.figure, sizing_mode="stretch_width", height=420))

    def _build_inputs(self) -> None:
        select, card = self._dataset_card()
        self._top.append(select)
        self._left.extend([card, self._controls()])

    def _build_side(self) -> None:
        self._left.extend([self._compare_buttons(), self._reveal(), self._downloads()])
        beam, d = self._beam, self.session.diagnosis
        guide = pn.bind(lambda name, measurement: beam_guide(measurement, simulated=d.has_answer()),
                        beam.param.dataset, beam.param.measurement)
        self._right.append(pn.Card(Markdown(guide, sizing_mode="stretch_width"), title="For the class",
                                   collapsible=True, collapsed=False, sizing_mode="stretch_width",
                                   css_classes=["beam-class-guide"]))

    def _build_tabs(self) -> None:
        beam = self._beam
        self._posterior_tab = pn.Column(Markdown(
            "Posterior draws (the parameter values that fit the data): each parameter alone on the diagonal, "
            "pairs below — blue current, grey pinned, green the truth after *Reveal*.", margin=(0, 10)),
            sizing_mode="stretch_width")
        self.result_tabs = pn.Tabs(
            ("Parameters", DataFrame(pn.bind(bs.truth_table, beam.param.result, self.session.diagnosis.param.answer),
                                             sizing_mode="stretch_width", escape=True,
                                             css_classes=["beam-parameter-table"])),
            ("Posterior: marginals and pairs", self._posterior_tab),
            ("Correlations", DataFrame(pn.bind(bs.correlation_table, beam.param.result), escape=True)),
            ("Compare table", DataFrame(pn.bind(bs.compare_table, beam.param.result, beam.param.pinned),
                                                sizing_mode="stretch_width", escape=True)),
            dynamic=True, sizing_mode="stretch_width")
        self.result_tabs.param.watch(self._tab_opened, "active")
        beam.param.watch(self._update_corner, ["result", "pinned"])
        self.session.diagnosis.param.watch(self._update_corner, "answer")
        self._centre.append(self.result_tabs)

    # -- inputs ---------------------------------------------------------------------------------
    def _dataset_card(self) -> tuple[pn.widgets.Select, pn.Card]:
        """The dataset's menu and the upload card."""
        beam = self._beam
        select = pn.widgets.Select(label="Dataset (bundled lab runs or an upload)", sizing_mode="stretch_width",
                                   max_width=760, css_classes=["beam-dataset"])

        def sync(*_):
            select.options = {beam.dataset_label(n): n for n in beam.param.dataset.objects}
            select.value = beam.dataset

        sync()
        beam.param.watch(sync, ["dataset", "uploads"])
        select.param.watch(lambda e: setattr(beam, "dataset", e.new) if e.new != beam.dataset else None, "value")
        # FileDropper (FilePond) sends a file in UPLOAD_CHUNK_BYTES pieces, shows each file's progress
        # and refuses a file over max_file_size in the browser ("File is too large"), before sending
        # anything. No type filter: browsers report a CSV as text/csv, application/vnd.ms-excel or
        # nothing, a TOML file mostly as nothing; the contents are checked on the server.
        limits = {"csv": MAX_UPLOAD_BYTES, "toml": MAX_SIDECAR_UPLOAD_BYTES}
        droppers: dict[str, pn.widgets.FileDropper] = {}
        load = pn.widgets.Button(label="Load the uploaded measurement", color="primary", sizing_mode="stretch_width",
                                 css_classes=["beam-upload-load"], disabled=True)

        def ready(*_) -> None:
            load.disabled = not (droppers["csv"].value and droppers["toml"].value)

        def new_dropper(kind: str) -> pn.widgets.FileDropper:
            droppers[kind] = pn.widgets.FileDropper(
                multiple=False, max_file_size=str(limits[kind]), chunk_size=UPLOAD_CHUNK_BYTES, previews=[],
                layout="compact", width=None, sizing_mode="stretch_width", margin=(0, 10, 5, 10),
                css_classes=[f"beam-upload-{kind}"])
            droppers[kind].param.watch(ready, "value")
            return droppers[kind]

        def last(dropper: pn.widgets.FileDropper) -> tuple[str | None, bytes | str | None]:
            """The dropper's (latest) file as (name, contents); (None, None) before one is uploaded."""
            return next(reversed(dropper.value.items()), (None, None))

        # (a refused pair keeps its widgets: replaced at once after the click, their FilePond threw in
        # the browser, "Cannot read properties of null (reading 'file')"; the red box says why)
        load.on_click(lambda event: beam.upload(*last(droppers["csv"]), *last(droppers["toml"])))
        card = pn.Card(
            Markdown(f"**Upload** a record: `NAME.csv` (`time_s`, then `voltage_V`, `force_N` or no input column "
                     "for a free response, then `displacement_m`, `velocity_m_s` or `acceleration_m_s2`) and its "
                     f"sidecar `NAME.toml` (geometry, sensor position); the CSV at most "
                     f"{upload_size_text(MAX_UPLOAD_BYTES)} ({MAX_UPLOAD_BYTES // 2**20} MiB), the sidecar at most "
                     f"{upload_size_text(MAX_SIDECAR_UPLOAD_BYTES)}. Drop or browse both, then load them.",
                     margin=(0, 10)),
            Markdown("Data file (.csv)", margin=(0, 10)), new_dropper("csv"),
            Markdown("Sidecar (.toml)", margin=(0, 10)), new_dropper("toml"), load,
            title="Measurement", collapsible=False, sizing_mode="stretch_width")
        return select, card

    def _controls(self) -> pn.Card:
        beam = self._beam
        window = pn.widgets.RangeSlider.from_param(beam.param.window_s, step=0.05, format="0.00",
                                                   sizing_mode="stretch_width", css_classes=["beam-cal-window"])

        def bounds(*_):
            t = beam.measurement.time_s
            window.param.update(start=float(t[0]), end=float(t[-1]))

        bounds()
        beam.param.watch(bounds, "measurement")
        modes = pn.widgets.IntSlider.from_param(beam.param.modes, name="Number of modes", sizing_mode="stretch_width",
                                                css_classes=["beam-modes"])
        effects = pn.widgets.CheckBoxGroup(options=beam.effect_options(), value=list(beam.effects), inline=False,
                                           sizing_mode="stretch_width", css_classes=["beam-effects"])
        effects.param.watch(lambda e: setattr(beam, "effects", list(e.new)) if list(e.new) != list(beam.effects) else None,
                            "value")
        beam.param.watch(lambda e: setattr(effects, "value", list(e.new)) if list(e.new) != effects.value else None,
                         "effects")

        def offered(*_):  # the effects that apply to this record (no patch's effects on a bare strip)
            options = beam.effect_options()
            if options != effects.options:
                effects.options = options

        beam.param.watch(offered, ["measurement", "effects"])
        likelihood = pn.widgets.Select.from_param(beam.param.likelihood, sizing_mode="stretch_width")
        caption = Markdown(pn.bind(lambda m: effects_caption(m), beam.param.measurement), margin=(5, 10, 0, 10),
                           css_classes=["beam-effects-caption"])
        return pn.Card(window, modes, caption, effects, likelihood, title="Model and calibration", collapsible=False,
                       sizing_mode="stretch_width")

    # -- outputs --------------------------------------------------------------------------------
    def _status(self) -> list:
        beam = self._beam

        def data(result, dataset, record):
            r = bs.readouts(result)
            return {"dataset": dataset, "record": html.escape(record),
                    "effects": "+".join(result.setup.effects) if result is not None else "",
                    "preview": int(result is None or result.is_preview),
                    "averaged": int(result is not None and result.approximation is not None),
                    "rmse_prediction": f"{r['rmse_prediction']:.6g}", "unit": r["unit"]}

        return run_status(beam.run, "cal-status", _STAGE_TEXT, error_css="beam-cal-error", data=data,
                          text=lambda stage, result, *_: stage_text(stage, result),
                          depends=(beam.param.result, beam.param.dataset, beam.run.param.shown_subject))

    def _readouts(self) -> pn.pane.HTML:
        """The read-outs, judged against the model (one HTML pane whose text changes: cheap in the browser)."""
        def text(result, answer):
            return readouts_html(bs.judged_readouts(result), _true_noise(answer))

        return HTML(pn.bind(text, self._beam.param.result, self.session.diagnosis.param.answer),
                            sizing_mode="stretch_width", margin=(4, 10), css_classes=["beam-cal-readouts"])

    def _convergence(self) -> pn.pane.HTML:
        """Convergence notice (one HTML pane whose text changes: see :func:`dashboard.views.panes.alert_html`)."""
        return HTML(pn.bind(convergence_html, self._beam.param.result), sizing_mode="stretch_width",
                            margin=(0, 10), css_classes=["beam-convergence"])

    def _reveal(self) -> pn.Card:
        d, beam = self.session.diagnosis, self._beam
        button = pn.widgets.Button(label="Reveal the true values", color="warning", sizing_mode="stretch_width",
                                   css_classes=["beam-reveal"], stylesheets=BUTTON_WRAP,
                                   disabled=pn.bind(lambda name, uploads: not d.has_answer(), beam.param.dataset,
                                                    beam.param.uploads))
        button.on_click(lambda e: d.reveal())
        note = Markdown(pn.bind(lambda a, name: NO_ANSWER if not d.has_answer() else
                                "True values shown in green: *Parameters* table, pair plot, and the true "
                                "noise around the model mean." if a is not None else
                                "Bundled simulated records only: shows what the record was simulated with.",
                                d.param.answer, beam.param.dataset), margin=(0, 10), css_classes=["beam-answer-note"])
        return pn.Card(button, note, title="Answer (for the teacher)", collapsible=True, collapsed=True,
                       sizing_mode="stretch_width")

    def _tab_opened(self, event) -> None:
        if event.new == 1 and self.corner is None:
            self._update_corner()

    def _update_corner(self, *_) -> None:
        if self.result_tabs.active != 1 and self.corner is None:
            return  # built when its tab is first opened (one figure per pair)
        beam = self._beam
        if beam.result is None:
            return
        names = tuple(bs.summary(beam.result))
        if self.corner is None or self.corner.names != names:
            self.corner = CornerPlot(names, labels={n: bs.short_label(n, bs.output_units(beam.result).si_unit) for n in names})
            self._posterior_tab[:] = [self._posterior_tab[0], corner_grid(self.corner.grid, self.corner.size)]
        pinned = beam.pinned if beam.pinned is not None and tuple(bs.summary(beam.pinned)) == names else None
        answer = self.session.diagnosis.answer
        self.corner.update(_Draws(beam.result, answer["parameters"] if answer else None),
                            _Draws(pinned) if pinned is not None else None)

    def _compare_buttons(self) -> pn.Card:
        return compare_card(self._beam, "grey")

    def _downloads(self) -> pn.Card:
        return download_card(self._beam, bs, "beam")
