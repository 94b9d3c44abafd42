"""The page of a cold start: what a visitor sees while the server imports the app for the first time.

The first session after ``panel serve dashboard/app.py`` used to run the app's imports (the
numerical library, HoloViews, the views) inside its request: the browser showed a blank page
for as long (measured 27 s on the class machine). :func:`start` runs those imports, the worker
processes' start and the process set-up on a background thread, and :func:`loading_page` is a
light page (Panel only) that says what is being loaded, second by second; once everything is
imported it reloads itself, and the app opens. ``panel serve dashboard/app.py --warm`` starts
the same thread before the first visitor arrives (``docs/dashboard.md``).

This module imports nothing but Panel: everything heavy is named in :data:`STEPS` and imported
by :func:`start`'s thread.
"""

from __future__ import annotations

import importlib
import threading
import time

import panel as pn

__all__ = ["LOADING_CSS_CLASS", "STEPS", "Startup", "loading_page", "start", "startup"]

#: CSS class of the loading page's text (the browser tests wait until it is gone).
LOADING_CSS_CLASS = "beam-loading-page"

#: (what the visitor reads, modules imported), in import order.
STEPS = (
    ("the numerical library (NumPy, SciPy, the compiled beam kernels)", ("beam.calibration", "beam.discovery.report")),
    ("the dashboard's jobs and worker processes", ("dashboard.jobs.beam", "dashboard.jobs.warm", "dashboard.runtime.server",
                                                   "dashboard.runtime.monitor")),
    ("the plotting library (HoloViews, Bokeh)", ("dashboard.plots.elements",)),
    ("the three views", ("dashboard.state.session", "dashboard.views.tabs")),
)


class Startup:
    """Imports :data:`STEPS` on a thread, then runs ``finish`` (both once); readable from any thread.

    Attributes
    ----------
    step : int
        Index in :data:`STEPS` of the step running (``len(STEPS)`` when done).
    error : str
        The failure of a step, or ``""``.
    """

    def __init__(self, finish=None) -> None:
        self.step = 0
        self.error = ""
        self.started_s = time.monotonic()
        self._finish = finish
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._run, name="beam-startup", daemon=True)

    def begin(self) -> Startup:
        self._thread.start()
        return self

    @property
    def done(self) -> bool:
        """Whether every step ran (successfully or not: see :attr:`error`)."""
        return self._done.is_set()

    def wait(self, timeout_s: float | None = None) -> bool:
        """Block until done (or ``timeout_s``); whether it is done."""
        return self._done.wait(timeout_s)

    def _run(self) -> None:
        try:
            for self.step, (_, modules) in enumerate(STEPS):
                for module in modules:
                    importlib.import_module(module)
            self.step = len(STEPS)
            if self._finish is not None:
                self._finish()
        except Exception as exc:  # shown on the page; the app's own import then reports it in full
            self.error = f"{type(exc).__name__}: {exc}"
        finally:
            self._done.set()

    def text(self) -> str:
        """What the page says now (Markdown)."""
        seconds = time.monotonic() - self.started_s
        lines = []
        for k, (what, _) in enumerate(STEPS):
            mark = "✓" if k < self.step else ("…" if k == self.step and not self.error else "·")
            lines.append(f"{mark} {what}")
        head = (f"**Starting the explorer** ({seconds:.0f} s). The first visit after the server started loads "
                "the numerical and plotting libraries, about half a minute; the page opens by itself when "
                "they are ready, and every later visit opens at once.")
        if self.error:
            head += f"\n\n**The app could not start:** {self.error}"
        return head + "\n\n" + "<br>".join(lines)


_lock = threading.Lock()
_startup: Startup | None = None


def start(finish=None) -> Startup:
    """The process's :class:`Startup`, begun by the first call (later calls return it)."""
    global _startup
    with _lock:
        if _startup is None:
            _startup = Startup(finish).begin()
        return _startup


def startup() -> Startup | None:
    """The process's :class:`Startup`, or None before :func:`start`."""
    return _startup


def loading_page(state: Startup, title: str) -> pn.template.BootstrapTemplate:
    """A light page that shows ``state``'s progress every half second and reloads itself when it is done
    (its title ends in ``": starting"``: the browser tests wait for the app's page)."""
    text = pn.pane.Markdown(state.text(), css_classes=[LOADING_CSS_CLASS], sizing_mode="stretch_width",
                            styles={"font-size": "16px"})
    page = pn.template.BootstrapTemplate(title=f"{title}: starting", main=[text], header_background="#2f4f6f")

    def tick() -> None:
        text.object = state.text()
        if state.done and not state.error:
            callback.stop()
            location = pn.state.location
            if location is not None:  # None in the session ``--warm`` runs without a browser
                location.reload = True
                location.search = f"?started={int(time.time())}"  # a new address: the browser loads the app

    callback = pn.state.add_periodic_callback(tick, period=500)
    return page
