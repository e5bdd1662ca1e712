"""What a measured record must satisfy (``docs/record-format.md``), in one place for every
reader of :mod:`creepcomp.io.records`: the header and the columns it must hold, units and the
time scale, numbers and finite values, time order and repeated times, and the messages that
name the file, line and column of the first problem.

The line reader checks each cell here and words every fault. The pyarrow readers (a whole
file, or a file in pieces) ask :func:`all_finite` and :func:`time_increases` of each block they
parse and leave a block that fails to the line reader, so that a fault gets the same message
from every reader.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from typing import Callable, Mapping, Sequence

import numpy as np

from creepcomp.errors import InputError

__all__ = ["REQUIRED", "OPTIONAL", "COLUMNS", "TIME_UNITS_TO_SECONDS", "ColumnMap", "RecordHead",
           "check_delimiter", "split_fields", "sniff_delimiter", "lower_keys", "take_header_line",
           "no_header_error", "resolve_columns", "apply_units", "row_values", "finish_arrays",
           "check_time_order", "all_finite", "time_increases", "check_arrays"]

REQUIRED = ("time", "load", "signal")
OPTIONAL = ("temperature", "corrected")
COLUMNS = REQUIRED + OPTIONAL
TIME_UNITS_TO_SECONDS = {"s": 1.0, "sec": 1.0, "second": 1.0, "seconds": 1.0, "ms": 1e-3,
                         "min": 60.0, "minutes": 60.0, "h": 3600.0, "hr": 3600.0, "hours": 3600.0}
DUPLICATE_TIMES = ("error", "mean")


@dataclass(frozen=True)
class ColumnMap:
    """Where each record column comes from: a column of the file, or a constant value (a
    number in the column mapping, such as ``load=1``).

    Attributes
    ----------
    header : tuple of str
        The file's column names.
    read : dict
        Record column -> index of the file's column it is read from.
    constants : dict
        Record column -> its constant value.
    """

    header: tuple[str, ...]
    read: dict[str, int]
    constants: dict[str, float]

    def is_units_row(self, row: Sequence[str]) -> bool:
        """True when a read column's cell of ``row`` is not a number (the row names units)."""
        return any(index < len(row) and not _is_number(row[index].strip())
                   for index in self.read.values())

    def constant_arrays(self, n: int) -> dict[str, np.ndarray]:
        """Record column -> ``n`` samples of its constant value."""
        return {name: np.full(n, value) for name, value in self.constants.items()}

    def units(self, row: Sequence[str]) -> dict[str, str]:
        """Record column -> the unit a units row gives it (non-empty cells only)."""
        return {name: row[index].strip() for name, index in self.read.items()
                if index < len(row) and row[index].strip()}


@dataclass(frozen=True)
class RecordHead:
    """What precedes a record's data: metadata, columns, delimiter and a units row.

    Attributes
    ----------
    source : str
        The file, for messages.
    metadata : dict
        The ``# key: value`` lines before the header.
    columns : ColumnMap
    delimiter : str
    header_at : int
        Index of the header line (0 for the first line).
    units_row : list of str or None
        The row right below the header when it names units (mapped files only).
    """

    source: str
    metadata: dict
    columns: ColumnMap
    delimiter: str
    header_at: int
    units_row: list | None

    @property
    def first_data_line(self) -> int:
        """Line number (from 1) of the first data row."""
        return self.header_at + 2 + (self.units_row is not None)


def check_delimiter(delimiter: str | None) -> None:
    """Raise for a delimiter that cannot separate CSV fields."""
    if delimiter is not None and (len(delimiter) != 1 or delimiter in "\r\n\"" or delimiter.isalnum()):
        raise InputError(f"delimiter {delimiter!r}: give one character such as ',', ';' or a "
                         "tab ('tab'), not a letter, digit, quote or line break")


def split_fields(line: str, delimiter: str, where: str = "record") -> list[str]:
    """The fields of one line of a record; a csv fault (a field over the csv module's limit
    of 128 KiB, which cannot be a column name, a unit or a number) as one InputError naming
    ``where``."""
    try:
        return next(csv.reader([line], delimiter=delimiter), [])
    except csv.Error as exc:
        raise InputError(f"{where}: {exc}; no column name, unit or number is that long") from None


def sniff_delimiter(line: str) -> str:
    """The delimiter of a header line: comma, tab or semicolon (comma when none is there)."""
    for d in (",", "\t", ";"):
        if d in line:
            return d
    return ","


def lower_keys(columns: Mapping[str, str] | None) -> dict[str, str]:
    """A column mapping with its record-column names in lower case."""
    return {k.lower(): v for k, v in (columns or {}).items()}


def take_header_line(line: str, mapping: Mapping[str, str], delimiter: str | None,
                     metadata: dict) -> bool:
    """True for the header line; a ``# key: value`` line before it goes into ``metadata``.

    Without a mapping the header is the first line that is neither blank nor a comment; with
    one, the first line that holds every mapped column name.
    """
    stripped = line.strip()
    if stripped.startswith("#"):
        body = stripped.lstrip("#").strip()
        if ":" in body:
            key, value = body.split(":", 1)
            metadata[key.strip()] = value.strip()
        return False
    if not stripped:
        return False
    if not mapping:
        return True
    d = delimiter or sniff_delimiter(line)
    fields = [f.strip() for f in split_fields(line, d, "a line before the header")]
    return all(any(f.lower() == w.lower() for f in fields) for w in _mapped_names(mapping))


def no_header_error(source: str, mapping: Mapping[str, str]) -> InputError:
    """The error for a file in which no line is the header."""
    if mapping:
        return InputError(f"{source}: no header line holds the mapped columns "
                          f"{', '.join(repr(v) for v in _mapped_names(mapping))}")
    return InputError(f"{source}: no header line (the file is empty or all comments)")


def resolve_columns(header: Sequence[str], mapping: Mapping[str, str], source: str,
                    header_at: int | None) -> ColumnMap:
    """Where each record column is in ``header`` (or its constant); raise for missing ones.
    ``header_at`` is the header's line in a file (None: columns held in memory, which the
    messages then name without a line)."""
    where = source if header_at is None else f"{source}, line {header_at + 1}"
    mapping_hint = "--columns" if header_at is not None else "columns={'time': NAME, ...}"
    lowered = [h.lower() for h in header]
    read: dict[str, int] = {}
    constants: dict[str, float] = {}
    for name in COLUMNS:
        wanted = mapping.get(name, name if name not in mapping else None)
        if name in mapping and _is_number(mapping[name]) and mapping[name].lower() not in lowered:
            constants[name] = float(mapping[name])
            continue
        if wanted is not None and wanted.lower() in lowered:
            read[name] = _only_column(header, wanted, where)
        elif name in mapping:
            raise InputError(f"{where}: mapped column '{mapping[name]}' for "
                             f"'{name}' not found; columns found: {', '.join(header)}")
    missing = [c for c in REQUIRED if c not in read and c not in constants]
    if missing:
        raise InputError(f"{where}: missing required column"
                         f"{'s' if len(missing) > 1 else ''} {', '.join(repr(m) for m in missing)}; "
                         f"columns found: {', '.join(header)} (map others with {mapping_hint})")
    return ColumnMap(tuple(header), read, constants)


def apply_units(head: RecordHead) -> float:
    """Put the units row's units into the head's metadata; the factor that converts time to
    seconds, from the units row or the metadata line ``# units.time:`` (1 without either; a
    unit already converted, ``s (converted from ms)``, is seconds). Raise for a time unit that
    is not one of :data:`TIME_UNITS_TO_SECONDS`."""
    metadata = head.metadata
    if head.units_row is not None:
        for name, unit in head.columns.units(head.units_row).items():
            metadata.setdefault(f"units.{name}", unit)
    unit = str(metadata.get("units.time", "s")).split("(")[0].strip().lower()
    scale = TIME_UNITS_TO_SECONDS.get(unit)
    if scale is None:
        raise InputError(f"{head.source}: time unit '{metadata['units.time']}' is not one of "
                         f"{', '.join(TIME_UNITS_TO_SECONDS)}")
    if scale != 1.0:
        metadata["units.time"] = f"s (converted from {str(metadata['units.time']).strip()})"
    return scale


def row_values(row: Sequence[str], head: RecordHead, line_no: int) -> list[float] | None:
    """The values of one data row's read columns (in the order of ``head.columns.read``), or
    None for a blank row; raise, naming the line and column, for a missing field or a cell
    that is not a finite number."""
    if not row or all(not f.strip() for f in row):
        return None
    header, source = head.columns.header, head.source
    values = []
    for index in head.columns.read.values():
        if index >= len(row):
            raise InputError(f"{source}, line {line_no}: column '{header[index]}' is missing "
                             f"(the row has {len(row)} fields)")
        cell = row[index].strip()
        try:
            x = float(cell)
        except ValueError:
            raise InputError(f"{source}, line {line_no}, column '{header[index]}': "
                             f"'{cell}' is not a number") from None
        if not math.isfinite(x):
            raise InputError(f"{source}, line {line_no}, column '{header[index]}': "
                             f"'{cell}' is not a finite number")
        values.append(x)
    return values


def finish_arrays(arrays: dict[str, np.ndarray], head: RecordHead, time_scale: float,
                  duplicate_times: str) -> dict[str, np.ndarray]:
    """Time converted to seconds, the check for data, and repeated times averaged when asked
    (``duplicate_times="mean"``; the number merged goes into the head's metadata)."""
    if time_scale != 1.0:
        arrays["time"] = arrays["time"] * time_scale
    if len(arrays["time"]) == 0:
        raise InputError(f"{head.source}: no data rows after the header (line {head.header_at + 1})")
    if duplicate_times not in DUPLICATE_TIMES:
        raise InputError(f"duplicate_times '{duplicate_times}': use 'error' or 'mean'")
    if duplicate_times == "mean":
        arrays, merged = _merge_duplicate_times(arrays)
        if merged:
            head.metadata["merged_duplicate_times"] = str(merged)
    return arrays


def _merge_duplicate_times(arrays: dict) -> tuple[dict, int]:
    """Average the rows of each run of equal time stamps (time must not go backwards)."""
    t = arrays["time"]
    if np.any(np.diff(t) < 0):
        return arrays, 0           # going backwards stays an error, reported by the time check
    starts = np.flatnonzero(np.diff(t, prepend=np.nan) != 0)
    counts = np.diff(np.append(starts, len(t)))
    merged = {name: np.add.reduceat(v, starts) / counts for name, v in arrays.items()}
    return merged, int(len(t) - len(starts))


def check_time_order(t: np.ndarray, source: str, line_of: Callable[[int], int]) -> None:
    """Raise, naming the line (``line_of(sample)``), when time is not strictly increasing."""
    k = _first_step_not_forward(t)
    if k is not None:
        what = "repeats the previous time" if t[k] == t[k - 1] else "is earlier than the previous time"
        raise InputError(f"{source}, line {line_of(k)}, column 'time': {t[k]:g} {what} "
                         f"({t[k - 1]:g}); time must be strictly increasing")


def all_finite(arrays: Mapping[str, np.ndarray]) -> bool:
    """True when every value of a block read by pyarrow is finite."""
    return all(np.isfinite(v).all() for v in arrays.values())


def time_increases(t: np.ndarray, after: float | None = None) -> bool:
    """True when time strictly increases, from ``after`` (the last time of the block before)."""
    return _first_step_not_forward(t) is None and (after is None or len(t) == 0 or t[0] > after)


def check_arrays(record) -> None:
    """Shape, finiteness and time-order checks of a record built from arrays
    (:class:`creepcomp.io.records.Record`), naming the sample."""
    n = len(record.time)
    for name in COLUMNS:
        value = getattr(record, name)
        if value is None:
            continue
        if value.ndim != 1 or len(value) != n:
            raise InputError(f"{record.source}: column '{name}' has {value.size} values for "
                             f"{n} time points")
        bad = np.flatnonzero(~np.isfinite(value))
        if bad.size:
            raise InputError(f"{record.source}: column '{name}', sample {bad[0]}: "
                             f"{value[bad[0]]} is not a finite number")
    t = record.time
    i = _first_step_not_forward(t)
    if i is not None:
        kind = "repeats" if t[i] == t[i - 1] else "goes back from"
        raise InputError(f"{record.source}: time is not strictly increasing: sample {i} "
                         f"({t[i]:g} s) {kind} the previous one ({t[i - 1]:g} s)")


def _first_step_not_forward(t: np.ndarray) -> int | None:
    """The first sample whose time is not after the previous one's, or None."""
    bad = np.flatnonzero(np.diff(t) <= 0)
    return int(bad[0]) + 1 if bad.size else None


def _only_column(header: Sequence[str], wanted: str, where: str) -> int:
    """The index of the one column named ``wanted`` (in any case); raise when several are."""
    hits = [i for i, h in enumerate(header) if h.lower() == wanted.lower()]
    if len(hits) > 1:
        raise InputError(f"{where}: columns "
                         f"{' and '.join(repr(header[i]) for i in hits)} are the same column "
                         f"'{wanted.lower()}' (names are read in any case): rename or drop one")
    return hits[0]


def _mapped_names(mapping: Mapping[str, str]) -> list[str]:
    """The mapped column names (constants, such as ``load=1``, left out)."""
    return [v for v in mapping.values() if not _is_number(v)]


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
