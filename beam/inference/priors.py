"""Prior distributions with bounds, and the internal sampling coordinate of each parameter.

Every prior is proper and has a support ``[lower, upper]`` (possibly infinite for the normal
kinds). Samplers and optimisers work in an *internal* coordinate ``z``:

=============  ==========================  ===============================================
kind           natural density ``p(x)``     internal coordinate and density ``p(z)``
=============  ==========================  ===============================================
uniform        ``1 / (upper - lower)``      ``z = x``; flat (or, optionally, ``z = logit`` of
                                            the position in the interval; logistic)
log-uniform    ``1 / (x log(upper/lower))`` ``z = log x``; flat on ``[log lower, log upper]``
normal         truncated ``N(mean, sd²)``   ``z = x``; the same truncated normal
log-normal     truncated log-normal         ``z = log x``; truncated ``N(log median, sigma²)``
=============  ==========================  ===============================================

The density of ``z`` includes the Jacobian of the change of variables,
``p_z(z) = p_x(x(z)) |dx/dz|`` with ``|dx/dz| = x`` for the log coordinates, so sampling ``z``
from ``p_z(z) L(x(z))`` and mapping back gives draws of the posterior of ``x``. In the internal
coordinate every kind is either flat or a (truncated) Gaussian, which is what lets the MAP
search write the prior as least-squares pseudo-residuals (:meth:`Prior.pseudo_residual`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy import special

__all__ = ["PRIOR_KINDS", "LogNormal", "LogUniform", "Normal", "Prior", "Uniform"]

_LOG_SQRT_2PI = 0.5 * math.log(2.0 * math.pi)


def _log_normal_mass(a: float, b: float) -> float:
    """``log(Phi(b) - Phi(a))`` for standardised bounds ``a < b``, accurate in both tails."""
    if a > 0.0:  # both in the upper tail: use the symmetry Phi(b) - Phi(a) = Phi(-a) - Phi(-b)
        a, b = -b, -a
    # now a <= 0; Phi(b) - Phi(a) = Phi(b) * (1 - Phi(a)/Phi(b))
    log_b = float(special.log_ndtr(b))
    log_a = float(special.log_ndtr(a))
    return log_b + math.log1p(-math.exp(log_a - log_b)) if log_a > -np.inf else log_b


@dataclass(frozen=True)
class Prior:
    """Base class of a bounded prior; use one of :class:`Uniform`, :class:`LogUniform`,
    :class:`Normal`, :class:`LogNormal`.

    Attributes
    ----------
    lower, upper : float
        Support of the prior in the parameter's own unit. ``lower < upper``.
    """

    lower: float
    upper: float

    #: Name of the kind, one of :data:`PRIOR_KINDS`.
    kind = "base"
    #: True when the internal coordinate is ``log x``.
    log_coordinate = False
    #: Name of the internal coordinate: ``"linear"``, ``"log"`` or ``"logit"``.
    coordinate = "linear"

    def __post_init__(self) -> None:
        lo, hi = float(self.lower), float(self.upper)
        if math.isnan(lo) or math.isnan(hi) or not lo < hi:
            raise ValueError(f"{self.kind} prior needs lower < upper, got [{lo}, {hi}]")
        if self.log_coordinate and lo < 0.0:
            raise ValueError(f"{self.kind} prior needs lower >= 0, got {lo}")
        object.__setattr__(self, "lower", lo)
        object.__setattr__(self, "upper", hi)

    # -- coordinates ------------------------------------------------------------------------
    def to_internal(self, x):
        """Map natural values ``x`` to the internal coordinate ``z`` (array-friendly)."""
        x = np.asarray(x, dtype=float)
        if self.log_coordinate:
            with np.errstate(divide="ignore"):
                return np.log(x)
        return x

    def from_internal(self, z):
        """Map internal values ``z`` back to natural values ``x``.

        Total on the reals: in the log coordinate a ``z`` beyond the float range (above about
        709.78, e.g. the end of an interval of a parameter the data do not identify, centre ± a
        huge spread) maps to ``inf`` and one far below to ``0.0``, the saturated values, without a
        floating-point warning.
        """
        z = np.asarray(z, dtype=float)
        if not self.log_coordinate:
            return z
        with np.errstate(over="ignore"):
            return np.exp(z)

    @cached_property
    def internal_bounds(self) -> tuple[float, float]:
        """Support of the prior in the internal coordinate."""
        lo, hi = self.to_internal(self.lower), self.to_internal(self.upper)
        return float(lo), float(hi)

    @cached_property
    def _safe_internal(self) -> float:
        """An internal value inside the support (stands in for rejected values)."""
        lo, hi = self.internal_bounds
        if math.isfinite(lo) and math.isfinite(hi):
            return 0.5 * (lo + hi)
        return lo + 1.0 if math.isfinite(lo) else (hi - 1.0 if math.isfinite(hi) else 0.0)

    @cached_property
    def internal_scale(self) -> float:
        """A typical width of the prior in the internal coordinate (for step sizes).

        The interval length for the uniform kinds, the standard deviation of the (untruncated)
        Gaussian for the normal kinds, whichever is smaller when both are finite.
        """
        lo, hi = self.internal_bounds
        return float(hi - lo)

    def internal_quadratic(self) -> tuple[float, float, float] | None:
        """``(c, mu, sigma)`` with ``log p_z(z) = c - ½ ((z - mu) / sigma)²`` inside the support.

        ``sigma`` is ``inf`` (and ``mu`` 0) for the flat internal densities; None when the
        internal density is not of this form (logit coordinate). Lets a problem evaluate its
        priors in one vectorised expression.
        """
        return float(self._log_density_internal_unchecked(np.zeros(1))[0]), 0.0, math.inf

    def log_jacobian(self, z):
        """``log |dx/dz|`` at internal values ``z`` (``z`` itself for log coordinates)."""
        z = np.asarray(z, dtype=float)
        return z.copy() if self.log_coordinate else np.zeros_like(z)

    # -- densities --------------------------------------------------------------------------
    def log_density_internal(self, z):
        """Normalised log density of the internal coordinate, ``-inf`` outside the support.

        This is ``log p_x(x(z)) + log |dx/dz|`` (the Jacobian is included).
        """
        z = np.asarray(z, dtype=float)
        lo, hi = self.internal_bounds
        inside = (z >= lo) & (z <= hi)
        safe = np.where(inside, z, self._safe_internal)
        out = np.where(inside, self._log_density_internal_unchecked(safe), -np.inf)
        return out if out.ndim else float(out)

    def log_density(self, x):
        """Normalised log density of the natural value ``x``, ``-inf`` outside the support."""
        x = np.asarray(x, dtype=float)
        inside = (x >= self.lower) & (x <= self.upper)
        if self.log_coordinate:
            inside &= x > 0.0
        safe = np.where(inside, x, 1.0 if self.log_coordinate else 0.0)
        z = self.to_internal(safe)
        out = np.where(inside, self._log_density_internal_unchecked(z) - self.log_jacobian(z), -np.inf)
        return out if out.ndim else float(out)

    def _log_density_internal_unchecked(self, z):  # pragma: no cover - abstract
        raise NotImplementedError

    def pseudo_residual(self, z):
        """Residual ``r(z)`` with ``log p_z(z) = -r²/2 + const`` inside the support.

        Empty (length-0) for the flat internal densities (uniform, log-uniform) and for the
        logit coordinate (whose logistic density the least-squares stage of the MAP search
        leaves out; the Newton polish includes it); one value ``(z - centre) / width`` for the
        Gaussian ones.
        """
        return np.zeros(0)

    # -- sampling and summaries -------------------------------------------------------------
    def sample(self, rng: np.random.Generator, size: int) -> np.ndarray:
        """Draw ``size`` natural values (inverse-CDF in the internal coordinate)."""
        return self.from_internal(self._sample_internal(rng, size))

    def _sample_internal(self, rng, size):  # pragma: no cover - abstract
        raise NotImplementedError

    def internal_centre(self) -> float:
        """A central internal value (the median of ``z``), used as a default starting point."""
        raise NotImplementedError  # pragma: no cover

    def describe(self) -> str:
        """Short human-readable description, e.g. ``log-uniform[0.01, 100]``."""
        return f"{self.kind}[{self.lower:g}, {self.upper:g}]"


@dataclass(frozen=True)
class Uniform(Prior):
    """Uniform prior on ``[lower, upper]`` (both finite).

    Parameters
    ----------
    lower, upper : float
        Support, in the parameter's unit.
    coordinate : {"linear", "logit"}
        Internal coordinate. ``"linear"`` (default): ``z = x``, flat, bounded like ``x``.
        ``"logit"``: ``z = log((x - lower) / (upper - x))``, unbounded, with the standard
        logistic density ``p_z(z) = s(z) (1 - s(z))`` (``s`` the logistic sigmoid; the Jacobian
        ``dx/dz = (upper - lower) s (1 - s)`` is included). Use it for a parameter whose
        posterior can press against a bound (e.g. an AR(1) coefficient near 1): samplers and
        the Laplace approximation then see a smooth unbounded coordinate.
    """

    coordinate: str = "linear"
    kind = "uniform"

    def __post_init__(self) -> None:
        super().__post_init__()
        if not (math.isfinite(self.lower) and math.isfinite(self.upper)):
            raise ValueError("uniform prior needs finite bounds")
        if self.coordinate not in ("linear", "logit"):
            raise ValueError(f"uniform prior coordinate must be 'linear' or 'logit', got {self.coordinate!r}")

    @property
    def _logit(self) -> bool:
        return self.coordinate == "logit"

    def to_internal(self, x):
        x = np.asarray(x, dtype=float)
        if not self._logit:
            return x
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.log(x - self.lower) - np.log(self.upper - x)

    def from_internal(self, z):
        z = np.asarray(z, dtype=float)
        if not self._logit:
            return z
        return self.lower + (self.upper - self.lower) * special.expit(z)

    @cached_property
    def internal_bounds(self) -> tuple[float, float]:
        return (-math.inf, math.inf) if self._logit else (self.lower, self.upper)

    @cached_property
    def internal_scale(self) -> float:
        return math.pi / math.sqrt(3.0) if self._logit else self.upper - self.lower

    def log_jacobian(self, z):
        z = np.asarray(z, dtype=float)
        if not self._logit:
            return np.zeros_like(z)
        return math.log(self.upper - self.lower) + special.log_expit(z) + special.log_expit(-z)

    def log_density(self, x):
        x = np.asarray(x, dtype=float)
        out = np.where((x >= self.lower) & (x <= self.upper), -math.log(self.upper - self.lower), -np.inf)
        return out if out.ndim else float(out)

    def _log_density_internal_unchecked(self, z):
        z = np.asarray(z, dtype=float)
        if self._logit:
            return special.log_expit(z) + special.log_expit(-z)
        return np.full_like(z, -math.log(self.upper - self.lower), dtype=float)

    def internal_quadratic(self) -> tuple[float, float, float] | None:
        return None if self._logit else super().internal_quadratic()

    def _sample_internal(self, rng, size):
        return self.to_internal(rng.uniform(self.lower, self.upper, size))

    def internal_centre(self) -> float:
        return 0.0 if self._logit else 0.5 * (self.lower + self.upper)

    def describe(self) -> str:
        extra = ", logit coordinate" if self._logit else ""
        return f"uniform[{self.lower:g}, {self.upper:g}{extra}]"


@dataclass(frozen=True)
class LogUniform(Prior):
    """Log-uniform (Jeffreys-like, scale-invariant) prior on ``[lower, upper]``, ``0 < lower``.

    Density ``1 / (x log(upper/lower))``; internal coordinate ``z = log x`` is uniform.
    """

    kind = "log-uniform"
    log_coordinate = True
    coordinate = "log"

    def __post_init__(self) -> None:
        super().__post_init__()
        if not (self.lower > 0.0 and math.isfinite(self.upper)):
            raise ValueError("log-uniform prior needs 0 < lower < upper < inf")

    def _log_density_internal_unchecked(self, z):
        return np.full_like(z, -math.log(math.log(self.upper / self.lower)), dtype=float)

    def _sample_internal(self, rng, size):
        lo, hi = self.internal_bounds
        return rng.uniform(lo, hi, size)

    def internal_centre(self) -> float:
        lo, hi = self.internal_bounds
        return 0.5 * (lo + hi)


@dataclass(frozen=True)
class _GaussianInternal(Prior):
    """Truncated Gaussian in the internal coordinate: centre ``mu``, width ``sigma``."""

    def _mu_sigma(self) -> tuple[float, float]:  # pragma: no cover - abstract
        raise NotImplementedError

    @cached_property
    def _log_mass(self) -> float:
        mu, sigma = self._mu_sigma()
        lo, hi = self.internal_bounds
        return _log_normal_mass((lo - mu) / sigma, (hi - mu) / sigma)

    def _log_density_internal_unchecked(self, z):
        mu, sigma = self._mu_sigma()
        u = (np.asarray(z, dtype=float) - mu) / sigma
        return -0.5 * u * u - _LOG_SQRT_2PI - math.log(sigma) - self._log_mass

    @cached_property
    def internal_scale(self) -> float:
        lo, hi = self.internal_bounds
        return float(min(self._mu_sigma()[1], hi - lo))

    def internal_quadratic(self) -> tuple[float, float, float]:
        mu, sigma = self._mu_sigma()
        return -_LOG_SQRT_2PI - math.log(sigma) - self._log_mass, mu, sigma

    def pseudo_residual(self, z):
        mu, sigma = self._mu_sigma()
        return np.atleast_1d((np.asarray(z, dtype=float) - mu) / sigma)

    def _sample_internal(self, rng, size):
        mu, sigma = self._mu_sigma()
        lo, hi = self.internal_bounds
        a, b = special.ndtr((lo - mu) / sigma), special.ndtr((hi - mu) / sigma)
        u = rng.uniform(a, b, size)
        return mu + sigma * special.ndtri(u)

    def internal_centre(self) -> float:
        mu, sigma = self._mu_sigma()
        lo, hi = self.internal_bounds
        a, b = special.ndtr((lo - mu) / sigma), special.ndtr((hi - mu) / sigma)
        return float(mu + sigma * special.ndtri(0.5 * (a + b)))


@dataclass(frozen=True, init=False)
class Normal(_GaussianInternal):
    """Normal prior ``N(mean, sd²)`` truncated to ``[lower, upper]`` (default: untruncated).

    Parameters
    ----------
    mean, sd : float
        Location and scale, in the parameter's unit; ``sd > 0``.
    lower, upper : float, optional
        Truncation bounds; the density is renormalised to integrate to one on them.
    """

    mean: float
    sd: float
    kind = "normal"

    def __init__(self, mean: float, sd: float, lower: float = -math.inf, upper: float = math.inf):
        object.__setattr__(self, "mean", float(mean))
        object.__setattr__(self, "sd", float(sd))
        object.__setattr__(self, "lower", lower)
        object.__setattr__(self, "upper", upper)
        if not (self.sd > 0.0 and math.isfinite(self.sd) and math.isfinite(self.mean)):
            raise ValueError(f"normal prior needs a finite mean and sd > 0, got {mean}, {sd}")
        self.__post_init__()

    def _mu_sigma(self):
        return self.mean, self.sd

    def describe(self) -> str:
        return f"normal(mean={self.mean:g}, sd={self.sd:g})[{self.lower:g}, {self.upper:g}]"


@dataclass(frozen=True, init=False)
class LogNormal(_GaussianInternal):
    """Log-normal prior: ``log x ~ N(log median, sigma²)`` truncated to ``[lower, upper]``.

    Parameters
    ----------
    median : float
        Median of ``x`` (before truncation), in the parameter's unit; ``> 0``.
    sigma : float
        Standard deviation of ``log x`` (dimensionless); ``> 0``.
    lower, upper : float, optional
        Truncation bounds in the parameter's unit (default ``[0, inf]``).
    """

    median: float
    sigma: float
    kind = "log-normal"
    log_coordinate = True
    coordinate = "log"

    def __init__(self, median: float, sigma: float, lower: float = 0.0, upper: float = math.inf):
        object.__setattr__(self, "median", float(median))
        object.__setattr__(self, "sigma", float(sigma))
        object.__setattr__(self, "lower", lower)
        object.__setattr__(self, "upper", upper)
        if not (self.median > 0.0 and self.sigma > 0.0 and math.isfinite(self.median * self.sigma)):
            raise ValueError(f"log-normal prior needs median > 0 and sigma > 0, got {median}, {sigma}")
        self.__post_init__()

    def _mu_sigma(self):
        return math.log(self.median), self.sigma

    def describe(self) -> str:
        return f"log-normal(median={self.median:g}, sigma={self.sigma:g})[{self.lower:g}, {self.upper:g}]"


#: The prior kinds, by name.
PRIOR_KINDS = {"uniform": Uniform, "log-uniform": LogUniform, "normal": Normal, "log-normal": LogNormal}
