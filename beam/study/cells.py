"""One cell of a window study: one full calibration of one record on one window, then its held-out prediction.

:class:`StudyCell` holds everything that decides a cell's result; :meth:`StudyCell.calibration_options`
is the one place where it becomes the options of :func:`beam.calibration.calibrate` (the engine of
``beam calibrate`` and the dashboard), so a cell's numbers are those ``beam calibrate`` prints
with the same options and seed. :func:`run_cell` runs a cell (in a Dask worker or in-process)
and never raises: a failed cell comes back with its error.
"""

from __future__ import annotations

import hashlib
import json
import math
import socket
import time
import traceback
from dataclasses import asdict, dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from beam.errors import BeamInputError
from beam.io.measurement import Measurement

__all__ = ["CELL_KEYS", "DRAWS_KEPT", "StudyCell", "code_version", "error_row", "record_fingerprint", "run_cell"]

#: Keys of a cell in ``beam study --json``, in this order (the ones ``beam calibrate --json`` also
#: has mean the same: ``window`` is its ``window_s``, ``record`` its ``measurement``).
CELL_KEYS = ("record", "window", "effects", "likelihood", "rmse_calibration", "rmse_prediction",
             "coverage95_prediction", "parameters", "ess_min", "rhat_max", "seconds", "error")
#: Posterior draws kept per cell for the study's netCDF file (picked without replacement).
DRAWS_KEPT = 1000


@dataclass(frozen=True)
class StudyCell:
    """What decides one cell's result (the record by its content, not its path).

    Parameters
    ----------
    record : str
        The record's name as shown in the table.
    record_hash : str
        :func:`record_fingerprint` of the record.
    window : (float, float)
        Calibration window (s).
    effects : tuple of str
        Effect ids added to the base model (catalogue order).
    likelihood : {"iid", "ar1"}
        Noise model.
    modes : int or "auto"
        Retained modes.
    seed : int
        Seed of the sampler and of the band draws.
    steps, walkers : int or None
        Fixed ensemble steps / walkers (None: the engine's defaults, sampling to its target ESS).
    """

    record: str
    record_hash: str
    window: tuple[float, float]
    effects: tuple[str, ...]
    likelihood: str
    modes: int | str
    seed: int
    steps: int | None = None
    walkers: int | None = None

    def calibration_options(self) -> dict:
        """The keyword options of :func:`beam.calibration.calibrate` for this cell (the only place they are built)."""
        return dict(window=self.window, effects=self.effects, modes=self.modes, likelihood=self.likelihood,
                    walkers=self.walkers, steps=self.steps, seed=self.seed)

    def key(self, version: str) -> str:
        """Hex digest of the cell's content (record content, options, seed) and the code ``version``:
        the name of its stored result (two cells with the same key have the same result)."""
        fields = {k: v for k, v in asdict(self).items() if k != "record"}
        text = json.dumps({"cell": fields, "code": version}, sort_keys=True, default=list)
        return hashlib.sha256(text.encode()).hexdigest()[:24]


def record_fingerprint(measurement: Measurement) -> str:
    """Hex digest of a record's content: its samples (time, input, output), geometry, nominal
    values and sensor range, not its file's name or place."""
    h = hashlib.sha256()
    for name in ("time_s", "voltage_V", "force_N", "displacement_m", "velocity_m_s", "acceleration_m_s2"):
        values = getattr(measurement, name)
        h.update(name.encode())
        if values is not None:
            h.update(np.ascontiguousarray(values, dtype=np.float64).tobytes())
    h.update(repr(measurement.geometry).encode())
    h.update(json.dumps(measurement.nominal, sort_keys=True).encode())
    h.update(repr(measurement.sensor_range).encode())
    return h.hexdigest()[:24]


@lru_cache(maxsize=1)
def code_version() -> str:
    """Hex digest of the ``beam`` package's Python sources: a stored cell is reused only by the same code."""
    root = Path(__file__).resolve().parents[1]
    h = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        h.update(path.relative_to(root).as_posix().encode())
        h.update(path.read_bytes())
    return h.hexdigest()[:16]


def _finite_or_none(value):
    if value is None:
        return None
    value = float(value)
    return value if math.isfinite(value) else None


def error_row(cell: StudyCell, error: str) -> dict:
    """The ``--json`` cell of a failed calibration: its identity and the error, no numbers."""
    return {"record": cell.record, "window": list(cell.window), "effects": list(cell.effects),
            "likelihood": cell.likelihood, "rmse_calibration": None, "rmse_prediction": None,
            "coverage95_prediction": None, "parameters": {}, "ess_min": None, "rhat_max": None,
            "seconds": None, "error": error}


def run_cell(measurement: Measurement, cell: StudyCell) -> dict:
    """Calibrate ``measurement`` as ``cell`` says and score the held-out prediction; never raises.

    Returns
    -------
    dict
        ``row``: the ``--json`` cell (:data:`CELL_KEYS`; the numbers of ``beam calibrate --json``,
        NaN as None); ``extra``: ``modes`` (retained), ``width95_prediction`` (mean width of the
        95 % prediction band on the held-out samples, output's unit), ``noise_sd`` (posterior
        mean, output's unit), ``n_held_out``; ``draws``: up to :data:`DRAWS_KEPT` posterior draws
        ``{name: array}`` (natural units); ``task``: ``start``/``end`` (epoch s) and ``host``.
    """
    from beam.calibration import calibrate

    start = time.time()
    out = {"row": None, "extra": {}, "draws": {}, "task": {}}
    try:
        result = calibrate(measurement, **cell.calibration_options())
        summary = result.to_json()
        row = {"record": cell.record, "window": summary["window_s"], "effects": summary["effects"],
               "likelihood": summary["likelihood"], **{k: summary[k] for k in CELL_KEYS[4:11]}, "error": None}
        for key in ("rmse_calibration", "rmse_prediction", "coverage95_prediction", "ess_min", "rhat_max", "seconds"):
            row[key] = _finite_or_none(row[key])
        mask = result.held_out_mask
        band = result.bands
        width = float(np.mean((band.prediction_upper - band.prediction_lower)[mask])) if mask.any() else math.nan
        out["row"] = row
        out["extra"] = {"modes": int(summary["modes"]), "width95_prediction": _finite_or_none(width),
                        "noise_sd": _finite_or_none((summary.get("noise_sd") or {}).get("mean")),
                        "n_held_out": int(mask.sum()), "output_unit": summary["output_unit"]}
        out["draws"] = {k: np.asarray(v, dtype=float) for k, v in
                        result.posterior.thinned_draws(DRAWS_KEPT, cell.seed).items()}
    except BeamInputError as exc:
        out["row"] = error_row(cell, " ".join(str(exc).split()))
    except Exception as exc:  # noqa: BLE001 - a failed cell is reported, the study goes on
        last = traceback.extract_tb(exc.__traceback__)[-1]
        out["row"] = error_row(cell, f"{type(exc).__name__}: {' '.join(str(exc).split())[:300]} "
                                     f"({Path(last.filename).name}:{last.lineno})")
    out["task"] = {"start": start, "end": time.time(), "host": socket.gethostname()}
    return out
