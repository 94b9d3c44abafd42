"""Beam discrepancy explorer: headless library (no UI imports).

Euler–Bernoulli cantilever with a piezoelectric patch, discretised by Galerkin's method with
cubic B-splines (double knots at the patch ends); a catalogue of optional physical effects; a
fast modal response; measurement files; Bayesian inference; residual diagnostics.
"""

from beam.errors import BeamInputError

__all__ = ["BeamInputError"]
__version__ = "0.1.0"
