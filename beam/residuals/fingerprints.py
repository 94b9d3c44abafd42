"""Fingerprints of missing physics: a few dimensionless numbers, and one sentence per effect.

:func:`fingerprints` condenses the diagnostics — the modal table (identified against model
modes, :func:`beam.residuals.compare_modes`), the backbone and decay of mode 1, the residual
spectrum and whiteness — into a flat dict of numbers (NaN where an input is missing).
:func:`effect_scores` turns them into one number per candidate effect
(:data:`beam.physics.effects.CANDIDATE_EFFECTS`)
(0: no sign; 1: at the threshold of notice; larger: stronger), and :func:`explain` into one
sentence per effect that quotes the measured numbers. What each effect leaves behind, its
threshold and its sentence are the effect's own
(:attr:`beam.physics.effects.effect.Effect.fingerprint`, in each effect's module); the shared
readings of the frequency errors e_k = f_data,k / f_model,k − 1 are
:mod:`beam.physics.effects.fingerprint`.

The damping law zeta = a / omega + b omega (Rayleigh: a = alpha / 2, b = beta / 2) is also fitted to
the identified and to the model modes (non-negative least squares).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
import scipy.optimize

from beam.physics.effects import CANDIDATE_EFFECTS, EFFECTS
from beam.physics.effects.fingerprint import TIP_SHARE  # noqa: F401 - re-exported
from beam.residuals.envelope import Backbone, DecayLaw
from beam.residuals.modal_id import ModeMatch
from beam.residuals.spectra import ResidualSpectrum
from beam.residuals.whiteness import Whiteness

__all__ = ["THRESHOLDS", "effect_scores", "explain", "fingerprints"]

NAN = float("nan")

#: Size of each fingerprint that makes its effect's score 1 ("worth noticing"), by candidate effect.
THRESHOLDS: dict[str, float] = {e: EFFECTS[e].fingerprint.threshold for e in CANDIDATE_EFFECTS}


def _finite(values: Sequence[float]) -> list[float]:
    return [float(v) for v in values if v is not None and math.isfinite(v)]


def _mean(values: Sequence[float]) -> float:
    values = _finite(values)
    return float(np.mean(values)) if values else NAN


def _damping_law(omega: np.ndarray, zeta: np.ndarray) -> tuple[float, float]:
    """(a, b) of zeta = a / omega + b omega by non-negative least squares, relative to each zeta."""
    if omega.size < 2:
        return NAN, NAN
    design = np.column_stack([1 / omega, omega]) / zeta[:, None]
    (a, b), _ = scipy.optimize.nnls(design, np.ones_like(zeta))
    return float(a), float(b)


def _exponent(omega: np.ndarray, zeta: np.ndarray) -> float:
    """Slope of log zeta against log omega (−1: air, +1: Kelvin–Voigt)."""
    if omega.size < 2:
        return NAN
    return float(np.polyfit(np.log(omega), np.log(zeta), 1)[0])


def fingerprints(
    comparison: Sequence[ModeMatch],
    *,
    backbone: Backbone | None = None,
    decay: DecayLaw | None = None,
    spectrum: ResidualSpectrum | None = None,
    whiteness: Whiteness | None = None,
    modes: int = 3,
    free_decay: bool | None = None,
) -> dict[str, float]:
    """Dimensionless fingerprints of missing physics (NaN where an input is missing).

    Parameters
    ----------
    comparison : sequence of ModeMatch
        Identified against model modes, from :func:`beam.residuals.compare_modes`.
    backbone, decay : optional
        Of mode 1, from :func:`beam.residuals.analyse_mode`.
    spectrum : ResidualSpectrum, optional
        From :func:`beam.residuals.residual_spectrum`.
    whiteness : Whiteness, optional
        From :func:`beam.residuals.residual_whiteness`.
    modes : int
        Modes used for the patterns (the first ``modes`` model modes, default 3).
    free_decay : bool, optional
        Whether the record is a free decay (a backbone can only be read from one); None: not
        known.

    Returns
    -------
    dict of str to float
        ``frequency_error_mode{k}``, ``damping_error_mode{k}`` (data / model − 1, per mode);
        ``damping_mode2_out_of_line`` (the same for log(1 + damping error));
        ``frequency_error_mean`` (ē over the matched modes); ``mode1_deficit`` (r, see the
        module notes); ``mode1_deficit_share`` (r / |ē|); ``mode2_out_of_line`` (distance of
        e_2 outside [min(e_1, e_3), max(e_1, e_3)], signed); ``damping_growth_data``,
        ``damping_growth_model`` (zeta_k / zeta_1 for the highest matched mode k <= ``modes``,
        which is ``damping_growth_mode``),
        ``damping_growth_excess`` (their ratio); ``damping_exponent_data``,
        ``damping_exponent_model`` (slope of log zeta against log omega);
        ``damping_law_a_data_rad_s``, ``damping_law_b_data_s`` and the same for the model
        (zeta = a / omega + b omega); ``amplitude_frequency_shift`` and
        ``backbone_slope_Hz_per_m``, ``backbone_slope_z`` (slope / standard error);
        ``decay_rate_change``, ``decay_r_squared``, ``decay_rms_log_residual``;
        ``residual_power_fraction``, ``residual_to_data_power_mode{k}``,
        ``residual_peak_mode``, ``residual_peak_offset``; ``ljung_box_p_value``,
        ``acf_fraction_outside``; ``free_decay`` (1 or 0, NaN when not known).
    """
    rows = [row for row in comparison if row.mode <= modes]
    fp: dict[str, float] = {}
    errors: dict[int, float] = {}
    for row in rows:
        e = row.frequency_data_Hz / row.frequency_model_Hz - 1 if row.matched else NAN
        fp[f"frequency_error_mode{row.mode}"] = float(e)
        fp[f"damping_error_mode{row.mode}"] = float(row.damping_data / row.damping_model - 1) if (
            row.matched and row.damping_model > 0) else NAN
        if math.isfinite(e):
            errors[row.mode] = float(e)
    mean_error = _mean(list(errors.values()))
    fp["frequency_error_mean"] = mean_error
    deficit = NAN
    if 1 in errors:
        deficit = _mean([(1 + errors[k]) / (1 + errors[1]) - 1 for k in (2, 3) if k in errors])
    fp["mode1_deficit"] = deficit
    fp["mode1_deficit_share"] = deficit / abs(mean_error) if math.isfinite(deficit) and abs(mean_error) > 1e-4 else NAN
    out_of_line = NAN
    if all(k in errors for k in (1, 2, 3)):
        low, high = sorted((errors[1], errors[3]))
        out_of_line = min(errors[2] - low, 0.0) + max(errors[2] - high, 0.0)
    fp["mode2_out_of_line"] = out_of_line
    log_damping = {k: math.log1p(fp.get(f"damping_error_mode{k}", NAN)) for k in (1, 2, 3)
                   if math.isfinite(fp.get(f"damping_error_mode{k}", NAN)) and fp[f"damping_error_mode{k}"] > -1}
    damping_out_of_line = NAN
    if len(log_damping) == 3:
        low, high = sorted((log_damping[1], log_damping[3]))
        damping_out_of_line = min(log_damping[2] - low, 0.0) + max(log_damping[2] - high, 0.0)
    fp["damping_mode2_out_of_line"] = damping_out_of_line

    damped = [r for r in rows if r.matched and r.damping_data > 0 and r.damping_model > 0]
    growth_data = growth_model = growth_mode = NAN
    if len(damped) >= 2 and damped[0].mode == 1:
        first, last = damped[0], damped[-1]
        growth_data = last.damping_data / first.damping_data
        growth_model = last.damping_model / first.damping_model
        growth_mode = float(last.mode)
    fp["damping_growth_mode"] = growth_mode
    fp["damping_growth_data"] = growth_data
    fp["damping_growth_model"] = growth_model
    fp["damping_growth_excess"] = growth_data / growth_model
    omega_data = np.array([2 * np.pi * r.frequency_data_Hz for r in damped])
    omega_model = np.array([2 * np.pi * r.frequency_model_Hz for r in damped])
    zeta_data = np.array([r.damping_data for r in damped])
    zeta_model = np.array([r.damping_model for r in damped])
    fp["damping_exponent_data"] = _exponent(omega_data, zeta_data)
    fp["damping_exponent_model"] = _exponent(omega_model, zeta_model)
    fp["damping_law_a_data_rad_s"], fp["damping_law_b_data_s"] = _damping_law(omega_data, zeta_data)
    fp["damping_law_a_model_rad_s"], fp["damping_law_b_model_s"] = _damping_law(omega_model, zeta_model)

    trusted = backbone is not None and backbone.reliable  # an unreliable backbone's shift is unknown
    fp["amplitude_frequency_shift"] = backbone.relative_shift if trusted else NAN
    fp["backbone_slope_Hz_per_m"] = backbone.slope_Hz_per_m if trusted else NAN
    fp["backbone_slope_z"] = (
        backbone.slope_Hz_per_m / backbone.slope_stderr_Hz_per_m
        if trusted and backbone.slope_stderr_Hz_per_m > 0 else NAN
    )
    fp["decay_rate_change"] = decay.decay_rate_change if decay is not None else NAN
    fp["decay_r_squared"] = decay.r_squared if decay is not None else NAN
    fp["decay_rms_log_residual"] = decay.rms_log_residual if decay is not None else NAN

    fp["residual_power_fraction"] = spectrum.residual_power_fraction if spectrum is not None else NAN
    if spectrum is not None:
        for power in spectrum.modes[:modes]:
            fp[f"residual_to_data_power_mode{power.mode}"] = power.ratio
    top = spectrum.peaks[0] if spectrum is not None and spectrum.peaks else None
    fp["residual_peak_mode"] = float(top.nearest_mode) if top is not None and top.nearest_mode else NAN
    fp["residual_peak_offset"] = top.offset_from_mode if top is not None else NAN
    fp["ljung_box_p_value"] = whiteness.p_value if whiteness is not None else NAN
    fp["acf_fraction_outside"] = whiteness.fraction_outside if whiteness is not None else NAN
    fp["free_decay"] = NAN if free_decay is None else float(bool(free_decay))
    return {key: float(value) for key, value in fp.items()}


def effect_scores(fp: Mapping[str, float]) -> dict[str, float]:
    """One score per effect id of :data:`beam.physics.effects.CANDIDATE_EFFECTS`: 0 no sign, >= 1 worth noticing.

    Each score is the effect's own (:attr:`beam.physics.effects.effect.Fingerprint.score`): the
    size of its fingerprint divided by its threshold (:data:`THRESHOLDS`); a lowering of all modes
    is split between ``clamp_compliance`` (the uniform share) and ``tip_mass`` (the mode-1 share)
    by r / |ē| around :data:`TIP_SHARE`. NaN fingerprints give 0.
    """
    return {effect_id: float(EFFECTS[effect_id].fingerprint.score(fp)) for effect_id in CANDIDATE_EFFECTS}


def explain(fp: Mapping[str, float]) -> dict[str, str]:
    """One sentence per effect id of :data:`beam.physics.effects.CANDIDATE_EFFECTS`, quoting the fingerprints.

    A sentence says what was measured and whether it points to the effect (its score from
    :func:`effect_scores` >= 1) or not, or that the data needed to judge is missing
    (:attr:`beam.physics.effects.effect.Fingerprint.explain`).
    """
    scores = effect_scores(fp)
    return {effect_id: EFFECTS[effect_id].fingerprint.explain(fp, scores[effect_id]) for effect_id in CANDIDATE_EFFECTS}
