"""The forward model of a driven record: the beam from rest, driven by the record's input."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from beam.errors import BeamInputError
from beam.io.measurement import Measurement
from beam.physics.model import BeamModel

__all__ = ["BeamForwardModel"]


@dataclass
class BeamForwardModel:
    """Vectorised forward model of a driven record for :class:`beam.inference.Problem`.

    The beam starts at rest at the first sample of the record and is driven by the record's
    input (voltage or point force); ``model(values, time_s)`` returns the sensor's output
    (displacement m, velocity m/s or acceleration m/s², as the record) at the requested
    samples, which must be samples of the record. A uniform record is stepped by
    :meth:`BeamModel.response`, an irregular one by :meth:`BeamModel.response_at` (exactly at
    the recorded stamps). Free responses have :class:`beam.calibration.free.ProjectedFreeModel`.
    """

    model: BeamModel
    measurement: Measurement
    modes: int

    def __post_init__(self) -> None:
        if self.measurement.input is None:
            raise BeamInputError("a free response has no input to drive the model: use ProjectedFreeModel")
        self._names = self.model.parameter_names_for(self.modes)
        self._index_cache: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    def sample_indices(self, time_s: np.ndarray) -> np.ndarray | slice:
        """Record indices of the times ``time_s`` (cached per array object): a slice when they
        are consecutive samples (a window, the whole record), else an index array."""
        cached = self._index_cache.get(id(time_s))
        if cached is not None and cached[0] is time_s:
            return cached[1]
        record = self.measurement.time_s
        times = np.asarray(time_s, dtype=float)
        if self.measurement.uniform:
            t0, dt = record[0], self.measurement.sample_interval_s
            index = np.rint((times - t0) / dt).astype(int)
        else:
            index = np.clip(np.searchsorted(record, times), 0, record.size - 1)
            below = np.clip(index - 1, 0, record.size - 1)
            index = np.where(np.abs(record[below] - times) < np.abs(record[index] - times), below, index)
            step = self.measurement.min_interval_s
            if index.size and np.max(np.abs(record[index] - times)) > 1e-6 * step:
                raise BeamInputError("prediction times must be time stamps of the record")
        if index.size and (index.min() < 0 or index.max() >= record.size):
            raise BeamInputError("prediction times must lie within the record")
        if index.size and np.array_equal(index, np.arange(index[0], index[0] + index.size)):
            index = slice(int(index[0]), int(index[0]) + index.size)
        self._index_cache[id(time_s)] = (time_s, index)
        return index

    def __call__(self, values: Mapping[str, np.ndarray], time_s: np.ndarray) -> np.ndarray:
        index = self.sample_indices(time_s)
        if isinstance(index, slice):
            needed = index.stop
        else:
            needed = int(index.max()) + 1 if index.size else 1
        needed = max(needed, 2)
        parameters = {name: values[name] for name in self._names}
        record = self.measurement
        if record.uniform:
            response = self.model.response(parameters, record.input[:needed], record.sample_interval_s, self.modes,
                                           output=record.output_kind)
        else:
            response = self.model.response_at(parameters, record.input[:needed], record.time_s[:needed], self.modes,
                                              output=record.output_kind)
        response = np.atleast_2d(response)
        if isinstance(index, slice) and index.start == 0 and index.stop == response.shape[1]:
            return response  # the whole computed response: no copy
        return response[:, index]
