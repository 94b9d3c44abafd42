"""Candidates scored on a free decay's own backbone and damping curves, through their averaged forms.

A free decay identified block by block (:func:`beam.residuals.identify_backbone`: per mode and
block its amplitude A, natural frequency f and damping ratio zeta, with standard errors) is,
for a model, a set of predictions: mode k's linear pole (sigma_k + i omega_d,k, from the model's
eigenproblem and damping) moved by the describing functions of its nonlinear effects at the
block's modal amplitudes (the averaged slot's ``describing``,
:mod:`beam.physics.effects.averaged`), and a linear effect (a mass, a compliant clamp, a rotary
inertia, an effective length) moving the frequencies and their ratios by the eigenproblem
itself. :func:`score_candidates` fits the base model and the base plus each candidate to the
window's blocks (MAP in the priors' internal coordinates, the calibration's priors), and scores
each fit by

* its log posterior at the MAP and its Laplace log evidence (nats),
* the log predictive density of the blocks after the window at the MAP (held-out, nats), and
  their rms z-score,

in about a second of CPU per candidate (0.3-1.6 s on the stand-in families): no integration,
one eigenproblem per parameter set.

The likelihood: each block's frequency and damping ratio is Gaussian about the prediction with
its identification's standard error times a scale s_g per mode and quantity, profiled:
s_g² = max(1, chi²_g / n_g) (the identification's errors are calibrated on linear decays, rms z
1.0; where a model misses what the curves hold, its own scale widens, and its likelihood pays
n_g ln s_g). The MAP alternates a least squares at fixed scales and the scales' update, to the
profiled optimum.

Nested fits are monotone: every candidate's search starts from the base's MAP with the
candidate at its null value (the embedded point) besides its own starts, and keeps the best by
the profiled log posterior. The null values lie :data:`~beam.calibration.nulls.NULL_MARGIN`
inside a prior bound, where an effect nests the base only in the limit (a clamp joint of
1e6 N m/rad still moves a 40 cm strip's frequencies by 1e-5 of themselves, three of the
curves' standard errors), so when the search ends below the base's log posterior plus the
candidate's prior density at its null, the score is that nested limit (``nested_limit``): the
base's fit, likelihood, held-out density and evidence, the candidate at its null. Base +
candidate therefore never scores below the base (its log posterior, less the candidate's prior
density at the null; its likelihood and held-out density in the limit).

Units: frequencies in Hz, damping ratios dimensionless, log densities in nats, amplitudes in the
record's unit (the identification's), times in s, CPU seconds (``time.process_time``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from types import SimpleNamespace

import numpy as np

from beam.calibration.free import retained_poles
from beam.calibration.nulls import null_value
from beam.calibration.setup import parameter_prior
from beam.errors import BeamInputError
from beam.physics.effects import EFFECTS, parse_effects
from beam.physics.effects.base import BENDING_STIFFNESS
from beam.physics.effects.modal_damping import ratio_name
from beam.physics.model import BeamModel

__all__ = ["CurveBlocks", "CurveModel", "SlowFlowScore", "centre_values", "curve_blocks", "curve_starts", "score_candidates",
           "score_model"]

#: Orders of the time derivative of the displacement each output kind is.
OUTPUT_ORDERS = {"displacement": 0, "velocity": 1, "acceleration": 2, "strain": 0}
#: Most modes the curves are fitted on (the identification's resolved modes up to this number).
MAX_CURVE_MODES = 4
#: Points of the log grid of a candidate's parameter without start hints.
GRID_POINTS = 9
#: Starts (the best screened) each searched by the least squares; the best end is kept.
SEARCHED_STARTS = 4
#: Passes of the least squares and the profiled scales' update.
SCALE_PASSES = 2
#: Most residual evaluations of one least squares (each Jacobian one batched call besides).
MAX_EVALUATIONS = 30


@dataclass(frozen=True)
class CurveBlocks:
    """The identified blocks the curves are fitted on (one row per block of a resolved mode).

    Attributes
    ----------
    mode : ndarray (b,) of int
        Mode number (1-based) of each block.
    time_s : ndarray (b,)
        Block centres (s).
    amplitude : ndarray (b,)
        The mode's displacement (or strain) amplitude at the sensor (m, or strain).
    frequency_Hz, frequency_sd_Hz, damping_ratio, damping_ratio_sd : ndarray (b,)
        The identified natural frequency and damping ratio and their standard errors.
    """

    mode: np.ndarray
    time_s: np.ndarray
    amplitude: np.ndarray
    frequency_Hz: np.ndarray
    frequency_sd_Hz: np.ndarray
    damping_ratio: np.ndarray
    damping_ratio_sd: np.ndarray

    def __len__(self) -> int:
        return int(self.mode.size)

    def subset(self, keep: np.ndarray) -> CurveBlocks:
        """The blocks where ``keep`` (bool (b,)) holds."""
        return CurveBlocks(*(getattr(self, f)[keep] for f in ("mode", "time_s", "amplitude", "frequency_Hz",
                                                              "frequency_sd_Hz", "damping_ratio", "damping_ratio_sd")))


def _moves_shapes(name: str) -> bool:
    """Whether a parameter enters the undamped eigenproblem (a mass or stiffness term, a geometry)."""
    from beam.physics.effects import effect_of_parameter
    from beam.physics.effects.base import BASE_TERMS

    effect = effect_of_parameter(name)
    terms = BASE_TERMS if effect is None else EFFECTS[effect].terms
    moving = any(t.parameter == name and t.target in ("mass", "stiffness") for t in terms)
    geometry = effect is not None and EFFECTS[effect].geometry is not None and EFFECTS[effect].geometry.parameter == name
    return moving or geometry


def curve_blocks(backbone, max_modes: int = MAX_CURVE_MODES) -> CurveBlocks:
    """Every resolved block of the resolved modes numbered up to ``max_modes`` of ``backbone``
    (a :class:`beam.residuals.FreeDecayBackbone`), their amplitudes as displacements (or
    strains) at the sensor."""
    parts = [m for m in backbone.resolved if m.number <= max_modes]
    if not parts:
        raise BeamInputError("the record's identification resolves no mode: no backbone to score candidates on")
    cat = np.concatenate
    return CurveBlocks(cat([np.full(m.time_s.size, m.number) for m in parts]), cat([m.time_s for m in parts]),
                       cat([m.displacement_amplitude for m in parts]), cat([m.frequency_Hz for m in parts]),
                       cat([m.frequency_sd_Hz for m in parts]), cat([m.damping_ratio for m in parts]),
                       cat([m.damping_ratio_sd for m in parts]))


class CurveModel:
    """A model's predictions of the identified curves (see the module notes).

    Parameters
    ----------
    measurement : Measurement
        The free decay (its geometry, output kind, nominal values and spreads for the priors).
    effects : sequence of str
        The model's effects (base + candidate).
    modes : int
        Retained modes (at least the highest mode number of the blocks).
    blocks : CurveBlocks
        Every block of the record (the other modes' amplitudes at a block's time are read from it).
    """

    def __init__(self, measurement, effects: Sequence[str], modes: int, blocks: CurveBlocks) -> None:
        self.effects = parse_effects(effects)
        self.model = BeamModel(measurement.geometry, self.effects, input_kind=None)
        self.modes = int(modes)
        self.names = tuple(self.model.parameter_names_for(self.modes))
        self.nominal = measurement.prior_nominal
        self.priors = {n: parameter_prior(n, self.nominal, measurement.nominal_spread) for n in self.names}
        self.output = measurement.output_kind
        self.forms = [EFFECTS[e].averaged for e in self.effects if EFFECTS[e].nonlinear]
        if any(form is None for form in self.forms):
            raise BeamInputError("every nonlinear effect of a curve model needs an averaged form")
        self.blocks = blocks
        geometry = self.model.geometry
        self.sensor_row = (-0.5 * geometry.thickness_m * self.model.parts.sensor_curvatures if self.output == "strain"
                           else self.model.parts.sensor_values)
        self.shape_names = tuple(n for n in self.names if _moves_shapes(n))
        self._cache: dict[bytes, tuple] = {}

    # ------------------------------------------------------------------ coordinates
    def internal(self, values: Mapping[str, float]) -> np.ndarray:
        """Internal coordinates (d,) of natural values."""
        return np.array([float(self.priors[n].to_internal(float(values[n]))) for n in self.names])

    def natural(self, z: np.ndarray) -> dict[str, float]:
        """Natural values by name of internal coordinates ``z`` (d,)."""
        return {n: float(self.priors[n].from_internal(z[i])) for i, n in enumerate(self.names)}

    def log_prior(self, z: np.ndarray) -> float:
        """log prior density of the internal coordinates (nats, Jacobian included)."""
        return float(sum(self.priors[n].log_density_internal(z[i]) for i, n in enumerate(self.names)))

    # ------------------------------------------------------------------ predictions
    def poles(self, table: Mapping[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """The linear poles' real parts sigma (B, m) (1/s) and damped frequencies omega_d (B, m)
        (rad/s) of B parameter sets ``table`` ((B,) arrays by name), in one batched eigenproblem."""
        reduced, _, _ = self.model.reduced_system({n: np.atleast_1d(np.asarray(table[n], dtype=float))
                                                   for n in self.names}, self.modes)
        upper = retained_poles(reduced["omega2"], reduced["damping"])[:, ::2]
        return upper.real, np.abs(upper.imag)

    def shapes(self, values: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(omega (m,) rad/s, mass-normalised shapes (n, m), sensor gains (m,)) of one set (cached)."""
        key = np.array([values[n] for n in self.shape_names]).tobytes()  # damping and nonlinear laws move no shape
        if key not in self._cache:
            omega2, shapes = self.model.mode_shapes({n: float(values[n]) for n in self.names}, self.modes)
            if len(self._cache) > 256:
                self._cache.clear()
            self._cache[key] = (np.sqrt(np.maximum(omega2, 0.0)), shapes, self.sensor_row @ shapes)
        return self._cache[key]

    def linear(self, values: Mapping[str, float]) -> tuple:
        """(omega (m,) rad/s, shapes (n, m), sigma (m,) 1/s, omega_d (m,) rad/s, sensor gains (m,)) of one set."""
        omega, shapes, gains = self.shapes(values)
        sigma, omega_d = self.poles(values)
        return omega, shapes, sigma[0], omega_d[0], gains

    def modal_amplitudes(self, values: Mapping[str, float], blocks: CurveBlocks) -> np.ndarray:
        """Every mode's modal amplitude (b, m) at each block's time: its own from its blocks
        (sensor amplitude over the sensor's gain), linearly interpolated in time between them, 0
        after its last block."""
        _, _, gains = self.shapes(values)
        out = np.zeros((len(blocks), self.modes))
        for k in range(self.modes):
            own = self.blocks.mode == k + 1
            if not own.any():
                continue
            t, a = self.blocks.time_s[own], self.blocks.amplitude[own] / max(abs(gains[k]), 1e-300)
            order = np.argsort(t)
            out[:, k] = np.interp(blocks.time_s, t[order], a[order], right=0.0)
        return out

    def predict_rows(self, z: np.ndarray, blocks: CurveBlocks) -> tuple[np.ndarray, np.ndarray]:
        """Predicted natural frequencies (Hz) and damping ratios (B, b) at ``blocks`` of B sets of
        internal coordinates ``z`` (B, d): the poles in one batched call, the nonlinear forms'
        describing functions set by set."""
        z = np.atleast_2d(z)
        table = {n: self.priors[n].from_internal(z[:, i]) for i, n in enumerate(self.names)}
        sigma, omega_d = self.poles(table)
        k = blocks.mode - 1
        frequency, decay = omega_d[:, k].copy(), -sigma[:, k]
        if self.forms:
            rows = np.arange(len(blocks))
            for i in range(z.shape[0]):
                one = {n: float(v[i]) for n, v in table.items()}
                omega, shapes, _ = self.shapes(one)
                amplitudes = self.modal_amplitudes(one, blocks)
                for form in self.forms:
                    prepared = form.prepare(self.model, one, shapes, omega, sigma[i], np.zeros(0), output=self.output)
                    shift, rate = form.describing(prepared, amplitudes)
                    frequency[i] += shift[rows, k]
                    decay[i] += rate[rows, k]
        natural = np.hypot(frequency, decay)
        return natural / (2.0 * math.pi), decay / natural

    def predict(self, values: Mapping[str, float], blocks: CurveBlocks) -> tuple[np.ndarray, np.ndarray]:
        """Predicted natural frequency (Hz) and damping ratio (b,) at ``blocks``."""
        f, zeta = self.predict_rows(self.internal(values)[None, :], blocks)
        return f[0], zeta[0]

    def residual_rows(self, z: np.ndarray, blocks: CurveBlocks, scales: np.ndarray) -> np.ndarray:
        """(f_obs - f) / (s sd_f) and (zeta_obs - zeta) / (s sd_zeta) (B, 2b) at ``blocks`` of B
        sets of internal coordinates (B, d), ``scales`` (2, m) the profiled scales per quantity and mode."""
        f, zeta = self.predict_rows(z, blocks)
        k = blocks.mode - 1
        return np.concatenate([(blocks.frequency_Hz - f) / (scales[0, k] * blocks.frequency_sd_Hz),
                               (blocks.damping_ratio - zeta) / (scales[1, k] * blocks.damping_ratio_sd)], axis=1)

    def residuals(self, values: Mapping[str, float], blocks: CurveBlocks, scales: np.ndarray) -> np.ndarray:
        """:meth:`residual_rows` of one set of natural values (2b,)."""
        return self.residual_rows(self.internal(values)[None, :], blocks, scales)[0]

    def jacobian(self, z: np.ndarray, blocks: CurveBlocks, scales: np.ndarray) -> np.ndarray:
        """Forward-difference Jacobian (2b, d) of the residuals at internal ``z`` (d,): one batched call."""
        steps = 1e-6 * np.maximum(1.0, np.abs(z))
        points = np.vstack([z, z[None, :] + np.diag(steps)])
        rows = self.residual_rows(points, blocks, scales)
        return ((rows[1:] - rows[0]) / steps[:, None]).T

    def profiled_scales(self, values: Mapping[str, float], blocks: CurveBlocks) -> np.ndarray:
        """s_g = sqrt(max(1, chi²_g / n_g)) (2, m) per quantity and mode (module notes)."""
        r = self.residuals(values, blocks, np.ones((2, self.modes)))
        b = len(blocks)
        scales = np.ones((2, self.modes))
        for q in range(2):
            for k in range(self.modes):
                own = r[q * b:(q + 1) * b][blocks.mode == k + 1]
                if own.size:
                    scales[q, k] = math.sqrt(max(1.0, float(np.mean(own**2))))
        return scales

    def log_likelihood(self, values: Mapping[str, float], blocks: CurveBlocks, scales: np.ndarray) -> float:
        """Gaussian log likelihood (nats) of the blocks' frequencies and damping ratios."""
        r = self.residuals(values, blocks, scales)
        k = blocks.mode - 1
        sd = np.concatenate([scales[0, k] * blocks.frequency_sd_Hz, scales[1, k] * blocks.damping_ratio_sd])
        return float(-0.5 * np.sum(r**2) - np.sum(np.log(sd)) - 0.5 * r.size * math.log(2.0 * math.pi))


@dataclass(frozen=True)
class SlowFlowScore:
    """One model's averaged fit to a record's identified curves (:func:`score_model`).

    Attributes
    ----------
    effects : tuple of str
        The model's effects.
    candidate : str or None
        The effect added to the base (None for the base itself).
    values : dict of str to float
        MAP, natural units (the parameters' public names).
    intervals : dict of str to (float, float)
        Laplace 95 % intervals, natural units.
    log_posterior : float
        Profiled log likelihood plus log prior at the MAP (nats; internal coordinates).
    log_likelihood : float
        Profiled log likelihood of the window's blocks at the MAP (nats).
    log_evidence : float
        Laplace log evidence (nats): ``log_posterior + d/2 ln 2 pi - ½ ln det H``.
    heldout_log_density : float
        Log density (nats) of the blocks after the window at the MAP, with the window's scales
        (NaN when no block lies after the window).
    heldout_rms_z : float
        Their rms z-score (1 when the prediction is within the identification's errors).
    n_window, n_heldout : int
        Blocks in the window and after it.
    scales : ndarray (2, m)
        The profiled scales (frequency, damping) per mode.
    at_bound : tuple of str
        Parameters whose MAP lies at a bound of the prior.
    converged : bool
        Whether the least squares ended on its tolerance.
    cpu_s : float
        CPU seconds of the fit.
    nested_limit : bool
        Whether the candidate's search found nothing better than the base with the candidate at
        its null value, so that the score is that nested limit (:func:`score_model`).
    window_rms_z, heldout_rms_z_identified : float
        The rms z-score of the window's blocks and of the blocks after it (NaN: none) at the MAP
        with the identification's own standard errors (unit scales, not the profiled ones): the
        curves' error of the model, comparable between models (1 when they follow the curves to
        the identification's errors), as the one rule's errors (:mod:`beam.discovery.averaged`).
    """

    effects: tuple[str, ...]
    candidate: str | None
    values: dict
    intervals: dict
    log_posterior: float
    log_likelihood: float
    log_evidence: float
    heldout_log_density: float
    heldout_rms_z: float
    n_window: int
    n_heldout: int
    scales: np.ndarray = field(repr=False)
    at_bound: tuple[str, ...] = ()
    converged: bool = True
    cpu_s: float = 0.0
    nested_limit: bool = False
    window_rms_z: float = math.nan
    heldout_rms_z_identified: float = math.nan


def _fit(curve: CurveModel, blocks: CurveBlocks, starts: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, bool]:
    """The profiled MAP (internal z, scales (2, m), converged) from the best-screened of ``starts``."""
    from scipy import optimize

    bounds = np.array([curve.priors[n].internal_bounds for n in curve.names], dtype=float)
    span = np.where(np.isfinite(bounds[:, 1] - bounds[:, 0]), bounds[:, 1] - bounds[:, 0], 1.0)
    lower, upper = bounds[:, 0] + 1e-9 * span, bounds[:, 1] - 1e-9 * span
    quadratic = [curve.priors[n].internal_quadratic() for n in curve.names]

    def prior_residuals(z):
        return np.array([(z[j] - q[1]) / q[2] if q is not None and math.isfinite(q[2]) else 0.0
                         for j, q in enumerate(quadratic)])

    prior_rows = np.diag([1.0 / q[2] if q is not None and math.isfinite(q[2]) else 0.0 for q in quadratic])

    def objective(z, scales):
        return np.concatenate([curve.residual_rows(z[None, :], blocks, scales)[0], prior_residuals(z)])

    def jacobian(z, scales):
        return np.vstack([curve.jacobian(z, blocks, scales), prior_rows])

    costs, matched = [], []
    for z in starts:
        z = _matched(curve, blocks, np.clip(z, lower, upper), lower, upper)
        with np.errstate(all="ignore"):
            r = objective(z, np.ones((2, curve.modes)))
        costs.append(float(r @ r) if np.all(np.isfinite(r)) else math.inf)
        matched.append(z)
    best = None
    for i in np.argsort(costs, kind="stable")[:SEARCHED_STARTS]:
        if not math.isfinite(costs[i]):
            continue
        z, scales, converged = matched[i], np.ones((2, curve.modes)), False
        for _ in range(SCALE_PASSES):
            # whitened coordinates z = z0 + W u (W W^T the inverse Gauss–Newton matrix at z0): the
            # ridges between parameters (EI against a clamp's stiffness, k_f against M_s) are the
            # axes there, which a box-scaled trust region crawls along
            whiten = _whitening(jacobian(z, scales))
            origin = z.copy()

            def point(u, origin=origin, whiten=whiten):
                return np.clip(origin + whiten @ u, lower, upper)

            solution = optimize.least_squares(lambda u: objective(point(u), scales), np.zeros(z.size),
                                              jac=lambda u: jacobian(point(u), scales) @ whiten, method="trf",
                                              xtol=1e-6, ftol=1e-6, max_nfev=MAX_EVALUATIONS)
            z, converged = point(solution.x), bool(solution.status > 0)
            new = curve.profiled_scales(curve.natural(z), blocks)
            if np.allclose(new, scales, rtol=1e-3):
                break
            scales = new
        lp, scales = _log_posterior(curve, blocks, z)
        if best is None or lp > best[0]:
            best = (lp, z, scales, converged)
    if best is None:
        raise BeamInputError("no start of the curves' fit gives a finite prediction")
    return best[1], best[2], best[3]


def _whitening(jac: np.ndarray) -> np.ndarray:
    """W (d, d) with W^T (J^T J) W = I on the directions J resolves (eigenvalues below 1e-10 of
    the largest are held at that floor)."""
    eigenvalues, vectors = np.linalg.eigh(jac.T @ jac)
    floor = 1e-10 * max(float(eigenvalues[-1]), 1e-300)
    return vectors / np.sqrt(np.maximum(eigenvalues, floor))[None, :]


def _matched(curve: CurveModel, blocks: CurveBlocks, z: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """``z`` with EI rescaled (two steps of omega² ∝ EI) so that the lowest identified mode's
    predicted frequency meets its median: a start's other parameters move the frequencies, and
    the curves resolve a frequency to 1e-5 of itself, so an unmatched start is screened out by
    its frequency alone."""
    ei = BENDING_STIFFNESS.name
    if ei not in curve.names:
        return z
    j = curve.names.index(ei)
    lowest = blocks.mode == int(blocks.mode.min())
    observed = float(np.median(blocks.frequency_Hz[lowest]))
    for _ in range(2):
        with np.errstate(all="ignore"):
            f, _ = curve.predict(curve.natural(z), blocks.subset(lowest))
        predicted = float(np.median(f))
        if not (math.isfinite(predicted) and predicted > 0.0):
            return z
        z = z.copy()
        z[j] = float(np.clip(z[j] + 2.0 * math.log(observed / predicted) * _log_slope(curve.priors[ei]), lower[j], upper[j]))
    return z


def _log_slope(prior) -> float:
    """d z / d ln x of a prior's internal coordinate (1 for a log coordinate)."""
    return 1.0 if prior.log_coordinate else float(prior.to_internal(math.e) - prior.to_internal(1.0))


def _log_posterior(curve: CurveModel, blocks: CurveBlocks, z: np.ndarray) -> tuple[float, np.ndarray]:
    """The profiled log posterior (nats) at ``z`` and its scales."""
    values = curve.natural(z)
    scales = curve.profiled_scales(values, blocks)
    return curve.log_likelihood(values, blocks, scales) + curve.log_prior(z), scales


def _laplace(curve: CurveModel, blocks: CurveBlocks, z: np.ndarray, scales: np.ndarray) -> tuple[float, np.ndarray]:
    """(½ ln det H, covariance) of the Gauss–Newton Hessian at ``z`` (internal coordinates, the
    priors' curvature included)."""
    d = z.size
    jac = curve.jacobian(z, blocks, scales)
    info = jac.T @ jac
    for j, n in enumerate(curve.names):
        q = curve.priors[n].internal_quadratic()
        if q is not None and math.isfinite(q[2]):
            info[j, j] += 1.0 / q[2] ** 2
    info += 1e-12 * np.eye(d) * max(float(np.max(np.diag(info))), 1.0)
    sign, logdet = np.linalg.slogdet(info)
    cov = np.linalg.pinv(info)
    return (0.5 * logdet if sign > 0 else math.inf), cov


def _starts(curve: CurveModel, base: Mapping[str, float], candidate: str | None, blocks: CurveBlocks) -> list:
    """Internal starts: the base optimum with the candidate at its null value (the embedded
    point), the candidate's own free-decay hints from there, or a log grid of its parameter."""
    embedded = dict(base)
    if candidate is None:
        return [curve.internal(embedded)]
    names = [n for n in curve.names if n not in base]
    for n in names:
        embedded[n] = null_value(_priors_as_problem(curve), n)
    out = [curve.internal(embedded)]
    hint = EFFECTS[candidate].hints.free_decay
    if hint is not None:
        first = blocks.time_s.min()
        amplitudes = curve.modal_amplitudes(embedded, CurveBlocks(
            np.arange(1, curve.modes + 1), np.full(curve.modes, first), *(np.zeros(curve.modes) for _ in range(5))))[0]
        duration = float(blocks.time_s.max() - first)
        state = np.concatenate([amplitudes, np.zeros(curve.modes)])
        try:
            hinted = hint(curve.model, embedded, state, duration)
        except (BeamInputError, np.linalg.LinAlgError, ValueError):
            hinted = []
        out += [curve.internal({**embedded, **h}) for h in hinted if all(n in h for n in curve.names)]
    if len(out) == 1 or hint is None:
        for n in names:
            lo, hi = curve.priors[n].internal_bounds
            for z in np.linspace(lo, hi, GRID_POINTS + 2)[1:-1]:
                point = curve.internal(embedded)
                point[curve.names.index(n)] = z
                out.append(point)
    return out


def _priors_as_problem(curve: CurveModel):
    """The lookup :func:`beam.calibration.nulls.null_value` reads (``problem.parameter(name).prior``)."""
    return SimpleNamespace(parameter=lambda name: SimpleNamespace(prior=curve.priors[name]))


def score_model(measurement, effects: Sequence[str], blocks: CurveBlocks, window: tuple[float, float], *,
                modes: int | None = None, base: SlowFlowScore | None = None,
                candidate: str | None = None) -> SlowFlowScore:
    """The averaged fit of one model (``effects``) to the identified ``blocks`` whose centres
    lie in ``window`` (s), scored on them and on the blocks after it (module notes).

    Parameters
    ----------
    measurement : Measurement
        The free decay (geometry, output kind, nominal values for the priors).
    effects : sequence of str
        The model's effects.
    blocks : CurveBlocks
        Every identified block of the record (:func:`curve_blocks`).
    window : (float, float)
        The calibration window (s): blocks whose centres lie inside are fitted, those after it
        are held out.
    modes : int, optional
        Retained modes (default: the highest mode number of the blocks).
    base : SlowFlowScore, optional
        The base model's score: its MAP (with the candidate at its null value) is the embedded start.
    candidate : str, optional
        The effect ``effects`` adds to ``base``'s (for the report and the starts).

    Returns
    -------
    SlowFlowScore
    """
    cpu = time.process_time()
    modes = int(blocks.mode.max()) if modes is None else int(modes)
    curve = CurveModel(measurement, effects, modes, blocks)
    inside = (blocks.time_s >= window[0]) & (blocks.time_s <= window[1])
    after = blocks.time_s > window[1]
    fit_blocks, held = blocks.subset(inside), blocks.subset(after)
    if len(fit_blocks) < 3:
        raise BeamInputError(f"the window {window[0]:g}:{window[1]:g} s holds {len(fit_blocks)} identified blocks; "
                             "at least 3 are needed to fit the curves")
    start = dict(base.values) if base is not None else _linear_start(curve, fit_blocks)
    starts = _starts(curve, start, candidate if base is not None else None, fit_blocks)
    z, scales, converged = _fit(curve, fit_blocks, starts)
    lp, scales = _log_posterior(curve, fit_blocks, z)
    embedded = starts[0]
    lp_embedded, scales_embedded = _log_posterior(curve, fit_blocks, embedded)
    if not lp >= lp_embedded:  # nested fits are monotone: the embedded point when the search ended lower
        z, lp, scales = embedded, lp_embedded, scales_embedded
    if base is not None:
        added = [i for i, n in enumerate(curve.names) if n not in base.values]
        reference = base.log_posterior + sum(curve.priors[curve.names[i]].log_density_internal(embedded[i])
                                             for i in added)
        if not lp >= reference:  # the nested limit: the candidate at its null is the base (module notes)
            return _nested_limit(curve, base, candidate, embedded, added, reference, time.process_time() - cpu)
    values = curve.natural(z)
    half_logdet, cov = _laplace(curve, fit_blocks, z, scales)
    evidence = lp + 0.5 * z.size * math.log(2.0 * math.pi) - half_logdet
    spread = 1.959963984540054 * np.sqrt(np.maximum(np.diag(cov), 0.0))
    intervals = {n: (float(curve.priors[n].from_internal(z[i] - spread[i])),
                     float(curve.priors[n].from_internal(z[i] + spread[i]))) for i, n in enumerate(curve.names)}
    unit = np.ones((2, curve.modes))
    window_z = float(np.sqrt(np.mean(curve.residuals(values, fit_blocks, unit) ** 2)))
    held_z = float(np.sqrt(np.mean(curve.residuals(values, held, unit) ** 2))) if len(held) else math.nan
    if len(held):
        r = curve.residuals(values, held, scales)
        k = held.mode - 1
        sd = np.concatenate([scales[0, k] * held.frequency_sd_Hz, scales[1, k] * held.damping_ratio_sd])
        heldout = float(-0.5 * np.sum(r**2) - np.sum(np.log(sd)) - 0.5 * r.size * math.log(2.0 * math.pi))
        rms = float(np.sqrt(np.mean(r**2)))
    else:
        heldout, rms = math.nan, math.nan
    bounds = {n: curve.priors[n].internal_bounds for n in curve.names}
    at_bound = tuple(n for i, n in enumerate(curve.names)
                     if min(abs(z[i] - bounds[n][0]), abs(bounds[n][1] - z[i])) < 1e-6 * curve.priors[n].internal_scale)
    return SlowFlowScore(curve.effects, candidate, values, intervals, lp,
                         curve.log_likelihood(values, fit_blocks, scales), evidence, heldout, rms, len(fit_blocks),
                         len(held), scales, at_bound, converged, time.process_time() - cpu, window_rms_z=window_z,
                         heldout_rms_z_identified=held_z)


def _nested_limit(curve: CurveModel, base: SlowFlowScore, candidate: str | None, embedded: np.ndarray,
                  added: list[int], reference: float, cpu_s: float) -> SlowFlowScore:
    """The score of base + candidate when no point of its prior's support fits the curves better
    than the base with the candidate at its null (module notes): the base's fit, the candidate's
    parameters at their null values (their intervals that point), its log posterior the base's
    plus the candidate's prior density there, its evidence the base's (an upper bound: the
    likelihood nowhere exceeds the base's), ``nested_limit`` set."""
    values = {**base.values, **{curve.names[i]: float(curve.priors[curve.names[i]].from_internal(embedded[i]))
                                for i in added}}
    intervals = {**base.intervals, **{curve.names[i]: (values[curve.names[i]],) * 2 for i in added}}
    return SlowFlowScore(curve.effects, candidate, values, intervals, float(reference), base.log_likelihood,
                         base.log_evidence, base.heldout_log_density, base.heldout_rms_z, base.n_window,
                         base.n_heldout, base.scales, tuple(curve.names[i] for i in added), base.converged, cpu_s,
                         nested_limit=True, window_rms_z=base.window_rms_z,
                         heldout_rms_z_identified=base.heldout_rms_z_identified)


def centre_values(curve: CurveModel) -> dict[str, float]:
    """Every parameter of ``curve`` at its prior's centre (the nominal value, or the range's geometric mean)."""
    from beam.calibration.setup import prior_centre

    return {n: float(np.clip(prior_centre(n, curve.nominal), curve.priors[n].lower, curve.priors[n].upper))
            for n in curve.names}


def _linear_start(curve: CurveModel, blocks: CurveBlocks) -> dict[str, float]:
    """The base's start: the prior centres, EI scaled to the lowest mode's median frequency and
    each modal damping ratio at its mode's median."""
    values = centre_values(curve)
    ei = BENDING_STIFFNESS.name
    lowest = int(blocks.mode.min())
    observed = float(np.median(blocks.frequency_Hz[blocks.mode == lowest]))
    omega, *_ = curve.linear(values)
    if ei in values and omega[lowest - 1] > 0.0:
        values[ei] = float(np.clip(values[ei] * (2 * math.pi * observed / omega[lowest - 1]) ** 2,
                                   curve.priors[ei].lower, curve.priors[ei].upper))
    for k in range(curve.modes):
        name = ratio_name(k + 1)
        own = blocks.mode == k + 1
        if name in values and own.any():
            values[name] = float(np.clip(np.median(blocks.damping_ratio[own]), curve.priors[name].lower,
                                         curve.priors[name].upper))
    return values


def score_candidates(measurement, base_effects: Iterable[str], candidates: Iterable[str], *,
                     window: tuple[float, float] | None = None, backbone=None,
                     modes: int | None = None) -> list[SlowFlowScore]:
    """The base model and base + each candidate fitted to the record's identified backbone and
    damping curves by their averaged forms (module notes): the ranking's first look.

    Parameters
    ----------
    measurement : Measurement
        A free decay.
    base_effects : iterable of str
        The base model's effects (e.g. ``("modal_damping",)``).
    candidates : iterable of str
        Effects to score, each added alone to the base (a linear one, or a nonlinear one with
        an averaged form: ``quadratic_drag``, ``clamp_friction``, ``tip_cubic_spring``).
    window : (float, float), optional
        Calibration window (s); default the calibration's (:func:`beam.calibration.defaults.default_window`).
    backbone : FreeDecayBackbone, optional
        The record's identification (:func:`beam.residuals.record_backbone`); default made here,
        its modes asked at the base model's frequencies at the prior centres.
    modes : int, optional
        Retained modes (default: the highest resolved mode number, at most :data:`MAX_CURVE_MODES`).

    Returns
    -------
    list of SlowFlowScore
        The base first, then each candidate in the order given. Compare ``log_evidence``
        (Laplace, nats) and ``heldout_log_density`` with the base's; a candidate's
        ``log_posterior`` is never below the base's at the embedded point (less the
        candidate's prior density there).

    Raises
    ------
    BeamInputError
        A driven record, no resolved mode, a window with fewer than 3 blocks, an unknown effect
        or a nonlinear candidate without an averaged form.
    """
    from beam.calibration.defaults import default_window

    base_effects = parse_effects(base_effects)
    if "free" not in measurement.features:  # the record feature the averaged forms need (a free decay)
        raise BeamInputError("candidates are scored on the curves of a free decay; this record is driven")
    candidates = [c for c in parse_effects(candidates) if c not in base_effects] if not isinstance(
        candidates, str) else list(parse_effects(candidates))
    for c in candidates:
        if EFFECTS[c].nonlinear and EFFECTS[c].averaged is None:
            raise BeamInputError(f"{c} has no averaged form: it cannot be scored on the curves")
    if window is None:
        t = measurement.time_s
        window = default_window(float(t[0]), float(t[-1]))
    if backbone is None:
        from beam.residuals import record_backbone

        probe = CurveModel(measurement, base_effects, MAX_CURVE_MODES, _EMPTY)
        omega, *_ = probe.linear(centre_values(probe))
        nyquist = 0.5 / float(np.median(np.diff(measurement.time_s)))
        asked = [f for f in omega / (2 * math.pi) if f < 0.9 * nyquist]
        backbone = record_backbone(measurement, frequencies_Hz=asked or None)
    blocks = curve_blocks(backbone)
    base = score_model(measurement, base_effects, blocks, window, modes=modes)
    out = [base]
    for candidate in candidates:
        effects = tuple(e for e in EFFECTS if e in set(base_effects) | {candidate})
        out.append(score_model(measurement, effects, blocks, window, modes=modes, base=base, candidate=candidate))
    return out


_EMPTY = CurveBlocks(*(np.zeros(0, dtype=int if i == 0 else float) for i in range(7)))


def curve_starts(measurement, effects: Sequence[str], window: tuple[float, float],
                 linear_optimum: Mapping[str, float], names: Sequence[str]) -> list[dict[str, float]]:
    """Starts of a full nonlinear calibration from the curves: the averaged MAP of ``effects``
    on the record's identified backbone and damping curves (its linear sub-model's curves fit
    first, the nonlinear effect then added by :func:`score_model`), read as natural values of
    ``names`` (the calibration's physical parameters). Two starts: the curves' MAP, and
    ``linear_optimum`` (the time-domain fit of the linear sub-model) with the curves' nonlinear
    parameters. Empty where the curves cannot say (a driven record, no resolved mode, a window
    of fewer than 3 blocks, more than one nonlinear effect, one without an averaged form, or a
    fit that ends at the nested limit: the effect not seen on the curves).

    Parameters
    ----------
    measurement : Measurement
        The record.
    effects : sequence of str
        The calibration's effects.
    window : (float, float)
        Its window (s).
    linear_optimum : mapping
        Natural values of its linear sub-model's MAP (every name of ``names`` but the nonlinear
        effect's parameters).
    names : sequence of str
        The calibration's physical parameter names.
    """
    from beam.residuals import record_backbone

    effects = parse_effects(effects)
    nonlinear = [e for e in effects if EFFECTS[e].nonlinear]
    linear = tuple(e for e in effects if not EFFECTS[e].nonlinear)
    if len(nonlinear) != 1 or EFFECTS[nonlinear[0]].averaged is None or "free" not in measurement.features:
        return []
    try:
        probe = CurveModel(measurement, linear, MAX_CURVE_MODES, _EMPTY)
        omega, *_ = probe.linear({**centre_values(probe), **{n: float(v) for n, v in linear_optimum.items()
                                                             if n in probe.names}})
        nyquist = 0.5 / float(np.median(np.diff(measurement.time_s)))
        asked = [f for f in omega / (2 * math.pi) if f < 0.9 * nyquist]
        blocks = curve_blocks(record_backbone(measurement, frequencies_Hz=asked or None))
        base = score_model(measurement, linear, blocks, window)
        score = score_model(measurement, effects, blocks, window, base=base, candidate=nonlinear[0])
    except (BeamInputError, np.linalg.LinAlgError, ValueError):
        return []
    if score.nested_limit:
        return []
    own = set(EFFECTS[nonlinear[0]].parameter_names)
    curves = {n: float(score.values[n]) for n in names if n in score.values}
    if not own <= set(curves) or any(n not in curves and n not in linear_optimum for n in names):
        return []
    from_curves = {n: curves.get(n, float(linear_optimum.get(n, math.nan))) for n in names}
    from_linear = {n: (curves[n] if n in own else float(linear_optimum[n])) for n in names}
    return [from_curves, from_linear]
