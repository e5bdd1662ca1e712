"""Atomic output files: written to a temporary file in the same folder, then renamed over the
target, so an output is either complete or absent (never half-written, also on Ctrl-C).

The target must be a regular file or new (:func:`creepcomp.io.outputs.check_replaceable`),
checked before the writing and again just before the rename: a rename never replaces a named
pipe, a device or a link to one.
"""

from __future__ import annotations

import contextlib
import os
import uuid
from pathlib import Path
from typing import Iterator

from creepcomp.io.outputs import check_replaceable

__all__ = ["atomic_path", "write_text_atomic", "write_bytes_atomic"]


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path beside ``path``; renamed to ``path`` when the block ends normally,
    removed when it raises (interrupts included).

    Parameters
    ----------
    path : str or Path
        The final output file.

    Yields
    ------
    Path
        Where to write; it does not exist yet when the block starts.

    Raises
    ------
    InputError
        When ``path`` exists and is not a regular file (or a link to one).
    """
    target = Path(path)
    check_replaceable(target)
    # a fresh name rather than mkstemp: the file is then created with the user's usual
    # permissions (mkstemp's are 0600)
    tmp = target.with_name(f".{target.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}.part")
    try:
        yield tmp
        check_replaceable(target)
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


def write_text_atomic(path: str | Path, text: str, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` atomically; returns the path."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding=encoding)
    return Path(path)


def write_bytes_atomic(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically; returns the path."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)
