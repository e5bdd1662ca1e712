"""Output paths checked before any work: not an input, in a folder that can be written (a
missing folder is made later, as before, when its nearest existing parent is a writable
folder), not a folder where a file is wanted (and the reverse), a regular file or a new path
(never a named pipe, a device such as ``/dev/null`` or ``/dev/full``, a socket, or a symbolic
link to one of those or to a folder), and a file ending a writer knows (``--plot x.xyz`` is
refused before the work, not after it).

A symbolic link to a regular file is accepted and replaced by the new file, as any existing
file is: the link's target is left unchanged. The output never lands outside the folder its
path names.

While a command runs (:func:`inputs_of_this_run`), every file it reads is noted
(:func:`note_input`, called by :func:`creepcomp.io.inputs.check_input_file`), and no output
replaces one of them: not at the check, not at the write (:func:`check_replaceable`), also
for a file found only during the run (a record's ``# design:``, a folder output's contents).
A file the command derives a name for (not named by the user) never replaces an existing
file (:func:`unnamed_output`).

Every command that writes files calls :func:`check_outputs` first, so a long run never ends
in "cannot write" and never overwrites the file it read; the files themselves are then
written atomically (:mod:`creepcomp.io.atomic`). :func:`check_outputs` also takes each
output's lock (:func:`hold_lock`, held until :func:`release_outputs` or the process ends): a
second run writing the same file or folder meanwhile is refused instead of silently replacing
the first one's result.
"""

from __future__ import annotations

import atexit
import contextlib
import os
import stat
import tempfile
from pathlib import Path
from typing import Callable, Iterable, Mapping, Sequence

from creepcomp.errors import InputError

__all__ = ["PLOT_SUFFIXES", "OUTPUT_SUFFIXES", "check_outputs", "check_output_file",
           "check_output_dir", "check_replaceable", "file_kind", "csv_cell", "hold_lock",
           "free_lock", "lock_output", "release_outputs", "lock_path", "note_input",
           "inputs_of_this_run", "unnamed_output"]

#: File endings a plot can be saved as (matplotlib's formats); no ending is PNG.
PLOT_SUFFIXES = ("png", "pdf", "svg", "svgz", "eps", "ps", "jpg", "jpeg", "tif", "tiff", "webp",
                 "pgf", "raw", "rgba")

#: Option -> the file endings its output may have (without the dot; "" for none), checked by
#: :func:`check_outputs` unless the caller gives its own.
OUTPUT_SUFFIXES = {"--plot": ("",) + PLOT_SUFFIXES}


def file_kind(mode: int) -> str:
    """What a file of ``mode`` (``os.stat``'s ``st_mode``) is, in words."""
    if stat.S_ISREG(mode):
        return "a regular file"
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a named pipe (FIFO)"
    if stat.S_ISCHR(mode):
        return "a character device"
    if stat.S_ISBLK(mode):
        return "a block device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


#: (device, inode) of each file read by the command running (:func:`inputs_of_this_run`);
#: None outside a command (a notebook may rewrite the file it read).
_READ: set[tuple[int, int]] | None = None


def note_input(st: os.stat_result) -> None:
    """Note a file the running command reads (its ``os.stat``): no output may replace it."""
    if _READ is not None:
        _READ.add((st.st_dev, st.st_ino))


@contextlib.contextmanager
def inputs_of_this_run():
    """While the block runs, the files read are noted and no output replaces one of them
    (the command line wraps every command in it)."""
    global _READ
    before, _READ = _READ, set()
    try:
        yield
    finally:
        _READ = before


def _read_by_this_run(p: Path) -> bool:
    if not _READ:
        return False
    try:
        st = os.stat(p)
    except OSError:
        return False
    return (st.st_dev, st.st_ino) in _READ


def unnamed_output(path: str | Path) -> Path:
    """Where to write a file whose name the command derives (not named by the user): ``path``
    when it is free, else the first free ``STEM-2.EXT``, ``STEM-3.EXT`` ... beside it, so an
    existing file is never replaced by one the user did not ask for by name.

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> _ = (folder / "creep.model.json").write_text("{}")
    >>> unnamed_output(folder / "creep.model.json").name
    'creep.model-2.json'
    """
    p = Path(path)
    stem, suffix = p.name[:len(p.name) - len(p.suffix)], p.suffix
    k = 1
    while p.exists() or p.is_symlink():
        k += 1
        p = p.with_name(f"{stem}-{k}{suffix}")
    return p


def check_replaceable(path: str | Path, option: str = "output") -> None:
    """Refuse an existing ``path`` that is not a regular file (or a symbolic link to one): a
    new file renamed over it would replace a pipe, a device or a link the user did not mean;
    and one the running command read (:func:`inputs_of_this_run`).

    Raises
    ------
    InputError
        Naming the path and what it is.
    """
    if _read_by_this_run(Path(path)):
        raise InputError(f"{option} {path}: is a file this command reads; an output never "
                         "replaces an input: choose another output path")
    p = Path(path)
    try:
        link = stat.S_ISLNK(os.lstat(p).st_mode)
    except (FileNotFoundError, NotADirectoryError):  # a new path (its folder is checked apart)
        return
    except OSError as exc:
        raise InputError(f"{option} {p}: cannot look at it ({exc.strerror or exc})") from None
    try:
        mode = os.stat(p).st_mode
    except OSError:
        raise InputError(f"{option} {p}: a symbolic link to a missing or unreadable path; "
                         "give a regular file or a new path") from None
    if not stat.S_ISREG(mode):
        what = file_kind(mode)
        where = f"a symbolic link to {os.path.realpath(p)}, {what}" if link else what
        raise InputError(f"{option} {p}: is {where}; outputs go to regular files or new paths "
                         "only")


def _check_suffix(p: Path, option: str, suffixes) -> None:
    if suffixes is None:
        return
    ending = p.suffix.lstrip(".").lower()
    if ending not in suffixes:
        known = ", ".join("." + s for s in suffixes if s)
        raise InputError(f"{option} {p}: unknown file ending '{p.suffix}'; use one of {known}")


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
                      inputs: Iterable[str | Path | None] = (),
                      suffixes: Sequence[str] | None = None) -> Path:
    """Check an output file path; return it.

    Parameters
    ----------
    path : str or Path
        Where the file will be written (replaced if it exists).
    option : str
        The option that named it, for the message.
    inputs : iterable of paths
        Files the command reads: the output may not be one of them.
    suffixes : sequence of str, optional
        The file endings allowed (without the dot, "" for none); default: any.

    Raises
    ------
    InputError
        The output is an input, a folder, not a regular file (a pipe, a device, a link to
        one), in a missing or read-only folder, an existing file that cannot be replaced, or
        has an ending not in ``suffixes``.
    """
    p = Path(path)
    _check_suffix(p, option, suffixes)
    for source in inputs:
        if source is not None and _same(p, Path(source)):
            raise InputError(f"{option} {p}: that is the input file {source}; choose another "
                             "output path (the input would be overwritten)")
    if p.is_dir():
        raise InputError(f"{option} {p}: is a folder; give a file name")
    check_replaceable(p, option)
    _writable_folder(p.parent if str(p.parent) else Path("."), option, p)
    if p.exists() and not os.access(p, os.W_OK):
        raise InputError(f"{option} {p}: the existing file cannot be replaced (not writable)")
    return p


def check_output_dir(path: str | Path, option: str = "-o",
                     inputs: Iterable[str | Path | None] = (),
                     contents: Iterable[str] = ()) -> Path:
    """Check an output folder (made later if missing, its parent must exist); return it.

    Parameters
    ----------
    path : str or Path
    option : str
        The option that named it, for the message.
    inputs : iterable of paths
        Files the command reads.
    contents : iterable of str
        Names of the files the command will write in the folder: each must be a regular
        file or new (:func:`check_replaceable`).

    Raises
    ------
    InputError
        The path is an input file, not a folder, its parent folder is missing or read-only,
        or one of ``contents`` is there and not a regular file.
    """
    p = Path(path)
    for source in inputs:
        if source is not None and _same(p, Path(source)):
            raise InputError(f"{option} {p}: that is the input file {source}")
    if p.exists():
        if not p.is_dir():
            mode = os.stat(p).st_mode
            what = "a file" if stat.S_ISREG(mode) else file_kind(mode)
            raise InputError(f"{option} {p}: is {what}, not a folder")
        _writable_folder(p, option, p)
        for name in contents:
            for source in inputs:
                if source is not None and _same(p / name, Path(source)):
                    raise InputError(f"{option} {p}: it would get a new {name}, but {source} is an "
                                     "input of this command; choose another output folder")
            check_replaceable(p / name, option)
    else:
        _writable_folder(p.parent if str(p.parent) else Path("."), option, p)
    return p


def check_outputs(files: Mapping[str, str | Path | None] | None = None,
                  dirs: Mapping[str, str | Path | None] | None = None,
                  inputs: Iterable[str | Path | None] = (),
                  suffixes: Mapping[str, Sequence[str]] | None = None,
                  contents: Mapping[str, Iterable[str]] | None = None) -> None:
    """Check every output of a command before it starts (None entries are skipped).

    Parameters
    ----------
    files : mapping
        Option -> output file path, e.g. ``{"-o": out, "--plot": png}``.
    dirs : mapping
        Option -> output folder path.
    inputs : iterable of paths
        Files the command reads.
    suffixes : mapping, optional
        Option -> the file endings allowed; default :data:`OUTPUT_SUFFIXES` (``--plot``).
    contents : mapping, optional
        Folder option -> names of the files written in it (:func:`check_output_dir`).

    Raises
    ------
    InputError
        For the first bad output, or two outputs that are the same file.
    """
    inputs = [i for i in inputs if i is not None]
    endings = OUTPUT_SUFFIXES if suffixes is None else suffixes
    seen: list[tuple[str, Path]] = []
    for option, path in (files or {}).items():
        if path is None:
            continue
        p = check_output_file(path, option, inputs, endings.get(option))
        for other, q in seen:
            if _same(p, q):
                raise InputError(f"{option} {p}: the same file as {other}; give different paths")
        seen.append((option, p))
    for option, path in (dirs or {}).items():
        if path is not None:
            check_output_dir(path, option, inputs, (contents or {}).get(option, ()))
    for option, p in seen:
        lock_output(p, option)
    for option, path in (dirs or {}).items():
        if path is not None:
            lock_output(path, option)


#: Lock file -> open descriptor, for the locks this process holds (:func:`lock_output`).
_HELD: dict[Path, int] = {}


def lock_path(path: str | Path) -> Path | None:
    """The lock file of an output file or folder ``NAME``: ``.NAME.lock`` beside it (None for
    the root folder, which has no name)."""
    p = Path(os.path.abspath(path))
    return p.with_name(f".{p.name}.lock") if p.name else None


def hold_lock(path: Path, busy: Callable[[str], str]) -> int:
    """Take the advisory lock (``flock``) of the lock file ``path`` and write this process's id
    in it; returns its descriptor (-1 where the system has no ``flock``). The system frees the
    lock when the process ends, however it ends: a lock file left by a process that died is
    simply taken over.

    Raises
    ------
    InputError
        ``busy(holder)`` when another process holds it (``holder``: its process id as written).
    """
    try:
        import fcntl
    except ImportError:  # no flock on this system: no lock
        return -1
    while True:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            holder = os.read(fd, 64).decode("ascii", "replace").strip() or "unknown"
            os.close(fd)
            raise InputError(busy(holder)) from None
        try:  # the holder before may have removed the file between our open and our lock
            same = os.stat(path).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        if same:
            break
        os.close(fd)
    os.ftruncate(fd, 0)
    os.write(fd, f"{os.getpid()}\n".encode("ascii"))
    return fd


def free_lock(path: Path, fd: int) -> None:
    """Remove the lock file ``path`` and free its lock (``fd`` from :func:`hold_lock`)."""
    if fd < 0:
        return
    with contextlib.suppress(OSError):
        os.unlink(path)
    with contextlib.suppress(OSError):
        os.close(fd)


def lock_output(path: str | Path, option: str = "-o") -> None:
    """Hold the lock of an output file or folder (:func:`lock_path`) until
    :func:`release_outputs` or the end of the process; one this process holds already is kept.
    In a folder that does not exist yet there is no lock (nothing is made before the work).

    Raises
    ------
    InputError
        When another creepcomp run holds it: its output would replace this one's.
    """
    lock = lock_path(path)
    if lock is None or not lock.parent.is_dir():
        return
    key = lock.parent.resolve() / lock.name
    if key in _HELD:
        return

    def busy(holder: str) -> str:
        return (f"{option} {path}: is being written by another creepcomp run (pid {holder}); wait "
                "for it to end or choose another path")
    try:
        _HELD[key] = hold_lock(lock, busy)
    except OSError:  # no lock file can be made there: the checks above judged the folder
        return


def release_outputs() -> None:
    """Free every output lock this process holds (:func:`lock_output`)."""
    while _HELD:
        path, fd = _HELD.popitem()
        free_lock(path, fd)


atexit.register(release_outputs)


def csv_cell(text: str) -> str:
    """A cell a spreadsheet cannot run: text starting with ``=``, ``+``, ``-``, ``@``, a tab
    or a carriage return (a formula to a spreadsheet) gets a leading ``'``; a number stays
    a number, and a lone ``-`` (no value) stays itself."""
    if text == "-":
        return text
    try:
        float(text)
        return text
    except ValueError:
        return "'" + text if text[:1] in ("=", "+", "-", "@", "\t", "\r") else text
