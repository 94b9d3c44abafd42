"""Posterior summaries in the format shared by the Laplace preview, MCMC and the CLI."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

__all__ = ["SUMMARY_KEYS", "summarize_draws"]

#: Keys of each parameter's summary: mean, standard deviation, 2.5 % and 97.5 % quantiles.
SUMMARY_KEYS = ("mean", "sd", "q025", "q975")


def summarize_draws(draws: Mapping[str, np.ndarray]) -> dict[str, dict[str, float]]:
    """``{name: {"mean", "sd", "q025", "q975"}}`` of one-dimensional draws (natural units).

    The sd uses ``ddof=1``; the quantiles are the equal-tailed 95 % interval (numpy's default
    linear interpolation).
    """
    out: dict[str, dict[str, float]] = {}
    for name, x in draws.items():
        x = np.asarray(x, dtype=float).ravel()
        q025, q975 = np.quantile(x, [0.025, 0.975])
        out[name] = {
            "mean": float(np.mean(x)),
            "sd": float(np.std(x, ddof=1)) if x.size > 1 else 0.0,
            "q025": float(q025),
            "q975": float(q975),
        }
    return out
