"""The diagnosis page's "Diagnosis for print (HTML)" is the page ``beam diagnose --report`` writes."""

from __future__ import annotations

import re
from pathlib import Path
from types import SimpleNamespace

from beam.discovery.handout import report_handout
from beam.discovery.report import diagnose
from beam.io.measurement import read_measurement
from dashboard.outputs.beam import diagnosis_html, ladder_steps, output_units
from dashboard.state.beam import ladder_rung


MEASUREMENTS = Path(__file__).resolve().parents[2] / "assets" / "measurements"


def _same_page(text: str) -> str:
    return re.sub(r"clip\d+", "clip", text)  # the clip paths are numbered per process


def test_the_dashboard_export_is_the_command_line_report():
    record = read_measurement(MEASUREMENTS / "lab_run_2.csv")
    report = diagnose(record, window=(0.0, 0.8), modes=3)
    assert len(report.ladder) >= 2  # the tip mass is added: a ladder of two rungs at least
    # what the view holds: the diagnosis and the ladder's rows in the read-out unit (µm)
    rungs = [ladder_rung(step.result, step.added, i) for i, step in enumerate(report.ladder)]
    assert rungs[0]["unit"] == "µm" and output_units(report).scale == 1e6
    steps = ladder_steps(report, rungs)
    for step, back in zip(report.ladder, steps):
        assert abs(back.rmse_prediction - step.rmse_prediction) <= 1e-12 * step.rmse_prediction
        assert back.added == step.added
    shown = SimpleNamespace(base=report.base, residuals=report.residuals, candidates=report.ranking.candidates,
                            verdict=report.verdict, pending=[])
    page = diagnosis_html(shown, rungs).getvalue().decode("utf-8")
    assert _same_page(page) == _same_page(report_handout(report))
    assert diagnosis_html(None, rungs) is None
    assert diagnosis_html(SimpleNamespace(pending=["tip_mass"]), rungs) is None  # not before the ranking is complete
