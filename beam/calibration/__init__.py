"""Calibrate the beam model on measurements (window, modes, effects, likelihood).

See :func:`calibrate`, :func:`calibration_preview` and :func:`calibration_stream`.
"""

from beam.calibration.run import (
    CalibrationResult,
    calibrate,
    calibration_preview,
    calibration_stream,
    known_map,
    prepare,
    remember_maps,
)
from beam.calibration.modes import ModeChoice, suggest_modes
from beam.calibration.setup import (
    AUTO_MODES,
    DEFAULT_EFFECTS,
    DEFAULT_MODES,
    DEFAULT_WINDOW_FRACTION,
    BeamCalibrationSetup,
    BeamForwardModel,
    build_problem,
    make_setup,
    parameter_prior,
)

__all__ = [
    "AUTO_MODES",
    "ModeChoice",
    "suggest_modes",
    "DEFAULT_EFFECTS",
    "DEFAULT_MODES",
    "DEFAULT_WINDOW_FRACTION",
    "BeamCalibrationSetup",
    "BeamForwardModel",
    "CalibrationResult",
    "build_problem",
    "calibrate",
    "calibration_preview",
    "calibration_stream",
    "known_map",
    "make_setup",
    "parameter_prior",
    "prepare",
    "remember_maps",
]
