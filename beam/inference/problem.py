"""A calibration problem: named parameters with priors, a vectorised forward model, data.

The same :class:`Problem` drives the MAP search, the Laplace preview, the emcee sampler and
the posterior predictive, for the toy oscillator (:mod:`beam.toy`) and for the beam.

Forward model contract
----------------------
``model(values, time_s) -> ndarray (B, len(time_s))`` where ``values`` maps *every* parameter
name (sampled and fixed, noise parameters included) to a float array of shape ``(B,)``, one
entry per parameter set (e.g. per emcee walker), and ``time_s`` is any 1-D time grid in
seconds. The model must be vectorised over ``B``; it returns the noise-free prediction in the
data unit. It may cache work keyed on ``time_s`` (the calibration grid is passed as the same
array object every time, :attr:`Problem.time_s`).

Noise
-----
The noise parameters named by the likelihood kind (``noise_sd``; ``ar1_coefficient`` for
``"ar1"``) are ordinary parameters: with a prior they are *estimated* (sampled jointly with the
physical parameters, not marginalised analytically); listed in ``fixed`` they are known.

Linear parameters profiled by the model
---------------------------------------
A model may fit some linear coefficients itself, by least squares on the calibration data, at
every call (variable projection: the unknown initial state of a free response). Its problem
is then given ``likelihood_correction(values) -> ndarray (B,)``, the term that turns the
profile likelihood of the calibration grid into the likelihood with those coefficients
integrated out (called right after the model on :attr:`Problem.time_s` with the same
``values``); :meth:`Problem.log_likelihood` and :meth:`Problem.log_posterior` add it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy import special

from beam.inference.likelihood import (
    LIKELIHOODS,
    estimate_noise_parameters,
    log_likelihood,
    whiten,
)
from beam.inference.priors import Prior

__all__ = ["ForwardModel", "InitialGuesses", "Parameter", "Problem"]

ForwardModel = Callable[[Mapping[str, np.ndarray], np.ndarray], np.ndarray]
InitialGuesses = Callable[["Problem"], Sequence[Mapping[str, float]]]


@dataclass(frozen=True)
class Parameter:
    """A sampled parameter.

    Attributes
    ----------
    name : str
        Identifier, used as the key of value dictionaries and as the ArviZ variable name.
    prior : Prior
        Its prior (with bounds); fixes the internal sampling coordinate.
    unit : str
        Unit of the natural value, e.g. ``"Hz"`` (free text, for labels and netCDF attributes).
    description : str
        One-line description for tables and plots.
    """

    name: str
    prior: Prior
    unit: str = ""
    description: str = ""


@dataclass
class Problem:
    """Everything needed to compute a posterior.

    Parameters
    ----------
    parameters : sequence of Parameter
        The sampled parameters, including the noise parameters of ``likelihood`` unless
        they are given in ``fixed``.
    model : ForwardModel
        Vectorised forward model, see the module docstring.
    time_s : ndarray, shape (n,)
        Calibration time grid in seconds (uniform spacing when ``likelihood="ar1"``).
    data : ndarray, shape (n,)
        Observations on ``time_s``, in the data unit.
    likelihood : {"iid", "ar1"}
        Noise model, see :mod:`beam.inference.likelihood`.
    fixed : mapping of str to float
        Parameters held at known values (passed to the model, never sampled).
    initial_guesses : callable, optional
        ``initial_guesses(problem) -> [ {name: value, ...}, ... ]``: starting points for the
        MAP search (natural units). Keys may omit parameters: a missing noise parameter is
        estimated from the residuals of the guess, a missing physical parameter starts at the
        centre of its prior. Without it the search starts from the prior centre and a few
        seeded prior draws (:func:`beam.inference.optimize.default_initial_guesses`).
    name : str
        Label used in results and netCDF attributes.
    data_unit : str
        Unit of ``data`` (free text).
    proportional_to : str, optional
        A sampled parameter the prediction is proportional to, the others held (the coupling of
        a linear model's only input). The MAP search then forms its finite difference in that
        parameter from the unperturbed prediction instead of a model call
        (:mod:`beam.calibration.fit`).
    likelihood_correction : callable, optional
        ``likelihood_correction(values) -> (B,)`` (nats): added to the log likelihood of the
        model's prediction on :attr:`time_s` (see the module notes); None: nothing is added.
    """

    parameters: Sequence[Parameter]
    model: ForwardModel
    time_s: np.ndarray
    data: np.ndarray
    likelihood: str = "iid"
    fixed: Mapping[str, float] = field(default_factory=dict)
    initial_guesses: InitialGuesses | None = None
    name: str = "problem"
    data_unit: str = ""
    proportional_to: str | None = None
    likelihood_correction: Callable[[Mapping[str, np.ndarray]], np.ndarray] | None = None

    def __post_init__(self) -> None:
        self.parameters = tuple(self.parameters)
        self.time_s = np.ascontiguousarray(self.time_s, dtype=float)
        self.data = np.ascontiguousarray(self.data, dtype=float)
        self.fixed = {str(k): float(v) for k, v in dict(self.fixed).items()}
        if self.likelihood not in LIKELIHOODS:
            raise ValueError(f"unknown likelihood {self.likelihood!r}; expected one of {', '.join(LIKELIHOODS)}")
        if self.time_s.ndim != 1 or self.data.shape != self.time_s.shape or self.time_s.size < 3:
            raise ValueError("time_s and data must be 1-D arrays of the same length (at least 3)")
        if not (np.all(np.isfinite(self.data)) and np.all(np.isfinite(self.time_s))):
            raise ValueError("time_s and data must be finite")
        names = [p.name for p in self.parameters]
        if len(set(names)) != len(names):
            raise ValueError(f"duplicate parameter names in {names}")
        clash = set(names) & set(self.fixed)
        if clash:
            raise ValueError(f"parameters both sampled and fixed: {sorted(clash)}")
        if not names:
            raise ValueError("a problem needs at least one sampled parameter")
        for noise_name in LIKELIHOODS[self.likelihood]:
            if noise_name not in names and noise_name not in self.fixed:
                raise ValueError(f"likelihood {self.likelihood!r} needs {noise_name!r} as a parameter or a fixed value")
        if self.proportional_to is not None and self.proportional_to not in names:
            raise ValueError(f"proportional_to {self.proportional_to!r} is not a sampled parameter")
        self._names = tuple(names)
        self._index = {n: i for i, n in enumerate(names)}
        self._lower = np.array([p.prior.internal_bounds[0] for p in self.parameters])
        self._upper = np.array([p.prior.internal_bounds[1] for p in self.parameters])
        self._log_rows = np.array([p.prior.log_coordinate for p in self.parameters])
        self._log_idx = np.flatnonzero(self._log_rows)
        self._logit_idx = np.array([i for i, p in enumerate(self.parameters) if p.prior.coordinate == "logit"], dtype=int)
        self._logit_lo = np.array([self.parameters[i].prior.lower for i in self._logit_idx])
        self._logit_width = np.array([self.parameters[i].prior.upper - self.parameters[i].prior.lower for i in self._logit_idx])
        quads = [p.prior.internal_quadratic() for p in self.parameters]
        quad = np.array([q if q is not None else (0.0, 0.0, np.inf) for q in quads])
        self._other_priors = [(i, p.prior) for i, (p, q) in enumerate(zip(self.parameters, quads)) if q is None]
        self._prior_const = float(quad[:, 0].sum())
        self._prior_mu = quad[:, 1]
        self._prior_inv_sigma = 1.0 / quad[:, 2]  # 0 for flat internal densities
        self._has_gaussian_prior = bool(np.any(self._prior_inv_sigma > 0.0))
        self.n_model_rows = 0  # number of parameter sets pushed through the model (a cost counter)

    # -- names and coordinates --------------------------------------------------------------
    @property
    def names(self) -> tuple[str, ...]:
        """Names of the sampled parameters, in internal-vector order."""
        return self._names

    @property
    def ndim(self) -> int:
        """Number of sampled parameters."""
        return len(self._names)

    @property
    def noise_names(self) -> tuple[str, ...]:
        """Noise parameters required by the likelihood kind (sampled or fixed)."""
        return LIKELIHOODS[self.likelihood]

    @property
    def model_names(self) -> tuple[str, ...]:
        """Sampled parameters that are not noise parameters."""
        return tuple(n for n in self._names if n not in self.noise_names)

    @property
    def internal_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the internal coordinates, each shape (ndim,)."""
        return self._lower.copy(), self._upper.copy()

    def index(self, name: str) -> int:
        """Position of a sampled parameter in the internal vector."""
        return self._index[name]

    def parameter(self, name: str) -> Parameter:
        """The :class:`Parameter` called ``name``."""
        return self.parameters[self._index[name]]

    def to_internal(self, values: Mapping[str, float | np.ndarray]) -> np.ndarray:
        """Internal coordinates of natural values; shape ``(..., ndim)``."""
        cols = [p.prior.to_internal(values[p.name]) for p in self.parameters]
        return np.stack(np.broadcast_arrays(*cols), axis=-1).astype(float)

    def from_internal(self, z: np.ndarray, *, include_fixed: bool = True) -> dict[str, np.ndarray]:
        """Natural values of internal vectors ``z`` (shape (B, ndim)) as ``{name: (B,)}``.

        With ``include_fixed`` the fixed parameters are added, broadcast to shape (B,).
        """
        z = np.atleast_2d(np.asarray(z, dtype=float))
        x = z.copy()
        if self._log_idx.size:
            with np.errstate(over="ignore"):  # saturated as Prior.from_internal: beyond the float range is inf
                x[:, self._log_idx] = np.exp(z[:, self._log_idx])
        if self._logit_idx.size:
            x[:, self._logit_idx] = self._logit_lo + self._logit_width * special.expit(z[:, self._logit_idx])
        out = {n: x[:, i] for i, n in enumerate(self._names)}
        if include_fixed:
            for n, v in self.fixed.items():
                out[n] = np.full(z.shape[0], v)
        return out

    # -- densities ---------------------------------------------------------------------------
    def in_support(self, z: np.ndarray) -> np.ndarray:
        """Boolean (B,): rows of ``z`` inside every prior's support."""
        z = np.atleast_2d(z)
        return np.all((z >= self._lower) & (z <= self._upper), axis=1)

    def log_prior(self, z: np.ndarray) -> np.ndarray:
        """Log prior density of internal vectors (Jacobian included), shape (B,)."""
        z = np.atleast_2d(np.asarray(z, dtype=float))
        return np.where(self.in_support(z), self._log_prior_inside(z), -np.inf)

    def _log_prior_inside(self, z: np.ndarray) -> np.ndarray:
        """Log prior of rows known to be inside the support (all kinds at once)."""
        if self._has_gaussian_prior:
            u = (z - self._prior_mu) * self._prior_inv_sigma
            out = self._prior_const - 0.5 * np.einsum("ij,ij->i", u, u)
        else:
            out = np.full(z.shape[0], self._prior_const)
        for i, prior in self._other_priors:
            out = out + prior.log_density_internal(z[:, i])
        return out

    def predict(self, values: Mapping[str, np.ndarray], time_s: np.ndarray | None = None) -> np.ndarray:
        """Model predictions ``(B, len(time_s))`` for natural ``values`` (fixed ones added).

        ``time_s`` defaults to the calibration grid.
        """
        grid = self.time_s if time_s is None else np.asarray(time_s, dtype=float)
        vals = {k: np.atleast_1d(np.asarray(v, dtype=float)) for k, v in values.items()}
        batch = max(v.shape[0] for v in vals.values())
        for n, v in self.fixed.items():
            vals.setdefault(n, np.full(batch, v))
        out = np.asarray(self.model(vals, grid), dtype=float)
        if out.shape != (batch, grid.size):
            raise ValueError(f"model returned shape {out.shape}, expected {(batch, grid.size)}")
        self.n_model_rows += batch
        return out

    def noise_values(self, values: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """The noise parameters out of a value dictionary (fixed ones included)."""
        return {n: np.asarray(values[n], dtype=float) for n in self.noise_names}

    def residuals(self, z: np.ndarray) -> np.ndarray:
        """``data - prediction`` on the calibration grid for internal vectors, shape (B, n)."""
        values = self.from_internal(z)
        return self.data - self.predict(values)

    def whitened_residuals(self, z: np.ndarray) -> np.ndarray:
        """Residuals whitened by the noise model at each row's noise parameters, shape (B, n)."""
        values = self.from_internal(z)
        return whiten(self.likelihood, self.data - self.predict(values), self.noise_values(values))

    def log_likelihood(self, z: np.ndarray) -> np.ndarray:
        """Log likelihood of internal vectors (rows must be inside the support), shape (B,)."""
        values = self.from_internal(z)
        resid = self.data - self.predict(values)
        return log_likelihood(self.likelihood, resid, self.noise_values(values)) + self._correction(values)

    def _correction(self, values: Mapping[str, np.ndarray]) -> np.ndarray | float:
        """:attr:`likelihood_correction` at ``values`` (0 when there is none)."""
        correction = self.likelihood_correction
        return 0.0 if correction is None else np.asarray(correction(values), dtype=float)

    def log_posterior(self, z: np.ndarray) -> np.ndarray:
        """Unnormalised log posterior density of internal vectors, shape (B,).

        This is the vectorised ``log_prob_fn`` given to emcee: ``-inf`` for rows outside the
        prior support (the model is not evaluated there) or where the model is not finite.
        A 1-D ``z`` is treated as one row and returns shape (1,).
        """
        z = np.atleast_2d(np.asarray(z, dtype=float))
        ok = np.all((z >= self._lower) & (z <= self._upper), axis=1)
        all_ok = bool(ok.all())
        zz = z if all_ok else z[ok]
        if zz.shape[0] == 0:
            return np.full(z.shape[0], -np.inf)
        with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
            values = self.from_internal(zz)
            pred = np.asarray(self.model(values, self.time_s), dtype=float)
            if pred.shape != (zz.shape[0], self.time_s.size):
                raise ValueError(f"model returned shape {pred.shape}, expected {(zz.shape[0], self.time_s.size)}")
            self.n_model_rows += zz.shape[0]
            ll = log_likelihood(self.likelihood, self.data - pred, values) + self._correction(values)
            lp = self._log_prior_inside(zz) + ll
        lp[~np.isfinite(lp)] = -np.inf
        if all_ok:
            return lp
        out = np.full(z.shape[0], -np.inf)
        out[ok] = lp
        return out

    def noise_estimate(self, values: Mapping[str, float]) -> dict[str, float]:
        """Moment estimates of the noise parameters at a parameter set (natural units)."""
        vals = {k: np.atleast_1d(float(v)) for k, v in values.items()}
        resid = self.data - self.predict(vals)[0]
        return estimate_noise_parameters(self.likelihood, resid)

    def describe_priors(self) -> dict[str, str]:
        """``{name: "kind[lower, upper]"}`` for every sampled parameter."""
        return {p.name: p.prior.describe() for p in self.parameters}
