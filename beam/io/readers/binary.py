"""Binary records: NumPy ``.npy``/``.npz``, MATLAB ``.mat`` (v5 and v7.3), NI ``.tdms``.

Every reader is a maintained library: :func:`numpy.load` (no pickles), :func:`scipy.io.loadmat`
(MATLAB v4-v7.2), :mod:`h5py` (MATLAB v7.3 is HDF5; MATLAB stores arrays column-major, so a
MATLAB n x k matrix appears as k x n and is transposed back), :mod:`nptdms` (NI TDMS).

What the arrays mean:

* a 2-D numeric array is a table, one column per channel (an array with fewer rows than
  columns and at most 16 rows is read transposed: one channel per row); without names its
  columns are ``column 1`` ... (``NAME[1]`` ... for a named matrix) and the first is the time
  when it increases;
* named arrays (the variables of a ``.npz`` or ``.mat``, the fields of a MATLAB struct, the
  fields of a structured ``.npy``) are channels by name, their units read from the names
  (``acc_z_g``, ``t``); a scalar named ``fs``, ``rate``, ``sample_rate``, ``sampling_rate``
  or ``Fs`` (Hz) or ``dt`` (s) gives the sampling rate;
* a TDMS group is a block; its channels' ``unit_string`` property gives the units and
  ``wf_increment`` (s) / ``wf_start_offset`` (s) the time when no channel is named time.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from beam.errors import BeamInputError
from beam.io.readers.table import Block, RawRecord, find_time_column, looks_like_time, make_columns

#: Names of a scalar sampling rate (Hz), compared in lower case.
RATE_NAMES = ("fs", "rate", "sample_rate", "sampling_rate", "samplerate", "rate_hz", "fs_hz", "sample_rate_hz")
#: Names of a scalar sampling interval (s), compared in lower case.
STEP_NAMES = ("dt", "ts", "delta_t", "sample_interval", "dt_s")
#: Most rows a table may have to be read as one channel per row.
_MAX_CHANNEL_ROWS = 16


def _table_columns(array: np.ndarray, prefix: str = "column") -> tuple[list[str], list[np.ndarray]]:
    if array.ndim == 1:
        return [f"{prefix} 1" if prefix == "column" else prefix], [array]
    if array.ndim != 2:
        raise ValueError(f"a {array.ndim}-D array")
    if array.shape[0] < array.shape[1] and array.shape[0] <= _MAX_CHANNEL_ROWS:
        array = array.T
    if prefix == "column":
        names = [f"column {k}" for k in range(1, array.shape[1] + 1)]
    else:
        names = [f"{prefix}[{k}]" for k in range(1, array.shape[1] + 1)]
    return names, [array[:, k] for k in range(array.shape[1])]


def _block_from_named(path: Path, named: Mapping[str, np.ndarray], what: str) -> Block:
    """A block from named arrays (module notes)."""
    rate = None
    names: list[str] = []
    arrays: list[np.ndarray] = []
    for key, raw in named.items():
        array = np.asarray(raw)
        if array.dtype.kind not in "fiub" or array.dtype.kind == "b":
            continue
        if array.size == 1:
            value = float(array.reshape(-1)[0])
            if key.lower() in RATE_NAMES and math.isfinite(value) and value > 0:
                rate = value
            elif key.lower() in STEP_NAMES and math.isfinite(value) and value > 0:
                rate = 1.0 / value
            continue
        try:
            column_names, column_arrays = _table_columns(np.squeeze(array), key)
        except ValueError:
            continue
        names += column_names
        arrays += [np.asarray(a, dtype=float) for a in column_arrays]
    if not arrays:
        raise BeamInputError(f"{path}: no numeric arrays in the {what}; expected a numeric matrix (rows = samples) "
                             "or named arrays of one length (time and the sensor's signal)")
    lengths = {a.size for a in arrays}
    if len(lengths) > 1:
        longest = max(lengths)
        kept = [(n, a) for n, a in zip(names, arrays) if a.size == longest]
        names, arrays = [n for n, _ in kept], [a for _, a in kept]
    columns = make_columns(names, arrays)
    time = find_time_column(columns)
    unnamed = columns[0].name == "column 1" or columns[0].name.endswith("[1]")
    if time is None and len(columns) >= 2 and unnamed and looks_like_time(columns[0].values):
        time = columns[0]
    return Block(columns, time, rate)


def read_npy(path: Path) -> RawRecord:
    """A ``.npy`` array: a table, or a structured array of named fields."""
    try:
        array = np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError) as exc:
        raise BeamInputError(f"{path}: not a readable NumPy .npy array ({' '.join(str(exc).split())[:120]})") from None
    if array.dtype.names:
        block = _block_from_named(path, {name: array[name] for name in array.dtype.names}, "structured array")
    else:
        if array.dtype.kind not in "fiu":
            raise BeamInputError(f"{path}: a {array.dtype} array; expected numbers")
        try:
            names, arrays = _table_columns(array)
        except ValueError as exc:
            raise BeamInputError(f"{path}: {exc}; expected a 1-D signal or a 2-D table (rows = samples)") from None
        block = _block_from_named(path, dict(zip(names, arrays)), "array")
    return RawRecord(path, "NumPy .npy", [block])


def read_npz(path: Path) -> RawRecord:
    """A ``.npz`` archive: its arrays are channels by name (a rate scalar gives the time)."""
    try:
        with np.load(path, allow_pickle=False) as archive:
            named = {key: archive[key] for key in archive.files}
    except (ValueError, OSError, EOFError) as exc:
        raise BeamInputError(f"{path}: not a readable NumPy .npz archive ({' '.join(str(exc).split())[:120]})") from None
    return RawRecord(path, "NumPy .npz", [_block_from_named(path, named, ".npz archive")])


def _flatten_mat(value, prefix: str, out: dict[str, np.ndarray]) -> None:
    """Named numeric arrays of a loadmat value (structs become their fields)."""
    if isinstance(value, Mapping):
        for key, item in value.items():
            _flatten_mat(item, key if not prefix else key, out)
        return
    array = np.asarray(value)
    if array.dtype.kind in "fiu" and array.size:
        out[prefix] = array


def read_mat(path: Path) -> RawRecord:
    """A MATLAB ``.mat`` file: v5 (scipy.io) or v7.3 (h5py)."""
    import scipy.io

    try:
        content = scipy.io.loadmat(path, simplify_cells=True)
    except NotImplementedError:  # v7.3: HDF5
        return _read_mat73(path)
    except (ValueError, OSError, TypeError) as exc:
        raise BeamInputError(f"{path}: not a readable MATLAB .mat file ({' '.join(str(exc).split())[:120]})") from None
    named: dict[str, np.ndarray] = {}
    for key, value in content.items():
        if not key.startswith("__"):
            _flatten_mat(value, key, named)
    return RawRecord(path, "MATLAB .mat (v5)", [_block_from_named(path, named, "MATLAB file")])


def _read_mat73(path: Path) -> RawRecord:
    import h5py

    named: dict[str, np.ndarray] = {}

    def visit(name: str, item) -> None:
        if isinstance(item, h5py.Dataset) and not name.startswith("#refs#") and item.dtype.kind in "fiu":
            named[name.rsplit("/", 1)[-1]] = np.asarray(item[()]).T  # column-major: transpose back
    try:
        with h5py.File(path, "r") as handle:
            handle.visititems(visit)
    except OSError as exc:
        raise BeamInputError(f"{path}: not a readable MATLAB v7.3 file ({' '.join(str(exc).split())[:120]})") from None
    return RawRecord(path, "MATLAB .mat (v7.3, HDF5)", [_block_from_named(path, named, "MATLAB file")])


def read_tdms(path: Path) -> RawRecord:
    """An NI ``.tdms`` file: one block per group with data."""
    from nptdms import TdmsFile

    try:
        tdms = TdmsFile.read(path)
    except Exception as exc:  # npTDMS raises ValueError, KeyError, struct.error... on a bad file
        raise BeamInputError(f"{path}: not a readable NI TDMS file ({type(exc).__name__}: "
                             f"{' '.join(str(exc).split())[:120]})") from None
    blocks = []
    for group in tdms.groups():
        channels = [c for c in group.channels() if len(c) > 1 and np.asarray(c[:2]).dtype.kind in "fiu"]
        if not channels:
            continue
        names = [c.name for c in channels]
        units = [str(c.properties.get("unit_string") or c.properties.get("NI_UnitDescription") or "") or None
                 for c in channels]
        arrays = [np.asarray(c[:], dtype=float) for c in channels]
        longest = max(a.size for a in arrays)
        kept = [k for k, a in enumerate(arrays) if a.size == longest]
        columns = make_columns([names[k] for k in kept], [arrays[k] for k in kept], [units[k] for k in kept])
        time = find_time_column(columns)
        increment = channels[kept[-1]].properties.get("wf_increment")
        offset = channels[kept[-1]].properties.get("wf_start_offset", 0.0)
        rate = 1.0 / float(increment) if increment and float(increment) > 0 else None
        blocks.append(Block(columns, time, rate, float(offset or 0.0), label=f"group {group.name!r}"))
    if not blocks:
        raise BeamInputError(f"{path}: no group with numeric channels in the NI TDMS file; expected at least one channel of samples")
    return RawRecord(path, f"NI TDMS ({len(blocks)} group(s))", blocks)
