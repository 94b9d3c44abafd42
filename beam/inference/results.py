"""The result of a posterior run: draws, diagnostics and an ArviZ ``InferenceData``.

InferenceData layout (ArviZ conventions, walkers stored as chains as ``arviz.from_emcee`` does)
------------------------------------------------------------------------------------------------
``posterior``
    One variable per sampled parameter, natural units, dims ``(chain, draw)``; the variable
    attribute ``units`` holds the unit and ``prior`` the prior.
``sample_stats``
    ``lp``: unnormalised log posterior in the internal coordinates (nats).
``observed_data``
    ``y`` on the ``time_s`` coordinate (the calibration data).
``constant_data``
    The fixed parameters (scalars), if any.
Global attributes: likelihood kind, problem name, seed, burn-in, the diagnostics as JSON text.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from beam.inference._arviz import import_arviz
from beam.inference.predictive import PredictiveBands, predictive_bands
from beam.inference.problem import Problem
from beam.inference.summaries import summarize_draws

if TYPE_CHECKING:  # pragma: no cover
    import arviz

    from beam.inference.convergence import Diagnostics
    from beam.inference.laplace import LaplaceResult

__all__ = ["PosteriorResult", "load_inference_data"]


@dataclass
class PosteriorResult:
    """Posterior draws of a problem with their diagnostics.

    Attributes
    ----------
    problem : Problem
        The problem sampled.
    chain : ndarray, shape (n_kept, n_walkers, ndim)
        Post-burn-in positions, internal coordinates.
    log_prob : ndarray, shape (n_kept, n_walkers)
        Log posterior of each position.
    diagnostics : Diagnostics
        Convergence report.
    laplace : LaplaceResult or None
        The preview the walkers started from.
    seed : int
        Seed of the run.
    seconds : float
        Wall time (MAP, Laplace, sampling, diagnostics).
    """

    problem: Problem
    chain: np.ndarray
    log_prob: np.ndarray
    diagnostics: Diagnostics
    laplace: LaplaceResult | None = None
    seed: int = 0
    seconds: float = 0.0
    _idata: arviz.InferenceData | None = field(default=None, repr=False)

    @classmethod
    def from_chain(cls, problem: Problem, chain: np.ndarray, log_prob: np.ndarray, **kwargs) -> PosteriorResult:
        """Build from post-burn-in positions (internal coordinates) and their log posterior."""
        return cls(problem=problem, chain=np.asarray(chain, dtype=float), log_prob=np.asarray(log_prob, dtype=float), **kwargs)

    # -- draws and summaries -----------------------------------------------------------------
    @property
    def n_draws(self) -> int:
        """Number of stored draws (kept steps times walkers)."""
        return int(self.chain.shape[0] * self.chain.shape[1])

    def draws(self, *, include_fixed: bool = False) -> dict[str, np.ndarray]:
        """All draws in natural units, ``{name: (n_draws,)}`` (step-major order)."""
        flat = self.chain.reshape(-1, self.chain.shape[-1])
        return self.problem.from_internal(flat, include_fixed=include_fixed)

    def thinned_draws(self, n: int, seed: int = 0) -> dict[str, np.ndarray]:
        """``n`` draws picked without replacement (all if fewer), natural units."""
        flat = self.chain.reshape(-1, self.chain.shape[-1])
        if n < flat.shape[0]:
            idx = np.sort(np.random.default_rng(seed).choice(flat.shape[0], n, replace=False))
            flat = flat[idx]
        return self.problem.from_internal(flat, include_fixed=False)

    def summary(self) -> dict[str, dict[str, float]]:
        """``{name: {"mean", "sd", "q025", "q975"}}`` in natural units."""
        return summarize_draws(self.draws())

    def predict(self, time_s: np.ndarray, *, n_draws: int = 1000, seed: int = 0, level: float = 0.95) -> PredictiveBands:
        """Credible and prediction bands on ``time_s`` from ``n_draws`` posterior draws."""
        return predictive_bands(self.problem, self.thinned_draws(n_draws, seed), time_s, level=level)

    # -- ArviZ ---------------------------------------------------------------------------------
    @property
    def idata(self) -> arviz.InferenceData:
        """ArviZ InferenceData (built on first access; layout in the module docstring)."""
        if self._idata is None:
            self._idata = self._build_idata()
        return self._idata

    def _build_idata(self) -> arviz.InferenceData:
        az = import_arviz()

        x = np.swapaxes(self.chain, 0, 1)  # (chain=walker, draw, ndim)
        values = self.problem.from_internal(x.reshape(-1, x.shape[-1]), include_fixed=False)
        posterior = {n: v.reshape(x.shape[0], x.shape[1]) for n, v in values.items()}
        attrs = {
            "problem": self.problem.name,
            "likelihood": self.problem.likelihood,
            "seed": int(self.seed),
            "n_burn": int(self.diagnostics.n_burn),
            "n_walkers": int(self.diagnostics.n_walkers),
            "diagnostics_json": json.dumps(self.diagnostics.to_dict()),
            "walkers_as_chains": "each emcee walker is stored as one chain; walkers are not independent",
            "inference_library": "emcee",
        }
        idata = az.from_dict(
            posterior=posterior,
            sample_stats={"lp": np.swapaxes(self.log_prob, 0, 1)},
            observed_data={"y": self.problem.data},
            constant_data={k: np.asarray(v) for k, v in self.problem.fixed.items()} or None,
            coords={"time_s": self.problem.time_s},
            dims={"y": ["time_s"]},
        )
        for group in idata.groups():
            idata[group].attrs.update(attrs)
        for p in self.problem.parameters:
            idata.posterior[p.name].attrs["units"] = p.unit
            idata.posterior[p.name].attrs["prior"] = p.prior.describe()
        idata.observed_data["y"].attrs["units"] = self.problem.data_unit
        return idata

    def to_netcdf(self, path: str | Path, *, engine: str = "h5netcdf") -> Path:
        """Write the InferenceData to a netCDF-4 file (one group per InferenceData group)."""
        path = Path(path)
        self.idata.to_netcdf(str(path), engine=engine)
        return path


def load_inference_data(path: str | Path, *, engine: str = "h5netcdf") -> arviz.InferenceData:
    """Read an InferenceData written by :meth:`PosteriorResult.to_netcdf` (loaded into memory)."""
    az = import_arviz()

    return az.InferenceData.from_netcdf(str(path), engine=engine)
