"""A record file's extra columns (those no record column is read from), read as the text of
their cells, row for row with the samples the record readers give: for commands that write
the record again with columns of their own (``correct -o``), so that nothing of the input
is dropped on the way (docs/record-format.md).

The cells are kept as text, exactly as the file has them (a number stays written as it was, a
note stays a note): an extra column is not read as a number by any command.
"""

from __future__ import annotations

import contextlib
import csv
import io
import itertools
from pathlib import Path
from typing import Iterator, Mapping, Sequence

from creepcomp.io.inputs import gunzipped, open_input
from creepcomp.io.record_check import (check_delimiter, lower_keys, no_header_error, resolve_columns,
                                       sniff_delimiter, take_header_line)

__all__ = ["ExtraColumns", "open_extra_columns", "output_names"]


def output_names(extra: Sequence[str], taken: Sequence[str]) -> list[str]:
    """The names the extra columns are written under: their own, except where one is
    (without regard to case) the name of a column the output has already (``taken``, e.g. a
    ``compensated`` column of a record corrected before): that one becomes ``input.NAME``
    (``input.NAME.2`` ... if that is taken too)."""
    used = {t.lower() for t in taken}
    out = []
    for name in extra:
        new, k = name, 1
        while new.lower() in used or not new:
            k += 1
            new = f"input.{name}" if k == 2 else f"input.{name}.{k - 1}"
        used.add(new.lower())
        out.append(new)
    return out


class ExtraColumns:
    """The extra columns of a record file, read piece by piece (:func:`open_extra_columns`).

    Attributes
    ----------
    names : list of str
        The file's names of its extra columns, in file order (empty: none); a column without a
        name is ``columnN`` (N: its place in the file, from 1).
    """

    def __init__(self, names: list[str], indices: list[int], rows: Iterator[list[str]] | None):
        self.names, self._indices, self._rows = names, indices, rows

    def take(self, n: int) -> dict[str, list[str]]:
        """The extra columns' cells of the next ``n`` samples (name -> texts; a missing field
        is an empty cell)."""
        if not self.names:
            return {}
        cells: list[list[str]] = [[] for _ in self.names]
        for row in itertools.islice(self._rows, n):
            for column, index in zip(cells, self._indices):
                column.append(row[index] if index < len(row) else "")
        return dict(zip(self.names, cells))


def _data_rows(reader) -> Iterator[list[str]]:
    """The rows of samples: blank rows are no sample for the record readers either."""
    for row in reader:
        if row and any(f.strip() for f in row):
            yield row


@contextlib.contextmanager
def open_extra_columns(path: str | Path, columns: Mapping[str, str] | None = None,
                       delimiter: str | None = None) -> Iterator[ExtraColumns]:
    """The extra columns of the record file ``path`` (plain or ``.gz`` CSV), with the column
    mapping and delimiter the record was read with. The file is the one the record was read
    from: its header, units row and blank rows are taken as the record readers take them, so
    the rows follow the record's samples one to one.

    Yields
    ------
    ExtraColumns
    """
    p = Path(path)
    check_delimiter(delimiter)
    with contextlib.ExitStack() as stack:
        if p.suffix.lower() == ".gz":
            p = stack.enter_context(gunzipped(p, "record"))
        fh = stack.enter_context(open_input(p, "record"))
        text = io.TextIOWrapper(fh, encoding="utf-8-sig", newline="")
        lines = (part for line in text for part in line.splitlines())
        mapping = lower_keys(columns)
        metadata: dict[str, str] = {}
        header_line = None
        for line in lines:
            if take_header_line(line, mapping, delimiter, metadata):
                header_line = line
                break
        if header_line is None:
            raise no_header_error(str(path), mapping)
        d = delimiter or sniff_delimiter(header_line)
        reader = csv.reader(itertools.chain([header_line], lines), delimiter=d)
        header = [h.strip() for h in next(reader)]
        column_map = resolve_columns(header, mapping, str(path), None)
        read = set(column_map.read.values())
        indices = [i for i in range(len(header)) if i not in read]
        if not indices:
            yield ExtraColumns([], [], None)
            return
        rows = _data_rows(reader)
        first = next(rows, None)
        if first is not None and not (mapping and column_map.is_units_row(first)):
            rows = itertools.chain([first], rows)
        yield ExtraColumns([header[i] or f"column{i + 1}" for i in indices], indices, rows)
