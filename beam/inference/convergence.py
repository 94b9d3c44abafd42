"""Convergence diagnostics of an emcee ensemble: acceptance, autocorrelation time, ESS, R-hat.

Conventions
-----------
* The integrated autocorrelation time ``tau`` (in steps) is that of
  :func:`emcee.autocorr.integrated_time` with ``tol=0, quiet=True`` (estimate from the
  walker-averaged autocorrelation function, Goodman & Weare 2010; the estimate is only
  trusted for chains longer than ``min_autocorr_times * tau``), a walker stuck for the whole
  segment counted as fully correlated (:func:`autocorr_time`).
* Bulk ESS and rank-normalised split R-hat come from ArviZ (:func:`arviz.ess`,
  :func:`arviz.rhat`, Vehtari et al. 2021). The ESS treats each walker after burn-in as a
  chain. The walkers of an affine-invariant ensemble are **not** independent chains (each move
  uses the positions of the others), so this figure is an approximation; it agrees with
  ``n_walkers * n_steps / tau`` when the ensemble mixes well. R-hat is computed over
  *independent ensembles* when the sampler runs several (each ensemble's pooled draws are one
  chain, :func:`ensemble_draws`), otherwise over walkers as chains. Both statistics are invariant
  under monotone transformations, so they are computed on the internal coordinates.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from beam.inference._arviz import import_arviz

__all__ = ["Diagnostics", "assess", "autocorr_time", "ensemble_draws", "ess_bulk", "rhat"]

#: R-hat above this flags non-convergence (Vehtari et al. 2021).
RHAT_MAX = 1.01
#: Chains shorter than this many autocorrelation times after burn-in are flagged.
MIN_AUTOCORR_TIMES = 20.0


def autocorr_time(chain: np.ndarray) -> np.ndarray:
    """Integrated autocorrelation time of each parameter, in steps.

    :func:`emcee.autocorr.integrated_time` (``c=5``, no length check): the walker-averaged
    normalised autocorrelation function, summed to Sokal's automatic window. One difference: a
    walker that did not move over the whole segment (every proposal rejected, seen on the strip
    record 114732 with a sensor mass: acceptance 0.08) has no normalised autocorrelation (0/0),
    which made emcee's average NaN; its autocorrelation is taken as 1 at every lag (the limit of
    a walker that moves ever less), so it lengthens the estimate instead of voiding it.

    Parameters
    ----------
    chain : ndarray, shape (n_steps, n_walkers, ndim)
        Post-burn-in positions (emcee's ``get_chain()`` layout).

    Returns
    -------
    ndarray, shape (ndim,)
    """
    from emcee.autocorr import auto_window, function_1d

    x = np.asarray(chain, dtype=float)
    n_steps, n_walkers, ndim = x.shape
    tau = np.empty(ndim)
    for d in range(ndim):
        acf = np.zeros(n_steps)
        for k in range(n_walkers):
            series = x[:, k, d]
            if np.all(series == series[0]):
                acf += 1.0
            else:
                acf += function_1d(series)
        acf /= n_walkers
        taus = 2.0 * np.cumsum(acf) - 1.0
        tau[d] = taus[auto_window(taus, 5)]
    return tau


def ess_bulk(chain: np.ndarray) -> np.ndarray:
    """ArviZ bulk effective sample size of each parameter (walkers as chains).

    Parameters
    ----------
    chain : ndarray, shape (n_steps, n_walkers, ndim)

    Returns
    -------
    ndarray, shape (ndim,)
    """
    az = import_arviz()

    x = np.swapaxes(chain, 0, 1)  # ArviZ layout (chain, draw)
    return np.array([float(az.ess(np.ascontiguousarray(x[..., i]), method="bulk")) for i in range(x.shape[-1])])


def ensemble_draws(chain: np.ndarray, n_ensembles: int) -> np.ndarray:
    """Pool each independent ensemble's walkers into one sequence of draws, in time order.

    Parameters
    ----------
    chain : ndarray, shape (n_steps, n_walkers, ndim)
        Walkers ``k * n_walkers / n_ensembles`` to ``(k + 1) * n_walkers / n_ensembles - 1``
        form ensemble ``k``.
    n_ensembles : int
        Number of independent ensembles (divides ``n_walkers``).

    Returns
    -------
    ndarray, shape (n_ensembles, n_steps * n_walkers / n_ensembles, ndim)
        ArviZ layout (chain, draw, parameter): draw ``t * m + j`` is walker ``j`` of the ensemble
        at step ``t``, so the first half of the draws is the first half of the steps (split R-hat
        splits in time).
    """
    n_steps, n_walkers, ndim = chain.shape
    if n_ensembles < 1 or n_walkers % n_ensembles:
        raise ValueError(f"{n_ensembles} ensembles do not divide {n_walkers} walkers")
    m = n_walkers // n_ensembles
    return chain.reshape(n_steps, n_ensembles, m, ndim).transpose(1, 0, 2, 3).reshape(n_ensembles, n_steps * m, ndim)


def rhat(chain: np.ndarray, n_ensembles: int = 1) -> np.ndarray:
    """ArviZ rank-normalised split R-hat of each parameter.

    Parameters
    ----------
    chain : ndarray, shape (n_steps, n_walkers, ndim)
    n_ensembles : int
        1: each walker is a chain (the walkers of one ensemble are not independent, so this is
        an approximation, and a strict one: ``R-hat - 1`` scales as ``tau / n_steps`` whatever
        the ensemble size). More: the walkers form that many *independent* ensembles (walkers
        never interact across ensembles, see :class:`beam.inference.sampling.GroupedMove`)
        and each ensemble's pooled draws are one chain (:func:`ensemble_draws`) -- independent
        chains, as R-hat assumes.

    Returns
    -------
    ndarray, shape (ndim,)
    """
    az = import_arviz()

    x = np.swapaxes(chain, 0, 1) if n_ensembles == 1 else ensemble_draws(chain, n_ensembles)
    return np.array([float(az.rhat(np.ascontiguousarray(x[..., i]), method="rank")) for i in range(x.shape[-1])])


@dataclass
class Diagnostics:
    """Convergence report of one run.

    Attributes
    ----------
    names : tuple of str
        Parameter names, in the order of the arrays below.
    n_walkers, n_steps, n_burn : int
        Ensemble size, total steps taken and steps discarded as burn-in.
    acceptance_fraction : float
        Mean acceptance fraction over walkers and all steps.
    autocorr_time : ndarray
        Integrated autocorrelation time per parameter (steps, after burn-in).
    ess_bulk : ndarray
        Bulk ESS per parameter.
    rhat : ndarray
        Rank-normalised split R-hat per parameter.
    target_ess : float or None
        ESS the run aimed for.
    n_ensembles : int
        Independent ensembles the R-hat compares (1: walkers as chains).
    converged : bool
        R-hat <= 1.01, ESS >= target and chain length >= 20 autocorrelation times.
    warnings : list of str
        One message per failed criterion.
    """

    names: tuple[str, ...]
    n_walkers: int
    n_steps: int
    n_burn: int
    acceptance_fraction: float
    autocorr_time: np.ndarray
    ess_bulk: np.ndarray
    rhat: np.ndarray
    target_ess: float | None
    converged: bool
    warnings: list[str] = field(default_factory=list)
    n_ensembles: int = 1

    @property
    def ess_min(self) -> float:
        """Smallest bulk ESS over parameters."""
        return float(np.min(self.ess_bulk))

    @property
    def rhat_max(self) -> float:
        """Largest R-hat over parameters."""
        return float(np.max(self.rhat))

    @property
    def autocorr_time_max(self) -> float:
        """Largest autocorrelation time over parameters (steps)."""
        return float(np.max(self.autocorr_time))

    def to_dict(self) -> dict:
        """Plain-Python version, for JSON and netCDF attributes."""
        return {
            "n_walkers": int(self.n_walkers),
            "n_ensembles": int(self.n_ensembles),
            "n_steps": int(self.n_steps),
            "n_burn": int(self.n_burn),
            "acceptance_fraction": float(self.acceptance_fraction),
            "autocorr_time": {n: float(v) for n, v in zip(self.names, self.autocorr_time)},
            "ess_bulk": {n: float(v) for n, v in zip(self.names, self.ess_bulk)},
            "rhat": {n: float(v) for n, v in zip(self.names, self.rhat)},
            "ess_min": self.ess_min,
            "rhat_max": self.rhat_max,
            "target_ess": None if self.target_ess is None else float(self.target_ess),
            "converged": bool(self.converged),
            "warnings": list(self.warnings),
        }


def assess(
    names: Sequence[str],
    chain: np.ndarray,
    *,
    n_steps: int,
    n_burn: int,
    acceptance_fraction: float,
    target_ess: float | None,
    rhat_max: float = RHAT_MAX,
    min_autocorr_times: float = MIN_AUTOCORR_TIMES,
    precomputed: tuple[np.ndarray | None, np.ndarray | None, np.ndarray | None] = (None, None, None),
    n_ensembles: int = 1,
) -> Diagnostics:
    """Compute all diagnostics of a post-burn-in chain and decide convergence.

    Parameters
    ----------
    names : sequence of str
        Parameter names.
    chain : ndarray, shape (n_kept, n_walkers, ndim)
        Post-burn-in positions (internal coordinates).
    n_steps, n_burn : int
        Total steps and burn-in steps.
    acceptance_fraction : float
        Mean acceptance fraction (reported, not a convergence criterion: ESS covers mixing).
    target_ess : float or None
        Required bulk ESS per parameter (None: no requirement).
    rhat_max : float
        Largest acceptable R-hat.
    min_autocorr_times : float
        Required chain length after burn-in, in autocorrelation times.
    precomputed : tuple
        ``(tau, ess, rhat)`` already computed on this very chain (None entries are computed).
    n_ensembles : int
        Independent ensembles among the walkers (see :func:`rhat`).

    Returns
    -------
    Diagnostics
    """
    tau, ess, rh = precomputed
    tau = autocorr_time(chain) if tau is None else tau
    ess = ess_bulk(chain) if ess is None else ess
    rh = rhat(chain, n_ensembles) if rh is None else rh
    warnings = []
    if np.any(~np.isfinite(rh)) or np.max(rh) > rhat_max:
        worst = names[int(np.nanargmax(np.where(np.isfinite(rh), rh, np.inf)))]
        warnings.append(f"R-hat {np.max(rh):.3f} > {rhat_max} for {worst}")
    if target_ess is not None and np.min(ess) < target_ess:
        worst = names[int(np.argmin(ess))]
        warnings.append(f"bulk ESS {np.min(ess):.0f} < target {target_ess:.0f} for {worst}")
    n_kept = chain.shape[0]
    if not np.all(np.isfinite(tau)) or n_kept < min_autocorr_times * np.max(tau):
        warnings.append(
            f"chain of {n_kept} steps after burn-in is shorter than {min_autocorr_times:.0f} "
            f"autocorrelation times ({np.max(tau):.1f} steps)"
        )
    return Diagnostics(
        names=tuple(names),
        n_walkers=int(chain.shape[1]),
        n_steps=int(n_steps),
        n_burn=int(n_burn),
        acceptance_fraction=float(acceptance_fraction),
        autocorr_time=tau,
        ess_bulk=ess,
        rhat=rh,
        target_ess=target_ess,
        converged=not warnings,
        warnings=warnings,
        n_ensembles=int(n_ensembles),
    )
