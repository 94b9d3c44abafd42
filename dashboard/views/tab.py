"""What every tab of the app shares: :class:`TabView`, a Viewer built in steps when first opened.

A tab's page is a :attr:`TabView.layout` column holding one line (:attr:`TabView.placeholder`)
until :meth:`TabView.build` replaces it by the pieces :meth:`TabView.steps` makes, one step at a
time on the server's event loop (:func:`dashboard.runtime.staging.run_steps`: no session holds
the loop for long). The app calls :meth:`TabView.activate` when the tab is opened: it builds
the page and starts what the tab runs when opened (:meth:`TabView.start`). A view that opens
another tab sets :attr:`TabView.goto` to its title (the app opens it).
"""

from __future__ import annotations

from collections.abc import Callable

import panel as pn
import param

from dashboard.runtime.staging import run_steps
from dashboard.state.session import SessionState
from dashboard.views.panes import Markdown

__all__ = ["TabView"]


class TabView(pn.viewable.Viewer):
    """A tab over the browser session's state, built when first opened.

    Subclasses give :meth:`steps` (the page's pieces in page order), and may give :meth:`frame`,
    :meth:`start` and :attr:`placeholder`; they set the attributes their tests read (a plot, a table) to None
    in their ``__init__`` and to the piece once built.
    """

    session = param.ClassSelector(class_=SessionState, doc="State of the browser session.")
    goto = param.String("", doc="Title of a tab to open (the app opens it, then clears this).")

    #: What the tab shows before it is built.
    placeholder = "Open this tab."
    #: CSS classes of the page's root column.
    css_classes: tuple[str, ...] = ()
    #: Whether opening this tab also opens (builds and starts) the beam calibration's.
    opens_beam = False

    def __init__(self, **params) -> None:
        super().__init__(**params)
        #: Whether :meth:`build` has run (its steps may still be queued on a served page).
        self.built = False
        #: The view's root panel (what ``__panel__`` returns).
        self.layout = pn.Column(Markdown(self.placeholder), sizing_mode="stretch_width",
                                css_classes=list(self.css_classes))

    def __panel__(self):
        return self.layout

    def frame(self) -> None:
        """Put the page's empty frame (its columns) in place at once, before the steps fill it."""

    def steps(self) -> list[Callable[[], None]]:
        """The callables that build the page's pieces and put them in place, in order."""
        raise NotImplementedError

    def build(self) -> None:
        """Build the page (once): its frame now, its pieces in steps (see :mod:`dashboard.runtime.staging`)."""
        if self.built:
            return
        self.built = True
        self.frame()
        run_steps(self.steps())

    def start(self) -> None:
        """What the tab runs when it is opened (nothing by default)."""

    def activate(self) -> None:
        """Build the page and start what the tab runs (called when the tab is opened)."""
        self.build()
        self.start()

    def open_tab(self, title: str) -> None:
        """Ask the app to show the tab ``title``."""
        self.goto = title
        self.goto = ""
