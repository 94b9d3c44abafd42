"""Where the model fails: diagnostics of a record against a model prediction.

Pure functions on plain arrays (seconds, metres, volts, hertz) that return small frozen
dataclasses — arrays for plots, summary numbers for tables — each with ``to_dict()`` giving
JSON-ready values (NaN as None; :func:`jsonable` converts anything else, e.g. a fingerprint
dict). Bad input raises :class:`beam.errors.BeamInputError` with a
one-line message.

==========================  ====================================================================
module                      what
==========================  ====================================================================
:mod:`.residuals`           residuals against the prediction band, out-of-band intervals,
                            coverage; RMSE and coverage in the calibration / prediction windows
:mod:`.spectra`             Welch PSD of residual and data, residual peaks, residual/data power
                            near each model mode
:mod:`.whiteness`           residual autocorrelation with its ±1.96/sqrt(n) band, Ljung–Box test
:mod:`.modal_id`            free-decay modal identification (matrix pencil): frequency, damping
                            ratio, amplitude per mode; matching against model modes
:mod:`.envelope`            band-pass + Hilbert envelope and instantaneous frequency of one mode:
                            backbone (frequency against amplitude), decay law
:mod:`.amplitude_id`        amplitude-resolved identification of a free decay: per mode A(t),
                            frequency and damping ratio against amplitude with their errors, at
                            the record's own stamps (phones, clipping, hum, a node, taps)
:mod:`.fingerprints`        dimensionless fingerprints of missing effects, a score and one
                            sentence per effect id
:mod:`.phase`               the phase lag of mode 1 after the window, block by block, and how
                            much of the held-out error it explains
==========================  ====================================================================
"""

from beam.residuals.amplitude_id import (
    BackboneSettings,
    CurveLaw,
    FreeDecayBackbone,
    ModeBackbone,
    SpectralLine,
    identify_backbone,
    record_backbone,
)
from beam.residuals.common import jsonable
from beam.residuals.envelope import (
    Backbone,
    DecayLaw,
    ModeAnalysis,
    ModeEnvelope,
    analyse_mode,
    backbone,
    check_backbone,
    decay_law,
    extrapolate,
    mode_envelope,
    spectral_drift,
)
from beam.residuals.fingerprints import (
    THRESHOLDS,
    effect_scores,
    explain,
    fingerprints,
)
from beam.residuals.modal_id import (
    DIFFERENCE_CONVENTION,
    IdentifiedModes,
    ModeMatch,
    ModeRow,
    compare_modes,
    difference_words,
    free_decay_start,
    identify_modes,
    matrix_pencil_poles,
    resolution_reasons,
    unseen_reason,
)
from beam.residuals.noise import NoiseFloor, noise_floor, record_noise_floor
from beam.residuals.phase import PhaseDrift, phase_drift
from beam.residuals.residuals import (
    BandResiduals,
    ExceedanceInterval,
    WindowScore,
    WindowScores,
    band_residuals,
    window_scores,
)
from beam.residuals.spectra import (
    ModePower,
    ResidualSpectrum,
    SpectralPeak,
    default_nperseg,
    residual_spectrum,
)
from beam.residuals.whiteness import (
    Whiteness,
    autocorrelation,
    default_max_lag,
    ljung_box,
    residual_whiteness,
)

__all__ = [
    "analyse_mode",
    "autocorrelation",
    "Backbone",
    "backbone",
    "BackboneSettings",
    "band_residuals",
    "BandResiduals",
    "check_backbone",
    "compare_modes",
    "CurveLaw",
    "decay_law",
    "DecayLaw",
    "default_max_lag",
    "default_nperseg",
    "DIFFERENCE_CONVENTION",
    "difference_words",
    "effect_scores",
    "ExceedanceInterval",
    "explain",
    "extrapolate",
    "fingerprints",
    "free_decay_start",
    "FreeDecayBackbone",
    "IdentifiedModes",
    "identify_backbone",
    "identify_modes",
    "jsonable",
    "ljung_box",
    "matrix_pencil_poles",
    "resolution_reasons",
    "mode_envelope",
    "ModeAnalysis",
    "ModeBackbone",
    "ModeEnvelope",
    "ModeMatch",
    "ModePower",
    "ModeRow",
    "noise_floor",
    "NoiseFloor",
    "phase_drift",
    "PhaseDrift",
    "record_backbone",
    "record_noise_floor",
    "residual_spectrum",
    "residual_whiteness",
    "ResidualSpectrum",
    "spectral_drift",
    "SpectralLine",
    "SpectralPeak",
    "THRESHOLDS",
    "unseen_reason",
    "Whiteness",
    "window_scores",
    "WindowScore",
    "WindowScores",
]
