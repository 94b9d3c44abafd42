"""The defaults of a calibration: the one place they are set.

:class:`beam.calibration.spec.CalibrationSpec` reads them when it is built (its field
defaults), and so do the command line, the dashboard and the model builder
(:func:`beam.calibration.pipeline.make_setup`): change one here and every front end sees it. This
module imports nothing.
"""

__all__ = ["AUTO_MODES", "DEFAULT_CALIBRATION_MODES", "DEFAULT_EFFECTS", "DEFAULT_LIKELIHOOD", "DEFAULT_MAX_STEPS", "DEFAULT_MODES",
           "DEFAULT_SEED", "DEFAULT_TARGET_ESS", "DEFAULT_WINDOW_FRACTION", "LIKELIHOOD_NAMES", "SPEC_DEFAULTS",
           "default_window"]

#: The number of modes chosen from the record (:func:`beam.calibration.modes.suggest_modes`).
AUTO_MODES = "auto"
#: Effects of the default model (besides the base EI and k_p).
DEFAULT_EFFECTS: tuple[str, ...] = ("air_damping", "kelvin_voigt")
#: The number of modes a calibration retains unless told: chosen from the record.
DEFAULT_CALIBRATION_MODES = AUTO_MODES
#: Modes retained when ``"auto"`` cannot choose (a record too short for a spectrum) and for a free
#: response (:mod:`beam.calibration.modes`); the model builder's default.
DEFAULT_MODES = 4
#: The default calibration window: this fraction of the record from its start.
DEFAULT_WINDOW_FRACTION = 0.3
#: Noise model.
DEFAULT_LIKELIHOOD = "iid"
#: The noise models a calibration offers (:data:`beam.inference.LIKELIHOODS`' names; a test checks they agree).
LIKELIHOOD_NAMES = ("iid", "ar1")
#: Seed of the sampler and of the band draws.
DEFAULT_SEED = 0
#: Bulk ESS every parameter must reach.
DEFAULT_TARGET_ESS = 1000.0
#: Cap on ensemble steps.
DEFAULT_MAX_STEPS = 20000

#: Field of :class:`~beam.calibration.spec.CalibrationSpec` -> name of its default here.
SPEC_DEFAULTS = {
    "effects": "DEFAULT_EFFECTS",
    "modes": "DEFAULT_CALIBRATION_MODES",
    "likelihood": "DEFAULT_LIKELIHOOD",
    "seed": "DEFAULT_SEED",
    "target_ess": "DEFAULT_TARGET_ESS",
    "max_steps": "DEFAULT_MAX_STEPS",
    "window_fraction": "DEFAULT_WINDOW_FRACTION",
}


def default_window(first_s: float, last_s: float, fraction: float | None = None) -> tuple[float, float]:
    """The default calibration window of a record from ``first_s`` to ``last_s`` (s): its first
    ``fraction`` (default :data:`DEFAULT_WINDOW_FRACTION`, read when called)."""
    share = DEFAULT_WINDOW_FRACTION if fraction is None else fraction
    return float(first_s), float(first_s + share * (last_s - first_s))
