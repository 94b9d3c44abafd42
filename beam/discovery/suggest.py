"""Which record to take next: where a new record would separate two explanations most.

When the top two explanations of a record (or of a joint set) fit it alike, their calibrated
models agree on what was measured and disagree elsewhere. :func:`suggest_record` predicts, from
each model's posterior (Laplace draws of its physical parameters), the natural frequencies of the
same strip in another setting of the rig:

- another **free length** (the strip clamped shorter or longer; the sensor stays glued where it
  is on the strip, at the same distance from the tip), within ``length_range``;
- another **sensor position** (at the reference record's length), within ``position_range``.

Each setting is scored by how far apart the two MAP models put f1 against what a record can tell:
``|f1_a - f1_b| / sqrt(sd_a^2 + sd_b^2 + (1/T)^2)`` (sd: the spread of each model's predicted f1
over Laplace draws of its parameters, 0 where its Laplace approximation is not sound; 1/T: the
frequency resolution of a record of the reference record's duration T). f1 is scored because a
free decay always shows it; f2 is reported beside it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from beam.errors import BeamInputError
from beam.physics.effects import effective_length, modal_damping

__all__ = ["Setting", "Suggestion", "default_length_range", "next_record", "suggest_record"]

#: Default free-length range of a suggestion, as fractions of the reference record's length: a
#: strip is clamped shorter by pushing it onto the table and somewhat longer if it has spare length.
LENGTH_FRACTIONS = (0.6, 1.2)
#: Default sensor-position range, as fractions of the reference record's length (from the clamp).
POSITION_FRACTIONS = (0.4, 1.0)
#: Settings scanned per range.
POINTS = 17
#: Laplace draws of each model's parameters.
DRAWS = 64


@dataclass(frozen=True)
class Setting:
    """One scanned setting of the rig and what the two models predict for it.

    Attributes
    ----------
    kind : {"length", "sensor_position"}
        What was changed from the reference record.
    length_m, sensor_position_m : float
        Free length and sensor position (from the clamp), m.
    f1_Hz, f2_Hz : tuple of float
        First and second natural frequencies of the MAP model a and the MAP model b (Hz).
    f1_sd_Hz : tuple of float
        Spread (sd) of each model's predicted f1 over Laplace draws (Hz; 0: MAP only).
    duration_s : float
        Duration of the record the resolution refers to (s).
    """

    kind: str
    length_m: float
    sensor_position_m: float
    f1_Hz: tuple[float, float]
    f2_Hz: tuple[float, float]
    f1_sd_Hz: tuple[float, float]
    duration_s: float

    @property
    def resolution_Hz(self) -> float:
        """Frequency resolution 1/T of a record of :attr:`duration_s` (Hz)."""
        return 1.0 / self.duration_s

    @property
    def f1_difference_pct(self) -> float:
        """100 |f1_a - f1_b| / f1_b."""
        return 100.0 * abs(self.f1_Hz[0] - self.f1_Hz[1]) / self.f1_Hz[1]

    @property
    def f2_difference_pct(self) -> float:
        """100 |f2_a - f2_b| / f2_b."""
        return 100.0 * abs(self.f2_Hz[0] - self.f2_Hz[1]) / self.f2_Hz[1]

    @property
    def f1_difference_resolutions(self) -> float:
        """|f1_a - f1_b| in units of the resolution 1/T."""
        return abs(self.f1_Hz[0] - self.f1_Hz[1]) / self.resolution_Hz

    @property
    def score(self) -> float:
        """|f1_a - f1_b| / sqrt(sd_a² + sd_b² + (1/T)²): the separation in units of what is uncertain."""
        return abs(self.f1_Hz[0] - self.f1_Hz[1]) / float(np.sqrt(np.sum(np.square(self.f1_sd_Hz))
                                                                  + self.resolution_Hz ** 2))

    def to_json(self) -> dict:
        return {"kind": self.kind, "length_m": self.length_m, "sensor_position_m": self.sensor_position_m,
                "f1_Hz": list(self.f1_Hz), "f2_Hz": list(self.f2_Hz), "f1_sd_Hz": list(self.f1_sd_Hz),
                "f1_difference_pct": self.f1_difference_pct, "f2_difference_pct": self.f2_difference_pct,
                "duration_s": self.duration_s, "resolution_Hz": self.resolution_Hz,
                "f1_difference_resolutions": self.f1_difference_resolutions, "score": self.score}


@dataclass
class Suggestion:
    """Where a new record separates explanations ``effects[0]`` and ``effects[1]`` most.

    Attributes
    ----------
    effects : tuple of str
        The two explanations (a, b).
    delta_log_evidence : float
        Their current evidence difference, a minus b (nats).
    best : Setting
        The setting with the highest :attr:`Setting.score`.
    reference : str
        The record whose beam the settings change.
    settings : list of Setting
        Every scanned setting.
    """

    effects: tuple[str, str]
    delta_log_evidence: float
    best: Setting
    reference: str
    settings: list[Setting] = field(default_factory=list)

    def best_of(self, kind: str) -> Setting | None:
        """The best setting of one kind (None when that kind was not scanned)."""
        own = [s for s in self.settings if s.kind == kind]
        return max(own, key=lambda s: s.score) if own else None

    def words(self) -> str:
        """One sentence, e.g. "clamp it at 35 cm: sensor_mass and tip_mass predict f1 4.3 % apart,
        40x what a 20 s record resolves"; when the best setting's f1 difference is below the
        resolution 1/T, that no setting within the ranges separates them."""
        a, b = self.effects
        best = self.best
        where = (f"clamp it at {100.0 * best.length_m:.0f} cm (sensor {100.0 * best.sensor_position_m:.0f} cm "
                 f"from the clamp)" if best.kind == "length"
                 else f"move the sensor to {100.0 * best.sensor_position_m:.0f} cm from the clamp "
                      f"(free length {100.0 * best.length_m:.0f} cm)")
        if best.f1_difference_resolutions < 1.0:
            return (f"no setting within the ranges separates {a} from {b} as calibrated: at best ({where}) they "
                    f"predict f1 {best.f1_difference_pct:.2g} % apart, {best.f1_difference_resolutions:.2g}x what a "
                    f"{best.duration_s:.3g} s record resolves ({best.resolution_Hz:.2g} Hz). Explanations that predict the "
                    f"same frequencies everywhere (effects that only damp, or two fits that both left their effect "
                    f"out, such as a mass near zero) are not told apart by another length or sensor position: widen "
                    f"the ranges, or compare what the frequencies do not show (each mode's damping).")
        return (f"{where}: {a} and {b} predict f1 {best.f1_difference_pct:.2g} % apart "
                f"({best.f1_Hz[0]:.4g} against {best.f1_Hz[1]:.4g} Hz), {best.f1_difference_resolutions:.2g}x what a "
                f"{best.duration_s:.3g} s record resolves ({best.resolution_Hz:.2g} Hz), and f2 "
                f"{best.f2_difference_pct:.2g} % apart.")

    def to_json(self) -> dict:
        """The ``suggestion`` key of ``beam diagnose ... --suggest --json``."""
        best = self.best
        return {"effects": list(self.effects), "delta_log_evidence": self.delta_log_evidence,
                "reference": self.reference, "kind": best.kind, "length_m": best.length_m,
                "sensor_position_m": best.sensor_position_m,
                "f1_Hz": list(best.f1_Hz), "f2_Hz": list(best.f2_Hz),
                "f1_difference_pct": best.f1_difference_pct, "f2_difference_pct": best.f2_difference_pct,
                "duration_s": best.duration_s, "resolution_Hz": best.resolution_Hz,
                "f1_difference_resolutions": best.f1_difference_resolutions,
                "words": self.words(), "settings": [s.to_json() for s in self.settings]}


def default_length_range(length_m: float) -> tuple[float, float]:
    """The default free-length range (m) around a record's length (:data:`LENGTH_FRACTIONS`)."""
    return LENGTH_FRACTIONS[0] * length_m, LENGTH_FRACTIONS[1] * length_m


def suggest_record(
    fits: Sequence,
    effects: Sequence[str],
    delta_log_evidence: float,
    *,
    reference: int = 0,
    length_range: tuple[float, float] | None = None,
    position_range: tuple[float, float] | None = None,
    lengths: bool = True,
    positions: bool = True,
    draws: int = DRAWS,
    seed: int = 0,
    points: int = POINTS,
) -> Suggestion:
    """Scan settings of the rig for the one where two calibrated explanations differ most.

    Parameters
    ----------
    fits : sequence of two JointCalibrationResult
        The joint (or one-record) calibrations of the two explanations on the same records.
    effects : sequence of two str
        Their names (for the words).
    delta_log_evidence : float
        Their current evidence difference (nats), reported as is.
    reference : int
        The record whose beam is changed (its geometry, duration and per-record parameters).
    length_range, position_range : (float, float), optional
        Free lengths (m) and sensor positions (m from the clamp) the rig allows; default
        :func:`default_length_range` and :data:`POSITION_FRACTIONS` of the reference length.
    lengths, positions : bool
        Which kinds of setting to scan.
    draws, seed : int
        Laplace draws of each model's parameters (their spread of the predicted f1), and the seed.
    points : int
        Settings per range.

    Returns
    -------
    Suggestion
    """
    if len(fits) != 2 or len(effects) != 2:
        raise BeamInputError("a suggestion compares two explanations")
    if not (lengths or positions):
        raise BeamInputError("nothing to scan: neither lengths nor sensor positions")
    setup = fits[0].records[reference].setup
    geometry = setup.measurement.geometry
    time_s = np.asarray(setup.measurement.time_s, dtype=float)
    duration = float(time_s[-1] - time_s[0])
    length = float(geometry.length_m)
    from_tip = length - float(geometry.sensor_position_m)
    samples = [_parameter_draws(fit, reference, draws, seed) for fit in fits]
    candidates: list[tuple[str, float, float]] = []
    if lengths:
        lo, hi = _range(length_range or default_length_range(length), "length range")
        candidates += [("length", float(L), float(L) - from_tip) for L in np.linspace(lo, hi, points) if L > from_tip]
    if positions:
        lo, hi = _range(position_range or (POSITION_FRACTIONS[0] * length, POSITION_FRACTIONS[1] * length),
                        "sensor-position range")
        if hi > length * (1.0 + 1e-9):
            raise BeamInputError(f"the sensor-position range reaches past the tip ({hi:g} m > {length:g} m)")
        candidates += [("sensor_position", length, float(x)) for x in np.linspace(lo, hi, points)]
    if not candidates:
        raise BeamInputError("no setting to scan: every length of the range is shorter than the sensor's "
                             "distance from the tip")
    settings = []
    for kind, L, x in candidates:
        changed = replace(geometry, length_m=L, sensor_position_m=x)
        f = [_frequencies(fit.records[reference].setup, changed, values, length) for fit, values in zip(fits, samples)]
        settings.append(Setting(kind, L, x, (float(f[0][0, 0]), float(f[1][0, 0])), (float(f[0][1, 0]), float(f[1][1, 0])),
                                (float(f[0][0, 1:].std()) if f[0].shape[1] > 2 else 0.0,
                                 float(f[1][0, 1:].std()) if f[1].shape[1] > 2 else 0.0), duration))
    best = max(settings, key=lambda s: s.score)
    return Suggestion((effects[0], effects[1]), float(delta_log_evidence), best,
                      setup.measurement.name, settings)


def next_record(
    ranked: Sequence[tuple[str, float | None]],
    fits_of,
    *,
    length_range: tuple[float, float] | None = None,
    position_range: tuple[float, float] | None = None,
) -> dict:
    """Which record to take next, as ``beam diagnose --suggest`` reports it.

    Parameters
    ----------
    ranked : sequence of (str, float or None)
        The candidate effects and their Δ log evidence (nats), best first; None for a failed fit.
    fits_of : callable
        ``fits_of(a, b)``: the two joint calibrations of explanations ``a`` and ``b`` (as
        :func:`suggest_record` takes them); called only when a suggestion is needed.
    length_range, position_range : (float, float), optional
        As :func:`suggest_record`.

    Returns
    -------
    dict
        ``{"needed": False, "words": ...}`` (with ``effects`` and ``delta_log_evidence`` when
        the best candidate is not material, :data:`beam.discovery.ranking.MATERIAL_LOG_EVIDENCE`,
        or the top two are separated by :data:`beam.discovery.joint.SEPARATING_NATS` already), else
        ``{"needed": True, **Suggestion.to_json()}``.
    """
    from beam.discovery.joint import SEPARATING_NATS
    from beam.discovery.ranking import MATERIAL_LOG_EVIDENCE

    ranked = [(e, d) for e, d in ranked if d is not None]
    if len(ranked) < 2:
        return {"needed": False, "words": "fewer than two explanations were fitted: nothing to separate."}
    (a, da), (b, db) = ranked[:2]
    if da < MATERIAL_LOG_EVIDENCE:  # no explanation is supported: there is no pair to tell apart
        return {"needed": False, "effects": [a, b], "delta_log_evidence": da - db,
                "words": f"no candidate improves the model materially (the best, {a}, by {da:.1f} nats, under "
                         f"{MATERIAL_LOG_EVIDENCE:g}): there are no two explanations to tell apart yet."}
    if da - db >= SEPARATING_NATS:
        return {"needed": False, "effects": [a, b], "delta_log_evidence": da - db,
                "words": f"{a} and {b} are separated already ({da - db:.1f} nats): no further record needed."}
    suggestion = suggest_record(fits_of(a, b), (a, b), da - db, length_range=length_range,
                                position_range=position_range)
    return {"needed": True, **suggestion.to_json()}


def _range(pair: tuple[float, float], what: str) -> tuple[float, float]:
    lo, hi = (float(v) for v in pair)
    if not (np.isfinite(lo) and np.isfinite(hi) and 0.0 < lo < hi):
        raise BeamInputError(f"the {what} must be 0 < A < B (m), got {lo:g}:{hi:g}")
    return lo, hi


def _parameter_draws(fit, record: int, n: int, seed: int) -> dict[str, np.ndarray]:
    """The MAP and ``n - 1`` Laplace draws of record ``record``'s physical parameters (its own
    names) under a joint fit; the MAP alone where the Laplace approximation is not sound (a flat
    ridge: its Gaussian does not describe the posterior, and its draws would not even reproduce
    the frequencies the records measured)."""
    problem = fit.problem
    names = problem.record_names(record)
    setup = fit.records[record].setup
    drawn = fit.laplace.draws(n - 1, seed=seed) if n > 2 and fit.laplace.ok else {}
    out = {}
    for own in setup.physical_names:
        centre = float(fit.laplace.map.values[names[own]])
        rest = np.asarray(drawn.get(names[own], np.empty(0)), dtype=float)[: max(n - 1, 0)]
        out[own] = np.concatenate([[centre], rest])
    return out


def _frequencies(setup, geometry, values: dict[str, np.ndarray], stated_length_m: float) -> np.ndarray:
    """f1 and f2 (Hz), shape (2, draws), of ``setup``'s effects on ``geometry`` at ``values``
    (an effective length scales with the stated one)."""
    from beam.calibration.joint import model_modes
    from beam.physics.model import BeamModel

    values = dict(values)
    first = values.get(modal_damping.ratio_name(1))
    for j in (1, 2):  # a fit of one mode has no ratio for mode 2: |pole| = the natural frequency whatever it is
        if first is not None and modal_damping.ratio_name(j) not in values:
            values[modal_damping.ratio_name(j)] = first
    length = effective_length.LENGTH.name
    if length in values:
        values[length] = values[length] * geometry.length_m / stated_length_m
    model = BeamModel(geometry, setup.model.effects, input_kind=None)
    f, _ = model_modes(model, values, 2)
    return f.T
