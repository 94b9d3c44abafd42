"""Materials a student's beam is made of, and what the beam's dimensions give.

A rectangular strip of width b, thickness h (m) in a material of Young's modulus E (Pa) and
density rho (kg/m³) has

* linear density ``rho b h`` (kg/m);
* bending stiffness ``EI = E b h³ / 12`` (N m², bending about the axis along the width).

Presets (:data:`MATERIALS`): E and rho with their relative standard deviations, the spread of
the material as bought (alloy, temper, grain), taken from

* steel, stainless steel, aluminium, brass, copper, acrylic: W. D. Callister and D. G.
  Rethwisch, *Materials Science and Engineering: An Introduction*, 10th ed., Wiley (2018),
  Appendix B (Tables B.1 density, B.2 modulus of elasticity): plain carbon steel 1020 207 GPa,
  7.85 g/cm³; stainless 304 193 GPa, 8.00 g/cm³; aluminium alloys 69-72 GPa, 2.70-2.80 g/cm³;
  brass 260 110 GPa, 8.53 g/cm³; copper C11000 115 GPa, 8.89 g/cm³; PMMA 2.24-3.24 GPa,
  1.19 g/cm³ (polystyrene, the other plastic of rulers: 2.28-3.28 GPa, 1.05 g/cm³);
* spring steel ruler: the same reference's carbon and 301/304 stainless steels (rulers are
  hardened carbon or 301 stainless steel): 193-210 GPa, 7.8-8.0 g/cm³;
* wood ruler: USDA Forest Products Laboratory, *Wood Handbook*, FPL-GTR-282 (2021),
  Table 5-3a (hardwoods along the grain at 12 % moisture, e.g. sugar maple 12.6 GPa,
  specific gravity 0.63; American beech 11.9 GPa, 0.64) and Table 5-6 (coefficient of
  variation of the modulus of clear wood: 22 %).

The prior of the bending stiffness (:func:`bending_stiffness_spread`) is log-normal around
``E b h³ / 12`` with a log standard deviation combining, as independent relative errors, the
material's E spread, three times the thickness's (h enters cubed), the width's, and four
times the free length's (the clamp's edge is never exact: a length error shifts every
frequency as an EI error of four times its size would), floored at
:data:`MIN_BENDING_STIFFNESS_LOG_SD`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from beam.errors import BeamInputError


@dataclass(frozen=True)
class Material:
    """A material preset.

    Attributes
    ----------
    name : str
        The key (``"aluminium"``).
    youngs_modulus_Pa : float
        Young's modulus E (Pa).
    youngs_modulus_spread : float
        Relative standard deviation of E.
    density_kg_m3 : float
        Density rho (kg/m³).
    density_spread : float
        Relative standard deviation of rho.
    """

    name: str
    youngs_modulus_Pa: float
    youngs_modulus_spread: float
    density_kg_m3: float
    density_spread: float


#: Presets by name (module notes for the sources).
MATERIALS: dict[str, Material] = {
    m.name: m
    for m in (
        Material("steel", 207e9, 0.025, 7850.0, 0.01),
        Material("stainless steel", 193e9, 0.03, 8000.0, 0.01),
        Material("aluminium", 69e9, 0.03, 2700.0, 0.015),
        Material("brass", 110e9, 0.06, 8530.0, 0.015),
        Material("copper", 115e9, 0.05, 8890.0, 0.01),
        Material("wood ruler", 12e9, 0.22, 700.0, 0.12),
        Material("acrylic ruler", 2.9e9, 0.12, 1180.0, 0.05),
        Material("spring steel ruler", 200e9, 0.03, 7850.0, 0.01),
    )
}

#: Other spellings a student may write, to their preset.
ALIASES: dict[str, str] = {
    "aluminum": "aluminium", "al": "aluminium", "alu": "aluminium",
    "stainless": "stainless steel", "stainless_steel": "stainless steel", "inox": "stainless steel",
    "carbon steel": "steel", "mild steel": "steel",
    "wood": "wood ruler", "wooden ruler": "wood ruler", "wood_ruler": "wood ruler",
    "acrylic": "acrylic ruler", "plastic": "acrylic ruler", "plastic ruler": "acrylic ruler", "pmma": "acrylic ruler",
    "acrylic/plastic ruler": "acrylic ruler", "acrylic_ruler": "acrylic ruler", "plastic_ruler": "acrylic ruler",
    "spring steel": "spring steel ruler", "steel ruler": "spring steel ruler", "spring_steel_ruler": "spring steel ruler",
    "metal ruler": "spring steel ruler",
}

#: Smallest log standard deviation of the bending stiffness's prior from a description.
MIN_BENDING_STIFFNESS_LOG_SD = 0.1
#: Default uncertainty of a thickness (m): a caliper's reading.
THICKNESS_UNCERTAINTY_M = 2e-5
#: Default uncertainty of a width (m): a ruler's reading.
WIDTH_UNCERTAINTY_M = 2e-4
#: Default uncertainty of the free length (m): where the clamp's edge holds.
LENGTH_UNCERTAINTY_M = 5e-3


def find_material(name: str) -> Material:
    """The preset of a material name (any case; spaces, ``_`` or ``-`` between words).

    Raises
    ------
    BeamInputError
        An unknown name; the message lists the presets.
    """
    key = " ".join(str(name).strip().lower().replace("_", " ").replace("-", " ").split())
    key = ALIASES.get(key, ALIASES.get(key.replace(" ", "_"), key))
    if key not in MATERIALS:
        raise BeamInputError(f"material {name!r}: unknown; expected one of {', '.join(MATERIALS)} "
                             "(or give youngs_modulus_Pa and density_kg_m3)")
    return MATERIALS[key]


def linear_density(density_kg_m3: float, width_m: float, thickness_m: float) -> float:
    """rho b h (kg/m)."""
    return density_kg_m3 * width_m * thickness_m


def bending_stiffness(youngs_modulus_Pa: float, width_m: float, thickness_m: float) -> float:
    """E b h³ / 12 (N m²)."""
    return youngs_modulus_Pa * width_m * thickness_m**3 / 12.0


def bending_stiffness_spread(youngs_modulus_spread: float, length_m: float, width_m: float, thickness_m: float) -> float:
    """Log standard deviation of the bending stiffness's prior (module notes)."""
    relative = (
        youngs_modulus_spread**2
        + (3.0 * THICKNESS_UNCERTAINTY_M / thickness_m) ** 2
        + (WIDTH_UNCERTAINTY_M / width_m) ** 2
        + (4.0 * LENGTH_UNCERTAINTY_M / length_m) ** 2
    )
    return max(MIN_BENDING_STIFFNESS_LOG_SD, math.sqrt(relative))
