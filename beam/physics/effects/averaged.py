"""The averaged (slow-flow) slot of an effect: a closed-form free decay with one nonlinear effect.

A free decay of the retained modes rings, mode k, at its damped frequency omega_d,k under an
exponential envelope a_k e^(-c_k tau) (c_k = -Re(pole_k), tau the time since the window's
start). A weak nonlinear effect changes, to first order in the averaging over one cycle, each
mode's envelope and phase slowly (Krylov–Bogoliubov): the averaged response is the linear
free-response basis with mode k's two columns multiplied by ``ratio_k(tau)`` =
A_k(tau) / (a_k e^(-c_k tau)) and turned by ``phase_k(tau)`` (rad, added to omega_d,k tau). At
the effect's null value the ratio is 1 and the phase 0: the averaged model *is* the linear one.

**The contract of the slot** (what a module implements to give its effect an averaged form; the
calibration, :mod:`beam.calibration.free_averaged`, does the rest: the linear basis, the
amplitudes and offset, the MAP, the Laplace covariance, the bands and the preview event):

``note`` : str
    The label of every result of the averaged form (a preview, not the full integration).
``prepare(model, values, shapes, omega, sigma, tau)``
    What depends on the parameters only (the caller caches it per parameter set): ``model`` the
    :class:`~beam.physics.model.BeamModel`, ``values`` the natural-unit parameters (floats by
    name), ``shapes`` (n, m) its mass-normalised undamped shapes (Galerkin coefficients, tip
    positive), ``omega`` (m,) their undamped frequencies (rad/s), ``sigma`` (m,) the linear
    poles' real parts (1/s, negative), ``tau`` (N,) the times since the window's start (s).
    Raise :class:`~beam.errors.BeamInputError` when the form does not apply (the caller then
    shows no averaged preview).
``envelope(prepared, amplitudes)``
    ``(ratio, phase)``: (N, m) arrays for the initial modal envelopes ``amplitudes`` (m,)
    (modal coordinates at the window's start); ``phase`` may be None (no phase change).

Limits belong to each form's module docstring (what it keeps of the coupling of the modes, when it
holds). The drag's is in :mod:`beam.physics.effects.quadratic_drag`; a form for
``clamp_friction`` (amplitude-dependent stiffness and loss of the Iwan joint: a phase and an
envelope) or ``tip_cubic_spring`` (the backbone: a phase only) is written in its module alone.
"""

from __future__ import annotations

from typing import Any, Protocol

__all__ = ["AveragedForm"]


class AveragedForm(Protocol):
    """The averaged (slow-flow) form of an effect's free decay (see the module notes)."""

    note: str

    def prepare(self, model: Any, values: dict, shapes: Any, omega: Any, sigma: Any, tau: Any) -> Any:
        """Per-parameter constants of the form (see the module notes)."""

    def envelope(self, prepared: Any, amplitudes: Any) -> tuple[Any, Any | None]:
        """(ratio (N, m), phase (N, m) or None) for initial modal envelopes ``amplitudes`` (m,)."""
