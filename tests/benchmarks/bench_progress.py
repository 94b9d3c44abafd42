"""How long the progress shown stands still during a diagnosis (#40 item 5; run on demand:
``python tests/benchmarks/bench_progress.py [--browser | --browser-only]``).

The record: a shared 50 cm run (``../shared/real-data``, else the bundled one) recorded as a
phone at 400 Hz would (jittered stamps, its sensor's low-pass: ``tests/record_families.py``),
written as a CSV with the run's sidecar. Three figures, in wall seconds:

* **CLI**: ``beam diagnose RECORD`` on a pseudo-terminal; the largest gap between two redraws of
  its progress line (the ticker's time field or a new step), and between two new steps.
* **Dashboard job**: the diagnosis job on two warmed worker processes (as the served app runs
  it), its updates through a run slot (0.2 s progress interval) to a :class:`~dashboard.state.run.Run`;
  the session's status line (:func:`~dashboard.views.status.status_text`) read at each update
  and every second (its periodic redraw): the largest gap between two changes of the line, and
  of the step it shows.
* **Browser** (``--browser``): the served app in chromium, the bundled real run (the same strip
  as recorded, ~2.9 kHz) chosen in the beam view and diagnosed; the line sampled every 0.5 s; the longest it showed the same words
  while busy, and the same step (its seconds left out).
"""

from __future__ import annotations

import os
import pty
import re
import select
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path[:0] = [str(ROOT), str(ROOT / "tests"), str(ROOT / "tests" / "browser")]

from record_families import _phone_version, shared_runs  # noqa: E402

from beam.io.measurement import read_measurement  # noqa: E402

RATE_HZ = 400.0


def phone_record(folder: Path) -> Path:
    """The first shared run at :data:`RATE_HZ` phone stamps, as ``folder/phone400.csv`` + its sidecar."""
    source = shared_runs()[0]
    run = read_measurement(source)
    m, _ = _phone_version(run, RATE_HZ, 0.0, float(run.time_s[-1]), 1.0, np.random.default_rng(0))
    out = folder / "phone400.csv"
    np.savetxt(out, np.column_stack([m.time_s, m.output]), delimiter=",", header="time_s,acceleration_m_s2",
               comments="", fmt="%.6f")
    shutil.copy(source.with_suffix(".toml"), out.with_suffix(".toml"))
    return out


def largest_gap(seq: list[tuple[float, str]]) -> tuple[float, str]:
    return max(((b[0] - a[0]), a[1][:140]) for a, b in zip(seq, seq[1:]))


def cli(record: Path) -> None:
    master, slave = pty.openpty()
    env = {**os.environ, "PYTHONPATH": str(ROOT), "COLUMNS": "160"}
    t0 = time.monotonic()
    proc = subprocess.Popen([sys.executable, "-m", "beam", "diagnose", str(record)], stdin=subprocess.DEVNULL,
                            stdout=slave, stderr=slave, cwd=ROOT, env=env)
    os.close(slave)
    events = []
    while True:
        ready, _, _ = select.select([master], [], [], 0.2)
        if ready:
            try:
                chunk = os.read(master, 65536)
            except OSError:
                break
            if not chunk:
                break
            now = time.monotonic() - t0
            events += [(now, piece) for piece in chunk.decode(errors="replace").split("\r") if piece]
        elif proc.poll() is not None:
            break
    proc.wait()
    line = [(t, p) for t, p in events if re.match(r"(\x1b\[K)?\[\s*\d+ s\]", p)]
    steps = []
    for t, p in line:
        if p.startswith("\x1b[K"):
            text = re.sub(r"^\x1b\[K\[\s*\d+ s\] ", "", p)
            if not steps or steps[-1][1] != text:
                steps.append((t, text))
    print(f"CLI: {time.monotonic() - t0:.1f} s wall, exit {proc.returncode}, {len(line)} redraws, {len(steps)} steps")
    print("  largest gap between redraws of the line: %.2f s (after %r)" % largest_gap(line))
    print("  largest gap between new steps:           %.2f s (after %r)" % largest_gap(steps))


def dashboard_job(record: Path, warm_s: float = 60.0) -> None:
    from beam.calibration import CalibrationSpec
    from dashboard.jobs import diagnosis as jobs
    from dashboard.jobs.beam import CalibrationKey, record_key, warm_worker
    from dashboard.runtime import scheduler as sch
    from dashboard.state.run import Run
    from dashboard.views.status import REFRESH_MS, status_text

    m = read_measurement(record)
    pool = sch.RunPool(max_workers=2, idle_timeout_s=5.0, processes=True, name="bench-progress", warm=warm_worker)
    pool.start_processes()
    time.sleep(warm_s)  # the workers warm up, as while the first visitor reads the loading page
    run = Run("Diagnosis")
    lock = threading.Lock()
    seen: list[tuple[float, str, str]] = []

    def look() -> None:
        with lock:
            line = re.sub(r"<[^>]*>", "", status_text({"diagnosis": run}, "diagnosis"))
            if not seen or seen[-1][1] != line:
                seen.append((time.monotonic(), line, run.status))

    slot = sch.RunSlot(lambda u: (run.on_update(u), look()), pool=pool, debounce_s=0.0, progress_interval_s=0.2)
    run.attach(slot)
    t0 = time.monotonic()
    run.request(lambda: jobs.diagnosis_run(CalibrationKey(record_key(m), CalibrationSpec()), m, use_cache=False),
                status="diagnosing", subject=m.name)
    while run.busy:
        look()
        time.sleep(REFRESH_MS / 1000)
    look()
    pool.shutdown(wait=True)
    busy = [(t, line) for t, line, _ in seen if line.startswith("Working")]
    steps: list[tuple[float, str]] = []
    for t, line, step in seen:
        if line.startswith("Working") and (not steps or steps[-1][1] != step):
            steps.append((t, step))
    print(f"dashboard job: {time.monotonic() - t0:.1f} s wall, {run.stage}")
    print("  largest gap between changes of the line: %.2f s (after %r)" % largest_gap(busy))
    print("  largest gap between new steps:           %.2f s (after %r)" % largest_gap(steps))


def browser(dataset: str = "adxl_50cm_114655") -> None:
    import harness
    from playwright.sync_api import sync_playwright
    from test_progress_browser import SAMPLE_JS, longest_still

    with tempfile.TemporaryDirectory() as tmp, harness.serve_app(log_path=Path(tmp) / "panel.log") as url, \
            sync_playwright() as p:
        context = harness.launch(p, str(Path(tmp) / "profile"))
        page = context.new_page()
        page.goto(url)
        page.locator(".bk-tab", has_text="Beam calibration").first.click()
        harness.wait_for_status(page, harness.BEAM_FINAL, timeout_ms=240000)
        page.evaluate(SAMPLE_JS)
        select_ = page.locator(".beam-dataset select")
        label = next(o for o in select_.evaluate("s => Array.from(s.options).map(o => o.text)") if o.startswith(dataset))
        select_.select_option(label=label)
        page.locator(".bk-tab", has_text="Diagnosis").first.click()
        harness.wait_for_status(page, "s.stage === 'final' && s.ladder_n >= 1", css="diag-status", timeout_ms=900000)
        page.wait_for_timeout(1500)
        samples = page.evaluate("() => { clearInterval(window.__sampler); return window.__samples; }")
        context.close()
    busy = [s for s in samples if s[1]]
    worst, words = longest_still(samples)
    steps = [[t, b, re.sub(r"( \(\d+ %\))? · \d+ s", "", text)] for t, b, text in samples]
    worst_step, step = longest_still(steps)
    print(f"browser ({dataset}): {len(busy) * 0.5:.0f} s busy, sampled every 0.5 s")
    print(f"  longest the line stood still: {worst:.1f} s ({words[:140]!r})")
    print(f"  longest one step was shown:   {worst_step:.1f} s ({step[:140]!r})")


def main() -> None:
    if "--browser-only" in sys.argv:
        browser()
        return
    with tempfile.TemporaryDirectory() as tmp:
        record = phone_record(Path(tmp))
        print(f"record: {record.name} from {shared_runs()[0].name}, {RATE_HZ:g} Hz phone stamps")
        cli(record)
        dashboard_job(record)
    if "--browser" in sys.argv:
        browser()


if __name__ == "__main__":
    main()
