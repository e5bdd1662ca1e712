"""Output paths checked before any work: not an input, in a folder that can be written (a
missing folder is made later, as before, when its nearest existing parent is a writable
folder), not a folder where a file is wanted (and the reverse).

Every command that writes files calls :func:`check_outputs` first, so a long run never ends
in "cannot write" and never overwrites the file it read; the files themselves are then
written atomically (:mod:`creepcomp.io.atomic`).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Iterable, Mapping

from creepcomp.errors import InputError

__all__ = ["check_outputs", "check_output_file", "check_output_dir", "check_figure_suffix", "FIGURE_SUFFIXES"]


def _same(a: Path, b: Path) -> bool:
    try:
        if a.exists() and b.exists():
            return os.path.samefile(a, b)
    except OSError:
        pass
    return a.resolve() == b.resolve()


def _writable_folder(folder: Path, option: str, path: Path) -> None:
    """Refuse a folder that is not a folder, or cannot take a new file (a missing folder is
    judged by its nearest existing parent, where it would be made)."""
    while not folder.exists() and not folder.is_symlink() and folder != folder.parent:
        folder = folder.parent
    if not folder.is_dir():
        raise InputError(f"{option} {path}: {folder} is a file, not a folder")
    # os.access alone is not enough (root, read-only mounts): try to create a file there
    try:
        with tempfile.TemporaryFile(dir=folder, prefix=".creepcomp-probe-"):
            pass
    except OSError as exc:
        raise InputError(f"{option} {path}: cannot write in folder {folder} "
                         f"({exc.strerror or exc})") from None


def check_output_file(path: str | Path, option: str = "-o",
                      inputs: Iterable[str | Path | None] = ()) -> Path:
    """Check an output file path; return it.

    Parameters
    ----------
    path : str or Path
        Where the file will be written (replaced if it exists).
    option : str
        The option that named it, for the message.
    inputs : iterable of paths
        Files the command reads: the output may not be one of them.

    Raises
    ------
    InputError
        The output is an input, a folder, in a missing or read-only folder, or an existing
        file that cannot be replaced.
    """
    p = Path(path)
    for source in inputs:
        if source is not None and _same(p, Path(source)):
            raise InputError(f"{option} {p}: that is the input file {source}; choose another "
                             "output path (the input would be overwritten)")
    if p.is_dir():
        raise InputError(f"{option} {p}: is a folder; give a file name")
    _writable_folder(p.parent if str(p.parent) else Path("."), option, p)
    if p.exists() and not os.access(p, os.W_OK):
        raise InputError(f"{option} {p}: the existing file cannot be replaced (not writable)")
    return p


def check_output_dir(path: str | Path, option: str = "-o",
                     inputs: Iterable[str | Path | None] = ()) -> Path:
    """Check an output folder (made later if missing, its parent must exist); return it.

    Raises
    ------
    InputError
        The path is an input file, a file, or its parent folder is missing or read-only.
    """
    p = Path(path)
    for source in inputs:
        if source is not None and _same(p, Path(source)):
            raise InputError(f"{option} {p}: that is the input file {source}")
    if p.exists():
        if not p.is_dir():
            raise InputError(f"{option} {p}: is a file, not a folder")
        _writable_folder(p, option, p)
    else:
        _writable_folder(p.parent if str(p.parent) else Path("."), option, p)
    return p


#: The file types matplotlib's file backend writes (a ``--plot`` file's suffix names one).
FIGURE_SUFFIXES = ("avif", "eps", "gif", "jpeg", "jpg", "pdf", "pgf", "png", "ps", "raw", "rgba", "svg",
                   "svgz", "tif", "tiff", "webp")


def check_figure_suffix(path: str | Path, option: str) -> None:
    """Raise :class:`InputError` unless ``path`` ends in one of :data:`FIGURE_SUFFIXES`."""
    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix not in FIGURE_SUFFIXES:
        raise InputError(f"{option} {path}: the suffix names no figure format; use .png, .svg or "
                         f".pdf (or one of {', '.join(FIGURE_SUFFIXES)})")


def check_outputs(files: Mapping[str, str | Path | None] | None = None,
                  dirs: Mapping[str, str | Path | None] | None = None,
                  inputs: Iterable[str | Path | None] = ()) -> None:
    """Check every output of a command before it starts (None entries are skipped).

    Parameters
    ----------
    files : mapping
        Option -> output file path, e.g. ``{"-o": out, "--plot": png}``.
    dirs : mapping
        Option -> output folder path.
    inputs : iterable of paths
        Files the command reads.

    Raises
    ------
    InputError
        For the first bad output, or two outputs that are the same file.
    """
    inputs = [i for i in inputs if i is not None]
    seen: list[tuple[str, Path]] = []
    for option, path in (files or {}).items():
        if path is None:
            continue
        if option.startswith("--plot"):
            check_figure_suffix(path, option)
        p = check_output_file(path, option, inputs)
        for other, q in seen:
            if _same(p, q):
                raise InputError(f"{option} {p}: the same file as {other}; give different paths")
        seen.append((option, p))
    for option, path in (dirs or {}).items():
        if path is not None:
            check_output_dir(path, option, inputs)
