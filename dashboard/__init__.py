"""Beam discrepancy explorer: the interactive dashboard (the only UI layer of the project).

Run with ``panel serve dashboard/app.py``. Modules:

* :mod:`dashboard.runtime.scheduler` — run scheduler (thread pool, latest-run slots, debounce,
  cooperative cancellation); pure Python.
* :mod:`dashboard.jobs.toy` — preview / streamed MCMC / window-sweep jobs of the toy model;
  pure Python.
* :mod:`dashboard.state.session` — one :class:`~dashboard.state.session.SessionState` per browser session
  (param only, no panel).
* :mod:`dashboard.outputs.toy`, :mod:`dashboard.outputs.exports` — tables, read-outs and downloads of a
  result; pure Python.
* :mod:`dashboard.plots.toy`, :mod:`dashboard.views.toy` — the "Toy periodic model" view.
* :mod:`dashboard.views.tabs` — the other views of the app (placeholders this round).
* :mod:`dashboard.app` — the template with the views as tabs.

The ``beam`` library is reached only through the session state; ``beam`` itself never
imports panel, holoviews or bokeh.
"""
