"""The diagnosis's modes table as the class sees it: its words match its numbers (``pytest -m browser``)."""

from __future__ import annotations

import pytest
from harness import BEAM_FINAL, wait_for_status
from playwright.sync_api import expect

pytestmark = pytest.mark.browser

def table_rows(page) -> list[dict]:
    """The modes table's rows as {column: text} (Playwright's locators pierce the shadow roots)."""
    table = page.locator(".diag-modes-table table").first
    head = [h.strip() for h in table.locator("thead tr").first.locator("th").all_inner_texts()]
    head[0] = head[0] or "mode"
    rows = []
    for i in range(table.locator("tbody tr").count()):
        cells = [c.strip() for c in table.locator("tbody tr").nth(i).locator("th, td").all_inner_texts()]
        rows.append(dict(zip(head, cells)))
    return rows


def test_the_modes_table_words_match_its_numbers(page):
    """lab_run_1 on the default model: measured 5.513 Hz against a model's 4.693 Hz reads
    "17.5 % higher" (the measured mode above the model's), never "high" for the model."""
    page.locator(".bk-tab", has_text="Beam calibration").first.click()
    wait_for_status(page, BEAM_FINAL)
    page.locator(".bk-tab", has_text="Diagnosis").first.click()
    wait_for_status(page, "s.stage === 'final'", css="diag-status", timeout_ms=240000)
    page.locator(".diag-residual-tabs .bk-tab", has_text="Modes and backbone").first.click()
    expect(page.get_by_text("measured f vs model").first).to_be_visible(timeout=30000)
    rows = table_rows(page)
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
