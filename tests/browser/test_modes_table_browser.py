"""The diagnosis's modes table as the class sees it: its words match its numbers (``pytest -m browser``)."""

from __future__ import annotations

import pytest
from harness import BEAM_FINAL, wait_for_status
from playwright.sync_api import expect

pytestmark = pytest.mark.browser

#: The table's rows as {column: text}.
ROWS_JS = """() => {
  const table = document.querySelector('.diag-modes-table table') ||
                [...document.querySelectorAll('table')].find(t => t.innerText.includes('measured f vs model'));
  const head = [...table.querySelectorAll('thead tr:first-child th')].map(th => th.innerText.trim());
  return [...table.querySelectorAll('tbody tr')].map(tr => {
    const cells = [...tr.querySelectorAll('th, td')].map(td => td.innerText.trim());
    return Object.fromEntries(head.map((h, i) => [h || 'mode', cells[i]]));
  });
}"""


def test_the_modes_table_words_match_its_numbers(page):
    """lab_run_1 on the default model: measured 5.513 Hz against a model's 4.693 Hz reads
    "17.5 % higher" (the measured mode above the model's), never "high" for the model."""
    page.locator(".bk-tab", has_text="Beam calibration").first.click()
    wait_for_status(page, BEAM_FINAL)
    page.locator(".bk-tab", has_text="Diagnosis").first.click()
    wait_for_status(page, "s.stage === 'final'", css="diag-status", timeout_ms=240000)
    page.locator(".diag-residual-tabs .bk-tab", has_text="Modes and backbone").first.click()
    expect(page.get_by_text("measured f vs model").first).to_be_visible(timeout=30000)
    rows = page.evaluate(ROWS_JS)
    checked = 0
    for row in rows:
        words = row["measured f vs model"]
        if words.startswith("not seen") or words == "–":
            continue
        measured, model = float(row["measured f (Hz)"]), float(row["model f (Hz)"])
        if words == "matches":
            assert abs(measured / model - 1) < 0.0006, row
            continue
        size, direction = words.split(" % ")
        assert direction == ("higher" if measured > model else "lower"), row
        assert float(size) == pytest.approx(100 * abs(measured / model - 1), abs=0.1), row
        checked += 1
    assert checked >= 1, rows
    assert page.errors == []
