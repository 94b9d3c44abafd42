"""Nonlinear forces as channels: what an effect hands the integrator instead of integrator arguments.

A **channel** is a nonlinear generalised force acting at P points of the beam (a point, the
Gauss points of a distributed force, the root's rotation). It reads the beam there through P
Galerkin rows (the displacement w_p = row_p . q, or the rotation for a row of slopes; the
velocity through the same rows), computes one force per point from the values there and its
coefficients by its **law**, and acts back through the same rows (the force's virtual work is
F_p row_p . dq): in the retained modal coordinates the forcing is sum_p psi_p F_p, psi_p =
row_p . Phi. The integrator (:func:`beam.physics.nonlinear.integrate_general`) takes the
channels of a model as a list and steps them together by ETDRK4; in its compiled kernel they
are stacked arrays with a law code per point (:class:`ChannelArrays`).

Laws (the integrator implements each; a new law is a new branch of its kernel):

:data:`LAW_POINT_CUBIC`
    F = -k w³ at the point (k = coefficient 0), w its displacement plus the discarded modes'
    quasi-static share of the input and of F itself when the channel asks for the static
    correction (one Newton step, :func:`beam.physics.nonlinear._corrected_tip`).
:data:`LAW_VELOCITY_SQUARED`
    F = -c |v| v at the point (c = coefficient 0, kg/m for a distributed drag's quadrature
    weight), v its velocity.
:data:`LAW_IWAN_JOINT`
    M = k theta - R(theta) at the point (a rotation theta): the nonlinear part of an Iwan joint
    of stick stiffness k (coefficient 0; its linear part k theta is a term of the effect) that
    slips wholly at M_s (coefficient 1), R on its Masing branch from the last reversal (a memory
    per point, started from the settled cycle of the amplitude at the start, moved at each
    reversal of the rotation rate). Off when M_s <= 0.

This module imports no numerical library.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, NamedTuple

__all__ = ["LAWS", "catalogue_channel", "LAW_IWAN_JOINT", "LAW_POINT_CUBIC", "LAW_VELOCITY_SQUARED", "Channel", "ChannelArrays"]

#: Law codes of the integrator's kernel (see the module notes).
LAW_POINT_CUBIC = 0
LAW_VELOCITY_SQUARED = 1
LAW_IWAN_JOINT = 2
LAWS = (LAW_POINT_CUBIC, LAW_VELOCITY_SQUARED, LAW_IWAN_JOINT)


@dataclass(frozen=True)
class Channel:
    """The nonlinear force of one effect (see the module notes).

    Attributes
    ----------
    effect : str
        The id of the effect it belongs to (for messages).
    law : int
        One of :data:`LAWS`.
    parameters : tuple of str
        The effect's parameters it reads.
    switch : str
        The parameter whose positive value switches the force on (where every set has it at 0
        the model is linear and takes its linear paths).
    rows : callable
        ``rows(model) -> (P, n)``: the Galerkin rows of its P points of the
        :class:`~beam.physics.model.BeamModel` ``model`` (displacement or slope rows).
    coefficients : callable
        ``coefficients(model, values) -> (B, P, 2)``: each set's law coefficients at each point,
        from the given parameter values ``values`` ((B,) arrays by name).
    on_when_given : bool
        The force is on whenever its parameters are given, whatever the switch's value (a
        joint's memory makes the path nonlinear even before it slips).
    static_correction : bool
        Whether the discarded modes answer its force quasi-statically (a point force: their
        share at its point and at the sensor is added, as for the input).
    driven : callable or None
        Its own integration of a driven record on uniform stamps (displacement only), used when it
        is the only channel on: ``driven(system, coefficients, input, dt, static_gains) -> (B, n)``,
        ``system`` the retained complex modes (:class:`~beam.physics.modal.ComplexModes`; inputs
        the record's and a unit tip force, outputs the sensor and the tip), ``static_gains``
        (B, 4) the discarded modes' quasi-static shares of both at both. A channel with one is
        refused at irregular stamps (the linear :meth:`~beam.physics.model.BeamModel.response_at`).
    """

    effect: str
    law: int
    parameters: tuple[str, ...]
    switch: str
    rows: Callable[[Any], Any] = field(repr=False)
    coefficients: Callable[[Any, Mapping[str, Any]], Any] = field(repr=False)
    on_when_given: bool = False
    static_correction: bool = False
    driven: Callable | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        if self.law not in LAWS:
            raise ValueError(f"channel law must be one of {LAWS}, got {self.law!r}")
        if self.switch not in self.parameters:
            raise ValueError(f"channel of {self.effect}: its switch {self.switch!r} is not one of its parameters")

    def __reduce__(self):  # pickled by reference: its callables are its effect module's
        return (catalogue_channel, (self.effect,))

    def is_on(self, values: Mapping[str, Any]) -> bool:
        """Whether any parameter set of ``values`` ((B,) arrays or floats by name) switches it on."""
        if self.switch not in values:
            return False
        if self.on_when_given:
            return True
        value = values[self.switch]
        try:
            return bool((value > 0).any())
        except AttributeError:
            return bool(value > 0)


class ChannelArrays(NamedTuple):
    """One channel's arrays for the integrator, for B parameter sets and m retained modes.

    ``law`` (int); ``rows`` (B, P, m): the points' modal rows psi_p = row_p . Phi (mass-normalised
    shapes); ``coefficients`` (B, P, 2); ``static`` (B, P, 3) or None: per point, the discarded
    modes' quasi-static displacement per unit input, per unit of its own force, and the sensor's
    per unit of its force (displacement outputs with the static correction only).
    """

    law: int
    rows: Any
    coefficients: Any
    static: Any = None


def catalogue_channel(effect_id: str) -> Channel:
    """The channel of the catalogue's effect ``effect_id`` (the ``EFFECT`` of its module ``beam.physics.effects.<id>``)."""
    return importlib.import_module(f"beam.physics.effects.{effect_id}").EFFECT.channel
