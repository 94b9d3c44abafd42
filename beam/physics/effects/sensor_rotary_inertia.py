"""``sensor_rotary_inertia``: the rotary inertia J of a sensor glued at x_obs.

A sensor that is not small beside the strip turns with it: its kinetic energy
½ J w_xt(x_obs, t)² adds J w'(x_obs) w'(x_obs) to the mass matrix (the part ``rotary_sensor``,
phi_i'(x_obs) phi_j'(x_obs), assembled here from the basis and the sensor's position; the moment
it puts there makes the curvature jump, so the basis has a double knot at the sensor). It lowers
the modes whose slope at the sensor is large, the higher ones most: a phone taped along a strip
(~15 cm long, 0.15–0.2 kg: J = m l² / 12 ≈ 3e-4 kg m², a uniform bar about its centre) takes the
second mode of the shared 50 cm aluminium strip from 41 Hz to 30 Hz with the sensor 6 cm from
the tip (its mass alone, 0.17 kg, to 38 Hz). An accelerometer board of a few grams and 2 cm has
J ~ 1e-7 kg m², negligible. It complements ``sensor_mass`` (the translation of the same body).

Offered where a contact sensor is (an accelerometer, a phone), like ``sensor_mass``; left out of
the missing-effect ranking, which does not offer it either: it trades with the sensor's mass and
the bending stiffness on the mode ratios, and a ranking fit of it on a record without it costs a
candidate's fit for every contact-sensor record (ranking it is later work). Its prior reaches
down to 1e-12 kg m² (a 0.1 g, 5 mm chip has 2e-10), where the effect vanishes: a model with it
nests the model without it.
"""

from __future__ import annotations

from beam.physics.effects.effect import Effect, ParameterSpec, Part, Term

__all__ = ["EFFECT", "INERTIA", "rotary_part", "sensor_knot"]

INERTIA = ParameterSpec("sensor_rotary_inertia_kg_m2", "kg m²", "J_s",
                        "rotary inertia of the sensor about the strip's width, at its position", 1e-12, 1e-2,
                        nominal_log_sd=1.0)


def sensor_knot(geometry) -> tuple[float, ...]:
    """The sensor's position (m): the moment J w_tt' there makes the curvature jump (a double knot)."""
    return (geometry.sensor_position_m,)


def rotary_part(basis, geometry):
    """phi_i'(x_obs) phi_j'(x_obs) (n, n) (1/m²): the sensor's rotary inertia for a unit J."""
    import numpy as np

    slope = basis.evaluate([geometry.sensor_position_m], 1)[0]
    return np.outer(slope, slope)


EFFECT = Effect(
    "sensor_rotary_inertia",
    "Sensor rotary inertia",
    "rotary inertia J of the sensor at its position x_obs: kinetic energy ½ J w_xt(x_obs)²",
    (INERTIA,),
    (Term("mass", "rotary_sensor", INERTIA.name),),
    parts=(Part("rotary_sensor", rotary_part),),
    knots=sensor_knot,
    missing_effect_candidate=False,
    needs=frozenset({"contact_sensor"}),
    catalogue_order=105,
)
