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

Three readers share the checks of :mod:`creepcomp.io.record_check`: the line reader
(:func:`parse_record`), which words every fault; pyarrow reading a whole file
(:func:`read_record`), which leaves a file to the line reader when its head or data are not
plain; and pyarrow reading a file in pieces (:func:`open_record_stream`), which says when a
file is to be read whole instead.
"""

from __future__ import annotations

import contextlib
import csv
import io
import itertools
import math
import os
import stat
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable, Iterator, Mapping

import numpy as np

from creepcomp.display import Shown, data_frame
from creepcomp.errors import InputError
from creepcomp.io.inputs import check_input_file, gunzipped, open_input
from creepcomp.io.record_check import (COLUMNS, OPTIONAL, REQUIRED, TIME_UNITS_TO_SECONDS,
                                       RecordHead, all_finite, apply_units, check_arrays,
                                       check_delimiter, check_time_order, finish_arrays,
                                       lower_keys, no_header_error, resolve_columns, row_values,
                                       sniff_delimiter, split_fields, take_header_line,
                                       time_increases)

__all__ = ["REQUIRED", "OPTIONAL", "COLUMNS", "TIME_UNITS_TO_SECONDS", "Record", "check_arrays",
           "parse_columns", "read_record", "parse_record", "write_record", "WRITE_ROWS",
           "NotStreamable", "STREAM_BYTES", "WHOLE_PIECES", "reads_whole", "RecordStream",
           "open_record_stream", "read_record_chunks", "record_writer", "RecordScan", "scan_record"]

#: Rows per block when writing a record (bounds the memory of the text being written).
WRITE_ROWS = 500_000
#: Lines read before the header by the pyarrow readers (beyond that the line reader takes over).
FAST_HEADER_LINES = 10_000
#: Bytes of CSV text per piece of :func:`open_record_stream` (about 35 000 rows of 3 columns).
#: Small on purpose: the resident memory of pyarrow's streaming reader grew to about 20
#: times its block size (390 MB for 16 MB blocks on a 300 MB file; 118 MB for 1 MB blocks).
STREAM_BYTES = 1 << 20
#: Files the piecewise reader leaves to other readers (:func:`creepcomp.io.formats.read_any`).
NOT_STREAMED_SUFFIXES = (".gz", ".mat", ".xlsx")
#: :func:`creepcomp.fit.reduce.read_reduced` reads a file of at most this many pieces of CSV
#: text whole (32 MiB for the default pieces, about 1.3 million rows of three columns): one
#: parse instead of the two passes of the piecewise reduction, for a peak memory of about five
#: times the file's size (the piecewise passes hold about 70 MB, whatever the size): up to this
#: size, below the peak of the fit of the reduced record that follows (about 300 MB for 50,000
#: samples).
WHOLE_PIECES = 32


def reads_whole(path: str | Path, duplicate_times: str = "error", taxel: int | None = None,
                sheet: str | None = None, block_bytes: int = STREAM_BYTES) -> bool:
    """Whether :func:`creepcomp.fit.reduce.read_reduced` reads the record file whole
    (:func:`creepcomp.io.formats.read_any`) rather than in pieces: anything but a plain CSV
    file of more than :data:`WHOLE_PIECES` pieces of ``block_bytes`` read with repeated time
    stamps an error (the piecewise reader may still leave a file to the whole one)."""
    return not (duplicate_times.strip().lower() == "error" and taxel is None and sheet is None
                and _file_bytes(path) > WHOLE_PIECES * block_bytes)


def _file_bytes(path) -> int:
    """Size of a regular file; 0 for anything else (the whole reader words what it is)."""
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        return 0
    return st.st_size if stat.S_ISREG(st.st_mode) else 0


@dataclass(frozen=True, eq=False)
class Record(Shown):
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

    def __repr__(self) -> str:
        from creepcomp.units import format_quantity, format_time

        ranges = ", ".join(f"{c} {format_quantity(float(getattr(self, c).min()), self.unit(c))} to "
                           f"{format_quantity(float(getattr(self, c).max()), self.unit(c))}"
                           for c in ("load", "signal"))
        return f"<Record {self.source!r}: {len(self)} samples over {format_time(self.duration)}; {ranges}>"

    def to_dict(self) -> dict:
        """JSON form of what the record is (the columns' data: :meth:`to_pandas`): source,
        samples, duration (s), the columns present, units and metadata."""
        return {"source": self.source, "samples": len(self), "duration_s": self.duration,
                "columns": [c for c in COLUMNS if getattr(self, c) is not None],
                "units": {c: self.unit(c) for c in COLUMNS if self.unit(c)},
                "metadata": {str(k): str(v) for k, v in self.metadata.items()}}

    def to_pandas(self):
        """The columns as a pandas DataFrame (pandas needed; imported here)."""
        return data_frame({c: getattr(self, c) for c in COLUMNS if getattr(self, c) is not None})

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


def read_record(path, columns: Mapping[str, str] | None = None,
                delimiter: str | None = None, duplicate_times: str = "error",
                metadata: Mapping[str, str] | None = None) -> Record:
    """Read and check a measured record: from a file, an open file, a data frame or arrays.

    A plain file is read by pyarrow; a file whose head or data are not plain (a blank or
    non-numeric cell, a short row, time not increasing ...) by the line reader
    (:func:`parse_record`), which names the line and column of the first problem. Columns
    held in memory are matched by name in the same way and checked in the same way (numbers,
    finite, time strictly increasing); nothing is converted or dropped.

    Parameters
    ----------
    path : str, Path, file object, data frame, mapping or Record
        A CSV file, or a gzip-compressed one (``.gz``: decompressed into a temporary file, with
        the bound of :func:`creepcomp.io.inputs.gzip_limit`); an open file of CSV text (text
        or bytes); a data frame (pandas, polars, a pyarrow table, or any object with
        ``columns`` and ``frame[name]``: neither pandas nor polars is needed otherwise) or a
        numpy structured array; a mapping of column name -> array. A :class:`Record` is
        returned as it is.
    columns : mapping, optional
        Record column -> the file's (or frame's) column name (or a constant number).
    delimiter : str, optional
        Field delimiter; default: detected from the header (comma, tab or semicolon).
    duplicate_times : {"error", "mean"}
        Repeated time stamps are an error, or (asked for explicitly, e.g. for files whose
        time stamps were rounded) the rows sharing a time are averaged; the number merged is
        kept in ``metadata["merged_duplicate_times"]``.
    metadata : mapping, optional
        ``key: value`` pairs added to the record's (``units.load``, ``units.signal`` ...; a
        key given here wins over the file's).

    Returns
    -------
    Record

    Raises
    ------
    InputError
        Naming the file, line and column of the first problem (the sample of a column in
        memory); or the file and the reason when it cannot be read; or the type of an object
        that is none of the above.

    Examples
    --------
    The force-sensor record that ships with the package:

    >>> from creepcomp.data import path
    >>> record = read_record(path("hidden_effect.csv"))
    >>> len(record), list(record.columns())
    (3001, ['time', 'load', 'signal'])
    >>> record.unit("load"), record.unit("signal"), record.duration
    ('N', 'V', 1500.0)

    Arrays (or a data frame) with the columns' units:

    >>> import numpy as np
    >>> t = np.arange(5.0)
    >>> arrays = {"Time": t, "load": [0, 1, 1, 1, 1], "signal": 2.0 * t}
    >>> read_record(arrays, metadata={"units.signal": "V"}).unit("signal")
    'V'
    >>> read_record({"time": [0.0, 2.0, 1.0], "load": [0, 1, 1], "signal": [0, 1, 2]})
    Traceback (most recent call last):
    ...
    creepcomp.errors.InputError: dict: time is not strictly increasing: sample 2 (1 s) goes back from the previous one (2 s)
    """
    if metadata:
        record = read_record(path, columns, delimiter, duplicate_times)
        return replace(record, metadata={**record.metadata, **metadata})
    if not isinstance(path, (str, os.PathLike)):
        return _read_object(path, columns, delimiter, duplicate_times)
    p = Path(path)
    check_delimiter(delimiter)
    check_input_file(p, "record")
    if p.suffix.lower() == ".gz":
        with gunzipped(p, "record") as plain:
            return _read_plain(plain, str(p), columns, delimiter, duplicate_times)
    return _read_plain(p, str(p), columns, delimiter, duplicate_times)


def _read_object(obj, columns, delimiter, duplicate_times) -> Record:
    """:func:`read_record` of what is not a path: a Record, an open file or named columns."""
    from creepcomp.io.columnar import column_arrays, named_columns

    if isinstance(obj, Record):
        if columns:
            raise InputError(f"{obj.source}: a Record's columns are named already; "
                             "give no column mapping")
        return obj
    if hasattr(obj, "read"):
        return _read_open_file(obj, columns, delimiter, duplicate_times)
    if named_columns(obj) is None:
        raise InputError(f"record: a {type(obj).__module__}.{type(obj).__qualname__} is not a "
                         "record: give a file's path, an open file, a data frame (pandas, "
                         "polars, or any object with named columns) or a mapping of column "
                         "name -> array")
    source = type(obj).__name__
    if delimiter is not None:
        raise InputError(f"{source}: a delimiter is for text; columns in memory have none")
    mapping = {k: str(v) for k, v in lower_keys(columns).items()}
    arrays, metadata = column_arrays(obj, mapping, source, duplicate_times)
    return Record(source=source, metadata=metadata, **{name: arrays.get(name) for name in COLUMNS})


def _read_open_file(fh, columns, delimiter, duplicate_times) -> Record:
    """:func:`read_record` of an open file of CSV text (text, or bytes of UTF-8 text): its
    content goes to a temporary file read as any file is (the same readers, checks and
    messages, naming the open file's name)."""
    import tempfile

    check_delimiter(delimiter)
    name = getattr(fh, "name", None)
    source = str(name) if isinstance(name, (str, os.PathLike)) else "open file"
    try:
        data = fh.read()
    except OSError as exc:
        raise InputError(f"record {source}: cannot read it ({exc.strerror or exc})") from None
    if isinstance(data, str):
        data = data.encode("utf-8")
    elif not isinstance(data, bytes):
        raise InputError(f"record {source}: read() gave a {type(data).__name__}, not text")
    if data[:2] == b"\x1f\x8b":
        raise InputError(f"record {source}: gzip-compressed: give its path, or open it "
                         "with gzip.open(path, 'rt')")
    with tempfile.TemporaryDirectory(prefix="creepcomp-record-") as folder:
        copy = Path(folder) / "record.csv"
        copy.write_bytes(data)
        del data
        return _read_plain(copy, source, columns, delimiter, duplicate_times)


def _read_plain(p: Path, source: str, columns, delimiter, duplicate_times) -> Record:
    """:func:`read_record` of a plain text file; ``source`` names it in messages."""
    record = _read_fast(p, lower_keys(columns), delimiter, duplicate_times, source)
    if record is not None:
        return record
    with _open(p) as fh:
        text = io.TextIOWrapper(fh, encoding="utf-8-sig", newline="")
        try:
            return _parse_lines(_split_lines(text), source, columns, delimiter, duplicate_times)
        except UnicodeDecodeError as exc:
            raise InputError(f"record {source}: not UTF-8 text ({exc.reason} at byte "
                             f"{_first_bad_byte(p)})") from None
        except OSError as exc:
            raise _read_error(Path(source), exc) from None


def _split_lines(text: Iterator[str]) -> Iterator[str]:
    """The lines of a text file as ``str.splitlines`` would give them for its whole text,
    read one at a time (the file opened with ``newline=""``)."""
    for line in text:
        yield from line.splitlines()


def _first_bad_byte(path: Path) -> int:
    """Offset of the first byte of ``path`` that is not UTF-8 (read in blocks)."""
    import codecs

    decoder = codecs.getincrementaldecoder("utf-8")()
    position = 0
    with _open(path) as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            pending = len(decoder.getstate()[0])
            try:
                decoder.decode(block)
            except UnicodeDecodeError as exc:
                return position - pending + exc.start
            position += len(block)
    return position


def _read_error(path: Path, exc: OSError) -> InputError:
    """The message for a record file that cannot be opened or read."""
    if isinstance(exc, FileNotFoundError):
        return InputError(f"record {path}: no such file")
    return InputError(f"record {path}: cannot read it ({exc.strerror})")


def _open(path: Path):
    """``path`` checked (:func:`~creepcomp.io.inputs.check_input_file`) and opened for reading
    bytes; an :class:`InputError` when it cannot be."""
    try:
        return open_input(path, "record")
    except OSError as exc:
        raise _read_error(path, exc) from None


def parse_record(text: str, source: str = "record", columns: Mapping[str, str] | None = None,
                 delimiter: str | None = None, duplicate_times: str = "error") -> Record:
    """Parse record text line by line (see :func:`read_record`).

    Faults are found in this order: the header (a missing or unmapped column, an unknown
    time unit), the cells row by row, no data, the time order.
    """
    return _parse_lines(iter(text.splitlines()), source, columns, delimiter, duplicate_times)


def _parse_lines(lines: Iterator[str], source: str, columns: Mapping[str, str] | None,
                 delimiter: str | None, duplicate_times: str) -> Record:
    """:func:`parse_record` over lines read one at a time: the memory is the values read
    (8 bytes each), not the text."""
    from array import array

    check_delimiter(delimiter)
    mapping = lower_keys(columns)
    metadata: dict[str, str] = {}
    header_at = None
    for i, line in enumerate(lines):
        if take_header_line(line, mapping, delimiter, metadata):
            header_at, header_line = i, line
            break
    if header_at is None:
        raise no_header_error(source, mapping)
    d = delimiter or sniff_delimiter(header_line)
    reader = _csv_rows(csv.reader(itertools.chain([header_line], lines), delimiter=d), source, header_at)
    header = [h.strip() for h in next(reader)]
    column_map = resolve_columns(header, mapping, source, header_at)
    first = next(reader, None)
    units_row = first if mapping and first is not None and column_map.is_units_row(first) else None
    head = RecordHead(source, metadata, column_map, d, header_at, units_row)
    rows = reader if first is None or units_row is not None else itertools.chain([first], reader)
    time_scale = apply_units(head)
    values = [array("d") for _ in column_map.read]
    line_of_sample = array("q")
    for offset, row in enumerate(rows):
        line_no = head.first_data_line + offset
        row_of_values = row_values(row, head, line_no)
        if row_of_values is None:
            continue
        for column, x in zip(values, row_of_values):
            column.append(x)
        line_of_sample.append(line_no)
    arrays = {name: np.frombuffer(v, dtype=float).copy() if len(v) else np.zeros(0)
              for name, v in zip(column_map.read, values)}
    del values
    arrays.update(column_map.constant_arrays(len(line_of_sample)))
    arrays = finish_arrays(arrays, head, time_scale, duplicate_times)
    check_time_order(arrays["time"], source, line_of_sample.__getitem__)
    return Record(source=source, metadata=metadata, **{name: arrays.get(name) for name in COLUMNS})


def _csv_rows(reader, source: str, header_at: int) -> Iterator[list[str]]:
    """The rows of a csv reader that starts at the header line; a csv fault (a field over
    the csv module's limit of 128 KiB, which cannot be a number or a unit) as one InputError
    naming the line."""
    while True:
        try:
            row = next(reader)
        except StopIteration:
            return
        except csv.Error as exc:
            raise InputError(f"{source}, line {header_at + reader.line_num}: {exc}") from None
        yield row


def _read_head(fh, source: str, mapping: dict, delimiter: str | None) -> RecordHead | None:
    """The head of the binary file ``fh`` (up to the header and a units row), leaving ``fh``
    at the first data line; None when the head is for the line reader: a line that is not
    UTF-8 or holds other line separators, or no header in the first
    :data:`FAST_HEADER_LINES` lines. Raise for a missing column."""
    metadata: dict[str, str] = {}
    header_at, header_line = None, None
    for i in range(FAST_HEADER_LINES):
        raw = fh.readline()
        if not raw:
            break
        line = _decode(raw, "utf-8-sig" if i == 0 else "utf-8")
        if line is None or len(line.splitlines()) > 1:
            return None
        if take_header_line(line, mapping, delimiter, metadata):
            header_at, header_line = i, line
            break
    if header_at is None:
        return None
    d = delimiter or sniff_delimiter(header_line)
    header = [h.strip() for h in split_fields(header_line, d, f"{source}, line {header_at + 1}")]
    column_map = resolve_columns(header, mapping, source, header_at)
    start = fh.tell()
    units_row = None
    if mapping:
        line = _decode(fh.readline(), "utf-8")
        if line is None:
            return None
        row = split_fields(line, d, f"{source}, line {header_at + 2}")
        if column_map.is_units_row(row):
            units_row, start = row, fh.tell()
    fh.seek(start)
    return RecordHead(source, metadata, column_map, d, header_at, units_row)


def _decode(raw: bytes, encoding: str) -> str | None:
    try:
        return raw.decode(encoding)
    except UnicodeDecodeError:
        return None


def _csv_options(head: RecordHead, block_size: int | None = None) -> dict:
    """pyarrow CSV options that read the head's file columns as float64 (named ``c<index>``)."""
    import pyarrow as pa
    import pyarrow.csv as pacsv

    wanted = sorted({f"c{index}" for index in head.columns.read.values()})
    read = pacsv.ReadOptions(column_names=[f"c{k}" for k in range(len(head.columns.header))],
                             **({"block_size": block_size} if block_size else {}))
    return {"read_options": read, "parse_options": pacsv.ParseOptions(delimiter=head.delimiter),
            "convert_options": pacsv.ConvertOptions(include_columns=wanted,
                                                    column_types={c: pa.float64() for c in wanted})}


def _columns_of(table, head: RecordHead) -> dict:
    """Record column -> its pyarrow column in ``table`` (read with :func:`_csv_options`)."""
    return {name: table.column(f"c{index}") for name, index in head.columns.read.items()}


def _plain_arrays(columns: dict, head: RecordHead, n: int) -> dict[str, np.ndarray] | None:
    """The record's columns from pyarrow's float64 columns (each released once converted, to
    bound memory) and its constants; None when a cell is blank or a value is not finite."""
    if any(column.null_count for column in columns.values()):
        return None
    arrays = {}
    for name in list(columns):
        chunks = columns.pop(name).chunks
        arrays[name] = np.concatenate([c.to_numpy(zero_copy_only=False) for c in chunks])
        del chunks
    if not all_finite(arrays):
        return None
    arrays.update(head.columns.constant_arrays(n))
    return arrays


def _read_fast(path: Path, mapping: dict, delimiter: str | None,
               duplicate_times: str, source: str | None = None) -> Record | None:
    """Read a plain record with pyarrow's CSV reader (fast, little memory); None when the
    file is for the line reader, which names the line and column of a problem.

    Only the lines up to the header (and a units row) are parsed in Python; the data go to
    pyarrow as float64. A blank or non-numeric cell, a short or long row, no data, a
    non-finite value, time not increasing or a head the line reader must read
    (:func:`_read_head`) leave the file to the line reader.
    """
    import pyarrow as pa
    import pyarrow.csv as pacsv

    source = str(path) if source is None else source
    with _open(path) as fh:
        head = _read_head(fh, source, mapping, delimiter)
        if head is None:
            return None
        time_scale = apply_units(head)
        try:
            table = pacsv.read_csv(fh, **_csv_options(head))
        except (pa.ArrowException, ValueError):
            return None
    n = table.num_rows
    arrays = _plain_arrays(_columns_of(table, head), head, n) if n else None
    del table
    if arrays is None:
        return None
    arrays = finish_arrays(arrays, head, time_scale, duplicate_times)
    if not time_increases(arrays["time"]):
        return None
    return Record(source=source, metadata=head.metadata,
                  **{name: arrays.get(name) for name in COLUMNS})


class NotStreamable(Exception):
    """Raised by :func:`read_record_chunks` and :func:`scan_record` for a record to read
    whole (:func:`read_record`) instead: :attr:`RecordStream.whole_reason` says why."""


class RecordStream:
    """A record file read in consecutive pieces, each a :class:`Record` of some thousand
    rows, in the memory of one piece (:func:`open_record_stream`).

    The pieces hold exactly what :func:`read_record` would read (same metadata, units and
    time conversion); every piece's time follows the previous piece's. A file that is not
    a plain CSV record is read whole instead: :attr:`whole_reason` says so, before any
    piece, or when a piece holds something only the line reader words (a bad cell, time
    going back); the iteration then ends early. The stream can be iterated more than once
    (each pass reads the file again).

    Attributes
    ----------
    source : str
        The file.
    """

    def __init__(self, path: Path, head: RecordHead | None, data_start: int, block_bytes: int,
                 refused: str | None = None):
        self.source = str(path)
        self._path, self._head, self._data_start = path, head, data_start
        self._block_bytes = block_bytes
        self._refused, self._stopped = refused, None
        self._time_scale = apply_units(head) if head is not None else 1.0

    @property
    def whole_reason(self) -> str | None:
        """Why the file is to be read whole (:func:`read_record`), or None while its pieces
        are all a plain record."""
        return self._refused or self._stopped

    def __iter__(self) -> Iterator[Record]:
        import pyarrow as pa
        import pyarrow.csv as pacsv

        self._stopped = None
        if self._refused is not None:
            return
        head = self._head
        with _open(self._path) as fh:
            fh.seek(self._data_start)
            try:
                reader = pacsv.open_csv(fh, **_csv_options(head, self._block_bytes))
            except (pa.ArrowException, ValueError) as exc:
                self._stopped = f"pyarrow cannot read it as CSV ({exc})"
                return
            last_time, rows = None, 0
            while True:
                try:
                    batch = reader.read_next_batch()
                except StopIteration:
                    break
                except (pa.ArrowException, ValueError) as exc:
                    self._stopped = f"pyarrow cannot read the rows after row {rows} ({exc})"
                    return
                n = batch.num_rows
                if n == 0:
                    continue
                arrays = _plain_arrays(_columns_of(pa.Table.from_batches([batch]), head), head, n)
                if arrays is None:
                    self._stopped = f"a blank cell or a value that is not finite after row {rows}"
                    return
                if self._time_scale != 1.0:
                    arrays["time"] = arrays["time"] * self._time_scale
                if not time_increases(arrays["time"], last_time):
                    self._stopped = f"time not strictly increasing after row {rows}"
                    return
                last_time = float(arrays["time"][-1])
                rows += n
                yield Record(source=self.source, metadata=dict(head.metadata),
                             **{name: arrays.get(name) for name in COLUMNS})
        if rows == 0:
            self._stopped = "nothing after the header"

    def scan(self, max_changes: int = 0,
             progress: Callable[[int], None] | None = None) -> RecordScan | None:
        """One pass over the pieces (:class:`RecordScan`); None when the file is to be read
        whole (:attr:`whole_reason`).

        Parameters
        ----------
        max_changes : int
            Keep the indices of up to this many load changes (they are counted in any case).
        progress : callable, optional
            Called as ``progress(rows_read)``.
        """
        pieces = iter(self)
        first = next(pieces, None)
        if first is None:
            return None

        def counted():
            done = 0
            for piece in itertools.chain([first], pieces):
                done += len(piece)
                if progress:
                    progress(done)
                yield piece

        scan = RecordScan.of(first, counted(), max_changes)
        return None if self.whole_reason is not None else scan


def open_record_stream(path: str | Path, columns: Mapping[str, str] | None = None,
                       delimiter: str | None = None,
                       block_bytes: int = STREAM_BYTES) -> RecordStream:
    """A record file to read in pieces (:class:`RecordStream`), or to read whole.

    Parameters
    ----------
    path : str or Path
        CSV file (not compressed).
    columns, delimiter
        As :func:`read_record`.
    block_bytes : int
        CSV text per piece.

    Returns
    -------
    RecordStream
        Its :attr:`~RecordStream.whole_reason` is set already for a file that is not a plain
        CSV file (compressed, missing, a head that is not plain UTF-8 lines).

    Raises
    ------
    InputError
        For problems of the header (missing column, unknown time unit), or a file that
        cannot be opened.
    """
    p = Path(path)
    check_delimiter(delimiter)
    if p.suffix.lower() in NOT_STREAMED_SUFFIXES:
        return RecordStream(p, None, 0, block_bytes, f"a '{p.suffix}' file, not a plain CSV file")
    if not p.is_file():  # missing, a pipe, a device: the whole reader refuses it (never opened here)
        return RecordStream(p, None, 0, block_bytes, "not a file")
    with _open(p) as fh:
        head = _read_head(fh, str(p), lower_keys(columns), delimiter)
        start = fh.tell()
    if head is None:
        return RecordStream(p, None, 0, block_bytes,
                            "its head is not plain UTF-8 lines with a header in the first "
                            f"{FAST_HEADER_LINES} lines")
    return RecordStream(p, head, start, block_bytes)


def read_record_chunks(path: str | Path, columns: Mapping[str, str] | None = None,
                       delimiter: str | None = None, block_bytes: int = STREAM_BYTES) -> Iterator[Record]:
    """The pieces of a record file (:class:`RecordStream`), raising at the end of a file to
    read whole.

    Parameters
    ----------
    path, columns, delimiter, block_bytes
        As :func:`open_record_stream`.

    Yields
    ------
    Record

    Raises
    ------
    NotStreamable
        When the file is to be read with :func:`read_record` instead (it words any
        problem). This can happen after some pieces were yielded.
    InputError
        For problems of the header (missing column, unknown time unit).
    """
    stream = open_record_stream(path, columns, delimiter, block_bytes)
    yield from stream
    if stream.whole_reason is not None:
        raise NotStreamable(stream.source)


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
    """One pass over a record file in pieces (:meth:`RecordStream.scan`): its length, time
    span and steps, load range and load changes, in the memory of one piece.

    Parameters
    ----------
    path, columns, delimiter, block_bytes
        As :func:`open_record_stream`.
    max_changes : int
        Keep the indices of up to this many load changes (they are counted in any case).
    progress : callable, optional
        Called as ``progress(rows_read)``.

    Raises
    ------
    NotStreamable
        For a file to read whole (:attr:`RecordStream.whole_reason`).
    """
    stream = open_record_stream(path, columns, delimiter, block_bytes)
    scan = stream.scan(max_changes, progress)
    if scan is None:
        raise NotStreamable(stream.source)
    return scan


@contextlib.contextmanager
def record_writer(path: str | Path, names: list[str], metadata: Mapping[str, str],
                  digits: int | None = None) -> Iterator[Callable[[Mapping[str, np.ndarray]], None]]:
    """Write a record piece by piece, atomically: the file appears, complete, when the block
    ends, and not at all when it raises or the writer was discarded
    (:mod:`creepcomp.io.atomic`).

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
        ``write(columns)``: append rows, one array per name (equal lengths);
        ``write.discard()``: leave no file when the block ends.
    """
    from creepcomp.io.atomic import atomic_path

    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    try:
        with atomic_path(p) as tmp, tmp.open("wb") as fh:
            head = "".join(f"# {key}: {value}\n" for key, value in metadata.items()) + _csv_line(names)
            fh.write(head.encode("utf-8"))
            writer = _PieceWriter(fh, list(names), digits)
            yield writer
            if writer.discarded:
                raise _Discarded()        # atomic_path removes its file when the block raises
    except _Discarded:
        pass


def _is_text(values) -> bool:
    """A column of text cells (a list of str, or a numpy array of str or objects)."""
    if isinstance(values, np.ndarray):
        return values.dtype.kind in "OUS"
    return bool(len(values)) and isinstance(values[0], str)


def _csv_field(text: str) -> str:
    """One CSV field: quoted (quotes doubled) when it holds the delimiter, a quote, a line
    break or leading or trailing blanks; as it is otherwise."""
    if any(c in text for c in ',"\r\n') or text != text.strip():
        return '"' + text.replace('"', '""') + '"'
    return text


def _csv_line(names: list[str]) -> str:
    """A header line of column names."""
    return ",".join(_csv_field(str(n)) for n in names) + "\n"


class _Discarded(Exception):
    """A discarded :func:`record_writer` block: its file is removed, nothing is reported."""


class _PieceWriter:
    """The ``write`` of :func:`record_writer`."""

    def __init__(self, fh, names: list[str], digits: int | None):
        import pyarrow.csv as pacsv

        self._fh, self._names, self._digits = fh, names, digits
        self._options = pacsv.WriteOptions(include_header=False)
        self.discarded = False

    def __call__(self, columns: Mapping[str, np.ndarray]) -> None:
        import pyarrow as pa
        import pyarrow.csv as pacsv

        names = self._names
        if any(_is_text(columns[k]) for k in names):
            self._write_with_text(columns)
            return
        for lo in range(0, len(columns[names[0]]), WRITE_ROWS):
            part = {k: np.asarray(columns[k], dtype=float)[lo:lo + WRITE_ROWS] for k in names}
            if self._digits is None:
                pacsv.write_csv(pa.table(part), self._fh, self._options)
            else:
                np.savetxt(self._fh, np.column_stack(list(part.values())), delimiter=",",
                           fmt=f"%.{int(self._digits)}g")

    def _write_with_text(self, columns: Mapping[str, np.ndarray]) -> None:
        """Rows holding text columns (a record's extra columns passed through as they were
        written): each run of number columns is written as the other rows are, the text cells
        quoted where CSV needs it."""
        names = self._names
        n = len(columns[names[0]])
        for lo in range(0, n, WRITE_ROWS):
            hi = min(lo + WRITE_ROWS, n)
            parts = []
            for text, group in itertools.groupby(names, key=lambda k: _is_text(columns[k])):
                group = list(group)
                if text:
                    parts.append([",".join(_csv_field(str(columns[k][i])) for k in group)
                                  for i in range(lo, hi)])
                else:
                    parts.append(self._number_lines({k: columns[k][lo:hi] for k in group}))
            self._fh.write("".join(",".join(cells) + "\n" for cells in zip(*parts)).encode("utf-8"))

    def _number_lines(self, part: Mapping[str, np.ndarray]) -> list[str]:
        """The number columns' cells of rows, one text per row, written as :meth:`__call__`
        writes them."""
        import pyarrow as pa
        import pyarrow.csv as pacsv

        buffer = io.BytesIO()
        part = {k: np.asarray(v, dtype=float) for k, v in part.items()}
        if self._digits is None:
            pacsv.write_csv(pa.table(part), buffer, self._options)
        else:
            np.savetxt(buffer, np.column_stack(list(part.values())), delimiter=",",
                       fmt=f"%.{int(self._digits)}g")
        return buffer.getvalue().decode("ascii").splitlines()

    def discard(self) -> None:
        """Leave no file when the writer's block ends."""
        self.discarded = True


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
        More columns, one value per sample: numbers, or text cells (a list of str, such as
        a record's extra columns passed through: :mod:`creepcomp.io.extra_columns`), written
        as they are (quoted where CSV needs it).
    metadata : mapping, optional
        ``# key: value`` lines added to the record's.
    digits : int, optional
        Write numbers rounded to this many significant digits (``%g``) instead of exactly.
    progress : callable, optional
        Called as ``progress(rows_written, rows)`` while writing.
    """
    cols = dict(record.columns())
    for name, values in (extra or {}).items():
        if not _is_text(values):
            values = np.asarray(values, dtype=float)
        if len(values) != len(record) or (isinstance(values, np.ndarray) and values.ndim != 1):
            raise InputError(f"column '{name}' has {np.size(values)} values for {len(record)} samples")
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
