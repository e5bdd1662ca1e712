"""Which records a fleet run processes: files, folders and glob patterns, and each unit's name.

Only paths are handled here: no record is opened (the workers read them).
"""

from __future__ import annotations

import glob
import os
import re
from pathlib import Path
from typing import Iterable

from creepcomp.errors import InputError

__all__ = ["RECORD_SUFFIXES", "find_records", "unit_names"]

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


def unit_names(paths: list[Path]) -> list[str]:
    """A unit name per record, unique within the batch and usable as a folder name: the path
    relative to the records' common folder, without its ending, ``/`` written as ``__``
    (``lot7/S0001.csv`` and ``lot8/S0001.csv`` become ``lot7__S0001`` and ``lot8__S0001``;
    records of one folder are named by their stem).

    Parameters
    ----------
    paths : list of Path
        Absolute record paths (as :func:`find_records` gives them).
    """
    if not paths:
        return []
    root = Path(os.path.commonpath([str(p.parent) for p in paths]))
    names = []
    for p in paths:
        rel = p.relative_to(root).with_suffix("")
        names.append(re.sub(r"[^A-Za-z0-9._+-]", "_", "__".join(rel.parts)))
    seen: dict[str, Path] = {}
    for name, p in zip(names, paths):
        if name in seen:
            raise InputError(f"{seen[name]} and {p} give the same unit name '{name}': "
                             "rename one or run them in separate batches")
        seen[name] = p
    return names
