"""A window study: every (record, window, effect set, likelihood) cell calibrated, stored and tabled.

:func:`study_cells` lays the cells out; :func:`run_study` reuses the stored ones
(:class:`beam.study.store.CellStore`), runs the others on Dask (:mod:`beam.study.engine`) as
they finish (longest expected first, :mod:`beam.study.schedule`, corrected by the seconds the
stored cells took), stores each at once (an interrupted study resumes), and writes the tables.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from beam.errors import BeamInputError
from beam.calibration.spec import CalibrationSpec
from beam.io.measurement import Measurement
from beam.physics.effects import parse_effects
from beam.study.cells import StudyCell, code_version, record_fingerprint
from beam.study.engine import open_client, scheduler_address, stream_cells
from beam.study.schedule import expected_cost, rescaled_costs
from beam.study.store import CellStore, write_tables
from beam.study.windows import default_windows

__all__ = ["StudyResult", "parse_effect_sets", "run_study", "study_cells", "warm_kernels"]

LIKELIHOODS = ("iid", "ar1")


def parse_effect_sets(text: str) -> tuple[tuple[str, ...], ...]:
    """Effect sets separated by ``;``, each as ``beam calibrate --effects`` takes it (``''``: the bare
    model); without repeats, in the order given."""
    sets = [parse_effects(part) for part in text.split(";")]
    return tuple(dict.fromkeys(sets))


def parse_likelihoods(text: str) -> tuple[str, ...]:
    """``iid``, ``ar1`` or both, comma-separated."""
    items = tuple(dict.fromkeys(part.strip().lower() for part in text.split(",") if part.strip()))
    bad = [item for item in items if item not in LIKELIHOODS]
    if bad or not items:
        raise BeamInputError(f"unknown likelihood {bad[0] if bad else text!r}; expected iid, ar1 or iid,ar1")
    return items


@dataclass
class StudyResult:
    """The outcome of :func:`run_study`.

    Attributes
    ----------
    entries : list of dict
        One per cell in study order: ``cell``, ``index`` (window position within its record),
        ``key``, ``row`` (the ``--json`` cell), ``extra``, ``draws``, ``task``, ``reused``,
        ``computed_utc``.
    written : list of Path
        The table files.
    computed, reused : int
        Cells calibrated now / taken from the output folder.
    """

    entries: list[dict]
    written: list[Path]
    computed: int
    reused: int

    @property
    def rows(self) -> list[dict]:
        """The ``--json`` cells."""
        return [e["row"] for e in self.entries]


def study_cells(records: Sequence[tuple[str, Measurement]], windows: Sequence[tuple[float, float]] | None,
                effect_sets: Sequence[tuple[str, ...]], likelihoods: Sequence[str], *, modes: int | str = "auto",
                seed: int = 0, steps: int | None = None, walkers: int | None = None) -> list[tuple[int, StudyCell]]:
    """The cells, record by record, then window, effect set, likelihood; with each cell's window
    position. ``windows`` None: each record's :func:`~beam.study.windows.default_windows`."""
    out, seen = [], set()
    for name, record in records:
        fingerprint = record_fingerprint(record)
        if (name, fingerprint) in seen:  # the same record given twice
            continue
        seen.add((name, fingerprint))
        chosen = windows if windows is not None else default_windows(float(record.time_s[0]), float(record.time_s[-1]))
        for index, window in enumerate(chosen):
            for effects in effect_sets:
                for likelihood in likelihoods:
                    spec = CalibrationSpec(window=tuple(window), effects=tuple(effects), likelihood=likelihood,
                                           modes=modes, seed=seed, steps=steps, walkers=walkers)
                    out.append((index, StudyCell(name, fingerprint, spec)))
    return out


def warm_kernels(record: Measurement, cells: Iterable[StudyCell]) -> None:
    """Compile (or load) the numba kernels the cells need, in this process: one short calibration
    (2 modes, 10 steps, the first tenth of the record) per effect set and likelihood. The kernels
    are cached on disk, so workers started afterwards load them instead of compiling them. Never
    raises: a calibration that fails here fails in its cells, which report it."""
    from beam.calibration import calibrate

    start, end = float(record.time_s[0]), float(record.time_s[-1])
    for effects, likelihood in dict.fromkeys((c.effects, c.likelihood) for c in cells):
        try:
            calibrate(record, window=(start, start + 0.1 * (end - start)), effects=effects, modes=2,
                      likelihood=likelihood, steps=10)
        except Exception:  # noqa: BLE001 - best effort: the cells that meet the same error report it
            pass


def _costs(by_hash: dict[str, Measurement], todo: Sequence[StudyCell], stored: Sequence[dict]) -> dict[StudyCell, float]:
    """Expected cost of each cell to run, rescaled by the seconds the ``stored`` entries took."""
    costs = {cell: expected_cost(cell, by_hash[cell.record_hash]) for cell in todo}
    recorded = [(e["cell"], expected_cost(e["cell"], by_hash[e["cell"].record_hash]), e["row"].get("seconds"))
                for e in stored if e["cell"].record_hash in by_hash]
    return rescaled_costs(costs, recorded)


def run_study(records: Sequence[tuple[str, Measurement]], cells: Sequence[tuple[int, StudyCell]], *,
              out: str | Path, scheduler: str | None = None, workers: int | None = None,
              on_cell: Callable[[dict, int, int], None] | None = None) -> StudyResult:
    """Run a study (cells from :func:`study_cells`) and write its tables under ``out``.

    Parameters
    ----------
    records : sequence of (name, Measurement)
        The records the cells name.
    cells : sequence of (window position, StudyCell)
        The cells, in the order of the tables.
    out : str or Path
        Output prefix (:mod:`beam.study.store`); stored cells with the same key are reused.
    scheduler : str, optional
        Address of a running Dask scheduler (else ``DASK_SCHEDULER_ADDRESS``, else a local cluster).
    workers : int, optional
        Worker processes of the local cluster (default: the machine's cores).
    on_cell : callable, optional
        ``on_cell(entry, done, total)`` after each cell (reused ones first), in this process.
    """
    version = code_version()
    store = CellStore(out, version)
    by_hash = {record_fingerprint(m): m for _, m in records}
    entries: list[dict | None] = [None] * len(cells)
    todo = []
    done = 0
    for position, (index, cell) in enumerate(cells):
        stored = store.load(cell)
        if stored is None:
            todo.append(position)
            continue
        entries[position] = {"cell": cell, "index": index, "key": store.key(cell), "reused": True, **stored}
    reused = len(cells) - len(todo)
    for entry in entries:
        if entry is not None:
            done += 1
            if on_cell is not None:
                on_cell(entry, done, len(cells))
    if todo:
        pending = {cells[p][1]: p for p in todo}  # a cell appears once (windows, sets and likelihoods have no repeats)
        first = by_hash[cells[todo[0]][1].record_hash]
        address = scheduler_address(scheduler)
        costs = _costs(by_hash, [cells[p][1] for p in todo], [e for e in entries if e is not None])
        with open_client(address, workers, warm=lambda: warm_kernels(first, (cells[p][1] for p in todo))) as client:
            for cell, outcome in stream_cells(client, by_hash, (cells[p][1] for p in todo), costs=costs):
                stamp = store.save(cell, outcome)
                position = pending[cell]
                entry = {"cell": cell, "index": cells[position][0], "key": store.key(cell), "reused": False,
                         "computed_utc": stamp, **outcome}
                entries[position] = entry
                done += 1
                if on_cell is not None:
                    on_cell(entry, done, len(cells))
    written = write_tables(out, entries)
    return StudyResult(entries=entries, written=written, computed=len(todo), reused=reused)
