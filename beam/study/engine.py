"""Dask distributed as the study's engine: a local cluster or an existing one, cells as tasks.

:func:`open_client` connects to the scheduler at an address (``--scheduler`` or
``DASK_SCHEDULER_ADDRESS``) or starts a :class:`distributed.LocalCluster` of worker processes
with one thread each and single-threaded numba/BLAS (:data:`SINGLE_THREAD_ENV`, set by the
nanny before the worker starts). :func:`stream_cells` scatters each record once, submits one
task per cell (longest expected first, as many at a time as the workers have threads) and yields
the results as they finish (:func:`distributed.as_completed`); a task
that fails outside the calibration (a worker lost) is turned into an error row, never raised.
"""

from __future__ import annotations

import logging
import os
import time
import uuid
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import contextmanager

from beam.errors import BeamInputError
from beam.io.measurement import Measurement
from beam.study.cells import StudyCell, code_version, error_row, run_cell
from beam.study.schedule import expected_cost, submission_order

__all__ = ["SCHEDULER_ENV", "SINGLE_THREAD_ENV", "connect", "disconnect", "open_client", "scheduler_address",
           "stream_cells"]

#: Environment variable naming an existing scheduler (Dask's own convention).
SCHEDULER_ENV = "DASK_SCHEDULER_ADDRESS"
#: Environment of the local workers: one thread for numba and every BLAS (one cell per core).
SINGLE_THREAD_ENV = {"NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
                     "MKL_NUM_THREADS": "1"}


def scheduler_address(given: str | None) -> str | None:
    """The scheduler to use: ``given``, else :data:`SCHEDULER_ENV`, else None (a local cluster)."""
    address = given if given else os.environ.get(SCHEDULER_ENV, "").strip()
    return address or None


def _import_engine() -> str:
    """Import the calibration engine and ArviZ in a worker (before its first cell, not during it);
    returns the worker's :func:`~beam.study.cells.code_version`."""
    from beam.calibration import calibrate  # noqa: F401
    from beam.inference import import_arviz

    import_arviz()
    return code_version()


def connect(address: str | None = None, workers: int | None = None, warm: Callable[[], None] | None = None,
            timeout_s: float = 60.0):
    """A :class:`distributed.Client` on the scheduler at ``address``, or on a new local cluster,
    ready for cells; the caller closes it (and ``client.cluster``, a local one) with :func:`disconnect`.

    Parameters
    ----------
    address : str, optional
        ``tcp://HOST:PORT`` of a running scheduler; None for a local cluster.
    workers : int, optional
        Local worker processes (default the machine's cores); not allowed with ``address``.
    warm : callable, optional
        Called once in this process before a local cluster's workers start (so that they find
        the compiled kernels on disk instead of compiling them each, at the same time).
    timeout_s : float
        How long to wait for the scheduler, and for its first worker (s).

    Returns
    -------
    distributed.Client
        With the engine imported on every worker present.

    Raises
    ------
    BeamInputError
        ``workers`` with an address; a scheduler that cannot be reached or has no worker within
        ``timeout_s``; a worker whose ``beam`` sources differ from this process's (its cells would
        be stored under this code's version).
    """
    from distributed import Client, LocalCluster

    cluster = None
    if address is not None:
        if workers is not None:
            raise BeamInputError("--workers sizes a local cluster; with a scheduler the cluster has its own workers")
        try:
            client = Client(address, timeout=timeout_s)
        except (OSError, TimeoutError) as exc:
            raise BeamInputError(f"cannot reach the Dask scheduler at {address}: {' '.join(str(exc).split())}") from None
    else:
        if warm is not None:
            warm()
        cluster = LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1, processes=True,
                               env=SINGLE_THREAD_ENV, dashboard_address=None, silence_logs=logging.ERROR)
        client = Client(cluster)
    try:
        try:
            client.wait_for_workers(1, timeout=timeout_s)
        except TimeoutError:
            raise BeamInputError(f"no Dask worker joined the scheduler at {address} within {timeout_s:g} s") from None
        other = {w: v for w, v in client.run(_import_engine).items() if v != code_version()}
        if other:
            raise BeamInputError(f"the Dask worker {next(iter(other))} runs another version of beam than this "
                                 "command (install the same code on the cluster)")
    except BaseException:
        disconnect(client)
        raise
    return client


def disconnect(client) -> None:
    """Close a client of :func:`connect` and the local cluster it started, if any (never raises)."""
    cluster = getattr(client, "cluster", None)
    for closable in (client, cluster):
        if closable is not None:
            try:
                closable.close()
            except Exception:  # noqa: BLE001 - closing a cluster that is already gone
                logging.getLogger(__name__).debug("closing %r failed", closable, exc_info=True)


@contextmanager
def open_client(address: str | None = None, workers: int | None = None,
                warm: Callable[[], None] | None = None, timeout_s: float = 60.0):
    """:func:`connect` as a context manager: yields the client, closes it (and its local cluster) at exit."""
    client = connect(address, workers, warm, timeout_s)
    try:
        yield client
    finally:
        disconnect(client)


def stream_cells(client, records: Mapping[str, Measurement], cells: Iterable[StudyCell], *,
                 stop: Callable[[], bool] | None = None, poll_s: float = 0.2,
                 costs: Mapping[StudyCell, float] | None = None) -> Iterator[tuple[StudyCell, dict]]:
    """Run ``cells`` on ``client``'s workers; yield ``(cell, outcome)`` as each finishes.

    ``records`` maps a cell's ``record_hash`` to its record; each record is sent to the cluster
    once. Cells are submitted longest expected first (:mod:`beam.study.schedule`), no more at a
    time than the workers have threads, the next one as each finishes: the first free worker takes
    the longest cell left, and the short ones fill the workers at the end. ``costs``
    gives a cell's expected cost (any positive scale), default
    :func:`beam.study.schedule.expected_cost`. ``outcome`` is :func:`beam.study.cells.run_cell`'s
    dict, with ``task["submitted"]`` and ``task["received"]`` (epoch s, this process's clock) added.

    ``stop``, if given, is asked every ``poll_s`` seconds (s) while no result is ready: once it
    returns True the cells not finished are cancelled (a cell already running on a worker runs to
    its end there; its result is dropped) and the iteration ends. Closing the iterator early
    cancels them too.
    """
    from distributed import as_completed

    cells = list(cells)
    if not cells:
        return
    needed = {cell.record_hash for cell in cells}
    scattered = {key: client.scatter(records[key], hash=False) for key in needed}
    run = uuid.uuid4().hex[:8]
    if costs is None:
        costs = {cell: expected_cost(cell, records[cell.record_hash]) for cell in cells}
    queue = deque(submission_order({cell: costs[cell] for cell in cells}))
    futures = {}
    pending = as_completed()

    def top_up() -> None:
        # as many cells in flight as the workers have threads: each is taken by the first free worker,
        # never queued on a busy one behind a long cell (Dask places a task by its data and its guesses)
        slots = max(1, sum(client.nthreads().values()))
        while queue and len(futures) < slots:
            cell = queue.popleft()
            future = client.submit(run_cell, scattered[cell.record_hash], cell, key=f"beam-study-{run}-{len(queue)}",
                                   pure=False, priority=float(costs[cell]))
            futures[future.key] = (cell, future, time.time())
            pending.add(future)

    top_up()
    try:
        while not pending.is_empty():
            if stop is None:
                batch = [next(pending)]
            else:
                batch = pending.next_batch(block=False)
                if not batch:
                    if stop():
                        return
                    time.sleep(poll_s)
                    top_up()  # a worker that joined meanwhile takes a cell now
                    continue
            for future in batch:
                cell, _, submitted = futures.pop(future.key)
                try:
                    outcome = future.result()
                except Exception as exc:  # noqa: BLE001 - a lost worker: that cell fails, the others go on
                    outcome = {"row": error_row(cell, f"{type(exc).__name__}: {' '.join(str(exc).split())[:300]}"),
                               "extra": {}, "draws": {}, "task": {}}
                future.release()
                outcome["task"].update(submitted=submitted, received=time.time())
                top_up()
                yield cell, outcome
    finally:
        if futures:  # stopped or closed early: what has not finished is not wanted
            left = [f for _, f, _ in futures.values()]
            try:
                client.cancel(left)
            except Exception:  # noqa: BLE001 - the client is closing
                pass
            for _, f, _ in futures.values():
                f.release()
            futures.clear()
        for future in scattered.values():
            future.release()
