"""One BLAS thread while a fit runs.

A fit's matrices are tall and narrow (thousands of rows, a few to a few ten columns), and
OpenBLAS splits even their products over its threads: where another process uses the other
cores, the threads wait for each other (on 2 busy cores a fit of the three-term step record
took four times the CPU time and up to four times the wall time with the default threads).
Within :func:`one_blas_thread` the BLAS libraries loaded in the process use one thread
(threadpoolctl); the count before is restored when the block ends. Newer OpenBLAS keeps the
count per thread, so a fit in another thread (a Dask worker's) may keep the default: there
Dask sets one thread for its workers already.
"""

from __future__ import annotations

import contextlib
import threading
from typing import Iterator

__all__ = ["one_blas_thread"]

_lock = threading.Lock()
_controller = None


def _blas_controller():
    """The thread-pool controller of the libraries loaded (found once: a few milliseconds)."""
    global _controller
    with _lock:
        if _controller is None:
            import scipy.linalg  # noqa: F401  (loads scipy's BLAS, so that it is found)
            from threadpoolctl import ThreadpoolController

            _controller = ThreadpoolController()
        return _controller


@contextlib.contextmanager
def one_blas_thread() -> Iterator[None]:
    """Within the block, BLAS uses one thread; the count before is restored after it."""
    with _blas_controller().limit(limits=1, user_api="blas"):
        yield
