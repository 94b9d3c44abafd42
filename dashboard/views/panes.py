"""Panes shared by the views.

:func:`alert_html`
    The HTML of a coloured notice (Bootstrap's alert colours, inline). For a notice whose
    colour follows the results: in the browser a change of a model's ``css_classes`` (what
    :class:`panel.pane.Alert` changes with ``alert_type``) costs 0.2–0.3 s of re-layout per
    change (measured in chromium on the beam view), a change of an HTML pane's text ~1 ms.
:func:`status_html`
    A run's status line with its state in ``data-*`` attributes (read by the browser tests).
:class:`HTML`, :class:`DataFrame`
    Panel's panes, but their stylesheets stay on this server (:class:`LocalStylesheets`).
:class:`Markdown`
    Panel's Markdown pane (stylesheets on this server too), but each text is converted to HTML once per server process: Panel
    renders the Markdown in Python (markdown-it) every time a pane is made or its text
    changes, ~5–15 ms for the guides of the views, and every session makes the same panes on
    the server's event loop.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from html import escape as html_escape

import panel as pn

from dashboard.state.run import BUSY

__all__ = ["ALERT_COLOURS", "WRAP", "bar_percent", "compare_card", "download_card", "run_status", "BASE_TEXT_PX", "BUTTON_WRAP", "ClassroomDesign", "FLEX_ITEM_GUIDE", "FLEX_ITEM_INPUTS", "FLEX_ITEM_MAIN", "DataFrame",
           "HTML", "MIN_TEXT_PX", "corner_grid", "diagnosis_download", "Markdown", "READABLE_CSS", "ROOT_CSS", "alert_html",
           "status_html", "three_columns"]

#: Layout of the views (CSS, shared with the diagnosis view): a wrapping flex row of a fixed
#: input column, a main column that takes the rest, and the "For the class" panel, which
#: wraps below when the window is too narrow for three columns.
FLEX_ITEM_INPUTS = {"flex": "0 0 300px", "min-width": "0"}
FLEX_ITEM_MAIN = {"flex": "1 1 560px", "min-width": "0"}
#: The class panel stays in view while the main column scrolls (it was blank beside the lower
#: plots and tables): sticky at the top of the scrolled area, its own scroll bar when longer than
#: the window (the template's header and the tab bar take ~110 px).
FLEX_ITEM_GUIDE = {"flex": "1 1 300px", "min-width": "0", "max-width": "460px", "position": "sticky", "top": "0",
                   "max-height": "calc(100vh - 110px)", "overflow-y": "auto"}
#: Lets a button's label wrap instead of spilling over its edges.
BUTTON_WRAP = [":host .bk-btn { white-space: normal; text-align: center; }"]

#: Smallest text a student reads on a projected 1280 x 800 screen (px): the base size of every
#: widget and pane (Bokeh's ``--bokeh-font-size``, 12 px by default), of buttons (Bootstrap's
#: 0.8 rem, 12.8 px), of ``<small>`` and ``<code>`` (0.875 of the base, 10.5 px before) and of
#: the tables (Panel's ``dataframe.css``: 12 px).
MIN_TEXT_PX = 14
#: The text size of the views (px).
BASE_TEXT_PX = 15
#: The template's own stylesheet: the base size, inherited by every component's shadow root
#: (a CSS custom property crosses shadow boundaries).
ROOT_CSS = f":root {{ --bokeh-font-size: {BASE_TEXT_PX}px; }}"
#: Added to every component by :class:`ClassroomDesign` (after Bootstrap's sheet, so it wins);
#: a button's label, a check box's label and a row of tabs wrap (at 15 px, "4. Drift, 12 s, AR(1)"
#: ran past its half of the column, "Patch stiffening (Δρ in kg/m, ΔEI in N m²)" past the input
#: column, the beam view's fourth result tab past the main column at 1280 px).
READABLE_CSS = (f".bk-btn {{ --bs-btn-font-size: {BASE_TEXT_PX}px; white-space: normal; }} "
                f"small, code, .bk-slider-value {{ font-size: max({MIN_TEXT_PX}px, 0.9em); }} "
                f":host table.panel-df {{ font-size: {BASE_TEXT_PX}px; }} "
                ".bk-input-group label { white-space: normal; } :host(.bk-above) .bk-headers-wrapper { flex-wrap: wrap; }")


class ClassroomDesign(pn.theme.Bootstrap):
    """Panel's Bootstrap design with :data:`READABLE_CSS` on every component: nothing a student
    reads is drawn smaller than :data:`MIN_TEXT_PX` (``tests/browser/test_projector_browser.py``)."""

    modifiers = {
        **pn.theme.Bootstrap.modifiers,
        pn.viewable.Viewable: {"stylesheets": [*pn.theme.Bootstrap.modifiers[pn.viewable.Viewable]["stylesheets"],
                                               READABLE_CSS]},
    }


#: Background, text and border colours of :func:`alert_html` by kind (Bootstrap 5's alerts).
ALERT_COLOURS = {
    "secondary": ("#e2e3e5", "#41464b", "#d3d6d8"),
    "success": ("#d1e7dd", "#0f5132", "#badbcc"),
    "warning": ("#fff3cd", "#664d03", "#ffecb5"),
    "danger": ("#f8d7da", "#842029", "#f5c2c7"),
}


def alert_html(kind: str, html: str) -> str:
    """``html`` in a box coloured as a Bootstrap alert of ``kind`` (a key of :data:`ALERT_COLOURS`);
    ``data-kind`` carries the kind for tests."""
    background, colour, border = ALERT_COLOURS[kind]
    return (f'<div class="notice" data-kind="{kind}" style="background:{background};color:{colour};'
            f'border:1px solid {border};border-radius:6px;padding:8px 12px;overflow-wrap:anywhere;">{html}</div>')


def status_html(css: str, stage: str, status: str, requested: int, shown: int, text: str, **data) -> str:
    """The status line, with the state in ``data-*`` attributes (read by the browser tests)."""
    attrs = " ".join(f'data-{k.replace("_", "-")}="{v}"' for k, v in data.items())
    detail = f" <small>({html_escape(status)})</small>" if status else ""
    return (f'<div class="{css}" data-stage="{stage}" data-requested="{requested}" data-shown="{shown}" {attrs}>'
            f"<b>{text}</b>{detail}</div>")


#: An error's box keeps its text inside: a long word (a path, a quoted header) wraps.
WRAP = {"overflow-wrap": "anywhere", "word-break": "break-word", "max-width": "100%"}


def bar_percent(stage: str, fraction: float) -> int:
    """A run's progress bar (%): full at the end, the fraction done while it works, else empty."""
    if stage in ("final", "read"):
        return 100
    return round(100 * fraction) if stage in BUSY else 0


def run_status(run, css: str, texts: dict, *, error_css: str | None = None, data=None, text=None, depends=(),
               bar: bool = True, bar_label: str | None = None) -> list:
    """A run's status line (:func:`status_html`: the state in ``data-*`` attributes for the tests)
    with its progress bar, and its error (a red box, shown only when there is one), from the
    run's parameters: two panes, for a page's column. (The session's one status line above the tabs,
    :mod:`dashboard.views.status`, is the one that stays in view.)

    Parameters
    ----------
    run : dashboard.state.run.Run
        The run shown.
    css, error_css : str
        CSS classes of the status line and of the error box (default ``CSS-error``).
    texts : dict
        The status line's words in bold by stage.
    data, text : callable, optional
        ``data(*values)``: extra ``data-*`` attributes; ``text(stage, *values)``: the words instead
        of ``texts``; ``values`` are those of ``depends`` (parameters of other objects).
    bar, bar_label : bool, str
        Whether there is a progress bar, and its label.
    """
    p = run.param

    def line(stage, status, requested, shown, *values):
        words = text(stage, *values) if text is not None else texts.get(stage, stage)
        return status_html(css, stage, status, requested, shown, words, **(data(*values) if data is not None else {}))

    head = [HTML(pn.bind(line, p.stage, p.status, p.requested, p.shown, *depends), sizing_mode="stretch_width",
                 margin=(5, 10, 0, 10))]
    if bar:
        head.append(pn.indicators.Progress(value=pn.bind(bar_percent, p.stage, p.progress), max=100, height=14,
                                           sizing_mode="stretch_width", margin=(0, 10), bar_color="primary",
                                           **({"label": bar_label} if bar_label else {})))
    alert = pn.pane.Alert(pn.bind(lambda e: f"**Error:** {e}" if e else "", p.error), alert_type="danger",
                          visible=pn.bind(bool, p.error), sizing_mode="stretch_width", css_classes=[error_css or f"{css}-error"],
                          styles=WRAP)
    return [pn.Column(*head, sizing_mode="stretch_width", css_classes=[f"{css}-line"]), alert]


def compare_card(state, colour: str) -> pn.Card:
    """The "Compare" card of a result (``state.result``, ``state.pinned``): pin the shown result, unpin it;
    ``colour`` names the pinned result's colour on the plot."""
    pin = pn.widgets.Button(label="Pin this result", color="primary", sizing_mode="stretch_width",
                            disabled=pn.bind(lambda r: r is None, state.param.result))
    unpin = pn.widgets.Button(label="Unpin", color="default", sizing_mode="stretch_width",
                              disabled=pn.bind(lambda r: r is None, state.param.pinned))
    pin.on_click(lambda event: state.pin())
    unpin.on_click(lambda event: state.unpin())
    note = Markdown(pn.bind(lambda r: f"Pinned result drawn in {colour}; see *Compare table*." if r is not None
                            else "Pin a result, then change an input to compare.", state.param.pinned))
    return pn.Card(pin, unpin, note, title="Compare", collapsible=False, sizing_mode="stretch_width")


def download_card(state, module, owner: str) -> pn.Card:
    """The "Download" card of a result (``state.result``): the printable summary, the JSON summary, the
    predictive bands and the MCMC posterior, each written by ``module``'s function of the same name
    (``summary_html``, ``summary_json``, ``bands_csv``, ``posterior_netcdf``) and named by its
    ``filename(result, extension)``; ``owner`` names the file before the first result."""

    def download(label: str, ext: str, make, enabled=lambda r: r is not None) -> pn.widgets.FileDownload:
        widget = pn.widgets.FileDownload(callback=lambda: make(state.result), filename=f"{owner}.{ext}", label=label,
                                         color="default", sizing_mode="stretch_width",
                                         disabled=pn.bind(lambda r: not enabled(r), state.param.result))
        state.param.watch(lambda e: setattr(widget, "filename", module.filename(e.new, ext)) if e.new is not None
                          else None, "result")
        return widget

    return pn.Card(
        download("Summary for print (HTML)", "html", module.summary_html),
        download("Summary (JSON)", "json", module.summary_json),
        download("Predictive bands (CSV)", "csv", module.bands_csv),
        download("Posterior (netCDF)", "nc", module.posterior_netcdf, lambda r: r is not None and r.posterior is not None),
        title="Download", collapsible=False, sizing_mode="stretch_width")


def three_columns(prefix: str) -> tuple[pn.Column, pn.Column, pn.Column, pn.FlexBox]:
    """The views' wrapping layout: an input column, a main column and the "For the class" column
    (CSS classes ``PREFIX-inputs``, ``PREFIX-main``, ``PREFIX-guide``), and the flex row holding them."""
    left = pn.Column(sizing_mode="stretch_width", styles=FLEX_ITEM_INPUTS, css_classes=[f"{prefix}-inputs"])
    centre = pn.Column(sizing_mode="stretch_width", min_height=600, styles=FLEX_ITEM_MAIN, css_classes=[f"{prefix}-main"])
    right = pn.Column(sizing_mode="stretch_width", styles=FLEX_ITEM_GUIDE, css_classes=[f"{prefix}-guide"])
    row = pn.FlexBox(left, centre, right, flex_wrap="wrap", align_items="flex-start", sizing_mode="stretch_width")
    return left, centre, right, row


def corner_grid(grid: list[list], size: int) -> pn.Column:
    """The pair plot's figures (rows of :attr:`dashboard.plots.corner.CornerPlot.grid`, None above
    the diagonal) as one pane each in a grid of ``size`` px cells (not a bokeh GridPlot, see
    :mod:`dashboard.plots.corner`), in a column that scrolls sideways when the grid is wider
    than it: its last column (the noise σ) ran over the class panel at 1280 px."""
    cells = [pn.pane.Bokeh(fig, sizing_mode="fixed", margin=0) if fig is not None
             else pn.Spacer(width=size, height=grid[i][0].height, margin=0)
             for i, row in enumerate(grid) for fig in row]
    return pn.Column(pn.GridBox(*cells, ncols=len(grid), sizing_mode="fixed"), sizing_mode="stretch_width",
                     styles={"overflow-x": "auto", "max-width": "100%"}, css_classes=["pair-plot"])


def diagnosis_download(diagnosis_state) -> pn.widgets.FileDownload:
    """"Diagnosis for print (HTML)": the page ``beam diagnose --report`` writes, of the diagnosis
    and ladder ``diagnosis_state`` (a :class:`~dashboard.state.beam.DiagnosisState`) shows;
    enabled once the diagnosis is complete."""
    from dashboard.outputs.beam import diagnosis_html

    d = diagnosis_state

    def name() -> str:
        return f"{d.diagnosis.base.setup.measurement.name}_diagnosis.html" if d.diagnosis is not None else "diagnosis.html"

    widget = pn.widgets.FileDownload(callback=lambda: diagnosis_html(d.diagnosis, d.ladder), filename="diagnosis.html",
                                     label="Diagnosis for print (HTML)", sizing_mode="stretch_width",
                                     css_classes=["diag-download"],
                                     disabled=pn.bind(lambda diagnosis: diagnosis is None or bool(diagnosis.pending),
                                                      d.param.diagnosis))
    d.param.watch(lambda event: setattr(widget, "filename", name()), "diagnosis")
    return widget


_CACHE_SIZE = 256
_cache: OrderedDict = OrderedDict()
_lock = threading.Lock()


class LocalStylesheets:
    """Mixin for Panel's HTML-type panes: their stylesheets are never rewritten to the CDN.

    Why: when the text of such a pane changes while its bokeh model is not attached to the
    document (a pane in a tab not shown, ``dynamic=True``), Panel 1.9 recomputes the model's
    properties with ``doc=None`` (``HTMLBasePane._update``: ``model.document``), and without a
    document it resolves the pane's stylesheets (``loading.css``, ``markdown.css``,
    ``dataframe.css``, the theme's) to cdn.holoviz.org; the browser requested them from there
    when the tab was opened. Measured: 30 such updates in one session (load, two tabs opened).
    Falling back to the current document, whose ``dist_url`` is this server's, keeps them local.
    """

    # Panel 1.9 internal (Panel has no public hook for a pane's stylesheets without a document)
    def _get_properties(self, doc):
        return super()._get_properties(doc if doc is not None else pn.state.curdoc)


class HTML(LocalStylesheets, pn.pane.HTML):
    """:class:`panel.pane.HTML` with its stylesheets on this server (:class:`LocalStylesheets`)."""


class DataFrame(LocalStylesheets, pn.pane.DataFrame):
    """:class:`panel.pane.DataFrame` with its stylesheets on this server (:class:`LocalStylesheets`)."""


class Markdown(LocalStylesheets, pn.pane.Markdown):
    """:class:`panel.pane.Markdown` with the HTML of each text cached (LRU, process-wide)."""

    # Panel 1.9 internal (Panel has no public hook to cache a pane's rendered HTML)
    def _transform_object(self, obj) -> dict:
        if not isinstance(obj, str):
            return super()._transform_object(obj)
        key = (obj, self.renderer, tuple(map(repr, self.plugins)), self.hard_line_break, self.disable_anchors,
               self.dedent, tuple(self.extensions), repr(sorted(self.renderer_options.items())))
        with _lock:
            hit = _cache.get(key)
            if hit is not None:
                _cache.move_to_end(key)
                return dict(hit)
        out = super()._transform_object(obj)
        with _lock:
            _cache[key] = dict(out)
            while len(_cache) > _CACHE_SIZE:
                _cache.popitem(last=False)
        return out
