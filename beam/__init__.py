"""Beam discrepancy explorer: headless library (no UI imports).

Euler–Bernoulli cantilever with a piezoelectric patch, discretised by Galerkin's method with
cubic B-splines (double knots at the patch ends); a catalogue of optional physical effects; a
fast modal response; measurement files; Bayesian inference; residual diagnostics; the ranking of missing effects.

The main entry points are importable from here; each is imported on first use, so that
``import beam`` stays light (the command line reads and checks files before numpy-heavy imports).
"""

from __future__ import annotations

import importlib
from typing import Any

from beam.errors import BeamInputError

__version__ = "0.1.0"

#: Public name -> module that defines it.
_LAZY = {
    "BeamGeometry": "beam.physics.geometry",
    "BeamModel": "beam.physics.model",
    "EFFECTS": "beam.physics.effects",
    "Measurement": "beam.io.measurement",
    "read_measurement": "beam.io.measurement",
    "write_measurement": "beam.io.measurement",
    "load_config": "beam.io.config",
    "simulate": "beam.io.simulation",
    "calibrate": "beam.calibration",
    "calibration_preview": "beam.calibration",
    "CalibrationResult": "beam.calibration",
    "CalibrationSpec": "beam.calibration",
    "Engine": "beam.calibration",
    "diagnose": "beam.discovery.report",
    "DiagnosisReport": "beam.discovery.report",
    "ToyScenario": "beam.toy",
    "run_toy": "beam.toy",
}

__all__ = ["BeamInputError", *_LAZY]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'beam' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
