"""A plucked strip: the free decay after a release from a static tip deflection.

A student bends the strip by its tip and lets go: at the release the strip is at rest in the
shape a static tip load gives it. That shape is q0 = d K⁻¹ t / (t · K⁻¹ t) (K the Galerkin
stiffness of the model's parameters, t the tip row, d the tip displacement), and its modal
state is eta = Phi^T M q0, eta' = 0 in the coordinates of
:meth:`beam.physics.model.BeamModel.mode_shapes` (mass-normalised, tip positive). Mode 1 takes
about 97 % of a cantilever's tip deflection, mode 2 most of the rest; an accelerometer sees
mode 2 larger than its share (its acceleration goes as omega²).

:func:`simulate_release` integrates the free decay from that state with
:meth:`beam.physics.model.BeamModel.free_response` (exact exponentials for a linear model,
the ETDRK4 integrator with the drag, the tip spring or the clamp friction), at any stamps,
for any output of the model (a strain needs the strip's thickness).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from beam.errors import BeamInputError
from beam.physics.model import BeamModel

__all__ = ["release_state", "simulate_release"]


def release_state(model: BeamModel, parameters: Mapping[str, float], tip_displacement_m: float,
                  modes: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """Modal state (eta (m,), eta' (m,)) of the strip at rest under a static tip load that
    deflects its tip by ``tip_displacement_m`` (m), in the coordinates of
    :meth:`~beam.physics.model.BeamModel.mode_shapes` (m sqrt(kg) and m sqrt(kg)/s).

    The static shape is the model's linear one (a tip spring or a slipping clamp would bend it
    slightly otherwise at large amplitude).

    Raises
    ------
    BeamInputError
        A tip displacement that is not finite and non-zero.
    """
    d = float(tip_displacement_m)
    if not np.isfinite(d) or d == 0.0:
        raise BeamInputError(f"tip_displacement_m must be finite and non-zero, got {tip_displacement_m!r}")
    matrices = model.system_matrices(dict(parameters))
    stiffness, mass = matrices["stiffness"][0], matrices["mass"][0]
    tip = model.parts.tip_values
    shape = np.linalg.solve(stiffness, tip)
    q0 = d * shape / float(tip @ shape)
    _, shapes = model.mode_shapes(dict(parameters), modes)
    return shapes.T @ mass @ q0, np.zeros(shapes.shape[1])


def simulate_release(model: BeamModel, parameters: Mapping[str, float], time_s: np.ndarray,
                     tip_displacement_m: float, *, modes: int = 4, output: str = "acceleration") -> np.ndarray:
    """The sensor's output (m, m/s, m/s² or strain) at ``time_s`` (s, increasing, any spacing;
    the release at ``time_s[0]``) of the free decay from :func:`release_state`."""
    eta, rate = release_state(model, parameters, tip_displacement_m, modes)
    return model.free_response(dict(parameters), np.asarray(time_s, dtype=float), eta, rate, modes=modes, output=output)
