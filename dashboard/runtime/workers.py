"""Worker processes: the CPU-bound part of the jobs runs here, not in the server process.

Why: the server's event loop answers every browser. Inference on threads of the server
process shares its GIL with the event loop, and on the 2-core machine that made every piece of
event-loop work (building a session, applying a slider change, drawing a result) two to three
times slower while anything was sampling (the slowest of eight sessions' requests 1.5-2.5 s with
threads, 0.37-0.73 s with processes). In separate processes the event loop keeps its
interpreter to itself, and the operating system shares the cores (the workers can run at a
lower priority, ``nice``).

Why not :class:`concurrent.futures.ProcessPoolExecutor` (measured,
``tests/benchmarks/bench_dashboard_runs.py``): it cannot stop a call that runs, so a calibration
superseded mid-MCMC holds its process to the end (the new request's preview 16.5 s after it was
made, against 3.2 s here, load 9-11 on 2 cores); it returns one value per call, so the preview
and the sampler's progress could not stream; and its plain pickle refuses a calibration result
(``Can't pickle local object 'prepare.<locals>.starts'``: the problem's starting points are a
closure, which the pickler below replaces).

Pure Python (no panel, holoviews or bokeh).

:class:`WorkerProcess`
    One ``spawn``-ed process and a pipe. :meth:`WorkerProcess.run` sends it a generator
    function with its arguments and yields the :class:`~dashboard.runtime.scheduler.Stage` items the
    function yields over there, as they come. Cancellation is cooperative and immediate in
    the parent: once the run's ``cancelled`` event is set nothing more is yielded, a
    ``cancel`` message goes to the worker, which closes the generator at its next stage (its
    ``finally`` blocks run) and reports ``done``; the parent waits for that (the worker is then
    free again) in the generator's ``finally``, so closing the run's generator also waits.
:class:`WorkerProcesses`
    A fixed set of workers (one per pool thread), started once and kept (an idle worker
    sleeps on its pipe: no CPU); a worker that died is started again on its next use.

What crosses the pipe
    The function and its arguments are pickled as usual. Stages come back through a pickler
    that (1) sends an object that *is* one of the call's arguments back as a reference, so the
    parent gets its own object again (e.g. the measurement a calibration was given: the plots
    compare records by identity), and (2) sends a :class:`beam.inference.problem.Problem`
    without the callables that cannot be pickled (a closure for the MAP starting points):
    those are replaced by :func:`_not_in_this_process`, which raises if called. Everything
    else of a result — bands, draws, posterior chain, the beam's forward model — arrives
    whole (a beam posterior is ~5 MB, a millisecond to pickle).
"""

from __future__ import annotations

import io
import itertools
import logging
import multiprocessing
import os
import pickle
import sys
import threading
import traceback
from collections.abc import Callable, Iterator
from typing import Any

__all__ = ["WorkerError", "WorkerProcess", "WorkerProcesses"]

log = logging.getLogger(__name__)

#: Environment variables that keep numerical libraries to one thread per worker process.
_ONE_THREAD = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")
#: Seconds between two checks for cancellation while waiting for the next stage.
POLL_S = 0.05


class WorkerError(RuntimeError):
    """A worker process stopped, or an error of the job could not be sent back as itself."""


def _not_in_this_process(*args, **kwargs):
    """Stand-in for a callable that stayed in the worker process."""
    raise WorkerError("this function of the result stayed in the worker process that computed it")


def _rebuild(cls, state: dict):
    obj = cls.__new__(cls)
    obj.__dict__.update(state)
    return obj


#: Argument types sent back by value, not as references to the caller's objects.
_PLAIN = (int, float, complex, str, bytes, bool, type(None))


class _StagePickler(pickle.Pickler):
    """Pickles a worker's messages; see the module docstring."""

    def __init__(self, file, anchors: dict[int, int]) -> None:
        super().__init__(file, protocol=pickle.HIGHEST_PROTOCOL)
        self._anchors = anchors
        from beam.inference.problem import Problem

        self._problem = Problem

    def persistent_id(self, obj):
        index = self._anchors.get(id(obj))
        return None if index is None else ("arg", index)

    def reducer_override(self, obj):
        if type(obj) is self._problem:
            state = dict(obj.__dict__)
            for name in ("model", "initial_guesses"):
                if "<locals>" in getattr(state.get(name), "__qualname__", ""):
                    state[name] = _not_in_this_process
            return _rebuild, (type(obj), state)
        return NotImplemented


class _StageUnpickler(pickle.Unpickler):
    def __init__(self, file, args: tuple) -> None:
        super().__init__(file)
        self._args = args

    def persistent_load(self, pid):
        return self._args[pid[1]]


def _send(conn, message: tuple, anchors: dict[int, int]) -> None:
    buffer = io.BytesIO()
    _StagePickler(buffer, anchors).dump(message)
    conn.send_bytes(buffer.getbuffer())


def _portable(exc: BaseException) -> BaseException:
    """``exc`` if it survives pickling, else a :class:`WorkerError` (or ``ValueError``) with its text."""
    try:
        pickle.loads(pickle.dumps(exc))
        return exc
    except Exception:  # noqa: BLE001 - any pickling problem
        text = f"{type(exc).__name__}: {exc}"
        return ValueError(str(exc)) if isinstance(exc, ValueError) else WorkerError(text)


def _pending_orders(conn, task: int) -> tuple[bool, bool]:
    """Read the pending messages: (whether one cancels ``task`` or stops the worker, whether one
    stops the worker). A ``stop`` read here must not be lost: the worker exits after the run."""
    cancelled = stop = False
    while conn.poll():
        message = conn.recv()
        if message[0] == "stop":
            cancelled = stop = True
        elif message[0] == "cancel" and message[1] == task:
            cancelled = True
    return cancelled, stop


def _warm(warm: Callable[[], None]) -> None:
    try:
        warm()
    except Exception:  # noqa: BLE001 - a failed warm-up only costs time later
        traceback.print_exc()


def _worker_main(conn, nice: int, warm: Callable[[], None] | None) -> None:
    """Body of a worker process: run the functions sent until told to stop or the pipe closes."""
    if nice:
        try:
            os.nice(nice)
        except OSError:  # pragma: no cover - not permitted: run at the normal priority
            pass
    if warm is not None:  # beside the first jobs, not before them: a preview needs less than the sampler
        threading.Thread(target=_warm, args=(warm,), name="beam-worker-warm-up", daemon=True).start()
    while True:
        try:
            message = conn.recv()
        except (EOFError, OSError):
            return
        if message[0] == "stop":
            return
        if message[0] != "run":
            continue  # a late cancel of a task that has finished
        _, task, fn, args, kwargs = message
        # plain values are not anchored: their identity means nothing (small ints and short strings are
        # shared objects), and an int argument equal to an anchor's index made the pickler recurse
        anchors = {id(a): i for i, a in enumerate(args) if not isinstance(a, _PLAIN)}
        gen = None
        stop = False
        outcome: tuple = ("done", task, None)
        try:
            gen = iter(fn(*args, **kwargs))
            for stage in gen:
                cancelled, stop = _pending_orders(conn, task)
                if cancelled:
                    break
                _send(conn, ("stage", task, stage), anchors)
        except Exception as exc:  # noqa: BLE001 - sent to the parent, which publishes it
            if not isinstance(exc, ValueError):
                traceback.print_exc()
            outcome = ("error", task, _portable(exc))
        finally:
            close = getattr(gen, "close", None)
            if close is not None:
                try:
                    close()
                except Exception:  # noqa: BLE001 - a job's finally block failing
                    traceback.print_exc()
        try:
            _send(conn, outcome, anchors)
        except (BrokenPipeError, EOFError, OSError):
            return
        if stop:
            return


def _spawn_context():
    return multiprocessing.get_context("spawn")


class WorkerProcess:
    """One worker process (started on first use, or by :meth:`start`).

    Parameters
    ----------
    name : str
        Process name.
    nice : int
        Added to the process's niceness (lower priority than the server: its event loop wins
        the CPU when both want it).
    warm : callable, optional
        Called once in the new process, on a thread of its own beside the first jobs (imports,
        compiled kernels).
    """

    def __init__(self, name: str = "beam-worker", *, nice: int = 0, warm: Callable[[], None] | None = None) -> None:
        self.name, self.nice, self.warm = name, int(nice), warm
        self._process = None
        self._conn = None
        self._tasks = itertools.count(1)
        self._lock = threading.Lock()

    @property
    def pid(self) -> int | None:
        """Process id, None before the start."""
        return None if self._process is None else self._process.pid

    @property
    def alive(self) -> bool:
        """Whether the process runs."""
        return self._process is not None and self._process.is_alive()

    def start(self) -> None:
        """Start the process unless it runs (non-blocking: it warms up on its own)."""
        with self._lock:
            if self.alive:
                return
            self._close_pipe()
            ctx = _spawn_context()
            parent, child = ctx.Pipe(duplex=True)
            saved = {k: os.environ.get(k) for k in _ONE_THREAD}
            try:  # the child reads its environment at start: one thread each, two workers on two cores
                for k in _ONE_THREAD:
                    os.environ.setdefault(k, "1")
                process = ctx.Process(target=_worker_main, args=(child, self.nice, self.warm), name=self.name,
                                      daemon=True)
                process.start()
            finally:
                for k, v in saved.items():
                    if v is None:
                        os.environ.pop(k, None)
                    else:
                        os.environ[k] = v
            child.close()
            self._process, self._conn = process, parent

    def _close_pipe(self) -> None:
        if self._conn is not None:
            try:
                self._conn.close()
            except OSError:  # pragma: no cover
                pass
            self._conn = None

    def stop(self, timeout: float = 5.0) -> None:
        """Ask the process to stop; terminate it if it has not within ``timeout``."""
        with self._lock:
            process, conn = self._process, self._conn
            if process is None:
                return
            try:
                conn.send(("stop",))
            except (BrokenPipeError, OSError):
                pass
            process.join(timeout)
            if process.is_alive():
                process.terminate()
                process.join(timeout)
            self._close_pipe()
            self._process = None

    def _died(self) -> WorkerError:
        code = None if self._process is None else self._process.exitcode
        with self._lock:
            self._close_pipe()
            self._process = None
        return WorkerError(f"the worker process stopped unexpectedly (exit code {code}); it is restarted for the next run")

    def _receive(self, args: tuple) -> tuple:
        data = self._conn.recv_bytes()
        return _StageUnpickler(io.BytesIO(data), args).load()

    def run(self, fn: Callable[..., Iterator[Any]], args: tuple = (), kwargs: dict | None = None, *,
            cancelled: threading.Event | None = None) -> Iterator[Any]:
        """Yield what ``fn(*args, **kwargs)`` yields in the worker process.

        Raises what the function raised (as itself when it pickles), or :class:`WorkerError`
        when the process dies. Nothing is yielded once ``cancelled`` is set.
        """
        self.start()
        task = next(self._tasks)
        args = tuple(args)
        conn = self._conn
        try:
            conn.send(("run", task, fn, args, dict(kwargs or {})))
        except (BrokenPipeError, OSError):
            raise self._died() from None
        finished, cancel_sent = False, False
        try:
            while True:
                if cancelled is not None and cancelled.is_set() and not cancel_sent:
                    conn.send(("cancel", task))
                    cancel_sent = True
                if not conn.poll(POLL_S):
                    if not self._process.is_alive():
                        finished = True
                        raise self._died()
                    continue
                try:
                    kind, tid, payload = self._receive(args)
                except (EOFError, OSError):
                    finished = True
                    raise self._died() from None
                if tid != task:
                    continue
                if kind == "stage":
                    if not cancel_sent:
                        yield payload
                    continue
                finished = True
                if kind == "error":
                    raise payload
                return
        finally:
            if not finished:  # closed early (the run was cancelled): stop the worker's generator
                self._finish(task, cancel_sent, args)

    def _finish(self, task: int, cancel_sent: bool, args: tuple) -> None:
        conn = self._conn
        try:
            if not cancel_sent:
                conn.send(("cancel", task))
            while True:
                if not conn.poll(POLL_S):
                    if not self._process.is_alive():
                        self._died()
                        return
                    continue
                kind, tid, _ = self._receive(args)
                if tid == task and kind in ("done", "error"):
                    return
        except (EOFError, OSError, pickle.UnpicklingError):
            self._died()


class WorkerProcesses:
    """A fixed set of worker processes, lent to one run at a time.

    Parameters
    ----------
    count : int
        Number of processes.
    nice : int
        Niceness added to each worker.
    warm : callable, optional
        Run once in each new process (see :class:`WorkerProcess`).
    """

    def __init__(self, count: int, *, nice: int = 0, warm: Callable[[], None] | None = None) -> None:
        if count < 1:
            raise ValueError(f"count must be at least 1, got {count}")
        self.workers = [WorkerProcess(f"beam-worker-{i + 1}", nice=nice, warm=warm) for i in range(count)]
        self._free = list(self.workers)
        self._waiting = 0  # ordinary acquirers waiting (see acquire)
        self._cv = threading.Condition()
        self._closed = False

    @property
    def pids(self) -> list[int]:
        """Process ids of the workers running now."""
        return [w.pid for w in self.workers if w.alive]

    def start(self) -> None:
        """Start every worker (they warm up in parallel)."""
        for w in self.workers:
            w.start()

    def acquire(self, *, background: bool = False) -> WorkerProcess:
        """A free worker (waits for one). A ``background`` acquirer (the fits a diagnosis spreads
        over the workers) also waits while an ordinary one is waiting, so a calibration another
        session (or the same one) asks for takes the next free worker."""
        with self._cv:
            if not background:
                self._waiting += 1
            try:
                while not self._free or (background and self._waiting > 0):
                    if self._closed:
                        raise RuntimeError("the worker processes are shut down")
                    self._cv.wait()
                if self._closed:
                    raise RuntimeError("the worker processes are shut down")
                return self._free.pop()
            finally:
                if not background:
                    self._waiting -= 1
                    self._cv.notify_all()  # background acquirers re-check

    def release(self, worker: WorkerProcess) -> None:
        """Give a worker back."""
        with self._cv:
            self._free.append(worker)
            self._cv.notify_all()  # ordinary and background acquirers alike

    def run(self, fn: Callable[..., Iterator[Any]], args: tuple = (), kwargs: dict | None = None, *,
            cancelled: threading.Event | None = None, background: bool = False) -> Iterator[Any]:
        """:meth:`WorkerProcess.run` on a free worker (see :meth:`acquire` for ``background``)."""
        worker = self.acquire(background=background)
        try:
            yield from worker.run(fn, args, kwargs, cancelled=cancelled)
        finally:
            self.release(worker)

    def shutdown(self, timeout: float = 5.0) -> None:
        """Stop every worker."""
        with self._cv:
            self._closed = True
            self._cv.notify_all()
        for w in self.workers:
            w.stop(timeout)


def in_worker() -> bool:
    """Whether this code runs in a worker process (for logs and tests)."""
    return multiprocessing.current_process().name.startswith("beam-worker")


if __name__ == "__main__":  # pragma: no cover
    sys.exit("dashboard.runtime.workers is a library module")
