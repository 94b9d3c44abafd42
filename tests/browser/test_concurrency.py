"""Reliability of the served app: eight sessions at once, a slider storm, nothing leaked."""

from __future__ import annotations

import threading
import time
import urllib.request
from pathlib import Path

import pytest
from conftest import IGNORED
from harness import read_state, settle, wait_for_result, window_handle

pytestmark = pytest.mark.browser


def _server_pid(app_url: str) -> int:
    """The panel serve process listening on the app's port (found through /proc)."""
    port = app_url.split(":")[2].split("/")[0]
    for proc in Path("/proc").iterdir():
        if proc.name.isdigit():
            try:
                cmdline = (proc / "cmdline").read_bytes().split(b"\0")
            except OSError:
                continue
            if b"panel" in cmdline and b"serve" in cmdline and port.encode() in cmdline:
                return int(proc.name)
    raise RuntimeError("panel serve process not found")


def _children(pid: int) -> set[int]:
    """Process ids of the server's child processes (its inference workers)."""
    out: set[int] = set()
    for task in Path(f"/proc/{pid}/task").iterdir():
        try:
            out.update(int(c) for c in (task / "children").read_text().split())
        except OSError:
            continue
    return out


def _workers(pid: int) -> set[int]:
    """The server's inference worker processes (multiprocessing ``spawn`` children)."""
    out = set()
    for child in _children(pid):
        try:
            if b"spawn_main" in Path(f"/proc/{child}/cmdline").read_bytes():
                out.add(child)
        except OSError:
            continue
    return out


def _cpu_seconds(pid: int) -> float:
    """CPU time of the server and its worker processes (s)."""
    total = 0.0
    for p in {pid} | _children(pid):
        try:
            fields = Path(f"/proc/{p}/stat").read_text().rsplit(")", 1)[1].split()
        except OSError:  # a process that has just exited
            continue
        total += (int(fields[11]) + int(fields[12])) / 100.0  # utime + stime, clock ticks of 10 ms
    return total


def _threads(pid: int) -> int:
    return len(list(Path(f"/proc/{pid}/task").iterdir()))


def _settled_threads(pid: int, *, quiet_s: float = 3.0, timeout_s: float = 30.0) -> int:
    """The server's thread count once it has not changed for ``quiet_s`` (idle scheduler threads exit after 2 s)."""
    start = last_change = time.monotonic()
    count = _threads(pid)
    while time.monotonic() - last_change < quiet_s:
        if time.monotonic() - start > timeout_s:
            raise AssertionError(f"the thread count did not settle in {timeout_s:g} s")
        time.sleep(0.2)
        now = _threads(pid)
        if now != count:
            count, last_change = now, time.monotonic()
    return count


def _wait_idle(pid: int, *, timeout_s: float = 60.0, window_s: float = 2.0, busy: float = 0.1) -> float:
    """Wait until the server and its workers use less than ``busy`` of a core over ``window_s``; returns the time taken."""
    start = time.monotonic()
    while time.monotonic() - start < timeout_s:
        before = _cpu_seconds(pid)
        time.sleep(window_s)
        if (_cpu_seconds(pid) - before) / window_s < busy:
            return time.monotonic() - start
    raise AssertionError(f"the server stayed busy for {timeout_s:g} s")


class _Prober(threading.Thread):
    """Sends a small HTTP request to the server every 0.2 s and logs when each was sent and answered
    (monotonic seconds): the event loop must keep answering while the sessions work."""

    def __init__(self, url: str) -> None:
        super().__init__(daemon=True)
        self.url, self.answers, self.failures = url, [], []
        self._stop_event = threading.Event()

    def run(self) -> None:
        while not self._stop_event.is_set():
            start = time.monotonic()
            try:
                with urllib.request.urlopen(self.url, timeout=10) as response:
                    response.read()
                self.answers.append((start, time.monotonic()))
            except Exception as exc:  # noqa: BLE001 - any failure is a finding
                self.failures.append(repr(exc))
            self._stop_event.wait(0.2)

    def stop(self) -> None:
        self._stop_event.set()
        self.join(15)


def test_eight_sessions_at_once_each_see_their_own_result_and_the_server_stays_responsive(browser_context, app_url):
    static = app_url.rsplit("/", 1)[0] + "/static/extensions/panel/css/loading.css"
    urllib.request.urlopen(static, timeout=30).read()  # the probe target exists
    prober = _Prober(static)
    prober.start()
    pages, opened, settled = [], [], []
    try:
        for _ in range(8):
            page = browser_context.new_page()
            page.errors = []
            page.on("pageerror", lambda e, p=page: p.errors.append(str(e)))
            page.on("console", lambda m, p=page: p.errors.append(f"console.{m.type}: {m.text}")
                    if m.type == "error" and not any(s in m.text for s in IGNORED) else None)
            opened.append(time.monotonic())
            page.goto(app_url)
            pages.append(page)
        first = [wait_for_result(page, timeout_ms=180000) for page in pages]
        moved = time.monotonic()  # every session shows its first result
        for steps, page in enumerate(pages):  # session i moves its window by i steps of 0.5 s
            handle = window_handle(page)
            handle.focus()
            for _ in range(steps):
                page.keyboard.press("ArrowRight")
        shown = []
        for i, page in enumerate(pages):
            shown.append(settle(page, after_request=first[i]["requested"] if i else 0, timeout_ms=180000))
            settled.append(time.monotonic())
    finally:
        prober.stop()
    logged = [page.errors for page in pages]  # said with any failure below: a message the page refused
    for steps, state in enumerate(shown):
        assert state["window"] == pytest.approx(5.0 + 0.5 * steps), logged  # no cross-talk of state
        assert state["stage"] == "final" and state["shown"] == state["requested"], logged
    assert len({round(s["band_sum"], 9) for s in shown}) == 8, (shown, logged)  # eight different results
    assert not prober.failures, prober.failures[:3]
    # Responsiveness, as events (the answer times are a benchmark's: bench_dashboard.py --sessions 8):
    # the event loop answered the probe while each session was opening and calibrating, and while
    # the eight windows were moved and re-calibrated, not only before or after them.
    answers = prober.answers
    assert len(answers) >= 50, f"only {len(answers)} answers: the probe did not run throughout"
    for i in range(8):
        during = [a for a in answers if opened[i] <= a[0] and a[1] <= moved]
        assert during, f"no probe was sent and answered while session {i + 1} opened and showed its first result"
    between = [a for a in answers if moved <= a[0] and a[1] <= settled[-1]]
    assert len(between) >= 2, "no probe was answered while the eight moved windows were re-calibrated"
    for page in pages:
        assert page.errors == []
        page.close()


def test_a_slider_storm_shows_only_the_last_result_and_leaves_nothing_running(page, app_url):
    pid = _server_pid(app_url)
    before = wait_for_result(page, timeout_ms=120000)
    _wait_idle(pid)
    threads_idle, workers_idle = _settled_threads(pid), _workers(pid)
    assert len(workers_idle) == 2, f"expected the two inference worker processes, found {workers_idle}"
    handle = window_handle(page)
    handle.focus()
    for i in range(20):  # 20 changes in about 2 s: right 12 times, then left 8 times -> window 7 s
        page.keyboard.press("ArrowRight" if i < 12 else "ArrowLeft")
        page.wait_for_timeout(40)  # plus the press's own round trip to the browser
    during = read_state(page)
    # a storm: its changes came faster than the runs, the last one is not shown yet
    assert during["requested"] > before["requested"] and during["shown"] != during["requested"], during
    after = settle(page, after_request=before["requested"], timeout_ms=120000)
    assert after["window"] == pytest.approx(7.0)
    assert after["stage"] == "final" and after["shown"] == after["requested"]
    assert after["requested"] - before["requested"] <= 20  # debounced: fewer runs than changes
    _wait_idle(pid)  # CPU of the server and of its workers back to idle
    assert _settled_threads(pid) == threads_idle  # no leaked threads: back to the idle count
    assert _workers(pid) == workers_idle  # the same worker processes: none leaked, none restarted
    assert read_state(page)["shown"] == after["shown"]  # nothing stale arrives later
    assert page.errors == []
