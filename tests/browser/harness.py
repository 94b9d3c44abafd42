"""Shared by the browser tests and the dashboard benchmark: serve the app, drive chromium, read it.

* :func:`serve_app` runs the real ``panel serve dashboard/app.py`` on a free port in its own
  process group and stops the whole group afterwards.
* :func:`launch` starts Debian's chromium (``/usr/bin/chromium``, never a downloaded browser)
  headless with an empty profile.
* :data:`READ_STATE_JS` reads what the page shows from the Bokeh document: the status
  element's ``data-*`` attributes and the prediction band's data source.
"""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
#: Debian's chromium; ``BEAM_TEST_CHROMIUM`` overrides it (e.g. to check the missing-browser message).
CHROMIUM = os.environ.get("BEAM_TEST_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]
MISSING_CHROMIUM = (
    f"{CHROMIUM} not found: the browser tests drive Debian's chromium. "
    "Install it with `apt-get update && apt-get install -y chromium` (not `playwright install`)."
)

#: Interval (ms) at which the waits below re-read the page: a result stays on screen until the
#: next request, so 0.1 s late at most; polling every animation frame walked the Bokeh document
#: 60 times a second and took CPU from the server's runs for the whole wait.
POLL_MS = 100

#: Reads the page state from the Bokeh models: stage / request ids of the status element, the
#: prediction band (sum and length of its upper-edge ``y``) and the window slider's value.
READ_STATE_JS = """() => {
  const doc = Bokeh.documents[0];
  const out = {stage: null, requested: -1, shown: -1, band_n: 0, band_sum: null, window: null};
  if (!doc) return out;
  for (const m of doc.all_models) {
    const text = typeof m.text === 'string' ? m.text.replace(/&quot;/g, '"') : null;  // HTML panes send escaped text
    if (text !== null && text.includes('beam-status')) {
      const attr = (k) => { const r = new RegExp(k + '="([^"]*)"').exec(text); return r ? r[1] : null; };
      out.stage = attr('data-stage');
      out.requested = Number(attr('data-requested'));
      out.shown = Number(attr('data-shown'));
    }
    if (m.css_classes && m.css_classes.includes && m.css_classes.includes('beam-window-slider')) out.window = m.value;
  }
  const band = doc.get_model_by_name('prediction-band');
  if (band) {
    const y = band.data.upper;
    out.band_n = y.length;
    let s = 0; for (let i = 0; i < y.length; i++) s += y[i] * (1 + (i % 7));
    out.band_sum = y.length ? s : null;
  }
  return out;
}"""


#: Defines ``window.__deepAll(selector)``: the elements of the page that match, shadow roots
#: included (Panel renders each pane in one), with a non-empty box.
DEEP_JS = """
window.__deepAll = (sel) => {
  const out = [];
  const walk = (root) => {
    root.querySelectorAll(sel).forEach((e) => out.push(e));
    root.querySelectorAll('*').forEach((e) => { if (e.shadowRoot) walk(e.shadowRoot); });
  };
  walk(document);
  return out.filter((e) => { const r = e.getBoundingClientRect(); return r.width > 0 && r.height > 0; });
};
"""


def free_port() -> int:
    """A TCP port free on 127.0.0.1 right now."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


@contextlib.contextmanager
def serve_app(timeout_s: float = 120.0, log_path: Path | None = None, ready: bool = True):
    """Run ``panel serve dashboard/app.py`` and yield the app URL; kill its process group at exit.

    ``ready=False``: yield as soon as the server answers (the loading page of a cold start)."""
    port = free_port()
    log_path = log_path or Path(tempfile.mkdtemp(prefix="beam-serve-")) / "panel.log"
    cmd = [sys.executable, "-m", "panel", "serve", "dashboard/app.py", "--port", str(port), "--address", "127.0.0.1",
           f"--allow-websocket-origin=127.0.0.1:{port}"]
    # idle scheduler threads exit after 2 s (not 30), so a test can see the thread count return to idle
    env = {**os.environ, "BEAM_DASHBOARD_IDLE_S": os.environ.get("BEAM_DASHBOARD_IDLE_S", "2")}
    with open(log_path, "wb") as log:
        proc = subprocess.Popen(cmd, cwd=REPO, stdout=log, stderr=subprocess.STDOUT, start_new_session=True, env=env)
    url = f"http://127.0.0.1:{port}/app"
    try:
        deadline = time.monotonic() + timeout_s
        while True:
            if proc.poll() is not None:
                raise RuntimeError(f"panel serve exited with status {proc.returncode}:\n{log_path.read_text()[-3000:]}")
            try:
                with urllib.request.urlopen(url, timeout=30) as response:
                    # the app itself, not the loading page of a cold start (dashboard.views.loading)
                    if response.status == 200 and (not ready or b": starting</title>" not in response.read()):
                        break
            except (urllib.error.URLError, ConnectionError, TimeoutError):
                pass
            if time.monotonic() > deadline:
                raise RuntimeError(f"panel serve did not answer within {timeout_s:g} s:\n{log_path.read_text()[-3000:]}")
            time.sleep(0.3)
        yield url
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGTERM)
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(10)


def launch(playwright, user_data_dir: str, **kwargs):
    """Debian's chromium, headless, empty profile (a persistent context in ``user_data_dir``)."""
    if not Path(CHROMIUM).exists():
        raise FileNotFoundError(MISSING_CHROMIUM)
    return playwright.chromium.launch_persistent_context(
        user_data_dir, executable_path=CHROMIUM, headless=True, args=CHROMIUM_ARGS,
        viewport={"width": 1500, "height": 1000}, accept_downloads=True, **kwargs)


def read_state(page) -> dict:
    """:data:`READ_STATE_JS` evaluated on ``page``."""
    return page.evaluate(READ_STATE_JS)


def wait_for_result(page, *, after_request: int = 0, stage: str = "final", timeout_ms: float = 60000) -> dict:
    """Wait until the page shows ``stage`` for a request newer than ``after_request``; returns the state."""
    from playwright.sync_api import TimeoutError as PlaywrightTimeout

    try:
        page.wait_for_function(
            f"""() => {{ const s = ({READ_STATE_JS})();
                       return s.stage === '{stage}' && s.shown > {after_request} && s.shown === s.requested && s.band_n > 0; }}""",
            timeout=timeout_ms, polling=POLL_MS)
    except PlaywrightTimeout:  # say what the page showed instead (a lost update, an error, a slow run)
        raise AssertionError(f"no {stage!r} result for a request after {after_request} within {timeout_ms / 1000:g} s; "
                             f"the page shows {read_state(page)}") from None
    return read_state(page)


def settle(page, *, after_request: int = 0, quiet_ms: int = 600, timeout_ms: float = 60000) -> dict:
    """Wait for the final result of the *last* request (no new request for ``quiet_ms``)."""
    state = wait_for_result(page, after_request=after_request, timeout_ms=timeout_ms)
    while True:
        page.wait_for_timeout(quiet_ms)
        again = read_state(page)
        if again["requested"] == state["requested"]:
            return again
        state = wait_for_result(page, after_request=after_request, timeout_ms=timeout_ms)


def window_handle(page):
    """The handle of the calibration-window slider."""
    return page.locator(".beam-window-slider .noUi-handle").first


#: Reads the ``data-*`` attributes of a status element (``cal-status`` or ``diag-status``) and the
#: length and weighted sum of the beam view's prediction band.
READ_STATUS_JS = """(css) => {
  const doc = Bokeh.documents[0];
  const out = {stage: null, requested: -1, shown: -1, band_n: 0, band_sum: null};
  if (!doc) return out;
  for (const m of doc.all_models) {
    const text = typeof m.text === 'string' ? m.text.replace(/&quot;/g, '"') : null;
    if (text !== null && text.includes('class="' + css + '"')) {
      const re = /data-([a-z0-9-]+)="([^"]*)"/g;
      let r;
      while ((r = re.exec(text)) !== null) out[r[1].replace(/-/g, '_')] = r[1] === 'stage' ? r[2] : (isNaN(Number(r[2])) || r[2] === '' ? r[2] : Number(r[2]));
    }
  }
  const band = doc.get_model_by_name('beam-prediction-band');
  if (band) {
    const y = band.data.upper;
    out.band_n = y.length;
    let s = 0; for (let i = 0; i < y.length; i++) s += y[i] * (1 + (i % 7));
    out.band_sum = y.length ? s : null;
  }
  return out;
}"""


def read_status(page, css: str = "cal-status") -> dict:
    """:data:`READ_STATUS_JS` of the status element with class ``css``."""
    return page.evaluate(READ_STATUS_JS, css)


def wait_for_status(page, condition: str, css: str = "cal-status", timeout_ms: float = 90000) -> dict:
    """Wait until ``condition`` (a JS expression over ``s``, the status) holds; returns the status."""
    page.wait_for_function(f"(css) => {{ const s = ({READ_STATUS_JS})(css); return {condition}; }}", arg=css,
                           timeout=timeout_ms, polling=POLL_MS)
    return read_status(page, css)


def wait_while_moving(page, done, moving, *, stall_ms: float = 60000, poll_ms: float = 500) -> dict:
    """Wait until ``done()`` is true for as long as the page shows that it works: fail only when
    ``moving()`` (what the page shows of the work: an upload's progress text, a status line) has not
    changed for ``stall_ms``. On a loaded machine an upload or a read takes longer, and a fixed
    deadline failed while the page was still progressing (issue #39). Returns ``{"seconds",
    "changes"}`` (the wait and how many times what the page showed changed)."""
    import time as _time

    start = last_change = _time.monotonic()
    seen, changes = None, 0
    while True:
        now = _time.monotonic()
        if done():
            return {"seconds": now - start, "changes": changes}
        shown = moving()
        if shown != seen:
            seen, last_change, changes = shown, now, changes + 1
        elif (now - last_change) * 1000 > stall_ms:
            raise AssertionError(f"the page showed no progress for {stall_ms / 1000:g} s: {seen!r}")
        page.wait_for_timeout(poll_ms)


#: The beam view shows the final posterior of its latest request.
BEAM_FINAL = "s.stage === 'final' && s.shown > 0 && s.shown === s.requested && s.preview === 0 && s.band_n > 0"


#: The files of the FilePond upload widget under ``element`` as [status, name] (FilePond's status
#: codes: 3 processing, 5 processing complete), for a failure's message.
FILEPOND_FILES_JS = """el => { const p = window.FilePond && FilePond.find(el);
  return p ? p.getFiles().map(f => [f.status, f.filename]) : 'no FilePond here' }"""


def upload_state(page, css: str) -> str:
    """What the upload widget with class ``css`` holds and what the page logged (a failure's message)."""
    try:
        root = page.locator(f".{css} .filepond--root").first
        files = root.evaluate(FILEPOND_FILES_JS) if root.count() else "no widget"
    except Exception as exc:  # noqa: BLE001 - only a failure's message: say why it could not be read
        files = f"unreadable ({exc})"
    return f"FilePond files (status, name): {files}; page errors: {getattr(page, 'errors', None)}"
