"""A class's cold start (run on demand: ``python tests/benchmarks/bench_cold_start.py [--no-warm]``).

Not collected by pytest (file name ``bench_*.py``). Starts ``panel serve dashboard/app.py --warm``
(or without ``--warm``) and measures, in seconds from the server's start (wall clock: what the
teacher waits):

* **ready**: the server prints ``Bokeh app running at`` (with ``--warm``: after the app ran once);
* **tabs**: a first visitor, arriving at that moment in Debian's headless chromium, sees the tabs;
* **toy result**: the toy's first posterior is drawn (its status ``final`` with a band);
* **beam result**: the Beam calibration tab, opened then, shows its first final posterior.

The machine's load average (1 min) is printed with them.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "browser"))

from harness import BEAM_FINAL, POLL_MS, READ_STATE_JS, REPO, free_port, launch, wait_for_status  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--no-warm", action="store_true", help="start without --warm")
    args = parser.parse_args(argv)
    from playwright.sync_api import sync_playwright

    port = free_port()
    log = Path(tempfile.mkdtemp(prefix="bench-cold-")) / "panel.log"
    cmd = [sys.executable, "-m", "panel", "serve", "dashboard/app.py", "--port", str(port), "--address", "127.0.0.1",
           f"--allow-websocket-origin=127.0.0.1:{port}", *([] if args.no_warm else ["--warm"])]
    load = os.getloadavg()[0]
    t0 = time.monotonic()
    with open(log, "wb") as out:
        proc = subprocess.Popen(cmd, cwd=REPO, stdout=out, stderr=subprocess.STDOUT, start_new_session=True)
    try:
        while b"Bokeh app running at" not in log.read_bytes():
            if proc.poll() is not None:
                raise RuntimeError(log.read_text()[-3000:])
            time.sleep(0.05)
        ready = time.monotonic() - t0
        with sync_playwright() as p:
            context = launch(p, tempfile.mkdtemp(prefix="bench-cold-chromium-"))
            page = context.new_page()
            page.goto(f"http://127.0.0.1:{port}/app")
            page.locator(".bk-tab", has_text="Toy periodic model").first.wait_for(timeout=300000)
            tabs = time.monotonic() - t0
            # the toy's own band (READ_STATE_JS; wait_for_status reads the beam view's)
            page.wait_for_function(f"() => {{ const s = ({READ_STATE_JS})(); return s.stage === 'final' && s.band_n > 0; }}",
                                   timeout=300000, polling=POLL_MS)
            toy = time.monotonic() - t0
            page.locator(".bk-tab", has_text="Beam calibration").first.click()
            wait_for_status(page, BEAM_FINAL, timeout_ms=300000)
            beam = time.monotonic() - t0
            context.close()
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGTERM)
        proc.wait(20)
    print(f"{'--warm' if not args.no_warm else 'no --warm'}: load average {load:.1f} before, {os.getloadavg()[0]:.1f} "
          f"after, {os.cpu_count()} cores; seconds from the server's start")
    print(f"  server ready            {ready:7.1f}")
    print(f"  first visitor: tabs     {tabs:7.1f}  ({tabs - ready:.1f} after ready)")
    print(f"  toy result drawn        {toy:7.1f}  ({toy - ready:.1f} after ready)")
    print(f"  beam result drawn       {beam:7.1f}  ({beam - ready:.1f} after ready)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
