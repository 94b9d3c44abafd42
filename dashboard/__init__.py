"""Beam discrepancy explorer: the interactive dashboard (the only UI layer of the project).

Run with ``panel serve dashboard/app.py``. Modules:

* :mod:`dashboard.scheduler` — run scheduler (thread pool, latest-run slots, debounce,
  cooperative cancellation); pure Python.
* :mod:`dashboard.toy_jobs` — preview / streamed MCMC / window-sweep jobs of the toy model;
  pure Python.
* :mod:`dashboard.state` — one :class:`~dashboard.state.SessionState` per browser session
  (param only, no panel).
* :mod:`dashboard.summaries`, :mod:`dashboard.exports` — tables, read-outs and downloads of a
  result; pure Python.
* :mod:`dashboard.toy_plots`, :mod:`dashboard.toy_view` — the "Toy periodic model" view.
* :mod:`dashboard.views` — the other views of the app (placeholders this round).
* :mod:`dashboard.app` — the template with the views as tabs.

The ``beam`` library is reached only through the session state; ``beam`` itself never
imports panel, holoviews or bokeh.
"""
