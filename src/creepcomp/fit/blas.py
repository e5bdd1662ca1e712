"""One BLAS thread while a fit runs.

A fit's matrices are tall and narrow (thousands of rows, a few to a few ten columns), and
OpenBLAS splits even their products over its threads: where another process uses the other
cores, the threads wait for each other (on 2 busy cores a fit of the three-term step record
took four times the CPU time and up to four times the wall time with the default threads). While any
thread is within :func:`one_blas_thread`, the OpenBLAS libraries bundled with numpy and scipy
use one thread (``openblas_set_num_threads_local``, OpenBLAS 0.3.27 and later, which sets the
process's count and returns the one before); the count before is restored when the last
thread leaves. Other BLAS libraries are left alone (where none is found it does nothing).
"""

from __future__ import annotations

import contextlib
import ctypes
import sys
import threading
from pathlib import Path
from typing import Callable, Iterator

__all__ = ["one_blas_thread", "blas_thread_setters"]

_found: list[Callable[[int], int]] | None = None
_lock = threading.Lock()
#: Threads within :func:`one_blas_thread`, and the counts to restore when none is.
_inside = 0
_before: list[int] = []


def blas_thread_setters() -> list[Callable[[int], int]]:
    """The thread-local thread-count setters of the OpenBLAS libraries bundled with numpy and
    scipy (each returns the count it replaces), found once."""
    global _found
    with _lock:
        if _found is None:
            _found = []
            for package in ("numpy", "scipy"):
                module = sys.modules.get(package)
                if module is None or not getattr(module, "__file__", None):
                    continue
                folder = Path(module.__file__).parent.parent / f"{package}.libs"
                for path in sorted(folder.glob("lib*openblas*.so*")):
                    try:     # (the library is loaded already: this finds its handle)
                        setter = ctypes.CDLL(str(path)).openblas_set_num_threads_local
                    except (OSError, AttributeError):
                        continue
                    setter.argtypes, setter.restype = [ctypes.c_int], ctypes.c_int
                    _found.append(setter)
        return _found


@contextlib.contextmanager
def one_blas_thread() -> Iterator[None]:
    """Within the block, BLAS uses one thread; the counts before are restored when the last
    thread within such a block leaves it."""
    global _inside, _before
    import scipy.linalg  # noqa: F401  (loads scipy's OpenBLAS, so that it is found)

    setters = blas_thread_setters()
    with _lock:
        if _inside == 0:
            _before = [setter(1) for setter in setters]
        _inside += 1
    try:
        yield
    finally:
        with _lock:
            _inside -= 1
            if _inside == 0:
                for setter, count in zip(setters, _before):
                    setter(count)
