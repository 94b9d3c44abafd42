"""Binary records: NumPy ``.npy``/``.npz``, MATLAB ``.mat`` (v5 and v7.3), HDF5, NI ``.tdms``.

Every reader is a maintained library: :func:`numpy.load` (no pickles), :func:`scipy.io.loadmat`
(MATLAB v4-v7.2), :mod:`h5py` (MATLAB v7.3 is HDF5; MATLAB stores arrays column-major, so a
MATLAB n x k matrix appears as k x n and is transposed back; any other HDF5 file is read as
NumPy wrote it), :mod:`nptdms` (NI TDMS).

What the arrays mean:

* a 2-D numeric array is a table, one column per channel (an array with fewer rows than
  columns and at most 16 rows is read transposed: one channel per row); without names its
  columns are ``column 1`` ... (``NAME[1]`` ... for a named matrix) and the first is the time
  when it increases;
* named arrays (the variables of a ``.npz`` or ``.mat``, the fields of a MATLAB struct, the
  fields of a structured ``.npy``) are channels by name, their units read from the names
  (``acc_z_g``, ``t``); a scalar named ``fs``, ``rate``, ``sample_rate``, ``sampling_rate``
  or ``Fs`` (Hz) or ``dt`` (s) gives the sampling rate (of its struct, or of every struct
  when it is a variable of the file);
* a file holding several records lists them as blocks of kind ``"record"`` (chosen by name:
  ``record=``, ``--record``): each MATLAB struct (v5) or HDF5 group (v7.3) with arrays of its
  own, each ``GROUP/`` of a ``.npz``, and, within one, the arrays of each length (a record's
  channels have one length); arrays of fewer than :data:`MIN_RECORD_SAMPLES` values are left
  out and said;
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
#: Fewest samples an array needs to be (part of) a record; shorter ones (coefficients, a
#: calibration's few values) are left out and said.
MIN_RECORD_SAMPLES = 16


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


def _rate_of(named: Mapping[str, np.ndarray]) -> float | None:
    """The sampling rate (Hz) a scalar among ``named`` states (module notes), None if none."""
    rate = None
    for key, raw in named.items():
        array = np.asarray(raw)
        if array.dtype.kind not in "fiu" or array.size != 1:
            continue
        value = float(array.reshape(-1)[0])
        if key.lower() in RATE_NAMES and math.isfinite(value) and value > 0:
            rate = value
        elif key.lower() in STEP_NAMES and math.isfinite(value) and value > 0:
            rate = 1.0 / value
    return rate


def _columns_of(named: Mapping[str, np.ndarray]) -> tuple[list[str], list[np.ndarray]]:
    """The named arrays (scalars left out) as columns: a matrix gives one column per channel."""
    names: list[str] = []
    arrays: list[np.ndarray] = []
    for key, raw in named.items():
        array = np.asarray(raw)
        if array.dtype.kind not in "fiu" or array.size <= 1:
            continue
        try:
            column_names, column_arrays = _table_columns(np.squeeze(array), key)
        except ValueError:
            continue
        names += column_names
        arrays += [np.asarray(a, dtype=float) for a in column_arrays]
    return names, arrays


def _block(names: list[str], arrays: list[np.ndarray], rate: float | None, label: str = "", kind: str = "segment") -> Block:
    columns = make_columns(names, arrays)
    time = find_time_column(columns)
    unnamed = columns[0].name == "column 1" or columns[0].name.endswith("[1]")
    if time is None and len(columns) >= 2 and unnamed and looks_like_time(columns[0].values):
        time = columns[0]
    return Block(columns, time, rate, label=label, kind=kind)


def _blocks_from_groups(path: Path, groups: Mapping[str, Mapping[str, np.ndarray]], what: str,
                        notes: list[str]) -> list[Block]:
    """The records of a file: one per group of named arrays (a MATLAB struct, an HDF5 group; ``""``
    for the file's own variables) and, within a group, one per length of its arrays (module
    notes). One record is a plain block; several are blocks of kind ``"record"``, labelled by
    their group (and arrays). Arrays shorter than :data:`MIN_RECORD_SAMPLES` are left out (said
    in ``notes``)."""
    shared_rate = _rate_of(groups.get("", {}))
    found: list[tuple[str, list[str], list[np.ndarray], float | None]] = []
    short: list[str] = []
    for group, named in groups.items():
        names, arrays = _columns_of(named)
        rate = _rate_of(named) or shared_rate
        lengths = list(dict.fromkeys(a.size for a in arrays))  # in the file's order
        for length in lengths:
            kept = [(n, a) for n, a in zip(names, arrays) if a.size == length]
            if length < MIN_RECORD_SAMPLES:
                short += [f"{n} ({length} values)" for n, _ in kept]
                continue
            label = group if len(lengths) == 1 or not group else f"{group}: {', '.join(n for n, _ in kept)}"
            if not label:
                label = ", ".join(n for n, _ in kept) if len(lengths) > 1 else "the file's variables"
            found.append((label, [n for n, _ in kept], [a for _, a in kept], rate))
    if short:
        notes.append(f"left out, too short to be a record: {', '.join(short)}")
    if not found:
        raise BeamInputError(f"{path}: no numeric arrays in the {what}; expected a numeric matrix (rows = samples) "
                             "or named arrays of one length (time and the sensor's signal)")
    if len(found) == 1:
        label, names, arrays, rate = found[0]
        return [_block(names, arrays, rate, label="" if label == "the file's variables" else label)]
    return [_block(names, arrays, rate, label=label, kind="record") for label, names, arrays, rate in found]


def _block_from_named(path: Path, named: Mapping[str, np.ndarray], what: str) -> Block:
    """One block from named arrays (a ``.npy`` table or structured array): its longest arrays."""
    blocks = _blocks_from_groups(path, {"": named}, what, [])
    return max(blocks, key=lambda b: b.columns[0].values.size)


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
    """A ``.npz`` archive: its arrays are channels by name (a rate scalar gives the time); names
    ``GROUP/NAME`` group them into records, and so do arrays of different lengths."""
    try:
        with np.load(path, allow_pickle=False) as archive:
            named = {key: archive[key] for key in archive.files}
    except (ValueError, OSError, EOFError) as exc:
        raise BeamInputError(f"{path}: not a readable NumPy .npz archive ({' '.join(str(exc).split())[:120]})") from None
    groups: dict[str, dict[str, np.ndarray]] = {}
    for key, array in named.items():
        group, _, name = key.rpartition("/")
        groups.setdefault(group, {})[name] = array
    notes: list[str] = []
    return RawRecord(path, "NumPy .npz", _blocks_from_groups(path, groups, ".npz archive", notes), notes)


def _flatten_mat(value, group: str, name: str, out: dict[str, dict[str, np.ndarray]]) -> None:
    """Named numeric arrays of a loadmat value, grouped by the struct holding them (``""`` for
    the file's variables; nested structs ``a.b``; the elements of a struct array ``a(1)``, ``a(2)``)."""
    if isinstance(value, Mapping):
        inner = f"{group}.{name}" if group else name
        for key, item in value.items():
            _flatten_mat(item, inner, key, out)
        return
    if isinstance(value, (list, tuple)) and value and all(isinstance(v, Mapping) for v in value):
        for k, item in enumerate(value, start=1):
            _flatten_mat(item, group, f"{name}({k})", out)
        return
    array = np.asarray(value)
    if array.dtype.kind in "fiu" and array.size:
        out.setdefault(group, {})[name] = array


def read_mat(path: Path) -> RawRecord:
    """A MATLAB ``.mat`` file: v5 (scipy.io) or v7.3 (h5py)."""
    import scipy.io

    try:
        content = scipy.io.loadmat(path, simplify_cells=True)
    except NotImplementedError:  # v7.3: HDF5
        return _read_mat73(path)
    except (ValueError, OSError, TypeError) as exc:
        raise BeamInputError(f"{path}: not a readable MATLAB .mat file ({' '.join(str(exc).split())[:120]})") from None
    groups: dict[str, dict[str, np.ndarray]] = {}
    for key, value in content.items():
        if not key.startswith("__"):
            _flatten_mat(value, "", key, groups)
    notes: list[str] = []
    return RawRecord(path, "MATLAB .mat (v5)", _blocks_from_groups(path, groups, "MATLAB file", notes), notes)


def _read_mat73(path: Path) -> RawRecord:
    """MATLAB v7.3 (HDF5): a struct is a group; text (``MATLAB_class`` char), logical and cell
    datasets and MATLAB's own ``#refs#``/``#subsystem#`` are not data."""
    return _read_hdf5(path, matlab=True)


def read_hdf5(path: Path) -> RawRecord:
    """An HDF5 file (h5py): each group of numeric datasets is a record; a group's numeric scalar
    attributes (``fs``, ``dt``) count as its variables (arrays are row-major, as NumPy writes them)."""
    return _read_hdf5(path, matlab=False)


def _read_hdf5(path: Path, matlab: bool) -> RawRecord:
    import h5py

    groups: dict[str, dict[str, np.ndarray]] = {}

    def visit(name: str, item) -> None:
        if isinstance(item, h5py.Group) and not matlab:
            scalars = {key: np.asarray(value) for key, value in item.attrs.items()
                       if np.asarray(value).dtype.kind in "fiu" and np.asarray(value).size == 1}
            if scalars:
                groups.setdefault(name.replace("/", "."), {}).update(scalars)
            return
        if not isinstance(item, h5py.Dataset) or name.startswith("#") or item.dtype.kind not in "fiu":
            return
        kind = item.attrs.get("MATLAB_class", b"double")
        if (kind.decode() if isinstance(kind, bytes) else str(kind)) in ("char", "logical", "cell"):
            return
        group, _, leaf = name.rpartition("/")
        value = np.asarray(item[()])
        groups.setdefault(group.replace("/", "."), {})[leaf] = value.T if matlab else value  # MATLAB: column-major
    what = "MATLAB v7.3" if matlab else "HDF5"
    try:
        with h5py.File(path, "r") as handle:
            handle.visititems(visit)
    except OSError as exc:
        raise BeamInputError(f"{path}: not a readable {what} file ({' '.join(str(exc).split())[:120]})") from None
    notes: list[str] = []
    blocks = _blocks_from_groups(path, groups, f"{what} file", notes)
    return RawRecord(path, "MATLAB .mat (v7.3, HDF5)" if matlab else "HDF5", blocks, notes)


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
