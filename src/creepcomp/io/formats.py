"""One entry point for every file a record can come from, chosen by the file's suffix.

``.mat`` insole files (:mod:`creepcomp.io.insole`, a ``taxel`` is needed), ``.xlsx`` creep
workbooks (:mod:`creepcomp.io.wood`, a ``sheet`` unless there is one), gzip-compressed
records (``.gz``: the CSV inside is read as any record, decompressed as it is read, with the
bound of :func:`creepcomp.io.inputs.gzip_limit`) and CSV/text records
(:func:`creepcomp.io.records.read_record`, with its column mapping and options). Every file is
checked first (:func:`creepcomp.io.inputs.check_input_file`): a pipe, a device or a folder is
refused before it is opened.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Mapping

from creepcomp.errors import InputError
from creepcomp.io.inputs import check_input_file
from creepcomp.io.records import Record, read_record

__all__ = ["read_any"]


def read_any(path: str | Path, columns: Mapping[str, str] | None = None, delimiter: str | None = None,
             duplicate_times: str = "error", taxel: int | None = None, sheet: str | None = None) -> Record:
    """Read a record from a CSV/text file, a gzip-compressed one, an insole ``.mat`` file or a
    creep ``.xlsx`` workbook.

    Anything that is not a path (an open file, a data frame, arrays, a :class:`Record`) goes
    to :func:`~creepcomp.io.records.read_record`: the API's functions that take a record read
    it here.

    Parameters
    ----------
    path : str, Path, or anything :func:`~creepcomp.io.records.read_record` takes
    columns, delimiter, duplicate_times
        As :func:`creepcomp.io.records.read_record` (text files only).
    taxel : int, optional
        The taxel of an insole ``.mat`` file (required there).
    sheet : str, optional
        The sheet (specimen) of an ``.xlsx`` workbook.

    Raises
    ------
    InputError
        For an option that does not apply to the file's kind, and every reader's own errors.
    """
    if not isinstance(path, (str, os.PathLike)):
        if taxel is not None or sheet is not None:
            raise InputError("a taxel or a sheet applies to .mat or .xlsx files only")
        return read_record(path, columns, delimiter=delimiter, duplicate_times=duplicate_times)
    p = Path(path)
    check_input_file(p, "record")
    suffix = p.suffix.lower()
    if suffix != ".mat" and taxel is not None:
        raise InputError(f"{p}: a taxel applies to insole .mat files only")
    if suffix != ".xlsx" and sheet is not None:
        raise InputError(f"{p}: a sheet applies to .xlsx workbooks only")
    if suffix in (".mat", ".xlsx") and (columns or delimiter):
        raise InputError(f"{p}: a column mapping or delimiter applies to text records only "
                         f"(a {suffix} file's columns are fixed)")
    if suffix == ".mat":
        from creepcomp.io.insole import read_insole, read_insole_file, working_taxels

        if taxel is None:
            good = working_taxels(read_insole_file(p))
            raise InputError(f"{p}: an insole file holds 280 taxels; name one (--taxel N), e.g. "
                             f"those that follow the pressure best: {good}")
        return read_insole(p, taxel)
    if suffix == ".xlsx":
        from creepcomp.io.wood import read_wood

        return read_wood(p, sheet)
    return read_record(p, columns, delimiter=delimiter, duplicate_times=duplicate_times)
