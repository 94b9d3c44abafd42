"""Benchmark of the diagnostics (run on demand: ``python tests/benchmarks/bench_diagnostics.py``).

On the bundled beam (assets/b1tapih.toml), struck by a 3 ms, 20 V pulse and ringing down for
500, 4,700 and 10,000 samples at 1 kHz with the bundled record's noise: modal identification of
the free decay, the envelope analysis of the lowest mode with 10 periods in the record (mode 2 in the shortest), the residual spectrum and the whiteness test
(residual: data − the clean simulation). Timings are the best of several repeats. The matrix pencil's QR is BLAS-bound: on
a machine whose cores are busy, set OPENBLAS_NUM_THREADS=1 (or OMP_NUM_THREADS=1) for stable
figures.
"""

from __future__ import annotations

import sys
import timeit
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from beam.io.config import load_config
from beam.physics.model import BeamModel
from beam.residuals import (
    analyse_mode,
    identify_modes,
    residual_spectrum,
    residual_whiteness,
)

RATE = 1000.0
NOISE_M = 1.2e-5  # the bundled record's sensor noise


def best_seconds(function, number: int = 1, repeat: int = 5) -> float:
    return min(timeit.repeat(function, number=number, repeat=repeat)) / number


def main() -> None:
    config = load_config(ROOT / "assets" / "b1tapih.toml")
    model = BeamModel(config.geometry, config.effects, config.intervals, config.knots)
    frequencies, _ = model.natural_modes(config.parameters, 4)
    truth = np.round(frequencies, 2)
    print(f"{'samples':>8} {'identify':>9} {'envelope':>9} {'spectrum':>9} {'whiteness':>9}  modes found (truth {truth})")
    for n in (500, 4700, 10_000):
        t = np.arange(n) / RATE
        v = np.zeros(n)
        v[:3] = 20.0
        clean = model.response(config.parameters, v, 1 / RATE, modes=6)
        y = clean + np.random.default_rng(0).normal(0, NOISE_M, n)
        found = identify_modes(t, y, v)
        mode = next(f for f in found.frequency_Hz if f * n / RATE >= 10)  # the lowest mode with 10 periods
        timings = [
            best_seconds(lambda t=t, y=y, v=v: identify_modes(t, y, v)),
            best_seconds(lambda t=t, y=y, v=v, f=mode: analyse_mode(t, y, f, v)),
            best_seconds(lambda t=t, y=y, c=clean: residual_spectrum(t, y, c, frequencies)),
            best_seconds(lambda y=y, c=clean: residual_whiteness(y - c)),
        ]
        cells = " ".join(f"{1e3 * s:7.1f}ms" for s in timings)
        print(f"{n:>8} {cells}  {np.round(found.frequency_Hz[:4], 2)}")


if __name__ == "__main__":
    main()
