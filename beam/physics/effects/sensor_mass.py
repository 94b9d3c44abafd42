"""``sensor_mass``: a point mass m_s at the sensor's position x_obs (translation only).

The position always comes from the sidecar's ``[sensor] position_m`` (the part ``mass_sensor``
is assembled from the geometry): an accelerometer glued to the strip loads it where it
measures. It matters for a contact sensor, which a displacement record from a laser does not
have, so it is not a ranking candidate in general; the diagnosis offers it where the record
comes from one (``contact_sensor``).
"""

from __future__ import annotations

from beam.physics.effects.effect import Effect, ParameterSpec, Term

__all__ = ["EFFECT", "MASS"]

MASS = ParameterSpec("sensor_mass_kg", "kg", "m_s", "point mass of the sensor at its position", 1e-7, 0.2,
                     nominal_log_sd=1.0)

EFFECT = Effect(
    "sensor_mass",
    "Sensor mass",
    "point mass of the sensor at its position x_obs (from the sidecar; translation only)",
    (MASS,),
    (Term("mass", "mass_sensor", MASS.name),),
    missing_effect_candidate=False,
    offered_on_records=True,
    needs=frozenset({"contact_sensor"}),
    catalogue_order=100,
)
