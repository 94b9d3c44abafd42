"""Readable on a projector: text sizes, nothing clipped, the ladder's labels apart, a cold start that talks.

``pytest -m browser tests/browser/test_projector_browser.py`` (real ``panel serve``, Debian chromium).

* At 1280 × 800 every text a student reads in the page is at least 14 px (computed style), and
  so is every text drawn on a plot's canvas (titles, axis and tick labels, legends, the ladder's
  values: read off the Bokeh models, as the canvas has no computed style).
* At 1024 × 768, 1280 × 800 and 1920 × 1080, on every tab: no title, label, cell, button or tab
  is clipped (``scrollWidth ≤ clientWidth``), the dataset menu shows its whole entry, no plot
  title is wider than its plot (measured with the canvas's own font), and the pair plot stays
  inside its column.
* The error ladder's tick labels and values do not overlap (their boxes computed from the
  plot's scales and the canvas's text metrics), with the single bar of a fresh diagnosis.
* A cold server shows its loading page within seconds, then opens the app by itself.

Screenshots of each tab at the three sizes (the page scrolled screen by screen) go to
``$BEAM_SHOTS_DIR`` (default: pytest's ``tmp_path``).
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest
from harness import BEAM_FINAL, DEEP_JS, serve_app, wait_for_status

pytestmark = pytest.mark.browser

SIZES = [(1024, 768), (1280, 800), (1920, 1080)]
MIN_PX = 14.0

#: ``__deepAll`` (the harness's: shadow roots included) and the helpers below; ``__shown`` leaves
#: out what is hidden. A function that returns nothing: as a script its value, the last function
#: it defines, costs Playwright tens of seconds per evaluation (docs/decisions.md, CI time).
HELPERS_JS = "() => {" + DEEP_JS + """
window.__shown = (sel) => window.__deepAll(sel).filter((e) => getComputedStyle(e).visibility !== 'hidden');
window.__label = (e) => (typeof e.className === 'string' && e.className ? e.className : e.tagName) + ': '
                        + (e.textContent || '').trim().slice(0, 60);
window.__px = (size) => {  // a Bokeh font size ("14px", "10.5pt", {value: "14px"}) in px
  const s = typeof size === 'object' && size !== null ? size.value : size;
  const m = /^([0-9.]+)(px|pt)$/.exec(String(s));
  return m ? Number(m[1]) * (m[2] === 'pt' ? 4 / 3 : 1) : NaN;
};
window.__ctx = document.createElement('canvas').getContext('2d');
window.__textWidth = (text, size, style, font) => {
  window.__ctx.font = `${style || 'normal'} ${size}px ${font || 'helvetica'}`;
  return Math.max(...String(text).split('\\n').map((t) => window.__ctx.measureText(t).width));
};
window.__plotViews = () => [...Bokeh.index.query((v) => v.model && v.model.type === 'Figure')]
  .filter((v) => v.el && v.el.isConnected && v.el.getBoundingClientRect().width > 0);
}"""

#: Text in the page (own text of an element) smaller than the minimum, at the current size.
SMALL_TEXT_JS = """(min) => {
  const small = [];
  for (const e of window.__shown('*')) {
    let own = '';
    for (const n of e.childNodes) if (n.nodeType === 3) own += n.textContent;
    if (!own.trim()) continue;
    const size = parseFloat(getComputedStyle(e).fontSize);
    if (size < min - 0.01) small.push(`${size.toFixed(1)} px ${window.__label(e)}`);
  }
  return small;
}"""

#: Text drawn on the canvases of the plots shown: (what, size in px) below the minimum.
CANVAS_TEXT_JS = """(min) => {
  const small = [];
  const check = (what, size) => { const px = window.__px(size); if (!(px >= min - 0.01)) small.push(`${what}: ${JSON.stringify(size)}`); };
  for (const v of window.__plotViews()) {
    const m = v.model;
    const name = (m.title && m.title.text) || m.css_classes.join(' ') || m.id;
    if (m.title && m.title.text) check(`title of ${name}`, m.title.text_font_size);
    for (const axis of [...m.left, ...m.below, ...m.right, ...m.above].filter((a) => a.type && a.type.endsWith('Axis'))) {
      if (!axis.visible) continue;
      check(`tick labels of ${name}`, axis.major_label_text_font_size);
      if (axis.axis_label) check(`axis label "${axis.axis_label}" of ${name}`, axis.axis_label_text_font_size);
    }
    for (const l of [...m.center, ...m.below, ...m.right, ...m.above].filter((a) => a.type === 'Legend'))
      if (l.items.length) check(`legend of ${name}`, l.label_text_font_size);
    for (const r of m.renderers) if (r.glyph && r.glyph.type === 'Text') check(`text labels of ${name}`, r.glyph.text_font_size);
  }
  return small;
}"""

#: What is cut or runs out of its place, at the current size.
CLIPPED_JS = """() => {
  const problems = [];
  for (const e of window.__shown('th, td, h1, h2, h3, h4, .bk-btn, .bk-tab, .bk-card-title, label, .bk-slider-title, .notice'))
    if (e.scrollWidth > e.clientWidth + 1) problems.push(`clipped: ${window.__label(e)} (${e.scrollWidth} > ${e.clientWidth})`);
  // a button, a check box's label, a tab inside its widget (whose box cuts or lets run over what is wider)
  for (const e of window.__shown('.bk-btn, .bk-input-group label, .bk-tab')) {
    const host = e.getRootNode().host;
    if (!host) continue;
    const a = e.getBoundingClientRect(), b = host.getBoundingClientRect();
    if (a.left < b.left - 1 || a.right > b.right + 1) problems.push(`runs out of its widget: ${window.__label(e)}`);
  }
  for (const s of window.__shown('select')) {  // a menu shows its whole entry
    const cs = getComputedStyle(s), opt = s.options[s.selectedIndex];
    if (!opt) continue;
    const room = s.clientWidth - parseFloat(cs.paddingLeft) - parseFloat(cs.paddingRight);
    const need = window.__textWidth(opt.text, parseFloat(cs.fontSize), cs.fontStyle, cs.fontFamily);
    if (need > room + 1) problems.push(`menu entry cut: "${opt.text}" (${need.toFixed(0)} > ${room.toFixed(0)} px)`);
  }
  for (const v of window.__plotViews()) {  // a plot's title fits its plot (the canvas cuts it, no wrap)
    const t = v.model.title;
    if (!t || !t.text) continue;
    const need = window.__textWidth(t.text, window.__px(t.text_font_size), t.text_font_style, t.text_font);
    // the title shares the row above the frame with the toolbar (collapsed to a menu when short of room)
    const frame = v.frame && v.frame.bbox ? v.frame.bbox.width : v.el.getBoundingClientRect().width;
    const bar = (v.toolbar_view && v.toolbar_view.el) || (v.shadow_el || v.el.shadowRoot || v.el).querySelector('.bk-Toolbar');
    const room = frame - (bar && v.model.toolbar_location === 'above' ? bar.getBoundingClientRect().width : 0);
    if (need > room) problems.push(`plot title cut: "${t.text}" (${need.toFixed(0)} > ${room.toFixed(0)} px)`);
  }
  const guides = window.__shown('.toy-class-guide, .beam-class-guide, .diag-class-guide');
  for (const g of window.__shown('.pair-plot')) {  // the pair plot inside its column (scrolling sideways if need be)
    const a = g.getBoundingClientRect();
    if (a.right > window.innerWidth + 1) problems.push('pair plot wider than the window');
    for (const guide of guides) {
      const b = guide.getBoundingClientRect();
      if (Math.min(a.right, b.right) - Math.max(a.left, b.left) > 1 && Math.min(a.bottom, b.bottom) - Math.max(a.top, b.top) > 1)
        problems.push('pair plot runs over the class panel');
    }
  }
  if (document.documentElement.scrollWidth > window.innerWidth + 1) problems.push('page wider than the window');
  return problems;
}"""

#: Boxes (canvas px) of the error ladder's tick labels and values, and which of them overlap.
LADDER_JS = """() => {
  const v = window.__plotViews().find((p) => p.model.css_classes.includes('diag-ladder-plot'));
  if (!v) return {found: false};
  const m = v.model, xs = v.frame.x_scale, ys = v.frame.y_scale;
  const boxes = {y: [], x: [], values: []};
  const axis = (list) => list.find((a) => a.type && a.type.endsWith('Axis'));
  const left = axis(m.left), below = axis(m.below);
  const label = (a, t) => { const o = a.major_label_overrides; const k = o instanceof Map ? o.get(String(t)) ?? o.get(t) : (o || {})[t];
                           return k !== undefined ? k : String(t); };
  const lsize = window.__px(left.major_label_text_font_size);
  for (const t of left.ticker.ticks) {
    if (t < m.y_range.start - 1e-12 || t > m.y_range.end * (1 + 1e-9)) continue;
    const cy = ys.compute(t), text = label(left, t);
    const w = window.__textWidth(text, lsize);
    boxes.y.push({text, x0: -w, x1: 0, y0: cy - lsize / 2, y1: cy + lsize / 2});
  }
  const bsize = window.__px(below.major_label_text_font_size);
  for (const t of below.ticker.ticks) {
    const cx = xs.compute(t), text = label(below, t), lines = String(text).split('\\n').length;
    const w = window.__textWidth(text, bsize);
    boxes.x.push({text, x0: cx - w / 2, x1: cx + w / 2, y0: 0, y1: lines * bsize * 1.2});
  }
  for (const r of m.renderers) {
    if (!r.glyph || r.glyph.type !== 'Text') continue;
    const d = r.data_source.data, size = window.__px(r.glyph.text_font_size);
    const xcol = r.glyph.x.field, ycol = r.glyph.y.field, tcol = r.glyph.text.field;
    for (let i = 0; i < d[tcol].length; i++) {
      const cx = xs.compute(d[xcol][i]), cy = ys.compute(d[ycol][i]), w = window.__textWidth(d[tcol][i], size);
      boxes.values.push({text: d[tcol][i], x0: cx - w / 2, x1: cx + w / 2, y0: cy - size, y1: cy});
    }
  }
  const overlaps = [];
  for (const [kind, list] of Object.entries(boxes))
    for (let i = 0; i < list.length; i++) for (let j = i + 1; j < list.length; j++) {
      const a = list[i], b = list[j];
      if (Math.min(a.x1, b.x1) - Math.max(a.x0, b.x0) > 0.5 && Math.min(a.y1, b.y1) - Math.max(a.y0, b.y0) > 0.5)
        overlaps.push(`${kind}: "${a.text}" / "${b.text}"`);
    }
  return {found: true, boxes, overlaps, bars: boxes.values.length};
}"""


def shots_dir(tmp_path: Path) -> Path:
    out = Path(os.environ.get("BEAM_SHOTS_DIR", tmp_path))
    out.mkdir(parents=True, exist_ok=True)
    return out


def screenshots(page, directory: Path, name: str) -> list[Path]:
    """The page's scrolled area (the template's ``#main``) screen by screen."""
    paths = []
    height, view = page.evaluate("() => { const m = document.getElementById('main'); return [m.scrollHeight, m.clientHeight]; }")
    for k, top in enumerate(range(0, max(height, 1), max(view - 60, 200))):
        page.evaluate("(y) => { document.getElementById('main').scrollTop = y; }", top)
        page.wait_for_timeout(250)
        path = directory / f"{name}_{k}.png"
        page.screenshot(path=str(path))
        paths.append(path)
        if k >= 5:
            break
    page.evaluate("() => { document.getElementById('main').scrollTop = 0; }")
    return paths


def open_tab(page, title: str, css: str = ".bk-tab") -> None:
    page.locator(css, has_text=title).first.click()
    page.wait_for_timeout(800)


def check_tab(page, name: str, directory: Path, report: dict) -> None:
    """At each size: screenshots, nothing clipped; at 1280 x 800: no text under 14 px (page and canvas)."""
    for w, h in SIZES:
        page.set_viewport_size({"width": w, "height": h})
        page.wait_for_timeout(1500)
        page.evaluate(HELPERS_JS)
        screenshots(page, directory, f"{name}_{w}x{h}")
        clipped = page.evaluate(CLIPPED_JS)
        assert clipped == [], f"{name} at {w} x {h}: {clipped} (screenshots in {directory})"
        if (w, h) == (1280, 800):
            small = page.evaluate(SMALL_TEXT_JS, MIN_PX)
            assert small == [], f"{name}: text under {MIN_PX:g} px at 1280 x 800: {small[:12]}"
            canvas = page.evaluate(CANVAS_TEXT_JS, MIN_PX)
            assert canvas == [], f"{name}: plot text under {MIN_PX:g} px: {canvas[:12]}"
            report[name] = len(page.evaluate("() => window.__plotViews().map((v) => v.model.id)"))


def test_every_tab_is_readable_on_a_projector(page, tmp_path):
    directory = shots_dir(tmp_path)
    report: dict = {}
    wait_for_status(page, "s.stage === 'final'", css="beam-status", timeout_ms=180000)
    page.wait_for_function("() => Bokeh.documents[0].get_model_by_name('sweep-coverage') !== null", timeout=120000)
    check_tab(page, "toy", directory, report)  # the window sweep is the open sub-tab
    open_tab(page, "Posterior: marginals and pairs")
    page.locator(".pair-plot").first.wait_for(timeout=60000)
    check_tab(page, "toy-pairs", directory, report)

    open_tab(page, "Beam calibration")
    wait_for_status(page, BEAM_FINAL, timeout_ms=300000)
    check_tab(page, "beam", directory, report)
    page.locator(".beam-main .bk-tab", has_text="Posterior: marginals and pairs").first.click()
    page.locator(".pair-plot").last.wait_for(timeout=60000)
    page.wait_for_timeout(1000)
    check_tab(page, "beam-pairs", directory, report)

    open_tab(page, "Diagnosis")
    wait_for_status(page, "s.stage === 'final' && s.ladder_n >= 1", css="diag-status", timeout_ms=400000)
    page.locator(".diag-class-guide").first.wait_for(timeout=30000)
    page.wait_for_timeout(1500)
    check_tab(page, "diagnosis", directory, report)
    for w, h in SIZES:  # the ladder of a fresh diagnosis: one bar, the case whose log axis overprinted
        page.set_viewport_size({"width": w, "height": h})
        page.wait_for_timeout(1200)
        page.evaluate(HELPERS_JS)
        ladder = page.evaluate(LADDER_JS)
        assert ladder["found"], "no ladder plot on the diagnosis tab"
        assert ladder["bars"] >= 1 and len(ladder["boxes"]["y"]) >= 2, ladder
        assert ladder["overlaps"] == [], f"ladder labels overlap at {w} x {h}: {ladder['overlaps']}"
    print(f"screenshots in {directory}; plots checked per tab: {report}")
    assert page.errors == []


def test_the_window_study_and_your_record_tabs_are_readable_on_a_projector(page, tmp_path):
    """The two tabs a teacher opens beside the class flow, before anything runs in them."""
    directory = shots_dir(tmp_path)
    report: dict = {}
    open_tab(page, "Window study")
    page.locator(".study-class-guide").first.wait_for(timeout=120000)
    page.locator(".study-run").first.wait_for(timeout=60000)
    check_tab(page, "study", directory, report)
    open_tab(page, "Your record")
    page.locator(".record-inputs").first.wait_for(timeout=120000)
    check_tab(page, "record", directory, report)
    print(f"screenshots in {directory}; plots checked per tab: {report}")
    assert page.errors == []


def test_a_cold_server_shows_its_loading_page_at_once_then_the_app(browser_context, tmp_path):
    """The first visit after ``panel serve`` starts: the loading page says what is loading within
    seconds (it was a blank page for the 27 s of imports), and the app follows by itself."""
    with serve_app(log_path=tmp_path / "panel.log", ready=False) as url:
        page = browser_context.new_page()
        errors: list[str] = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        t0 = time.monotonic()
        page.goto(url)
        page.locator(".beam-loading-page").first.wait_for(timeout=15000)
        text = page.get_by_text("Starting the explorer").first  # (the pane's text is in its shadow root)
        text.wait_for(timeout=5000)
        shown_s = time.monotonic() - t0
        page.screenshot(path=str(shots_dir(tmp_path) / "cold-start.png"))
        page.locator(".bk-tab", has_text="Toy periodic model").first.wait_for(timeout=240000)  # reloaded into the app
        opened_s = time.monotonic() - t0
        assert "starting" not in page.title()
        print(f"loading page after {shown_s:.1f} s, the app after {opened_s:.1f} s")
        assert errors == []
        page.close()
