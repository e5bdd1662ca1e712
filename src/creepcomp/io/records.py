"""Measured records (``docs/record-format.md``): reading, checking, column mapping, writing.

A record is a CSV file with ``time``, ``load`` and ``signal`` columns (and optionally
``temperature`` and ``corrected``), metadata lines ``# key: value`` before the header, and
one clear message, naming file, line and column, for every problem.

Other files are read with a column mapping (``{"time": "tR", "load": "P", "signal": "Ri"}``;
on the command line ``--columns time=tR,load=P,signal=Ri``). With a mapping the header is
the first line holding all the mapped names, so an instrument export's preamble is skipped;
a units row right under such a header is read as units (a time column in ``min``, ``ms`` or
``h`` is converted to seconds). A mapped value that is a number and not a column name, such
as ``load=1``, is a constant column: a material test's single load step.
"""

from __future__ import annotations

import contextlib
import csv
import io
import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable, Iterator, Mapping

import numpy as np

from creepcomp.errors import InputError

__all__ = ["REQUIRED", "OPTIONAL", "COLUMNS", "TIME_UNITS_TO_SECONDS", "Record", "check_arrays",
           "parse_columns", "read_record", "parse_record", "write_record", "WRITE_ROWS",
           "NotStreamable", "STREAM_BYTES", "read_record_chunks", "record_writer", "RecordScan",
           "scan_record"]

REQUIRED = ("time", "load", "signal")
OPTIONAL = ("temperature", "corrected")
COLUMNS = REQUIRED + OPTIONAL
#: Rows per block when writing a record (bounds the memory of the text being written).
WRITE_ROWS = 500_000
TIME_UNITS_TO_SECONDS = {"s": 1.0, "sec": 1.0, "ms": 1e-3, "min": 60.0, "h": 3600.0, "hr": 3600.0}


@dataclass(frozen=True)
class Record:
    """A measured record.

    Attributes
    ----------
    time, load, signal : numpy.ndarray
        Required columns; time in seconds, strictly increasing.
    temperature, corrected : numpy.ndarray or None
        Optional columns.
    metadata : dict
        ``# key: value`` lines (and units read from an instrument's units row).
    source : str
        Where it came from (file name), for messages.
    """

    time: np.ndarray
    load: np.ndarray
    signal: np.ndarray
    temperature: np.ndarray | None = None
    corrected: np.ndarray | None = None
    metadata: dict = field(default_factory=dict)
    source: str = "record"

    def __post_init__(self):
        for name in COLUMNS:
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, np.asarray(value, dtype=float))
        check_arrays(self)

    def __len__(self) -> int:
        return len(self.time)

    @property
    def duration(self) -> float:
        """Time span of the record (s)."""
        return float(self.time[-1] - self.time[0])

    @property
    def is_uniform(self) -> bool:
        """True when the sampling is uniform (see :func:`creepcomp.lti.is_uniform`)."""
        from creepcomp.lti import is_uniform

        return is_uniform(self.time)

    def unit(self, column: str) -> str:
        """The unit named in metadata ``units.<column>``, or an empty string."""
        return str(self.metadata.get(f"units.{column}", ""))

    def require(self, n_samples: int = 2, duration: float | None = None, what: str = "this analysis",
                columns: tuple[str, ...] = ()) -> None:
        """Raise a clear error when the record is too short or lacks a column.

        Parameters
        ----------
        n_samples : int
            Fewest samples needed.
        duration : float, optional
            Shortest time span needed (s), e.g. a multiple of the time scale to resolve.
        what : str
            The analysis, for the message.
        columns : tuple of str
            Optional columns that must be present.
        """
        if len(self) < n_samples:
            raise InputError(f"{self.source}: {len(self)} samples is too few for {what} "
                             f"(needs at least {n_samples})")
        if duration is not None and self.duration < duration:
            raise InputError(f"{self.source}: the record spans {self.duration:.4g} s, shorter than "
                             f"the {duration:.4g} s that {what} needs")
        for col in columns:
            if getattr(self, col) is None:
                raise InputError(f"{self.source}: {what} needs a '{col}' column")

    def design_path(self, override: str | Path | None = None) -> Path:
        """The design file of the network that produced ``corrected``.

        ``override`` (the CLI's ``--design``) wins over metadata ``design:``, which is
        relative to the record's folder.
        """
        if override is not None:
            return Path(override)
        name = self.metadata.get("design")
        if not name:
            raise InputError(f"{self.source}: the record has a 'corrected' column but names no "
                             "design: add '# design: FILE' or give --design FILE")
        base = Path(self.source).parent if self.source else Path(".")
        return base / str(name)

    def with_columns(self, **columns) -> "Record":
        """A copy with some columns replaced or added."""
        return replace(self, **columns)

    def columns(self) -> dict[str, np.ndarray]:
        """The present columns, in contract order."""
        return {name: getattr(self, name) for name in COLUMNS if getattr(self, name) is not None}


def check_arrays(record: Record) -> None:
    """Shape, finiteness and time-order checks of a record built from arrays."""
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
    dt = np.diff(record.time)
    bad = np.flatnonzero(dt <= 0)
    if bad.size:
        i = bad[0] + 1
        kind = "repeats" if dt[bad[0]] == 0 else "goes back from"
        raise InputError(f"{record.source}: time is not strictly increasing: sample {i} "
                         f"({record.time[i]:g} s) {kind} the previous one ({record.time[i - 1]:g} s)")


def parse_columns(text: str | None) -> dict[str, str]:
    """Parse ``time=tR,load=P,signal=Ri`` into a mapping; names must be record columns."""
    if not text:
        return {}
    out = {}
    for item in next(csv.reader([text], skipinitialspace=True)):
        if "=" not in item:
            raise InputError(f"--columns: '{item}' is not NAME=COLUMN (e.g. time=tR,signal=Ri)")
        key, value = (s.strip() for s in item.split("=", 1))
        key = key.lower()
        if key not in COLUMNS:
            raise InputError(f"--columns: '{key}' is not a record column ({', '.join(COLUMNS)})")
        if not value:
            raise InputError(f"--columns: no column name given for '{key}'")
        out[key] = value
    return out


def _sniff_delimiter(line: str) -> str:
    for d in (",", "\t", ";"):
        if d in line:
            return d
    return ","


def _number(text: str) -> float:
    return float(text.strip())


def _check_delimiter(delimiter: str | None) -> None:
    if delimiter is not None and (len(delimiter) != 1 or delimiter in "\r\n\"" or delimiter.isalnum()):
        raise InputError(f"delimiter {delimiter!r}: give one character such as ',', ';' or a "
                         "tab ('tab'), not a letter, digit, quote or line break")


def read_record(path: str | Path, columns: Mapping[str, str] | None = None,
                delimiter: str | None = None, duplicate_times: str = "error") -> Record:
    """Read and check a measured record.

    Parameters
    ----------
    path : str or Path
        CSV file.
    columns : mapping, optional
        Record column -> the file's column name (or a constant number).
    delimiter : str, optional
        Field delimiter; default: detected from the header (comma, tab or semicolon).
    duplicate_times : {"error", "mean"}
        Repeated time stamps are an error, or (asked for explicitly, e.g. for files whose
        time stamps were rounded) the rows sharing a time are averaged; the number merged is
        kept in ``metadata["merged_duplicate_times"]``.

    Returns
    -------
    Record

    Raises
    ------
    InputError
        Naming the file, line and column of the first problem.
    """
    p = Path(path)
    _check_delimiter(delimiter)
    if p.is_file():
        try:
            return _read_fast(p, {k.lower(): v for k, v in (columns or {}).items()}, delimiter,
                              duplicate_times)
        except _Slow:
            pass
        except OSError:
            pass                            # the full reader below words the message
    try:
        text = p.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise InputError(f"record {p}: no such file") from None
    except UnicodeDecodeError as exc:
        raise InputError(f"record {p}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    except OSError as exc:
        raise InputError(f"record {p}: cannot read it ({exc.strerror})") from None
    return parse_record(text, source=str(p), columns=columns, delimiter=delimiter,
                        duplicate_times=duplicate_times)


def parse_record(text: str, source: str = "record", columns: Mapping[str, str] | None = None,
                 delimiter: str | None = None, duplicate_times: str = "error") -> Record:
    """Parse record text (see :func:`read_record`)."""
    _check_delimiter(delimiter)
    mapping = {k.lower(): v for k, v in (columns or {}).items()}
    lines = text.splitlines()
    metadata: dict[str, str] = {}
    header_at = None
    for i, line in enumerate(lines):
        if _is_header(line, mapping, delimiter, metadata):
            header_at = i
            break
    if header_at is None:
        if mapping:
            raise InputError(f"{source}: no header line holds the mapped columns "
                             f"{', '.join(repr(v) for v in mapping.values() if not _is_number(v))}")
        raise InputError(f"{source}: no header line (the file is empty or all comments)")
    d = delimiter or _sniff_delimiter(lines[header_at])
    reader = csv.reader(io.StringIO("\n".join(lines[header_at:])), delimiter=d)
    header = [h.strip() for h in next(reader)]
    index = _resolve_columns(header, mapping, source, header_at)
    rows = list(reader)
    first_data = header_at + 2
    units_row = None
    if mapping and rows and not _row_is_numeric(rows[0], index):
        units_row, rows, first_data = rows[0], rows[1:], first_data + 1
    values = {name: [] for name in index}
    for offset, row in enumerate(rows):
        line_no = first_data + offset
        if not row or all(not f.strip() for f in row):
            continue
        for name, col in index.items():
            if isinstance(col, float):
                values[name].append(col)
                continue
            if col >= len(row):
                raise InputError(f"{source}, line {line_no}: column '{header[col]}' is missing "
                                 f"(the row has {len(row)} fields)")
            cell = row[col].strip()
            try:
                x = _number(cell)
            except ValueError:
                raise InputError(f"{source}, line {line_no}, column '{header[col]}': "
                                 f"'{cell}' is not a number") from None
            if not math.isfinite(x):
                raise InputError(f"{source}, line {line_no}, column '{header[col]}': "
                                 f"'{cell}' is not a finite number")
            values[name].append(x)
    arrays = {name: np.array(v, dtype=float) for name, v in values.items()}
    arrays = _finish(arrays, metadata, units_row, index, source, header_at, duplicate_times)
    _check_time_order(arrays["time"], source, first_data, rows)
    return Record(source=source, metadata=metadata,
                  **{name: arrays.get(name) for name in COLUMNS})


def _finish(arrays: dict, metadata: dict, units_row, index: dict, source: str, header_at: int,
            duplicate_times: str) -> dict:
    """Units from a units row (time converted to seconds), the empty check, merged duplicates."""
    scale = _apply_units(metadata, units_row, index, source)
    if scale != 1.0:
        arrays["time"] = arrays["time"] * scale
    if len(arrays["time"]) == 0:
        raise InputError(f"{source}: no data rows after the header (line {header_at + 1})")
    if duplicate_times == "mean":
        arrays, merged = _merge_duplicate_times(arrays)
        if merged:
            metadata["merged_duplicate_times"] = str(merged)
    elif duplicate_times != "error":
        raise InputError(f"duplicate_times '{duplicate_times}': use 'error' or 'mean'")
    return arrays


def _apply_units(metadata: dict, units_row, index: dict, source: str) -> float:
    """Put a units row's units into ``metadata``; the factor that converts time to seconds."""
    if units_row is None:
        return 1.0
    for name, col in index.items():
        if not isinstance(col, float) and col < len(units_row) and units_row[col].strip():
            metadata.setdefault(f"units.{name}", units_row[col].strip())
    scale = TIME_UNITS_TO_SECONDS.get(metadata.get("units.time", "s").strip().lower())
    if scale is None:
        raise InputError(f"{source}: time unit '{metadata['units.time']}' is not one of "
                         f"{', '.join(TIME_UNITS_TO_SECONDS)}")
    if scale != 1.0:
        metadata["units.time"] = f"s (converted from {metadata['units.time']})"
    return scale


class _Slow(Exception):
    """The fast reader met something it leaves to the line-by-line parser (and its message)."""


#: Lines read before the header by the fast reader (beyond that the full parser takes over).
FAST_HEADER_LINES = 10_000


@dataclass
class _FastHead:
    """What the fast readers learn before the data: metadata, columns, where the data start."""

    metadata: dict
    header: list
    index: dict
    delimiter: str
    header_at: int
    units_row: list | None

    @property
    def wanted(self) -> dict[str, str]:
        """Record column -> the name pyarrow gives the file's column."""
        return {name: f"c{col}" for name, col in self.index.items() if not isinstance(col, float)}

    def csv_options(self, block_size: int | None = None) -> dict:
        """pyarrow CSV options that read the wanted columns as float64."""
        import pyarrow as pa
        import pyarrow.csv as pacsv

        read = pacsv.ReadOptions(column_names=[f"c{k}" for k in range(len(self.header))],
                                 **({"block_size": block_size} if block_size else {}))
        return {"read_options": read, "parse_options": pacsv.ParseOptions(delimiter=self.delimiter),
                "convert_options": pacsv.ConvertOptions(
                    include_columns=sorted(set(self.wanted.values())),
                    column_types={c: pa.float64() for c in self.wanted.values()})}


def _fast_head(fh, source: str, mapping: dict, delimiter: str | None) -> _FastHead:
    """Read up to the header (and a units row) from the binary file ``fh``, leaving it at the
    first data line; :class:`_Slow` for anything the line parser should word."""
    metadata: dict[str, str] = {}
    header_at, header_line = None, None
    for i in range(FAST_HEADER_LINES):
        raw = fh.readline()
        if not raw:
            break
        try:
            line = raw.decode("utf-8-sig" if i == 0 else "utf-8")
        except UnicodeDecodeError:
            raise _Slow() from None
        if len(line.splitlines()) > 1:
            raise _Slow()               # separators other than newlines: leave to the parser
        if _is_header(line, mapping, delimiter, metadata):
            header_at, header_line = i, line
            break
    if header_at is None:
        raise _Slow()
    d = delimiter or _sniff_delimiter(header_line)
    header = [h.strip() for h in next(csv.reader([header_line], delimiter=d))]
    index = _resolve_columns(header, mapping, source, header_at)
    start = fh.tell()
    units_row = None
    if mapping:
        raw = fh.readline()
        try:
            row = next(csv.reader([raw.decode("utf-8")], delimiter=d), [])
        except UnicodeDecodeError:
            raise _Slow() from None
        if not _row_is_numeric(row, index):
            units_row, start = row, fh.tell()
    fh.seek(start)
    return _FastHead(metadata, header, index, d, header_at, units_row)


def _read_fast(path: Path, mapping: dict, delimiter: str | None,
               duplicate_times: str) -> Record:
    """Read a well-formed record with pyarrow's CSV reader (fast, little memory).

    Only the lines up to the header (and a units row) are parsed in Python; the data go to
    pyarrow as float64. Anything unusual (a blank or non-numeric cell, a short row, a
    non-finite value, time not increasing, a non-UTF-8 byte) raises :class:`_Slow`, and the
    line-by-line parser, which names the line and column, reads the file instead.
    """
    import pyarrow as pa
    import pyarrow.csv as pacsv

    source = str(path)
    with path.open("rb") as fh:
        head = _fast_head(fh, source, mapping, delimiter)
        try:
            table = pacsv.read_csv(fh, **head.csv_options())
        except (pa.ArrowException, ValueError):
            raise _Slow() from None
    columns = {name: table.column(c) for name, c in head.wanted.items()}
    n = table.num_rows
    del table
    if n == 0 or any(col.null_count for col in columns.values()):
        raise _Slow()
    arrays = {}
    for name in list(columns):
        chunks = columns.pop(name).chunks
        arrays[name] = np.concatenate([c.to_numpy(zero_copy_only=False) for c in chunks])
        del chunks
        if not np.isfinite(arrays[name]).all():
            raise _Slow()
    for name, col in head.index.items():
        if isinstance(col, float):
            arrays[name] = np.full(n, col)
    metadata = head.metadata
    arrays = _finish(arrays, metadata, head.units_row, head.index, source, head.header_at,
                     duplicate_times)
    if not np.all(np.diff(arrays["time"]) > 0):
        raise _Slow()
    return Record(source=source, metadata=metadata, **{name: arrays.get(name) for name in COLUMNS})


class NotStreamable(Exception):
    """A record :func:`read_record_chunks` leaves to :func:`read_record` (read whole): not a
    plain CSV file, or something in it that the full reader words (a bad cell, time going
    back), or repeated time stamps to average."""


#: Bytes of CSV text per piece of :func:`read_record_chunks` (about 35 000 rows of 3 columns).
#: Small on purpose: the resident memory of pyarrow's streaming reader grew to about 20
#: times its block size (390 MB for 16 MB blocks on a 300 MB file; 118 MB for 1 MB blocks).
STREAM_BYTES = 1 << 20


def read_record_chunks(path: str | Path, columns: Mapping[str, str] | None = None,
                       delimiter: str | None = None, block_bytes: int = STREAM_BYTES) -> Iterator[Record]:
    """Read a record in consecutive pieces, each a :class:`Record` of some thousand rows.

    Memory stays that of one piece whatever the record's length. The pieces hold exactly
    what :func:`read_record` would read (same metadata, units and time conversion); every
    piece's time follows the previous piece's.

    Parameters
    ----------
    path : str or Path
        CSV file (not compressed).
    columns, delimiter
        As :func:`read_record`.
    block_bytes : int
        CSV text per piece.

    Yields
    ------
    Record

    Raises
    ------
    NotStreamable
        When the file is not a plain, well-formed CSV record: read it with :func:`read_record`
        instead (it words any problem). This can happen after some pieces were yielded.
    InputError
        For problems of the header (missing column, unknown time unit).
    """
    import pyarrow as pa
    import pyarrow.csv as pacsv

    p = Path(path)
    _check_delimiter(delimiter)
    if p.suffix.lower() in (".gz", ".mat", ".xlsx") or not p.is_file():
        raise NotStreamable(str(p))
    source = str(p)
    mapping = {k.lower(): v for k, v in (columns or {}).items()}
    try:
        fh = p.open("rb")
    except OSError:
        raise NotStreamable(source) from None
    with fh:
        try:
            head = _fast_head(fh, source, mapping, delimiter)
        except _Slow:
            raise NotStreamable(source) from None
        scale = _apply_units(head.metadata, head.units_row, head.index, source)
        try:
            reader = pacsv.open_csv(fh, **head.csv_options(block_bytes))
        except (pa.ArrowException, ValueError):
            raise NotStreamable(source) from None
        last_time, rows = None, 0
        while True:
            try:
                batch = reader.read_next_batch()
            except StopIteration:
                break
            except (pa.ArrowException, ValueError):
                raise NotStreamable(source) from None
            n = batch.num_rows
            if n == 0:
                continue
            arrays = {}
            for name, c in head.wanted.items():
                col = batch.column(c)
                if col.null_count:
                    raise NotStreamable(source)
                arrays[name] = col.to_numpy(zero_copy_only=False)
                if not np.isfinite(arrays[name]).all():
                    raise NotStreamable(source)
            for name, col in head.index.items():
                if isinstance(col, float):
                    arrays[name] = np.full(n, col)
            if scale != 1.0:
                arrays["time"] = arrays["time"] * scale
            t = arrays["time"]
            if not (np.all(np.diff(t) > 0) and (last_time is None or t[0] > last_time)):
                raise NotStreamable(source)
            last_time = float(t[-1])
            rows += n
            yield Record(source=source, metadata=dict(head.metadata),
                         **{name: arrays.get(name) for name in COLUMNS})
        if rows == 0:
            raise NotStreamable(source)


def _is_header(line: str, mapping: Mapping[str, str], delimiter: str | None,
               metadata: dict) -> bool:
    """True for the header line; a ``# key: value`` line before it goes into ``metadata``."""
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
    d = delimiter or _sniff_delimiter(line)
    fields = [f.strip() for f in next(csv.reader([line], delimiter=d))]
    wanted = [v for v in mapping.values() if not _is_number(v)]
    return all(any(f.lower() == w.lower() for f in fields) for w in wanted)


def _resolve_columns(header: list[str], mapping: Mapping[str, str], source: str,
                     header_at: int) -> dict[str, int | float]:
    """Record column -> index in the header (or a constant value); raise for missing ones."""
    lowered = [h.lower() for h in header]
    index: dict[str, int | float] = {}
    for name in COLUMNS:
        wanted = mapping.get(name, name if name not in mapping else None)
        if name in mapping and _is_number(mapping[name]) and mapping[name].lower() not in lowered:
            index[name] = float(mapping[name])
            continue
        if wanted is not None and wanted.lower() in lowered:
            index[name] = lowered.index(wanted.lower())
        elif name in mapping:
            raise InputError(f"{source}, line {header_at + 1}: mapped column '{mapping[name]}' for "
                             f"'{name}' not found; columns found: {', '.join(header)}")
    missing = [c for c in REQUIRED if c not in index]
    if missing:
        raise InputError(f"{source}, line {header_at + 1}: missing required column"
                         f"{'s' if len(missing) > 1 else ''} {', '.join(repr(m) for m in missing)}; "
                         f"columns found: {', '.join(header)} (map others with --columns)")
    return index


def _merge_duplicate_times(arrays: dict) -> tuple[dict, int]:
    """Average the rows of each run of equal time stamps (time must not go backwards)."""
    t = arrays["time"]
    if np.any(np.diff(t) < 0):
        return arrays, 0           # going backwards stays an error, reported by the caller
    starts = np.flatnonzero(np.diff(t, prepend=np.nan) != 0)
    counts = np.diff(np.append(starts, len(t)))
    merged = {name: np.add.reduceat(v, starts) / counts for name, v in arrays.items()}
    return merged, int(len(t) - len(starts))


def _check_time_order(t: np.ndarray, source: str, first_data: int, rows) -> None:
    dt = np.diff(t)
    bad = np.flatnonzero(dt <= 0)
    if bad.size:
        k = bad[0] + 1
        nonblank = [i for i, r in enumerate(rows) if r and any(f.strip() for f in r)]
        line_no = first_data + nonblank[k]
        what = "repeats the previous time" if dt[bad[0]] == 0 else "is earlier than the previous time"
        raise InputError(f"{source}, line {line_no}, column 'time': {t[k]:g} {what} "
                         f"({t[k - 1]:g}); time must be strictly increasing")


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _row_is_numeric(row, index) -> bool:
    for col in index.values():
        if isinstance(col, float) or col >= len(row):
            continue
        if not _is_number(row[col].strip()):
            return False
    return True


@dataclass(frozen=True)
class RecordScan:
    """What one pass over a record file learns without holding it (:func:`scan_record`).

    Attributes
    ----------
    source : str
    metadata : dict
    names : tuple of str
        The columns present, in contract order.
    samples : int
    first_time, last_time : float
        Times of the first and last samples (s).
    step_min, step_max : float
        Smallest and largest time step (s; NaN for one sample).
    first_load, largest_load : float
        The first load and the largest ``|load|``.
    load_change_count : int
        Samples ``i`` where ``load[i] != load[i - 1]``.
    load_changes : numpy.ndarray or None
        Those ``i``; None when there are more than the scan kept.
    """

    source: str
    metadata: dict
    names: tuple
    samples: int
    first_time: float
    last_time: float
    step_min: float
    step_max: float
    first_load: float
    largest_load: float
    load_change_count: int
    load_changes: np.ndarray | None

    def unit(self, column: str) -> str:
        """The unit named in metadata ``units.<column>``, or an empty string."""
        return str(self.metadata.get(f"units.{column}", ""))

    @classmethod
    def of(cls, record: Record, pieces: Iterator[Record] | None = None,
           max_changes: int = 0) -> "RecordScan":
        """The scan of a record held in memory, or of its pieces (``record`` the first)."""
        n, first, last = 0, float(record.time[0]), None
        step_min, step_max, largest = math.inf, -math.inf, 0.0
        count, changes, prev_load = 0, [], None
        for piece in ([record] if pieces is None else pieces):
            t, load = piece.time, piece.load
            steps = np.diff(t) if last is None else np.diff(t, prepend=last)
            if steps.size:
                step_min, step_max = min(step_min, float(steps.min())), max(step_max, float(steps.max()))
            jumps = np.flatnonzero(load[1:] != load[:-1]) + 1 + n
            if prev_load is not None and load[0] != prev_load:
                jumps = np.concatenate(([n], jumps))
            count += len(jumps)
            if count <= max_changes:
                changes.append(jumps)
            largest = max(largest, float(np.max(np.abs(load))))
            n, last, prev_load = n + len(t), float(t[-1]), float(load[-1])
        if n < 2:
            step_min = step_max = math.nan
        return cls(record.source, dict(record.metadata),
                   tuple(name for name in COLUMNS if getattr(record, name) is not None), n, first,
                   last, step_min, step_max, float(record.load[0]), largest, count,
                   (np.concatenate(changes).astype(np.int64) if changes else np.zeros(0, np.int64))
                   if count <= max_changes else None)


def scan_record(path: str | Path, columns: Mapping[str, str] | None = None,
                delimiter: str | None = None, max_changes: int = 0,
                progress: Callable[[int], None] | None = None,
                block_bytes: int = STREAM_BYTES) -> RecordScan:
    """One pass over a record file in pieces (:func:`read_record_chunks`): its length, time
    span and steps, load range and load changes, in the memory of one piece.

    Parameters
    ----------
    path, columns, delimiter
        As :func:`read_record_chunks`.
    max_changes : int
        Keep the indices of up to this many load changes (they are counted in any case).
    progress : callable, optional
        Called as ``progress(rows_read)``.

    Raises
    ------
    NotStreamable
        As :func:`read_record_chunks`.
    """
    pieces = read_record_chunks(path, columns, delimiter, block_bytes)
    first = next(pieces)

    def counted():
        done = 0
        for piece in _chain_first(first, pieces):
            done += len(piece)
            if progress:
                progress(done)
            yield piece

    return RecordScan.of(first, counted(), max_changes)


def _chain_first(first, rest):
    yield first
    yield from rest


@contextlib.contextmanager
def record_writer(path: str | Path, names: list[str], metadata: Mapping[str, str],
                  digits: int | None = None) -> Iterator[Callable[[Mapping[str, np.ndarray]], None]]:
    """Write a record piece by piece, atomically: the file appears, complete, when the block
    ends, and not at all when it raises (:mod:`creepcomp.io.atomic`).

    Parameters
    ----------
    path : str or Path
    names : list of str
        The columns, in order.
    metadata : mapping
        ``# key: value`` lines.
    digits : int, optional
        Write numbers rounded to this many significant digits (``%g``) instead of exactly
        (shortest round-trip form: ``0.2`` stays ``0.2``).

    Yields
    ------
    callable
        ``write(columns)``: append rows, one array per name (equal lengths).
    """
    import pyarrow as pa
    import pyarrow.csv as pacsv

    from creepcomp.io.atomic import atomic_path

    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(p) as tmp, tmp.open("wb") as fh:
        head = "".join(f"# {key}: {value}\n" for key, value in metadata.items()) + ",".join(names) + "\n"
        fh.write(head.encode("utf-8"))
        options = pacsv.WriteOptions(include_header=False)

        def write(columns: Mapping[str, np.ndarray]) -> None:
            for lo in range(0, len(columns[names[0]]), WRITE_ROWS):
                part = {k: np.asarray(columns[k], dtype=float)[lo:lo + WRITE_ROWS] for k in names}
                if digits is None:
                    pacsv.write_csv(pa.table(part), fh, options)
                else:
                    np.savetxt(fh, np.column_stack(list(part.values())), delimiter=",",
                               fmt=f"%.{int(digits)}g")

        yield write


def write_record(path: str | Path, record: Record, extra: Mapping[str, np.ndarray] | None = None,
                 metadata: Mapping[str, str] | None = None, digits: int | None = None,
                 progress: Callable[[int, int], None] | None = None) -> Path:
    """Write a record (plus extra columns) as CSV with its metadata lines, atomically.

    Numbers are written in their shortest form that reads back as the same float (``0.2``
    stays ``0.2``). The file appears complete or not at all (:mod:`creepcomp.io.atomic`).

    Parameters
    ----------
    path : str or Path
    record : Record
    extra : mapping, optional
        More columns, one value per sample.
    metadata : mapping, optional
        ``# key: value`` lines added to the record's.
    digits : int, optional
        Write numbers rounded to this many significant digits (``%g``) instead of exactly.
    progress : callable, optional
        Called as ``progress(rows_written, rows)`` while writing.
    """
    cols = dict(record.columns())
    for name, values in (extra or {}).items():
        values = np.asarray(values, dtype=float)
        if values.shape != record.time.shape:
            raise InputError(f"column '{name}' has {values.size} values for {len(record)} samples")
        cols[name] = values
    meta = dict(record.metadata)
    meta.update(metadata or {})
    n = len(record)
    with record_writer(path, list(cols), meta, digits) as write:
        for lo in range(0, n, WRITE_ROWS):
            hi = min(lo + WRITE_ROWS, n)
            write({k: v[lo:hi] for k, v in cols.items()})
            if progress:
                progress(hi, n)
    return Path(path)
