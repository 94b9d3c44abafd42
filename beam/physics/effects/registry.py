"""The catalogue: every effect module of :mod:`beam.physics.effects`, found by its ``EFFECT``.

A module of the package that defines ``EFFECT`` (an :class:`~beam.physics.effects.effect.Effect`
whose id is the module's name) is an effect of the catalogue; the catalogue's order is the
effects' :attr:`~beam.physics.effects.effect.Effect.catalogue_order`. Adding an effect is adding
its module. The tables and look-ups every caller reads are derived here.
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Iterable

from beam.errors import BeamInputError
from beam.physics.effects.base import BASE_PARAMETERS, base_parameters
from beam.physics.effects.effect import Effect, ParameterSpec

__all__ = ["CANDIDATE_EFFECTS", "EFFECTS", "EFFECT_NEEDS", "PARAMETER_SPECS", "RECORD_FEATURES", "applicable",
           "effect_needs", "effect_of_parameter", "effects_switched_on", "model_parameter_names", "parameter_listing",
           "parameter_spec", "parse_effects"]

#: Modules of the package that are not effects.
_INFRASTRUCTURE = frozenset({"averaged", "base", "channel", "effect", "fingerprint", "registry"})


def _discover() -> dict[str, Effect]:
    package = importlib.import_module("beam.physics.effects")
    found = []
    for info in pkgutil.iter_modules(package.__path__):
        if info.name in _INFRASTRUCTURE or info.name.startswith("_"):
            continue
        module = importlib.import_module(f"beam.physics.effects.{info.name}")
        effect = getattr(module, "EFFECT", None)
        if not isinstance(effect, Effect):
            continue
        if effect.id != info.name:
            raise RuntimeError(f"beam.physics.effects.{info.name} defines the effect {effect.id!r}: an effect's module is named by its id")
        found.append(effect)
    found.sort(key=lambda e: (e.catalogue_order, e.id))
    return {effect.id: effect for effect in found}


#: Every effect, in catalogue order.
EFFECTS: dict[str, Effect] = _discover()

#: Effects the missing-effect ranking offers, in catalogue order.
CANDIDATE_EFFECTS: tuple[str, ...] = tuple(e.id for e in EFFECTS.values() if e.missing_effect_candidate)

#: Record features an effect can need before a diagnosis offers it (:func:`effect_needs`), or be
#: calibrated (:attr:`~beam.physics.effects.effect.Effect.refusals`).
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
#: (:attr:`~beam.physics.effects.effect.Effect.needs`; effects that need none are left out).
EFFECT_NEEDS: dict[str, frozenset[str]] = {e.id: e.needs for e in EFFECTS.values() if e.needs}

for _effect in EFFECTS.values():
    if _effect.missing_effect_candidate and _effect.fingerprint is None:
        raise RuntimeError(f"effect {_effect.id} is a ranking candidate without a fingerprint")
    for _feature in _effect.needs | {f for r in _effect.refusals for f in r.needs}:
        if _feature not in RECORD_FEATURES:
            raise RuntimeError(f"effect {_effect.id} needs {_feature!r}, which is no record feature")


def effect_needs(effect_id: str) -> frozenset[str]:
    """The record features (:data:`RECORD_FEATURES`) ``effect_id`` needs to apply to a record."""
    effect = EFFECTS[effect_id]
    needs = set(effect.needs)
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

_EFFECT_OF: dict[str, str] = {name: effect.id for effect in EFFECTS.values() for name in effect.parameter_names}


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
