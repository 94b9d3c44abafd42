"""What a calibration is asked for: one frozen, hashable settings object.

:class:`CalibrationSpec` holds the record window, the effects, the retained modes (a number or
``"auto"``), the likelihood, the seed and the sampling targets. Its field defaults are the
defaults of every front end (the Python API, ``beam calibrate``, ``beam diagnose``, the
dashboard): change one in :mod:`beam.calibration.defaults` and each of them sees it. :meth:`CalibrationSpec.resolve` fills in
what depends on the record (the default window, the ``"auto"`` number of modes) once; the
resolved spec is the key of the engine's memory (:class:`beam.calibration.engine.Engine`).

This module imports no numerical library: the command line reads its defaults before it reads
a file.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field, fields, replace
from typing import Any

from beam.calibration import defaults
from beam.calibration.defaults import AUTO_MODES, DEFAULT_EFFECTS, DEFAULT_MODES, DEFAULT_WINDOW_FRACTION
from beam.errors import BeamInputError
from beam.physics.effects import parse_effects

__all__ = ["AUTO_MODES", "DEFAULT_EFFECTS", "DEFAULT_MODES", "DEFAULT_WINDOW_FRACTION", "CalibrationSpec"]


def _default(field_name: str):
    """A field whose default is read from :mod:`beam.calibration.defaults` when a spec is built."""
    name = defaults.SPEC_DEFAULTS[field_name]
    return field(default_factory=lambda: getattr(defaults, name))


def _number(name: str, value) -> float:
    """``value`` as a finite float (BeamInputError naming ``name`` otherwise)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(float(value)):
        raise BeamInputError(f"{name} must be a finite number, got {value!r}")
    return float(value)


def _integer(name: str, value) -> int:
    """``value`` as an int (an integral float accepted; BeamInputError naming ``name`` otherwise)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not float(value).is_integer():
        raise BeamInputError(f"{name} must be an integer, got {value!r}")
    return int(value)


@dataclass(frozen=True)
class CalibrationSpec:
    """The settings of one calibration (frozen and hashable; defaults from :mod:`beam.calibration.defaults`).

    Attributes
    ----------
    window : (start_s, end_s) or None
        Calibration window (s); None: the first :attr:`window_fraction` of the record.
    effects : tuple of str
        Effects added to the base model, catalogue order (a comma-separated string or any
        iterable is accepted and normalised).
    modes : int or "auto"
        Retained modes; ``"auto"``: chosen from the record's excited band.
    likelihood : {"iid", "ar1"}
        Noise model.
    seed : int
        Seed of the sampler and of the band draws.
    target_ess : float
        Bulk ESS every parameter must reach (with R-hat <= 1.01).
    max_steps : int
        Cap on ensemble steps.
    walkers : int or None
        Ensemble size (None: :func:`beam.calibration.run.default_walkers`).
    steps : int or None
        Exactly this many ensemble steps instead of sampling to ``target_ess``.
    window_fraction : float
        Fraction of the record from its start that a default window covers.
    mode_choice : ModeChoice or None
        How ``"auto"`` modes were chosen (set by :meth:`resolve`; not part of the key).
    """

    window: tuple[float, float] | None = None
    effects: tuple[str, ...] = _default("effects")
    modes: int | str = _default("modes")
    likelihood: str = _default("likelihood")
    seed: int = _default("seed")
    target_ess: float = _default("target_ess")
    max_steps: int = _default("max_steps")
    walkers: int | None = None
    steps: int | None = None
    window_fraction: float = _default("window_fraction")
    mode_choice: Any = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        """Normalise and check every field (BeamInputError names the first one at fault; the
        bounds that depend on the record, the window inside it and the modes its mesh holds, are
        checked where the setup is made, :func:`beam.calibration.pipeline.make_setup`)."""
        object.__setattr__(self, "effects", parse_effects(self.effects))
        if self.window is not None:
            try:
                start, end = (float(v) for v in self.window)
            except (TypeError, ValueError):
                raise BeamInputError(f"calibration window must be (start, end) in seconds, got {self.window!r}") from None
            if not (math.isfinite(start) and math.isfinite(end)) or not start < end:
                raise BeamInputError(f"calibration window must have start < end, got {start}:{end}")
            object.__setattr__(self, "window", (start, end))
        modes = self.modes
        if modes is None or (isinstance(modes, str) and modes.strip().lower() == AUTO_MODES):
            modes = AUTO_MODES
        elif isinstance(modes, str) and modes.strip().isdigit():
            modes = int(modes)
        elif not isinstance(modes, bool) and isinstance(modes, (int, float)) and float(modes).is_integer():
            modes = int(modes)
        if modes != AUTO_MODES and not (isinstance(modes, int) and modes >= 1):
            raise BeamInputError(f"modes must be a positive integer or {AUTO_MODES!r}, got {self.modes!r}")
        object.__setattr__(self, "modes", modes)
        if self.likelihood not in defaults.LIKELIHOOD_NAMES:
            raise BeamInputError(f"unknown likelihood {self.likelihood!r}; expected one of {', '.join(defaults.LIKELIHOOD_NAMES)}")
        object.__setattr__(self, "likelihood", str(self.likelihood))
        object.__setattr__(self, "seed", _integer("seed", self.seed))
        target = _number("target_ess", self.target_ess)
        if not target > 0:
            raise BeamInputError(f"target_ess must be positive, got {self.target_ess!r}")
        object.__setattr__(self, "target_ess", target)
        max_steps = _integer("max_steps", self.max_steps)
        if max_steps < 1:
            raise BeamInputError(f"max_steps must be a positive integer, got {self.max_steps!r}")
        object.__setattr__(self, "max_steps", max_steps)
        for name, least in (("walkers", 2), ("steps", 10)):
            value = getattr(self, name)
            if value is not None and (isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < least):
                raise BeamInputError(f"{name} must be an integer >= {least}, got {value}")
        fraction = _number("window_fraction", self.window_fraction)
        if not 0.0 < fraction <= 1.0:
            raise BeamInputError(f"window_fraction must be in (0, 1], got {self.window_fraction!r}")
        object.__setattr__(self, "window_fraction", fraction)

    @classmethod
    def of(cls, spec: CalibrationSpec | None = None, **options) -> CalibrationSpec:
        """``spec`` (default: the defaults) with ``options`` replaced: the keywords of
        :func:`beam.calibration.calibrate` and friends build their spec so (a ``None`` option
        keeps the spec's value, except ``window``, ``walkers`` and ``steps``, whose None means
        their default).

        Raises
        ------
        TypeError
            An option that is not a field of the spec.
        """
        names = {f.name for f in fields(cls)}
        unknown = sorted(set(options) - names)
        if unknown:
            raise TypeError(f"unexpected calibration option {unknown[0]!r}")
        nullable = {"window", "walkers", "steps", "mode_choice"}
        options = {k: v for k, v in options.items() if v is not None or k in nullable}
        return replace(spec, **options) if spec is not None else cls(**options)

    @property
    def is_resolved(self) -> bool:
        """Whether the window and the number of modes are set."""
        return self.window is not None and self.modes != AUTO_MODES

    def default_window(self, measurement) -> tuple[float, float]:
        """The first :attr:`window_fraction` of ``measurement`` (s) (:func:`beam.calibration.defaults.default_window`)."""
        t = measurement.time_s
        return defaults.default_window(t[0], t[-1], self.window_fraction)

    def resolve(self, measurement) -> CalibrationSpec:
        """The spec with the default window and ``"auto"`` modes filled in from ``measurement``
        (the record as calibrated: a record longer than the calibration limit is decimated first,
        :func:`beam.calibration.records.decimate_measurement`). A resolved spec is returned as it is.

        ``"auto"``: :func:`beam.calibration.modes.suggest_modes` on the window; a record too short
        for a spectrum keeps :data:`DEFAULT_MODES` (a bad window is reported when the setup is made).
        """
        if self.is_resolved:
            return self
        from beam.calibration.modes import suggest_modes
        from beam.calibration.records import decimate_measurement
        from beam.io.limits import MAX_CALIBRATION_SAMPLES

        measurement, _ = decimate_measurement(measurement, MAX_CALIBRATION_SAMPLES)
        modes, choice = self.modes, None
        if modes == AUTO_MODES:
            try:
                choice = suggest_modes(measurement, self.window, self.effects)
                modes = choice.modes
            except BeamInputError:
                modes = DEFAULT_MODES
        window = self.window if self.window is not None else self.default_window(measurement)
        return replace(self, window=window, modes=modes, mode_choice=choice)

    def model_key(self) -> tuple:
        """What a model's optimum depends on besides the record: window, modes, likelihood and
        effects (not the seed nor the sampling targets). The spec must be resolved."""
        if not self.is_resolved:
            raise ValueError("resolve the spec first (CalibrationSpec.resolve)")
        return tuple(self.window), int(self.modes), self.likelihood, tuple(self.effects)

    @classmethod
    def of_setup(cls, setup) -> CalibrationSpec:
        """The resolved spec of a :class:`~beam.calibration.setup.BeamCalibrationSetup`'s model
        (window, effects, modes, likelihood and how the modes were chosen; the other fields at
        their defaults)."""
        return cls(setup.window, setup.effects, setup.modes, setup.likelihood, mode_choice=setup.mode_choice)

    def with_effects(self, effects) -> CalibrationSpec:
        """The same spec for another effect set."""
        return replace(self, effects=parse_effects(effects))

    def for_model(self, effects) -> CalibrationSpec:
        """The spec of the model with ``effects`` on this spec's window, modes and likelihood, every
        other field at its default (a candidate's preview, a sub-model's: what its optimum depends on)."""
        return CalibrationSpec(self.window, parse_effects(effects), self.modes, self.likelihood)

    def describe(self) -> str:
        """One line: ``window 0–1.05 s, 4 modes, effects air_damping, kelvin_voigt, likelihood iid``."""
        window = "default window" if self.window is None else f"window {self.window[0]:g}–{self.window[1]:g} s"
        effects = ", ".join(self.effects) or "none"
        return f"{window}, {self.modes} modes, effects {effects}, likelihood {self.likelihood}"
