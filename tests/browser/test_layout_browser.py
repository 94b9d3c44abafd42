"""Layout of the beam and diagnosis views at the window sizes of a class (``pytest -m browser``).

At each size the test takes a screenshot (under pytest's ``tmp_path``, to look at) and checks
with bounding boxes what a teacher would see: no read-out overlaps another element, no title,
table cell or button label is cut (``scrollWidth > clientWidth``), no table runs out of its
column, nothing is wider than the window, and the main plot keeps a readable width.
"""

from __future__ import annotations

import pytest
from harness import BEAM_FINAL, DEEP_JS, wait_for_status

pytestmark = pytest.mark.browser

SIZES = [(1024, 768), (1280, 800), (1400, 1000), (1920, 1080)]

LAYOUT_JS = """([readouts, others, plot]) => {
  const box = (e) => { const r = e.getBoundingClientRect(); return {x: r.left, y: r.top, r: r.right, b: r.bottom,
                                                                    w: r.width, h: r.height}; };
  const overlap = (a, b) => Math.min(a.r, b.r) - Math.max(a.x, b.x) > 1 && Math.min(a.b, b.b) - Math.max(a.y, b.y) > 1;
  const label = (e) => (e.className && e.className.baseVal === undefined ? e.className : e.tagName) + ': '
                       + (e.textContent || '').trim().slice(0, 50);
  const problems = [];
  const ro = window.__deepAll(readouts);
  const rest = others.flatMap((s) => window.__deepAll(s));
  for (let i = 0; i < ro.length; i++) {
    for (let j = i + 1; j < ro.length; j++) if (overlap(box(ro[i]), box(ro[j]))) problems.push('read-outs overlap: ' + label(ro[i]) + ' / ' + label(ro[j]));
    for (const o of rest) if (!o.contains(ro[i]) && !ro[i].contains(o) && overlap(box(ro[i]), box(o)))
      problems.push('read-out over another element: ' + label(ro[i]) + ' / ' + label(o));
    // its text stays inside its box
    for (const part of ro[i].querySelectorAll('div')) if (part.scrollWidth > part.clientWidth + 1)
      problems.push('read-out text cut: ' + label(part));
  }
  for (const e of window.__deepAll('th, td, h1, h2, h3, .bk-btn, .bk-tab, .bk-card-title, label'))
    if (e.scrollWidth > e.clientWidth + 1) problems.push('clipped: ' + label(e) + ` (${e.scrollWidth} > ${e.clientWidth})`);
  for (const t of window.__deepAll('table')) {
    const host = t.getRootNode().host;
    const r = box(t), h = host ? box(host) : {r: window.innerWidth};
    if (r.r > Math.min(h.r, window.innerWidth) + 1) problems.push('table runs out of its column: ' + label(t.querySelector('th') || t));
  }
  if (document.documentElement.scrollWidth > window.innerWidth + 1) problems.push('page wider than the window');
  const p = window.__deepAll(plot);
  return {problems, plot_width: p.length ? box(p[0]).w : 0, readouts: ro.length};
}"""


def check(page, readouts: str, others: list[str], plot: str) -> dict:
    page.evaluate(DEEP_JS)
    return page.evaluate(LAYOUT_JS, [readouts, others, plot])


def open_tab(page, title):
    page.locator(".bk-tab", has_text=title).first.click()


def test_beam_and_diagnosis_views_fit_every_class_screen(page, tmp_path):
    open_tab(page, "Beam calibration")
    wait_for_status(page, BEAM_FINAL, timeout_ms=240000)
    report = {}
    for w, h in SIZES:
        page.set_viewport_size({"width": w, "height": h})
        page.wait_for_timeout(1200)
        page.screenshot(path=str(tmp_path / f"beam_{w}x{h}.png"), full_page=True)
        out = check(page, ".beam-readouts .readout",
                    [".beam-class-guide", ".beam-inputs .bk-card", ".beam-plot", ".beam-convergence .notice"], ".beam-plot")
        report[("beam", w)] = out
        assert out["readouts"] == 4
        assert out["problems"] == [], f"beam view at {w} x {h}: {out['problems']} (screenshots in {tmp_path})"
        assert out["plot_width"] >= 480, f"beam plot {out['plot_width']:.0f} px wide at {w} x {h}"
    open_tab(page, "Diagnosis")
    wait_for_status(page, "s.stage === 'final' && s.ladder_n >= 1", css="diag-status", timeout_ms=300000)
    page.locator(".diag-class-guide").first.wait_for(timeout=30000)
    for w, h in SIZES:
        page.set_viewport_size({"width": w, "height": h})
        page.wait_for_timeout(1200)
        page.screenshot(path=str(tmp_path / f"diagnosis_{w}x{h}.png"), full_page=True)
        out = check(page, ".diag-verdict", [".diag-class-guide", ".diag-ladder-table", ".diag-ladder-plot"],
                    ".diag-ladder-plot")
        report[("diagnosis", w)] = out
        assert out["problems"] == [], f"diagnosis view at {w} x {h}: {out['problems']} (screenshots in {tmp_path})"
        assert out["plot_width"] >= 300
    print(f"screenshots in {tmp_path}")
    assert page.errors == []


def test_toy_view_fits_every_class_screen(page, tmp_path):
    """The toy view (the landing tab): its four read-outs wrap instead of running over the class
    panel (they did at 1024 and 1280 px), and the plot keeps its width (its legend is below it)."""
    wait_for_status(page, "s.stage === 'final'", css="beam-status", timeout_ms=120000)
    for w, h in SIZES:
        page.set_viewport_size({"width": w, "height": h})
        page.wait_for_timeout(1200)
        page.screenshot(path=str(tmp_path / f"toy_{w}x{h}.png"), full_page=True)
        out = check(page, ".toy-readout", [".toy-class-guide", ".toy-plot", ".beam-verdict"], ".toy-plot")
        assert out["readouts"] == 4
        assert out["problems"] == [], f"toy view at {w} x {h}: {out['problems']} (screenshots in {tmp_path})"
        assert out["plot_width"] >= 480, f"toy plot {out['plot_width']:.0f} px wide at {w} x {h}"
    assert page.errors == []


def test_the_class_panel_folds_away(page):
    open_tab(page, "Beam calibration")
    guide = page.locator(".beam-class-guide").first
    guide.wait_for(timeout=60000)
    text = page.get_by_text("Calibrate on the first second").first
    assert text.is_visible()
    guide.locator(".card-button, button").first.click()
    page.wait_for_timeout(500)
    assert not text.is_visible()
    assert page.errors == []
