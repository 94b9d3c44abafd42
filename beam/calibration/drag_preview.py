"""The averaged preview of a free decay's calibration with ``quadratic_drag``: the linear
sub-model's calibration preview, then the averaged (slow-flow) model's MAP and Laplace
approximation from it (:class:`beam.calibration.free_averaged.AveragedDragModel`).

Apart from :mod:`beam.calibration.free_averaged` because it drives the engine, which the full
nonlinear calibration (that starts from the averaged model) must not import.
"""

from __future__ import annotations

from beam.calibration.free_averaged import AveragedDragFit, AveragedDragModel
from beam.errors import BeamInputError

__all__ = ["averaged_drag_preview"]


def averaged_drag_preview(measurement, window: tuple[float, float], effects, modes: int | None = None,
                          likelihood: str = "iid", engine=None) -> AveragedDragFit:
    """The preview of a free decay's calibration with ``quadratic_drag`` by the averaged model:
    the calibration preview of the model without the drag (the linear sub-model, remembered by
    ``engine``), then the averaged model's MAP and Laplace approximation from its optimum (C_d at
    its null value). The result is labelled :data:`AVERAGED_NOTE`; its intervals are those of the
    averaged model and do not include its approximation error.

    Parameters
    ----------
    measurement : Measurement
        A free decay of a beam with a width.
    window : (float, float)
        Calibration window (s), starting at the free response's start.
    effects : str or sequence of str
        The effects, ``quadratic_drag`` among them (its only nonlinear effect).
    modes : int, optional
        Retained modes (the setup's choice by default).
    likelihood : str
        ``"iid"`` or ``"ar1"``.
    engine : Engine, optional
        Shared with the caller's calibrations (the linear sub-model's preview is remembered).

    Returns
    -------
    AveragedDragFit
    """
    from beam.calibration.engine import default_engine
    from beam.calibration.run import CalibrationSpec, linear_sub_map
    from beam.calibration.setup import build_problem, make_setup
    from beam.calibration.records import decimate_measurement
    from beam.io.limits import MAX_CALIBRATION_SAMPLES

    engine = default_engine() if engine is None else engine
    measurement, _ = decimate_measurement(measurement, MAX_CALIBRATION_SAMPLES)
    options = {"window": window, "effects": effects, "likelihood": likelihood} | ({} if modes is None else
                                                                                 {"modes": modes})
    spec = CalibrationSpec.of(None, **options).resolve(measurement)
    setup = make_setup(measurement, window=spec.window, effects=spec.effects, modes=spec.modes,
                       likelihood=spec.likelihood)
    problem = build_problem(setup)
    if not (setup.is_free and "drag_coefficient" in setup.physical_names):
        raise BeamInputError("the averaged preview is for a free decay with quadratic_drag")
    return AveragedDragModel(problem.model).fit_nested(problem, linear_sub_map(setup, engine))
