"""The "Window study" view: the paper's experiment on the beam, cell by cell, on Dask.

A :class:`pn.viewable.Viewer` over ``session.study`` (:class:`~dashboard.state.study.StudyState`);
nothing here calls ``beam`` directly. Pick a dataset, windows (``beam study --windows`` syntax),
effect sets and likelihoods, press *Run the study*: the cells run on the server's Dask cluster and
each appears on the plots (:class:`dashboard.plots.study.StudyPlots`) as it finishes. A click on
a point opens that calibration in the beam view (:meth:`StudyState.open_cell`) and switches to
its tab (:attr:`StudyView.goto`, which the app watches).
"""

from __future__ import annotations

import html

import panel as pn

from beam.study.engine import scheduler_address
from dashboard.outputs.beam import output_units, short_label
from dashboard.plots.study import LIKELIHOOD_TITLES, QUANTITIES, StudyPlots, set_colours, window_label
from dashboard.state.study import LIKELIHOOD_LABELS
from dashboard.views.panes import BUTTON_WRAP, HTML, Markdown, alert_html, run_status, three_columns
from dashboard.views.tab import TabView

__all__ = ["StudyView"]

#: Title of the beam view's tab (where a clicked cell opens).
BEAM_TAB = "Beam calibration"
_STAGE_TEXT = {
    "idle": "Choose windows and effect sets, then run the study.",
    "queued": "Study queued…",
    "running": "Cells running on the Dask cluster; each point appears as its cell finishes…",
    "final": "Study done.",
    "cancelled": "Study cancelled.",
    "error": "The study stopped.",
}
#: The "For the class" text. Its numbers are those of the view's defaults on lab_run_1 (the default
#: dataset: windows grow:0:0.35:2.1, both likelihoods) and of the same study with "+ Patch stiffening"
#: ticked, measured with ``beam study`` (docs/window-study.md, "In the dashboard").
STUDY_GUIDE = """**The paper's finding.** When a model misses physics, *the part of the record it is calibrated on*
decides how well it predicts the rest. Each point here is one full calibration on one window, judged on
the samples after it; a line joins one model's windows, i.i.d. and AR(1) noise side by side.

**On lab_run_1** (the defaults: six windows from the start, 0.35 s to 2.1 s) the default model misses
the piezo patch bonded to the beam:

- the **held-out error** depends on the window: 1.45 mm after the first 0.35 s, 0.93 mm after 2.1 s
  (i.i.d.); with AR(1) noise it stays between 1.09 and 1.31 mm — the noise model does not remove it;
- the **coverage** of the 95 % band is 62 % for the shortest window and 100 % from 1.05 s on (i.i.d.) —
  not a good prediction: the "noise" the model fits there (1.2–1.3 mm, about 80 times the sensor's 15 µm)
  absorbs the physics it misses;
- the **stiffness EI** (i.i.d.) settles near 0.286 N m², 42 % below the beam's true 0.491 N m², and the
  interval of the first window (0.292–0.300) excludes those of the later ones: the estimate drifts with
  the window (with AR(1) noise it even jumps to 0.367 on two windows).

**Tick "+ Patch stiffening" and run again:** from 0.7 s on the error falls 20- to 30-fold, to 0.04–0.06 mm,
and hardly depends on the window; EI moves to 0.491–0.493 N m². The coverage (51–72 %) says something is
still missing — the patch's damping. The window effect is a symptom of missing physics.

**Click a point** to open that calibration in the *Beam calibration* tab."""
WINDOWS_HELP = ("List `0:0.5,0:1,1:2`, growing family `grow:START:STEP:END` (all from START, each STEP longer), "
                "sliding `slide:LENGTH:START:STEP:END`; seconds. Each window × effect set × likelihood is one full "
                "calibration (7–9 s of one core for the default model).")


class StudyView(TabView):
    """Calibrate the beam on many windows at once and watch the held-out error and coverage change.

    Parameters
    ----------
    session : SessionState
        The browser session's state.

    Built when its tab is opened; no study starts before *Run*. :attr:`plots` holds the study's
    figures once built (None before).
    """

    opens_beam = True
    placeholder = "Open this tab to set up a window study."

    def __init__(self, **params) -> None:
        super().__init__(**params)
        self._study = self.session.study
        self.plots: StudyPlots | None = None

    def frame(self) -> None:
        self._left, self._centre, self._right, row = three_columns("study")
        self._top = pn.Row(sizing_mode="stretch_width", css_classes=["study-top"])
        self.layout[:] = [self._top, row]

    def steps(self) -> list:
        return [self._build_status, self._build_plots, self._build_inputs, self._build_side]

    # -- the steps of the build ------------------------------------------------------------------
    def _build_status(self) -> None:
        st = self._study

        def data(entries, total):
            return {"done": len(entries), "total": total, "failed": sum(1 for e in entries if e["row"]["error"])}

        self._legend = HTML("", sizing_mode="stretch_width", margin=(0, 10), css_classes=["study-legend"])
        self._centre.extend([*run_status(st.run, "study-status", _STAGE_TEXT, error_css="study-error", data=data,
                                         depends=(st.param.entries, st.param.total)), self._legend])

    def _build_plots(self) -> None:
        st = self._study
        self.plots = StudyPlots()
        self.plots.on_tap = self._open
        self._parameter = pn.widgets.Select(name="Parameter of the credible intervals", options=[],
                                            sizing_mode="stretch_width", max_width=420,
                                            css_classes=["study-parameter"])
        self._panes = {quantity: {lk: pn.pane.Bokeh(self.plots.figures[quantity][lk], sizing_mode="stretch_width",
                                                    height=250) for lk in LIKELIHOOD_TITLES}
                       for quantity, _ in QUANTITIES}
        rows = {quantity: pn.Row(sizing_mode="stretch_width", css_classes=[f"study-row-{quantity}"])
                for quantity, _ in QUANTITIES}
        self._rows = rows
        self._failed = HTML("", sizing_mode="stretch_width", margin=(0, 10), css_classes=["study-failed"])
        self._centre.extend([rows["error"], rows["coverage"], self._parameter, rows["interval"], self._failed])
        st.param.watch(self._redraw, ["entries", "layout"])
        self._parameter.param.watch(self._redraw, "value")
        self._redraw()

    def _build_inputs(self) -> None:
        st = self._study
        select = pn.widgets.Select(name="Dataset (the beam view's: bundled runs and uploads)", sizing_mode="stretch_width",
                                   max_width=760, css_classes=["study-dataset"])

        def sync(*_):
            select.options = {st.dataset_label(n): n for n in st.param.dataset.objects}
            select.value = st.dataset

        sync()
        st.param.watch(sync, ["dataset"])
        st.beam.param.watch(sync, ["uploads"])
        select.param.watch(lambda e: setattr(st, "dataset", e.new) if e.new != st.dataset else None, "value")
        self._top.append(select)

        windows = pn.widgets.TextInput.from_param(st.param.windows, name="Calibration windows (s)",
                                                  sizing_mode="stretch_width", css_classes=["study-windows"])
        sets = pn.widgets.CheckBoxGroup(inline=False, sizing_mode="stretch_width", css_classes=["study-sets"])

        def sync_sets(*_):
            sets.options = {label: value for label, value in st.effect_set_options().items()}
            sets.value = list(st.effect_sets)

        sync_sets()
        st.param.watch(sync_sets, ["effect_sets"])
        sets.param.watch(lambda e: setattr(st, "effect_sets", list(e.new)) if list(e.new) != list(st.effect_sets)
                         else None, "value")
        likelihoods = pn.widgets.CheckBoxGroup(options=LIKELIHOOD_LABELS, value=list(st.likelihoods), inline=False,
                                               sizing_mode="stretch_width", css_classes=["study-likelihoods"])
        likelihoods.param.watch(lambda e: setattr(st, "likelihoods", list(e.new)), "value")
        run = pn.widgets.Button(label="Run the study", button_type="primary", sizing_mode="stretch_width",
                                css_classes=["study-run"], stylesheets=BUTTON_WRAP)
        cancel = pn.widgets.Button(label="Cancel", sizing_mode="stretch_width", css_classes=["study-cancel"],
                                   disabled=pn.bind(lambda s: s not in ("queued", "running"), st.run.param.stage))
        run.on_click(lambda e: st.start())
        cancel.on_click(lambda e: st.cancel())
        address = scheduler_address(None)
        where = (f"the Dask scheduler at `{address}`" if address else
                 "a Dask cluster on this server (one worker process per core, started by the first study)")
        self._left.append(pn.Card(
            windows, Markdown(WINDOWS_HELP, margin=(0, 10)),
            Markdown("**Effect sets** (one line each)", margin=(5, 10, 0, 10)), sets,
            Markdown("**Likelihoods** (side by side)", margin=(5, 10, 0, 10)), likelihoods,
            run, cancel, Markdown(f"Runs on {where}.", margin=(0, 10)),
            title="Study", collapsible=False, sizing_mode="stretch_width"))

    def _build_side(self) -> None:
        self._right.append(pn.Card(Markdown(STUDY_GUIDE, sizing_mode="stretch_width"), title="For the class",
                                   collapsible=True, collapsed=False, sizing_mode="stretch_width",
                                   css_classes=["study-class-guide"]))

    # -- updates ---------------------------------------------------------------------------------
    def _set_labels(self) -> dict[tuple[str, ...], str]:
        st = self._study
        labels = {}
        for label, text in st.effect_set_options().items():
            labels[tuple(e for e in text.split(",") if e)] = label
        return labels

    def _redraw(self, *_) -> None:
        st = self._study
        entries, layout = st.entries, st.layout
        shown = {cell.likelihood for _, cell in layout} or set(st.likelihoods) or set(LIKELIHOOD_TITLES)
        for quantity, row in self._rows.items():  # the likelihoods of the study, side by side
            panes = [pane for lk, pane in self._panes[quantity].items() if lk in shown]
            if row.objects != panes:
                row.objects = panes
        names = list(dict.fromkeys(n for e in entries for n in e["row"].get("parameters", {})))
        units = output_units(st.measurement(layout[0][1].record) if layout else st.measurement())
        options = {short_label(n, units.si_unit): n for n in names}
        if options != self._parameter.options:
            keep = self._parameter.value
            self._parameter.options = options
            self._parameter.value = keep if keep in names else (names[0] if names else None)
        parameter = self._parameter.value
        labels = self._set_labels()
        self.plots.show(layout, entries, unit_scale=units.plot_scale, unit=units.plot_unit, parameter=parameter,
                         parameter_label=short_label(parameter, units.si_unit) if parameter else "Parameter",
                         set_labels=labels)
        sets = list(dict.fromkeys(cell.effects for _, cell in layout))
        colours = set_colours(sets)
        self._legend.object = "".join(
            f'<span style="display:inline-block;margin-right:16px;"><span style="display:inline-block;width:14px;'
            f'height:14px;border-radius:7px;background:{colours[s]};vertical-align:middle;"></span> '
            f'{html.escape(labels.get(s, ", ".join(s)))}</span>' for s in sets)
        failed = [e for e in entries if e["row"]["error"]]
        self._failed.object = "" if not failed else alert_html("warning", "<b>Failed cells</b> (the others went on):<ul>" + "".join(
            f"<li>{window_label(e['cell'].window)} s, {html.escape(labels.get(e['cell'].effects, ', '.join(e['cell'].effects)))}, "
            f"{e['cell'].likelihood}: {html.escape(e['row']['error'])}</li>" for e in failed) + "</ul>")

    def _open(self, position: int) -> None:
        """A click on a cell's point: open that calibration in the beam view and show it."""
        st = self._study
        entry = next((e for e in st.entries if e["position"] == position), None)
        if entry is None:
            return
        st.open_cell(entry)
        self.open_tab(BEAM_TAB)
