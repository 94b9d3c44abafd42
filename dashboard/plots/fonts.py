"""Text sizes of every plot, for a projected screen (no HoloViews import: the plain bokeh figures use it too).

Plot text is drawn on a canvas, where the page's CSS does not reach: each figure sets its sizes
from here. Nothing a student reads is below :data:`TICKS_PX` = 14 px, the views' smallest text
(``dashboard.views.panes.MIN_TEXT_PX``; the browser test reads the sizes off the Bokeh models).
"""

from __future__ import annotations

__all__ = ["HV_ACTIVE_TOOLS", "HV_FONTSIZE", "LABELS_PX", "LEGEND_PX", "TICKS_PX", "TITLE_PX", "style_figure"]

TITLE_PX = 16
LABELS_PX = 15
TICKS_PX = 14
LEGEND_PX = 14

#: HoloViews' ``active_tools`` option: the drag pans, the mouse wheel scrolls the page (not the plot)
#: until the student picks the wheel zoom in the toolbar.
HV_ACTIVE_TOOLS = ["pan"]
#: HoloViews' ``fontsize`` option with these sizes.
HV_FONTSIZE = {"title": f"{TITLE_PX}px", "labels": f"{LABELS_PX}px", "xticks": f"{TICKS_PX}px",
               "yticks": f"{TICKS_PX}px", "legend": f"{LEGEND_PX}px"}


def style_figure(fig, *, ticks_px: int = TICKS_PX) -> None:
    """Set the title, axis-label, tick-label and legend sizes of a bokeh figure (legends added before),
    and leave the mouse wheel to the page: no scroll tool is active until the student picks the
    wheel zoom in the figure's toolbar (a page scrolled over a plot zoomed the plot instead)."""
    fig.toolbar.active_scroll = None
    fig.title.text_font_size = f"{TITLE_PX}px"
    for axis in (*fig.xaxis, *fig.yaxis):
        axis.axis_label_text_font_size = f"{LABELS_PX}px"
        axis.major_label_text_font_size = f"{ticks_px}px"
    for legend in fig.legend:
        legend.label_text_font_size = f"{LEGEND_PX}px"
