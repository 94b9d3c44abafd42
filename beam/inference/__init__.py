"""Bayesian inference engine shared by the toy oscillator and the beam calibration.

Headless (numpy, scipy, emcee, ArviZ only). The pieces, in the order a calibration uses them:

* :mod:`~beam.inference.priors` — :class:`Uniform`, :class:`LogUniform`, :class:`Normal`,
  :class:`LogNormal` priors with bounds and internal (log) sampling coordinates;
* :mod:`~beam.inference.problem` — :class:`Parameter`, :class:`Problem` (priors, vectorised
  forward model, data, likelihood kind, fixed values, initial-guess hook);
* :mod:`~beam.inference.likelihood` — ``"iid"`` and exact ``"ar1"`` Gaussian likelihoods;
* :mod:`~beam.inference.optimize` — multi-start MAP (:func:`find_map`);
* :mod:`~beam.inference.laplace` — Laplace preview (:func:`preview`, :class:`LaplaceResult`);
* :mod:`~beam.inference.sampling` — emcee ensemble streamed as a generator
  (:class:`EnsembleRun`) or run to a target ESS (:func:`sample_posterior`);
* :mod:`~beam.inference.convergence` — acceptance, autocorrelation time, ESS, R-hat;
* :mod:`~beam.inference.results` — :class:`PosteriorResult` with ArviZ InferenceData and
  netCDF output;
* :mod:`~beam.inference.predictive` — credible / prediction bands, RMSE and coverage.
"""

from beam.inference._arviz import import_arviz
from beam.inference.convergence import Diagnostics
from beam.inference.laplace import LaplaceResult, laplace, preview
from beam.inference.likelihood import (
    AR1_COEFFICIENT,
    LIKELIHOODS,
    NOISE_SD,
    log_likelihood,
)
from beam.inference.optimize import MapResult, default_initial_guesses, find_map
from beam.inference.predictive import PredictiveBands, predictive_bands
from beam.inference.priors import LogNormal, LogUniform, Normal, Prior, Uniform
from beam.inference.problem import ForwardModel, Parameter, Problem
from beam.inference.results import PosteriorResult, load_inference_data
from beam.inference.sampling import EnsembleRun, Progress, sample_posterior
from beam.inference.summaries import summarize_draws

__all__ = [
    "AR1_COEFFICIENT",
    "LIKELIHOODS",
    "NOISE_SD",
    "Diagnostics",
    "EnsembleRun",
    "ForwardModel",
    "LaplaceResult",
    "LogNormal",
    "LogUniform",
    "MapResult",
    "Normal",
    "Parameter",
    "PosteriorResult",
    "PredictiveBands",
    "Prior",
    "Problem",
    "Progress",
    "Uniform",
    "default_initial_guesses",
    "find_map",
    "import_arviz",
    "laplace",
    "load_inference_data",
    "log_likelihood",
    "predictive_bands",
    "preview",
    "sample_posterior",
    "summarize_draws",
]
