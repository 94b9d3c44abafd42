"""Nested starts (:class:`NestedStarts`): the optimum of each sub-model (the model without one of
its effects), found by the engine, with that effect barely on. A model with an effect nests the
model without it, so its MAP is then at least as good as every such sub-model's."""

from __future__ import annotations

from beam.calibration.setup import BeamCalibrationSetup
from beam.calibration.spec import DEFAULT_EFFECTS
from beam.calibration.starts.base import StartStrategy, barely_on, clip_inside_prior, damping_only
from beam.inference import Problem

__all__ = ["NestedStarts", "nested_starts"]


def nested_starts(problem: Problem, setup: BeamCalibrationSetup, engine) -> list[dict[str, float]]:
    """For each effect of the model, the optimum of the model without it (``engine``'s
    :meth:`~beam.calibration.engine.Engine.submodel_map`)
    with that effect barely on (see the module notes); a pure damping effect only when the
    model without it still has an effect that changes the modes (whose optimum may lie in a
    basin no design point of the model with it reaches: lab_run_1, 30 % window, clamp
    compliance + patch damping ended 9 nats below the clamp-only optimum), and never the default
    damping (air, Kelvin-Voigt), which every model has: dropping it only made each preview fit
    its sub-models recursively (lab_run_1, 7 modes, + patch stiffening: 6.2 s, 4.5 s of it in
    sub-model fits)."""
    out = []
    for effect in setup.effects:
        if damping_only(effect) and (effect in DEFAULT_EFFECTS
                                      or all(damping_only(e) for e in setup.effects if e != effect)):
            continue  # the default damping is in every model: dropping it finds no new basin
        values = engine.submodel_map(setup, tuple(e for e in setup.effects if e != effect))
        guess = {name: values.get(name, barely_on(problem, name)) for name in setup.physical_names}
        out.append(clip_inside_prior(problem, guess))
    return out


class NestedStarts(StartStrategy):
    """The nested starts (:func:`nested_starts`)."""

    name = "nested"
    nested = True

    def __call__(self, problem, setup, engine):
        return nested_starts(problem, setup, engine)
