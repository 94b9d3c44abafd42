"""The "Beam calibration" view: dataset and upload, inputs, status, read-outs, plots, compare, downloads.

A :class:`pn.viewable.Viewer` over ``session.beam`` (:class:`~dashboard.state.beam.BeamState`);
nothing here calls ``beam`` directly. The main plot is plain bokeh updated in place
(:mod:`dashboard.plots.beam`); the pair plot reuses :class:`dashboard.plots.corner.CornerPlot`, built
when its tab is first opened and rebuilt when the set of parameters changes.
"""

from __future__ import annotations

import html
import math

import panel as pn
import param

from dashboard.jobs.beam import MAX_UPLOAD_BYTES
from dashboard.outputs import beam as bs
from dashboard.plots.beam import BeamTimeSeriesPlot
from dashboard.plots.corner import CornerPlot
from dashboard.runtime.staging import run_steps
from dashboard.state.session import SessionState
from dashboard.views.panes import Markdown, alert_html, status_html
from dashboard.views.texts import BEAM_GUIDE

__all__ = ["BeamCalibrationView"]

_STAGE_TEXT = {
    "idle": "Open this tab to calibrate.",
    "queued": "Inputs changed: calibrating…",
    "preview": "Preview (MAP + Laplace) shown; MCMC running…",
    "sampling": "MCMC running…",
    "final": "Posterior (MCMC) shown.",
    "error": "Could not calibrate with these inputs.",
}
_READOUTS = (
    ("rmse_calibration_um", "RMSE in the window (µm)", "{value:.4g}", None),
    ("rmse_prediction_um", "Held-out RMSE (µm)", "{value:.4g}", None),
    ("coverage_pct", "Held-out coverage, 95 % band (%)", "{value:.1f} %", [(85.0, "#d62728"), (101.0, "#2ca02c")]),
    ("noise_sd_um", "Estimated noise sd (µm)", "{value:.3g}", None),
)


class _Draws:
    """What :class:`CornerPlot` reads from a result: ``draws`` (dict) and ``truth`` (dict)."""

    def __init__(self, result) -> None:
        self.draws, self.truth = bs.thinned_draws(result), {}



class BeamCalibrationView(pn.viewable.Viewer):
    """Calibrate the cantilever beam model on a measurement and judge it on the held-out record.

    Parameters
    ----------
    session : SessionState
        The browser session's state.
    """

    session = param.ClassSelector(class_=SessionState, doc="State of the browser session.")

    def __init__(self, **params) -> None:
        super().__init__(**params)
        self._beam = self.session.beam
        self._built = False
        # built when the tab is first opened (~0.3 s of the event loop per session saved
        # for the sessions that never open it)
        self._layout = pn.Column(Markdown("Open this tab to load the beam calibration view."),
                                 sizing_mode="stretch_width")

    @property
    def layout(self):
        """The view's root panel (what ``__panel__`` returns)."""
        return getattr(self, "_layout", None)

    @property
    def corner(self):
        """The pair plot of the posterior draws (None until the first result)."""
        return getattr(self, "_corner", None)

    @property
    def built(self):
        """Whether the view's pieces exist (built when its tab is first opened)."""
        return getattr(self, "_built", None)

    @property
    def plot(self):
        """The measurement-and-bands figure."""
        return getattr(self, "_plot", None)

    @property
    def result_tabs(self):
        """The tabs below the plot (bands, pair plot, tables, ...)."""
        return getattr(self, "_tabs", None)

    def __panel__(self):
        return self._layout

    def build(self) -> None:
        """Build the widgets, plots and tables (once), in steps (see :mod:`dashboard.runtime.staging`)."""
        if self._built:
            return
        self._built = True
        self._left = pn.Column(width=320)
        self._centre = pn.Column(sizing_mode="stretch_width", min_height=600)
        self._right = pn.Column(width=320)
        self._layout[:] = [pn.Row(self._left, self._centre, self._right, sizing_mode="stretch_width")]
        run_steps([self._build_status, self._build_figure, self._build_plot, self._build_inputs, self._build_side,
                   self._build_tabs])

    # -- the steps of the build ------------------------------------------------------------------
    def _build_status(self) -> None:
        self._centre.extend([self._status(), self._readouts(), self._convergence()])

    def _build_figure(self) -> None:  # the bokeh figure alone (not in the document yet)
        beam = self._beam
        self._plot = BeamTimeSeriesPlot()
        self._plot.show_measurement(beam.measurement)
        self._plot.update(beam.result, beam.pinned)
        beam.param.watch(lambda e: self._plot.update(beam.result, beam.pinned), ["result", "pinned"])
        beam.param.watch(lambda e: self._plot.show_measurement(e.new), "measurement")

    def _build_plot(self) -> None:
        self._centre.append(pn.pane.Bokeh(self._plot.figure, sizing_mode="stretch_width", height=390))

    def _build_inputs(self) -> None:
        self._left.extend([self._dataset_card(), self._controls()])

    def _build_side(self) -> None:
        self._left.extend([self._compare_buttons(), self._downloads()])
        self._right.append(Markdown(BEAM_GUIDE, sizing_mode="stretch_width"))

    def _build_tabs(self) -> None:
        beam = self._beam
        self._corner: CornerPlot | None = None
        self._posterior_tab = pn.Column(Markdown(
            "Posterior draws: marginals on the diagonal, pairs below (blue; pinned result purple).", margin=(0, 10)),
            sizing_mode="stretch_width")
        self._tabs = pn.Tabs(
            ("Parameters", pn.pane.DataFrame(pn.bind(bs.parameter_table, beam.param.result), sizing_mode="stretch_width",
                                             escape=True, css_classes=["beam-parameter-table"])),
            ("Posterior: marginals and pairs", self._posterior_tab),
            ("Correlations", pn.pane.DataFrame(pn.bind(bs.correlation_table, beam.param.result), escape=True)),
            ("Compare table", pn.pane.DataFrame(pn.bind(bs.compare_table, beam.param.result, beam.param.pinned),
                                                sizing_mode="stretch_width", escape=True)),
            dynamic=True, sizing_mode="stretch_width")
        self._tabs.param.watch(self._tab_opened, "active")
        beam.param.watch(self._update_corner, ["result", "pinned"])
        self._centre.append(self._tabs)

    def activate(self) -> None:
        """Build the view and start the first calibration (called when the tab is first opened)."""
        self.build()
        if self._beam.requested == 0:
            self._beam.request(debounce=False)

    # -- inputs ---------------------------------------------------------------------------------
    def _dataset_card(self) -> pn.Card:
        beam = self._beam
        select = pn.widgets.Select(label="Dataset (bundled lab runs or an upload)", sizing_mode="stretch_width",
                                   css_classes=["beam-dataset"])

        def sync(*_):
            select.options = {beam.dataset_label(n): n for n in beam.param.dataset.objects}
            select.value = beam.dataset

        sync()
        beam.param.watch(sync, ["dataset", "uploads"])
        select.param.watch(lambda e: setattr(beam, "dataset", e.new) if e.new != beam.dataset else None, "value")
        mb = MAX_UPLOAD_BYTES // 2**20
        csv = pn.widgets.FileInput(accept=".csv", sizing_mode="stretch_width", css_classes=["beam-upload-csv"])
        toml = pn.widgets.FileInput(accept=".toml", sizing_mode="stretch_width", css_classes=["beam-upload-toml"])
        load = pn.widgets.Button(label="Load the uploaded measurement", color="primary", sizing_mode="stretch_width",
                                 css_classes=["beam-upload-load"])
        load.on_click(lambda e: beam.upload(csv.filename, csv.value, toml.filename, toml.value))
        return pn.Card(
            select,
            Markdown(f"**Upload** a record: `NAME.csv` (time_s, voltage_V, displacement_m) and its sidecar "
                             f"`NAME.toml` (geometry), at most {mb} MB each.", margin=(0, 10)),
            Markdown("Data file (.csv)", margin=(0, 10)), csv,
            Markdown("Sidecar (.toml)", margin=(0, 10)), toml, load,
            title="Measurement", collapsible=False, sizing_mode="stretch_width")

    def _controls(self) -> pn.Card:
        beam = self._beam
        window = pn.widgets.RangeSlider.from_param(beam.param.window_s, step=0.05, format="0.00",
                                                   sizing_mode="stretch_width", css_classes=["beam-cal-window"])

        def bounds(*_):
            t = beam.measurement.time_s
            window.param.update(start=float(t[0]), end=float(t[-1]))

        bounds()
        beam.param.watch(bounds, "measurement")
        modes = pn.widgets.IntSlider.from_param(beam.param.modes, sizing_mode="stretch_width", css_classes=["beam-modes"])
        options = beam.effect_options()
        effects = pn.widgets.CheckBoxGroup(options=options, value=list(beam.effects), inline=False,
                                           css_classes=["beam-effects"])
        effects.param.watch(lambda e: setattr(beam, "effects", list(e.new)) if list(e.new) != list(beam.effects) else None,
                            "value")
        beam.param.watch(lambda e: setattr(effects, "value", list(e.new)) if list(e.new) != effects.value else None,
                         "effects")
        likelihood = pn.widgets.Select.from_param(beam.param.likelihood, sizing_mode="stretch_width")
        return pn.Card(window, modes, Markdown("**Effects in the model** (besides EI in N m² and k_p in N m/V)",
                                                       margin=(5, 10, 0, 10)),
                       effects, likelihood, title="Model and calibration", collapsible=False, sizing_mode="stretch_width")

    # -- outputs --------------------------------------------------------------------------------
    def _status(self) -> pn.Column:
        beam = self._beam

        def html(stage, status, requested, shown, result, dataset):
            r = bs.readouts(result)
            effects = "+".join(result.setup.effects) if result is not None else ""
            return status_html("cal-status", stage, status, requested, shown, _STAGE_TEXT.get(stage, stage),
                               dataset=dataset, effects=effects, preview=int(result is None or result.is_preview),
                               rmse_prediction_um=f"{r['rmse_prediction_um']:.6g}")

        p = beam.param
        status = pn.pane.HTML(pn.bind(html, p.stage, p.status, p.requested, p.shown, p.result, p.dataset),
                              sizing_mode="stretch_width", margin=(5, 10, 0, 10))
        bar = pn.indicators.Progress(
            value=pn.bind(lambda s, f: 100 if s == "final" else round(100 * f) if s in ("preview", "sampling") else 0,
                          p.stage, p.progress),
            max=100, sizing_mode="stretch_width", height=14, margin=(0, 10), bar_color="primary")
        alert = pn.pane.Alert(pn.bind(lambda e: f"**Error:** {e}" if e else "", p.error), alert_type="danger",
                              visible=pn.bind(bool, p.error), sizing_mode="stretch_width", css_classes=["beam-cal-error"])
        return pn.Column(status, bar, alert, sizing_mode="stretch_width")

    def _readouts(self) -> pn.Row:
        values = pn.bind(bs.readouts, self._beam.param.result)
        items = []
        for key, label, fmt, colors in _READOUTS:
            value = pn.bind(lambda v, k=key: v[k] if math.isfinite(v[k]) else float("nan"), values)
            items.append(pn.indicators.Number(label=label, value=value, format=fmt, colors=colors, font_size="22pt",
                                              title_size="10pt", nan_format="–", margin=(0, 12),
                                              css_classes=[f"beam-cal-{key.replace('_', '-')}"]))
        return pn.Row(*items, sizing_mode="stretch_width")

    def _convergence(self) -> pn.pane.HTML:
        """Convergence notice: grey for a preview, green converged, yellow not (one HTML pane
        whose text changes: see :func:`dashboard.views.panes.alert_html`)."""
        def notice(result):
            c = bs.convergence(result)
            if result is None:
                return alert_html("secondary", "No result yet.")
            if not c["mcmc"]:
                return alert_html("secondary", "Preview (MAP + Laplace): the MCMC posterior follows; convergence is "
                                               "checked then.")
            head = "Converged" if c["converged"] else "<b>Not converged</b> — read the posterior with care"
            warn = html.escape("; " + "; ".join(c["warnings"])) if c["warnings"] else ""
            body = f"{head}: min bulk ESS {c['ess_min']:.0f} (target ≥ 1000), max R-hat {c['rhat_max']:.4f} (≤ 1.01){warn}."
            return alert_html("success" if c["converged"] else "warning", body)

        return pn.pane.HTML(pn.bind(notice, self._beam.param.result), sizing_mode="stretch_width",
                            margin=(0, 10), css_classes=["beam-convergence"])

    def _tab_opened(self, event) -> None:
        if event.new == 1 and self._corner is None:
            self._update_corner()

    def _update_corner(self, *_) -> None:
        if self._tabs.active != 1 and self._corner is None:
            return  # built when its tab is first opened (one figure per pair)
        beam = self._beam
        if beam.result is None:
            return
        names = tuple(bs.summary(beam.result))
        if self._corner is None or self._corner.names != names:
            self._corner = CornerPlot(names, size=150, labels={n: bs.short_label(n) for n in names})
            cells = [pn.pane.Bokeh(fig, sizing_mode="fixed", margin=0) if fig is not None else pn.Spacer(width=150, height=150)
                     for row in self._corner.grid for fig in row]
            grid = pn.GridBox(*cells, ncols=len(names), sizing_mode="fixed")
            self._posterior_tab[:] = [self._posterior_tab[0], grid]
        pinned = beam.pinned if beam.pinned is not None and tuple(bs.summary(beam.pinned)) == names else None
        self._corner.update(_Draws(beam.result), _Draws(pinned) if pinned is not None else None)

    def _compare_buttons(self) -> pn.Card:
        beam = self._beam
        pin = pn.widgets.Button(label="Pin this result", color="primary", sizing_mode="stretch_width",
                                disabled=pn.bind(lambda r: r is None, beam.param.result))
        unpin = pn.widgets.Button(label="Unpin", sizing_mode="stretch_width",
                                  disabled=pn.bind(lambda r: r is None, beam.param.pinned))
        pin.on_click(lambda e: beam.pin())
        unpin.on_click(lambda e: beam.unpin())
        note = Markdown(pn.bind(lambda r: "Pinned result drawn in purple; see *Compare table*." if r is not None
                                        else "Pin a result, then change an input to compare.", beam.param.pinned))
        return pn.Card(pin, unpin, note, title="Compare", collapsible=False, sizing_mode="stretch_width")

    def _downloads(self) -> pn.Card:
        beam = self._beam

        def download(label, ext, make, enabled=lambda r: r is not None):
            widget = pn.widgets.FileDownload(callback=lambda: make(beam.result), filename=f"beam.{ext}", label=label,
                                             sizing_mode="stretch_width",
                                             disabled=pn.bind(lambda r: not enabled(r), beam.param.result))
            beam.param.watch(lambda e: setattr(widget, "filename", bs.filename(e.new, ext)) if e.new is not None else None,
                             "result")
            return widget

        return pn.Card(
            download("Summary (JSON)", "json", bs.summary_json),
            download("Predictive bands (CSV)", "csv", bs.bands_csv),
            download("Posterior (netCDF)", "nc", bs.posterior_netcdf, lambda r: r is not None and r.posterior is not None),
            title="Download", collapsible=False, sizing_mode="stretch_width")
