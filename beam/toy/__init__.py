"""Toy periodic model with model discrepancy: what an i.i.d.-noise calibration gets wrong.

Truth and model
---------------
The data are ``y(t) = A sin(2π f t + φ) + δ d(t) + ε(t)`` with ``ε ~ N(0, σ²)`` i.i.d.; the
calibrated model is ``A sin(2π f t + φ)``, so ``δ d(t)`` is physics the model misses
(Kennedy & O'Hagan 2001; Brynjarsdóttir & O'Hagan 2014). Discrepancy shapes ``d(t)``:

``harmonic``  ``sin(4π f t + φ)`` — distortion at twice the frequency;
``tone``      ``sin(2π · 1.37 f t)`` — an unmodelled second mode;
``drift``     ``t / 5 s`` — a baseline drift reaching 1 at t = 5 s (:data:`DRIFT_TIME_S`, a fixed
              time constant: the truth does not change when the calibration window moves).

The model is calibrated on ``[0, T_window]`` and judged on the held-out ``(T_window, horizon]``.

Parameters and priors (data are in an arbitrary "data unit", du)
-----------------------------------------------------------------
``amplitude``       log-uniform on [0.01, 100] du. Restricting ``A > 0`` removes the sign
                    symmetry ``A sin(x + φ) = (-A) sin(x + φ + π)``.
``frequency_Hz``    uniform on [0.2, 5] Hz (well below the 10 Hz Nyquist frequency of the
                    default 20 samples/s).
``phase_rad``       uniform on a 2π-long branch ``[c - π, c + π]``, c = 0 by default, i.e.
                    (-π, π]. The model is 2π-periodic in φ and the prior is uniform on the
                    circle, so the choice of branch does not change the posterior, only where
                    the cut lies; :func:`run_toy` moves the branch (c = π) when the spectral
                    estimate of φ is within π/2 of ±π, so the posterior never straddles the
                    cut. With ``A > 0`` and one branch the posterior is unimodal.
``noise_sd``        log-uniform on [0.001, 10] du; estimated (sampled), not marginalised.
``ar1_coefficient`` (``--likelihood ar1`` only) uniform on (-1, 1), the whole stationary
                    range: the AR(1) correlation between consecutive samples. A smooth
                    discrepancy gives positive values; negative ones are allowed because
                    nothing in the likelihood requires rho >= 0. Sampled in the logit
                    coordinate (:class:`~beam.inference.priors.Uniform`): a smooth discrepancy
                    pushes rho towards 1, where a bounded coordinate would make the joint
                    posterior with ``noise_sd`` a sharply curved ridge (marginal sd ~
                    innovation sd / sqrt(1 - rho²)) that the ensemble explores slowly.

The "truth" of the noise parameters is that of the measurement noise (``noise_sd = σ``,
``ar1_coefficient = 0``): the discrepancy is not noise, which is exactly why an estimated
``noise_sd`` absorbs it.
"""


from beam.toy.problem import (
    phase_branch_centre,
    sine_model,
    spectral_initial_guesses,
    toy_problem,
)
from beam.toy.run import (
    ToyResult,
    calibration_problem,
    default_sweep_windows,
    run_toy,
    sweep_windows,
)
from beam.toy.scenario import (
    AMPLITUDE_PRIOR,
    AR1_PRIOR,
    DRIFT_TIME_S,
    FREQUENCY_PRIOR_HZ,
    KINDS,
    MODEL_PARAMETERS,
    NOISE_PRIOR,
    TONE_RATIO,
    UNITS,
    ToyData,
    ToyScenario,
    discrepancy_shape,
    simulate,
    wrap_phase,
)

__all__ = [
    "AMPLITUDE_PRIOR",
    "AR1_PRIOR",
    "DRIFT_TIME_S",
    "FREQUENCY_PRIOR_HZ",
    "KINDS",
    "MODEL_PARAMETERS",
    "NOISE_PRIOR",
    "TONE_RATIO",
    "UNITS",
    "ToyData",
    "ToyResult",
    "ToyScenario",
    "calibration_problem",
    "default_sweep_windows",
    "discrepancy_shape",
    "phase_branch_centre",
    "run_toy",
    "simulate",
    "sine_model",
    "spectral_initial_guesses",
    "sweep_windows",
    "toy_problem",
    "wrap_phase",
]

