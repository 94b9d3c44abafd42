"""The session's status line never stands still while the session works (#40 item 5): sampled
every 0.5 s in chromium through a diagnosis of a bundled record, it changes at least every 5 s
while anything runs and names what the diagnosis fits (``pytest -m browser``)."""

from __future__ import annotations

import re

import pytest
from harness import BEAM_FINAL, DEEP_JS, wait_for_status

pytestmark = pytest.mark.browser

#: Longest time (s) the line may show the same words while the session is busy.
LONGEST_STILL_S = 5.0

#: JS: sample the session status line (its Bokeh model's text, what the browser shows) every 0.5 s.
SAMPLE_JS = "() => {" + DEEP_JS + """
const samples = window.__samples = [];
const raw = document.createElement('textarea');
const textOf = () => {  // the line's HTML (the pane's text arrives escaped)
  for (const m of Bokeh.documents[0].all_models) {
    if (typeof m.text !== 'string') continue;
    raw.innerHTML = m.text;
    if (raw.value.includes('class="session-status"')) return raw.value;
  }
  return null;
};
window.__sampler = setInterval(() => {
  const text = textOf();
  const busy = text === null ? 0 : Number((/data-busy="(\\d+)"/.exec(text) || [0, 0])[1]);
  raw.innerHTML = text === null ? '' : text.replace(/<[^>]*>/g, '');  // its words, as shown
  samples.push([performance.now() / 1000, busy, raw.value]);
}, 500);
}"""


def longest_still(samples: list) -> tuple[float, str]:
    """The longest time (s) the busy line showed the same words, and those words."""
    worst, words, since, last = 0.0, "", None, None
    for t, busy, text in samples:
        if not busy:
            since, last = None, None
            continue
        if text != last:
            since, last = t, text
        elif t - since > worst:
            worst, words = t - since, text
    return worst, words


def test_the_status_line_changes_every_few_seconds_and_names_what_is_fitted(page):
    page.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=60000)
    page.evaluate(SAMPLE_JS)
    # a window no other test of the shared server asks for (its diagnosis is not in the server's
    # cache): lab_run_1 with the window's end 0.2 s earlier, calibrated, then diagnosed
    page.locator(".bk-tab", has_text="Beam calibration").first.click()
    wait_for_status(page, BEAM_FINAL, timeout_ms=300000)
    end = page.locator(".beam-cal-window .noUi-handle").nth(1)  # the window's end
    end.focus()
    for _ in range(4):
        page.keyboard.press("ArrowLeft")
    page.locator(".bk-tab", has_text="Diagnosis").first.click()
    wait_for_status(page, "s.stage === 'final' && s.ladder_n >= 1", css="diag-status", timeout_ms=400000)
    page.wait_for_timeout(1500)  # the line's last redraws
    samples = page.evaluate("() => { clearInterval(window.__sampler); return window.__samples; }")
    busy = [s for s in samples if s[1]]
    assert len(busy) >= 10, samples[-5:]
    worst, words = longest_still(samples)
    assert worst <= LONGEST_STILL_S, f"the line stood still {worst:.1f} s while busy: {words!r}"
    texts = {s[2] for s in busy}
    assert any(re.search(r"Diagnosis of lab_run_1: fitting \S+ on the base \(candidate \d+ of \d+\)", t) for t in texts), \
        sorted(texts)[:20]
    assert any(re.search(r"MAP search: iteration \d+", t) for t in texts)  # from inside a fit
    assert all(re.search(r"· \d+ s$", t.strip()) for t in texts if t.startswith("Working")), sorted(texts)[:5]
    assert page.errors == []
