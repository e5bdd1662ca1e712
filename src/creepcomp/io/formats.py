"""One entry point for every file a record can come from, chosen by the file's suffix.

``.mat`` insole files (:mod:`creepcomp.io.insole`, a ``taxel`` is needed), ``.xlsx`` creep
workbooks (:mod:`creepcomp.io.wood`, a ``sheet`` unless there is one), gzip-compressed
records (``.gz``: the CSV inside is read as any record) and CSV/text records
(:func:`creepcomp.io.records.read_record`, with its column mapping and options).
"""

from __future__ import annotations

import gzip
from pathlib import Path
from typing import Mapping

from creepcomp.errors import InputError
from creepcomp.io.records import Record, parse_record, read_record

__all__ = ["read_any"]


def read_any(path: str | Path, columns: Mapping[str, str] | None = None, delimiter: str | None = None,
             duplicate_times: str = "error", taxel: int | None = None, sheet: str | None = None) -> Record:
    """Read a record from a CSV/text file, a gzip-compressed one, an insole ``.mat`` file or a
    creep ``.xlsx`` workbook.

    Parameters
    ----------
    path : str or Path
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
    p = Path(path)
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
    if suffix == ".gz":
        try:
            text = gzip.decompress(p.read_bytes()).decode("utf-8-sig")
        except FileNotFoundError:
            raise InputError(f"record {p}: no such file") from None
        except (OSError, EOFError, UnicodeDecodeError) as exc:
            raise InputError(f"record {p}: not gzip-compressed UTF-8 text ({exc})") from None
        return parse_record(text, source=str(p), columns=columns, delimiter=delimiter,
                            duplicate_times=duplicate_times)
    return read_record(p, columns, delimiter=delimiter, duplicate_times=duplicate_times)
