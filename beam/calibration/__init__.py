"""Calibrate the beam model on measurements (window, modes, effects, likelihood).

A calibration is specified by a :class:`CalibrationSpec`, run by :func:`calibrate`,
:func:`calibration_preview` or :func:`calibration_stream`, and searched by an
:class:`Engine` that remembers the optima it found.

The names are imported on first use (``beam.calibration.spec`` needs no numerical library: the
command line reads its defaults before it reads a file).
"""

from __future__ import annotations

import importlib
from typing import Any

#: Public name -> module that defines it.
_LAZY = {
    "CalibrationResult": "beam.calibration.run",
    "calibrate": "beam.calibration.run",
    "calibration_preview": "beam.calibration.run",
    "calibration_stream": "beam.calibration.run",
    "known_map": "beam.calibration.run",
    "prepare": "beam.calibration.run",
    "remember_maps": "beam.calibration.run",
    "Engine": "beam.calibration.engine",
    "Memory": "beam.calibration.engine",
    "default_engine": "beam.calibration.engine",
    "ModeChoice": "beam.calibration.modes",
    "suggest_modes": "beam.calibration.modes",
    "AUTO_MODES": "beam.calibration.spec",
    "DEFAULT_EFFECTS": "beam.calibration.spec",
    "DEFAULT_MODES": "beam.calibration.spec",
    "DEFAULT_WINDOW_FRACTION": "beam.calibration.spec",
    "CalibrationSpec": "beam.calibration.spec",
    "BeamCalibrationSetup": "beam.calibration.setup",
    "BeamForwardModel": "beam.calibration.forward",
    "build_problem": "beam.calibration.setup",
    "make_setup": "beam.calibration.pipeline",
    "CalibrationModel": "beam.calibration.pipeline",
    "averaged_drag_preview": "beam.calibration.pipeline",
    "parameter_prior": "beam.calibration.setup",
}

__all__ = list(_LAZY)


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'beam.calibration' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
