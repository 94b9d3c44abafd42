"""What an effect is: its parameters, its linear terms and every other thing the project knows of it.

An :class:`Effect` is one small object, like one of emcee's moves: the model, the calibration,
the diagnosis and the dashboard ask it, never its id. Each effect is defined in its own module
of :mod:`beam.physics.effects` (the module named by its id) as the object ``EFFECT``; the
registry (:mod:`beam.physics.effects.registry`) collects them.

This module imports no numerical library (the command line reads the catalogue before a record).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from beam.errors import BeamInputError

__all__ = ["ABSENT_AT", "PLAUSIBLE_SCALES", "Effect", "catalogue_effect", "Fingerprint", "GeometryChange", "ParameterSpec", "Part", "Refusal", "StartHints",
           "TARGETS", "Term"]

#: Where on its prior's range a parameter's effect vanishes (:attr:`ParameterSpec.absent_at`).
ABSENT_AT = ("low", "high", "centre")
#: What a :attr:`ParameterSpec.plausible` range is counted in (:attr:`ParameterSpec.plausible_scale`):
#: None natural units; ``"EI/L"`` the strip's root stiffness (N m/rad, and N m for a moment: a
#: rotation in rad); ``"EI/L^5"`` (N/m³: a cubic tip stiffness); ``"rho L"`` the strip's own mass (kg).
PLAUSIBLE_SCALES = (None, "EI/L", "EI/L^5", "rho L")


@dataclass(frozen=True)
class ParameterSpec:
    """A physical parameter: name (with its unit in it), meaning, default prior and known values.

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
    nominal_log_sd : float or None
        sigma of log x of the log-normal prior centred on a ``[nominal]`` value (how well such a
        quantity is usually known: :func:`beam.calibration.setup.parameter_prior`); None: a
        nominal value of it is not expected (asked for, it is a KeyError).
    plausible : (float, float) or None
        Values the literature finds for it (in ``plausible_scale``), when it does; None otherwise.
        A calibrated value outside it is not this effect (:mod:`beam.discovery.plausibility`).
    plausible_source : str or None
        Where ``plausible`` comes from (references), None when ``plausible`` is.
    plausible_scale : str or None
        What ``plausible`` is counted in (:data:`PLAUSIBLE_SCALES`): None natural units, else a
        scale of the record's strip (its EI at the calibrated value and its stated length and
        density), so that one range holds for a 2 mm aluminium strip and a 5 mm steel bar.
    """

    name: str
    unit: str
    symbol: str
    description: str
    prior_low: float
    prior_high: float
    required: bool = True
    absent_at: str = "low"
    nominal_log_sd: float | None = None
    plausible: tuple[float, float] | None = None
    plausible_source: str | None = None
    plausible_scale: str | None = None

    def __post_init__(self) -> None:
        if self.plausible_scale not in PLAUSIBLE_SCALES:
            raise ValueError(f"{self.name}: plausible_scale must be one of {PLAUSIBLE_SCALES}, got {self.plausible_scale!r}")
        if self.absent_at not in ABSENT_AT:
            raise ValueError(f"absent_at must be one of {ABSENT_AT}, got {self.absent_at!r}")
        if (self.plausible is None) != (self.plausible_source is None):
            raise ValueError(f"{self.name}: a plausible range needs its source, and a source its range")

    @property
    def label(self) -> str:
        """Axis label with the unit, e.g. ``EI (N m²)``."""
        return f"{self.symbol} ({self.unit})"


#: What a :class:`Term` adds to: a matrix, the input's force vector, or one undamped mode's damping.
TARGETS = ("mass", "damping", "stiffness", "force", "modal_ratio")


@dataclass(frozen=True)
class Term:
    """One contribution ``value of parameter * part`` to the linear system.

    ``target`` is ``"mass"``, ``"damping"`` or ``"stiffness"`` (a matrix part), ``"force"`` (a
    vector multiplying the input: the voltage V(t) or a point force F(t)) or ``"modal_ratio"``
    (2 zeta omega added to the damping of the undamped mode ``mode``, 1-based; ``part`` is then
    ``"undamped_modes"``). ``part`` names an attribute of
    :class:`beam.physics.assembly.GalerkinParts` or a :class:`Part` of the effect's own;
    ``parameter`` names the parameter whose value is the coefficient (``linear_density_kg_m`` is
    the sidecar's rho, ``unit`` the number 1, e.g. for a measured point force in N).
    Nonlinear forces are not terms: they are channels (:class:`beam.physics.effects.channel.Channel`).
    """

    target: str
    part: str
    parameter: str
    mode: int = 0

    def __post_init__(self) -> None:
        if self.target not in TARGETS:
            raise ValueError(f"term target must be one of {TARGETS}, got {self.target!r}")


@dataclass(frozen=True)
class Part:
    """A Galerkin part an effect assembles itself, for a unit coefficient.

    ``assemble(basis, geometry)`` returns the (n, n) matrix (or (n,) vector) of the basis
    :class:`~beam.physics.basis.SplineBasis` on the geometry
    :class:`~beam.physics.geometry.BeamGeometry`; a :class:`Term` names it by ``name``, which
    must not be the name of a :class:`~beam.physics.assembly.GalerkinParts` attribute.
    :class:`~beam.physics.model.BeamModel` assembles it once, with the shared parts.
    """

    name: str
    assemble: Callable[[Any, Any], Any] = field(repr=False)


@dataclass(frozen=True)
class GeometryChange:
    """An effect that changes the geometry instead of adding a term (the effective free length).

    ``parameter`` is the parameter whose value makes a new geometry; ``apply(geometry, value)``
    returns it. :class:`~beam.physics.model.BeamModel` then assembles one model per value (the
    same mesh, input and other effects) and routes every call to it.
    """

    parameter: str
    apply: Callable[[Any, float], Any] = field(repr=False)


@dataclass(frozen=True)
class Refusal:
    """A condition on the record for the effect to be calibrated, and the refusal in words.

    The record must have every feature of ``needs`` (:data:`beam.physics.effects.RECORD_FEATURES`);
    otherwise the setup (:func:`beam.calibration.pipeline.make_setup`) raises
    :class:`~beam.errors.BeamInputError` with ``words``.
    """

    needs: frozenset[str]
    words: str


@dataclass(frozen=True)
class Fingerprint:
    """What an effect leaves in the residuals of a model without it (:mod:`beam.residuals.fingerprints`).

    Attributes
    ----------
    threshold : float
        Size of the fingerprint that makes the effect's score 1 ("worth noticing").
    score : callable
        ``score(fp)`` from the flat dict of fingerprints (:func:`beam.residuals.fingerprints.fingerprints`):
        0 no sign, >= 1 worth noticing. NaN fingerprints must give 0.
    explain : callable
        ``explain(fp, score)``: one sentence quoting the measured numbers, saying whether they
        point to the effect (``score >= 1``) or not, or what is missing to judge.
    """

    threshold: float
    score: Callable[[Mapping[str, float]], float] = field(repr=False)
    explain: Callable[[Mapping[str, float], float], str] = field(repr=False)


@dataclass(frozen=True)
class StartHints:
    """Where a MAP search may start with the effect on (each hint optional).

    Attributes
    ----------
    spectral : callable or None
        ``spectral(reduced, window_amplitude_m, values) -> omega2`` (B, m) (rad²/s²): the
        retained modes' squared frequencies the record's spectral peaks show with the effect on
        at the window's displacement amplitude (``reduced`` of
        :meth:`beam.physics.model.BeamModel.reduced_system`, ``values`` (B,) arrays by name): the
        spectral starts match these instead of the linear frequencies.
    free_decay : callable or None
        ``free_decay(model, one, state, duration_s) -> list of dict``: starts of a free decay's
        calibration with the effect on, from the optimum ``one`` (natural units) of the model
        without it (its parameters at their null values), ``state`` the modal state (eta, eta')
        (2m,) at the window's start (:meth:`~beam.physics.model.BeamModel.free_state_from_amplitudes`
        coordinates), ``duration_s`` the window's length from that start.
    """

    spectral: Callable | None = field(default=None, repr=False)
    free_decay: Callable | None = field(default=None, repr=False)


@dataclass(frozen=True)
class Effect:
    """A named, optional physical effect and everything known of it.

    Parameters
    ----------
    id : str
        Public identifier, e.g. ``tip_mass`` (also the name of its module).
    title : str
        Short human title.
    physics : str
        One sentence on what it models.
    parameters : tuple of ParameterSpec
        Parameters it declares.
    terms : tuple of Term
        What it adds to the linear system; a term of an optional parameter applies only when
        that parameter is given.
    parts : tuple of Part
        Galerkin parts it assembles itself (its terms may name them).
    knots : callable or None
        ``knots(geometry) -> positions (m)`` where its own part makes the curvature jump (a
        concentrated moment): its model's basis has a double knot there (C¹ only,
        :func:`beam.physics.basis.knot_vector`), so the frequencies keep converging at fourth order.
    channel : Channel or None
        Its nonlinear force (:class:`beam.physics.effects.channel.Channel`); None for a linear effect.
    averaged : AveragedForm or None
        Its averaged (slow-flow) form on a free decay (:class:`beam.physics.effects.averaged.AveragedForm`).
    geometry : GeometryChange or None
        When it changes the geometry instead of adding a term.
    frees_root_rotation : bool
        True when the effect replaces the rigid clamp (the basis keeps the root rotation).
    per_mode : bool
        True when ``parameters`` is a family with one parameter per undamped mode (mode 1
        first); a model retaining m modes needs the first m of them.
    needs_patch : bool
        True when the effect acts on the piezo patch (the sidecar must have ``[patch]``).
    missing_effect_candidate : bool
        Whether the missing-effect ranking offers it (:data:`beam.physics.effects.CANDIDATE_EFFECTS`).
    offered_on_records : bool
        Whether a diagnosis of a record offers it where the record has its needs, though it is
        not a ranking candidate in general (the sensor's mass on a contact sensor's record).
    needs : frozenset of str
        Record features (:data:`beam.physics.effects.RECORD_FEATURES`) it needs before a
        diagnosis offers it, beyond those :func:`beam.physics.effects.effect_needs` derives
        (the patch for ``needs_patch``, an input for a term that multiplies the input).
    refusals : tuple of Refusal
        Conditions on the record for it to be calibrated at all, each with its refusal.
    fingerprint : Fingerprint or None
        What it leaves in the residuals (the ranking's candidates have one).
    hints : StartHints
        Where a MAP search may start with it on.
    left_out_of_nominal : str or None
        Why the nominal model that chooses the number of modes leaves it out
        (:func:`beam.calibration.modes.suggest_modes`), None when it is in.
    catalogue_order : float
        Its place in the catalogue (effects are listed, and a model's effects ordered, by it).
    """

    id: str
    title: str
    physics: str
    parameters: tuple[ParameterSpec, ...]
    terms: tuple[Term, ...] = field(default=(), repr=False)
    parts: tuple[Part, ...] = field(default=(), repr=False)
    knots: Callable | None = field(default=None, repr=False)
    channel: Any = field(default=None, repr=False)
    averaged: Any = field(default=None, repr=False)
    geometry: GeometryChange | None = field(default=None, repr=False)
    frees_root_rotation: bool = False
    per_mode: bool = False
    needs_patch: bool = False
    missing_effect_candidate: bool = True
    offered_on_records: bool = False
    needs: frozenset[str] = frozenset()
    refusals: tuple[Refusal, ...] = field(default=(), repr=False)
    fingerprint: Fingerprint | None = field(default=None, repr=False)
    hints: StartHints = field(default=StartHints(), repr=False)
    left_out_of_nominal: str | None = None
    catalogue_order: float = 0.0

    def __post_init__(self) -> None:
        own = {p.name for p in self.parameters}
        for term in self.terms:
            if term.parameter not in own:
                raise ValueError(f"effect {self.id}: term of {term.parameter!r}, not one of its parameters")
        if self.channel is not None and not set(self.channel.parameters) <= own:
            raise ValueError(f"effect {self.id}: its channel reads parameters it does not declare")

    def __reduce__(self):  # pickled by reference: its callables are its module's
        return (catalogue_effect, (self.id,))

    @property
    def nonlinear(self) -> bool:
        """True when the effect makes the equations of motion nonlinear (it has a channel)."""
        return self.channel is not None

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """Every parameter it declares (for a per-mode family: all of them)."""
        return tuple(p.name for p in self.parameters)

    @property
    def required_parameter_names(self) -> tuple[str, ...]:
        """Parameters that must be given when the effect is on (a per-mode family: mode 1's)."""
        return tuple(p.name for p in self.parameters if p.required)

    def parameter(self, name: str) -> ParameterSpec:
        """The spec of one of its parameters (KeyError otherwise)."""
        for p in self.parameters:
            if p.name == name:
                return p
        raise KeyError(name)

    def required_parameter_names_for(self, modes: int | None) -> tuple[str, ...]:
        """Parameters to calibrate in a model that retains ``modes`` modes.

        For a per-mode family the first ``modes`` (at most :data:`beam.physics.effects.MAX_DAMPED_MODES`);
        for any other effect its required parameters. ``modes=None`` is allowed only for the latter.
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

    def refusal(self, features: Iterable[str]) -> str | None:
        """The first refusal whose needs a record with ``features`` lacks, in words, or None."""
        have = set(features)
        return next((r.words for r in self.refusals if not r.needs <= have), None)


def catalogue_effect(effect_id: str) -> Effect:
    """The catalogue's effect ``effect_id``: the ``EFFECT`` of its module ``beam.physics.effects.<id>``."""
    return importlib.import_module(f"beam.physics.effects.{effect_id}").EFFECT
