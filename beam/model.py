"""The cantilever model: base beam plus any set of effects, composed at assembly time.

``BeamModel(geometry, effects)`` assembles the Galerkin parts once. Each effect declares terms
``parameter * part`` (:class:`beam.effects.Term`); a call forms M = sum rho_i M_i,
C = sum c_i C_i, K = sum k_i K_i and the force from the parameter values, for one or many
parameter sets at once (values given as arrays of shape (B,)).

Responses:

* :meth:`BeamModel.response` — the fast path: modal truncation to ``modes`` modes, exact
  damping in the retained subspace (complex modes), exact ZOH stepping, vectorised over
  parameter sets; the tip cubic spring is integrated in modal coordinates
  (:mod:`beam.nonlinear`).
* :meth:`BeamModel.response_full` — the reference: the full state space (all 2n states) stepped
  exactly under ZOH by :func:`scipy.signal.lsim` (linear models only).

Mode shapes are cached: they depend only on the ratios of the mass coefficients and of the
stiffness coefficients, so a change of EI alone (or of rho alone, or of any damping or of k_p)
reuses them and rescales the frequencies.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np

from beam import modal
from beam.assembly import GalerkinParts, assemble_parts
from beam.basis import DEFAULT_INTERVALS, DEFAULT_KNOTS, INTERVALS_RANGE, KNOT_LAYOUTS, KnotLayout
from beam.effects import BASE_PARAMETERS, BASE_TERMS, EFFECTS, PARAMETER_SPECS, Term, parse_effects
from beam.errors import BeamInputError
from beam.geometry import BeamGeometry

_SHAPE_CACHE_SIZE = 256
#: Galerkin parts that damping terms may multiply (their modal projections are cached).
_DAMPING_PARTS = ("mass_beam", "stiffness_beam", "stiffness_patch")
_DENSITY = "linear_density_kg_m"


@dataclass(frozen=True)
class _Layout:
    """Where each term's coefficient comes from, for one set of given parameter names."""

    terms: tuple[Term, ...]
    columns: np.ndarray  # row of the value table for each term
    mass: np.ndarray  # indices into terms, base (rho) first
    stiffness: np.ndarray  # base (EI) first
    damping: np.ndarray
    force: np.ndarray
    damping_map: np.ndarray  # (n_damping_terms, len(_DAMPING_PARTS)) 0/1
    scale_matrix: np.ndarray  # (3 + len(_DAMPING_PARTS), rows): rho, EI, force coefficient, damping parts
    key_matrix: np.ndarray  # (mass + stiffness terms, rows): the coefficients that set the mode shapes
    key_denominators: np.ndarray  # row of key_matrix @ table dividing each (rho or EI): the ratios
    cubic_row: int  # row of the tip cubic stiffness in the table, -1 if not given


class BeamModel:
    """Euler–Bernoulli cantilever with a piezo patch and optional effects.

    Parameters
    ----------
    geometry : BeamGeometry
        Beam, patch and sensor (m), linear density (kg/m).
    effects : iterable of str or str
        Effect ids from :data:`beam.effects.EFFECTS` (or a comma-separated string).
    intervals : int
        Number N of B-spline elements (knot intervals), default
        :data:`beam.basis.DEFAULT_INTERVALS`.
    knots : {"patch", "uniform"}
        Knot layout (:mod:`beam.basis`): ``"patch"`` (default) puts double knots at the patch ends
        (fourth-order accurate for the stepped beam); ``"uniform"`` is Smith's uniform C² mesh.
    """

    def __init__(self, geometry: BeamGeometry, effects: Iterable[str] | str = (), intervals: int = DEFAULT_INTERVALS,
                 knots: KnotLayout = DEFAULT_KNOTS) -> None:
        if isinstance(intervals, bool) or int(intervals) != intervals or not INTERVALS_RANGE[0] <= intervals <= INTERVALS_RANGE[1]:
            raise BeamInputError(f"intervals must be an integer in [{INTERVALS_RANGE[0]}, {INTERVALS_RANGE[1]}], got {intervals!r}")
        if knots not in KNOT_LAYOUTS:
            raise BeamInputError(f"knots must be one of {', '.join(repr(k) for k in KNOT_LAYOUTS)}, got {knots!r}")
        self.geometry = geometry
        self.effects = parse_effects(effects)
        self.intervals = int(intervals)
        self.knots: str = knots
        frees_root = any(EFFECTS[e].frees_root_rotation for e in self.effects)
        self.parts: GalerkinParts = assemble_parts(geometry, self.intervals, frees_root, knots)
        self._shape_cache: OrderedDict[bytes, tuple[np.ndarray, ...]] = OrderedDict()
        self._layouts: dict[tuple[str, ...], _Layout] = {}
        self._accepted = frozenset(self.accepted_parameter_names)
        self._required = frozenset(self.parameter_names)

    # ------------------------------------------------------------------ parameters
    @property
    def parameter_names(self) -> tuple[str, ...]:
        """Required parameters of the base model and its effects, base first."""
        names = [p.name for p in BASE_PARAMETERS]
        for effect_id in self.effects:
            names.extend(EFFECTS[effect_id].required_parameter_names)
        return tuple(names)

    @property
    def accepted_parameter_names(self) -> tuple[str, ...]:
        """Required plus optional parameters this model understands."""
        names = [p.name for p in BASE_PARAMETERS]
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
        """Validate values; returns (names, table (len(names) + 1, B) with rho last, batched)."""
        if tuple(parameters) in self._layouts:  # these names were checked before
            pass
        elif not parameters.keys() <= self._accepted:
            unknown = sorted(set(parameters) - self._accepted)[0]
            raise BeamInputError(
                f"parameter {unknown!r} is not part of this model (effects: {', '.join(self.effects) or 'none'}); "
                f"expected {', '.join(self.accepted_parameter_names)}"
            )
        elif not self._required <= parameters.keys():
            missing = [name for name in self.parameter_names if name not in parameters][0]
            raise BeamInputError(f"missing value for parameter {missing!r}")
        names = tuple(parameters)
        values = list(parameters.values())
        if all(isinstance(v, float) for v in values):  # one parameter set of plain floats: fast path
            if all(0.0 <= v < math.inf for v in values) and parameters["bending_stiffness_Nm2"] > 0:
                values.append(self.geometry.linear_density_kg_m)
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
        if not np.isfinite(table).all() or (table < 0).any() or (table[names.index("bending_stiffness_Nm2")] <= 0).any():
            for name, row in zip(names, table):
                if not np.isfinite(row).all():
                    raise BeamInputError(f"parameter {name!r} must be finite, got {row}")
                if (row < 0).any() or (name == "bending_stiffness_Nm2" and (row <= 0).any()):
                    raise BeamInputError(f"parameter {name!r} must be positive, got {row}")
        density = np.full((1, table.shape[1]), self.geometry.linear_density_kg_m)
        return names, np.concatenate([table, density]), batched

    def _layout(self, names: tuple[str, ...]) -> _Layout:
        """The terms present for these given names, and where their coefficients sit (cached)."""
        layout = self._layouts.get(names)
        if layout is None:
            rows = {name: i for i, name in enumerate(names + (_DENSITY,))}
            candidates = list(BASE_TERMS) + [t for e in self.effects for t in EFFECTS[e].terms]
            terms = tuple(
                t for t in candidates if t.parameter in rows or PARAMETER_SPECS[t.parameter].required
            )

            def where(target: str) -> np.ndarray:
                return np.array([i for i, t in enumerate(terms) if t.target == target], dtype=int)

            damping = where("damping")
            damping_map = np.zeros((damping.size, len(_DAMPING_PARTS)))
            for row, index in enumerate(damping):
                damping_map[row, _DAMPING_PARTS.index(terms[index].part)] = 1.0
            columns = np.array([rows[t.parameter] for t in terms])
            mass, stiffness, force = where("mass"), where("stiffness"), where("force")
            select = np.zeros((len(terms), len(rows)))  # coefficient of each term from the table
            select[np.arange(len(terms)), columns] = 1.0
            scale_matrix = np.concatenate([select[mass[:1]], select[stiffness[:1]], select[force].sum(axis=0, keepdims=True),
                                           damping_map.T @ select[damping]])
            key_matrix = select[np.concatenate([mass, stiffness])]
            key_denominators = np.repeat([0, mass.size], [mass.size, stiffness.size])
            cubic_row = rows.get("tip_cubic_stiffness_N_m3", -1)
            layout = _Layout(terms, columns, mass, stiffness, damping, force, damping_map, scale_matrix, key_matrix,
                             key_denominators, cubic_row)
            self._layouts[names] = layout
        return layout

    def _coefficients(self, parameters: Mapping[str, float | np.ndarray]) -> tuple[_Layout, np.ndarray, dict, bool]:
        """(layout, coefficient table (T, B), values by name (B,), batched)."""
        names, table, batched = self._table(parameters)
        layout = self._layout(names)
        values = dict(zip(names, table))
        return layout, table[layout.columns], values, batched

    def _combine(self, layout: _Layout, coef: np.ndarray, target: str) -> np.ndarray:
        first = self.parts.patch_force if target == "force" else self.parts.mass_beam
        total = np.zeros((coef.shape[1],) + first.shape)
        for term, c in zip(layout.terms, coef):
            if term.target == target:
                part = getattr(self.parts, term.part)
                total += c.reshape((-1,) + (1,) * part.ndim) * part
        return total

    def system_matrices(self, parameters: Mapping[str, float | np.ndarray]) -> dict[str, np.ndarray]:
        """M, C, K (B, n, n) and the force per volt f (B, n) of the Galerkin model.

        M q'' + C q' + K q = f V(t) (- k3 (tip @ q)³ tip with the tip cubic spring).
        """
        layout, coef, _, _ = self._coefficients(parameters)
        return {target: self._combine(layout, coef, target) for target in ("mass", "damping", "stiffness", "force")}

    # ------------------------------------------------------------------ modes
    def _unit_modes(self, layout: _Layout, table: np.ndarray, n_modes: int) -> tuple[np.ndarray, tuple[np.ndarray, ...]]:
        """Cached unit-scale modes for each parameter set: ``(which (B,), unit_modes)``.

        Mode shapes depend only on the ratios of the mass coefficients and of the stiffness
        coefficients, so they are solved once per distinct ratio (scaled to rho = EI = 1) and
        cached with their projections; :func:`beam.modal.scale_unit_modes` rescales them.
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
        found = {k: self._shape_cache[k] for k in index if k not in missing}
        if missing:  # solved now; a batch larger than the cache reads them from here, not the cache
            found.update(self._solve_shapes(rows[[index[k] for k in missing]], missing, layout, n_modes))
        entries = [found[k] for k in index]
        return which, tuple(np.concatenate(parts) for parts in zip(*entries))

    def _reduced_modes(self, layout: _Layout, table: np.ndarray, n_modes: int) -> dict[str, np.ndarray]:
        """Retained undamped modes and the projections the response needs, batched over B.

        Returns omega2 (B, m), damping (B, m, m), force (B, m), sensor (B, m), tip (B, m),
        static (B, 2) (see :func:`beam.modal.scale_unit_modes`).
        """
        which, unit_modes = self._unit_modes(layout, table, n_modes)
        scaled = modal.scale_unit_modes(which, unit_modes, layout.scale_matrix @ table)
        return dict(zip(("omega2", "damping", "force", "sensor", "tip", "static"), scaled))

    def _solve_shapes(self, rows: np.ndarray, keys: list[bytes], layout: _Layout, n_modes: int) -> dict[bytes, tuple]:
        """Solve the undamped eigenproblem for normalised coefficient rows; cache and return the entries.

        Each entry is a tuple of arrays with a leading axis of length 1 (see :func:`beam.modal.scale_unit_modes`).
        """
        n_mass = layout.mass.size
        mass = sum(rows[:, j, None, None] * getattr(self.parts, layout.terms[i].part) for j, i in enumerate(layout.mass))
        stiff = sum(
            rows[:, n_mass + j, None, None] * getattr(self.parts, layout.terms[i].part)
            for j, i in enumerate(layout.stiffness)
        )
        try:
            with np.errstate(over="raise", invalid="raise"):
                omega2, shapes = modal.undamped_modes(mass, stiff, shift=self.parts.basis.free_root_rotation)
        except (np.linalg.LinAlgError, FloatingPointError, OverflowError) as exc:
            raise BeamInputError(f"the beam's mass and stiffness matrices cannot be solved ({exc}); check the geometry and values") from None
        kept = shapes[:, :, :n_modes]
        # static (mode-acceleration) correction: the quasi-static response of the discarded
        # modes, sum over them of (c.phi)(phi.f)/omega² (= c K⁻¹ f minus the retained part),
        # for unit rho and EI; summed directly, which stays accurate when K is nearly singular
        dropped = shapes[:, :, n_modes:]
        outputs = np.stack([self.parts.sensor_values, self.parts.tip_values])  # (2, n)
        per_mode = (outputs @ dropped) * ((self.parts.patch_force @ dropped) / omega2[:, n_modes:])[:, None, :]
        residual_static = per_mode.sum(axis=2)  # (U, 2): sensor, tip
        kept_t = np.swapaxes(kept, 1, 2)
        projections = np.stack([kept_t @ getattr(self.parts, name) @ kept for name in _DAMPING_PARTS], axis=1)
        force = kept.transpose(0, 2, 1) @ self.parts.patch_force
        sensor = self.parts.sensor_values @ kept
        tip = self.parts.tip_values @ kept
        entries = {}
        for i, key in enumerate(keys):
            entries[key] = tuple(
                np.ascontiguousarray(part[i : i + 1], dtype=float)
                for part in (omega2[:, :n_modes], projections, force, sensor, tip, residual_static)
            )
            self._shape_cache[key] = entries[key]
            if len(self._shape_cache) > _SHAPE_CACHE_SIZE:
                self._shape_cache.popitem(last=False)
        return entries

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
    def _check_record(self, voltage_V: np.ndarray, sample_interval_s: float) -> np.ndarray:
        voltage = np.asarray(voltage_V, dtype=float)
        if voltage.ndim != 1 or voltage.size < 2:
            raise BeamInputError("voltage_V must be a 1-d array of at least two samples")
        if not np.all(np.isfinite(voltage)):
            raise BeamInputError("voltage_V holds NaN or infinite values")
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

    def reduced_system(self, parameters: Mapping[str, float | np.ndarray], modes: int | None = 4):
        """Retained modes in modal coordinates: ``(reduced, values, batched)``.

        ``reduced`` holds omega2 (B, m) (rad²/s²), damping (B, m, m) (1/s), force per volt (B, m),
        sensor and tip output rows (B, m), for mass-normalised shapes, and static (B, 2): the
        quasi-static displacement per volt of the discarded modes at the sensor and the tip (m/V);
        ``values`` maps each given parameter name to its (B,) values.
        """
        n_modes = self._check_modes(modes)
        names, table, batched = self._table(parameters)
        return self._reduced_modes(self._layout(names), table, n_modes), dict(zip(names, table)), batched

    def modal_system(self, parameters: Mapping[str, float | np.ndarray], modes: int | None = 4) -> modal.ComplexModes:
        """Retained complex modes (:class:`beam.modal.ComplexModes`).

        Inputs: voltage (index 0) and a unit tip force (index 1); outputs: sensor (0) and tip (1).
        """
        reduced, _, _ = self.reduced_system(parameters, modes)
        return _complex_modes_of(reduced)

    def response(
        self,
        parameters: Mapping[str, float | np.ndarray],
        voltage_V: np.ndarray,
        sample_interval_s: float,
        modes: int | None = 4,
        static_correction: bool = True,
    ) -> np.ndarray:
        """Sensor displacement y[k] = w(x_obs, t_k) (m) for the voltage record ``voltage_V`` (V).

        Starts at rest; V[k] is held over [t_k, t_k+1). ``modes=None`` keeps all modes. Returns
        shape (n,) for scalar parameters, (B, n) when any parameter is an array of length B.
        With ``tip_cubic_stiffness_N_m3`` > 0 the nonlinear modal integrator is used.

        ``static_correction`` adds the quasi-static response of the discarded modes to the
        voltage (the mode-acceleration method): D V[k] with D = sum over the discarded modes of
        (c.phi)(phi.f)/omega². It is exact for slow inputs, removes most of the truncation error
        below the first discarded mode, and is zero when every mode is kept.
        """
        voltage = np.asarray(voltage_V, dtype=float)
        if voltage.ndim != 1 or voltage.size < 2 or not (math.isfinite(sample_interval_s) and sample_interval_s > 0):
            self._check_record(voltage, sample_interval_s)  # raises the precise error
        n_modes = self._check_modes(modes)
        names, table, batched = self._table(parameters)
        layout = self._layout(names)
        if layout.cubic_row >= 0 and np.any(table[layout.cubic_row] > 0):
            from beam.nonlinear import integrate_tip_cubic

            reduced = self._reduced_modes(layout, table, n_modes)
            static = reduced["static"] if static_correction else np.zeros_like(reduced["static"])
            out = integrate_tip_cubic(_complex_modes_of(reduced), table[layout.cubic_row],
                                      self._check_record(voltage, sample_interval_s), sample_interval_s,
                                      static_gains=static)
            finite = np.isfinite(out).all()
        else:  # linear: rescaled cached shapes, poles, residues and ZOH stepping in one compiled call
            which, unit_modes = self._unit_modes(layout, table, n_modes)
            out, finite = modal.cached_modes_response(which, unit_modes, layout.scale_matrix @ table,
                                                      sample_interval_s, voltage, static_correction)
        if not finite:
            self._check_record(voltage, sample_interval_s)  # a NaN or infinite voltage is named as such
            raise BeamInputError(
                "the response is not finite (parameters or voltage out of any physical range, or the tip spring "
                "too stiff for the amplitude); check the values"
            )
        return out if batched else out[0]

    def response_full(
        self, parameters: Mapping[str, float | np.ndarray], voltage_V: np.ndarray, sample_interval_s: float
    ) -> np.ndarray:
        """Reference response of the full state space (all modes) by :func:`scipy.signal.lsim` (ZOH).

        The state matrix is balanced first (:func:`scipy.linalg.matrix_balance`), which keeps the
        exponential accurate on fine meshes, whose stiffest modes are far above the sampling rate.
        """
        voltage = self._check_record(voltage_V, sample_interval_s)
        if np.any(np.asarray(parameters.get("tip_cubic_stiffness_N_m3", 0.0)) > 0):
            raise BeamInputError("the full state-space reference is linear; use response() for tip_cubic_spring")
        _, _, batched = self._table(parameters)
        matrices = self.system_matrices(parameters)
        batch = matrices["mass"].shape[0]
        import scipy.linalg
        import scipy.signal  # only the reference path needs it (a slow import)

        time = np.arange(voltage.size) * sample_interval_s
        out = np.empty((batch, voltage.size))
        for b in range(batch):
            a, bvec, c = full_state_space(
                matrices["mass"][b], matrices["damping"][b], matrices["stiffness"][b], matrices["force"][b],
                self.parts.sensor_values,
            )
            # balanced (a diagonal similarity, LAPACK gebal): the matrix exponential of the raw
            # state matrix, whose stiffest modes reach omega ~ 3e6 rad/s at 40 elements, lost up
            # to 7e-7 (relative L2) there against a 40-digit reference; balanced, 3e-9
            a, (scale, _) = scipy.linalg.matrix_balance(a, permute=False, separate=True)
            bvec, c = bvec / scale, c * scale
            _, y, _ = scipy.signal.lsim((a, bvec[:, None], c[None, :], np.zeros((1, 1))), voltage, time, interp=False)
            out[b] = y
        return out if batched else out[0]


def _complex_modes_of(reduced: dict[str, np.ndarray]) -> modal.ComplexModes:
    return modal.complex_modes(
        reduced["omega2"],
        reduced["damping"],
        np.stack([reduced["force"], reduced["tip"]], axis=1),
        np.stack([reduced["sensor"], reduced["tip"]], axis=1),
    )


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
