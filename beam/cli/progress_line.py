"""The progress line of the long commands (``beam diagnose``, ``beam calibrate``) on a terminal."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["TerminalProgress", "fitted", "progress_line", "wants_progress"]


class TerminalProgress:
    """One status line on a terminal, rewritten in place: ``[  12 s] <the step>``.

    Calling it with a text draws the line anew (cut to the terminal's width by :func:`fitted`). A ticker thread
    redraws the elapsed time every ``tick_s`` seconds while the step stays the same (only the time
    field: the step's text is left on the screen, so a long step still counts its seconds), until
    :meth:`close` stops the thread (joined) and erases the line. Called from the fitting threads
    too: a lock keeps the lines whole.

    Parameters
    ----------
    stream : file
        Where the line is drawn (a terminal; the caller decides whether there is one).
    clock : callable
        Seconds (default :func:`time.perf_counter`); a test gives a fake one.
    tick_s : float or None
        Seconds between two redraws of the elapsed time; None: no ticker thread (a test calls
        :meth:`tick`).
    """

    def __init__(self, stream, *, clock=None, tick_s: float | None = 1.0) -> None:
        import threading
        import time

        self._stream, self._lock, self._clock = stream, threading.Lock(), clock or time.perf_counter
        self._t0 = self._clock()
        self._text: str | None = None
        self._prefix = ""
        self._stop = threading.Event()
        self._ticker = None
        if tick_s is not None:
            self._ticker = threading.Thread(target=self._tick_every, args=(float(tick_s),), name="beam-progress-ticker",
                                            daemon=True)
            self._ticker.start()

    def _time(self) -> str:
        return f"[{self._clock() - self._t0:4.0f} s]"

    def __call__(self, text: str) -> None:
        import shutil

        with self._lock:
            self._text = text
            self._prefix = self._time()
            line = fitted(f"{self._prefix} {text}", max(shutil.get_terminal_size().columns - 1, 20))
            self._stream.write(f"\r\x1b[K{line}")
            self._stream.flush()

    def tick(self) -> None:
        """Redraw the elapsed time of the line (the whole line when the time field's width changed)."""
        with self._lock:
            if self._text is None or self._stop.is_set():
                return
            prefix = self._time()
            if prefix == self._prefix:
                return
            if len(prefix) != len(self._prefix):
                text = self._text
            else:
                self._prefix = prefix
                self._stream.write(f"\r{prefix}")
                self._stream.flush()
                return
        self(text)

    def _tick_every(self, tick_s: float) -> None:
        while not self._stop.wait(tick_s):
            self.tick()

    def close(self) -> None:
        """Stop the ticker (waits for its thread) and erase the line."""
        self._stop.set()
        if self._ticker is not None:
            self._ticker.join()
        with self._lock:
            self._stream.write("\r\x1b[K")
            self._stream.flush()


def fitted(line: str, width: int) -> str:
    """``line`` in ``width`` characters: a longer one keeps its start (what is fitted) and its end
    (what the fit is doing), joined by "…"."""
    if len(line) <= width:
        return line
    head = (width - 1) * 3 // 5
    return line[:head] + "…" + line[len(line) - (width - 1 - head):]


def wants_progress(args: argparse.Namespace) -> bool:
    """A progress line only for a person at a terminal: not with ``--json``, not when stdout or
    stderr is redirected (a pipe, a file, a test's capture)."""
    return not args.json and sys.stdout.isatty() and sys.stderr.isatty()


@contextmanager
def progress_line(args: argparse.Namespace, label: str) -> Iterator[TerminalProgress | None]:
    """A :class:`TerminalProgress` on stderr when :func:`wants_progress` (else None), told
    ``label`` and then what the fits inside the block say under it
    (:func:`beam.inference.progress.reporting`); closed (erased) when the block ends."""
    from beam.inference.progress import reporting

    line = TerminalProgress(sys.stderr) if wants_progress(args) else None
    try:
        with reporting(line, label):
            yield line
    finally:
        if line is not None:
            line.close()
