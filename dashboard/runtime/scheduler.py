"""Run scheduler: inference jobs off the server's event loop, latest request wins.

Pure Python (no panel, holoviews or bokeh), so that every rule below is unit-tested without a
browser or a server.

Vocabulary
----------
job
    A zero-argument callable returning an iterator of :class:`Stage` (usually a generator
    function bound with :func:`functools.partial`). It runs on a worker thread of a
    :class:`RunPool`. Cancellation is cooperative: the scheduler checks for it between two
    stages and then closes the generator (its ``finally`` blocks run), so a job should yield
    at least every few tenths of a second (the sampler's progress reports do).
stage
    What a job yields: ``preview`` (instant MAP/Laplace result), ``progress`` (fraction done),
    ``partial`` (intermediate result), ``final``. An exception raised by the job becomes an
    ``error`` update carrying a readable one-line message (:func:`readable_error`).
slot
    :class:`RunSlot`: the "latest run" of one activity of one browser session. A new request
    cancels the previous one (still waiting, queued or running). Requests are debounced,
    leading and trailing edge: a request that comes after a quiet spell of ``debounce_s``
    starts at once (a click on a slider or a select answers without delay); one that comes
    within ``debounce_s`` of the previous request waits until ``debounce_s`` has passed
    without a newer one, so a slider dragged through twenty values runs at most two jobs
    (the first, soon cancelled, and the last). A cancelled or superseded job never publishes:
    currency is checked on the worker before dispatching *and* again, under the slot's lock,
    when the update is delivered (the dispatch may hop to the event loop in between).
pool
    :class:`RunPool`: one per server process (:func:`shared_pool`), at most ``max_workers``
    threads (default 2, the machine's cores; environment variable ``BEAM_DASHBOARD_WORKERS``),
    shared by all sessions. Delayed (debounced) work waits in a heap, not on a thread; worker
    threads are started on demand and exit after ``idle_timeout_s`` without work
    (``BEAM_DASHBOARD_IDLE_S``, default 30 s), so an idle server runs no scheduler thread at all.
worker processes
    A pool made with ``processes=True`` (the shared pool, unless ``BEAM_DASHBOARD_PROCESSES=0``)
    also owns one worker *process* per thread (:class:`dashboard.runtime.workers.WorkerProcesses`).
    A job hands its CPU-bound part to one with :func:`offload` — ``yield from
    offload(fn, *args)`` yields what the generator function ``fn`` yields over there — so the
    job's thread in the server only waits on a pipe and the server's event loop never shares
    its GIL with inference. Cancellation reaches the worker at once and takes effect at its
    next stage, as for a job on the thread. Without worker processes (the unit tests' pools)
    :func:`offload` runs ``fn`` on the thread itself.

Why hand-written (what no library here does, measured)
------------------------------------------------------
* **A running job is cancelled, not waited for.** ``concurrent.futures`` (threads or processes)
  and Panel's ``pn.state.execute`` start a call and give back its one result; a call that runs
  cannot be stopped (``Future.cancel`` refuses) and shows nothing before it returns. A slot's job
  is a generator that streams its stages and is closed at the next one when a newer request
  comes. Measured (``tests/benchmarks/bench_dashboard_runs.py``: lab_run_1 with the tip mass, the
  window moved while the first run samples; one worker process, load 9-11 on 2 cores): the new
  request's preview 3.2 s (slowest 3.5 s) after it was made, against 16.5 s (16.8 s) with a
  one-process ``ProcessPoolExecutor``, where it waits for the superseded calibration to end.
* **Debounce in the slot.** Panel's throttled sliders (``value_throttled``) throttle a mouse
  drag only; each arrow key, select, check-box or ``param.update`` is a change of its own. The
  slot runs the first and the last of a burst: the browser storm test
  (``tests/browser/test_concurrency.py``, 20 key presses in ~2 s) runs at most 20 and shows
  only the last, and a dragged slider runs at most two jobs (``tests/dashboard/test_scheduler.py``).
* **One heap of delayed calls and threads that exit when idle.** A debounced request waits in
  :class:`RunPool`'s heap, not on a thread of its own (a ``threading.Timer`` per request is a
  thread per key press of a storm), and an idle server keeps no scheduler thread: the storm test
  finds the server's thread count back at its idle value; ``ThreadPoolExecutor`` keeps its
  threads until it is shut down.
"""

from __future__ import annotations

import heapq
import itertools
import logging
import os
import queue
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

__all__ = [
    "KINDS",
    "RunPool",
    "RunSlot",
    "Stage",
    "Update",
    "final",
    "offload",
    "offload_map",
    "OffloadQueue",
    "final_value",
    "Cancelled",
    "partial",
    "preview",
    "progress",
    "readable_error",
    "set_worker_warm_up",
    "shared_pool",
]

log = logging.getLogger(__name__)

#: What the running job's thread knows: its pool and its request's cancellation event.
_current = threading.local()

#: Kinds of updates, in the order a successful job publishes them (``error`` ends a failed one).
KINDS = ("preview", "progress", "partial", "final", "error")

Job = Callable[[], Iterator["Stage"]]
Dispatch = Callable[[Callable[[], None]], None]


T = TypeVar("T")


@dataclass(frozen=True)
class Stage(Generic[T]):
    """One item yielded by a job; ``Stage[CalibrationResult]`` names the type of its value.

    Attributes
    ----------
    kind : {"preview", "progress", "partial", "final"}
        What the item is.
    value : object
        The (intermediate) result, None for ``progress``.
    fraction : float or None
        Fraction of the job done, in [0, 1].
    message : str
        Short human-readable status ("sampling, 120 of 400 steps").
    """

    kind: str
    value: T | None = None
    fraction: float | None = None
    message: str = ""


def preview(value: Any, message: str = "") -> Stage:
    """A ``preview`` stage (fraction 0)."""
    return Stage("preview", value, 0.0, message)


def progress(fraction: float, message: str = "") -> Stage:
    """A ``progress`` stage (no value)."""
    return Stage("progress", None, float(fraction), message)


def partial(value: Any, fraction: float | None = None, message: str = "") -> Stage:
    """A ``partial`` stage: an intermediate result."""
    return Stage("partial", value, None if fraction is None else float(fraction), message)


def final(value: Any, message: str = "") -> Stage:
    """The ``final`` stage (fraction 1)."""
    return Stage("final", value, 1.0, message)


@dataclass(frozen=True)
class Update:
    """A stage as published to the slot's owner.

    Attributes
    ----------
    request : int
        Id of the request (1, 2, ... per slot) the update belongs to.
    kind : str
        One of :data:`KINDS`.
    value : object
        Result carried by ``preview``, ``partial`` and ``final``.
    fraction : float or None
        Fraction done.
    message : str
        Status text, or the error message for ``error``.
    elapsed_s : float
        Seconds since the request was made (debounce included).
    slot : str
        Name of the slot.
    """

    request: int
    kind: str
    value: Any
    fraction: float | None
    message: str
    elapsed_s: float
    slot: str = ""


def readable_error(exc: BaseException) -> str:
    """One line for the user: the message of a user error, the type and message of a bug.

    :class:`beam.errors.BeamInputError` (and any ``ValueError``) carries a message meant for
    the user; anything else is an internal error whose traceback goes to the server log.
    """
    text = " ".join(str(exc).split()) or type(exc).__name__
    if isinstance(exc, ValueError):
        return text
    return f"internal error ({type(exc).__name__}: {text}); the details are in the server log"


# -- the pool ---------------------------------------------------------------------------------


class _Entry:
    """A scheduled call (see :meth:`RunPool.cancel`)."""

    __slots__ = ("cancelled", "due", "fn", "on_drop", "seq", "taken")

    def __init__(self, due: float, seq: int, fn: Callable[[], None], on_drop: Callable[[], None] | None) -> None:
        self.due, self.seq, self.fn, self.on_drop = due, seq, fn, on_drop
        self.cancelled = False
        self.taken = False

    def __lt__(self, other: _Entry) -> bool:
        return (self.due, self.seq) < (other.due, other.seq)


class RunPool:
    """A small thread pool with delayed calls and worker threads that exit when idle.

    Parameters
    ----------
    max_workers : int
        Upper bound on worker threads.
    idle_timeout_s : float
        A worker exits after this long without work.
    name : str
        Prefix of the thread names.
    processes : bool
        Also keep ``max_workers`` worker processes for :func:`offload` (started by
        :meth:`start_processes` or on first use; they stay until :meth:`shutdown`).
    nice : int
        Niceness added to the worker processes.
    warm : callable, optional
        Run once in each new worker process (imports, compiled kernels).
    """

    def __init__(self, max_workers: int = 2, *, idle_timeout_s: float = 30.0, name: str = "beam-run",
                 processes: bool = False, nice: int = 0, warm: Callable[[], None] | None = None) -> None:
        if max_workers < 1:
            raise ValueError(f"max_workers must be at least 1, got {max_workers}")
        self.max_workers = int(max_workers)
        #: The worker processes of :func:`offload` (None: offloaded work runs on the threads).
        self.workers = None
        if processes:
            from dashboard.runtime.workers import WorkerProcesses

            self.workers = WorkerProcesses(self.max_workers, nice=nice, warm=warm)
        self.idle_timeout_s = float(idle_timeout_s)
        self.name = name
        self._cv = threading.Condition()
        self._heap: list[_Entry] = []
        self._seq = itertools.count()
        self._threads: set[threading.Thread] = set()
        self._idle = 0
        self._closed = False

    @property
    def n_threads(self) -> int:
        """Worker threads currently alive."""
        with self._cv:
            return len(self._threads)

    @property
    def process_ids(self) -> list[int]:
        """Process ids of the worker processes running now (empty without processes)."""
        return [] if self.workers is None else self.workers.pids

    def start_processes(self) -> None:
        """Start the worker processes now (they warm up in the background); no-op without processes."""
        if self.workers is not None:
            self.workers.start()

    def cancel(self, entry: _Entry) -> bool:
        """Cancel a scheduled call; True if that prevented it from running."""
        with self._cv:
            entry.cancelled = True
            return not entry.taken

    def schedule(self, fn: Callable[[], None], delay_s: float = 0.0, *, on_drop: Callable[[], None] | None = None) -> _Entry:
        """Run ``fn()`` on a worker no sooner than ``delay_s`` from now; returns a cancellable entry.

        ``on_drop()`` is called instead if :meth:`shutdown` drops the call before it started.
        """
        with self._cv:
            if self._closed:
                raise RuntimeError("the run pool is shut down")
            entry = _Entry(time.monotonic() + max(float(delay_s), 0.0), next(self._seq), fn, on_drop)
            heapq.heappush(self._heap, entry)
            pending = sum(not e.cancelled for e in self._heap)
            if pending > self._idle and len(self._threads) < self.max_workers:
                thread = threading.Thread(target=self._work, name=f"{self.name}-{entry.seq}", daemon=True)
                self._threads.add(thread)
                thread.start()
            self._cv.notify()
            return entry

    def _next(self) -> _Entry | None:
        """Wait for the next due, uncancelled entry (None: exit the thread). Caller holds the lock."""
        idle_until = time.monotonic() + self.idle_timeout_s
        self._idle += 1
        try:
            while not self._closed:
                while self._heap and self._heap[0].cancelled:
                    heapq.heappop(self._heap)
                now = time.monotonic()
                if self._heap and self._heap[0].due <= now:
                    entry = heapq.heappop(self._heap)
                    entry.taken = True
                    return entry
                if self._heap:
                    self._cv.wait(self._heap[0].due - now)
                    idle_until = time.monotonic() + self.idle_timeout_s
                elif now >= idle_until:
                    return None
                else:
                    self._cv.wait(idle_until - now)
            return None
        finally:
            self._idle -= 1

    def _work(self) -> None:
        me = threading.current_thread()
        try:
            while True:
                with self._cv:
                    entry = self._next()
                    if entry is None:
                        return
                try:
                    entry.fn()
                except Exception:  # the slot catches job errors; this is a bug in the scheduler itself
                    log.exception("unhandled error in a scheduled call")
        finally:
            with self._cv:
                self._threads.discard(me)
                self._cv.notify_all()

    def shutdown(self, wait: bool = True, timeout: float | None = 10.0) -> None:
        """Drop pending calls, let running ones finish, and (if ``wait``) join the workers."""
        with self._cv:
            self._closed = True
            dropped = [e for e in self._heap if not e.cancelled and e.on_drop is not None]
            for entry in self._heap:
                entry.cancelled = True
            self._heap.clear()
            self._cv.notify_all()
            threads = list(self._threads)
        for entry in dropped:
            entry.on_drop()
        if wait:
            deadline = None if timeout is None else time.monotonic() + timeout
            for thread in threads:
                thread.join(None if deadline is None else max(deadline - time.monotonic(), 0.0))
        if self.workers is not None:
            self.workers.shutdown()


#: Niceness of the shared pool's worker processes (``BEAM_DASHBOARD_NICE``): the server's
#: event loop, which answers every browser, gets the CPU first.
DEFAULT_NICE = 10

_shared: RunPool | None = None
_shared_lock = threading.Lock()
_worker_warm_up: Callable[[], None] | None = None


def set_worker_warm_up(warm: Callable[[], None] | None) -> None:
    """What each new worker process of the shared pool runs first (a module-level function).

    The app sets it (:func:`dashboard.jobs.warm.warm_worker`) before the pool is first used, so
    the runtime imports nothing of the jobs it runs.
    """
    global _worker_warm_up
    _worker_warm_up = warm


def shared_pool() -> RunPool:
    """The process-wide pool shared by all sessions (created on first use)."""
    global _shared
    with _shared_lock:
        if _shared is None or _shared._closed:
            workers = int(os.environ.get("BEAM_DASHBOARD_WORKERS", "2"))
            idle_s = float(os.environ.get("BEAM_DASHBOARD_IDLE_S", "30"))
            processes = os.environ.get("BEAM_DASHBOARD_PROCESSES", "1") not in ("0", "", "no", "false")
            nice = int(os.environ.get("BEAM_DASHBOARD_NICE", str(DEFAULT_NICE)))
            warm = _worker_warm_up if processes else None
            _shared = RunPool(max_workers=max(workers, 1), idle_timeout_s=idle_s, processes=processes, nice=nice,
                              warm=warm)
        return _shared


def offload(fn: Callable[..., Iterator[Stage]], *args: Any, **kwargs: Any) -> Iterator[Stage]:
    """Yield the stages of ``fn(*args, **kwargs)``, computed in a worker process of the job's pool.

    Use it inside a job (``yield from offload(...)``): the stages come back as they are
    yielded over there, and closing the job (cancellation) stops ``fn`` at its next stage.
    ``fn`` and the arguments must pickle (a module-level generator function); objects passed
    as arguments come back as themselves inside the results (see :mod:`dashboard.runtime.workers`).
    Outside a job of a pool with worker processes, ``fn`` runs here, on the calling thread.
    """
    pool = getattr(_current, "pool", None)
    workers = None if pool is None else pool.workers
    if workers is None:
        yield from fn(*args, **kwargs)
        return
    yield from workers.run(fn, args, kwargs, cancelled=getattr(_current, "cancelled", None))


class Cancelled(Exception):
    """The job that called :func:`offload_map` was cancelled while the calls ran."""


class OffloadQueue:
    """Calls of generator functions on the pool's worker processes, submitted while earlier ones
    run; their final values come back in the order the calls finish.

    Use it inside a job, as :func:`offload`: ``submit`` a call under a key, ``next()`` waits for
    the next call to finish and returns ``(key, final value)`` (an exception raised by a call as
    its value). The calls' ``progress`` stages are kept for :meth:`reports` (what the running
    calls say, for the job to pass on while it waits: :meth:`ended` tells when to stop waiting);
    the other stages are dropped. As many calls run at once as the
    pool has processes; the others wait in submission order (``first=True`` jumps the queue). A
    call waits for a free process and gives way to any other run waiting for one
    (:meth:`~dashboard.runtime.workers.WorkerProcesses.acquire`, ``background``). :meth:`idle`
    tells whether a process would otherwise be left without work: the diagnosis fills it with
    fits it will probably need (:mod:`dashboard.jobs.diagnosis`).

    Cancellation (the job's ticket) stops every call at its next stage and raises
    :class:`Cancelled` from :meth:`next`. :meth:`close` drops the calls not started; a call in
    progress finishes on its process (a fit cannot stop between two of its own stages) and its
    value is dropped. Outside a job of a pool with worker processes, :meth:`next` runs the first
    waiting call on the calling thread (one at a time: :attr:`capacity` is 1).
    """

    def __init__(self) -> None:
        pool = getattr(_current, "pool", None)
        self._workers = None if pool is None else pool.workers
        self._cancelled: threading.Event | None = getattr(_current, "cancelled", None)
        self._waiting: list[tuple[Any, Callable[..., Iterator[Stage]], tuple, dict]] = []
        self._running = 0
        self._drivers = 0
        self._closed = False
        self._lock = threading.Lock()
        self._done: queue.Queue = queue.Queue()
        self._unread = 0
        self._told: list[tuple[Any, Stage]] = []
        self._stirred = threading.Event()  # a report or an ended call since the last wait

    @property
    def capacity(self) -> int:
        """How many calls run at once (the pool's processes; 1 on the calling thread)."""
        return 1 if self._workers is None else len(self._workers.workers)

    def idle(self) -> int:
        """Processes that no running or waiting call will occupy."""
        with self._lock:
            return max(self.capacity - self._running - len(self._waiting), 0)

    def outstanding(self) -> int:
        """Calls submitted whose values :meth:`next` has not returned yet."""
        with self._lock:
            return self._unread

    def submit(self, key: Any, fn: Callable[..., Iterator[Stage]], *args: Any, first: bool = False,
               **kwargs: Any) -> None:
        """Queue ``fn(*args, **kwargs)`` under ``key`` (``first``: ahead of the calls waiting)."""
        with self._lock:
            if self._closed:
                raise RuntimeError("submit to a closed OffloadQueue")
            entry = (key, fn, args, kwargs)
            self._waiting.insert(0, entry) if first else self._waiting.append(entry)
            self._unread += 1
            start = self._workers is not None and self._drivers < self.capacity
            if start:
                self._drivers += 1
        if start:
            threading.Thread(target=self._drive, name="offload-queue", daemon=True).start()

    def _drive(self) -> None:
        while True:
            with self._lock:
                if not self._waiting or self._closed or (self._cancelled is not None and self._cancelled.is_set()):
                    self._drivers -= 1
                    return
                key, fn, args, kwargs = self._waiting.pop(0)
                self._running += 1
            try:
                value = self._final(key, self._workers.run(fn, args, kwargs, cancelled=self._cancelled, background=True))
            except BaseException as exc:  # noqa: BLE001 - handed to the caller as the call's value
                value = exc
            with self._lock:
                self._running -= 1
            self._done.put((key, value))
            self._stirred.set()

    def _final(self, key: Any, stages: Iterator[Stage]) -> Any:
        """:func:`final_value` of a call's stages, its ``progress`` stages kept for :meth:`reports`."""
        value, seen = None, False
        for stage in stages:
            if stage.kind == "final":
                value, seen = stage.value, True
            elif stage.kind == "progress" and self._workers is not None:  # inline: told after the fact, dropped
                with self._lock:
                    self._told.append((key, stage))
                self._stirred.set()
        if not seen:
            raise Cancelled()
        return value

    def ended(self) -> bool:
        """Whether :meth:`next` would return without waiting for a process: a call has ended (or
        the calls run on the calling thread, in :meth:`next` itself), or none is outstanding."""
        return self._workers is None or not self._done.empty() or self.outstanding() == 0

    def reports(self, timeout: float | None = None) -> list[tuple[Any, Stage]]:
        """``(key, progress stage)`` of the running calls since the last call, oldest first; waits
        up to ``timeout`` seconds (default :data:`POLL_S`) for one unless a call has ended.

        Raises
        ------
        Cancelled
            The job was cancelled.
        """
        if not self.ended():
            self._stirred.wait(POLL_S if timeout is None else timeout)
        if self._cancelled is not None and self._cancelled.is_set():
            raise Cancelled()
        with self._lock:
            told, self._told = self._told, []
            self._stirred.clear()
        return told

    def next(self) -> tuple[Any, Any]:
        """``(key, final value)`` of the next call to finish (waits for it).

        Raises
        ------
        Cancelled
            The job was cancelled.
        LookupError
            No call is outstanding.
        """
        with self._lock:
            if self._unread == 0:
                raise LookupError("no call is outstanding")
        if self._workers is None:
            if self._cancelled is not None and self._cancelled.is_set():
                raise Cancelled()
            if self._done.empty():
                with self._lock:
                    key, fn, args, kwargs = self._waiting.pop(0)
                try:
                    self._done.put((key, self._final(key, fn(*args, **kwargs))))
                except Cancelled:
                    raise
                except BaseException as exc:  # noqa: BLE001 - as on a worker process
                    self._done.put((key, exc))
        while True:
            try:
                key, value = self._done.get(timeout=POLL_S)
                break
            except queue.Empty:
                if self._cancelled is not None and self._cancelled.is_set():
                    raise Cancelled() from None
        if self._cancelled is not None and self._cancelled.is_set():
            raise Cancelled()
        with self._lock:
            self._unread -= 1
        return key, value

    def close(self) -> None:
        """Drop the calls not started (a call in progress finishes; its value is dropped)."""
        with self._lock:
            self._closed = True
            self._unread -= len(self._waiting)
            self._waiting.clear()


def offload_map(fn: Callable[..., Iterator[Stage]], calls: list[tuple[tuple, dict]]) -> Iterator[tuple[int, Any]]:
    """Run ``fn(*args, **kwargs)`` for each ``(args, kwargs)`` of ``calls`` on the pool's worker
    processes, as many at once as the pool has processes; yield ``(index, final value)`` as each
    call finishes (completion order), an exception raised by a call as its value.

    An :class:`OffloadQueue` with every call submitted at once, in the order given (put the
    slow ones first); the same rules for waiting, giving way and cancellation. Leaving the
    loop early drops the calls not started.

    Measured (the dashboard's diagnosis of lab_run_1, 7 modes: five candidate fits, then four
    more on top of the best; quiet 2-core machine): 12.2 s on two processes against 22.1 s with
    the calls one after the other; two threads of one process had gained only ~1.2x (the model's
    Python between the compiled kernels holds the GIL).
    """
    calls_queue = OffloadQueue()
    for i, (args, kwargs) in enumerate(calls):
        calls_queue.submit(i, fn, *args, **kwargs)
    try:
        for _ in range(len(calls)):
            yield calls_queue.next()
    finally:
        calls_queue.close()


#: Seconds between two checks for cancellation while :func:`offload_map` waits.
POLL_S = 0.05


def final_value(stages: Iterator[Stage]) -> Any:
    """The value of the ``final`` stage of ``stages`` (:class:`Cancelled` if there is none)."""
    value, seen = None, False
    for stage in stages:
        if stage.kind == "final":
            value, seen = stage.value, True
    if not seen:
        raise Cancelled()
    return value


# -- the per-session slot -----------------------------------------------------------------------


class _Ticket:
    """One request of a slot. ``finished`` is set once it can publish nothing more."""

    def __init__(self, request: int, job: Job, made: float) -> None:
        self.request = request
        self.job = job
        self.made = made
        self.cancelled = threading.Event()
        self.finished = threading.Event()
        self.entry: _Entry | None = None
        self.last_progress = -1.0

    def cancel(self, pool: RunPool) -> None:
        self.cancelled.set()
        if self.entry is not None and pool.cancel(self.entry):
            self.finished.set()  # never started and never will


def _call_now(fn: Callable[[], None]) -> None:
    fn()


class RunSlot:
    """The "latest run" of one activity of one session.

    Parameters
    ----------
    on_update : callable
        Called with each :class:`Update` of the current request, through ``dispatch``.
    pool : RunPool, optional
        Where jobs run (default :func:`shared_pool`).
    dispatch : callable, optional
        ``dispatch(fn)`` must eventually call ``fn()`` (e.g. on the session's event loop); it
        is called from worker threads. Default: call at once, on the worker.
    debounce_s : float
        Requests closer together than this are a burst: only the last of a burst runs, once
        it has been quiet for ``debounce_s`` (see the module docstring).
    progress_interval_s : float
        Minimum time between two published ``progress`` updates of a request.
    name : str
        Name carried by the updates.
    """

    def __init__(
        self,
        on_update: Callable[[Update], None],
        *,
        pool: RunPool | None = None,
        dispatch: Dispatch | None = None,
        debounce_s: float = 0.15,
        progress_interval_s: float = 0.2,
        name: str = "run",
    ) -> None:
        self._on_update = on_update
        self._pool = pool
        self._dispatch = dispatch or _call_now
        self.debounce_s = float(debounce_s)
        self.progress_interval_s = float(progress_interval_s)
        self.name = name
        self._lock = threading.RLock()
        self._ticket: _Ticket | None = None
        self._count = 0
        self._last_request = -float("inf")
        self._closed = False
        #: Updates dropped because their request had been superseded (for tests and logs).
        self.dropped = 0

    @property
    def pool(self) -> RunPool:
        """The pool jobs run on."""
        if self._pool is None:
            self._pool = shared_pool()
        return self._pool

    @property
    def latest(self) -> int:
        """Id of the latest request (0 before the first)."""
        return self._count

    @property
    def busy(self) -> bool:
        """True while the latest request is waiting, queued or running."""
        ticket = self._ticket
        return ticket is not None and not ticket.finished.is_set() and not ticket.cancelled.is_set()

    def request(self, job: Job, *, debounce_s: float | None = None) -> int:
        """Supersede the current request by ``job``; returns the new request id at once.

        ``debounce_s`` overrides the slot's debounce for this request (0: start now).
        """
        now = time.perf_counter()
        with self._lock:
            if debounce_s is not None:
                delay = float(debounce_s)
            else:  # leading edge after a quiet spell, trailing edge within a burst
                delay = self.debounce_s if now - self._last_request < self.debounce_s else 0.0
            self._last_request = now
            if self._closed:
                raise RuntimeError(f"run slot {self.name!r} is closed")
            if self._ticket is not None:
                self._ticket.cancel(self.pool)
            self._count += 1
            ticket = _Ticket(self._count, job, now)
            self._ticket = ticket
            ticket.entry = self.pool.schedule(lambda: self._run(ticket), delay, on_drop=ticket.finished.set)
            return ticket.request

    def cancel(self) -> None:
        """Cancel the current request (nothing more of it is published)."""
        with self._lock:
            if self._ticket is not None:
                self._ticket.cancel(self.pool)

    def close(self) -> None:
        """Cancel and refuse further requests (call when the session ends)."""
        with self._lock:
            self.cancel()
            self._closed = True

    def wait(self, timeout: float | None = None) -> bool:
        """Block until the latest request has finished running (for tests and scripts)."""
        ticket = self._ticket
        return True if ticket is None else ticket.finished.wait(timeout)

    # -- worker side ----------------------------------------------------------------------------
    def _run(self, ticket: _Ticket) -> None:
        gen = None
        _current.pool, _current.cancelled = self.pool, ticket.cancelled
        try:
            if ticket.cancelled.is_set():
                return
            gen = iter(ticket.job())
            for stage in gen:
                if ticket.cancelled.is_set():
                    break
                self._publish(ticket, stage)
        except Exception as exc:
            if not ticket.cancelled.is_set():
                if not isinstance(exc, ValueError):
                    log.exception("run %s #%d failed", self.name, ticket.request)
                self._publish(ticket, Stage("error", None, None, readable_error(exc)))
        finally:
            close = getattr(gen, "close", None)
            if close is not None:
                try:
                    close()
                except Exception:  # pragma: no cover - a job's finally block failing
                    log.exception("closing run %s #%d failed", self.name, ticket.request)
            _current.pool = _current.cancelled = None
            ticket.finished.set()

    def _publish(self, ticket: _Ticket, stage: Stage) -> None:
        if ticket.cancelled.is_set():
            return
        now = time.perf_counter()
        if stage.kind == "progress":
            if now - ticket.last_progress < self.progress_interval_s:
                return
            ticket.last_progress = now
        if stage.kind not in KINDS:
            raise ValueError(f"a job yielded an unknown stage kind {stage.kind!r}")
        update = Update(ticket.request, stage.kind, stage.value, stage.fraction, stage.message, now - ticket.made, self.name)
        try:
            self._dispatch(lambda: self._deliver(ticket, update))
        except Exception:  # the session's document is gone: stop this slot
            log.debug("dispatch failed for run %s; closing the slot", self.name, exc_info=True)
            self.close()

    def _deliver(self, ticket: _Ticket, update: Update) -> None:
        with self._lock:
            if self._closed or ticket is not self._ticket or ticket.cancelled.is_set():
                self.dropped += 1
                return
            self._on_update(update)
