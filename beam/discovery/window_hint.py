"""The "longer window" hint: when a free decay's calibration window is too short to tell a
damping that grows with the amplitude (``quadratic_drag``) from a constant one.

A viscous damping makes the log-envelope of a mode a straight line; a quadratic drag bends it
(the decay rate is proportional to the amplitude's share the drag takes). Over a window in which
the amplitude falls little, the bend is invisible: both laws fit the window equally well and
part company only later, on the held-out record. How far the amplitude must fall: the decay
rate of the drag's share goes with the amplitude, so to see it change by a factor the amplitude
must change by that factor; :data:`MIN_FALL` asks for a fall to half (the issue's two-mode
envelope check fitted on 0-2 s of the strip, where mode 1 falls ~30 %, gained 1.0-1.6x on the
held-out error and on 0-5 s, a fall of ~55 %, 1.34-1.47x with a consistent drag coefficient).

The hint is given on a free decay when the mode-1 envelope of the whole record shows a decay rate
that changes with the amplitude (the decay law's ``decay_rate_change`` beyond
:data:`RATE_CHANGE`), the amplitude falls less than :data:`MIN_FALL` inside the window, and the
record goes on long enough to reach that fall: it names the fall inside the window and the window
that would reach it.
"""

from __future__ import annotations

import math

import numpy as np

from beam.physics.effects import quadratic_drag

__all__ = ["MIN_FALL", "RATE_CHANGE", "longer_window_hint", "window_hint_notes"]

#: Fraction by which the mode-1 amplitude must fall inside the window to tell the damping laws apart.
MIN_FALL = 0.5
#: |relative change of the decay rate| over the record beyond which the damping changes with the
#: amplitude: the drag's fingerprint threshold (:data:`beam.residuals.fingerprints.THRESHOLDS`).
RATE_CHANGE = quadratic_drag.EFFECT.fingerprint.threshold


def longer_window_hint(time_s: np.ndarray, envelope: np.ndarray, window: tuple[float, float],
                       decay_rate_change: float) -> str | None:
    """The hint for a mode-1 envelope (``time_s`` in s, ``envelope`` in any unit, > 0) and a
    calibration ``window`` (s), or None when none is due (see the module notes).

    The amplitude at the window's ends is the envelope's mean over the first and last 5 % of the
    window's envelope samples (at least one); the suggested window keeps its start and ends at
    the first whole second at which the envelope has fallen by :data:`MIN_FALL` from its value
    at the start.
    """
    t = np.asarray(time_s, dtype=float)
    a = np.asarray(envelope, dtype=float)
    if not (math.isfinite(decay_rate_change) and abs(decay_rate_change) >= RATE_CHANGE):
        return None
    inside = (t >= window[0]) & (t <= window[1]) & np.isfinite(a) & (a > 0)
    if np.count_nonzero(inside) < 4:
        return None
    values = a[inside]
    edge = max(1, values.size // 20)
    start, end = float(np.mean(values[:edge])), float(np.mean(values[-edge:]))
    fall = 1.0 - end / start
    if fall >= MIN_FALL:
        return None
    later = (t > window[1]) & np.isfinite(a) & (a <= (1.0 - MIN_FALL) * start)
    if not np.any(later):
        return None  # the record never falls that far: no longer window would tell
    reach = math.ceil(float(t[np.argmax(later)]))
    return (f"the swing falls only {100 * fall:.0f} % inside {window[0]:g}–{window[1]:g} s: too little to tell a "
            f"damping that grows with amplitude from a constant one (the decay rate of mode 1 changes by "
            f"{100 * abs(decay_rate_change):.0f} % over the record); calibrate on {window[0]:g}–{reach:g} s, where it "
            f"falls by half")


def window_hint_notes(result, mode1) -> list[str]:
    """The hint (a list of at most one note) for a calibration ``result`` of a free decay and its
    mode-1 analysis ``mode1`` (:func:`beam.residuals.analyse_mode` over the record, or None)."""
    if mode1 is None or not result.setup.is_free:
        return []
    hint = longer_window_hint(mode1.envelope.time_s, mode1.envelope.envelope_m, result.setup.window,
                              mode1.decay.decay_rate_change)
    return [] if hint is None else [hint]
