"""The base beam every model has: bending stiffness EI, and the patch coupling k_p of a voltage input.

Euler–Bernoulli bending rho w_tt + (EI w_xx)_xx = 0 with the patch's moment k_p V(t) between its
ends (a voltage input), a point force F(t) at ``[force] position_m`` (N; no coefficient) or no
input (a free response from an initial state). rho is the sidecar's linear density, fixed.
"""

from __future__ import annotations

from beam.errors import BeamInputError
from beam.physics.effects.effect import ParameterSpec, Term

__all__ = ["BASE_PARAMETERS", "BASE_TERMS", "BENDING_STIFFNESS", "DENSITY", "INPUT_KINDS", "INPUT_TERMS",
           "PATCH_COUPLING", "UNIT", "base_parameters", "check_input_kind"]

#: EI: always calibrated.
BENDING_STIFFNESS = ParameterSpec("bending_stiffness_Nm2", "N m²", "EI", "bending stiffness of the bare beam", 0.01,
                                  10.0, nominal_log_sd=0.5)
#: k_p: the moment per volt of the patch (a voltage input only).
PATCH_COUPLING = ParameterSpec("patch_coupling_NmV", "N m/V", "k_p", "moment per volt applied by the piezo patch",
                               1e-4, 1.0, nominal_log_sd=0.7)
BASE_PARAMETERS: tuple[ParameterSpec, ...] = (BENDING_STIFFNESS, PATCH_COUPLING)

#: Pseudo-parameters of the terms: the sidecar's linear density (kg/m) and the number 1 (the
#: coefficient of a measured point force).
DENSITY = "linear_density_kg_m"
UNIT = "unit"

#: Terms of the base beam: rho M_beam, EI K_beam and the patch moment k_p V(t).
BASE_TERMS: tuple[Term, ...] = (
    Term("mass", "mass_beam", DENSITY),
    Term("stiffness", "stiffness_beam", BENDING_STIFFNESS.name),
    Term("force", "patch_force", PATCH_COUPLING.name),
)

#: What drives the beam: the patch voltage (V), a point force at ``[force] position_m`` (N), or
#: nothing (a free response from an initial state).
INPUT_KINDS: tuple[str | None, ...] = ("voltage", "force", None)

#: The force term of each input kind (None: no force term, the beam is not driven).
INPUT_TERMS: dict[str | None, Term | None] = {
    "voltage": Term("force", "patch_force", PATCH_COUPLING.name),
    "force": Term("force", "point_force", UNIT),
    None: None,
}


def check_input_kind(input_kind: str | None) -> None:
    """Raise BeamInputError unless ``input_kind`` is ``"voltage"``, ``"force"`` or None."""
    if input_kind not in INPUT_KINDS:
        raise BeamInputError(f"input kind must be 'voltage', 'force' or None (a free response), got {input_kind!r}")


def base_parameters(input_kind: str | None = "voltage") -> tuple[ParameterSpec, ...]:
    """Base parameters for an input kind: EI always, the patch coupling k_p for a voltage input."""
    check_input_kind(input_kind)
    return BASE_PARAMETERS if input_kind == "voltage" else BASE_PARAMETERS[:1]
