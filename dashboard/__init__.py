"""Beam discrepancy explorer: the interactive dashboard (the only UI layer of the project).

Run with ``panel serve dashboard/app.py`` (``--warm`` for a class). Sub-packages, lowest first
(a module imports only from its own folder or the ones listed before it;
``tests/test_architecture.py`` checks it):

* :mod:`dashboard.runtime` — serving machinery that knows no job: run scheduler, worker
  processes, staged page builds, server set-up, lag monitor, caches.
* :mod:`dashboard.jobs` — what runs in the worker processes (toy and beam runs, diagnosis,
  warm-up); pure Python.
* :mod:`dashboard.outputs` — read-outs, tables and downloads of a result; pure Python.
* :mod:`dashboard.state` — one :class:`~dashboard.state.session.SessionState` per browser
  session (param only, no panel).
* :mod:`dashboard.plots` — figures updated in place.
* :mod:`dashboard.views` — the tabs (Panel Viewers), shared panes, texts for the class.
* :mod:`dashboard.app` — the served script: the template with the views as tabs.

The ``beam`` library is reached only through the session state; ``beam`` itself never
imports panel, holoviews or bokeh.
"""
