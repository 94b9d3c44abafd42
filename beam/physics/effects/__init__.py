"""The catalogue of physical effects: one module per effect, each an object that carries everything about it.

Like emcee's moves (one strategy, one small object) and lmfit's components, each effect is the
object ``EFFECT`` of its own module (``beam.physics.effects.tip_mass``, ...,
:class:`~beam.physics.effects.effect.Effect`): its parameters (name with unit, default prior,
the spread of a prior around a nominal value, plausible values with their source), the linear
terms it adds to the Galerkin system (and any Galerkin part it assembles itself), its nonlinear
force as a channel the integrator takes from a list (:mod:`beam.physics.effects.channel`), its
averaged (slow-flow) form (:mod:`beam.physics.effects.averaged`), where it applies and the
refusal in words, its fingerprint in the residuals, its start hints. The model
(:mod:`beam.physics.model`) composes the base beam (:mod:`beam.physics.effects.base`) with any
set of effects at assembly time; the catalogue (:mod:`beam.physics.effects.registry`) is every
module of the package that defines an ``EFFECT``: adding an effect is adding its module.

Effect ids and parameter names are a public contract (files, CLI, dashboard). The base's
parameters are ``bending_stiffness_Nm2`` (always) and ``patch_coupling_NmV`` (a voltage input);
each effect's are in its module. Every parameter declares where its effect vanishes
(:attr:`ParameterSpec.absent_at`, used by the missing-effect ranking to start a candidate
"barely switched on" and by the null values of nested fits).

Each effect's physics, its limits and sources are in its module's notes. Effects flagged
``missing_effect_candidate=False`` are left out of the missing-effect ranking
(:data:`CANDIDATE_EFFECTS`); the diagnosis decides when to offer them
(:attr:`~beam.physics.effects.effect.Effect.offered_on_records`, :func:`effect_needs`).

This package imports no numerical library (the command line reads the catalogue before a record).
"""

from __future__ import annotations

from beam.physics.effects.base import (
    BASE_PARAMETERS,
    BASE_TERMS,
    INPUT_KINDS,
    INPUT_TERMS,
    base_parameters,
    check_input_kind,
)
from beam.physics.effects.channel import Channel, ChannelArrays
from beam.physics.effects.effect import Effect, Fingerprint, GeometryChange, ParameterSpec, Part, Refusal, StartHints, Term
from beam.physics.effects.registry import (
    CANDIDATE_EFFECTS,
    EFFECT_NEEDS,
    EFFECTS,
    PARAMETER_SPECS,
    RECORD_FEATURES,
    applicable,
    effect_needs,
    effect_of_parameter,
    effects_switched_on,
    model_parameter_names,
    parameter_listing,
    parameter_spec,
    parse_effects,
)
from beam.physics.effects.effective_length import FREE_LENGTH_LOG_SD
from beam.physics.effects.modal_damping import MAX_DAMPED_MODES

__all__ = [
    "BASE_PARAMETERS", "BASE_TERMS", "CANDIDATE_EFFECTS", "EFFECTS", "EFFECT_NEEDS", "FREE_LENGTH_LOG_SD", "INPUT_KINDS",
    "INPUT_TERMS", "MAX_DAMPED_MODES", "PARAMETER_SPECS", "RECORD_FEATURES", "Channel", "ChannelArrays", "Effect",
    "Fingerprint", "GeometryChange", "ParameterSpec", "Part", "Refusal", "StartHints", "Term", "applicable",
    "base_parameters", "check_input_kind", "effect_needs", "effect_of_parameter", "effects_switched_on",
    "model_parameter_names", "parameter_listing", "parameter_spec", "parse_effects",
]
