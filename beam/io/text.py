"""Reading and writing the small text files users bring: UTF-8 text, TOML, atomic writes.

Every reading error is a :class:`beam.errors.BeamInputError` whose one-line message starts with
the file name and names the line or key at fault. TOML is read with :mod:`tomllib` and written
with :mod:`tomli_w` (:func:`dump_toml`).
"""

from __future__ import annotations

import difflib
import math
import numbers
import os
import secrets
import sys
import tomllib
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import tomli_w

from beam.errors import BeamInputError, as_finite_float, short_repr  # noqa: F401 - re-exported
from beam.io.limits import MAX_MEASUREMENT_BYTES, MAX_TOML_BYTES

# ---------------------------------------------------------------------------------------------
# reading
# ---------------------------------------------------------------------------------------------


def read_text_file(
    path: str | os.PathLike[str], what: str = "file", max_bytes: int = MAX_MEASUREMENT_BYTES
) -> str:
    """Read a UTF-8 text file (an optional byte-order mark is dropped).

    Parameters
    ----------
    path : str or path-like
        File to read.
    what : str
        What the file is, for the message when it is missing (e.g. ``"sidecar"``).
    max_bytes : int
        Largest size read; a larger file is refused before it is read (default
        :data:`beam.io.limits.MAX_MEASUREMENT_BYTES`).

    Returns
    -------
    str
        The decoded text.

    Raises
    ------
    BeamInputError
        The file is missing, is a directory or not a regular file (a device, a pipe), cannot
        be read, is larger than ``max_bytes``, holds binary data (a NUL byte) or is not UTF-8;
        the message names the file and, for bad bytes, the line.
    """
    path = Path(path)
    raw = _read_bytes(path, what, max_bytes)
    if b"\x00" in raw:
        line = raw.count(b"\n", 0, raw.index(b"\x00")) + 1
        raise BeamInputError(f"{path}: line {line}: binary content (NUL byte); expected a UTF-8 text file")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        raise BeamInputError(
            f"{path}: line {line}: not UTF-8 text (byte 0x{raw[exc.start]:02x}); save the file as UTF-8"
        ) from None


def _read_bytes(path: Path, what: str, max_bytes: int) -> bytes:
    """At most ``max_bytes`` bytes of a regular file, or a BeamInputError saying why not."""
    try:
        if not path.exists():
            raise BeamInputError(f"{path}: {what} not found")
        if path.is_dir():
            raise BeamInputError(f"{path}: is a directory, expected a {what}")
        if not path.is_file():
            raise BeamInputError(f"{path}: not a regular file (a device or a pipe?), expected a {what}")
        with path.open("rb") as stream:
            raw = stream.read(max_bytes + 1)  # bounded: the size on disk may change or lie
    except BeamInputError:
        raise
    except PermissionError:
        raise BeamInputError(f"{path}: permission denied") from None
    except (OSError, ValueError) as exc:  # a name too long, a NUL in the name, an I/O error
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise BeamInputError(f"{path}: cannot read the {what}: {reason}") from None
    if len(raw) > max_bytes:
        hint = "; shorten the record or lower its sampling rate" if "CSV" in what else ""
        raise BeamInputError(f"{path}: larger than the {_size(max_bytes)} allowed for a {what}{hint}")
    return raw


def _size(count: int) -> str:
    """``64 MiB``, ``1 MiB``, ``512 KiB`` or ``100 bytes``."""
    for unit, scale in (("MiB", 2**20), ("KiB", 2**10)):
        if count >= scale and count % scale == 0:
            return f"{count // scale} {unit}"
    return f"{count} bytes"


def load_toml(path: str | os.PathLike[str], what: str = "TOML file") -> dict[str, Any]:
    """Parse a TOML file; syntax errors report tomllib's line and column.

    Parameters
    ----------
    path : str or path-like
        The TOML file (at most :data:`beam.io.limits.MAX_TOML_BYTES`).
    what : str
        What the file is, for the message when it is missing.

    Returns
    -------
    dict
        The parsed document.

    Raises
    ------
    BeamInputError
        Besides :func:`read_text_file`'s reasons: a syntax error, arrays or inline tables
        nested too deeply, an integer of more than 4300 digits.
    """
    text = read_text_file(path, what, MAX_TOML_BYTES)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise BeamInputError(f"{path}: TOML syntax error: {exc}") from None
    except RecursionError:
        raise BeamInputError(f"{path}: arrays or inline tables nested too deeply") from None
    except ValueError as exc:  # int("1" * 5000): Python's limit on integer digits
        if "digits" in str(exc):
            raise BeamInputError(f"{path}: an integer has more than {sys.get_int_max_str_digits()} digits") from None
        raise BeamInputError(f"{path}: a value cannot be read: {_one_line(str(exc))}") from None


def _one_line(text: str) -> str:
    return " ".join(text.split())


class TomlReader:
    """Typed access to a parsed TOML document with one-line errors naming file, table and key.

    Parameters
    ----------
    document : dict
        Parsed TOML (from :func:`load_toml`).
    path : path-like
        The file it came from (used in messages only).
    """

    def __init__(self, document: Mapping[str, Any], path: str | os.PathLike[str]):
        self.document = document
        self.path = Path(path)

    def fail(self, where: str, message: str) -> BeamInputError:
        """An error ``PATH: WHERE: MESSAGE`` to raise."""
        return BeamInputError(f"{self.path}: {where}: {message}" if where else f"{self.path}: {message}")

    def check_top_level(self, tables: Iterable[str], keys: Iterable[str] = ()) -> None:
        """Reject unknown top-level tables and keys (a typo must not be silently ignored)."""
        tables, keys = tuple(tables), tuple(keys)
        for name, value in self.document.items():
            if isinstance(value, dict):
                if name not in tables:
                    hint = did_you_mean(name, tables)
                    raise self.fail(f"[{name}]", f"unknown table{hint}; expected one of {_listing(tables, '[{}]')}")
            elif name not in keys:
                if name in tables:
                    raise self.fail(name, f"must be a table [{name}], got {_type_name(value)}")
                allowed = f"top-level keys are {_listing(keys)}" if keys else "no top-level keys are allowed"
                hint = did_you_mean(name, keys + tables)
                raise self.fail(name, f"unknown key{hint}; {allowed} and tables {_listing(tables, '[{}]')}")

    def table(self, name: str, required: bool = True) -> dict[str, Any] | None:
        """The table ``[name]``, or None when it is absent and optional."""
        if name not in self.document:
            if required:
                raise self.fail(f"[{name}]", "missing table")
            return None
        value = self.document[name]
        if not isinstance(value, dict):
            raise self.fail(name, f"must be a table [{name}], got {_type_name(value)}")
        return value

    def check_keys(self, table_name: str, table: Mapping[str, Any], allowed: Iterable[str]) -> None:
        """Reject keys of ``[table_name]`` that are not in ``allowed``."""
        allowed = tuple(allowed)
        for key in table:
            if key not in allowed:
                hint = did_you_mean(key, allowed)
                raise self.fail(f"[{table_name}] {key}", f"unknown key{hint}; expected {_listing(allowed)}")

    def number(
        self,
        table_name: str | None,
        table: Mapping[str, Any],
        key: str,
        *,
        required: bool = True,
        default: float | None = None,
        positive: bool = True,
        allow_zero: bool = False,
    ) -> float | None:
        """A finite real number (TOML integer or float, never a boolean or string).

        Parameters
        ----------
        table_name : str or None
            Name of the table for messages; None for a top-level key.
        table : mapping
            The table to read from.
        key : str
            Key to read.
        required : bool
            Whether a missing key is an error; otherwise ``default`` is returned.
        default : float, optional
            Value of an optional missing key.
        positive : bool
            Require a value > 0 (or >= 0 with ``allow_zero``).
        allow_zero : bool
            Accept 0 when ``positive`` is set.
        """
        where = f"[{table_name}] {key}" if table_name else key
        if key not in table:
            if required:
                raise self.fail(where, "missing key")
            return default
        value = table[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.fail(where, f"must be a number, got {_type_name(value)} {short_repr(value)}")
        number = as_finite_float(value)
        if number is None:
            too_large = " (too large for a float)" if isinstance(value, int) else ""
            raise self.fail(where, f"must be finite, got {short_repr(value)}{too_large}")
        value = number
        if positive and (value < 0 or (value == 0 and not allow_zero)):
            bound = ">= 0" if allow_zero else "> 0"
            raise self.fail(where, f"must be {bound}, got {value!r}")
        return value

    def integer(
        self,
        table_name: str | None,
        table: Mapping[str, Any],
        key: str,
        *,
        required: bool = True,
        default: int | None = None,
        minimum: int | None = None,
        maximum: int | None = None,
    ) -> int | None:
        """A TOML integer within ``[minimum, maximum]``."""
        where = f"[{table_name}] {key}" if table_name else key
        if key not in table:
            if required:
                raise self.fail(where, "missing key")
            return default
        value = table[key]
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.fail(where, f"must be an integer, got {_type_name(value)} {short_repr(value)}")
        if minimum is not None and value < minimum:
            raise self.fail(where, f"must be >= {minimum}, got {short_repr(value)}")
        if maximum is not None and value > maximum:
            raise self.fail(where, f"must be <= {maximum}, got {short_repr(value)}")
        return value

    def string(
        self, table_name: str | None, table: Mapping[str, Any], key: str, *, required: bool = True,
        default: str | None = None,
    ) -> str | None:
        """A TOML string."""
        where = f"[{table_name}] {key}" if table_name else key
        if key not in table:
            if required:
                raise self.fail(where, "missing key")
            return default
        value = table[key]
        if not isinstance(value, str):
            raise self.fail(where, f"must be a string, got {_type_name(value)} {short_repr(value)}")
        return value


def did_you_mean(name: str, candidates: Iterable[str]) -> str:
    """``" (did you mean 'x'?)"`` for the closest candidate to a misspelt name, else ``""``."""
    close = difflib.get_close_matches(name, list(candidates), n=1, cutoff=0.75)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _type_name(value: Any) -> str:
    if isinstance(value, bool):
        return "boolean"
    if isinstance(value, dict):
        return "table"
    if isinstance(value, list):
        return "array"
    return {int: "integer", float: "float", str: "string"}.get(type(value), type(value).__name__)


def _listing(names: Iterable[str], pattern: str = "{}") -> str:
    names = [pattern.format(n) for n in names]
    return ", ".join(names) if names else "(none)"


# ---------------------------------------------------------------------------------------------
# writing
# ---------------------------------------------------------------------------------------------


def _plain(value: Any) -> Any:
    """``value`` with numpy scalars as Python numbers and tuples as lists (what tomli-w writes)."""
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if not isinstance(value, (str, bool, int, float)) and hasattr(value, "item") and callable(value.item):
        return value.item()  # numpy scalar
    return value


def dump_toml(document: Mapping[str, Any], header_comment: str | None = None) -> str:
    """TOML text of ``document`` (:mod:`tomli_w`), optionally after ``# ...`` comment lines.

    Parameters
    ----------
    document : mapping
        Keys to values: strings, booleans, integers, floats (written exactly: shortest repr),
        lists, numpy scalars, and mappings (tables).
    header_comment : str, optional
        Lines written first as ``# ...`` comments.

    Returns
    -------
    str
        TOML text that :func:`tomllib.loads` parses back to an equal document.

    Raises
    ------
    TypeError
        A value TOML cannot hold.
    """
    head = ""
    if header_comment:
        head = "\n".join(f"# {line}".rstrip() for line in header_comment.splitlines()) + "\n\n"
    return head + tomli_w.dumps(_plain(document))


def atomic_write_texts(contents: Mapping[str | os.PathLike[str], str]) -> list[Path]:
    """Write several text files so that none is left half-written.

    Each text goes to a temporary file in its target's directory (created if needed); only
    when all are written and flushed are they renamed over their targets with
    :func:`os.replace` (each rename is atomic). On an error while writing, the temporary files
    are removed and every target is left as it was.

    Parameters
    ----------
    contents : mapping
        Target path to UTF-8 text.

    Returns
    -------
    list of Path
        The targets, in the given order.
    """
    targets = [Path(p) for p in contents]
    temporaries: list[Path] = []
    try:
        for target, text in zip(targets, contents.values()):
            target.parent.mkdir(parents=True, exist_ok=True)
            temporary = target.parent / f".{target.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp"
            # os.open (not tempfile.mkstemp) so that the file gets the usual umask permissions
            handle = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
            temporaries.append(temporary)
            with os.fdopen(handle, "w", encoding="utf-8", newline="\n") as stream:
                stream.write(text)
                stream.flush()
                os.fsync(stream.fileno())
        for temporary, target in zip(temporaries, targets):
            os.replace(temporary, target)
    except BaseException:
        for temporary in temporaries:
            temporary.unlink(missing_ok=True)
        raise
    return targets
