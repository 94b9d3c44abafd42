"""The cantilever model: base beam plus any set of effects, composed at assembly time.

``BeamModel(geometry, effects, input_kind=...)`` assembles the Galerkin parts once. Each effect
declares terms ``parameter * part`` (:class:`beam.physics.effects.Term`); a call forms M = sum rho_i M_i,
C = sum c_i C_i, K = sum k_i K_i and the force from the parameter values, for one or many
parameter sets at once (values given as arrays of shape (B,)).

Inputs (``input_kind``): the patch voltage V(t) (force vector k_p f_patch, the default), a
point force F(t) in N at ``geometry.force_position_m`` (force vector = the basis functions at
that point, no coefficient), or none (a free response from an initial state).
Outputs at the sensor (``output``): ``"displacement"`` (m), ``"velocity"`` (m/s),
``"acceleration"`` (m/s²).

Responses:

* :meth:`BeamModel.response` — the fast path: modal truncation to ``modes`` modes, exact
  damping in the retained subspace (complex modes), exact ZOH stepping on a uniform grid,
  vectorised over parameter sets; the tip cubic spring is integrated in modal coordinates
  (:mod:`beam.physics.nonlinear`, displacement only).
* :meth:`BeamModel.response_at` — the same at irregular recorded times: the input held over
  each recorded interval, each mode stepped exactly with z_k = exp(lambda dt_k).
* :meth:`BeamModel.free_response`, :meth:`BeamModel.free_response_basis` — free responses of
  the retained modes, exact at any times (modal exponentials), and the basis in which the
  unknown initial state enters linearly (for variable projection in a calibration).
* :meth:`BeamModel.response_full`, :meth:`BeamModel.free_response_full` — the reference: the
  full state space (all 2n states) with its C and D for each output, stepped exactly under ZOH
  by :func:`scipy.signal.lsim` (linear models only, uniform time).

Correction for the discarded modes
----------------------------------
Modes j > m answer an input far below their frequency quasi-statically:
eta_j ≈ phi_j^T f u / omega_j² (plus their own ringing after an abrupt input, which the model
drops). Their share of the sensor's displacement is then D u, with
D = sum over discarded j of (c phi_j)(phi_j^T f) / omega_j² = c K⁻¹ f - c Phi_r Omega_r⁻² Phi_r^T f,
so their share of the velocity is D du/dt and of the acceleration D d²u/dt²: the relative
truncation error, |D| against the retained modes' gain, is the same for all three outputs
(measured for 4 modes of the strip at 20 Hz: 0.12-0.13 % for a point force, 0.4 % for the
patch, whose moment pair excites high modes strongly). Option ``static_correction`` adds:

* displacement: D u[k] (the static, "mode-acceleration" correction);
* velocity: D (u[k] - u[k-1]) / (t_k - t_k-1), the held input's slope over the last interval,
  i.e. at t_k - dt/2, where the held (ZOH) staircase stands for the smooth input (the retained
  modes see it delayed by half a step); 0 at t_0;
* acceleration: D times the divided second difference of u over the last two intervals.

They take the truncation error from 0.1-0.4 % to 1e-5 (velocity; acceleration to the hold's own
half-step error, tests/test_physics_inputs_outputs.py). A difference amplifies the noise of a
*measured* input by up to 2/dt (velocity) and 4/dt² (acceleration): for a noisy force signal
switch the correction off (``static_correction=False``) or smooth the input first.

The full model's direct feed-through c M⁻¹ f in the acceleration (its D matrix:
q'' = M⁻¹ (f u - C q' - K q)) is *not* a correction to add. Split as c Phi_r Phi_r^T f (the
retained modes' own feed-through, part of their exact acceleration
eta_r'' = f_r u - C_r eta_r' - Omega_r² eta_r, and included) plus c Phi_d Phi_d^T f (discarded),
the discarded part is cancelled by the discarded modes' quasi-static stiffness force
-c Phi_d Omega_d² eta_d ≈ -c Phi_d Phi_d^T f u: substituting the mode-acceleration displacement
q = Phi_r eta + (K⁻¹ - Phi_r Omega_r⁻² Phi_r^T) f u into c M⁻¹ (f u - K q) leaves c Phi_r eta''
(undamped part), c M⁻¹ f cancels. Under a constant force the acceleration is 0, while adding
c (M⁻¹ - Phi_r Phi_r^T) f u would leave a constant acceleration (0.23 of the peak in the tests).
The discarded feed-through shows in the full model only at each step of a held input (the jump
of the staircase, an artefact of the hold, not physics); the tests compare the acceleration
with the full model driven by the interpolated input.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Iterable, Mapping
import dataclasses
import functools
from dataclasses import dataclass

import numpy as np

from beam.errors import BeamInputError
from beam.physics import modal
from beam.physics.assembly import GalerkinParts, assemble_parts
from beam.physics.basis import (
    DEFAULT_INTERVALS,
    DEFAULT_KNOTS,
    INTERVALS_RANGE,
    KNOT_LAYOUTS,
    KnotLayout,
)
from beam.physics.effects import (
    BASE_TERMS,
    EFFECTS,
    INPUT_TERMS,
    PARAMETER_SPECS,
    ChannelArrays,
    Term,
    base_parameters,
    check_input_kind,
    parse_effects,
)
from beam.physics.effects.base import BENDING_STIFFNESS, DENSITY, UNIT
from beam.physics.geometry import BeamGeometry

_SHAPE_CACHE_SIZE = 256
#: Tridiagonal reductions kept for :meth:`BeamModel._point_mass_modes` (one per rest of the model).
_FACTOR_CACHE_SIZE = 16
#: Rank-one mass parts (a point mass) and the row s of their s sᵀ in :class:`GalerkinParts`.
_POINT_MASS_PARTS = {"mass_sensor": "sensor_values", "mass_tip": "tip_values"}
#: Shared Galerkin parts that damping terms may multiply (their modal projections are cached; an
#: effect's own damping parts join them in its model).
_DAMPING_PARTS = ("mass_beam", "stiffness_beam", "stiffness_patch")
_DENSITY = DENSITY
#: The bending stiffness: every model's parameter, always positive.
_EI = BENDING_STIFFNESS.name
#: Rayleigh–Ritz modes (:meth:`BeamModel._ritz_rows`): smallest batch, largest subspace (fraction
#: of the dofs), trust radius and snapshot step (relative to each coefficient), and the accepted
#: bound on the angle (rad) between a Ritz mode and the exact one.
_RITZ_MIN_ROWS = 8
_RITZ_MAX_SIZE = 0.6
_RITZ_RADIUS = 0.05
_RITZ_STEP = 1e-2
_RITZ_ANGLE = 1e-7
#: Rows this close (relative, every coefficient) to a solved row take its modes to first order
#: (:func:`_stencil_centres`): finite-difference stencils, whose steps are ~1e-8 relative.
_STENCIL_RADIUS = 1e-6
_STENCIL_MAX_ROWS = 2048
#: Pseudo-parameter whose value is 1 (the coefficient of a measured point force).
_UNIT = UNIT

#: Outputs of the sensor and the order of the time derivative of the displacement each is.
OUTPUT_ORDERS: dict[str, int] = {"displacement": 0, "velocity": 1, "acceleration": 2, "strain": 0}
#: Models of other geometries kept by a model with an effect that changes the geometry (one per value seen).
_LENGTH_CACHE_SIZE = 64


def _dispatched(method):
    """Route a public method taking ``parameters`` first: to the model of the given geometry (an
    effect with a :class:`~beam.physics.effects.effect.GeometryChange`, the effective free length),
    and a ``"strain"`` output to the strain twin (:meth:`BeamModel._strain_twin`)."""
    name = method.__name__

    @functools.wraps(method)
    def wrapper(self, parameters, *args, **kwargs):
        if self._geometry_change is not None:
            return self._per_free_length(name, parameters, args, kwargs)
        if kwargs.get("output") == "strain":
            return getattr(self._strain_twin(), name)(parameters, *args, **{**kwargs, "output": "displacement"})
        return method(self, parameters, *args, **kwargs)

    return wrapper


def _merge(pieces: list, groups: list[np.ndarray], batch: int):
    """Batched results of parameter groups put back in the batch's order (arrays on axis 0;
    dicts, tuples and dataclasses of them element by element; anything else from the first)."""
    first = pieces[0]
    if isinstance(first, np.ndarray) and first.ndim >= 1:
        out = np.empty((batch,) + first.shape[1:], dtype=np.result_type(*pieces))
        for piece, rows in zip(pieces, groups):
            out[rows] = piece
        return out
    if isinstance(first, dict):
        return {key: _merge([p[key] for p in pieces], groups, batch) for key in first}
    if isinstance(first, tuple):
        return tuple(_merge(list(parts), groups, batch) for parts in zip(*pieces))
    if dataclasses.is_dataclass(first) and not isinstance(first, type):
        return dataclasses.replace(first, **{f.name: _merge([getattr(p, f.name) for p in pieces], groups, batch)
                                             for f in dataclasses.fields(first) if f.init})
    return first


#: Parameters whose positive value makes the equations nonlinear (the state-space references refuse them).
_NONLINEAR_SWITCHES = tuple(e.channel.switch for e in EFFECTS.values() if e.channel is not None)


def _and_list(names: Iterable[str]) -> str:
    """``"a, b and c"``."""
    names = list(names)
    return names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]


#: The nonlinear effects, for messages ("tip_cubic_spring, quadratic_drag and clamp_friction").
_NONLINEAR_WORDS = _and_list(e for e in EFFECTS if EFFECTS[e].nonlinear)


@dataclass(frozen=True)
class _Layout:
    """Where each term's coefficient comes from, for one set of given parameter names."""

    terms: tuple[Term, ...]
    columns: np.ndarray  # row of the value table for each term
    mass: np.ndarray  # indices into terms, base (rho) first
    stiffness: np.ndarray  # base (EI) first
    damping: np.ndarray
    force: np.ndarray
    damping_map: np.ndarray  # (n_damping_terms, damping parts) 0/1
    scale_matrix: np.ndarray  # (3 + damping parts, rows): rho, EI, force coefficient, damping parts
    key_matrix: np.ndarray  # (mass + stiffness terms, rows): the coefficients that set the mode shapes
    key_denominators: np.ndarray  # row of key_matrix @ table dividing each (rho or EI): the ratios
    channels: tuple  # the nonlinear channels whose parameters are given (catalogue order)
    switch_rows: tuple[int, ...]  # row of each channel's switch in the table
    modal_rows: np.ndarray  # rows of the table holding the given modal damping ratios
    modal_modes: np.ndarray  # their 0-based mode indices


class BeamModel:
    """Euler–Bernoulli cantilever with a piezo patch and optional effects.

    Parameters
    ----------
    geometry : BeamGeometry
        Beam, patch and sensor (m), linear density (kg/m).
    effects : iterable of str or str
        Effect ids from :data:`beam.physics.effects.EFFECTS` (or a comma-separated string).
    intervals : int
        Number N of B-spline elements (knot intervals), default
        :data:`beam.physics.basis.DEFAULT_INTERVALS`.
    knots : {"patch", "uniform"}
        Knot layout (:mod:`beam.physics.basis`): ``"patch"`` (default) puts double knots at the
        patch ends (fourth-order accurate for the stepped beam); ``"uniform"`` is Smith's uniform C² mesh.
    input_kind : {"voltage", "force", None}
        What drives the beam: the patch voltage (needs a patch; parameter
        ``patch_coupling_NmV``), a point force in N at ``geometry.force_position_m``, or nothing
        (free responses only).
    """

    def __init__(
        self, geometry: BeamGeometry, effects: Iterable[str] | str = (), intervals: int = DEFAULT_INTERVALS,
        knots: KnotLayout = DEFAULT_KNOTS, *, input_kind: str | None = "voltage",
    ) -> None:
        if isinstance(intervals, bool) or int(intervals) != intervals or not INTERVALS_RANGE[0] <= intervals <= INTERVALS_RANGE[1]:
            raise BeamInputError(f"intervals must be an integer in [{INTERVALS_RANGE[0]}, {INTERVALS_RANGE[1]}], got {intervals!r}")
        if knots not in KNOT_LAYOUTS:
            raise BeamInputError(f"knots must be one of {', '.join(repr(k) for k in KNOT_LAYOUTS)}, got {knots!r}")
        check_input_kind(input_kind)
        self.geometry = geometry
        self.effects = parse_effects(effects)
        self.intervals = int(intervals)
        self.knots: str = knots
        self.input_kind = input_kind
        if input_kind == "voltage" and not geometry.has_patch:
            raise BeamInputError("a voltage input needs the piezo patch: the sidecar has no [patch]")
        if input_kind == "force" and geometry.force_position_m is None:
            raise BeamInputError("a point-force input needs its position: the sidecar has no [force] position_m")
        for effect_id in self.effects:
            if EFFECTS[effect_id].needs_patch and not geometry.has_patch:
                raise BeamInputError(f"effect {effect_id} acts on the piezo patch, but the sidecar has no [patch]")
        frees_root = any(EFFECTS[e].frees_root_rotation for e in self.effects)
        double_knots = sorted({float(x) for e in self.effects if EFFECTS[e].knots is not None
                               for x in EFFECTS[e].knots(geometry)})
        self.parts: GalerkinParts = assemble_parts(geometry, self.intervals, frees_root, knots, double_knots)
        #: The effects' own Galerkin parts (:class:`~beam.physics.effects.effect.Part`), by name.
        self.own_parts: dict[str, np.ndarray] = {
            part.name: np.asarray(part.assemble(self.parts.basis, geometry), dtype=float)
            for e in self.effects for part in EFFECTS[e].parts}
        #: Parts that damping terms multiply (their modal projections are cached): the shared ones, then the effects' own.
        self._damping_parts: tuple[str, ...] = _DAMPING_PARTS + tuple(dict.fromkeys(
            t.part for e in self.effects for t in EFFECTS[e].terms if t.target == "damping" and t.part in self.own_parts))
        input_term = INPUT_TERMS[input_kind]
        self._base_terms: tuple[Term, ...] = BASE_TERMS[:2] + ((input_term,) if input_term is not None else ())
        self._input_vector = getattr(self.parts, input_term.part) if input_term is not None else np.zeros(self.size)
        self._shape_cache: OrderedDict[bytes, tuple[np.ndarray, ...]] = OrderedDict()
        self._point_mass_factors: OrderedDict[bytes, modal.RankOneFactorisation | None] = OrderedDict()
        self._point_mass_plans: dict[tuple[Term, ...], tuple[int, np.ndarray] | None | bool] = {}
        self._layouts: dict[tuple[str, ...], _Layout] = {}
        self._ritz_bases: dict[tuple[tuple[Term, ...], int], modal.RitzBasis] = {}
        self._accepted = frozenset(self.accepted_parameter_names)
        self._required = frozenset(self._names_for(None, per_mode_first=True))
        #: Output row of the sensor: its displacement, or for the strain twin -(h/2) w''(x_obs).
        self._sensor_row: np.ndarray = self.parts.sensor_values
        self._twin: BeamModel | None = None
        self._geometry_change = next((EFFECTS[e].geometry for e in self.effects if EFFECTS[e].geometry is not None), None)
        self._length_models: OrderedDict[float, BeamModel] = OrderedDict()

    # ------------------------------------------------------------------ strain, free length
    def _strain_twin(self) -> "BeamModel":
        """This model with the sensor's output row -(h/2) phi''(x_obs): its displacement output is
        the strain of a gauge on the strip's surface at the sensor (dimensionless).

        Everything that reads the output row (the retained modes' gains, the discarded modes'
        static correction c K⁻¹ f - c Phi_r Omega_r⁻² Phi_r^T f, the full state space) then
        gives the strain: the correction is the curvature of the static residual. Mode shapes
        do not depend on the output, so the twin shares the parts; it keeps its own caches.
        """
        if self._twin is None:
            thickness = self.geometry.thickness_m
            if thickness is None:
                raise BeamInputError("a strain output needs the strip's thickness: [beam] thickness_m in the sidecar")
            twin = object.__new__(BeamModel)
            twin.__dict__.update(self.__dict__)
            twin._sensor_row = -0.5 * thickness * self.parts.sensor_curvatures
            twin._shape_cache, twin._point_mass_factors = OrderedDict(), OrderedDict()
            twin._point_mass_plans, twin._layouts, twin._ritz_bases = {}, {}, {}
            twin._twin = twin
            self._twin = twin
        return self._twin

    def _part(self, name: str) -> np.ndarray:
        """The unit-coefficient part ``name``: a shared one (:class:`GalerkinParts`) or an effect's own."""
        own = self.own_parts.get(name)
        return getattr(self.parts, name) if own is None else own

    def free_length_model(self, length_m: float) -> "BeamModel":
        """The model (without the effect that changes the geometry, ``effective_length``) of this
        strip with the free length ``length_m`` (m):
        :meth:`beam.physics.geometry.BeamGeometry.with_free_length` (the sensor and force point keep
        their distance from the end they are nearer, the patch from the tip), the same mesh,
        knots, input and other effects. Cached per length."""
        key = float(length_m)
        model = self._length_models.get(key)
        if model is None:
            effects = tuple(e for e in self.effects if EFFECTS[e].geometry is None)
            model = BeamModel(self._geometry_change.apply(self.geometry, key), effects, self.intervals, self.knots,
                              input_kind=self.input_kind)
            self._length_models[key] = model
            if len(self._length_models) > _LENGTH_CACHE_SIZE:
                self._length_models.popitem(last=False)
        else:
            self._length_models.move_to_end(key)
        return model

    def _per_free_length(self, name: str, parameters: Mapping[str, float | np.ndarray], args: tuple, kwargs: dict):
        """Call ``name`` on the model of each free length given (batched: one call per distinct
        length, the results put back in order; arrays of ndim >= 2 among the other arguments
        whose first axis is the batch, e.g. initial states, are split with the parameters)."""
        free_length = self._geometry_change.parameter
        if free_length not in parameters:
            raise BeamInputError(f"missing value for parameter {free_length!r}")
        rest = {key: value for key, value in parameters.items() if key != free_length}
        lengths = np.asarray(parameters[free_length], dtype=float)
        if lengths.ndim > 1 or not np.isfinite(lengths).all() or (lengths <= 0).any():
            raise BeamInputError(f"parameter {free_length!r} must be positive and finite (scalar or 1-d), got {lengths}")
        if lengths.ndim == 0:
            out = getattr(self.free_length_model(float(lengths)), name)(rest, *args, **kwargs)
            if name == "reduced_system":
                out[1][free_length] = lengths.reshape(1)
            return out
        batch = lengths.size
        try:
            rest = {key: np.broadcast_to(np.asarray(value, dtype=float), (batch,)) for key, value in rest.items()}
        except ValueError:
            raise BeamInputError("parameter arrays must all have the same length") from None
        unique, inverse = np.unique(lengths, return_inverse=True)
        groups = [np.flatnonzero(inverse == i) for i in range(unique.size)]

        def part(value, rows):
            if isinstance(value, np.ndarray) and value.ndim >= 2 and value.shape[0] == batch:
                return value[rows]
            return value

        pieces = [
            getattr(self.free_length_model(float(length)), name)(
                {key: value[rows] for key, value in rest.items()}, *(part(a, rows) for a in args),
                **{key: part(value, rows) for key, value in kwargs.items()})
            for length, rows in zip(unique, groups)
        ]
        out = pieces[0] if len(pieces) == 1 else _merge(pieces, groups, batch)
        if name == "reduced_system":  # (reduced, values by name, batched): the length is a value too
            out[1][free_length] = lengths
        return out

    # ------------------------------------------------------------------ parameters
    @property
    def parameter_names(self) -> tuple[str, ...]:
        """Required parameters of the base model and its effects, base first.

        A model with a per-mode effect (``modal_damping``) has one parameter per retained mode:
        use :meth:`parameter_names_for`; here it raises BeamInputError.
        """
        return self._names_for(None)

    def parameter_names_for(self, modes: int | None) -> tuple[str, ...]:
        """Parameters to calibrate when ``modes`` modes are retained, base first.

        The same as :attr:`parameter_names` except that a per-mode effect contributes its
        first ``modes`` parameters (``damping_ratio_mode_1`` .. ``damping_ratio_mode_<modes>``).
        """
        return self._names_for(modes)

    def _names_for(self, modes: int | None, per_mode_first: bool = False) -> tuple[str, ...]:
        names = [p.name for p in base_parameters(self.input_kind)]
        for effect_id in self.effects:
            effect = EFFECTS[effect_id]
            if per_mode_first and effect.per_mode:
                names.extend(effect.required_parameter_names)  # what any call must give
            else:
                names.extend(effect.required_parameter_names_for(modes))
        return tuple(names)

    @property
    def accepted_parameter_names(self) -> tuple[str, ...]:
        """Required plus optional parameters this model understands."""
        names = [p.name for p in base_parameters(self.input_kind)]
        for effect_id in self.effects:
            names.extend(EFFECTS[effect_id].parameter_names)
        return tuple(names)

    @property
    def is_nonlinear(self) -> bool:
        return any(EFFECTS[e].nonlinear for e in self.effects)

    @property
    def size(self) -> int:
        """Number of Galerkin degrees of freedom n (the full state space has 2n states)."""
        return self.parts.size

    def _table(self, parameters: Mapping[str, float | np.ndarray]) -> tuple[tuple[str, ...], np.ndarray, bool]:
        """Validate values; returns (names, table (len(names) + 2, B) with rho then 1 last, batched)."""
        if tuple(parameters) in self._layouts:  # these names were checked before
            pass
        elif not parameters.keys() <= self._accepted:
            unknown = sorted(set(parameters) - self._accepted)[0]
            raise BeamInputError(
                f"parameter {unknown!r} is not part of this model (effects: {', '.join(self.effects) or 'none'}); "
                f"expected {', '.join(self.accepted_parameter_names)}"
            )
        elif not self._required <= parameters.keys():
            missing = [name for name in self._names_for(None, per_mode_first=True) if name not in parameters][0]
            raise BeamInputError(f"missing value for parameter {missing!r}")
        names = tuple(parameters)
        values = list(parameters.values())
        if all(isinstance(v, float) for v in values):  # one parameter set of plain floats: fast path
            if all(0.0 <= v < math.inf for v in values) and parameters[_EI] > 0:
                values.append(self.geometry.linear_density_kg_m)
                values.append(1.0)
                return names, np.array(values)[:, None], False
            table = np.array(values)
        else:
            try:
                table = np.array(np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in values)), ndmin=2)
            except ValueError:
                raise BeamInputError("parameter arrays must all have the same length") from None
        batched = any(np.ndim(v) > 0 for v in values)
        if table.ndim > 2:
            raise BeamInputError("parameter values must be scalars or 1-d arrays")
        table = table.reshape(len(names), -1)
        if not np.isfinite(table).all() or (table < 0).any() or (table[names.index(_EI)] <= 0).any():
            for name, row in zip(names, table):
                if not np.isfinite(row).all():
                    raise BeamInputError(f"parameter {name!r} must be finite, got {row}")
                if (row < 0).any() or (name == _EI and (row <= 0).any()):
                    raise BeamInputError(f"parameter {name!r} must be positive, got {row}")
        density = np.full((1, table.shape[1]), self.geometry.linear_density_kg_m)
        return names, np.concatenate([table, density, np.ones((1, table.shape[1]))]), batched

    def _layout(self, names: tuple[str, ...]) -> _Layout:
        """The terms present for these given names, and where their coefficients sit (cached)."""
        layout = self._layouts.get(names)
        if layout is None:
            rows = {name: i for i, name in enumerate(names + (_DENSITY, _UNIT))}
            candidates = list(self._base_terms) + [t for e in self.effects for t in EFFECTS[e].terms]
            terms = tuple(
                t for t in candidates if t.parameter in rows or PARAMETER_SPECS[t.parameter].required
            )

            def where(target: str) -> np.ndarray:
                return np.array([i for i, t in enumerate(terms) if t.target == target], dtype=int)

            damping = where("damping")
            damping_map = np.zeros((damping.size, len(self._damping_parts)))
            for row, index in enumerate(damping):
                damping_map[row, self._damping_parts.index(terms[index].part)] = 1.0
            columns = np.array([rows[t.parameter] for t in terms])
            mass, stiffness, force = where("mass"), where("stiffness"), where("force")
            select = np.zeros((len(terms), len(rows)))  # coefficient of each term from the table
            select[np.arange(len(terms)), columns] = 1.0
            scale_matrix = np.concatenate([select[mass[:1]], select[stiffness[:1]], select[force].sum(axis=0, keepdims=True),
                                           damping_map.T @ select[damping]])
            key_matrix = select[np.concatenate([mass, stiffness])]
            key_denominators = np.repeat([0, mass.size], [mass.size, stiffness.size])
            channels = tuple(EFFECTS[e].channel for e in self.effects
                             if EFFECTS[e].channel is not None and EFFECTS[e].channel.switch in rows)
            switch_rows = tuple(rows[c.switch] for c in channels)
            modal = where("modal_ratio")
            modal_rows = np.array([rows[terms[i].parameter] for i in modal], dtype=int)
            modal_modes = np.array([terms[i].mode - 1 for i in modal], dtype=int)
            layout = _Layout(terms, columns, mass, stiffness, damping, force, damping_map, scale_matrix, key_matrix,
                             key_denominators, channels, switch_rows, modal_rows, modal_modes)
            self._layouts[names] = layout
        return layout

    def _coefficients(self, parameters: Mapping[str, float | np.ndarray]) -> tuple[_Layout, np.ndarray, dict, bool]:
        """(layout, coefficient table (T, B), values by name (B,), batched)."""
        names, table, batched = self._table(parameters)
        layout = self._layout(names)
        values = dict(zip(names, table))
        return layout, table[layout.columns], values, batched

    def _modal_ratios(self, layout: _Layout, table: np.ndarray, n_modes: int) -> np.ndarray | None:
        """Modal damping ratios (B, n_modes) of the retained modes (0 where none is given), or None."""
        if layout.modal_rows.size == 0:
            return None
        ratios = np.zeros((table.shape[1], n_modes))
        for row, mode in zip(layout.modal_rows, layout.modal_modes):
            if mode < n_modes:
                ratios[:, mode] = table[row]
        return ratios

    def _combine(self, layout: _Layout, coef: np.ndarray, target: str) -> np.ndarray:
        first = self.parts.patch_force if target == "force" else self.parts.mass_beam
        total = np.zeros((coef.shape[1],) + first.shape)
        for term, c in zip(layout.terms, coef):
            if term.target == target:
                part = self._part(term.part)
                total += c.reshape((-1,) + (1,) * part.ndim) * part
        return total

    @_dispatched
    def system_matrices(self, parameters: Mapping[str, float | np.ndarray]) -> dict[str, np.ndarray]:
        """M, C, K (B, n, n) and the force per unit input f (B, n) of the Galerkin model.

        M q'' + C q' + K q = f u(t) (- k3 (tip @ q)³ tip with the tip cubic spring), u the voltage
        (f = k_p f_patch, N m/V), the point force (f = phi(x_f), per N) or nothing (f = 0).
        Modal damping enters C as M Phi diag(2 zeta_j omega_j) Phi^T M over the undamped modes j
        with a ratio (mass-normalised shapes of this M and K).
        """
        names, table, _ = self._table(parameters)
        layout = self._layout(names)
        coef = table[layout.columns]
        matrices = {target: self._combine(layout, coef, target) for target in ("mass", "damping", "stiffness", "force")}
        if layout.modal_rows.size:
            mass, stiffness = matrices["mass"], matrices["stiffness"]
            omega2, shapes = modal.undamped_modes(mass, stiffness, shift=self.parts.basis.free_root_rotation)
            count = min(self.size, int(layout.modal_modes.max()) + 1)
            ratios = self._modal_ratios(layout, table, count)
            gains = 2.0 * ratios * np.sqrt(np.clip(omega2[:, :count], 0.0, None))  # (B, count)
            mass_shapes = mass @ shapes[:, :, :count]  # M Phi
            matrices["damping"] = matrices["damping"] + (mass_shapes * gains[:, None, :]) @ np.swapaxes(mass_shapes, 1, 2)
        return matrices

    # ------------------------------------------------------------------ modes
    def _unit_modes(self, layout: _Layout, table: np.ndarray, n_modes: int) -> tuple[np.ndarray, tuple[np.ndarray, ...]]:
        """Cached unit-scale modes for each parameter set: ``(which (B,), unit_modes)``.

        Mode shapes depend only on the ratios of the mass coefficients and of the stiffness
        coefficients, so they are solved once per distinct ratio (scaled to rho = EI = 1) and
        cached with their projections; :func:`beam.physics.modal.scale_unit_modes` rescales them.
        ``unit_modes`` stacks the U distinct solutions (see there); set b uses ``which[b]``.
        ``table`` is the value table of :meth:`_table` (rows: given names, then rho).
        """
        batch = table.shape[1]
        if layout.key_denominators.size == 2:  # rho and EI alone: one shape for every set
            key_bytes = [bytes([n_modes])]
            keys = np.ones((1, 2))
        else:
            coefficients = layout.key_matrix @ table
            keys = (coefficients / coefficients[layout.key_denominators]).T
            key_bytes = [keys.tobytes() + bytes([n_modes])] if batch == 1 else [row.tobytes() + bytes([n_modes]) for row in keys]
        first = key_bytes[0]
        if batch == 1 or all(k == first for k in key_bytes):  # one shape for every set
            entry = self._shape_cache.get(first)
            if entry is None:
                entry = self._solve_shapes(keys[:1], [first], layout, n_modes)[first]
            return np.zeros(batch, dtype=np.int64), entry
        index: dict[bytes, int] = {}
        which = np.array([index.setdefault(k, len(index)) for k in key_bytes], dtype=np.int64)
        rows = keys[[key_bytes.index(k) for k in index]]
        missing = [k for k in index if k not in self._shape_cache]
        if missing:
            ritz = self._ritz_entries(rows, layout, n_modes)
            if ritz is not None:  # every distinct row from one Rayleigh–Ritz subspace (not cached)
                return which, ritz
        found = {k: self._shape_cache[k] for k in index if k not in missing}
        if missing:  # solved now; a batch larger than the cache reads them from here, not the cache
            found.update(self._solve_shapes(rows[[index[k] for k in missing]], missing, layout, n_modes))
        entries = [found[k] for k in index]
        return which, tuple(np.concatenate(parts) for parts in zip(*entries))

    def _reduced_modes(self, layout: _Layout, table: np.ndarray, n_modes: int) -> dict[str, np.ndarray]:
        """Retained undamped modes and the projections the response needs, batched over B.

        Returns omega2 (B, m), damping (B, m, m), force (B, m), sensor (B, m), tip (B, m),
        static (B, 2) (see :func:`beam.physics.modal.scale_unit_modes`).
        """
        which, unit_modes = self._unit_modes(layout, table, n_modes)
        scaled = modal.scale_unit_modes(which, unit_modes, layout.scale_matrix @ table,
                                        self._modal_ratios(layout, table, n_modes))
        return dict(zip(("omega2", "damping", "force", "sensor", "tip", "static"), scaled))

    def _matrices_of_rows(self, rows: np.ndarray, layout: _Layout) -> tuple[np.ndarray, np.ndarray]:
        """Mass and stiffness matrices (U, n, n) of normalised coefficient rows (U, mass + stiffness terms)."""
        n_mass = layout.mass.size
        mass = sum(rows[:, j, None, None] * self._part(layout.terms[i].part) for j, i in enumerate(layout.mass))
        stiff = sum(
            rows[:, n_mass + j, None, None] * self._part(layout.terms[i].part)
            for j, i in enumerate(layout.stiffness)
        )
        return mass, stiff

    def _point_mass_modes(self, rows: np.ndarray, layout: _Layout, n_modes: int) -> tuple[np.ndarray, np.ndarray] | None:
        """Undamped modes of coefficient rows that differ only in one point mass, or None.

        When the layout has exactly one rank-one mass part (the sensor's or the tip's point
        mass, s sᵀ) and otherwise only the beam's own mass and stiffness (whose coefficients
        are 1 in every normalised row), the eigenproblems of all rows are
        one tridiagonal matrix with one alpha-dependent entry
        (:func:`beam.physics.modal.rank_one_factorisation`, cached per rest of the model):
        the modes of each row cost a tridiagonal solve (:func:`beam.physics.modal.rank_one_modes`).
        Only for a model without input (a free response), whose static correction of the
        discarded modes is zero: only the retained modes are solved (measured on the 41-dof
        strip, 4 modes: ~20-45 µs per row against 120-200 µs dense; all 41 modes, which a driven
        model's static correction needs, would cost more than the dense path). A model whose
        root rotation is free (a shifted solve), with two point masses or the patch's added mass
        or stiffness takes the dense path (None). The rows of one layout always take the same
        path, so a batch and its single rows agree to round-off.
        """
        if self.parts.basis.free_root_rotation or np.any(self._input_vector):
            return None
        plan = self._point_mass_plans.get(layout.terms, False)
        if plan is False:
            plan = None
            rank_one = [j for j, i in enumerate(layout.mass) if layout.terms[i].part in _POINT_MASS_PARTS]
            rest = [layout.terms[i] for i in np.concatenate([layout.mass, layout.stiffness])
                    if layout.terms[i].part not in _POINT_MASS_PARTS]
            if len(rank_one) == 1 and all(t.parameter in (_DENSITY, _EI) for t in rest):
                j = rank_one[0]
                plan = (j, getattr(self.parts, _POINT_MASS_PARTS[layout.terms[layout.mass[j]].part]))
            self._point_mass_plans[layout.terms] = plan
        if plan is None:
            return None
        j, vector = plan
        others = np.delete(rows, j, axis=1)
        if not np.all(others == others[:1]):
            return None
        key = others[0].tobytes() + bytes([j])
        factors = self._point_mass_factors.get(key)
        if factors is None:
            base = rows[:1].copy()
            base[0, j] = 0.0
            mass, stiff = self._matrices_of_rows(base, layout)
            try:
                factors = modal.rank_one_factorisation(mass[0], stiff[0], vector)
            except np.linalg.LinAlgError:  # K not positive definite: the dense path shifts it
                factors = None
            self._point_mass_factors[key] = factors
            if len(self._point_mass_factors) > _FACTOR_CACHE_SIZE:
                self._point_mass_factors.popitem(last=False)
        if factors is None:
            return None
        try:
            return modal.rank_one_modes(factors, rows[:, j], n_modes)
        except np.linalg.LinAlgError:  # MRRR did not settle (never seen): the dense path decides
            return None

    def _solve_shapes(self, rows: np.ndarray, keys: list[bytes], layout: _Layout, n_modes: int) -> dict[bytes, tuple]:
        """Solve the undamped eigenproblem for normalised coefficient rows; cache and return the entries.

        Each entry is a tuple of arrays with a leading axis of length 1 (see :func:`beam.physics.modal.scale_unit_modes`).
        Rows of a finite-difference stencil take the first-order perturbation of their centre
        (:func:`_stencil_centres`; within ~1e-10 of the dense solve, tests/test_physics_ritz.py),
        the others the dense solve. (Whole batches of nearby rows may instead take Rayleigh–Ritz
        modes, :meth:`_ritz_entries`, which are not cached.)
        """
        try:
            with np.errstate(over="raise", invalid="raise"):
                omega2, kept, residual_static = self._modes_and_static(rows, layout, n_modes)
        except (np.linalg.LinAlgError, FloatingPointError, OverflowError) as exc:
            raise BeamInputError(f"the beam's mass and stiffness matrices cannot be solved ({exc}); check the geometry and values") from None
        stacked = self._entry_parts(omega2, kept, residual_static)
        entries = {}
        for i, key in enumerate(keys):
            entries[key] = tuple(
                np.ascontiguousarray(part[i : i + 1], dtype=float)
                for part in stacked
            )
            self._shape_cache[key] = entries[key]
            if len(self._shape_cache) > _SHAPE_CACHE_SIZE:
                self._shape_cache.popitem(last=False)
        return entries

    def _entry_parts(self, omega2: np.ndarray, kept: np.ndarray, static: np.ndarray) -> tuple[np.ndarray, ...]:
        """The cached parts (see :func:`beam.physics.modal.scale_unit_modes`) of U solved rows:
        omega², damping projections, force, sensor and tip rows, static gains; shapes signed
        with a positive tip displacement."""
        kept = kept * _shape_signs(self.parts.tip_values @ kept)[:, None, :]
        kept_t = np.swapaxes(kept, 1, 2)
        projections = np.stack([kept_t @ self._part(name) @ kept for name in self._damping_parts], axis=1)
        force = kept.transpose(0, 2, 1) @ self._input_vector
        sensor = self._sensor_row @ kept
        tip = self.parts.tip_values @ kept
        return tuple(np.ascontiguousarray(part, dtype=float) for part in (omega2, projections, force, sensor, tip, static))

    def _ritz_entries(self, rows: np.ndarray, layout: _Layout, n_modes: int) -> tuple[np.ndarray, ...] | None:
        """Stacked entry parts of every distinct row of a batch from :meth:`_ritz_rows`, or None
        (then every row takes the dense path: a batch never mixes the two, whose values differ
        by ~1e-9, enough to spoil the difference quotients of a Hessian)."""
        try:
            with np.errstate(over="raise", invalid="raise"):
                solved = self._ritz_rows(rows, layout, n_modes)
        except (np.linalg.LinAlgError, FloatingPointError, OverflowError):  # the dense path decides
            return None
        return None if solved is None else self._entry_parts(*solved)

    def _modes_and_static(self, rows: np.ndarray, layout: _Layout, n_modes: int) -> tuple[np.ndarray, ...]:
        """Retained omega² (U, m), shapes (U, n, m) and the discarded modes' static gains (U, 4) of normalised rows.

        The static gains are, for unit rho and EI, sum over the discarded modes of
        (o.phi)(phi.f)/omega² for the outputs o = sensor, tip and the input f (first two) and a unit
        tip force (last two), summed over the discarded modes (accurate when K is nearly singular).
        """
        count = rows.shape[0]
        omega2 = np.empty((count, n_modes))
        kept = np.empty((count, self.size, n_modes))
        static = np.empty((count, 4))
        todo = np.ones(count, dtype=bool)
        sub = rows[todo]
        solved = self._point_mass_modes(sub, layout, n_modes)
        if solved is not None:  # only the retained modes (a free model: no static gains)
            values, shapes = solved
            omega2[todo], kept[todo] = values[:, :n_modes], shapes[:, :, :n_modes]
            static[todo] = self._dropped_static(values, shapes, n_modes)
            return omega2, kept, static
        if self.parts.basis.free_root_rotation:  # K nearly singular: its inverse from the modes is not used
            centre, owner = np.ones(sub.shape[0], dtype=bool), np.arange(sub.shape[0])
        else:
            centre, owner = _stencil_centres(sub)
        mass, stiff = self._matrices_of_rows(sub[centre], layout)
        values, shapes = modal.undamped_modes(mass, stiff, shift=self.parts.basis.free_root_rotation)
        where = np.flatnonzero(todo)
        omega2[where[centre]], kept[where[centre]] = values[:, :n_modes], shapes[:, :, :n_modes]
        static[where[centre]] = self._dropped_static(values, shapes, n_modes)
        if not centre.all():
            satellites = np.flatnonzero(~centre)
            position = np.cumsum(centre) - 1  # a centre's index among the centres
            for c in np.unique(owner[satellites]):
                mine = satellites[owner[satellites] == c]
                k = position[c]
                d_mass, d_stiff = self._matrices_of_rows(sub[mine] - sub[c], layout)
                o2, sh = modal.perturbed_modes(values[k], shapes[k], d_mass, d_stiff, n_modes)
                omega2[where[mine]], kept[where[mine]] = o2, sh
                static[where[mine]] = static[where[c]] + self._static_change(values[k], shapes[k], d_stiff, o2, sh, n_modes)
        return omega2, kept, static

    def _dropped_static(self, values: np.ndarray, shapes: np.ndarray, n_modes: int) -> np.ndarray:
        """Static gains (U, 4) summed over the discarded modes (see :meth:`_modes_and_static`)."""
        # static (mode-acceleration) correction: the quasi-static response of the discarded
        # modes, sum over them of (c.phi)(phi.f)/omega² (= c K⁻¹ f minus the retained part),
        # for unit rho and EI; summed directly, which stays accurate when K is nearly singular
        dropped = shapes[:, :, n_modes:]
        outputs = np.stack([self._sensor_row, self.parts.tip_values])  # (2, n)
        per_mode = (outputs @ dropped) * ((self._input_vector @ dropped) / values[:, n_modes:])[:, None, :]
        # … and the same for a unit force at the tip (the cubic spring's): its quasi-static share
        # at the sensor and at the tip, m/N at unit EI
        per_mode_tip = (outputs @ dropped) * ((self.parts.tip_values @ dropped) / values[:, n_modes:])[:, None, :]
        return np.concatenate([per_mode.sum(axis=2), per_mode_tip.sum(axis=2)], axis=1)

    def _static_change(self, values: np.ndarray, shapes: np.ndarray, d_stiff: np.ndarray, omega2: np.ndarray,
                       kept: np.ndarray, n_modes: int) -> np.ndarray:
        """First-order change (S, 4) of the static gains of one centre (all its modes ``values``,
        ``shapes``) under stiffness changes ``d_stiff`` (S, n, n), whose retained modes are
        ``omega2``, ``kept`` (from :func:`beam.physics.modal.perturbed_modes`).

        The gain o K⁻¹ l minus the retained share sum_i (o.phi_i)(l.phi_i)/omega_i²: the first
        changes by -(K⁻¹ o)ᵀ dK (K⁻¹ l) (K⁻¹ from all the centre's modes), the second by the
        change of each term. (A mass change moves only the retained share.) The two changes
        nearly cancel (the static gain is 0.1-0.4 % of the total): measured on lab_run_1's
        model, the derivative so formed is within 1.2e-3 of the exact one (K⁻¹ by refined
        solves), against 1e-4 for a forward difference of dense solves, i.e. < 5e-6 of the
        response's Jacobian (tests/test_physics_ritz.py).
        """
        outputs = np.stack([self._sensor_row, self.parts.tip_values])  # (2, n)
        loads = np.stack([self._input_vector, self.parts.tip_values])  # (2, n)
        inverse = (shapes / values[None, :]) @ shapes.T  # K⁻¹ of the centre
        full = -np.einsum("on,snk,lk->sol", outputs @ inverse, d_stiff, loads @ inverse)  # (S, outputs, loads)
        lam, phi = values[:n_modes], shapes[:, :n_modes]
        before = np.einsum("om,lm->ol", (outputs @ phi) / lam, loads @ phi)
        after = np.einsum("som,slm->sol", (outputs @ kept) / omega2[:, None, :], loads @ kept)
        change = full - (after - before[None])
        return np.concatenate([change[:, :, 0], change[:, :, 1]], axis=1)

    def _ritz_rows(self, rows: np.ndarray, layout: _Layout, n_modes: int) -> tuple[np.ndarray, ...] | None:
        """Modes of all the rows from a Rayleigh–Ritz subspace whose error bound passes for each, or None.

        For a batch of at least :data:`_RITZ_MIN_ROWS` distinct rows of a driven model with a
        clamped root whose shapes vary (e.g. the walkers of a posterior with the patch's added
        density and stiffness): a subspace of :func:`beam.physics.modal.ritz_basis` is built at
        the rows' median when this layout's does not cover them all (each coefficient within
        :data:`_RITZ_RADIUS`, relative, of its anchor) and the median does, from the anchor's
        modes and one snapshot per varying coefficient; it is kept for the next batches. The
        batch is accepted when the bound of :func:`beam.physics.modal.ritz_modes` on the angle
        to the exact modes is at most :data:`_RITZ_ANGLE` for every row; the static gains are
        o K⁻¹ l (K⁻¹ l by :func:`beam.physics.modal.ritz_static`) minus the retained modes' share.
        Returns (omega² (U, m), shapes (U, n, m), static gains (U, 4)).

        Measured on lab_run_1 (7 modes, 43 dofs, r = 20): 52 µs per row against ~160-190 µs
        dense; the static gains so formed differ from the dense sums by up to 4e-6 of themselves
        (0.1-0.4 % of the response, so ~1e-8 of it; on three rows both were within 4e-8 of an
        iteratively refined solve).
        """
        count = rows.shape[0]
        if count < _RITZ_MIN_ROWS or self.parts.basis.free_root_rotation or not np.any(self._input_vector):
            return None
        varying = np.flatnonzero(np.ptp(rows, axis=0) > 0)
        if varying.size == 0 or n_modes + 2 + varying.size * n_modes > _RITZ_MAX_SIZE * self.size:
            return None
        cache_key = (layout.terms, n_modes)
        basis = self._ritz_bases.get(cache_key)

        def near(anchor: np.ndarray) -> np.ndarray:
            scale = np.where(anchor > 0, anchor, 1.0)
            return np.all(np.abs(rows - anchor) <= _RITZ_RADIUS * scale, axis=1) & np.all((anchor > 0) | (rows == 0), axis=1)

        if basis is None or not near(basis.anchor).all():
            center = np.median(rows, axis=0)
            if not near(center).all() or np.any(center[varying] <= 0):
                return None
            steps = np.zeros((varying.size, rows.shape[1]))
            steps[np.arange(varying.size), varying] = _RITZ_STEP * center[varying]
            parts = [self._part(layout.terms[i].part) for i in np.concatenate([layout.mass, layout.stiffness])]
            n_mass = layout.mass.size
            basis = modal.ritz_basis(np.stack(parts[:n_mass]), np.stack(parts[n_mass:]), center, steps, n_modes)
            self._ritz_bases[cache_key] = basis
        omega2, shapes, angle = modal.ritz_modes(basis, rows, n_modes)
        if np.any(angle > _RITZ_ANGLE):
            return None
        loads = np.stack([self._input_vector, self.parts.tip_values], axis=1)  # (n, 2)
        outputs = np.stack([self._sensor_row, self.parts.tip_values])  # (2, n)
        solved = modal.ritz_static(basis, rows, loads)
        if solved is None:  # (not seen within the trust radius) a dense solve
            _, stiff = self._matrices_of_rows(rows, layout)
            solved = np.linalg.solve(stiff, np.broadcast_to(loads, (shapes.shape[0],) + loads.shape))
        full = outputs @ solved  # (A, 2, 2)
        seen = outputs @ shapes  # (A, 2, m)
        retained = np.einsum("aom,alm->aol", seen, (loads.T @ shapes) / omega2[:, None, :])  # (A, 2 outputs, 2 loads)
        static = np.concatenate([full[:, :, 0] - retained[:, :, 0], full[:, :, 1] - retained[:, :, 1]], axis=1)
        return omega2, shapes, static

    @_dispatched
    def natural_modes(self, parameters: Mapping[str, float], count: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Natural frequencies |lambda|/2pi (Hz) and damping ratios -Re(lambda)/|lambda| of the full model.

        From the eigenvalues lambda of the full first-order system, one per conjugate pair,
        lowest first. A rigid-body mode (free root, k_theta = 0) has frequency 0 and ratio 0.
        """
        matrices = self.system_matrices(parameters)
        if matrices["mass"].shape[0] != 1:
            raise BeamInputError("natural_modes takes one parameter set")
        n = self.size
        count = n if count is None else count
        if isinstance(count, bool) or int(count) != count or not 1 <= count <= n:
            raise BeamInputError(f"count must be between 1 and {n} (the number of Galerkin modes), got {count}")
        poles = _first_order_poles(matrices["mass"][0], matrices["damping"][0], matrices["stiffness"][0])
        frequencies, ratios = _frequencies_and_ratios(poles)
        return frequencies[: int(count)], ratios[: int(count)]

    # ------------------------------------------------------------------ responses
    def _input_name(self) -> str:
        return {"voltage": "voltage_V", "force": "force_N"}.get(self.input_kind, "input")

    def _check_record(self, voltage_V: np.ndarray, sample_interval_s: float) -> np.ndarray:
        name = self._input_name()
        voltage = np.asarray(voltage_V, dtype=float)
        if voltage.ndim != 1 or voltage.size < 2:
            raise BeamInputError(f"{name} must be a 1-d array of at least two samples")
        if not np.all(np.isfinite(voltage)):
            raise BeamInputError(f"{name} holds NaN or infinite values")
        if not (np.isfinite(sample_interval_s) and sample_interval_s > 0):
            raise BeamInputError(f"sample_interval_s must be positive, got {sample_interval_s}")
        return voltage

    def _check_modes(self, modes: int | None) -> int:
        n_modes = self.size if modes is None else modes
        if isinstance(n_modes, bool) or int(n_modes) != n_modes or not 1 <= n_modes <= self.size:
            raise BeamInputError(
                f"modes must be between 1 and {self.size} (the mesh of {self.intervals} intervals, knots "
                f"{self.knots!r}, holds {self.size} modes), got {modes}"
            )
        return int(n_modes)

    @staticmethod
    def _channels_on(layout: _Layout, table: np.ndarray) -> list:
        """The nonlinear channels of ``layout`` that some set of ``table`` switches on (their switch
        positive, or given for a channel on whenever given: the clamp friction, whatever its slip moment)."""
        return [c for c, row in zip(layout.channels, layout.switch_rows) if c.on_when_given or bool(np.any(table[row] > 0))]

    def _is_nonlinear_at(self, layout: _Layout, table: np.ndarray) -> bool:
        """Whether any set of ``table`` switches a nonlinear channel on."""
        return bool(self._channels_on(layout, table))

    @staticmethod
    def _own_integration(on: list):
        """The channel that is alone on and has its own driven integration (the tip spring's), or None."""
        return on[0] if len(on) == 1 and on[0].driven is not None else None

    def _general_response(
        self, parameters: Mapping[str, float | np.ndarray], layout: _Layout, table: np.ndarray, n_modes: int,
        inputs: np.ndarray, steps_s: np.ndarray, order: int, initial: np.ndarray | None, static_correction: bool,
    ) -> np.ndarray:
        """The retained modes with the nonlinear channels switched on
        (:func:`beam.physics.nonlinear.integrate_general`).

        The undamped modes are solved densely for each set (a distributed channel needs the shapes
        along the span, which the cached unit modes do not keep); C_r = Phi^T C Phi carries every
        damping term (modal damping included). The static correction (displacement only) is the
        discarded modes' quasi-static share of the input and of each point force that asks for it
        (:attr:`~beam.physics.effects.channel.Channel.static_correction`: the spring's), as in
        :meth:`response`; the shares between two such forces are neglected.
        """
        from beam.physics.nonlinear import integrate_general

        matrices = self.system_matrices(parameters)
        mass, damping, stiffness, force = (matrices[k] for k in ("mass", "damping", "stiffness", "force"))
        omega2, shapes = modal.undamped_modes(mass, stiffness, shift=self.parts.basis.free_root_rotation)
        shapes = shapes * _shape_signs(self.parts.tip_values @ shapes)[:, None, :]
        kept = shapes[:, :, :n_modes]
        kept_t = np.swapaxes(kept, 1, 2)
        reduced_damping = kept_t @ damping @ kept
        reduced_force = np.einsum("bnm,bn->bm", kept, force)
        sensor = self._sensor_row @ kept
        values = dict(zip(tuple(parameters), table))
        on = [(c, np.asarray(c.rows(self), dtype=float)) for c in self._channels_on(layout, table)]
        coefficients = [np.asarray(c.coefficients(self, values), dtype=float) for c, _ in on]
        statics: list = [None] * len(on)
        static_input = None
        if static_correction and order == 0:
            points = [rows for c, rows in on if c.static_correction]
            loads = np.concatenate([force[:, :, None]] + [np.broadcast_to(p.T, force.shape + (p.shape[0],))
                                                          for p in points], axis=2)  # (B, n, 1 + points)
            full = np.linalg.solve(stiffness, loads)  # K⁻¹ [f, points]
            retained = kept @ ((kept_t @ loads) / omega2[:, :n_modes, None])
            rest = full - retained
            observed = np.concatenate([self._sensor_row[None, :]] + points)  # (1 + points, n)
            share = observed @ rest  # (B, outputs, loads)
            static_input = share[:, 0, 0]
            first = 1
            for i, (c, rows) in enumerate(on):
                if c.static_correction:
                    at = np.arange(first, first + rows.shape[0])
                    statics[i] = np.stack([share[:, at, 0], share[:, at, at], share[:, 0, at]], axis=2)  # (B, P, 3)
                    first += rows.shape[0]
        channels = [ChannelArrays(c.law, rows @ kept, k, st) for (c, rows), k, st in zip(on, coefficients, statics)]
        return integrate_general(omega2[:, :n_modes], reduced_damping, reduced_force, sensor, channels, inputs,
                                 steps_s, order, initial, static_input)

    def _check_driven(self) -> None:
        if self.input_kind is None:
            raise BeamInputError("this model has no input (a free response): use free_response or free_response_basis")

    @staticmethod
    def _order(output: str) -> int:
        try:
            return OUTPUT_ORDERS[output]
        except (KeyError, TypeError):
            raise BeamInputError(
                f"output must be one of {', '.join(OUTPUT_ORDERS)}, got {output!r}"
            ) from None

    @staticmethod
    def _check_times(time_s: np.ndarray) -> np.ndarray:
        time = np.asarray(time_s, dtype=float)
        if time.ndim != 1 or time.size < 2:
            raise BeamInputError("time_s must be a 1-d array of at least two samples")
        steps = np.diff(time)
        if not (np.isfinite(time).all() and (steps > 0).all()):
            raise BeamInputError("time_s must be finite and strictly increasing")
        return time

    @_dispatched
    def reduced_system(self, parameters: Mapping[str, float | np.ndarray], modes: int | None = 4):
        """Retained modes in modal coordinates: ``(reduced, values, batched)``.

        ``reduced`` holds omega2 (B, m) (rad²/s²), damping (B, m, m) (1/s, modal damping
        included), force per unit input (B, m), sensor and tip output rows (B, m), for
        mass-normalised shapes (tip displacement positive), and static (B, 2): the quasi-static
        displacement per unit input of the discarded modes at the sensor and the tip (m/V, or
        m/N for a point force); ``values`` maps each given parameter name to its (B,) values.
        """
        n_modes = self._check_modes(modes)
        names, table, batched = self._table(parameters)
        return self._reduced_modes(self._layout(names), table, n_modes), dict(zip(names, table)), batched

    @_dispatched
    def modal_system(self, parameters: Mapping[str, float | np.ndarray], modes: int | None = 4) -> modal.ComplexModes:
        """Retained complex modes (:class:`beam.physics.modal.ComplexModes`).

        Inputs: the model's input (voltage or point force; zero for a free model, index 0) and a
        unit tip force (index 1); outputs: sensor (0) and tip (1) displacement.
        """
        reduced, _, _ = self.reduced_system(parameters, modes)
        return _complex_modes_of(reduced)

    @_dispatched
    def mode_shapes(self, parameters: Mapping[str, float], modes: int | None = 4) -> tuple[np.ndarray, np.ndarray]:
        """Undamped modes of one parameter set: omega² (m,) (rad²/s²) and shapes (n, m).

        Galerkin coefficient vectors, mass-normalised (Phi^T M Phi = I) with a positive tip
        displacement: the coordinates in which :meth:`free_response` takes its initial state.
        """
        n_modes = self._check_modes(modes)
        matrices = self.system_matrices(parameters)
        if matrices["mass"].shape[0] != 1:
            raise BeamInputError("mode_shapes takes one parameter set")
        omega2, shapes = modal.undamped_modes(matrices["mass"], matrices["stiffness"],
                                              shift=self.parts.basis.free_root_rotation)
        shapes = shapes * _shape_signs(self.parts.tip_values @ shapes)[:, None, :]
        return omega2[0, :n_modes], shapes[0, :, :n_modes]

    @_dispatched
    def modal_state(
        self, parameters: Mapping[str, float], displacement: np.ndarray, velocity: np.ndarray | None = None,
        modes: int | None = 4,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Modal coordinates (eta, eta') of a Galerkin state (q, q'): eta = Phi_r^T M q (one set).

        Parameters
        ----------
        displacement, velocity : (n,) arrays
            Galerkin coefficients of w(x, t0) (m) and w_t(x, t0) (m/s); velocity default 0.
        """
        _, shapes = self.mode_shapes(parameters, modes)
        mass = self.system_matrices(parameters)["mass"][0]
        q = np.asarray(displacement, dtype=float)
        v = np.zeros_like(q) if velocity is None else np.asarray(velocity, dtype=float)
        return shapes.T @ mass @ q, shapes.T @ mass @ v

    @_dispatched
    def response(
        self,
        parameters: Mapping[str, float | np.ndarray],
        input_signal: np.ndarray,
        sample_interval_s: float,
        modes: int | None = 4,
        static_correction: bool = True,
        *,
        output: str = "displacement",
    ) -> np.ndarray:
        """Sensor output y[k] at t_k = t_0 + k dt for the input record ``input_signal``.

        Starts at rest; u[k] is held over [t_k, t_k+1). The input is the voltage (V) or the point
        force (N) according to ``input_kind``. ``output`` is ``"displacement"`` (m, the
        default), ``"velocity"`` (m/s) or ``"acceleration"`` (m/s²). ``modes=None`` keeps all
        modes. Returns shape (n,) for scalar parameters, (B, n) when any parameter is an array
        of length B. With ``tip_cubic_stiffness_N_m3`` > 0 the nonlinear modal integrator is
        used (displacement only).

        ``static_correction`` adds the quasi-static response of the discarded modes (the
        mode-acceleration method): D u[k] with D = sum over the discarded modes of
        (c.phi)(phi.f)/omega² for the displacement, D times the input's backward slope or
        second difference for the velocity or acceleration (module notes). It is exact for
        slow inputs, removes most of the truncation error below the first discarded mode, and
        is zero when every mode is kept.
        """
        self._check_driven()
        order = self._order(output)
        voltage = np.asarray(input_signal, dtype=float)
        if voltage.ndim != 1 or voltage.size < 2 or not (math.isfinite(sample_interval_s) and sample_interval_s > 0):
            self._check_record(voltage, sample_interval_s)  # raises the precise error
        n_modes = self._check_modes(modes)
        names, table, batched = self._table(parameters)
        layout = self._layout(names)
        on = self._channels_on(layout, table)
        own = self._own_integration(on)
        if on and own is None:
            voltage = self._check_record(voltage, sample_interval_s)
            out = self._general_response(parameters, layout, table, n_modes, voltage,
                                         np.full(voltage.size - 1, float(sample_interval_s)), order, None,
                                         static_correction)
            if static_correction and order > 0:  # the input's share as in the linear path
                matrices_static = self._reduced_modes(layout, table, n_modes)["static"][:, 0]
                out += matrices_static[:, None] * held_input_derivative(voltage, sample_interval_s, order)[None, :]
            finite = np.isfinite(out).all()
        elif own is not None:  # the channel's own integration in the retained complex modes (the tip spring's)
            if order != 0:
                raise BeamInputError(f"with {own.effect} the response is computed for the displacement only")
            reduced = self._reduced_modes(layout, table, n_modes)
            static = reduced["static"] if static_correction else np.zeros_like(reduced["static"])
            out = own.driven(_complex_modes_of(reduced), own.coefficients(self, dict(zip(names, table))),
                             self._check_record(voltage, sample_interval_s), sample_interval_s, static)
            finite = np.isfinite(out).all()
        else:  # linear: rescaled cached shapes, poles, residues and ZOH stepping in one compiled call
            which, unit_modes = self._unit_modes(layout, table, n_modes)
            scales = layout.scale_matrix @ table
            out, finite = modal.cached_modes_response(which, unit_modes, scales,
                                                      sample_interval_s, voltage, static_correction,
                                                      self._modal_ratios(layout, table, n_modes), order)
            if static_correction and order > 0:  # D times the input's slope or curvature
                gains = unit_modes[5][which, 0] * (scales[2] / scales[1])
                out += gains[:, None] * held_input_derivative(voltage, sample_interval_s, order)[None, :]
        if not finite:
            self._check_record(voltage, sample_interval_s)  # a NaN or infinite voltage is named as such
            raise BeamInputError(
                "the response is not finite (parameters or voltage out of any physical range, or the tip spring "
                "too stiff for the amplitude); check the values"
            )
        return out if batched else out[0]

    @_dispatched
    def response_at(
        self,
        parameters: Mapping[str, float | np.ndarray],
        input_signal: np.ndarray,
        time_s: np.ndarray,
        modes: int | None = 4,
        static_correction: bool = True,
        *,
        output: str = "displacement",
    ) -> np.ndarray:
        """Sensor output at recorded, possibly irregular, times ``time_s`` (s), from rest at t_0.

        u[k] is held over [t_k, t_k+1) whatever its length (zero-order hold between the recorded
        samples); each retained mode is stepped exactly with z_k = exp(lambda dt_k). Otherwise as
        :meth:`response` (same outputs and correction), which it equals on a uniform grid.
        Linear models only.
        """
        self._check_driven()
        order = self._order(output)
        time = self._check_times(time_s)
        signal = np.asarray(input_signal, dtype=float)
        if signal.shape != time.shape or not np.isfinite(signal).all():
            raise BeamInputError(
                f"{self._input_name()} must be finite with one value per time stamp ({time.size}), got shape {signal.shape}"
            )
        n_modes = self._check_modes(modes)
        names, table, batched = self._table(parameters)
        layout = self._layout(names)
        on = self._channels_on(layout, table)
        own = [c.effect for c in on if c.driven is not None]
        if own:
            raise BeamInputError(f"response_at is linear; {_and_list(own)} needs response() on a uniform grid")
        if on:  # integrated at the stamps
            out = self._general_response(parameters, layout, table, n_modes, signal, np.diff(time), order, None,
                                         static_correction)
            if static_correction and order > 0:
                static = self._reduced_modes(layout, table, n_modes)["static"][:, 0]
                out += static[:, None] * held_input_derivative(signal, time, order)[None, :]
            if not np.isfinite(out).all():
                raise BeamInputError("the response is not finite (parameters out of any physical range); check the values")
            return out if batched else out[0]
        reduced = self._reduced_modes(layout, table, n_modes)
        poles, weights = modal.modal_poles_and_weights(reduced["omega2"], reduced["damping"], reduced["force"],
                                                       reduced["sensor"])
        weights, direct = modal.derivative_weights(poles, weights, order)
        if order == 0 and static_correction:
            direct = direct + reduced["static"][:, 0]
        out = modal.zoh_response_at(poles, weights, direct, time, signal)
        if static_correction and order > 0:
            out += reduced["static"][:, 0, None] * held_input_derivative(signal, time, order)[None, :]
        if not np.isfinite(out).all():
            raise BeamInputError("the response is not finite (parameters out of any physical range); check the values")
        return out if batched else out[0]

    @_dispatched
    def free_response_basis(
        self, parameters: Mapping[str, float | np.ndarray], time_s: np.ndarray, modes: int | None = 4
    ) -> np.ndarray:
        """Basis of the free responses of the retained modes at times ``time_s`` (s).

        A free response (no input; the beam moving at t_0) is linear in its unknown initial
        state, so at the sensor it is ``basis @ amplitudes`` with 2m real amplitudes. The
        columns, mode by mode (lowest first), are exp(sigma_j tau) cos(omega_dj tau) and
        exp(sigma_j tau) sin(omega_dj tau), tau = t - t_0, lambda_j = sigma_j + i omega_dj the
        retained poles (an overdamped mode gives exp(lambda tau) for each of its two real poles).
        The same basis spans the displacement, the velocity and the acceleration (each is a
        combination of the same exponentials): the output kind only changes the amplitudes,
        see :meth:`free_state_from_amplitudes`. Columns are exact at any times (irregular
        stamps included) and at most 1 in size (well scaled for least squares).

        Returns
        -------
        (n, 2m) array, or (B, n, 2m) for batched parameters.

        Notes
        -----
        For a calibration (variable projection): for given physical parameters, the amplitudes
        (and a constant output offset, one more column of ones) are linear; they can be profiled
        out by least squares or marginalised analytically under a Gaussian prior.
        """
        time = self._check_times(time_s)
        n_modes = self._check_modes(modes)
        names, table, batched = self._table(parameters)
        layout = self._layout(names)
        if self._is_nonlinear_at(layout, table):
            raise BeamInputError(f"the free-response basis is linear; {_NONLINEAR_WORDS} are not supported here "
                                 "(free_response integrates them)")
        reduced = self._reduced_modes(layout, table, n_modes)
        poles, _ = modal.modal_decomposition(reduced["omega2"], reduced["damping"])
        basis = modal.free_basis(poles, time)
        return basis if batched else basis[0]

    def _free_gains(self, reduced: dict[str, np.ndarray], order: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Poles (B, 2m), eigenvectors (B, 2m, 2m) and output gains (B, 2m) of the free retained system."""
        poles, vectors = modal.modal_decomposition(reduced["omega2"], reduced["damping"])
        m = reduced["omega2"].shape[1]
        gains = np.einsum("bi,bij->bj", reduced["sensor"], vectors[:, :m, :]) * poles**order
        return poles, vectors, gains

    @_dispatched
    def free_response(
        self,
        parameters: Mapping[str, float | np.ndarray],
        time_s: np.ndarray,
        initial_displacement: np.ndarray,
        initial_velocity: np.ndarray | None = None,
        modes: int | None = 4,
        *,
        output: str = "displacement",
    ) -> np.ndarray:
        """Free response at the sensor from the modal state (eta, eta') at t_0, exact at any times.

        Parameters
        ----------
        parameters : mapping
            Parameter values (scalars, or arrays of length B).
        time_s : (n,) array
            Strictly increasing times (s), t_0 first.
        initial_displacement, initial_velocity : (m,) or (B, m) arrays
            eta(t_0) (m sqrt(kg)) and eta'(t_0) (m sqrt(kg)/s) in the coordinates of
            :meth:`mode_shapes` (mass-normalised, tip positive); velocity default 0.
        modes : int
            Retained modes m.
        output : {"displacement", "velocity", "acceleration"}
            What the sensor measures.

        Returns
        -------
        (n,) or (B, n) array in m, m/s or m/s².
        """
        order = self._order(output)
        time = self._check_times(time_s)
        n_modes = self._check_modes(modes)
        names, table, batched = self._table(parameters)
        layout = self._layout(names)
        batch = table.shape[1]
        eta = np.broadcast_to(np.asarray(initial_displacement, dtype=float), (batch, n_modes))
        rate = np.zeros_like(eta) if initial_velocity is None else np.broadcast_to(
            np.asarray(initial_velocity, dtype=float), (batch, n_modes))
        if self._is_nonlinear_at(layout, table):  # the spring or the drag: integrated from the state
            out = self._general_response(parameters, layout, table, n_modes, np.zeros(time.size), np.diff(time), order,
                                         np.concatenate([eta, rate], axis=1), False)
            if not np.isfinite(out).all():
                raise BeamInputError("the free response is not finite (parameters out of any physical range); check the values")
            return out if batched else out[0]
        reduced = self._reduced_modes(layout, table, n_modes)
        poles, vectors, gains = self._free_gains(reduced, order)
        coefficients = np.linalg.solve(vectors, np.concatenate([eta, rate], axis=1)[:, :, None])[:, :, 0]
        tau = time - time[0]
        out = np.einsum("bj,bkj->bk", gains * coefficients, np.exp(poles[:, None, :] * tau[None, :, None])).real
        return out if batched else out[0]

    @_dispatched
    def free_state_from_amplitudes(
        self, parameters: Mapping[str, float], amplitudes: np.ndarray, modes: int | None = 4, *,
        output: str = "displacement",
    ) -> tuple[np.ndarray, np.ndarray]:
        """The modal state (eta, eta') at t_0 whose free response is ``basis @ amplitudes`` (one set).

        The inverse of :meth:`free_response_basis` for an output kind: amplitudes (2m,) fitted
        to a record of that output give the initial modal displacement and velocity (for
        :meth:`free_response`); a sensor at a node of a mode cannot see that mode (BeamInputError).
        """
        order = self._order(output)
        n_modes = self._check_modes(modes)
        names, table, batched = self._table(parameters)
        if batched:
            raise BeamInputError("free_state_from_amplitudes takes one parameter set")
        reduced = self._reduced_modes(self._layout(names), table, n_modes)
        poles, vectors, gains = self._free_gains(reduced, order)
        poles, vectors, gains = poles[0], vectors[0], gains[0]
        values = np.asarray(amplitudes, dtype=float)
        if values.shape != (2 * n_modes,):
            raise BeamInputError(f"amplitudes must have {2 * n_modes} values (2 per mode), got shape {values.shape}")
        coefficients = np.zeros(2 * n_modes, complex)
        j = column = 0
        while j < poles.size:
            if poles[j].imag > 0:  # Re(a e^{lambda tau}) with a = alpha - i beta; the pair halves it
                a = complex(values[column], -values[column + 1])
                coefficients[j] = a / (2.0 * gains[j])
                coefficients[j + 1] = np.conj(coefficients[j])
                j, column = j + 2, column + 2
            else:
                coefficients[j] = values[column] / gains[j]
                j, column = j + 1, column + 1
        if not np.isfinite(coefficients).all() or np.any(np.abs(gains) <= 1e-12 * np.abs(gains).max()):
            raise BeamInputError("the sensor sits at a node of a retained mode: its initial state cannot be recovered")
        state = (vectors @ coefficients).real
        return state[:n_modes], state[n_modes:]

    @_dispatched
    def response_full(
        self, parameters: Mapping[str, float | np.ndarray], input_signal: np.ndarray, sample_interval_s: float, *,
        output: str = "displacement",
    ) -> np.ndarray:
        """Reference response of the full state space (all modes) by :func:`scipy.signal.lsim` (ZOH).

        From rest, with the output's own C and D: displacement c q; velocity c q'; acceleration
        c q'' = c M⁻¹ (f u - C q' - K q), whose D = c M⁻¹ f (:func:`state_space`).
        """
        self._check_driven()
        order = self._order(output)
        voltage = self._check_record(input_signal, sample_interval_s)
        if any(np.any(np.asarray(parameters.get(name, 0.0)) > 0) for name in _NONLINEAR_SWITCHES):
            raise BeamInputError(f"the full state-space reference is linear; use response() for {_NONLINEAR_WORDS}")
        _, _, batched = self._table(parameters)
        matrices = self.system_matrices(parameters)
        batch = matrices["mass"].shape[0]
        import scipy.signal  # only the reference path needs it (a slow import)

        time = np.arange(voltage.size) * sample_interval_s
        out = np.empty((batch, voltage.size))
        for b in range(batch):
            system = _balanced(state_space(
                matrices["mass"][b], matrices["damping"][b], matrices["stiffness"][b], matrices["force"][b],
                self._sensor_row, order,
            ))
            _, y, _ = scipy.signal.lsim(system, voltage, time, interp=False)
            out[b] = y
        return out if batched else out[0]

    @_dispatched
    def free_response_full(
        self, parameters: Mapping[str, float], time_s: np.ndarray, displacement: np.ndarray,
        velocity: np.ndarray | None = None, *, output: str = "displacement",
    ) -> np.ndarray:
        """Reference free response of the full state space (all modes) from the Galerkin state (q, q') at t_0.

        One parameter set; ``time_s`` uniform (:func:`scipy.signal.lsim`).
        """
        order = self._order(output)
        time = self._check_times(time_s)
        if any(np.any(np.asarray(parameters.get(name, 0.0)) > 0) for name in _NONLINEAR_SWITCHES):
            raise BeamInputError(f"the full state-space reference is linear; use free_response() for {_NONLINEAR_WORDS}")
        matrices = self.system_matrices(parameters)
        if matrices["mass"].shape[0] != 1:
            raise BeamInputError("free_response_full takes one parameter set")
        import scipy.signal

        q = np.asarray(displacement, dtype=float)
        v = np.zeros_like(q) if velocity is None else np.asarray(velocity, dtype=float)
        system, scale = _balanced(state_space(matrices["mass"][0], matrices["damping"][0], matrices["stiffness"][0],
                                              np.zeros(self.size), self._sensor_row, order), with_scale=True)
        x0 = np.concatenate([q, v]) / scale  # the balanced state is diag(scale)⁻¹ x
        _, y, _ = scipy.signal.lsim(system, np.zeros(time.size), time - time[0], X0=x0, interp=False)
        return y


def _balanced(system: tuple[np.ndarray, ...], with_scale: bool = False):
    """The state space (A, B, C, D) balanced by a diagonal similarity (:func:`scipy.linalg.matrix_balance`).

    The matrix exponential of the raw state matrix, whose stiffest modes reach omega ~ 3e6 rad/s
    at 40 elements, lost up to 7e-7 (relative L2) against a 40-digit reference; balanced, 3e-9.
    """
    import scipy.linalg

    a, b, c, d = system
    a, (scale, _) = scipy.linalg.matrix_balance(a, permute=False, separate=True)
    balanced = (a, b / scale[:, None], c * scale[None, :], d)
    return (balanced, scale) if with_scale else balanced


def held_input_derivative(inputs: np.ndarray, time_s: np.ndarray | float, order: int) -> np.ndarray:
    """The first or second time derivative of a sampled input for the discarded modes' correction.

    ``order`` 1: (u[k] - u[k-1]) / (t_k - t_k-1), the slope over the last held interval, i.e. at
    t_k - dt/2, where the held (ZOH) staircase stands for the smooth input (the retained modes
    see the input delayed by half a step); 0 at t_0 (the record starts from rest).
    ``order`` 2: the divided second difference 2 (s_k - s_k-1) / (h_k + h_k-1) of those slopes;
    0 at the first two samples. ``time_s`` is the sample interval (s) of a uniform record or
    the (n,) time stamps of an irregular one.
    """
    u = np.asarray(inputs, dtype=float)
    steps = np.full(u.size - 1, float(time_s)) if np.ndim(time_s) == 0 else np.diff(np.asarray(time_s, dtype=float))
    slope = np.zeros(u.size)
    slope[1:] = np.diff(u) / steps
    if order == 1:
        return slope
    curvature = np.zeros(u.size)
    curvature[2:] = 2.0 * np.diff(slope[1:]) / (steps[1:] + steps[:-1])
    return curvature


def _stencil_centres(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Which rows are solved (centres) and, for each row, its centre: a row within
    :data:`_STENCIL_RADIUS` (relative, every coefficient) of an earlier centre is that
    centre's satellite (a finite-difference stencil point), solved by first-order
    perturbation (:func:`beam.physics.modal.perturbed_modes`)."""
    count = rows.shape[0]
    centre = np.ones(count, dtype=bool)
    owner = np.arange(count)
    if count < 2 or count > _STENCIL_MAX_ROWS:  # (the pairwise comparison grows as count²)
        return centre, owner
    close = np.all(np.abs(rows[:, None, :] - rows[None, :, :]) <= _STENCIL_RADIUS * np.abs(rows[None, :, :]), axis=2)
    np.fill_diagonal(close, False)
    if not close.any():
        return centre, owner
    for i in range(count):
        earlier = np.flatnonzero(close[i, :i] & centre[:i])
        if earlier.size:
            centre[i], owner[i] = False, earlier[0]
    return centre, owner


def _shape_signs(tip_values: np.ndarray) -> np.ndarray:
    """Signs that make each mode shape's tip displacement positive (the convention of the modal
    coordinates; a shape with a zero tip value keeps its sign)."""
    return np.where(tip_values < 0, -1.0, 1.0)


def _complex_modes_of(reduced: dict[str, np.ndarray]) -> modal.ComplexModes:
    return modal.quadratic_complex_modes(
        reduced["omega2"],
        reduced["damping"],
        np.stack([reduced["force"], reduced["tip"]], axis=1),
        np.stack([reduced["sensor"], reduced["tip"]], axis=1),
    )


def state_space(mass, damping, stiffness, force, output, order: int = 0) -> tuple[np.ndarray, ...]:
    """(A, B, C, D) of z = [q, q'], z' = A z + B u, y = C z + D u for the sensor row ``output``.

    ``order`` 0: y = c q (D = 0); 1: y = c q' (D = 0); 2: y = c q'' = c M⁻¹ (f u - C q' - K q),
    so C = c [-M⁻¹K, -M⁻¹C] and D = c M⁻¹ f (the full model's direct feed-through).
    """
    a, b, c = full_state_space(mass, damping, stiffness, force, output)
    n = mass.shape[0]
    row = np.asarray(output, dtype=float)
    if order == 0:
        c_row, d = c, 0.0
    elif order == 1:
        c_row, d = np.concatenate([np.zeros(n), row]), 0.0
    elif order == 2:
        c_row, d = row @ a[n:, :], float(row @ b[n:])
    else:
        raise ValueError(f"order must be 0, 1 or 2, got {order!r}")
    return a, b[:, None], c_row[None, :], np.array([[d]])


def full_state_space(mass, damping, stiffness, force, output) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """First-order form z = [q, q'], z' = A z + b V, y = c z of M q'' + C q' + K q = f V."""
    n = mass.shape[0]
    m_inv_k = np.linalg.solve(mass, stiffness)
    m_inv_c = np.linalg.solve(mass, damping)
    a = np.zeros((2 * n, 2 * n))
    a[:n, n:] = np.eye(n)
    a[n:, :n] = -m_inv_k
    a[n:, n:] = -m_inv_c
    b = np.concatenate([np.zeros(n), np.linalg.solve(mass, force)])
    c = np.concatenate([output, np.zeros(n)])
    return a, b, c


def _first_order_poles(mass, damping, stiffness) -> np.ndarray:
    a, _, _ = full_state_space(mass, damping, stiffness, np.zeros(mass.shape[0]), np.zeros(mass.shape[0]))
    return np.linalg.eigvals(a)


def _frequencies_and_ratios(poles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One (frequency Hz, damping ratio) per mode from first-order poles (pairs or real pairs)."""
    scale = max(np.abs(poles).max(), 1.0)
    oscillatory = poles[poles.imag > 1e-9 * scale]
    real = np.sort(poles[np.abs(poles.imag) <= 1e-9 * scale].real)[::-1]  # closest to zero first
    omegas = list(np.abs(oscillatory))
    ratios = list(-oscillatory.real / np.abs(oscillatory))
    for first, second in zip(real[0::2], real[1::2]):  # an overdamped or rigid mode: two real poles
        omega = np.sqrt(max(first * second, 0.0))
        omegas.append(omega)
        ratios.append(-(first + second) / (2 * omega) if omega > 0 else 0.0)
    order = np.argsort(omegas)
    return np.asarray(omegas)[order] / (2 * np.pi), np.asarray(ratios)[order]
