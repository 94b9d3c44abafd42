"""The "Toy periodic model" view: controls, status, read-outs, plots, compare and downloads.

A :class:`pn.viewable.Viewer` over a :class:`~dashboard.state.session.SessionState`: the widgets are
made from the parameters of ``session.toy`` (units in every label), the plots follow its
results (bokeh figures updated in place: :mod:`dashboard.plots.timeseries`, :mod:`dashboard.plots.corner`
and, for the window sweep, :mod:`dashboard.plots.toy`), and nothing here calls ``beam``
directly.
"""

from __future__ import annotations

import math

import panel as pn

from dashboard.outputs import exports
from dashboard.outputs.toy import compare_table, judge, readouts
from dashboard.plots.corner import CornerPlot
from dashboard.plots.timeseries import TimeSeriesPlot
from dashboard.plots.toy import SweepPlot
from dashboard.runtime.staging import run_steps
from dashboard.views.panes import HTML, DataFrame, Markdown, alert_html, compare_card, corner_grid, download_card
from dashboard.views.panes import run_status, three_columns
from dashboard.views.tab import TabView
from dashboard.views.texts import TOY_GLOSSARY, TOY_GUIDE, TOY_STEPS

__all__ = ["ToyView"]

_STAGE_TEXT = {
    "idle": "Waiting for the first run…",
    "queued": "Inputs changed: calibrating…",
    "preview": "Preview (MAP + Laplace) shown; MCMC starting…",
    "sampling": "MCMC running…",
    "final": "Posterior (MCMC) shown.",
    "error": "Could not run this scenario.",
}
#: (key, label, format, glossary entry of the tooltip). No colour thresholds: whether a value is
#: good news depends on the others (:func:`dashboard.outputs.toy.judge` says it in words beside them).
_READOUTS = (
    ("coverage_pct", "Held-out coverage of the 95 % band (%)", "{value:.1f}", "coverage"),
    ("rmse_du", "Held-out RMSE (du)", "{value:.3f}", "RMSE"),
    ("frequency_sd_mHz", "Posterior sd of f (mHz)", "{value:.2f}", "posterior"),
    ("noise_sd_du", "Estimated noise sd (du)", "{value:.3f}", None),
)
_NOISE_TIP = ("the noise sd the calibration estimates; compare it with the true noise sd (the Noise sd input): "
              "far above it, the model is absorbing missing physics as noise")


class ToyView(TabView):
    """Calibrate the toy periodic model interactively and see what discrepancy does.

    Parameters
    ----------
    session : SessionState
        The browser session's state.

    Built at once (the landing tab). Attributes read by the tests: :attr:`timeseries` (the
    data-and-bands figure), :attr:`result_tabs` (the tabs beside the plot), :attr:`corner` (the
    pair plot, built when its tab is first opened), :attr:`sweep_tab`, :attr:`sweep_plots` and
    :attr:`sweep_built` (the window sweep's plots, built when the first sweep arrives).
    """

    def __init__(self, **params) -> None:
        super().__init__(**params)
        self._toy = self.session.toy
        self.timeseries: TimeSeriesPlot | None = None
        self.corner: CornerPlot | None = None  # built when its tab is first opened (10 figures, ~0.7 s)
        self.result_tabs: pn.Tabs | None = None
        self.sweep_tab: pn.Column | None = None
        self.sweep_plots: list[SweepPlot] = []
        self.sweep_built = False
        self._toy.param.watch(self._sweep_arrived, "sweep")
        self.build()

    def frame(self) -> None:
        # the beam view's columns: the class panel goes below the plot where the window is narrow
        # (in one row the plot was 374 px wide at 1024 px)
        self._left, self._centre, self._right, row = three_columns("toy")
        self.layout[:] = [row]

    def steps(self) -> list:
        # one piece at a time on the server's event loop, so that no session holds it for long, in page order
        return [self._build_status, self._build_figure, self._build_plot, self._build_controls, self._build_side,
                self._build_guide, self._build_tabs]

    # -- the steps of the build ------------------------------------------------------------------
    def _build_status(self) -> None:
        self._centre.extend([*run_status(self._toy.run, "beam-status", _STAGE_TEXT, error_css="beam-error", bar_label="MCMC progress (%)"),
                             self._readouts()])

    def _build_figure(self) -> None:  # the bokeh figure alone (not in the document yet)
        toy = self._toy
        self.timeseries = TimeSeriesPlot()
        self.timeseries.update(toy.result, toy.pinned)
        toy.param.watch(lambda e: self.timeseries.update(toy.result, toy.pinned), ["result", "pinned"])

    def _build_plot(self) -> None:
        self._centre.append(pn.pane.Bokeh(self.timeseries.figure, sizing_mode="stretch_width", height=420))

    def _build_controls(self) -> None:
        self._left.extend([self._controls(), self._presets()])

    def _build_side(self) -> None:
        self._left.extend([self._compare_buttons(), self._downloads()])

    def _build_guide(self) -> None:
        self._right.append(pn.Card(Markdown(TOY_GUIDE, sizing_mode="stretch_width"), title="For the class",
                                   collapsible=True, collapsed=False, sizing_mode="stretch_width",
                                   css_classes=["toy-class-guide"]))

    def _build_tabs(self) -> None:
        toy = self._toy
        self._posterior_tab = pn.Column(
            Markdown("Posterior draws (blue; pinned result purple), truth in green.", margin=(0, 10)),
            sizing_mode="stretch_width")
        # the sweep plots are built when the first sweep arrives
        self.sweep_tab = pn.Column(Markdown(pn.bind(self._sweep_text, toy.sweep_run.param.status), margin=(0, 10)),
                                   sizing_mode="stretch_width")
        self.result_tabs = pn.Tabs(
            ("Window sweep", self.sweep_tab),
            ("Posterior: marginals and pairs", self._posterior_tab),
            ("Compare table", DataFrame(pn.bind(compare_table, toy.param.result, toy.param.pinned),
                                                sizing_mode="stretch_width", escape=True)),
            dynamic=True,
            sizing_mode="stretch_width",
        )
        self.result_tabs.param.watch(self._tab_opened, "active")
        self._centre.append(self.result_tabs)
        if toy.sweep is not None:
            self._sweep_arrived()

    def _sweep_arrived(self, *_) -> None:
        if self._toy.sweep is None or self.sweep_built or self.result_tabs is None:
            return
        self.sweep_built = True
        run_steps([self._build_sweep_figures, lambda: self._show_sweep(0), lambda: self._show_sweep(1)])

    def _build_sweep_figures(self) -> None:
        toy = self._toy
        self.sweep_plots = [SweepPlot("coverage"), SweepPlot("rmse")]
        self._update_sweep()
        # the marker follows the latest final result, not the slider (fewer redraws)
        toy.param.watch(self._update_sweep, ["sweep", "final"])
        # side by side where each has 320 px, one above the other where not
        self._sweep_row = pn.FlexBox(flex_wrap="wrap", align_items="flex-start", sizing_mode="stretch_width")
        self.sweep_tab.append(self._sweep_row)

    def _show_sweep(self, index: int) -> None:
        # not linked: both plots' value axis is named "value" (coverage in %, RMSE in du), and
        # pn.pane.HoloViews links the axes of panes in one layout by dimension name
        self._sweep_row.append(pn.pane.HoloViews(self.sweep_plots[index].figure, sizing_mode="stretch_width", height=290,
                                                 backend="bokeh", linked_axes=False,
                                                 styles={"flex": "1 1 320px", "min-width": "0"}))

    def _update_sweep(self, *_) -> None:
        toy = self._toy
        window = None if toy.final is None else toy.final.scenario.window_s
        for plot in self.sweep_plots:
            plot.update(toy.sweep, window)

    # -- pieces ---------------------------------------------------------------------------------
    def _tab_opened(self, event) -> None:
        if event.new == 1 and self.corner is None:
            toy = self._toy
            self.corner = CornerPlot()
            self.corner.update(toy.result, toy.pinned)
            toy.param.watch(lambda e: self.corner.update(toy.result, toy.pinned), ["result", "pinned"])
            self._posterior_tab.append(corner_grid(self.corner.grid, self.corner.size))

    def _controls(self) -> pn.Card:
        p = self._toy.param
        widgets = [
            pn.widgets.FloatSlider.from_param(p.window_s, format="0.0"),
            pn.widgets.FloatSlider.from_param(p.discrepancy, format="0.00"),
            pn.widgets.Select.from_param(p.kind),
            pn.widgets.Select.from_param(p.noise_sd),
            pn.widgets.Select.from_param(p.horizon_s),
            pn.widgets.Select.from_param(p.likelihood),
            pn.widgets.Select.from_param(p.seed),
        ]
        for w in widgets:
            w.sizing_mode = "stretch_width"
        widgets[0].css_classes = ["beam-window-slider"]
        return pn.Card(*widgets, title="Scenario", collapsible=False, sizing_mode="stretch_width")

    def _readouts(self) -> pn.Column:
        toy = self._toy
        values = pn.bind(readouts, toy.param.result)
        items = []
        for key, label, fmt, term in _READOUTS:
            value = pn.bind(lambda v, k=key: v[k] if math.isfinite(v[k]) else float("nan"), values)
            number = pn.indicators.Number(label=label, value=value, format=fmt, font_size="24pt", title_size="11pt",
                                          nan_format="–", margin=(0, 0, 0, 12),
                                          css_classes=[f"beam-readout-{key.replace('_', '-')}"])
            tip = TOY_GLOSSARY[term] if term else _NOISE_TIP
            items.append(pn.Row(number, pn.widgets.TooltipIcon(value=f"{term or 'noise sd'}: {tip}", margin=(4, 8)),
                                css_classes=["toy-readout"]))

        def verdict_html(result, pinned):
            kind, lines = judge(result, pinned)
            return alert_html(kind, "<br>".join(lines))

        verdict = HTML(pn.bind(verdict_html, toy.param.result, toy.param.pinned), sizing_mode="stretch_width",
                               margin=(0, 10), css_classes=["beam-verdict"])
        # wrapped onto a second line where the column is narrow (in one row they ran over the class
        # panel at 1024 and 1280 px)
        row = pn.FlexBox(*items, flex_wrap="wrap", sizing_mode="stretch_width", css_classes=["toy-readouts"])
        return pn.Column(row, verdict, sizing_mode="stretch_width")

    def _presets(self) -> pn.Card:
        """One button per preset of the "Try this" steps: it sets the inputs of the step at once."""
        toy = self._toy
        rows = []
        for k, (title, _, presets) in enumerate(TOY_STEPS, start=1):
            if not presets:
                continue
            buttons = []
            for label, settings in presets:
                button = pn.widgets.Button(label=f"{k}. {label}", color="light", sizing_mode="stretch_width",
                                           margin=(2, 4), description=f"Step {k} ({title}): sets the inputs of the step",
                                           css_classes=["beam-preset"])
                button.on_click(lambda event, s=dict(settings): toy.param.update(**s))
                buttons.append(button)
            rows.append(pn.Row(*buttons, sizing_mode="stretch_width", margin=0))
        return pn.Card(*rows, title="Try this (steps of the guide)", collapsible=False, sizing_mode="stretch_width")

    def _compare_buttons(self) -> pn.Card:
        return compare_card(self._toy, "purple")

    def _downloads(self) -> pn.Card:
        return download_card(self._toy, exports, "toy")

    @staticmethod
    def _sweep_text(status: str) -> str:
        head = ("Held-out coverage and RMSE of the Laplace preview for calibration windows of 1 to 15 s "
                "(same record; computed once per scenario).")
        return f"{head} <small>{status}</small>" if status else head
