"""The diagnosis's words against its numbers: the modes table's one sign convention."""

from __future__ import annotations

import math
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from beam.residuals import DIFFERENCE_CONVENTION, compare_modes, difference_words

ROOT = str(Path(__file__).resolve().parents[1])
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)


def _direction(words: str) -> int:
    """+1 for "… higher", -1 for "… lower", 0 for "matches"."""
    return 1 if words.endswith("higher") else -1 if words.endswith("lower") else 0


def test_difference_words_read_as_the_measured_value_against_the_model():
    # measured 5.513 Hz, model 4.693 Hz: the measured mode is 17.5 % higher than the model's
    (row,) = compare_modes(([5.513], [0.002]), [4.693], [0.004])
    assert row.frequency_error_pct == pytest.approx(100 * (5.513 / 4.693 - 1))
    assert difference_words(row.frequency_error_pct) == "17.5 % higher"
    assert difference_words(row.damping_error_pct, 0) == "50 % lower"  # 0.002 measured against 0.004
    assert difference_words(0.04) == "matches" and difference_words(math.nan) == "–"
    assert "positive when the measured value is higher" in DIFFERENCE_CONVENTION


def test_the_dashboard_modes_table_says_what_it_computes():
    """Every row's words agree with the table's own measured and model columns (the same
    convention as the JSON's ``frequency_error_pct``)."""
    pytest.importorskip("panel")
    from dashboard.views.diagnosis import modes_table

    rng = np.random.default_rng(4)
    model = np.array([4.693, 29.41, 82.35, 161.4])
    measured = model * (1 + rng.uniform(-0.3, 0.3, model.size))
    comparison = compare_modes((measured[:3], [0.0017, 0.0015, 0.004]), model, [0.036, 0.0061, 0.0029, 0.0028])
    table = modes_table(SimpleNamespace(residuals=SimpleNamespace(comparison=comparison)))
    assert "measured f vs model" in table.columns and "measured ζ vs model" in table.columns
    for row, match in zip(table.itertuples(), comparison):
        words = table.loc[row.Index, "measured f vs model"]
        if not match.matched:
            assert words == "–"
            continue
        shown_data, shown_model = float(table.loc[row.Index, "measured f (Hz)"]), float(table.loc[row.Index, "model f (Hz)"])
        assert _direction(words) == np.sign(round(shown_data - shown_model, 2))
        assert float(words.split(" %")[0]) == pytest.approx(abs(100 * (shown_data / shown_model - 1)), abs=0.1)
        zeta = table.loc[row.Index, "measured ζ vs model"]
        assert _direction(zeta) == np.sign(match.damping_data - match.damping_model)
