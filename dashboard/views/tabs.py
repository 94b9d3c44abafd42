"""The views of the app, as :class:`pn.viewable.Viewer` classes over one session state.

Each view takes the browser session's :class:`~dashboard.state.session.SessionState` as its only
argument; :data:`VIEWS` lists them in tab order. To add a view, write a
:class:`~dashboard.views.tab.TabView` (its page's steps, what it starts when opened) and, if it
runs ``beam`` jobs, a sub-state on the session whose activities are
:class:`~dashboard.state.run.Run` objects (the session gives each its slot:
:meth:`~dashboard.state.session.SessionState.attach`), and put it in :data:`VIEWS`.
"""

from __future__ import annotations

import panel as pn
import param

from dashboard.state.session import SessionState
from dashboard.views.beam import BeamCalibrationView
from dashboard.views.diagnosis import DiagnosisView
from dashboard.views.joint import JointView
from dashboard.views.panes import Markdown
from dashboard.views.study import StudyView
from dashboard.views.record import RecordView
from dashboard.views.texts import PLACEHOLDER
from dashboard.views.toy import ToyView

__all__ = ["VIEWS", "BeamCalibrationView", "DiagnosisView", "PlaceholderView"]


class PlaceholderView(pn.viewable.Viewer):
    """A view still to come: a title and one paragraph."""

    session = param.ClassSelector(class_=SessionState, doc="State of the browser session.")
    title = "View"
    what = ""

    def __panel__(self):
        return Markdown(PLACEHOLDER.format(title=self.title, what=self.what), sizing_mode="stretch_width")


#: (tab title, Viewer class) in tab order.
VIEWS = (
    ("Toy periodic model", ToyView),
    ("Beam calibration", BeamCalibrationView),
    ("Window study", StudyView),
    ("Diagnosis", DiagnosisView),
    ("Your record", RecordView),
    ("Several records", JointView),
)
