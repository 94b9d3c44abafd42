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
quadratic_drag      air drag -½ rho_air C_d b |w_t| w_t  drag_coefficient
clamp_friction      microslip of the clamp: a root       clamp_friction_stiffness_Nm_rad,
                    moment that softens and dissipates   clamp_slip_moment_Nm
                    with the amplitude (Iwan, Masing)
sensor_mass         point mass at the sensor x_obs       sensor_mass_kg
effective_length    free length L_eff instead of L       effective_length_m
modal_damping       damping ratio per undamped mode      damping_ratio_mode_1, damping_ratio_mode_2,
                                                         ... (one per retained mode)
==================  ===================================  =========================================

Every parameter declares where its effect vanishes (:attr:`ParameterSpec.absent_at`, used by the
missing-effect ranking to start a candidate "barely switched on"): all at the low end of their
range except the clamp's stiffness (a rigid clamp is k_theta -> infinity).

``sensor_mass``
    A point mass m_s at the sensor's position x_obs, which always comes from the sidecar's
    ``[sensor] position_m`` (the part ``mass_sensor`` is assembled from the geometry): an
    accelerometer glued to the strip loads it where it measures. Translation only.
``effective_length``
    The free length L_eff (m) between the clamp's edge and the tip, instead of the sidecar's
    ``[beam] length_m``: a clamp holds the strip over a jaw of finite depth and a documented
    419 mm bar can vibrate as if it were shorter. The model is assembled for the length
    (:meth:`beam.physics.geometry.BeamGeometry.with_free_length`: the tip, the sensor, the
    patch and the force point stay where they are on the strip, i.e. keep their distance from
    the tip, and the clamp's edge moves). It adds no term: it changes every part. It vanishes
    exactly at L_eff = L (``absent_at = "centre"``), the centre of its prior, which the
    calibration takes from the record's stated length: log-normal around it with
    sigma = :data:`FREE_LENGTH_LOG_SD` (0.1, i.e. about 10 %, truncated at 4 sigma, so
    0.67-1.49 L and always positive). 10 % because a jaw's depth is a few cm on strips of a
    few dm, the issue's own example (419 mm vibrating as 365 mm) is 13 % off, and a
    frequency, which goes as 1 / L², would pin a much narrower prior against EI's instead of
    letting the record's amplitude and mode ratios decide. It competes with
    ``clamp_compliance`` (both lower every frequency) in the missing-effect ranking; a
    compliant clamp changes the mode ratios, a shorter length does not.
``quadratic_drag``
    Air drag on the strip moving broadside, force per unit length -½ rho_air C_d b |w_t| w_t
    (rho_air = :data:`beam.physics.nonlinear.AIR_DENSITY_KG_M3`, b the width from the sidecar's
    ``[beam] width_m``, w_t the local transverse velocity): a damping that grows with the
    amplitude (equivalent viscous coefficient (8 / 3 pi) ½ rho_air C_d b |w_t|max). It is
    projected on the retained modes by Gauss quadrature along the span and integrated with the
    tip spring's ETDRK4 scheme (:func:`beam.physics.nonlinear.integrate_general`). Plausible
    values of C_d for a flat plate or strip in oscillating flow at Keulegan–Carpenter numbers
    KC = 2 pi A / b of order 0.1–10 lie between about 2 and 20, rising as KC falls
    (Keulegan & Carpenter 1958, J. Res. Natl. Bur. Stand. 60, 423–440, plates in an oscillating
    fluid; Graham 1980, J. Fluid Mech. 97, 331–346, C_d ∝ KC^(-1/3) for sharp-edged bodies at low
    KC; Bidkar et al. 2009, J. Fluid Mech. 634, 269–289, cantilevered strips at KC of order 1).
    The prior range 0.01–50 reaches below that band so that the effect vanishes at its low
    end (a model with it nests the model without it).
``clamp_friction``
    Frictional microslip where the clamp grips the strip: the root is held by a rotational
    joint of stick stiffness k_f (``clamp_friction_stiffness_Nm_rad``) whose contact slips
    progressively as the root moment grows, until the whole contact slips at the moment M_s
    (``clamp_slip_moment_Nm``). The joint is Iwan's parallel array of Jenkins elements with a
    uniform density of slip strengths (Iwan 1966, J. Appl. Mech. 33, 893–900; Segalman 2005,
    J. Appl. Mech. 72, 752–760): its loading curve is M(theta) = k_f theta (1 - |theta| / (2
    theta_s)) for |theta| <= theta_s = 2 M_s / k_f and M_s beyond, and it unloads and reloads
    along Masing's branches M = M_r + 2 M((theta - theta_r) / 2) from the last reversal
    (theta_r, M_r) (Masing 1926). In microslip (|theta| < theta_s) the cycle of amplitude A has
    the mean stiffness k_f - (k_f / 2 theta_s) A (half the sum of its branches) and dissipates
    (4 / 3) (k_f / 2 theta_s) A³: the frequency of every mode falls, and its damping ratio
    grows, linearly with the amplitude, the damping ratio 4 / 3 pi (0.42) times the relative
    frequency drop (``docs/physics-clamp-friction.md``). The linear part k_f theta
    replaces the rigid clamp (the basis keeps the root rotation, as ``clamp_compliance``);
    the softening, the hysteresis and the slip are integrated with the drag's ETDRK4 scheme
    (:func:`beam.physics.nonlinear.integrate_general`). Both parameters vanish at the top of
    their ranges (a rigid joint that never slips), where the model nests the model without it.
``modal_damping``
    Damping applied in the coordinates of the undamped modes (of the current M and K, sensor mass
    and all): mode j gets the ratio zeta_j, so that alone it has the poles
    lambda = -zeta_j omega_j ± i omega_j sqrt(1 - zeta_j²). It is a damping *model* that can
    replace ``air_damping`` + ``kelvin_voigt`` (a free decay often fixes each mode's decay rate
    better than any law in omega); with them it adds to their modal damping matrix. Its
    parameters are a *per-mode family* (:attr:`Effect.per_mode`): ``damping_ratio_mode_j`` for
    j = 1 .. :data:`MAX_DAMPED_MODES`, declared once in the catalogue; a model that retains m
    modes needs the first m (:meth:`Effect.required_parameter_names_for`,
    :func:`model_parameter_names` with ``modes``), and the catalogue marks only mode 1 required
    (the effect is on when its first ratio is given). A mode without a given ratio gets no
    damping from this effect. In the full Galerkin model (the reference) the same damping is the
    matrix C = M Phi diag(2 zeta_j omega_j) Phi^T M over the modes with a ratio (mass-normalised
    undamped shapes Phi), which leaves every other mode undamped by it.

Effects flagged ``missing_effect_candidate=False`` are left out of the missing-effect ranking
(:data:`CANDIDATE_EFFECTS`): ``modal_damping`` replaces a damping law rather than adding physics,
and ``sensor_mass`` matters for a contact sensor (an accelerometer), which a displacement record
from a laser does not have; the diagnosis decides when to offer them. ``clamp_friction`` is named
by the diagnosis's note on a held-out phase lag where the record's own frequency rises as the
swing dies, not fitted by the ranking: its calibration takes minutes, the ranking fits every
candidate (``docs/physics-clamp-friction.md``). ``quadratic_drag`` is
offered on free decays of a strip whose width the sidecar gives (:data:`EFFECT_NEEDS`).
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
    absent_at : {"low", "high", "centre"}
        The end of the range where the effect vanishes (a rigid clamp is k_theta -> infinity).
        The range reaches far enough that the effect is negligible there, so that a model with
        the effect nests the model without it. ``"centre"``: the effect vanishes exactly at its
        prior's centre, the record's own value (the effective length at the stated length).
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
    vector multiplying the input: the voltage V(t) or a point force F(t)), ``"tip_cubic"`` (the
    cubic tip force, vector part) or ``"modal_damping"`` (2 zeta omega added to the damping of
    the undamped mode ``mode``, 1-based; ``part`` is then ``"undamped_modes"``).
    ``part`` names an attribute of :class:`beam.physics.assembly.GalerkinParts`; ``parameter`` names the
    parameter whose value is the coefficient (``linear_density_kg_m`` is the sidecar's rho,
    ``unit`` the number 1, e.g. for a measured point force in N).
    """

    target: str
    part: str
    parameter: str
    mode: int = 0


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
    per_mode : bool
        True when ``parameters`` is a family with one parameter per undamped mode (mode 1
        first); a model retaining m modes needs the first m of them.
    needs_patch : bool
        True when the effect acts on the piezo patch (the sidecar must have ``[patch]``).
    missing_effect_candidate : bool
        Whether the missing-effect ranking offers it (see the module notes).
    """

    id: str
    title: str
    physics: str
    parameters: tuple[ParameterSpec, ...]
    terms: tuple[Term, ...] = field(repr=False)
    frees_root_rotation: bool = False
    nonlinear: bool = False
    per_mode: bool = False
    needs_patch: bool = False
    missing_effect_candidate: bool = True

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """Every parameter it declares (for a per-mode family: all :data:`MAX_DAMPED_MODES`)."""
        return tuple(p.name for p in self.parameters)

    @property
    def required_parameter_names(self) -> tuple[str, ...]:
        """Parameters that must be given when the effect is on (a per-mode family: mode 1's)."""
        return tuple(p.name for p in self.parameters if p.required)

    def required_parameter_names_for(self, modes: int | None) -> tuple[str, ...]:
        """Parameters to calibrate in a model that retains ``modes`` modes.

        For a per-mode family the first ``modes`` (at most :data:`MAX_DAMPED_MODES`); for any
        other effect its required parameters. ``modes=None`` is allowed only for the latter.
        """
        if not self.per_mode:
            return self.required_parameter_names
        if modes is None:
            raise BeamInputError(
                f"effect {self.id} has one parameter per retained mode; give the number of modes "
                "(parameter_names_for(modes))"
            )
        if isinstance(modes, bool) or int(modes) != modes or not 1 <= modes:
            raise BeamInputError(f"modes must be a positive integer, got {modes!r}")
        if modes > len(self.parameters):
            raise BeamInputError(
                f"effect {self.id} declares parameters for at most {len(self.parameters)} modes, got modes = {modes}"
            )
        return tuple(p.name for p in self.parameters[: int(modes)])


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

#: What drives the beam: the patch voltage (V), a point force at ``[force] position_m`` (N), or
#: nothing (a free response from an initial state).
INPUT_KINDS: tuple[str | None, ...] = ("voltage", "force", None)

#: The force term of each input kind (None: no force term, the beam is not driven).
INPUT_TERMS: dict[str | None, Term | None] = {
    "voltage": Term("force", "patch_force", "patch_coupling_NmV"),
    "force": Term("force", "point_force", "unit"),
    None: None,
}

#: Most modes a per-mode family (``modal_damping``) declares parameters for.
MAX_DAMPED_MODES = 20
#: sigma of log L_eff of the ``effective_length`` prior around the stated length (module notes).
FREE_LENGTH_LOG_SD = 0.1


def base_parameters(input_kind: str | None = "voltage") -> tuple[ParameterSpec, ...]:
    """Base parameters for an input kind: EI always, the patch coupling k_p for a voltage input."""
    check_input_kind(input_kind)
    return BASE_PARAMETERS if input_kind == "voltage" else BASE_PARAMETERS[:1]


def check_input_kind(input_kind: str | None) -> None:
    """Raise BeamInputError unless ``input_kind`` is ``"voltage"``, ``"force"`` or None."""
    if input_kind not in INPUT_KINDS:
        raise BeamInputError(f"input kind must be 'voltage', 'force' or None (a free response), got {input_kind!r}")


def _modal_damping_effect() -> Effect:
    specs = tuple(
        ParameterSpec(
            f"damping_ratio_mode_{j}", "1", f"ζ_{j}", f"damping ratio of undamped mode {j}", 1e-5, 0.3,
            required=j == 1,
        )
        for j in range(1, MAX_DAMPED_MODES + 1)
    )
    terms = tuple(Term("modal_damping", "undamped_modes", spec.name, mode=j) for j, spec in enumerate(specs, start=1))
    return Effect(
        "modal_damping",
        "Modal damping",
        "a damping ratio per undamped mode, applied in modal coordinates: lambda = -zeta omega ± i omega sqrt(1 - zeta²)",
        specs,
        terms,
        per_mode=True,
        missing_effect_candidate=False,
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
            needs_patch=True,
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
        Effect(
            "quadratic_drag",
            "Quadratic air drag",
            "air drag on the strip moving broadside, force per length -½ rho_air C_d b |w_t| w_t (b from [beam] width_m)",
            (ParameterSpec("drag_coefficient", "1", "C_d", "drag coefficient of the strip in oscillating flow", 0.01, 50.0),),
            (Term("quadratic_drag", "mass_beam", "drag_coefficient"),),
            nonlinear=True,
        ),
        Effect(
            "clamp_friction",
            "Clamp friction",
            "the clamp grips the strip by friction: a root joint of stick stiffness k_f that slips progressively "
            "(Iwan microslip, Masing hysteresis) and wholly at the moment M_s",
            (
                ParameterSpec("clamp_friction_stiffness_Nm_rad", "N m/rad", "k_f",
                              "stick stiffness of the clamp's frictional joint", 0.01, 1e6, absent_at="high"),
                ParameterSpec("clamp_slip_moment_Nm", "N m", "M_s",
                              "root moment at which the whole clamp contact slips", 1e-4, 1e4, absent_at="high"),
            ),
            (
                Term("stiffness", "stiffness_clamp", "clamp_friction_stiffness_Nm_rad"),
                Term("clamp_friction", "stiffness_clamp", "clamp_slip_moment_Nm"),
            ),
            frees_root_rotation=True,
            nonlinear=True,
            missing_effect_candidate=False,
        ),
        Effect(
            "sensor_mass",
            "Sensor mass",
            "point mass of the sensor at its position x_obs (from the sidecar; translation only)",
            (ParameterSpec("sensor_mass_kg", "kg", "m_s", "point mass of the sensor at its position", 1e-7, 0.2),),
            (Term("mass", "mass_sensor", "sensor_mass_kg"),),
            missing_effect_candidate=False,
        ),
        Effect(
            "effective_length",
            "Effective free length",
            "the strip vibrates as if its free length were L_eff, not the stated length (the clamp's edge is never exact)",
            (ParameterSpec("effective_length_m", "m", "L_eff", "free length between the clamp's edge and the tip",
                           0.01, 100.0, absent_at="centre"),),
            (),
        ),
        _modal_damping_effect(),
    )
}

#: Effects the missing-effect ranking offers, in catalogue order.
CANDIDATE_EFFECTS: tuple[str, ...] = tuple(e.id for e in EFFECTS.values() if e.missing_effect_candidate)

#: Record features an effect can need before a diagnosis offers it (:func:`effect_needs`).
RECORD_FEATURES: dict[str, str] = {
    "patch": "the sidecar places a piezo patch ([patch])",
    "input": "the record has an input (the patch voltage or a point force): the beam is driven",
    "contact_sensor": "the output comes from a contact sensor (an accelerometer), whose mass loads the beam",
    "uniform": "the time stamps are a uniform grid",
    "displacement": "the output is a displacement",
    "width": "the sidecar gives the strip's width ([beam] width_m)",
    "free": "the record has no input: a free decay",
    "rising_frequency": ("the free decay's mode-1 frequency rises as the swing dies (short-time spectra of its first "
                         "and last thirds): the beam is stiffer at small amplitude"),
    "no_patch": "the sidecar places no patch: the clamp's edge can move without carrying a bonded patch into the clamp",
}

#: Features each effect needs beyond what :func:`effect_needs` derives from the effect itself
#: (the patch for ``needs_patch``, an input for a term that multiplies the input). The tip's
#: cubic spring is calibrated by a solver that needs a driven displacement record on uniform stamps.
EFFECT_NEEDS: dict[str, frozenset[str]] = {
    "patch_damping": frozenset({"patch"}),
    "sensor_mass": frozenset({"contact_sensor"}),
    "tip_cubic_spring": frozenset({"input", "uniform", "displacement"}),
    # offered on free decays, where a damping that grows with the amplitude shows (the calibration
    # fits them: beam.calibration.free_nonlinear), of a strip whose width is known
    "quadratic_drag": frozenset({"width", "free"}),
    # calibrated on free decays (beam.calibration.free_nonlinear); offered where the record's own
    # spectra show the softening it stands for
    "clamp_friction": frozenset({"free", "rising_frequency"}),
    # a strip's free length is uncertain where it is clamped by hand; on a patch beam the prior's
    # range of lengths would move the bonded patch into the clamp (the fit then fails)
    "effective_length": frozenset({"no_patch"}),
}


def effect_needs(effect_id: str) -> frozenset[str]:
    """The record features (:data:`RECORD_FEATURES`) ``effect_id`` needs to apply to a record."""
    effect = EFFECTS[effect_id]
    needs = set(EFFECT_NEEDS.get(effect_id, ()))
    if effect.needs_patch:
        needs.add("patch")
    if any(term.target == "force" for term in effect.terms):
        needs.add("input")
    return frozenset(needs)


def applicable(effect_id: str, features: Iterable[str]) -> bool:
    """Whether ``effect_id`` applies to a record that has ``features`` (:data:`RECORD_FEATURES`)."""
    return effect_needs(effect_id) <= set(features)


#: Every public parameter name, base first.
PARAMETER_SPECS: dict[str, ParameterSpec] = {
    spec.name: spec for spec in BASE_PARAMETERS + tuple(p for e in EFFECTS.values() for p in e.parameters)
}


def parameter_listing() -> str:
    """The known parameter names for a message, a per-mode family shortened to its first and last."""
    names: list[str] = []
    for name in PARAMETER_SPECS:
        effect = _EFFECT_OF.get(name)
        if effect is not None and EFFECTS[effect].per_mode:
            family = EFFECTS[effect].parameter_names
            if name == family[0]:
                names.append(f"{family[0]} ... {family[-1]}")
            continue
        names.append(name)
    return ", ".join(names)


def parameter_spec(name: str) -> ParameterSpec:
    """The spec of a public parameter name; BeamInputError names the valid ones otherwise."""
    try:
        return PARAMETER_SPECS[name]
    except KeyError:
        raise BeamInputError(f"unknown parameter {name!r}; known parameters: {parameter_listing()}") from None


_EFFECT_OF: dict[str, str] = {name: effect.id for effect in EFFECTS.values() for name in effect.parameter_names}


def effect_of_parameter(name: str) -> str | None:
    """Effect id that declares ``name``, or None for a base parameter."""
    parameter_spec(name)
    return _EFFECT_OF.get(name)


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


def model_parameter_names(
    effects: Iterable[str], modes: int | None = None, input_kind: str | None = "voltage"
) -> tuple[str, ...]:
    """Required (calibrated) parameter names of the base model plus ``effects``.

    Parameters
    ----------
    effects : iterable of str or str
        Effect ids.
    modes : int, optional
        Retained modes; needed when an effect has a per-mode family (``modal_damping``).
    input_kind : {"voltage", "force", None}
        What drives the beam: ``patch_coupling_NmV`` belongs to a voltage input only.
    """
    names = [p.name for p in base_parameters(input_kind)]
    for effect_id in parse_effects(effects):
        names.extend(EFFECTS[effect_id].required_parameter_names_for(modes))
    return tuple(names)
