"""The calibration engine: the search for a model's MAP and the memory of the optima it found.

An :class:`Engine` runs the two stages of every driven MAP (the quick search from its start
strategies, :func:`beam.calibration.starts.starting_points`; then the searched design and the
walk along the ridge, :func:`beam.calibration.starts.searched_map`) and remembers each cold
search's MAP under its :class:`Memory` key: the record's content hash and the resolved spec's
model key (window, modes, likelihood, effects). A later calibration of that model recalls the
MAP (the same MAP, to the last digit) and a larger model starts from it (nested starts).

One engine per process is the default (:func:`default_engine`); a caller may pass its own. Its
memory can be exported (:meth:`Engine.export`, picklable) and merged into another process's
engine (:meth:`Engine.merge`): what that process would have found itself.

Contract: a remembered MAP is one found from the cold starts only (never a warm start's or a
caller's extra guesses'); a first-stage MAP (a screening fit's) is kept apart from the model's MAP.
"""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict
from collections.abc import Iterable, Sequence
from typing import NamedTuple

import numpy as np

from beam.calibration.fit import fast_map
from beam.calibration.free import StartMemo, free_start_indices
from beam.calibration.setup import BeamCalibrationSetup, build_problem
from beam.calibration.spec import CalibrationSpec
from beam.inference import MapResult, Problem

__all__ = ["FIRST_STAGE", "MAP", "Engine", "Memory", "default_engine", "forget_maps", "record_digest"]

#: Kinds of remembered optima: a model's MAP (both stages) and a first stage's MAP.
MAP = "map"
FIRST_STAGE = "first stage"


class Memory(NamedTuple):
    """One remembered optimum: ``key`` = (record digest, window, modes, likelihood, effects),
    ``kind`` (:data:`MAP` or :data:`FIRST_STAGE`) and the :class:`~beam.inference.MapResult`."""

    key: tuple
    kind: str
    found: MapResult


def record_digest(measurement) -> str:
    """Content hash of what a record's optima depend on: its time stamps, output and input samples,
    the samples left out of the likelihood, their kinds, the geometry and the nominal values with
    their spreads."""
    digest = hashlib.blake2b(np.ascontiguousarray(measurement.time_s, dtype=float).tobytes(), digest_size=16)
    digest.update(np.ascontiguousarray(measurement.output, dtype=float).tobytes())
    if measurement.input is not None:
        digest.update(np.ascontiguousarray(measurement.input, dtype=float).tobytes())
    digest.update(np.packbits(measurement.left_out).tobytes())  # the samples the likelihood leaves out
    digest.update(repr((measurement.output_kind, measurement.input_kind, measurement.geometry,
                        sorted(measurement.nominal.items()),
                        sorted(measurement.nominal_spread.items()))).encode())
    return digest.hexdigest()


class Engine:
    """The MAP search of beam calibrations and the memory of the optima found (thread-safe).

    Parameters
    ----------
    strategies : sequence of StartStrategy, optional
        The start strategies of the first stage (and, ``stage == "search"``, of the second), in
        the order their starts are tried; default
        :data:`beam.calibration.starts.DEFAULT_STRATEGIES`.
    capacity : int
        Optima kept per kind (least recently used dropped first).
    """

    def __init__(self, strategies: Sequence | None = None, capacity: int = 256) -> None:
        from beam.calibration.starts import DEFAULT_STRATEGIES

        self.strategies = tuple(DEFAULT_STRATEGIES if strategies is None else strategies)
        self.capacity = int(capacity)
        self._memory: dict[str, OrderedDict[tuple, MapResult]] = {MAP: OrderedDict(), FIRST_STAGE: OrderedDict()}
        self._lock = threading.Lock()
        self._digests: dict[int, tuple[object, str]] = {}
        self._starts = StartMemo()

    def __repr__(self) -> str:
        return f"Engine({len(self)} optima, strategies={[s.name for s in self.strategies]})"

    def __bool__(self) -> bool:  # an engine with an empty memory is still an engine
        return True

    def __len__(self) -> int:
        with self._lock:
            return sum(len(m) for m in self._memory.values())

    # -- keys ------------------------------------------------------------------------------------
    def _digest(self, measurement) -> str:
        cached = self._digests.get(id(measurement))
        if cached is not None and cached[0] is measurement:
            return cached[1]
        digest = record_digest(measurement)
        with self._lock:
            self._digests[id(measurement)] = (measurement, digest)
            while len(self._digests) > 16:
                self._digests.pop(next(iter(self._digests)))
        return digest

    def key(self, setup: BeamCalibrationSetup, effects: Iterable[str] | None = None) -> tuple:
        """The memory key of ``setup``'s model (or of the model with ``effects`` on its record,
        window, modes and likelihood): the record digest, then the spec's model key."""
        spec = CalibrationSpec.of_setup(setup)
        spec = spec if effects is None else spec.with_effects(effects)
        return (self._digest(setup.measurement), *spec.model_key())

    # -- memory ----------------------------------------------------------------------------------
    def remember(self, setup: BeamCalibrationSetup, found: MapResult, kind: str = MAP) -> None:
        """Keep ``found`` as the ``kind`` optimum of ``setup``'s model (a cold search's only)."""
        self._put(self.key(setup), kind, found)

    def _put(self, key: tuple, kind: str, found: MapResult) -> None:
        with self._lock:
            memory = self._memory[kind]
            memory[key] = found
            memory.move_to_end(key)
            while len(memory) > self.capacity:
                memory.popitem(last=False)

    def recall(self, setup: BeamCalibrationSetup, kind: str = MAP, effects: Iterable[str] | None = None) -> MapResult | None:
        """The remembered ``kind`` optimum of ``setup``'s model (or of ``effects``), or None."""
        key = self.key(setup, effects)
        with self._lock:
            memory = self._memory[kind]
            found = memory.get(key)
            if found is not None:
                memory.move_to_end(key)
            return found

    def submodels(self, setup: BeamCalibrationSetup) -> list[tuple[tuple[str, ...], MapResult]]:
        """``(effects, MAP)`` of every remembered model nested in ``setup``'s (a strict subset of
        its effects on the same record, window, modes and likelihood)."""
        key = self.key(setup)
        context, effects = key[:-1], set(key[-1])
        with self._lock:
            return [(k[-1], found) for k, found in self._memory[MAP].items()
                    if k[:-1] == context and set(k[-1]) < effects]

    def forget(self) -> None:
        """Drop every remembered optimum (and the free responses' starts)."""
        with self._lock:
            for memory in self._memory.values():
                memory.clear()
        self._starts.clear()

    def free_start_indices(self, measurement, modes: int) -> tuple[int, int]:
        """(release, first sample of the free response) of a free record fitted with ``modes``
        modes (:func:`beam.calibration.free.free_start_indices`), remembered for the engine's
        last few records (every model of a record in a diagnosis asks the same question)."""
        return free_start_indices(measurement, modes, self._starts)

    def export(self) -> tuple[Memory, ...]:
        """Every remembered optimum (picklable: send it to another process's :meth:`merge`)."""
        with self._lock:
            return tuple(Memory(key, kind, found) for kind, memory in self._memory.items()
                         for key, found in memory.items())

    def merge(self, memory: Iterable[Memory]) -> None:
        """Keep the optima of another engine's :meth:`export` (or of :meth:`memory_of`)."""
        for key, kind, found in memory:
            self._put(tuple(key), kind, found)

    def memory_of(self, result) -> Memory:
        """The :class:`Memory` entry of a cold-started :class:`~beam.calibration.CalibrationResult`:
        its MAP, or for a screening fit (``result.screened``) its first stage's."""
        return Memory(self.key(result.setup), FIRST_STAGE if result.screened else MAP, result.laplace.map)

    # -- search ----------------------------------------------------------------------------------
    def starting_points(self, problem: Problem, setup: BeamCalibrationSetup, warm=None,
                        search: bool = True) -> list[dict[str, float]]:
        """The starts of a driven model (:func:`beam.calibration.starts.starting_points`)."""
        from beam.calibration.starts import starting_points

        return starting_points(problem, setup, warm, search, engine=self)

    def searched_map(self, problem: Problem, setup: BeamCalibrationSetup, quick: MapResult) -> MapResult | None:
        """The second stage from ``quick`` (:func:`beam.calibration.starts.searched_map`): a better
        MAP, or None (``quick`` stands, to the last digit)."""
        from beam.calibration.starts import searched_map

        return searched_map(problem, setup, quick, strategies=self.second_stage_strategies(), engine=self)

    def second_stage_strategies(self) -> tuple:
        """The strategies of the second stage (``stage == "search"``)."""
        return tuple(s for s in self.strategies if s.stage == "search")

    def submodel_map(self, setup: BeamCalibrationSetup, effects: tuple[str, ...]) -> dict[str, float]:
        """Physical parameters (natural units) of the MAP of the model with ``effects`` on
        ``setup``'s record, window, modes and likelihood: remembered, or found by the same two
        stages as every calibration (recursively nested) and remembered."""
        cached = self.recall(setup, effects=effects)
        if cached is not None:
            return {name: float(v) for name, v in cached.values.items()}  # extra (noise) names: ignored by callers
        from beam.calibration.starts import model_setup

        sub = model_setup(setup, tuple(effects), setup.modes)
        problem = build_problem(sub)
        quick = fast_map(problem, self.starting_points(problem, sub, search=False))
        best = self.searched_map(problem, sub, quick) or quick
        self.remember(sub, best)
        return {name: float(best.values[name]) for name in sub.physical_names}


_DEFAULT: Engine | None = None
_DEFAULT_LOCK = threading.Lock()


def default_engine() -> Engine:
    """The process's engine (created on first use): what every calibration uses unless given one."""
    global _DEFAULT
    with _DEFAULT_LOCK:
        if _DEFAULT is None:
            _DEFAULT = Engine()
        return _DEFAULT


def forget_maps(engine: Engine | None = None) -> None:
    """Drop every optimum ``engine`` (default: the process's) remembers (benchmarks that time a
    cold calibration; tests)."""
    (default_engine() if engine is None else engine).forget()
