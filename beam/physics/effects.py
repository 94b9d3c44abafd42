"""The catalogue of physical effects: named components that add terms to M, C, K and forces.

Like lmfit's components, each effect declares its parameters (name with unit, a default prior
range) and, given parameter values, the terms it adds to the Galerkin system. The model
(:mod:`beam.physics.model`) composes the base beam with any set of effects at assembly time.

Effect ids and parameter names are a public contract (files, CLI, dashboard).

==================  ===================================  =========================================
effect id           physics                              parameter(s)
==================  ===================================  =========================================
(always)            bending stiffness, patch coupling    bending_stiffness_Nm2, patch_coupling_NmV
air_damping         viscous force gamma w_t              air_damping_Ns_m2
kelvin_voigt        strain-rate moment cI w_xxt          kelvin_voigt_Nm2s
tip_mass            point mass at x = L                  tip_mass_kg
clamp_compliance    rotational spring at the root        clamp_stiffness_Nm_rad
patch_stiffening    added density/stiffness on patch     patch_added_density_kg_m,
                                                         patch_added_stiffness_Nm2
patch_damping       added strain-rate damping on patch   patch_added_kelvin_voigt_Nm2s
tip_cubic_spring    nonlinear tip force -k3 w(L)^3       tip_cubic_stiffness_N_m3
==================  ===================================  =========================================
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

from beam.errors import BeamInputError


@dataclass(frozen=True)
class ParameterSpec:
    """A physical parameter: name (with its unit in it), meaning and default prior range.

    Parameters
    ----------
    name : str
        Public name, unit included, e.g. ``bending_stiffness_Nm2``.
    unit : str
        Unit for labels, e.g. ``N m²``.
    symbol : str
        Symbol used in the equations, e.g. ``EI``.
    description : str
        One line for tooltips and tables.
    prior_low, prior_high : float
        Default prior range (log-uniform) when a measurement gives no ``[nominal]`` value.
    required : bool
        Optional parameters default to 0 and are calibrated only when asked for.
    absent_at : {"low", "high"}
        The end of the range where the effect vanishes (a rigid clamp is k_theta -> infinity).
        The range reaches far enough that the effect is negligible there, so that a model with
        the effect nests the model without it.
    """

    name: str
    unit: str
    symbol: str
    description: str
    prior_low: float
    prior_high: float
    required: bool = True
    absent_at: str = "low"

    @property
    def label(self) -> str:
        """Axis label with the unit, e.g. ``EI (N m²)``."""
        return f"{self.symbol} ({self.unit})"


@dataclass(frozen=True)
class Term:
    """One contribution ``value of parameter * part`` to the system.

    ``target`` is ``"mass"``, ``"damping"`` or ``"stiffness"`` (a matrix part), ``"force"`` (a
    vector multiplying the voltage V(t)) or ``"tip_cubic"`` (the cubic tip force, vector part).
    ``part`` names an attribute of :class:`beam.physics.assembly.GalerkinParts`; ``parameter`` names the
    parameter whose value is the coefficient (``linear_density_kg_m`` is the sidecar's rho).
    """

    target: str
    part: str
    parameter: str


@dataclass(frozen=True)
class Effect:
    """A named, optional physical effect.

    Parameters
    ----------
    id : str
        Public identifier, e.g. ``tip_mass``.
    title : str
        Short human title.
    physics : str
        One sentence on what it models.
    parameters : tuple of ParameterSpec
        Parameters it declares.
    terms : tuple of Term
        What it adds to the system; a term of an optional parameter applies only when that
        parameter is given.
    frees_root_rotation : bool
        True when the effect replaces the rigid clamp (the basis keeps the root rotation).
    nonlinear : bool
        True when the effect makes the equations of motion nonlinear.
    """

    id: str
    title: str
    physics: str
    parameters: tuple[ParameterSpec, ...]
    terms: tuple[Term, ...] = field(repr=False)
    frees_root_rotation: bool = False
    nonlinear: bool = False

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    @property
    def required_parameter_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters if p.required)


BASE_PARAMETERS: tuple[ParameterSpec, ...] = (
    ParameterSpec("bending_stiffness_Nm2", "N m²", "EI", "bending stiffness of the bare beam", 0.01, 10.0),
    ParameterSpec("patch_coupling_NmV", "N m/V", "k_p", "moment per volt applied by the piezo patch", 1e-4, 1.0),
)


#: Terms of the base beam: rho M_beam, EI K_beam and the patch moment k_p V(t).
BASE_TERMS: tuple[Term, ...] = (
    Term("mass", "mass_beam", "linear_density_kg_m"),
    Term("stiffness", "stiffness_beam", "bending_stiffness_Nm2"),
    Term("force", "patch_force", "patch_coupling_NmV"),
)


EFFECTS: dict[str, Effect] = {
    effect.id: effect
    for effect in (
        Effect(
            "air_damping",
            "Air damping",
            "viscous force gamma w_t proportional to the local velocity",
            (ParameterSpec("air_damping_Ns_m2", "N s/m²", "γ", "viscous (air) damping per unit length", 1e-6, 1.0),),
            (Term("damping", "mass_beam", "air_damping_Ns_m2"),),
        ),
        Effect(
            "kelvin_voigt",
            "Kelvin–Voigt damping",
            "internal strain-rate damping moment cI w_xxt",
            (ParameterSpec("kelvin_voigt_Nm2s", "N m² s", "c_I", "Kelvin–Voigt strain-rate damping", 1e-9, 1e-3),),
            (Term("damping", "stiffness_beam", "kelvin_voigt_Nm2s"),),
        ),
        Effect(
            "tip_mass",
            "Tip mass",
            "point mass at the free end x = L (translation only)",
            (ParameterSpec("tip_mass_kg", "kg", "m_t", "point mass at the tip", 1e-7, 0.2),),
            (Term("mass", "mass_tip", "tip_mass_kg"),),
        ),
        Effect(
            "clamp_compliance",
            "Compliant clamp",
            "rotational spring at the root instead of a rigid clamp: EI w''(0) = k_theta w'(0)",
            (ParameterSpec(
                "clamp_stiffness_Nm_rad", "N m/rad", "k_θ", "rotational stiffness of the clamp", 0.01, 1e6, absent_at="high"
            ),),
            (Term("stiffness", "stiffness_clamp", "clamp_stiffness_Nm_rad"),),
            frees_root_rotation=True,
        ),
        Effect(
            "patch_stiffening",
            "Patch stiffening",
            "the bonded patch adds density and bending stiffness on [p_l, p_r]",
            (
                ParameterSpec("patch_added_density_kg_m", "kg/m", "Δρ", "density added by the patch", 1e-6, 5.0),
                ParameterSpec("patch_added_stiffness_Nm2", "N m²", "ΔEI", "bending stiffness added by the patch", 1e-6, 10.0),
            ),
            (
                Term("mass", "mass_patch", "patch_added_density_kg_m"),
                Term("stiffness", "stiffness_patch", "patch_added_stiffness_Nm2"),
            ),
        ),
        Effect(
            # its own effect (it was an optional parameter of patch_stiffening, which no control
            # could add): a record simulated with it is repaired only by a model that has it
            "patch_damping",
            "Patch damping",
            "the bonded patch (its adhesive layer) adds strain-rate damping Δc_I w_xxt on [p_l, p_r]",
            (ParameterSpec(
                "patch_added_kelvin_voigt_Nm2s", "N m² s", "Δc_I", "strain-rate damping added by the patch", 1e-9, 1e-3,
            ),),
            (Term("damping", "stiffness_patch", "patch_added_kelvin_voigt_Nm2s"),),
        ),
        Effect(
            "tip_cubic_spring",
            "Hardening tip spring",
            "nonlinear restoring force -k3 w(L, t)^3 at the tip",
            (ParameterSpec("tip_cubic_stiffness_N_m3", "N/m³", "k_3", "cubic stiffness at the tip", 1.0, 1e7),),
            (Term("tip_cubic", "tip_values", "tip_cubic_stiffness_N_m3"),),
            nonlinear=True,
        ),
    )
}

#: Every public parameter name, base first.
PARAMETER_SPECS: dict[str, ParameterSpec] = {
    spec.name: spec for spec in BASE_PARAMETERS + tuple(p for e in EFFECTS.values() for p in e.parameters)
}


def parameter_spec(name: str) -> ParameterSpec:
    """The spec of a public parameter name; BeamInputError names the valid ones otherwise."""
    try:
        return PARAMETER_SPECS[name]
    except KeyError:
        raise BeamInputError(
            f"unknown parameter {name!r}; known parameters: {', '.join(PARAMETER_SPECS)}"
        ) from None


def effect_of_parameter(name: str) -> str | None:
    """Effect id that declares ``name``, or None for a base parameter."""
    parameter_spec(name)
    for effect in EFFECTS.values():
        if name in effect.parameter_names:
            return effect.id
    return None


def effects_switched_on(parameter_names: Iterable[str]) -> tuple[str, ...]:
    """Effects switched on by the presence of their parameters, in catalogue order."""
    wanted = {effect_of_parameter(name) for name in parameter_names} - {None}
    return tuple(effect_id for effect_id in EFFECTS if effect_id in wanted)


def parse_effects(effects: str | Iterable[str]) -> tuple[str, ...]:
    """Validate effect ids (a comma-separated string or an iterable); catalogue order, no repeats."""
    items = [e.strip() for e in effects.split(",")] if isinstance(effects, str) else [str(e).strip() for e in effects]
    items = [e for e in items if e]
    unknown = [e for e in items if e not in EFFECTS]
    if unknown:
        raise BeamInputError(f"unknown effect {unknown[0]!r}; known effects: {', '.join(EFFECTS)}")
    return tuple(effect_id for effect_id in EFFECTS if effect_id in items)


def model_parameter_names(effects: Iterable[str]) -> tuple[str, ...]:
    """Required (calibrated) parameter names of the base model plus ``effects``."""
    names = [p.name for p in BASE_PARAMETERS]
    for effect_id in parse_effects(effects):
        names.extend(EFFECTS[effect_id].required_parameter_names)
    return tuple(names)
