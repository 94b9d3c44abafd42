"""``sensor_mass``: a point mass m_s at the sensor's position x_obs (translation only).

The position always comes from the sidecar's ``[sensor] position_m`` (the part ``mass_sensor``
is assembled from the geometry): an accelerometer glued to the strip loads it where it
measures. It matters for a contact sensor, which a displacement record from a laser does not
have, so it is not a ranking candidate in general; the diagnosis offers it where the record
comes from one (``contact_sensor``).

**Plausible values** (:data:`PLAUSIBLE_SOURCE`): 0.1 g to 0.25 kg when the record states no mass,
from a miniature piezoelectric accelerometer (0.2 g: PCB Piezotronics 352C23) through MEMS boards
with their wires (a few grams: the shared 50 cm runs' ADXL357 board calibrates at 4 g) to a
smartphone taped to the strip (iPhone 13 174 g, Galaxy S23 168 g; 140–230 g for current phones:
the makers' specifications). When the record states the sensor's mass (``[sensor] mass_kg``,
weighed or approximate), what the user stated decides instead: a calibrated mass more than three of
the statement's log standard deviations from it, and at least a factor 1.5 away (a weighed board
still carries its cable and glue), is not the sensor (:mod:`beam.discovery.plausibility`).
"""

from __future__ import annotations

from beam.physics.effects.effect import Effect, ParameterSpec, Term

__all__ = ["EFFECT", "MASS", "PLAUSIBLE_SOURCE"]

PLAUSIBLE_SOURCE = ("makers' specifications: PCB Piezotronics 352C23 miniature accelerometer 0.2 g; smartphones "
                    "140-230 g (Apple iPhone 13 174 g, Samsung Galaxy S23 168 g); MEMS boards with wires a few grams "
                    "(the shared 50 cm runs' ADXL357 board: 4.06 g calibrated jointly, docs/joint-calibration.md)")
MASS = ParameterSpec("sensor_mass_kg", "kg", "m_s", "point mass of the sensor at its position", 1e-7, 0.2,
                     nominal_log_sd=1.0, plausible=(1e-4, 0.25), plausible_source=PLAUSIBLE_SOURCE)

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
