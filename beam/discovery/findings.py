"""What a diagnosis finds, and the words it says it in: residual report, distance to the noise,
verdict, :class:`DiagnosisReport`.

The pieces of :func:`beam.discovery.report.diagnose` that do not depend on how its fits are run:
:func:`residual_report` (exceedances of the 95 % prediction band, residual spectrum against the
model's modes, whiteness, modal identification, envelope of mode 1, fingerprints and
explanations), :func:`remaining_error` (a rung against the record's noise floor), the verdict
(:func:`verdict_sentence`, :class:`VerdictParts`) and the report itself. Every part that cannot be
computed on a record (no free decay, say) is reported as a note instead of failing.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import asdict, dataclass, field, replace

import numpy as np

import beam.residuals as dx
from beam.calibration import CalibrationResult
from beam.discovery.judgement import AT_NOISE_RATIO as JUDGED_AT_NOISE
from beam.discovery.judgement import judge
from beam.discovery.plausibility import bound_notes
from beam.discovery.ranking import (
    MATERIAL_LOG_EVIDENCE,
    Explainer,
    LadderStep,
    Ranking,
    held_out_change,
    judgement_of,
    window_only,
)
from beam.discovery.window_hint import window_hint_notes
from beam.errors import BeamInputError
from beam.inference.progress import report
from beam.io.measurement import Measurement
from beam.physics.effects import clamp_friction, effective_length


@dataclass
class ResidualReport:
    """Where a calibrated model fails, over the whole record."""

    band: dx.BandResiduals
    spectrum: dx.ResidualSpectrum
    whiteness: dx.Whiteness
    identified: dx.IdentifiedModes | None
    comparison: list[dx.ModeMatch]
    mode1: dx.ModeAnalysis | None
    model_frequencies_Hz: np.ndarray
    model_damping_ratios: np.ndarray
    fingerprints: dict[str, float]
    explanations: dict[str, str]
    notes: list[str] = field(default_factory=list)


#: Held-out error of the last rung, in units of the noise floor, above which it is "well above the noise".
OUTSIDE_CATALOGUE_RATIO = 2.0
#: ... at or below which the model "predicts to the noise" (whatever the whiteness of what remains;
#: the one rule's point 2 reads the same number, :data:`beam.discovery.judgement.AT_NOISE_RATIO`).
AT_NOISE_RATIO = JUDGED_AT_NOISE


@dataclass(frozen=True)
class Remaining:
    """How far the best model the catalogue reaches is from the noise.

    Attributes
    ----------
    noise_floor : NoiseFloor
        The record's noise, estimated without any model (:func:`beam.residuals.noise.noise_floor`).
    remaining_error_ratio : float
        Held-out RMSE of the last rung's MAP / the noise floor's sd (1 for a model that predicts
        to the noise).
    white : bool
        Whether the last rung's residuals in the calibration window are white (Ljung–Box).
    ljung_box_p : float
        Their Ljung–Box p-value.
    more_modes : int or None
        When the remaining error is a truncation of the modal model (see :func:`remaining_error`):
        the number of modes to try; None otherwise.
    excess_Hz : float
        Highest frequency where the window's residual spectrum stands above the noise
        (:data:`beam.calibration.modes.EXCITED_RATIO` × its density; 0 when nowhere).
    """

    noise_floor: dx.NoiseFloor
    remaining_error_ratio: float
    white: bool
    ljung_box_p: float
    more_modes: int | None = None
    excess_Hz: float = 0.0

    @property
    def at_noise(self) -> bool:
        """What remains is at most :data:`AT_NOISE_RATIO` × the noise floor: the model predicts to the noise."""
        return bool(self.remaining_error_ratio <= AT_NOISE_RATIO)

    @property
    def above_noise(self) -> bool:
        """The last rung is still well above the noise and its residuals are not white."""
        return bool(self.remaining_error_ratio > OUTSIDE_CATALOGUE_RATIO and not self.white)

    @property
    def truncated(self) -> bool:
        """Well above the noise, and the misfit is the modal truncation: try more modes."""
        return self.above_noise and self.more_modes is not None

    @property
    def outside_catalogue(self) -> bool:
        """Well above the noise, residuals not white, and not a truncation of the modes."""
        return self.above_noise and self.more_modes is None


def uniform_view(measurement: Measurement, *series: np.ndarray, start_s: float | None = None
                 ) -> tuple[np.ndarray, list[np.ndarray]]:
    """Time stamps and ``series`` on a uniform grid for the residual diagnostics (which need one),
    from ``start_s`` (default the first sample; a free response's release).

    A uniform record is returned as it is; an irregular one is linearly interpolated onto its
    median step (the spectra, whiteness and modal identification are then approximations: the
    calibration itself uses the recorded stamps).
    """
    t = measurement.time_s
    first = 0 if start_s is None else int(np.searchsorted(t, start_s - 1e-12))
    t = t[first:]
    series = [np.asarray(s, dtype=float)[first:] for s in series]
    if measurement.uniform:
        return t, series
    step = measurement.median_interval_s
    grid = t[0] + step * np.arange(int(np.floor((t[-1] - t[0]) / step)) + 1)
    return grid, [np.interp(grid, t, s) for s in series]


def _offset(result: CalibrationResult) -> float:
    """The sensor's offset profiled out of a free-response calibration (0 otherwise)."""
    linear = result.linear_fit()
    return 0.0 if linear is None else float(linear["output_offset"])


def truncation_modes(result: CalibrationResult, floor: dx.NoiseFloor, residual: np.ndarray) -> tuple[int | None, float]:
    """Whether ``result``'s misfit is the truncation of its modal model, and how many modes to try.

    Two signs, either suffices; each must account for at least :data:`TRUNCATION_SHARE` of the
    excess residual (the window's residual RMS above the noise, sqrt(rms² - floor²)), so that a
    large misfit of another cause (a misplaced sensor: 190 × the noise) is not blamed on the modes:

    - the window's residual spectrum stands above the noise (:data:`~beam.calibration.modes.EXCITED_RATIO`
      × its density) up to a frequency above the highest retained mode's frequency (at the MAP)
      by more than :data:`~beam.calibration.modes.CLOSE_FRACTION`, or within that fraction of
      the next mode, and the residual power above that cut is that share of the excess power:
      the record holds modes the model does not keep; the count to try is then
      :func:`~beam.calibration.modes.suggest_modes`' band rule applied to that frequency;
    - the record's own choice (:func:`~beam.calibration.modes.suggest_modes` on the same window
      and effects) asks for more modes than retained, and the nominal model's truncation error
      with the retained count is that share of the excess RMS (its truncation check sees
      in-band errors of the dynamic correction that no peak shows).

    Returns
    -------
    (int or None, float)
        Modes to try (None: not a truncation) and the highest excess frequency (Hz).
    """
    from scipy import signal

    from beam.calibration.modes import CLOSE_FRACTION, EXCITED_RATIO, MARGIN_MODES, MAX_MODES, suggest_modes

    setup = result.setup
    fs = setup.measurement.rate_Hz
    excess_rms = float(np.sqrt(max(np.mean(residual**2) - floor.sd**2, 0.0)))
    excess, frequency, psd = 0.0, np.zeros(0), np.zeros(0)
    if residual.size >= 64:
        frequency, psd = signal.welch(residual - np.median(residual), fs=fs, nperseg=int(min(256, residual.size // 4)),
                                      detrend="linear")
        above = np.nonzero((psd > EXCITED_RATIO * floor.sd**2 / (0.5 * fs)) & (frequency > 0))[0]
        excess = float(frequency[above[-1]]) if above.size else 0.0
    values = {k: float(v) for k, v in result.laplace.map.values.items() if k in setup.physical_names}
    count = min(max(setup.modes + 1, MAX_MODES + 1), setup.model.size)
    try:
        frequencies = setup.model.natural_modes(values, count)[0]
    except (BeamInputError, KeyError, ValueError):  # a per-mode effect knows only its retained modes
        return None, excess
    highest, following = float(frequencies[setup.modes - 1]), float(frequencies[min(setup.modes, count - 1)])
    wanted = 0
    cut = min((1 + CLOSE_FRACTION) * highest, (1 - CLOSE_FRACTION) * following)
    if excess > cut:
        density = np.clip(psd - floor.sd**2 / (0.5 * fs), 0.0, None)  # the residual's excess over the noise
        step = float(frequency[1] - frequency[0])
        if float(np.sum(density[frequency >= cut]) * step) >= TRUNCATION_SHARE * excess_rms**2:
            band = int(np.count_nonzero(frequencies < excess))
            if band < frequencies.size and frequencies[band] <= (1 + CLOSE_FRACTION) * excess:
                band += 1
            wanted = band + MARGIN_MODES
    try:
        choice = suggest_modes(setup.measurement, setup.window, setup.effects)
    except BeamInputError:
        choice = None
    if choice is not None and choice.modes > setup.modes:
        error = choice.truncation_error(setup.modes)
        if error is not None and error >= TRUNCATION_SHARE * excess_rms:
            wanted = max(wanted, choice.modes)
    wanted = min(wanted, setup.model.size)
    return (int(wanted) if wanted > setup.modes else None), excess


def remaining_error(result: CalibrationResult, floor: dx.NoiseFloor) -> Remaining:
    """How far ``result`` (a rung's calibration) is from the noise ``floor``, and whether what remains
    is a truncation of its modes (:func:`truncation_modes`; only asked when well above the noise)."""
    measurement = result.setup.measurement
    window = result.setup.fit_mask
    residual = (measurement.output - result.map_prediction())[window]
    white = dx.residual_whiteness(residual, sample_interval_s=measurement.rate_Hz ** -1,
                                  fitted_parameters=result.problem.ndim)
    ratio = float(result.rmse_prediction_map / floor.sd) if floor.sd > 0 else float("inf")
    more, excess = None, 0.0
    if ratio > OUTSIDE_CATALOGUE_RATIO and not white.white:
        more, excess = truncation_modes(result, floor, residual)
    return Remaining(floor, ratio, bool(white.white), float(white.p_value), more, excess)


#: Share of the excess residual (RMS, or power above the cut frequency) a truncation must account
#: for to be named as the cause (:func:`truncation_modes`).
TRUNCATION_SHARE = 0.5


#: Two materially improving candidates whose log evidences differ by less than this (nats) and
#: whose held-out errors differ by less than INDISTINGUISHABLE_RMSE (relative) are named together:
#: the data cannot tell them apart (2 log Bayes factor < 6: "positive" at most on the
#: Kass–Raftery scale, short of "strong").
INDISTINGUISHABLE_LOG_EVIDENCE = 3.0
INDISTINGUISHABLE_RMSE = 0.1


#: ... or whose calibrated models give the same frequencies of every mode the record shows (within
#: SAME_FREQUENCY, relative) with calibration RMSEs within INDISTINGUISHABLE_RMSE_CALIBRATION: with
#: as many modes visible as the repair has parameters, each candidate fits those frequencies
#: exactly and the rest of the evidence difference is about how each absorbs misfit elsewhere
#: (with residuals far above the noise, an i.i.d. evidence difference of hundreds of nats is not
#: a measurement of where a mass sits).
SAME_FREQUENCY = 0.002
INDISTINGUISHABLE_RMSE_CALIBRATION = 0.25


def map_frequencies(result: CalibrationResult, count: int | None = None) -> np.ndarray:
    """Natural frequencies (Hz) of ``result``'s model at its MAP: the first ``count`` (default all
    retained modes)."""
    values = {k: float(v) for k, v in result.laplace.map.values.items() if k in result.setup.physical_names}
    return result.setup.model.natural_modes(values, count or result.setup.modes)[0]


def _has_fit(ranking: Ranking, effect: str) -> bool:
    return effect in ranking.results or effect in ranking.frequencies_Hz


def _map_frequencies(ranking: Ranking, effect: str, count: int) -> np.ndarray:
    if effect in ranking.frequencies_Hz:
        return np.asarray(ranking.frequencies_Hz[effect])[:count]
    return map_frequencies(ranking.results[effect], count)


def same_modes(ranking: Ranking, effect: str, visible_modes: int) -> int:
    """How many of the first ``visible_modes`` modes the fit with ``effect`` places where the best
    material candidate's fit does (within :data:`SAME_FREQUENCY`), counted from mode 1."""
    material = [c for c in ranking.candidates if c.material]
    if not material or not _has_fit(ranking, effect) or not _has_fit(ranking, material[0].effect):
        return 0
    fa = _map_frequencies(ranking, material[0].effect, visible_modes)
    fb = _map_frequencies(ranking, effect, visible_modes)
    same = np.abs(fb - fa) <= SAME_FREQUENCY * fa
    return int(np.argmin(same)) if not same.all() else int(same.size)


def indistinguishable(ranking: Ranking, visible_modes: int = 0) -> list[str]:
    """Materially improving candidates the data cannot tell from the best one (see above).

    ``visible_modes``: modes identified in the record (0: compare by evidence and held-out error only).
    """
    material = [c for c in ranking.candidates if c.material]
    if len(material) < 2:
        return []
    best = material[0]
    out = []
    for c in material[1:]:
        if getattr(c, "source", "full") != getattr(best, "source", "full"):
            continue  # the curves' evidence beside a full fit's: of other data
        if getattr(best, "source", "full") == "averaged":  # the curves: evidence alone (no RMSE, no fit)
            if best.delta_log_evidence - c.delta_log_evidence < INDISTINGUISHABLE_LOG_EVIDENCE:
                out.append(c.effect)
            continue
        close = (best.delta_log_evidence - c.delta_log_evidence < INDISTINGUISHABLE_LOG_EVIDENCE
                 and abs(c.rmse_prediction - best.rmse_prediction) <= INDISTINGUISHABLE_RMSE * best.rmse_prediction)
        if not close and visible_modes > 0 and _has_fit(ranking, best.effect) and _has_fit(ranking, c.effect):
            fa = _map_frequencies(ranking, best.effect, visible_modes)
            fb = _map_frequencies(ranking, c.effect, visible_modes)
            close = bool(np.all(np.abs(fb - fa) <= SAME_FREQUENCY * fa)
                         and c.rmse_calibration <= (1 + INDISTINGUISHABLE_RMSE_CALIBRATION) * best.rmse_calibration)
        if close:
            out.append(c.effect)
    return out


def verdict_sentence(missing: str | None, gain_nats: float, rmse_before_m: float, rmse_after_m: float,
                     remaining: Remaining | None, *, unit: str = "m", alternatives: Iterable[str] = (),
                     partly: Iterable[tuple[str, int]] = (), error_label: str = "held-out RMSE",
                     then: Iterable[str] = (), window_notes: Iterable[str] = ()) -> str:
    """The one-sentence verdict of a diagnosis (the command line's and the dashboard's).

    Parameters
    ----------
    missing : str or None
        Effect id of the best materially improving candidate.
    gain_nats : float
        Its log-evidence gain.
    rmse_before_m, rmse_after_m : float
        Held-out RMSE (in ``unit``) of the current model and with the missing effect (or of the
        last rung); the sentence gives a length in µm.
    remaining : Remaining or None
        Distance of the last rung from the noise floor (None: not estimated).
    unit : str
        The output's unit (the RMSE and the noise floor are in it).
    alternatives : iterable of str
        Candidates the data cannot tell from ``missing`` (:func:`indistinguishable`).
    partly : iterable of (str, int)
        Material candidates whose fits place the first ``int`` (>= 2) modes where ``missing``'s
        does, but not all the modes the record shows.
    error_label : str
        What the two RMSE are ("held-out RMSE"; a free decay's verdict quotes the calibration
        window's, by which its candidates are judged).
    then : iterable of str
        Effects the ladder added after ``missing`` (ranked on top of it); ``rmse_after_m`` is then
        the last rung's.
    window_notes : iterable of str
        Sentences on candidates whose evidence their held-out error contradicts
        (:func:`window_only_words`), added at the end.
    """
    alternatives = list(alternatives)
    partly = list(partly)
    notes = "".join(f"; {sentence}" for sentence in window_notes)
    if missing is not None:
        then = list(then)
        added = missing + "".join(f", then {effect}" for effect in then)
        before, after = _amount(rmse_before_m, unit).split(" ")[0], _amount(rmse_after_m, unit)
        head = f"missing: {added} (+{gain_nats:.0f} nats; {error_label} {before} -> {after})"
        if alternatives:
            head += (f"; the data cannot tell it from {' or '.join(alternatives)}: the same frequencies of the "
                     "modes the record shows, the same repair by another cause")
        for effect, count in partly:
            head += (f"; {effect} places modes 1-{count} as well, only mode {count + 1} tells them apart")
        if remaining is None:
            return head + notes
        if remaining.truncated or remaining.outside_catalogue:
            return f"{head}: it explains part of the misfit, but {remaining_words(remaining, unit)}{notes}"
        return f"{head}; {remaining_words(remaining, unit)}{notes}"
    head = "nothing in the catalogue is missing"
    if remaining is None:
        return head + notes
    if remaining.truncated or remaining.outside_catalogue:
        return f"{head}, but {remaining_words(remaining, unit)}{notes}"
    return f"{head}: {remaining_words(remaining, unit)}{notes}"


def p_words(p: float) -> str:
    """A Ljung–Box p-value for a student: how often white noise alone would show as much pattern
    (``"0.00026 (about 1 in 3,800)"``, ``"below one in a million"``)."""
    if p is None or not np.isfinite(p):
        return "unknown"
    if p < 1e-6:
        return "below one in a million"
    if p >= 0.05:
        return f"{p:.2g}"
    return f"{p:.2g} (about 1 in {float(f'{1 / p:.2g}'):,.0f})"


def remaining_words(remaining: Remaining, unit: str = "m", floor_text: str | None = None) -> str:
    """What remains of the misfit against the noise floor, in words: the one wording of the command
    line's verdict and the dashboard's.

    At most :data:`AT_NOISE_RATIO` × the floor the model predicts to the noise; a residual that is
    then not quite white is a note about the noise model (the AR(1) likelihood models correlated
    noise), never missing physics. Well above the floor with residuals that are not white: the
    modes the model keeps (:attr:`Remaining.truncated`) or something outside the catalogue.

    Parameters
    ----------
    remaining : Remaining
    unit : str
        The output's unit (the floor is quoted in it).
    floor_text : str, optional
        The floor as the caller shows it (e.g. ``"15 µm"``); default: a length in µm, another
        quantity in its SI unit, as ``beam calibrate`` prints them.
    """
    ratio = remaining.remaining_error_ratio
    floor = floor_text or _amount(remaining.noise_floor.sd, unit)
    size = f"{ratio:.1f}× the sensor's noise ({floor}, read from the record alone)"
    if remaining.at_noise:
        text = f"what remains is {size}: the model predicts to the noise"
        if not remaining.white:
            text += (f". That small residual is not quite white noise (Ljung–Box test: the chance that white noise "
                     f"shows this much pattern is {p_words(remaining.ljung_box_p)}); so close to the noise this is a note "
                     "about the noise model, not missing physics: the AR(1) likelihood allows correlated noise")
        return text
    if remaining.truncated:
        return f"the error is still {size}: {_more_modes(remaining)}"
    if remaining.outside_catalogue:
        return (f"the error is still {size} and the residuals are not white noise: something outside the "
                "catalogue is at work")
    if remaining.white:
        return f"what remains is {size} and looks like white noise: the model is close to the noise"
    return (f"what remains is {size}, close to the noise but not white (Ljung–Box chance "
            f"{p_words(remaining.ljung_box_p)}): look at the noise model (the AR(1) likelihood) before the physics")


def window_only_words(effect: str, gain_nats: float, held_out_change: float, free: bool = False) -> str:
    """Why a large evidence gain is no support for ``effect`` when its prediction after the window
    is worse (:func:`beam.discovery.ranking.window_only`); ``held_out_change`` relative (0.15: 15 %
    higher): for a free decay, of the amplitude-aware prediction (:mod:`beam.discovery.held_out`)."""
    percent = 100 * held_out_change
    rise = f"{percent:.1f} %" if percent < 10 else f"{percent:.0f} %"
    if free:
        return (f"{effect} fits the calibration window better (+{gain_nats:.0f} nats) but predicts the rest of the "
                f"decay worse (its error after the window {rise} higher): not borne out on held-out data, so it is "
                "not named missing")
    return (f"{effect} gains +{gain_nats:.0f} nats of evidence inside the calibration window while its held-out "
            f"error is {rise} higher: a base model this far from the data lets any added flexibility fit the "
            "window better, so this evidence is no support for the effect")


def _amount(value: float, unit: str) -> str:
    """A length in µm (as ``beam calibrate`` prints it), another quantity in its SI ``unit``; 3
    significant digits, never an exponent below 10⁶ (``"1150 µm"``, ``"46.5 µm"``)."""
    scaled, shown = (value * 1e6, "µm") if unit == "m" else (value, unit)
    return f"{scaled:.0f} {shown}" if 1e3 <= abs(scaled) < 1e6 else f"{scaled:.3g} {shown}"


def _more_modes(remaining: Remaining) -> str:
    where = (f"the residuals hold power up to {remaining.excess_Hz:.0f} Hz, " if remaining.excess_Hz > 0 else "")
    return (f"{where}the record excites more modes than the model keeps: try more modes "
            f"({remaining.more_modes}) before looking outside the catalogue")


class VerdictFacts:
    """What a verdict says beyond the best candidate, from ``ranking``, ``residuals`` and ``base``
    (shared by :class:`DiagnosisReport` and the dashboard's diagnosis: one rule for both)."""

    @property
    def visible_modes(self) -> int:
        """The model's modes matched by an identified mode of the record, from mode 1 on."""
        visible = 0
        for row in self.residuals.comparison:
            if row.frequency_data_Hz is None or not np.isfinite(row.frequency_data_Hz):
                break
            visible += 1
        return min(visible, self.base.setup.modes)

    @property
    def partly_indistinguishable(self) -> list[tuple[str, int]]:
        """Material candidates (not indistinguishable) whose fits place at least the first two modes
        where the missing effect's fit does: which mode tells them apart."""
        visible = self.visible_modes
        out = []
        for c in self.ranking.candidates[1:]:
            if c.material and c.effect not in self.indistinguishable and visible > 2:
                count = same_modes(self.ranking, c.effect, visible)
                if 2 <= count < visible:
                    out.append((c.effect, count))
        return out

    @property
    def indistinguishable(self) -> list[str]:
        """Candidates the data cannot tell from the missing one (:func:`indistinguishable`)."""
        return indistinguishable(self.ranking, self.visible_modes)

    @property
    def window_notes(self) -> list[str]:
        """Sentences on the (at most :data:`MAX_WINDOW_NOTES`) candidates with the largest evidence
        gains that their held-out error contradicts (:func:`beam.discovery.ranking.window_only`)."""
        return self.window_notes_named()

    def window_notes_named(self, name=str) -> list[str]:
        """:attr:`window_notes` with each effect called ``name(effect_id)`` (the dashboard: its title),
        then one sentence per candidate whose fit is not that effect (the judgement's reason)."""
        base = self.base
        added = {step.added for step in getattr(self, "ladder", ()) or () if step.added is not None}
        # an effect the ladder adds later (named missing on top of a rung) is no longer "not borne out"
        # or "not this effect": those were its judgement on the base alone
        # and a candidate whose figures are of another source than the report's (the curves' beside
        # the full fits') is judged on other errors: no note compares them
        source = getattr(self, "source", "full")
        kept = [c for c in self.ranking.candidates if c.effect not in added and getattr(c, "source", "full") == source]
        contradicted = sorted((c for c in kept if window_only(c, base)), key=lambda c: -c.delta_log_evidence)
        notes = [window_only_words(name(c.effect), c.delta_log_evidence, held_out_change(c, base), base.setup.is_free)
                 for c in contradicted[:MAX_WINDOW_NOTES]]
        notes += [judgement_of(c, base).reason(name) for c in kept
                  if judgement_of(c, base).status == "implausible"][:MAX_WINDOW_NOTES]
        return notes


#: Most candidates whose evidence their held-out error contradicts that a verdict names.
MAX_WINDOW_NOTES = 2


@dataclass(frozen=True)
class VerdictParts:
    """What a verdict says (:meth:`DiagnosisReport.verdict_parts`): the one rule behind the command
    line's sentence (:func:`verdict_sentence`) and the dashboard's words.

    ``missing`` is the best materially improving candidate (None: none), ``then`` the effects the
    ladder added after it, ``gain_nats`` its evidence gain, ``before``/``after`` the quoted error
    (output's unit) of the base model and of the last rung, ``error_label`` what that error is.
    """

    missing: str | None
    then: list[str]
    gain_nats: float
    before: float
    after: float
    remaining: Remaining | None
    unit: str
    alternatives: list[str]
    partly: list[tuple[str, int]]
    error_label: str
    window_notes: list[str]

    def sentence(self) -> str:
        """:func:`verdict_sentence` of these parts."""
        return verdict_sentence(self.missing, self.gain_nats, self.before, self.after, self.remaining, unit=self.unit,
                                alternatives=self.alternatives, partly=self.partly, error_label=self.error_label,
                                then=self.then, window_notes=self.window_notes)


@dataclass
class DiagnosisReport(VerdictFacts):
    """The diagnosis of one record: residuals, ranked candidates, error ladder, distance to the noise.

    A partial report (``complete`` False; :func:`beam.discovery.stream.diagnosis_stream` yields
    them) has the candidates ranked so far and names the others in ``pending``; its ladder is
    the base (and, once every candidate is ranked, the best material one).
    """

    measurement: Measurement
    residuals: ResidualReport
    ranking: Ranking
    ladder: list[LadderStep]
    seconds: float
    remaining: Remaining | None = None
    #: Candidates not ranked yet (empty once the ranking is complete).
    pending: list[str] = field(default_factory=list)
    #: Whether this is the complete report (ladder climbed, distance to the noise measured).
    complete: bool = True
    #: Where the ranking's figures come from: ``"averaged"`` (every candidate scored on the
    #: record's backbone and damping curves, :mod:`beam.discovery.averaged`; a free decay's first
    #: ranking) or ``"full"`` (the time-domain fits; candidates not fitted yet keep their
    #: averaged figures, each saying so by its :attr:`~beam.discovery.ranking.Candidate.source`).
    source: str = "full"
    #: The averaged ranking's verdict (None: no averaged ranking), said while the full fits confirm it.
    averaged_verdict: str | None = None

    @property
    def base(self) -> CalibrationResult:
        return self.ranking.base

    @property
    def candidates(self) -> list:
        """The candidates ranked so far, best first."""
        return self.ranking.candidates

    @property
    def missing(self) -> str | None:
        """The best materially improving candidate (None: none, or the ranking is not complete)."""
        return self.ranking.missing if not self.pending else None

    @property
    def climbed(self) -> list[str]:
        """Effects the ladder added after the missing one (ranked on top of it)."""
        return [step.added for step in self.ladder[2:] if step.added is not None]

    def errors(self, result: CalibrationResult) -> float:
        """The error a verdict quotes for ``result``: the held-out RMSE of its MAP, or for a free
        decay the calibration window's (by which its candidates are judged)."""
        return result.rmse_calibration_map if self.base.setup.is_free else result.rmse_prediction_map

    @property
    def climbed_rmse(self) -> float:
        """:meth:`errors` of the last rung when the ladder climbed beyond the missing effect (NaN otherwise)."""
        return self.errors(self.ladder[-1].result) if self.climbed and self.ladder[-1].result is not None else math.nan

    def verdict_parts(self, name=str) -> VerdictParts:
        """The facts of the verdict (``name(effect_id)`` names an effect in the window notes)."""
        best = self.ranking.candidates[0] if self.ranking.candidates else None
        last = self.ladder[-1] if self.ladder else None
        missing = self.missing
        return VerdictParts(
            missing, self.climbed, best.delta_log_evidence if best else math.nan, self.errors(self.base),
            self.errors(last.result) if last is not None and last.result is not None else math.nan,
            self.remaining, self.measurement.output_unit,
            self.indistinguishable if missing else [], self.partly_indistinguishable if missing else [],
            "calibration-window RMSE" if self.base.setup.is_free else "held-out RMSE", self.window_notes_named(name))

    @property
    def verdict(self) -> str:
        """One sentence: what is missing, how far the last rung is from the noise, or that nothing in the catalogue is."""
        if self.source == "averaged" and not self.pending and self.averaged_verdict is not None:
            return self.averaged_verdict
        if self.pending:
            if self.averaged_verdict is not None:
                return f"{self.averaged_verdict} ({len(self.pending)} full fits to go)"
            return f"ranking the candidates: {len(self.pending)} to go"
        return self.verdict_parts().sentence()

    @property
    def outside_catalogue(self) -> bool:
        """Whether the last rung is well above the noise with residuals that are not white."""
        return bool(self.remaining is not None and self.remaining.outside_catalogue)

    @property
    def repair_effects(self) -> tuple[str, ...] | None:
        """The full effect list of the repaired model (the last rung: the base's effects and every
        effect the ladder added), None when nothing is missing. What a student calibrates next: the
        base's damping stays in it."""
        if self.missing is None or not self.ladder:
            return None
        return tuple(self.ladder[-1].effects)

    def repair_command(self, data: str | None = None) -> str | None:
        """``beam calibrate DATA --window A:B --effects …`` of :attr:`repair_effects` (``data``: how the
        user named the record; default its name), None when nothing is missing."""
        effects = self.repair_effects
        if effects is None:
            return None
        start, end = (f"{round(t, 3):.3f}".rstrip("0").rstrip(".") for t in self.base.setup.window)  # to the ms
        return (f"beam calibrate {data or self.measurement.name} --window {start}:{end} "
                f"--modes {self.base.setup.modes} --effects {','.join(effects)}")

    @property
    def bound_notes(self) -> list[str]:
        """The base fit's parameters at a prior bound (:func:`beam.discovery.plausibility.bound_notes`),
        as notes: its value is not found there, whatever a convergence check says."""
        return [f"the base model's {note}: its value is not found (the prior does not reach it), so no "
                "calibration of this base is converged on it" for note in bound_notes(self.base)]

    def to_json(self) -> dict:
        """The summary of ``beam diagnose --json`` (see the README)."""
        base = self.base
        return {
            "measurement": self.measurement.name,
            "window_s": list(base.setup.window),
            "modes": base.setup.modes,
            **({"modes_reason": base.setup.mode_choice.reason} if base.setup.mode_choice is not None else {}),
            "base": list(base.setup.effects),
            "rmse_calibration_base": base.rmse_calibration_map,
            "rmse_prediction_base": base.rmse_prediction_map,
            "coverage95_prediction_base": base.coverage95_prediction,
            "source": self.source,
            **({"averaged_verdict": self.averaged_verdict} if self.averaged_verdict is not None else {}),
            "candidates": [c.to_json() for c in self.ranking.candidates],
            "missing": self.missing,
            "repair": (None if self.repair_effects is None else
                       {"effects": list(self.repair_effects), "command": self.repair_command()}),
            "indistinguishable": self.indistinguishable,
            "output": self.measurement.output_kind,
            "output_unit": self.measurement.output_unit,
            "verdict": self.verdict,
            "noise_floor": None if self.remaining is None else self.remaining.noise_floor.sd,
            "remaining_error_ratio": None if self.remaining is None else self.remaining.remaining_error_ratio,
            "outside_catalogue": self.outside_catalogue,
            "try_modes": None if self.remaining is None else self.remaining.more_modes,
            "ladder": [step.to_json() for step in self.ladder],
            "modes_table": [dx.jsonable(asdict(row)) for row in self.residuals.comparison],
            "modes_table_convention": dx.DIFFERENCE_CONVENTION,
            "exceedances": [dx.jsonable(asdict(interval)) for interval in self.residuals.band.intervals],
            "whiteness": {"ljung_box_p": dx.jsonable(self.residuals.whiteness.p_value),
                          "white": bool(self.residuals.whiteness.white)},
            "residual_peaks_Hz": [dx.jsonable(p.frequency_Hz) for p in self.residuals.spectrum.peaks],
            "fingerprints": dx.jsonable(self.residuals.fingerprints),
            "notes": [*self.residuals.notes, *self.bound_notes],
            "seconds": self.seconds,
        }


def residual_report(result: CalibrationResult) -> ResidualReport:
    """Residual diagnostics of a calibrated model over its whole record."""
    measurement = result.setup.measurement
    notes: list[str] = []
    bands = result.bands
    offset = _offset(result)
    start = result.setup.free_start_s if result.setup.is_free else None
    # the diagnostics need uniform stamps; the offset (a sensor bias) is no mode of the beam
    time_s, (data, prediction, mean, lower, upper) = uniform_view(
        measurement, measurement.output - offset, result.map_prediction() - offset, bands.mean - offset,
        bands.prediction_lower - offset, bands.prediction_upper - offset, start_s=start)
    voltage = None
    if measurement.input is not None:
        voltage = uniform_view(measurement, measurement.input)[1][0]
    if start is not None and start > measurement.time_s[0]:
        release, first = result.setup.free_start_indices
        at_rest = f"at rest until the release at {measurement.time_s[release]:.3g} s; " if release > 0 else ""
        notes.append(f"the free response and its diagnostics start at {start:.3g} s ({at_rest}"
                     f"{first - release} samples of the release's transient left out)")
    if not measurement.uniform:
        notes.append(f"irregular time stamps: residual spectra and modal identification on the record interpolated "
                     f"to its median step ({measurement.median_interval_s:.3g} s)")
    report("residual diagnostics: band and spectrum")
    band = dx.band_residuals(time_s, data, mean, lower, upper)
    map_values = {k: float(v) for k, v in result.laplace.map.values.items() if k in result.setup.physical_names}
    frequencies, ratios = result.setup.model.natural_modes(map_values, result.setup.modes)
    spectrum = dx.residual_spectrum(time_s, data, prediction, frequencies)
    window = result.setup.fit_mask
    whiteness = dx.residual_whiteness((measurement.output - result.map_prediction())[window],
                                      sample_interval_s=1.0 / measurement.rate_Hz,
                                      fitted_parameters=result.problem.ndim)
    identified, comparison, mode1 = None, [], None
    report("residual diagnostics: modal identification of the record")
    try:
        identified = dx.identify_modes(time_s, data, voltage, start_s=float(time_s[0]) if measurement.is_free else None)
        comparison = dx.compare_modes(identified, frequencies, ratios)
    except BeamInputError as exc:
        notes.append(f"no modal identification: {exc}")
    comparison = _name_unseen(result, map_values, comparison)
    if identified is not None:
        comparison = unresolved_marked(comparison, identified, dx.resolution_reasons(time_s, data, identified))
    first = next((row for row in comparison if row.mode == 1 and row.matched), None)
    if first is not None:  # the identified mode matched to the model's mode 1, not merely the lowest pole
        report("residual diagnostics: mode 1's envelope and backbone")
        try:
            mode1 = dx.analyse_mode(time_s, data, float(first.frequency_data_Hz), voltage,
                                    **({"start_s": float(time_s[0])} if measurement.is_free else {}))
        except BeamInputError as exc:
            notes.append(f"no envelope of mode 1: {exc}")
        if mode1 is not None and not mode1.backbone.reliable:
            notes.append(f"the amplitude-frequency relation of mode 1 is unknown: {mode1.backbone.unreliable}")
    elif identified is not None and len(identified.frequency_Hz):
        notes.append("no identified mode matches the model's mode 1: its amplitude-frequency relation is unknown")
    notes.extend(window_hint_notes(result, mode1))  # too short a window to tell the damping laws apart
    notes.extend(_phase_lag_notes(result, time_s, data, prediction, frequencies, mode1))
    fingerprints = dx.fingerprints(
        comparison, backbone=mode1.backbone if mode1 else None, decay=mode1.decay if mode1 else None,
        spectrum=spectrum, whiteness=whiteness, free_decay=measurement.is_free,
    )
    return ResidualReport(band, spectrum, whiteness, identified, comparison, mode1, frequencies, ratios,
                          fingerprints, dx.explain(fingerprints), notes)


#: A held-out lag of mode 1 worth a note: it explains at least this share of the residual power
#: after the window ...
PHASE_LAG_SHARE = 0.5
#: ... and reaches at least this many degrees (a tenth of a cycle and more: plainly visible).
PHASE_LAG_DEG = 30.0


def _phase_lag_notes(result: CalibrationResult, time_s: np.ndarray, data: np.ndarray, prediction: np.ndarray,
                     frequencies: np.ndarray, mode1) -> list[str]:
    """A note when, on a free decay, the held-out error is mostly mode 1 drifting out of phase
    (:func:`beam.residuals.phase.phase_drift`): how far, what frequency offset that is, what is
    left once it is aligned, and the physics a frequency changing with the swing points to."""
    setup = result.setup
    if not setup.is_free or not len(frequencies):
        return []
    try:
        drift = dx.phase_drift(time_s, data, prediction, float(frequencies[0]), float(setup.window[1]),
                            filter_from_s=float(time_s[0]))
    except BeamInputError:  # too short a held-out span, or samples the model does not cover
        return []
    last = float(drift.lag_deg[-1])
    if not (drift.lag_share >= PHASE_LAG_SHARE and abs(last) >= PHASE_LAG_DEG):
        return []
    unit = setup.measurement.output_unit
    ahead = last > 0
    spectral = getattr(getattr(mode1, "backbone", None), "spectral_drift", float("nan"))
    own = (f" The record's own f1 {'rises' if spectral < 0 else 'falls'} {abs(100 * spectral):.2g} % from the "
           "first to the last third of its decay (short-time spectrum)." if np.isfinite(spectral) else "")
    if np.isfinite(spectral) and (spectral < 0) == ahead:  # the record's own frequency drifts that way
        friction = clamp_friction.EFFECT.id
        physics = ((f"A frequency that rises as the swing dies is a stiffness that falls with amplitude — a clamp "
                    f"that slips at large swings: add {friction} (a frictional joint at the root, fitted on "
                    "free decays; its calibration takes minutes)."
                    if friction not in setup.effects else
                    f"A frequency that rises as the swing dies is what {friction} models; the window may be "
                    "too short to pin its slip moment.")
                   if ahead else
                   "A frequency that falls as the swing dies is a stiffness that grows with amplitude, as a "
                   "hardening spring's does.")
    else:
        physics = "A longer calibration window pins f1 more closely."
    return [f"after the window the model's mode 1 drifts out of phase with the record: the record runs "
            f"{'ahead' if ahead else 'behind'} by {abs(last):.0f}° at {drift.block_stop_s[-1]:.3g} s, its "
            f"f1 {abs(drift.frequency_offset_pct):.2g} % {'above' if ahead else 'below'} the model's there. "
            f"That lag is {100 * drift.lag_share:.0f} % of the error after the window: aligning the phase alone "
            f"would take it from {drift.rmse_total:.3g} to {drift.rmse_aligned_total:.3g} {unit}.{own} {physics}"]


def unresolved_marked(comparison: list[dx.ModeMatch], identified, reasons: list[str | None]) -> list[dx.ModeMatch]:
    """``comparison`` with every row matched to a pole the record does not resolve
    (:func:`beam.residuals.resolution_reasons`) shown as not resolved: no data values (so no
    fingerprint reads them), the reason as its note, ``resolved`` False."""
    nan = float("nan")
    out = []
    for row in comparison:
        j = (int(np.argmin(np.abs(identified.frequency_Hz - row.frequency_data_Hz))) if row.matched else None)
        if j is None or reasons[j] is None:
            out.append(row)
            continue
        out.append(replace(row, frequency_data_Hz=nan, damping_data=nan, frequency_error_pct=nan, damping_error_pct=nan,
                           note=reasons[j], resolved=False))
    return out


def _name_unseen(result: CalibrationResult, values: dict, comparison: list[dx.ModeMatch]) -> list[dx.ModeMatch]:
    """``comparison`` with a note on each model mode no identified mode matched: why the record
    may not show it, from the model's own shape of it at the MAP (:func:`beam.residuals.unseen_reason`)."""
    if all(row.matched for row in comparison):
        return comparison
    setup = result.setup
    model, geometry = setup.model, setup.measurement.geometry
    try:
        length = effective_length.LENGTH.name
        if length in values:  # the shapes live on the strip of that free length
            model = model.free_length_model(values[length])
            geometry, values = model.geometry, {k: v for k, v in values.items() if k != length}
        _, coefficients = model.mode_shapes(values, setup.modes)
        x = np.linspace(0.0, geometry.length_m, 401)
        shapes = model.parts.basis.evaluate(x) @ coefficients
    except (BeamInputError, ValueError, KeyError, np.linalg.LinAlgError):  # no shapes: the rows stay unexplained
        return comparison
    nyquist = 0.5 * setup.measurement.rate_Hz
    return [row if row.matched or row.mode > shapes.shape[1] else replace(row, note=dx.unseen_reason(
        x, shapes[:, row.mode - 1], geometry.sensor_position_m, row.frequency_model_Hz, nyquist)) for row in comparison]


def explainer(residuals: ResidualReport) -> Explainer:
    """The sentence of each candidate: its fingerprint sentence, led by what the one rule decided
    (:func:`beam.discovery.judgement.judge`) when its evidence is material: why a gain whose
    prediction after the window is worse is no support (:func:`window_only_words`), why a fit with
    parameters no such effect has is not this effect (and what else can explain the data), why a
    gain whose judged error barely falls is too little, or — when the data favour the effect but its
    fingerprint is weak (a tip mass and a soft clamp lower the modes almost alike) — the evidence."""
    scores = dx.effect_scores(residuals.fingerprints)

    def explain(effect: str, base_fit: CalibrationResult, fit: CalibrationResult) -> str:
        from beam.physics.effects import EFFECTS

        sentence = residuals.explanations.get(effect, "")
        judgement = judge(effect, base_fit, fit)
        gain = judgement.delta_log_evidence
        if gain < MATERIAL_LOG_EVIDENCE:
            return sentence
        title = EFFECTS[effect].title
        if judgement.status == "fails_after_window":
            words = window_only_words(title, gain, judgement.held_out_change, base_fit.setup.is_free)
            return f"{words}. What the residuals show: {sentence}"
        if judgement.status == "implausible":
            words = judgement.reason(lambda e: EFFECTS[e].title)
            change = judgement.judged_change
            moved = ("" if not math.isfinite(change) else
                     f", its {judgement.judged_label} {100 * abs(change):.0f} % {'lower' if change < 0 else 'higher'}")
            return (f"{words[0].upper()}{words[1:]} (+{gain:.0f} nats in the window{moved}). What the residuals show: "
                    f"{sentence}")
        if judgement.material and scores.get(effect, 0.0) >= 1.0:
            return sentence
        judged = judgement.judged_label
        before, after = judgement.judged_before, judgement.judged_after
        if judgement.material:
            head = f"the data favour it strongly (+{gain:.0f} nats, {judged} /{before / max(after, 1e-300):.1f})"
            if not sentence:  # no fingerprint of its own (the sensor's mass)
                return f"{head}; the residuals have no fingerprint of their own for it"
            return f"{head} although its fingerprint is ambiguous: {sentence.split(': no sign')[0]}"
        fall = 1 - after / before if before > 0 else 0.0
        change = f"falls only {100 * fall:.0f} %" if fall > 0 else "does not fall"
        return (f"the evidence rises (+{gain:.0f} nats) but the {judged} {change}: too little to call the effect "
                f"missing, and its fingerprint agrees: {sentence}")

    return explain


#: Most rungs the ladder climbs by re-ranking on top of its last rung (:func:`beam.discovery.report.climb_on`).
MAX_CLIMB = 2
