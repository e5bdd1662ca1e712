"""Input files checked for kind and size before they are read, and opened with a bound.

Every reader of a record, a model or a design file calls :func:`check_input_file` (through
:func:`open_input` or directly) first: a named pipe, a device (``/dev/zero``), a socket or a
folder is refused with one line instead of blocking or filling the memory, and a file larger
than its kind's limit is refused before it is read. A gzip-compressed record is decompressed
block by block into a temporary file, which is then read as any record (never whole into
memory), and refused once it expands beyond :func:`gzip_limit` of its size (a small file of
repeated rows expands a thousandfold).
"""

from __future__ import annotations

import contextlib
import gzip
import os
import stat
import tempfile
from pathlib import Path
from typing import Iterator

from creepcomp.errors import InputError
from creepcomp.io.outputs import file_kind, note_input

__all__ = ["MAX_JSON_BYTES", "MAX_GZIP_BYTES", "MIN_GZIP_BYTES", "MAX_GZIP_RATIO",
           "check_input_file", "gzip_limit", "open_input", "gunzipped", "format_bytes"]

#: Largest model or design file read (a model of thousands of terms is under 1 MiB).
MAX_JSON_BYTES = 16 << 20

#: Most bytes a gzip-compressed record may expand to, whatever its size.
MAX_GZIP_BYTES = 1 << 30

#: A gzip-compressed record may always expand to this many bytes ...
MIN_GZIP_BYTES = 64 << 20

#: ... and beyond it to this many times its compressed size (a measured record compresses a
#: few times; repeated rows about a thousand times).
MAX_GZIP_RATIO = 200


def format_bytes(n: int) -> str:
    """A byte count in words: ``305 KiB``, ``64 MiB``, ``1 GiB``."""
    for unit, size in (("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n} bytes"


def check_input_file(path: str | Path, what: str = "file",
                     max_bytes: int | None = None) -> os.stat_result:
    """Refuse what cannot be read as a file before reading it; return its ``os.stat``.

    Parameters
    ----------
    path : str or Path
        The file (a symbolic link is followed).
    what : str
        What it is, for the message (``record``, ``model file`` ...).
    max_bytes : int, optional
        Its largest size.

    Raises
    ------
    InputError
        For a missing path, a folder, anything but a regular file (a named pipe, a device, a
        socket), or a file larger than ``max_bytes``.
    """
    p = Path(path)
    try:
        st = os.stat(p)
    except FileNotFoundError:
        raise InputError(f"{what} {p}: no such file") from None
    except OSError as exc:
        raise InputError(f"{what} {p}: cannot read it ({exc.strerror or exc})") from None
    if not stat.S_ISREG(st.st_mode):
        raise InputError(f"{what} {p}: is {file_kind(st.st_mode)}, not a regular file; give a "
                         "file")
    if max_bytes is not None and st.st_size > max_bytes:
        raise InputError(f"{what} {p}: {format_bytes(st.st_size)}, more than the "
                         f"{format_bytes(max_bytes)} a {what} may have")
    note_input(st)
    return st


def gzip_limit(compressed_bytes: int) -> int:
    """The most bytes a gzip file of ``compressed_bytes`` may expand to:
    :data:`MAX_GZIP_RATIO` times its size, at least :data:`MIN_GZIP_BYTES`, at most
    :data:`MAX_GZIP_BYTES`."""
    return min(MAX_GZIP_BYTES, max(MIN_GZIP_BYTES, MAX_GZIP_RATIO * compressed_bytes))


def open_input(path: str | Path, what: str = "file", max_bytes: int | None = None):
    """Open a checked input file (:func:`check_input_file`) for reading bytes.

    Raises
    ------
    InputError
        As :func:`check_input_file`, or when the file cannot be opened.
    """
    p = Path(path)
    check_input_file(p, what, max_bytes)
    try:
        return p.open("rb")
    except OSError as exc:
        raise InputError(f"{what} {p}: cannot read it ({exc.strerror or exc})") from None


@contextlib.contextmanager
def gunzipped(path: str | Path, what: str = "record") -> Iterator[Path]:
    """A gzip-compressed file decompressed block by block into a temporary file (removed when
    the block ends), refused once it expands beyond :func:`gzip_limit` of its size.

    Yields
    ------
    Path
        The decompressed copy.

    Raises
    ------
    InputError
        For a file that is not gzip data, one that expands beyond its limit, or a temporary
        folder that cannot take the copy.
    """
    p = Path(path)
    limit = gzip_limit(check_input_file(p, what).st_size)
    fd, name = tempfile.mkstemp(prefix="creepcomp-", suffix=".csv")
    copy = Path(name)
    try:
        with os.fdopen(fd, "wb") as out, gzip.open(p, "rb") as packed:
            written = 0
            for block in iter(lambda: packed.read(1 << 20), b""):
                written += len(block)
                if written > limit:
                    raise InputError(
                        f"{what} {p}: expands to more than {format_bytes(limit)}, the limit for a "
                        f".gz file of its size ({MAX_GZIP_RATIO} times it, at least "
                        f"{format_bytes(MIN_GZIP_BYTES)}, at most {format_bytes(MAX_GZIP_BYTES)}); "
                        "decompress it and read the file itself")
                out.write(block)
    except (OSError, EOFError) as exc:
        copy.unlink(missing_ok=True)
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else exc
        raise InputError(f"{what} {p}: cannot decompress it ({reason})") from None
    except BaseException:
        copy.unlink(missing_ok=True)
        raise
    try:
        yield copy
    finally:
        copy.unlink(missing_ok=True)
