"""Fingerprints of missing physics: a few dimensionless numbers, and one sentence per effect.

:func:`fingerprints` condenses the diagnostics — the modal table (identified against model
modes, :func:`beam.residuals.compare_modes`), the backbone and decay of mode 1, the residual
spectrum and whiteness — into a flat dict of numbers (NaN where an input is missing).
:func:`effect_scores` turns them into one number per candidate effect
(:data:`beam.physics.effects.CANDIDATE_EFFECTS`)
(0: no sign; 1: at the threshold of notice; larger: stronger), and :func:`explain` into one
sentence per effect that quotes the measured numbers.

What each effect leaves behind (e_k = f_data,k / f_model,k − 1, frequency error of mode k):

* ``tip_mass`` — every mode falls, mode 1 most: r = mean over k = 2, 3 of
  (1 + e_k) / (1 + e_1) − 1 > 0 ("mode 1 low relative to modes 2–3"). r does not change when
  the bending stiffness is rescaled, so it survives a calibration of EI.
* ``clamp_compliance`` — every mode falls by a similar fraction (to first order a root spring
  k_theta lowers all omega² by the same 4 EI / (k_theta L)): mean error ē < 0 with r small
  against |ē|. A lower EI does the same, so after EI is calibrated this pattern fades.
  A small tip mass and a soft clamp lower the modes in nearly the same pattern (both shift
  all omega² alike to first order); they separate only when r is a clear share of |ē|.
* ``patch_stiffening`` — local mass and stiffness shift the modes unevenly: the error of
  mode 2 lies outside the range of modes 1 and 3 (for the beams here mode 2 falls most).
* ``patch_damping`` — damping added on the patch alone damps each mode by its share of
  curvature there, unevenly: the damping error of mode 2 (log of data / model) lies outside the
  range of modes 1 and 3.
* ``kelvin_voigt`` — strain-rate damping gives zeta ∝ omega: the measured zeta_k / zeta_1 grows
  with frequency faster than the model's.
* ``air_damping`` — velocity damping gives zeta ∝ 1 / omega: the measured ratio falls faster.
* ``tip_cubic_spring`` — the frequency of mode 1 rises with amplitude (hardening backbone).
* ``quadratic_drag`` — a damping that grows with the amplitude: the decay of mode 1 slows as it
  dies out, its log-envelope bends (the decay law's ``decay_rate_change`` < 0).

The damping law zeta = a / omega + b omega (Rayleigh: a = alpha / 2, b = beta / 2) is also fitted to
the identified and to the model modes (non-negative least squares).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
import scipy.optimize

from beam.physics.effects import CANDIDATE_EFFECTS
from beam.residuals.envelope import Backbone, DecayLaw
from beam.residuals.modal_id import ModeMatch, difference_words
from beam.residuals.spectra import ResidualSpectrum
from beam.residuals.whiteness import Whiteness

__all__ = ["THRESHOLDS", "effect_scores", "explain", "fingerprints"]

NAN = float("nan")

#: Size of each fingerprint that makes its effect's score 1 ("worth noticing").
THRESHOLDS: dict[str, float] = {
    "tip_mass": 0.02,  # mode 1 two percent low relative to modes 2–3
    "clamp_compliance": 0.02,  # all modes two percent low
    "effective_length": 0.02,  # all modes two percent high alike (f ∝ 1 / L²: a shorter free length)
    "patch_stiffening": 0.01,  # mode 2 one percent out of line with modes 1 and 3
    "kelvin_voigt": math.log(1.5),  # zeta_k / zeta_1 grows 1.5 x more than the model's
    "air_damping": math.log(1.5),  # ... or falls 1.5 x more
    "patch_damping": math.log(1.3),  # zeta_2 30 % out of line with modes 1 and 3
    "tip_cubic_spring": 0.005,  # mode-1 frequency 0.5 % higher at the largest amplitude
    "quadratic_drag": 0.25,  # mode-1 decay rate 25 % lower at the end of the decay than at its start
}
#: r / |ē| at which a lowering of the modes counts half as uniform (clamp), half as mode-1 (tip mass).
TIP_SHARE = 0.2


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


def _get(fp: Mapping[str, float], key: str) -> float:
    value = fp.get(key, NAN)
    return float(value) if value is not None else NAN


def effect_scores(fp: Mapping[str, float]) -> dict[str, float]:
    """One score per effect id of :data:`beam.physics.effects.CANDIDATE_EFFECTS`: 0 no sign, >= 1 worth noticing.

    Each score is the size of the effect's fingerprint divided by :data:`THRESHOLDS`; a lowering
    of all modes is split between ``clamp_compliance`` (the uniform share) and ``tip_mass``
    (the mode-1 share) by r / |ē| around :data:`TIP_SHARE`. NaN fingerprints give 0.
    """
    def nz(value: float) -> float:
        return value if math.isfinite(value) else 0.0

    deficit = nz(_get(fp, "mode1_deficit"))
    lowering = max(-nz(_get(fp, "frequency_error_mean")), 0.0)
    share = deficit / lowering if lowering > 1e-4 else 0.0
    uniform = 1.0 / (1.0 + (abs(share) / TIP_SHARE) ** 4)
    # every mode raised alike: the strip vibrates as if shorter than stated (f ∝ 1 / L²); a lowering
    # alike is the compliant clamp's (a bar pivoting in the jaw is a longer free length by another name)
    raising = max(nz(_get(fp, "frequency_error_mean")), 0.0)
    alike = 1.0 / (1.0 + (abs(deficit / raising if raising > 1e-4 else 0.0) / TIP_SHARE) ** 4)
    growth = _get(fp, "damping_growth_excess")
    log_growth = math.log(growth) if math.isfinite(growth) and growth > 0 else 0.0
    shift = nz(_get(fp, "amplitude_frequency_shift"))
    significant = abs(nz(_get(fp, "backbone_slope_z"))) > 2
    scores = {
        "air_damping": max(-log_growth, 0.0) / THRESHOLDS["air_damping"],
        "kelvin_voigt": max(log_growth, 0.0) / THRESHOLDS["kelvin_voigt"],
        "tip_mass": max(deficit, 0.0) / THRESHOLDS["tip_mass"],
        "clamp_compliance": lowering * uniform / THRESHOLDS["clamp_compliance"],
        "effective_length": raising * alike / THRESHOLDS["effective_length"],
        "patch_stiffening": abs(nz(_get(fp, "mode2_out_of_line"))) / THRESHOLDS["patch_stiffening"],
        "patch_damping": abs(nz(_get(fp, "damping_mode2_out_of_line"))) / THRESHOLDS["patch_damping"],
        "tip_cubic_spring": max(shift, 0.0) / THRESHOLDS["tip_cubic_spring"] if significant else 0.0,
        "quadratic_drag": max(-nz(_get(fp, "decay_rate_change")), 0.0) / THRESHOLDS["quadratic_drag"],
    }
    return {effect_id: float(scores[effect_id]) for effect_id in CANDIDATE_EFFECTS}


def _pct(value: float, signed: bool = True) -> str:
    """A fraction as a percentage with one decimal (no "-0.0")."""
    rounded = round(100 * value, 1) + 0.0
    return f"{rounded:+.1f} %" if signed and rounded != 0 else f"{rounded:.1f} %"


def _low(value: float) -> str:
    """A deficit worded once, without a sign: ``0.026`` -> ``"2.6 % low"``, ``-0.01`` -> ``"1.0 % high"``, ``1e-5`` -> ``"0.0 % off"``."""
    shown = _pct(abs(value), False)
    return f"{shown} off" if shown == "0.0 %" else f"{shown} {'low' if value > 0 else 'high'}"


def explain(fp: Mapping[str, float]) -> dict[str, str]:
    """One sentence per effect id of :data:`beam.physics.effects.CANDIDATE_EFFECTS`, quoting the fingerprints.

    A sentence says what was measured and whether it points to the effect (its score from
    :func:`effect_scores` >= 1) or not, or that the data needed to judge is missing.
    """
    scores = effect_scores(fp)
    errors = [(k, _get(fp, f"frequency_error_mode{k}")) for k in (1, 2, 3)]
    measured = [f"mode {k} {difference_words(100 * e)}" for k, e in errors if math.isfinite(e)]
    errors_text = f"measured against the model: {', '.join(measured)}" if measured else "no mode matched"
    out: dict[str, str] = {}

    growth_data, growth_model = _get(fp, "damping_growth_data"), _get(fp, "damping_growth_model")
    if math.isfinite(growth_data) and math.isfinite(growth_model):
        k = int(_get(fp, "damping_growth_mode"))
        ratio = f"ζ{k}/ζ1 = {growth_data:.2g} measured against {growth_model:.2g} in the model"
        out["kelvin_voigt"] = (
            f"measured damping ratios grow with frequency faster than the model allows ({ratio}): "
            "strain-rate (Kelvin–Voigt) damping, ζ ∝ ω, is missing or too weak"
            if scores["kelvin_voigt"] >= 1 else
            f"damping does not grow with frequency faster than the model allows ({ratio}): "
            "no sign of missing strain-rate (Kelvin–Voigt) damping"
        )
        out["air_damping"] = (
            f"measured damping ratios fall with frequency faster than the model allows ({ratio}): "
            "velocity-proportional (air) damping, ζ ∝ 1/ω, is missing or too weak"
            if scores["air_damping"] >= 1 else
            f"damping does not fall with frequency faster than the model allows ({ratio}): "
            "no sign of missing air damping"
        )
    else:
        missing = "fewer than two modes with damping were identified, so how damping varies with frequency is unknown"
        out["kelvin_voigt"] = f"{missing}: Kelvin–Voigt damping cannot be judged from the modes"
        out["air_damping"] = f"{missing}: air damping cannot be judged from the modes"

    deficit, mean_error = _get(fp, "mode1_deficit"), _get(fp, "frequency_error_mean")
    if math.isfinite(deficit):
        out["tip_mass"] = (
            f"mode 1 is {_pct(deficit, False)} low relative to modes 2–3 ({errors_text}): "
            "a mass at the tip lowers the first mode most"
            if scores["tip_mass"] >= 1 else
            f"mode 1 is not clearly low relative to modes 2–3 (it is {_low(deficit)}; {errors_text}): "
            "no sign of a missing tip mass"
        )
        out["clamp_compliance"] = (
            f"all modes are low by a similar fraction (measured against the model: {difference_words(100 * mean_error)} on "
            f"average, mode 1 only {_pct(deficit, False)} more): a compliant clamp (or a lower bending stiffness) lowers every mode alike"
            if scores["clamp_compliance"] >= 1 else
            f"the modes are {_pct(-mean_error, False)} low on average but not alike (mode 1 a further "
            f"{_pct(deficit, False)} low relative to modes 2–3): the pattern fits a tip mass better than a compliant clamp"
            if -mean_error >= THRESHOLDS["clamp_compliance"] and deficit > 0 else
            f"the modes are not lowered alike (measured against the model: {difference_words(100 * mean_error)} on "
            f"average, mode 1 {_low(deficit)} relative to modes 2–3): no sign of a compliant clamp"
        )
        out["effective_length"] = (
            f"all modes are high by a similar fraction (measured against the model: {difference_words(100 * mean_error)} "
            f"on average): a strip shorter than stated (the clamp holding more of it) raises every mode alike, f ∝ 1 / L²"
            if scores["effective_length"] >= 1 else
            f"the modes are not raised alike (measured against the model: {difference_words(100 * mean_error)} on "
            f"average): no sign of a free length shorter than the stated one"
        )
    else:
        out["effective_length"] = f"mode 1 and mode 2 or 3 must both be identified to judge the free length ({errors_text})"
        out["tip_mass"] = f"mode 1 and mode 2 or 3 must both be identified to judge a tip mass ({errors_text})"
        out["clamp_compliance"] = (
            f"mode 1 and mode 2 or 3 must both be identified to judge the clamp ({errors_text})"
        )

    out_of_line = _get(fp, "mode2_out_of_line")
    if math.isfinite(out_of_line):
        out["patch_stiffening"] = (
            f"{errors_text[0].upper()}{errors_text[1:]}: mode 2 does not follow modes 1 and 3, it sits "
            f"{100 * abs(out_of_line):.1f} percentage points {'below' if out_of_line < 0 else 'above'} the nearer of "
            "them. Added mass and stiffness on the patch region shift the modes unevenly like this"
            if scores["patch_stiffening"] >= 1 else
            f"the frequency errors change smoothly with mode number ({errors_text}): "
            "no sign of a stiffer, heavier patch"
        )
    else:
        out["patch_stiffening"] = f"modes 1, 2 and 3 must all be identified to judge patch stiffening ({errors_text})"

    damping_out = _get(fp, "damping_mode2_out_of_line")
    if math.isfinite(damping_out):
        out["patch_damping"] = (
            f"the damping of mode 2 does not follow modes 1 and 3: measured against the model, it is "
            f"{math.exp(damping_out):.2f} times the nearer of theirs. Damping added on the patch region damps "
            "the modes unevenly like this"
            if scores["patch_damping"] >= 1 else
            "the damping errors change smoothly with mode number: no sign of damping added on the patch"
        )
    else:
        out["patch_damping"] = "modes 1, 2 and 3 must all be identified with their damping to judge patch damping"

    shift, slope = _get(fp, "amplitude_frequency_shift"), _get(fp, "backbone_slope_Hz_per_m")
    if math.isfinite(shift):
        out["tip_cubic_spring"] = (
            f"the mode-1 frequency rises {_pct(shift, False)} from the smallest to the largest amplitude "
            f"(backbone slope {slope:.3g} Hz/m): a hardening (cubic) spring"
            if scores["tip_cubic_spring"] >= 1 else
            f"the mode-1 frequency barely depends on amplitude ({_pct(shift)} over the decay): "
            "no sign of a hardening spring"
        )
    elif _get(fp, "free_decay") == 0.0:
        out["tip_cubic_spring"] = (
            "a driven record has no free decay whose frequency could be followed as the swing dies: "
            "a hardening spring is judged here by the calibration's evidence alone"
        )
    else:
        out["tip_cubic_spring"] = (
            "no backbone of the free decay was measured, or none the record's spectrum confirms: "
            "a hardening spring cannot be judged"
        )
    change = _get(fp, "decay_rate_change")
    if math.isfinite(change):
        out["quadratic_drag"] = (
            f"the decay of mode 1 slows as it dies out (its decay rate {_pct(-change, False)} lower at the end "
            "than at the start): a damping that grows with the amplitude, such as air drag"
            if scores["quadratic_drag"] >= 1 else
            f"the decay rate of mode 1 barely depends on its amplitude ({_pct(change)} over the decay): "
            "no sign of a damping that grows with the amplitude"
        )
    else:
        out["quadratic_drag"] = "no decay law of mode 1 was measured: a damping that grows with the amplitude cannot be judged"
    return {effect_id: out[effect_id] for effect_id in CANDIDATE_EFFECTS}
