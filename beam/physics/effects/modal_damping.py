"""``modal_damping``: a damping ratio zeta_j per undamped mode, applied in modal coordinates.

Damping applied in the coordinates of the undamped modes (of the current M and K, sensor mass and
all): mode j gets the ratio zeta_j, so that alone it has the poles
lambda = -zeta_j omega_j ± i omega_j sqrt(1 - zeta_j²). It is a damping *model* that can replace
``air_damping`` + ``kelvin_voigt`` (a free decay often fixes each mode's decay rate better than
any law in omega); with them it adds to their modal damping matrix. Its parameters are a
*per-mode family* (:attr:`~beam.physics.effects.effect.Effect.per_mode`): ``damping_ratio_mode_j``
for j = 1 .. :data:`MAX_DAMPED_MODES`, declared once; a model that retains m modes needs the
first m (:meth:`~beam.physics.effects.effect.Effect.required_parameter_names_for`), and only
mode 1 is marked required (the effect is on when its first ratio is given). A mode without a
given ratio gets no damping from this effect. In the full Galerkin model (the reference) the
same damping is the matrix C = M Phi diag(2 zeta_j omega_j) Phi^T M over the modes with a ratio
(mass-normalised undamped shapes Phi), which leaves every other mode undamped by it.

Not a ranking candidate: it replaces a damping law rather than adding physics.
"""

from __future__ import annotations

from beam.physics.effects.effect import Effect, ParameterSpec, Term

__all__ = ["EFFECT", "MAX_DAMPED_MODES", "MODAL_DAMPING_LOG_SD", "RATIOS", "ratio_mode", "ratio_name"]

#: Most modes the family declares parameters for.
MAX_DAMPED_MODES = 20
#: sigma of log zeta of a ratio's prior centred on a nominal value.
MODAL_DAMPING_LOG_SD = 1.5
_PREFIX = "damping_ratio_mode_"


def ratio_name(mode: int) -> str:
    """The parameter name of the damping ratio of undamped mode ``mode`` (1-based)."""
    return f"{_PREFIX}{int(mode)}"


def ratio_mode(name: str) -> int | None:
    """The (1-based) mode whose damping ratio ``name`` is, or None for any other name."""
    if not name.startswith(_PREFIX):
        return None
    rest = name[len(_PREFIX):]
    return int(rest) if rest.isdigit() else None


RATIOS: tuple[ParameterSpec, ...] = tuple(
    ParameterSpec(ratio_name(j), "1", f"ζ_{j}", f"damping ratio of undamped mode {j}", 1e-5, 0.3, required=j == 1,
                  nominal_log_sd=MODAL_DAMPING_LOG_SD)
    for j in range(1, MAX_DAMPED_MODES + 1)
)

EFFECT = Effect(
    "modal_damping",
    "Modal damping",
    "a damping ratio per undamped mode, applied in modal coordinates: lambda = -zeta omega ± i omega sqrt(1 - zeta²)",
    RATIOS,
    tuple(Term("modal_ratio", "undamped_modes", spec.name, mode=j) for j, spec in enumerate(RATIOS, start=1)),
    per_mode=True,
    missing_effect_candidate=False,
    left_out_of_nominal="a damping ratio per mode sets no frequency",
    catalogue_order=120,
)
