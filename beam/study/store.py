"""A study's output folder: one stored result per cell (what a resumed study reuses) and the tables.

Layout for ``--out PREFIX``:

``PREFIX.cells/KEY.json``, ``PREFIX.cells/KEY.npz``
    One finished cell: its identity, ``--json`` row, extra numbers, task times and when it was
    computed; its kept posterior draws. ``KEY`` is :meth:`beam.study.cells.StudyCell.key` (record
    content, options, seed, code version). The ``.npz`` is written first and the ``.json`` last,
    each atomically: a cell whose ``.json`` exists is complete. Failed cells are not stored (a
    resumed study tries them again).
``PREFIX.csv``
    The tidy table: one row per cell (see :func:`cell_table`).
``PREFIX.summary.csv``
    Across records: one row per window position, effect set and likelihood (:func:`summary_table`).
``PREFIX.nc``
    ArviZ InferenceData, the kept posterior draws of every cell (:func:`posterior_dataset`).
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import asdict
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from beam.io.text import atomic_write_texts
from beam.study.cells import DRAWS_KEPT, StudyCell

__all__ = ["CellStore", "cell_table", "posterior_dataset", "summary_table"]

SUMMARY_STATS = ("mean", "sd", "q025", "q975")


class CellStore:
    """The stored cells under ``PREFIX.cells/``.

    Parameters
    ----------
    prefix : str or Path
        Output prefix (its folder is created on the first write).
    version : str
        Code version (:func:`beam.study.cells.code_version`) that is part of every key.
    """

    def __init__(self, prefix: str | os.PathLike, version: str):
        self.prefix = Path(prefix)
        self.folder = self.prefix.with_name(self.prefix.name + ".cells")
        self.version = version

    def key(self, cell: StudyCell) -> str:
        return cell.key(self.version)

    def load(self, cell: StudyCell) -> dict | None:
        """The stored outcome of ``cell`` (``row``, ``extra``, ``draws``, ``task``, ``computed_utc``), or None."""
        key = self.key(cell)
        path = self.folder / f"{key}.json"
        try:
            stored = json.loads(path.read_text(encoding="utf-8"))
            with np.load(self.folder / f"{key}.npz", allow_pickle=False) as data:
                draws = {name: data[name] for name in data.files}
        except (OSError, ValueError):
            return None
        if stored.get("key") != key or stored.get("row", {}).get("error") is not None:
            return None
        stored["row"]["record"] = cell.record  # the same content may be named otherwise this time
        return {"row": stored["row"], "extra": stored["extra"], "draws": draws, "task": stored["task"],
                "computed_utc": stored["computed_utc"]}

    def save(self, cell: StudyCell, outcome: dict) -> str:
        """Store a finished cell (not a failed one); returns the time it is stamped with (UTC, ISO 8601)."""
        stamp = datetime.now(timezone.utc).isoformat(timespec="milliseconds")
        if outcome["row"]["error"] is not None:
            return stamp
        key = self.key(cell)
        self.folder.mkdir(parents=True, exist_ok=True)
        npz = self.folder / f"{key}.npz"
        temporary = self.folder / f"{key}.tmp.npz"
        np.savez(temporary, **outcome["draws"])
        temporary.replace(npz)
        document = {"key": key, "code_version": self.version, "cell": asdict(cell), "row": outcome["row"],
                    "extra": outcome["extra"], "task": outcome["task"], "computed_utc": stamp}
        atomic_write_texts({self.folder / f"{key}.json": json.dumps(document, allow_nan=False, indent=1)})
        return stamp


def _effects_label(effects) -> str:
    return "+".join(effects) if effects else "none"


def cell_table(entries: list[dict]):
    """The tidy table of a study (a :class:`pandas.DataFrame`, one row per cell, in study order).

    ``entries`` are dicts with ``cell`` (:class:`StudyCell`), ``index`` (window position within
    the record), ``key``, ``row``, ``extra``, ``reused``, ``computed_utc``. Columns: record,
    window_index, window_start_s, window_end_s, effects (ids joined by ``+``, ``none`` for the
    bare model), likelihood, modes, output_unit, rmse_calibration, rmse_prediction,
    coverage95_prediction, width95_prediction, noise_sd, ess_min, rhat_max, seconds, error,
    reused, computed_utc, cell_key, then ``PARAMETER_mean``, ``_sd``, ``_q025``, ``_q975`` of
    every parameter (empty where a cell's model has none). RMSE, widths and noise in the
    record's output unit (m for displacement).
    """
    import pandas as pd

    rows = []
    for e in entries:
        row, extra, cell = e["row"], e["extra"], e["cell"]
        window = row["window"]
        out = {"record": row["record"], "window_index": e["index"], "window_start_s": window[0],
               "window_end_s": window[1], "effects": _effects_label(row["effects"]), "likelihood": row["likelihood"],
               "modes": extra.get("modes", cell.modes if isinstance(cell.modes, int) else None),
               "output_unit": extra.get("output_unit"),
               "rmse_calibration": row["rmse_calibration"], "rmse_prediction": row["rmse_prediction"],
               "coverage95_prediction": row["coverage95_prediction"],
               "width95_prediction": extra.get("width95_prediction"), "noise_sd": extra.get("noise_sd"),
               "ess_min": row["ess_min"], "rhat_max": row["rhat_max"], "seconds": row["seconds"],
               "error": row["error"] or "", "reused": bool(e["reused"]), "computed_utc": e["computed_utc"],
               "cell_key": e["key"]}
        for name, stats in row["parameters"].items():
            out.update({f"{name}_{s}": stats[s] for s in SUMMARY_STATS})
        rows.append(out)
    return pd.DataFrame(rows)


def summary_table(table):
    """Across records: per window position, effect set and likelihood, the number of records and
    failed cells, the window when every record had the same (else NaN), the mean held-out
    coverage of the 95 % band, and the median held-out RMSE relative to each record's best
    window for that effect set and likelihood (1 = the best window; unit-free, so records of
    different sensors can be pooled)."""
    import pandas as pd

    ok = table[table["error"] == ""].copy()
    best = ok.groupby(["record", "effects", "likelihood"])["rmse_prediction"].transform("min")
    ok["relative"] = ok["rmse_prediction"] / best
    rows = []
    for (index, effects, likelihood), group in table.groupby(["window_index", "effects", "likelihood"], sort=True):
        good = ok.loc[ok.index.intersection(group.index)]
        starts, ends = group["window_start_s"].unique(), group["window_end_s"].unique()
        rows.append({"window_index": index, "effects": effects, "likelihood": likelihood,
                     "records": int(group["record"].nunique()), "failed": int((group["error"] != "").sum()),
                     "window_start_s": float(starts[0]) if len(starts) == 1 else math.nan,
                     "window_end_s": float(ends[0]) if len(ends) == 1 else math.nan,
                     "coverage95_prediction_mean": float(good["coverage95_prediction"].mean()) if len(good) else math.nan,
                     "rmse_prediction_relative_median": float(good["relative"].median()) if len(good) else math.nan})
    return pd.DataFrame(rows)


def posterior_dataset(entries: list[dict]):
    """The kept posterior draws of every cell as an ArviZ InferenceData.

    Its ``posterior`` group has one variable per parameter (natural units) with dims
    ``(chain, draw, cell)``: one chain of :data:`~beam.study.cells.DRAWS_KEPT` draws (picked
    without replacement from the cell's ensemble), NaN where a cell's model has no such
    parameter, a cell failed or kept fewer draws. Coordinates on ``cell``: record, window_start_s,
    window_end_s, effects, likelihood, cell_key.
    """
    import xarray as xr

    from beam.inference import import_arviz

    names = sorted({name for e in entries for name in e["draws"]})
    n = len(entries)
    data = {name: np.full((1, DRAWS_KEPT, n), np.nan) for name in names}
    for j, e in enumerate(entries):
        for name, values in e["draws"].items():
            values = np.asarray(values, dtype=float)[:DRAWS_KEPT]
            data[name][0, :values.size, j] = values
    coords = {"chain": [0], "draw": np.arange(DRAWS_KEPT), "cell": np.arange(n),
              "record": ("cell", [e["row"]["record"] for e in entries]),
              "window_start_s": ("cell", [float(e["row"]["window"][0]) for e in entries]),
              "window_end_s": ("cell", [float(e["row"]["window"][1]) for e in entries]),
              "effects": ("cell", [_effects_label(e["row"]["effects"]) for e in entries]),
              "likelihood": ("cell", [e["row"]["likelihood"] for e in entries]),
              "cell_key": ("cell", [e["key"] for e in entries])}
    posterior = xr.Dataset({name: (("chain", "draw", "cell"), values) for name, values in data.items()}, coords=coords)
    return import_arviz().InferenceData(posterior=posterior)


def write_tables(prefix: str | os.PathLike, entries: list[dict]) -> list[Path]:
    """Write ``PREFIX.csv``, ``PREFIX.summary.csv`` and ``PREFIX.nc``; returns their paths."""
    prefix = Path(prefix)
    table = cell_table(entries)
    csv, summary = prefix.with_name(prefix.name + ".csv"), prefix.with_name(prefix.name + ".summary.csv")
    written = atomic_write_texts({csv: table.to_csv(index=False), summary: summary_table(table).to_csv(index=False)})
    nc = prefix.with_name(prefix.name + ".nc")
    temporary = nc.with_name(nc.name + ".tmp")
    posterior_dataset(entries).to_netcdf(str(temporary), engine="h5netcdf")
    temporary.replace(nc)
    return [*written, nc]
