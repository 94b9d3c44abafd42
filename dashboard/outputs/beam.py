"""Read-outs, tables and downloads of beam calibration results (pure Python: numpy and pandas).

Everything comes from the public :class:`beam.calibration.CalibrationResult` API; every
quantity carries its unit in its label. Read-outs follow the record's output
(:func:`output_units`): displacement and its RMSE in µm, velocity in mm/s, acceleration in m/s²;
coverage in %.
"""

from __future__ import annotations

import io
import json
import math
import threading
from dataclasses import dataclass

import numpy as np
import pandas as pd

from beam.calibration.handout import calibration_handout
from beam.errors import BeamInputError
from beam.physics.effects import EFFECTS, parameter_spec
from beam.discovery.ranking import judgement_of
from beam.discovery.report import remaining_words
from beam.residuals.noise import record_noise_floor
from dashboard.outputs.exports import jsonable, posterior_netcdf

__all__ = [
    "OutputUnits",
    "bands_csv",
    "compare_table",
    "convergence",
    "correlation_table",
    "diagnosis_html",
    "effect_title",
    "evidence_words",
    "filename",
    "fmt_pct",
    "fmt_um",
    "fmt_value",
    "judged_readouts",
    "ladder_steps",
    "noise_floor_m",
    "output_units",
    "parameter_label",
    "parameter_table",
    "posterior_netcdf",
    "readouts",
    "result_label",
    "summary",
    "summary_html",
    "summary_json",
    "verdict_text",
]

@dataclass(frozen=True)
class OutputUnits:
    """How a record's output is shown: read-outs in ``unit`` (``scale`` × the SI value), plots in
    ``plot_unit`` (``plot_scale`` × the SI value); ``quantity`` is ``"Displacement"``, ... ."""

    quantity: str
    si_unit: str
    scale: float
    unit: str
    plot_scale: float
    plot_unit: str

    def axis_label(self, what: str | None = None) -> str:
        """``"Acceleration (m/s²)"``, or ``"Residual (m/s²)"`` with ``what="Residual"`` (plot unit)."""
        return f"{what or self.quantity} ({self.plot_unit})"


_UNITS = {
    "displacement": OutputUnits("Displacement", "m", 1e6, "µm", 1e3, "mm"),
    "velocity": OutputUnits("Velocity", "m/s", 1e3, "mm/s", 1e3, "mm/s"),
    "acceleration": OutputUnits("Acceleration", "m/s²", 1.0, "m/s²", 1.0, "m/s²"),
    "strain": OutputUnits("Strain", "1", 1e6, "µε", 1e6, "µε"),
}


def output_units(source) -> OutputUnits:
    """The :class:`OutputUnits` of a measurement, a calibration result or a diagnosis
    (``measurement.output_kind``); displacement for None."""
    m = source
    if m is not None and not hasattr(m, "output_kind"):
        result = getattr(m, "base", m)  # a diagnosis: its base calibration
        m = result.setup.measurement
    return _UNITS["displacement" if m is None else m.output_kind]


_EXTRA_LABELS = {"noise_sd": "Noise sd σ (m)", "ar1_coefficient": "AR(1) coefficient ρ (1)"}


def parameter_label(name: str, output_unit: str = "m") -> str:
    """``"EI — bending stiffness (N m²)"`` for a catalogue parameter, ``"Noise sd σ (m)"`` for noise
    (in ``output_unit``, the record's output's SI unit: ``"m/s²"`` for an accelerometer)."""
    if name == "noise_sd":
        return f"Noise sd σ ({output_unit})"
    if name in _EXTRA_LABELS:
        return _EXTRA_LABELS[name]
    try:
        spec = parameter_spec(name)
    except ValueError:
        return name
    return f"{spec.symbol} — {spec.description} ({spec.unit})"


def short_label(name: str, output_unit: str = "m") -> str:
    """``"EI (N m²)"``: short axis label with unit (the noise sd's in ``output_unit``)."""
    if name == "noise_sd":
        return f"σ ({output_unit})"
    if name in _EXTRA_LABELS:
        return _EXTRA_LABELS[name].replace("Noise sd ", "").replace("AR(1) coefficient ", "")
    try:
        return parameter_spec(name).label
    except ValueError:
        return name


def result_label(result) -> str:
    """``"lab_run_1, window 0–1.05 s, 4 modes, air_damping + kelvin_voigt, iid"``."""
    s = result.setup
    lo, hi = s.window
    return f"{s.measurement.name}, window {lo:g}–{hi:g} s, {s.modes} modes, {' + '.join(s.effects) or 'bare beam'}, {s.likelihood}"


def convergence(result) -> dict:
    """``{"mcmc", "converged", "ess_min", "rhat_max", "warnings"}`` (preview: not converged, NaN)."""
    post = None if result is None else result.posterior
    if post is None:
        return {"mcmc": False, "converged": False, "ess_min": math.nan, "rhat_max": math.nan, "warnings": []}
    d = post.diagnostics
    return {"mcmc": True, "converged": bool(d.converged), "ess_min": float(d.ess_min), "rhat_max": float(d.rhat_max),
            "warnings": list(d.warnings)}


_memo: dict[tuple[int, str], tuple[object, object]] = {}
_memo_lock = threading.Lock()


def _memoised(result, what: str, compute):
    """``compute()`` once per result object (a result feeds several read-outs and tables at each update)."""
    key = (id(result), what)
    with _memo_lock:
        hit = _memo.get(key)
        if hit is not None and hit[0] is result:
            return hit[1]
    value = compute()
    with _memo_lock:
        _memo[key] = (result, value)
        while len(_memo) > 16:
            _memo.pop(next(iter(_memo)))
    return value


def summary(result) -> dict[str, dict[str, float]]:
    """``result.summary()``, computed once per result."""
    return _memoised(result, "summary", result.summary)


def readouts(result) -> dict:
    """RMSE in the window and held out, held-out 95 % coverage (%), noise sd; NaN without a result.

    The RMSEs and the noise sd are in ``out["unit"]`` (:func:`output_units` of the record: µm for
    displacement, mm/s for velocity, m/s² for acceleration).
    """
    keys = ("rmse_calibration", "rmse_prediction", "coverage_pct", "noise_sd")
    if result is None:
        return {**dict.fromkeys(keys, math.nan), "unit": output_units(None).unit}

    def compute():
        u = output_units(result)
        noise = summary(result).get("noise_sd", {}).get("mean", math.nan)
        return {"rmse_calibration": u.scale * result.rmse_calibration, "rmse_prediction": u.scale * result.rmse_prediction,
                "coverage_pct": 100.0 * result.coverage95_prediction, "noise_sd": u.scale * noise, "unit": u.unit}

    return dict(_memoised(result, "readouts", compute))


def _estimate(s: dict | None) -> str:
    if s is None:
        return "–"
    return f"{s['mean']:.4g} ± {s['sd']:.2g}  [{s['q025']:.4g}, {s['q975']:.4g}]"


def parameter_table(result) -> pd.DataFrame:
    """Parameters (mean ± sd [95 % interval]) with units; empty without a result."""
    if result is None:
        return pd.DataFrame()
    stats, si = summary(result), output_units(result).si_unit
    rows = {parameter_label(n, si): {"posterior mean ± sd [95 % interval]": _estimate(stats[n]),
                                 "relative sd (%)": f"{100 * stats[n]['sd'] / abs(stats[n]['mean']):.2g}"
                                 if stats[n]["mean"] else "–"} for n in stats}
    return pd.DataFrame.from_dict(rows, orient="index")


def correlation_table(result) -> pd.DataFrame:
    """Posterior correlations (sampling coordinates, 1), rounded to two decimals."""
    if result is None:
        return pd.DataFrame()
    corr = result.correlation()
    names, si = list(corr), output_units(result).si_unit
    return pd.DataFrame([[round(corr[a][b], 2) for b in names] for a in names],
                        index=[short_label(n, si) for n in names], columns=[short_label(n, si) for n in names])


def compare_table(current, pinned=None) -> pd.DataFrame:
    """Side by side: set-up, stage, parameters, RMSE (the current record's output unit, see
    :func:`output_units`), coverage (%), convergence; columns Pinned, Current."""
    if current is None:
        return pd.DataFrame()
    unit = output_units(current).unit
    columns = ({"Pinned": pinned} if pinned is not None else {}) | {"Current": current}
    names: list[str] = []
    for res in columns.values():
        names += [n for n in summary(res) if n not in names]
    index = (["Set-up", "Stage"] + [parameter_label(n, output_units(current).si_unit) for n in names] + [
        f"RMSE in the window ({unit})", f"Held-out RMSE ({unit})", "Held-out coverage, 95 % prediction band (%)",
        "Converged (min ESS, max R-hat)"])
    table = {}
    for label, res in columns.items():
        r, c, s = readouts(res), convergence(res), summary(res)
        conv = (f"{'yes' if c['converged'] else 'NO'} ({c['ess_min']:.0f}, {c['rhat_max']:.3f})" if c["mcmc"]
                else "preview (no MCMC)")
        table[label] = [result_label(res), "preview (MAP + Laplace)" if res.is_preview else "posterior (MCMC)"] + [
            _estimate(s.get(n)) for n in names] + [
            *(f"{r[k]:.4g}" + ("" if r["unit"] == unit else f" {r['unit']}") for k in ("rmse_calibration", "rmse_prediction")),
            f"{r['coverage_pct']:.1f}", conv]
    return pd.DataFrame(table, index=index)


# -- downloads ------------------------------------------------------------------------------------
def filename(result, extension: str) -> str:
    """e.g. ``lab_run_1_w0-1.05_m4_air_damping+kelvin_voigt_iid.json``."""
    s = result.setup
    effects = "+".join(s.effects) or "bare"
    return f"{s.measurement.name}_w{s.window[0]:g}-{s.window[1]:g}_m{s.modes}_{effects}_{s.likelihood}.{extension}"


def summary_json(result) -> io.BytesIO | None:
    """:meth:`CalibrationResult.to_json` as UTF-8 JSON (non-finite numbers as null)."""
    if result is None:
        return None
    text = json.dumps(jsonable(result.to_json()), indent=1, allow_nan=False)
    return io.BytesIO(text.encode("utf-8"))


def summary_html(result) -> io.BytesIO | None:
    """A one-page printable summary (:func:`beam.calibration.handout.calibration_handout`, self-contained
    HTML) with the read-outs judged in words as its first notes; None without a result."""
    if result is None:
        return None
    notes = [f"{it['label']}: {it['value']} {it['unit']} — {it['words']}" for it in judged_readouts(result) if it["words"]]
    return io.BytesIO(calibration_handout(result, notes).encode("utf-8"))


def ladder_steps(diagnosis, rungs: list[dict]) -> list:
    """The ladder's rows (:func:`dashboard.state.beam.ladder_rung`, in the read-out unit) as
    :class:`beam.discovery.ranking.LadderStep` (SI units), the starting model alone when there are none."""
    from beam.discovery.ranking import LadderStep

    if not rungs:
        base = diagnosis.base
        return [LadderStep(tuple(base.setup.effects), None, base.rmse_calibration, base.rmse_prediction,
                           base.coverage95_prediction, float(base.laplace.log_evidence), not base.is_preview, base)]
    scale = output_units(diagnosis).scale
    return [LadderStep(tuple(e for e in r["effects"].split(", ") if e), None if r["rung"] == 0 else r["added"],
                       r["rmse_calibration"] / scale, r["rmse_prediction"] / scale, r["coverage95_pct"] / 100.0,
                       r["log_evidence_laplace"], r["mcmc"]) for r in rungs]


def diagnosis_html(diagnosis, rungs: list[dict]) -> io.BytesIO | None:
    """The diagnosis's one-page printable summary, the page ``beam diagnose --report`` writes
    (:func:`beam.discovery.handout.diagnosis_handout`): the ladder as the view shows it, the
    ranked candidates, the residual plots; None before a complete diagnosis."""
    if diagnosis is None or diagnosis.pending:
        return None
    from beam.discovery.handout import diagnosis_handout

    text = diagnosis_handout(diagnosis.base, diagnosis.residuals, diagnosis.candidates, ladder_steps(diagnosis, rungs),
                             diagnosis.verdict, diagnosis.residuals.notes)
    return io.BytesIO(text.encode("utf-8"))


def bands_csv(result) -> io.BytesIO | None:
    """:meth:`CalibrationResult.band_table` (time, data, window flag, mean and 95 % bands, SI units)."""
    return None if result is None else io.BytesIO(result.band_table().encode("utf-8"))


def thinned_draws(result, n: int = 500) -> dict[str, np.ndarray]:
    """At most ``n`` evenly spaced posterior draws per parameter (for the pair plot)."""
    if result is None:
        return {}
    draws = result.draws()
    size = min(len(v) for v in draws.values())
    idx = np.linspace(0, size - 1, min(n, size)).astype(int)
    return {k: np.asarray(v)[idx] for k, v in draws.items()}


# -- words for students ---------------------------------------------------------------------------
def effect_title(effect: str) -> str:
    """``"Hardening tip spring"``: the catalogue title of an effect id (the id itself if unknown)."""
    e = EFFECTS.get(effect)
    return e.title if e is not None else effect


def effects_words(effects) -> str:
    """``"Air damping, Kelvin–Voigt damping"``, or ``"bare beam"``."""
    return ", ".join(effect_title(e) for e in effects) or "bare beam"


def fmt_value(value: float) -> str:
    """A read-out with sensible digits: ``"1 379"``, ``"57.3"``, ``"4.21"``, ``"0.052"``; ``"–"`` if not finite."""
    if not math.isfinite(value):
        return "–"
    a = abs(value)
    if a >= 100:
        return f"{value:,.0f}".replace(",", "\u2009")
    if a >= 10:
        return f"{value:.1f}"
    if a >= 1:
        return f"{value:.2f}"
    return f"{value:.2g}"


#: A length in µm (the same digits as :func:`fmt_value`).
fmt_um = fmt_value


def fmt_pct(value_pct: float) -> str:
    """A percentage with one decimal below 100 (``"99.4"``), ``"–"`` if not finite."""
    return f"{value_pct:.1f}" if math.isfinite(value_pct) else "–"


def change_words(new: float, old: float) -> str:
    """A signed change worded once: ``"3.3 % lower"``, ``"12 % higher"``, ``"unchanged"``."""
    if not (math.isfinite(new) and math.isfinite(old)) or old == 0:
        return "–"
    rel = 100.0 * (new - old) / abs(old)
    if abs(rel) < 0.05:
        return "unchanged"
    digits = 1 if abs(rel) < 10 else 0
    return f"{abs(rel):.{digits}f} % {'higher' if rel > 0 else 'lower'}"


_SUPERSCRIPT = str.maketrans("0123456789", "⁰¹²³⁴⁵⁶⁷⁸⁹")


def evidence_words(delta_nats: float) -> str:
    """Δ log evidence as odds: ``"+5.2 nats: odds about 180 : 1 for the effect"``."""
    if not math.isfinite(delta_nats):
        return "fit failed"
    if delta_nats > 230:  # e^230 ~ 1e100
        odds = "beyond 10¹⁰⁰ : 1"
    elif abs(delta_nats) < 0.05:
        return f"{delta_nats:+.1f} nats: no preference (odds 1 : 1)"
    else:
        ratio = math.exp(abs(delta_nats))
        digits = math.floor(math.log10(ratio))
        text = f"{float(f'{ratio:.2g}'):,.0f}" if digits < 4 else "10" + str(digits).translate(_SUPERSCRIPT)
        odds = f"about {text} : 1" if delta_nats > 0 else f"about 1 : {text}"
    side = "for" if delta_nats > 0 else "against"
    return f"{delta_nats:+.1f} nats: odds {odds} {side} the effect"


#: One-line glosses of the statistical terms the beam views show (also used as tooltips).
GLOSSES = {
    "posterior": "the parameter values that fit the data, with their uncertainty (MCMC draws)",
    "posterior predictive": "what the calibrated model predicts for new data, noise included",
    "prediction band": "where 95 % of new measurements should fall if the model were right",
    "credible band": "where the model's noise-free response lies, given the parameter uncertainty",
    "coverage": "share of held-out samples inside the 95 % prediction band (95 % if the model is right)",
    "held-out": "the part of the record not used for calibration",
    "log evidence": "how well a model explains the data, penalised for extra parameters; a difference "
                    "of Δ nats means odds of e^Δ : 1 between two models",
    "ESS": "effective sample size: how many independent draws the MCMC chain is worth",
    "R-hat": "agreement between chains; 1.00 means they agree, above 1.01 they have not converged",
    "Ljung-Box": "a test of whether the residuals are white noise; p < 0.05 means left-over structure",
    "noise floor": "the sensor noise read from the record itself (its quietest spectral band or its fourth differences), model-free",
    "MAP": "the single most probable parameter set (maximum a posteriori)",
}


# -- the noise floor of a record ------------------------------------------------------------------
def noise_floor_m(measurement) -> float:
    """Model-free estimate of the sensor noise sd of a record (in the output's SI unit: m, m/s or
    m/s²), NaN when it cannot be made.

    :func:`beam.residuals.noise.record_noise_floor` of the record as calibrated, the same estimate
    as the diagnosis's verdict and the command line's; memoised per record. A noise sd far above it
    is a misfit, not noise.
    """
    if measurement is None:
        return math.nan

    def compute():
        try:
            return record_noise_floor(measurement).sd
        except BeamInputError:
            return math.nan

    return _memoised(measurement, "noise_floor", compute)


def judged_readouts(result, floor_m: float | None = None) -> list[dict]:
    """The read-outs of a result, each judged against the model, not against coverage alone.

    Returns a list of ``{"key", "label", "value", "unit", "kind", "words", "gloss"}``; ``kind`` is
    ``"good"``, ``"bad"``, ``"warn"`` or ``"none"`` (colour of the number), ``words`` one
    sentence on what the number means for this model. The noise sd is compared with the
    record's model-free noise floor (:func:`noise_floor_m`): a model whose noise sd is several
    times the floor puts its misfit into the noise, so its wide band holds the data whatever
    the physics — a high coverage is then not good news, and is not coloured green.
    """
    r = readouts(result)
    u = output_units(result)
    if floor_m is None:
        floor_m = noise_floor_m(None if result is None else result.setup.measurement)
    floor_shown = u.scale * floor_m if floor_m is not None else math.nan  # in the read-outs' unit
    ratio = r["noise_sd"] / floor_shown if math.isfinite(floor_shown) and floor_shown > 0 else math.nan
    inflated = math.isfinite(ratio) and ratio > 3.0
    cov = r["coverage_pct"]
    out = []

    def item(key, label, value, unit, kind, words, gloss):
        out.append({"key": key, "label": label, "value": value, "unit": unit, "kind": kind, "words": words,
                    "gloss": gloss})

    if result is None:
        for key, label, unit in (("rmse_calibration", "Error in the window", u.unit),
                                 ("rmse_prediction", "Error on held-out data", u.unit),
                                 ("coverage_pct", "Held-out data inside the 95 % band", "%"),
                                 ("noise_sd", "Noise the model needs", u.unit)):
            item(key, label, "–", unit, "none", "", "")
        return out
    item("rmse_calibration", "Error in the window", fmt_value(r["rmse_calibration"]), u.unit, "none",
         "root-mean-square distance between data and model mean where it was calibrated",
         "RMSE: root-mean-square of data − model mean")
    ratio_pred = r["rmse_prediction"] / floor_shown if math.isfinite(ratio) else math.nan
    if math.isfinite(ratio_pred):
        if ratio_pred > 3.0:
            words = f"{ratio_pred:.0f}× the sensor noise (~{fmt_value(floor_shown)} {u.unit}): the model does not predict the rest of the record"
            kind = "bad"
        else:
            words = f"close to the sensor noise (~{fmt_value(floor_shown)} {u.unit}): the model predicts the rest of the record"
            kind = "good"
    else:
        words, kind = "root-mean-square error where the model was not calibrated", "none"
    item("rmse_prediction", "Error on held-out data", fmt_value(r["rmse_prediction"]), u.unit, kind, words,
         "RMSE on the part of the record not used for calibration")
    if not math.isfinite(cov):
        kind, words = "none", ""
    elif inflated:
        kind = "warn"
        words = (f"only because the band is {ratio:.0f}× too wide: the model needs a noise of "
                 f"{fmt_value(r['noise_sd'])} {u.unit} where the sensor has ~{fmt_value(floor_shown)} {u.unit}")
    elif cov < 85.0:
        kind, words = "bad", "well below 95 %: the band is too narrow, the model misses something"
    elif cov < 90.0:
        kind, words = "warn", "somewhat below 95 %: the band is a little too narrow"
    else:
        kind, words = "good", "about the 95 % a right model gives, with a noise close to the sensor's"
    item("coverage_pct", "Held-out data inside the 95 % band", fmt_pct(cov), "%", kind, words, GLOSSES["coverage"])
    if math.isfinite(ratio):
        kind = "bad" if inflated else "good"
        words = (f"{ratio:.0f}× the sensor's noise floor (~{fmt_value(floor_shown)} {u.unit}): the misfit is put into the noise"
                 if inflated else f"close to the sensor's noise floor (~{fmt_value(floor_shown)} {u.unit})")
    else:
        kind, words = "none", "standard deviation of the noise term of the likelihood"
    item("noise_sd", "Noise the model needs", fmt_value(r["noise_sd"]), u.unit, kind, words,
         "estimated noise sd σ; " + GLOSSES["noise floor"])
    return out


def verdict_text(diagnosis, rungs: list[dict] | None = None) -> str:
    """The diagnosis verdict in words, with effect titles, odds and the distance to the noise (Markdown).

    ``rungs``: the error ladder's rows (:func:`dashboard.state.beam.ladder_rung`, the beam view's
    calibrations in the read-out unit). When the last one is the model diagnosed, the error "now"
    is that row's, the figure the beam view shows for it (one number on the page), not the
    diagnosis's own preview of the same model."""
    if diagnosis is None:
        return ""
    if diagnosis.pending:
        return f"Ranking the candidate effects: {len(diagnosis.pending)} to go…"
    u = output_units(diagnosis)
    white = diagnosis.residuals.whiteness
    parts = diagnosis.verdict_parts(effect_title)  # the library's verdict (the command line's sentence), in words here
    missing, remaining = parts.missing, parts.remaining
    tail = ""
    if remaining is not None:  # the library's words (one wording with the command line's verdict)
        words = remaining_words(remaining, floor_text=f"{fmt_value(u.scale * remaining.noise_floor.sd)} {u.unit}")
        tail = f" {words[0].upper()}{words[1:]}."
    tail += "".join(f" {w[0].upper()}{w[1:]}." for w in parts.window_notes)
    if missing is not None:
        best = diagnosis.candidates[0]
        climbed = list(parts.then)
        free = diagnosis.base.setup.is_free
        what = "the error in the calibration window" if free else "the held-out error"
        before, after = u.scale * parts.before, u.scale * parts.after
        if rungs and rungs[-1]["effects"] == ", ".join(diagnosis.base.setup.effects) and rungs[-1]["unit"] == u.unit:
            before = rungs[-1]["rmse_calibration" if free else "rmse_prediction"]  # the beam view's figure of it
        names = ", then ".join(effect_title(e) for e in [missing, *climbed])
        text = (f"**Missing: {names}.** With {'them' if climbed else 'it'} {what} is {fmt_value(after)} {u.unit} instead "
                f"of {fmt_value(before)} {u.unit} ({change_words(after, before)}); evidence "
                f"{evidence_words(best.delta_log_evidence) if judgement_of(best, diagnosis.base).supports else f'{best.delta_log_evidence:+.1f} nats in the calibration window'}.")
        if climbed:
            text += (f" ({effect_title(climbed[0])} shows only once {effect_title(missing)} is in the model: "
                     "the diagnosis ranked the candidates again on top of it.)")
        alternatives = parts.alternatives
        if alternatives:
            text += (f" The data cannot tell it from {' or '.join(effect_title(e) for e in alternatives)}: the same "
                     "frequencies of the modes the record shows, the same repair by another cause.")
        for effect, count in parts.partly:
            text += f" {effect_title(effect)} places modes 1–{count} as well; only mode {count + 1} tells them apart."
        return text + tail
    if remaining is not None and (remaining.outside_catalogue or remaining.truncated):
        return "**Nothing in the catalogue helps.**" + tail
    if remaining is not None:
        return "**Nothing in the catalogue is missing.**" + tail
    if white.white:
        return ("**Nothing in the catalogue is missing**, and the residuals look like white noise "
                f"(Ljung–Box p = {white.p_value:.2g} ≥ 0.05)." + tail)
    return ("**Nothing in the catalogue is missing**, but the residuals are not white noise (Ljung–Box p = "
            f"{_p(white.p_value)} < 0.05): the discrepancy is outside the catalogue or in the noise model." + tail)


def _p(p: float) -> str:
    """A p-value: ``"0.032"``, ``"< 10⁻⁶"`` (never ``"0"``)."""
    if not math.isfinite(p):
        return "–"
    return "< 10⁻⁶" if p < 1e-6 else f"{p:.2g}"


def truth_table(result, answer: dict | None) -> pd.DataFrame:
    """Posterior against the true values of a revealed bundled dataset (units in the labels)."""
    if result is None:
        return pd.DataFrame()
    stats, si = summary(result), output_units(result).si_unit
    truth = dict((answer or {}).get("parameters", {}))
    if answer is not None and answer.get("noise_m") is not None:
        truth["noise_sd"] = float(answer["noise_m"])
    rows = {}
    for n, s in stats.items():
        row = {"posterior mean ± sd [95 % interval]": _estimate(s)}
        if answer is not None:
            t = truth.get(n)
            row["true value"] = f"{t:.4g}" if t is not None else "–"
            row["truth inside the 95 % interval"] = ("–" if t is None else
                                                     "yes" if s["q025"] <= t <= s["q975"] else "NO")
        rows[parameter_label(n, si)] = row
    if answer is not None:
        for n, t in truth.items():
            if n not in stats:
                rows[parameter_label(n, si)] = {"posterior mean ± sd [95 % interval]": "not in the model",
                                            "true value": f"{t:.4g}", "truth inside the 95 % interval": "–"}
    return pd.DataFrame.from_dict(rows, orient="index")
