"""Which records a fleet run processes: files, folders and glob patterns, and each unit's name.

Only paths are handled here: no record is opened (the workers read them).
"""

from __future__ import annotations

import glob
import hashlib
import os
import re
from pathlib import Path
from typing import Iterable

from creepcomp.errors import InputError

__all__ = ["RECORD_SUFFIXES", "MAX_UNIT_NAME", "find_records", "safe_unit_name", "unit_names"]

#: File endings taken from a folder (a file named explicitly may have any ending).
RECORD_SUFFIXES = (".csv", ".tsv", ".txt")


def find_records(inputs: Iterable[str | Path], exclude: str | Path | None = None) -> list[Path]:
    """The record files named by ``inputs``: files, folders (their record files, recursively)
    and glob patterns (``lot7/*.csv``, ``lot*/**/*.csv``).

    Parameters
    ----------
    inputs : iterable of str or Path
    exclude : str or Path, optional
        A folder whose files are never records (a run's output folder inside the records'
        folder: its tables and corrected records).

    Returns
    -------
    list of Path
        Absolute paths, each once, in the order given (a folder's files and a pattern's
        matches sorted by name).

    Raises
    ------
    InputError
        When an input names nothing (a missing file, an empty folder, a pattern that matches
        no file), or when no input is given.
    """
    found: dict[Path, None] = {}
    given = list(inputs)
    if not given:
        raise InputError("no records given: name files, folders or glob patterns")
    skip = Path(exclude).expanduser().resolve() if exclude is not None else None
    for item in given:
        text = str(item)
        path = Path(text).expanduser()
        if path.is_file():
            files = [path]
        elif path.is_dir():
            files = sorted(p for p in path.rglob("*")
                           if p.is_file() and p.suffix.lower() in RECORD_SUFFIXES
                           and not any(part.startswith(".") for part in p.relative_to(path).parts))
            if not files:
                raise InputError(f"{text}: the folder holds no record files "
                                 f"({', '.join(RECORD_SUFFIXES)})")
        elif glob.has_magic(text):
            files = sorted(Path(p) for p in glob.glob(os.path.expanduser(text), recursive=True)
                           if Path(p).is_file())
            if not files:
                raise InputError(f"{text}: the pattern matches no file")
        else:
            raise InputError(f"{text}: no such file or folder")
        for f in files:
            f = f.resolve()
            if skip is None or skip not in f.parents:
                found.setdefault(f, None)
    if not found:
        raise InputError(f"no records left outside the output folder {exclude}")
    return list(found)


#: Longest unit name (characters): a longer one is cut and ends with a hash of its path.
MAX_UNIT_NAME = 100

_UNSAFE = re.compile(r"[^A-Za-z0-9._+-]")
#: A name's first characters that a shell or a spreadsheet reads as something else (an
#: option, a formula) or that make it hidden or a parent folder (``.``, ``..``).
_UNSAFE_START = re.compile(r"^[.+-]+")


def safe_unit_name(relative: str) -> str:
    """A folder name for a record's relative path without its ending: ``/`` becomes ``__``,
    each character other than letters, digits, ``.``, ``_``, ``+``, ``-`` becomes ``_``
    (control characters, spaces, ``=``, quotes ...), leading ``.``, ``+``, ``-`` become
    ``_`` (``..`` is ``__``, ``.hidden`` is ``_hidden``), and a name longer than
    :data:`MAX_UNIT_NAME` is cut and ends with ``~`` and 8 hexadecimal digits of a hash of the
    path.

    Examples
    --------
    >>> safe_unit_name("lot7/S1"), safe_unit_name(".."), safe_unit_name('=HYPERLINK("x")')
    ('lot7__S1', '__', '_HYPERLINK__x__')
    """
    name = _UNSAFE.sub("_", "__".join(Path(relative).parts) if relative else "")
    name = _UNSAFE_START.sub(lambda m: "_" * len(m.group()), name) or "_"
    if len(name) > MAX_UNIT_NAME:
        digest = hashlib.sha256(relative.encode("utf-8", "surrogateescape")).hexdigest()[:8]
        name = f"{name[:MAX_UNIT_NAME - 9]}~{digest}"
    return name


def unit_names(paths: list[Path]) -> list[str]:
    """A unit name per record, unique within the batch and safe as a folder name and as a
    table cell: :func:`safe_unit_name` of the path relative to the records' common folder,
    without its ending (``lot7/S0001.csv`` and ``lot8/S0001.csv`` become ``lot7__S0001`` and
    ``lot8__S0001``; records of one folder are named by their stem). Names that are the same
    (also in another case: ``S 1`` and ``S_1``, ``A`` and ``a``) are told apart in the order
    of ``paths`` by ``~2``, ``~3`` ... (a character no cleaned name holds).

    Parameters
    ----------
    paths : list of Path
        Absolute record paths (as :func:`find_records` gives them).
    """
    if not paths:
        return []
    root = Path(os.path.commonpath([str(p.parent) for p in paths]))
    names: list[str] = []
    taken: set[str] = set()
    for p in paths:
        rel = p.relative_to(root)
        stem = str(rel.with_name(rel.stem)) if rel.stem else str(rel)
        name = base = safe_unit_name(stem)
        k = 1
        while name.lower() in taken:
            k += 1
            name = f"{base}~{k}"
        taken.add(name.lower())
        names.append(name)
    return names
