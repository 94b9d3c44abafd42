"""Beam discrepancy explorer: ``panel serve dashboard/app.py``.

Builds one :class:`~dashboard.state.session.SessionState` per browser session, wires its updates onto
the session's event loop, and shows the views of :data:`dashboard.views.tabs.VIEWS` as tabs of a
:class:`pn.template.BootstrapTemplate` (all its resources are bundled with Panel, so the app
works offline). Needs nothing but the repository.

What runs where (eight sessions at once, every request answered within a second; the measured
reasons are in ``docs/decisions.md``):

* this script runs on the server's event loop for each new browser session, so it builds only
  a skeleton; the views build their pieces in steps once the page is connected
  (:mod:`dashboard.runtime.staging`, one step at a time across all sessions);
* inference runs in worker processes (:mod:`dashboard.runtime.workers`), started once per server
  with the rest of the process set-up (:func:`dashboard.runtime.server.prepare`);
* the first toy run starts when the page has loaded (``pn.state.onload``), at once (no
  debounce), so the preview is on screen moments later;
* with ``panel serve --warm`` the server says it is ready only once everything is imported, the
  worker processes are warm and the first results a class asks for are in the caches
  (:func:`warm_results`): the first visitor gets the app and its results at once.

``BEAM_DASHBOARD_LAG_LOG=lag.jsonl`` records where the event loop stalls
(:mod:`dashboard.runtime.monitor`).
"""

from __future__ import annotations

import sys
import time
from functools import partial
from pathlib import Path

_ROOT = str(Path(__file__).resolve().parents[1])
if _ROOT not in sys.path:  # `panel serve dashboard/app.py` only puts dashboard/ on the path
    sys.path.insert(0, _ROOT)

import panel as pn
from panel.io.resources import LOCAL_DIST
from panel.io.state import set_curdoc

# Only Panel and the loading page at the top: the first session of a server shows the loading page
# at once while the rest is imported on a thread (dashboard.views.loading), then the app.
from dashboard.views.loading import loading_page, start

__all__ = ["create_app", "session_dispatch"]

TITLE = "Beam discrepancy explorer"


def session_dispatch(doc):
    """A dispatch function that runs callbacks on ``doc``'s event loop (safe from any thread).

    Each callback runs with the document held (:func:`dashboard.runtime.staging.held`): every
    change it makes reaches the browser in the order it was made.
    """

    from dashboard.runtime.staging import held

    def dispatch(fn):
        with set_curdoc(doc):
            pn.state.execute(partial(held, doc, fn), schedule=True)

    return dispatch


def create_app(session: SessionState | None = None) -> pn.template.BootstrapTemplate:
    """The template with one tab per view, all over one session state.

    Parameters
    ----------
    session : SessionState, optional
        Default: a new one whose updates are dispatched to the current document.
    """
    from dashboard.jobs.warm import schedule_warm_up
    from dashboard.state.session import SessionState
    from dashboard.views.panes import ROOT_CSS, ClassroomDesign
    from dashboard.views.status import session_status
    from dashboard.views.tabs import VIEWS

    pn.extension("filedropper", notifications=False)  # the upload widget (built with the Beam tab, after load)
    doc = pn.state.curdoc
    if session is None:
        session = SessionState(dispatch=session_dispatch(doc) if doc is not None else None)
    if doc is not None and doc.session_context is not None:
        pn.state.on_session_destroyed(lambda context: session.close())
        # Panel rewrites its components' stylesheets (named by CDN address) to the server's copy
        # using the document's ``dist_url``, which it sets only when the page is rendered; a model
        # made before (the staged build runs on the next ticks) kept the CDN address, and the page
        # asked cdn.holoviz.org for loading.css and dataframe.css. Set it now, as Panel will (Panel 1.9.4 has no
        # public way to set a document's template variables before the page is rendered: a Panel internal).
        doc._template_variables.setdefault("dist_url", f"{pn.state.rel_path}/{LOCAL_DIST}" if pn.state.rel_path
                                           else LOCAL_DIST)
    views = {title: view(session=session) for title, view in VIEWS}
    tabs = pn.Tabs(*views.items(), sizing_mode="stretch_width", css_classes=["beam-views"])

    def shown(active: int) -> None:
        """Only the open tab's page is visible to the layout (bokeh ``visible``).

        Why: Panel's tabs stack every tab's page in one grid cell and hide the others after each
        layout, so every change of a page's children (a diagnosis's rows, a new rung) laid out and
        repainted the hidden pages' plots as well: over one diagnosis of lab_run_1, the toy tab's
        three plots and the beam plot were each painted three times (~0.8 s of chromium's CPU, on
        the two cores the diagnosis's worker processes need). Invisible, they are skipped
        (renderer main-thread CPU over that diagnosis 3.2-3.5 -> 2.7-2.9 s)."""
        pages = tabs.objects
        pages[active].visible = True
        for i, page in enumerate(pages):
            if i != active:
                page.visible = False

    shown(tabs.active)

    beam_view = views.get("Beam calibration")

    def opened(event) -> None:  # the beam views start their (heavier) jobs when first opened
        shown(event.new)
        view = list(views.values())[event.new]
        if view.opens_beam and beam_view is not None:  # the tabs about the beam view's record start it too
            beam_view.activate()
        view.activate()

    tabs.param.watch(opened, "active")
    for view in views.values():  # a view may open another tab (the window study: a cell in the beam view)
        view.param.watch(lambda event: setattr(tabs, "active", list(views).index(event.new)) if event.new else None,
                         "goto")

    diagnosis_view = views.get("Diagnosis")
    if hasattr(diagnosis_view, "prebuild"):
        def prebuild(event) -> None:  # once the beam view's first calibration is final: the server is idle
            if event.new == "final":
                session.beam.run.param.unwatch(prebuild_watcher)
                diagnosis_view.prebuild()

        prebuild_watcher = session.beam.run.param.watch(prebuild, "stage")

    def start() -> None:
        session.toy.request(debounce=False)
        schedule_warm_up(session.pool)

    if doc is not None and doc.session_context is not None:
        # Not before the page is connected: changes made to the document before the browser
        # has pulled it can reach it as patches to models it does not know.
        pn.state.onload(start)
    else:
        start()
    # one status line for the whole session, above the tabs and always in view (dashboard.views.status)
    template = pn.template.BootstrapTemplate(title=TITLE, main=[session_status(session), tabs], header_background="#2f4f6f",
                                             design=ClassroomDesign, raw_css=[ROOT_CSS])
    template.session_state = session  # for tests and debugging
    template.views = views
    template.tab_titles = list(views)  # the titles the tabs show (for tests)
    return template


def start_workers() -> None:
    """Start the shared pool's worker processes with their warm-up (on the start-up thread, once
    the imports are done: they warm up while the first visitor still reads the loading page)."""
    from dashboard.jobs.beam import warm_worker
    from dashboard.runtime import scheduler

    scheduler.set_worker_warm_up(warm_worker)  # before the pool starts its worker processes
    scheduler.shared_pool().start_processes()


def warming() -> bool:
    """Whether this run of the script is ``panel serve --warm``'s, before the server starts: its
    document's session has no server."""
    context = getattr(pn.state.curdoc, "session_context", None)
    return context is not None and getattr(context, "server_context", None) is None


def warm_results(timeout_s: float = 300.0) -> None:
    """What the first visitors ask for first, computed while ``--warm`` holds the server's start: the
    landing's toy result, the default record's calibration and its diagnosis, kept in the process's
    caches (:mod:`dashboard.jobs.toy`, :mod:`dashboard.jobs.beam`), and the worker processes warm."""
    from dashboard.state.session import SessionState

    session = SessionState()
    try:
        session.toy.request(debounce=False)
        session.beam.request(debounce=False)
        session.wait(timeout_s)
        session.diagnosis.request()
        session.wait(timeout_s)
    finally:
        session.close()


if __name__.startswith("bokeh"):
    _startup = start(start_workers)  # once per server process (``--warm``: before the first visitor)
    if warming() and not _startup.done:
        # ``--warm``: the server says it is ready when this returns, so the page is usable then (not
        # the loading page: that is for a start without --warm)
        _startup.wait()
        if not _startup.error:
            warm_results()
    if not _startup.done or _startup.error:
        loading_page(_startup, TITLE).servable(title=f"{TITLE}: starting")  # the title tells it apart (tests)
    else:
        from dashboard.runtime import monitor, server

        server.prepare()  # once per server process, on the event loop: lag monitor, gc freeze
        _t0 = time.perf_counter()
        create_app().servable(title=TITLE)
        if monitor.current() is not None:
            monitor.current().note("session script", seconds=round(time.perf_counter() - _t0, 3))
