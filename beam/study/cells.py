"""One cell of a window study: one full calibration of one record on one window, then its held-out prediction.

:class:`StudyCell` holds everything that decides a cell's result: the record (by its content) and
the :class:`~beam.calibration.spec.CalibrationSpec` it is calibrated with, which
:func:`beam.calibration.calibrate` (the engine of ``beam calibrate`` and the dashboard) takes as
it is, so a cell's numbers are those ``beam calibrate`` prints with the same options and seed. :func:`run_cell` runs a cell (in a Dask worker or in-process)
and never raises: a failed cell comes back with its error.
"""

from __future__ import annotations

import hashlib
import json
import math
import socket
import time
import traceback
from dataclasses import dataclass, fields
from functools import lru_cache
from pathlib import Path

import numpy as np

from beam.calibration.spec import CalibrationSpec
from beam.calibration.spec_field import SpecField
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
    """What decides one cell's result: the record by its content (not its path) and the spec.

    Parameters
    ----------
    record : str
        The record's name as shown in the table (not part of the result's key).
    record_hash : str
        :func:`record_fingerprint` of the record.
    spec : CalibrationSpec
        What the record is calibrated with: window (s), effects, modes (a number or ``"auto"``),
        likelihood, seed, fixed steps / walkers (None: the engine's defaults, sampling to its
        target ESS); :meth:`key` depends on every field of it.
    """

    record: str
    record_hash: str
    spec: CalibrationSpec

    window = SpecField()
    effects = SpecField()
    likelihood = SpecField()
    modes = SpecField()
    seed = SpecField()
    steps = SpecField()
    walkers = SpecField()

    def calibration_options(self) -> dict:
        """The spec's options as :func:`beam.calibration.calibrate`'s keywords (for a report; the
        cell is calibrated with :attr:`spec` itself)."""
        return dict(window=self.window, effects=self.effects, modes=self.modes, likelihood=self.likelihood,
                    walkers=self.walkers, steps=self.steps, seed=self.seed)

    def key(self, version: str) -> str:
        """Hex digest of the cell's content (record content, options, seed) and the code ``version``:
        the name of its stored result (two cells with the same key have the same result)."""
        spec = {f.name: getattr(self.spec, f.name) for f in fields(self.spec) if f.compare}
        fields_ = {"record_hash": self.record_hash, "spec": spec}
        text = json.dumps({"cell": fields_, "code": version}, sort_keys=True, default=list)
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
        result = calibrate(measurement, cell.spec)
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
