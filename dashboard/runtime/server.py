"""Once per server process: what the app script sets up before its first session.

:func:`prepare` is idempotent and called at the top of every session's app script (Panel
re-runs ``dashboard/app.py`` for each browser session, so a module-level flag there would not
survive). It

* installs the event-loop lag monitor when ``BEAM_DASHBOARD_LAG_LOG`` is set
  (:mod:`dashboard.runtime.monitor`);
* starts the shared pool's worker processes, which warm up while the first page loads
  (:mod:`dashboard.runtime.workers`);
* serves every resource from this server (:func:`serve_resources_locally`), so that the page
  works without a network;
* collects garbage once and freezes what survives (:func:`gc.freeze`): the libraries the
  server imported (panel, bokeh, pandas, numpy, scipy, beam: hundreds of thousands of
  objects) are never freed anyway, and every full collection scanned them again — measured
  0.19–0.28 s of the event loop per collection while eight sessions opened. After the freeze
  a full collection scans only what the sessions made.
"""

from __future__ import annotations

import gc
import threading

from dashboard.runtime import monitor
from dashboard.runtime.scheduler import shared_pool

__all__ = ["prepare", "serve_resources_locally"]

_lock = threading.Lock()
_prepared = False


def serve_resources_locally() -> None:
    """Make bokeh and Panel serve their JS and CSS from this server, whatever the environment says.

    Why: Panel's components name their stylesheets by CDN address (``loading.css``,
    ``dataframe.css``, ...) and rewrite them to the server's ``static/extensions/panel/`` only
    when bokeh's resources mode is ``server`` (``panel.io.resources.use_cdn`` and the
    ``dist_url`` of ``panel.io.server.server_html_page_for_session``). Any other mode —
    ``BOKEH_RESOURCES=cdn`` or ``inline`` in the environment — leaves them on cdn.holoviz.org:
    measured with ``BOKEH_RESOURCES=inline``, the page requested 18 stylesheets from the CDN
    (loading.css, dataframe.css, markdown.css, the Bootstrap theme, ...), each a console error
    offline. ``settings.resources.set_value`` outranks the environment variable, from the
    second page on: the server renders the first session's page with the mode it started with.
    """
    from bokeh.settings import settings

    settings.resources.set_value("server")


def prepare() -> None:
    """Set up the server process (the first call does the work; later calls return at once)."""
    global _prepared
    with _lock:
        if _prepared:
            return
        _prepared = True
    serve_resources_locally()
    monitor.install()  # only with BEAM_DASHBOARD_LAG_LOG set (a diagnostic)
    shared_pool().start_processes()
    gc.collect()
    gc.freeze()
