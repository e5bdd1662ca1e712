"""Candidates fitted side by side in worker processes (``jobs`` of
:func:`creepcomp.diagnose.sensor.diagnose`).

The candidates of one step of the search are independent fits of the same record on top of
the same model. :class:`Workers` runs them in this process and in processes forked from it
(which hold the record already), and returns the results in the order given: the same
values a run in one process computes, bit for bit. Fits travel with their covariance still
deferred (:class:`~creepcomp.fit.solver.DeferredCovariance`): a diagnosis reads the
uncertainties of the few candidates it accepts. The record they refer to travels as a
reference: each process holds its own.
"""

from __future__ import annotations

import io
import multiprocessing
import os
import pickle
import signal
import sys
import time
import traceback
from typing import Any, Callable, Sequence

from creepcomp.fit.solver import DeferredCovariance
from creepcomp.interrupts import interrupts_held

__all__ = ["Workers", "available_cores", "forget_task_times", "last_seconds"]

#: Seconds the last few tasks of each kind took (by function and key), in this process, the
#: last one last: the longest known are handed out first, so that no process is left with a
#: long one at the end. A kind is known by the longest of its last :data:`_TASKS_KEPT` (a
#: task's time changes from record to record: one taken for short and started last costs
#: the wait for all of it, one taken for long and started early nothing).
_TASK_SECONDS: dict = {}
_TASKS_KEPT = 5


def last_seconds(fn: Callable, key) -> float | None:
    """Seconds the last task of this kind took (``fn`` and the key given to :meth:`Workers.map`)
    in this process, or None when none has run side by side yet."""
    seen = _TASK_SECONDS.get((fn.__name__, key))
    return seen[-1] if seen else None


def forget_task_times() -> None:
    """Forgets the task times this process has seen (:func:`last_seconds`). A process's first
    diagnosis loads modules and compiled loops: its tasks take several times as long as
    later, and would order the tasks of the next few diagnoses by that."""
    _TASK_SECONDS.clear()


def available_cores() -> int:
    """Cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:       # (not on Linux)
        return os.cpu_count() or 1


class _Pickler(pickle.Pickler):
    """Pickles a fit's deferred covariance as the computation it defers (by default it is
    computed: a pickle that leaves the diagnosis must hold its value), and what every process
    holds already (``shared``: the record, which every fitting problem refers to) as a
    reference to each process's own."""

    def __init__(self, file, shared=None):
        super().__init__(file, protocol=pickle.HIGHEST_PROTOCOL)
        self.shared = shared

    def reducer_override(self, obj):
        if type(obj) is DeferredCovariance:
            return obj.deferred_reduction()
        return NotImplemented

    def persistent_id(self, obj):
        return "shared" if self.shared is not None and obj is self.shared else None


class _Unpickler(pickle.Unpickler):
    """Reads what :class:`_Pickler` wrote, the reference to ``shared`` as this process's own."""

    def __init__(self, file, shared):
        super().__init__(file)
        self.shared = shared

    def persistent_load(self, pid):
        if pid != "shared" or self.shared is None:
            raise pickle.UnpicklingError(f"unknown reference {pid!r}")
        return self.shared


def _dumps(value, shared=None) -> bytes:
    buffer = io.BytesIO()
    _Pickler(buffer, shared).dump(value)
    return buffer.getvalue()


def _loads(message: bytes, shared):
    return _Unpickler(io.BytesIO(message), shared).load()


def _claim(counter, n: int) -> int | None:
    """The position of the next item to run (None: all are taken)."""
    with counter.get_lock():
        i = counter.value
        if i >= n:
            return None
        counter.value = i + 1
        return i


def _timed(fn: Callable, shared, common, item) -> tuple:
    start = time.perf_counter()
    value = fn(shared, common, item)
    return value, time.perf_counter() - start


def _serve(connection, counter, shared) -> None:
    """A worker process: for each call received, runs the items left until none is and
    sends back what it computed (an exception as its text: it need not pickle)."""
    from creepcomp.lti import compiled_loops

    # Ctrl-C and SIGTERM reach a whole process group (a terminal's, a service manager's): the
    # diagnosis handles them and ends the workers when it ends (a worker gone at once would
    # fail the call it serves before the diagnosis has taken its own signal)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    while True:
        try:
            message = connection.recv_bytes()
        except EOFError:
            return
        if not message:         # (the end: a forked process holds the other ends too)
            return
        fn, common, items, order = _loads(message, shared)
        done = []
        with compiled_loops():
            while (at := _claim(counter, len(order))) is not None:
                i = order[at]
                try:
                    done.append((i, *_timed(fn, shared, common, items[i]), None))
                except Exception:
                    done.append((i, None, 0.0, traceback.format_exc()))
        try:
            connection.send_bytes(_dumps(done, shared))
        except OSError:         # (the diagnosis stopped before reading it)
            return


class Workers:
    """Runs ``fn(shared, common, item)`` for many items, in this process and ``jobs - 1``
    processes forked at the first call that has two items or more: each runs the next item
    left until none is. All in this process when ``jobs`` is 1, off Linux (forking a process
    that uses some BLAS libraries is unsafe elsewhere), or where this process may not have
    children (a Dask worker's).

    Parameters
    ----------
    jobs : int
        Processes at most, this one included.
    shared : object
        What every call reads besides its items (the forked processes keep it).
    """

    def __init__(self, jobs: int, shared: Any):
        self.jobs = max(1, int(jobs))
        self.shared = shared
        self._processes: list = []
        self._ending: list = []         # (released, not yet waited for)
        self._connections: list = []
        self._counter = None

    @property
    def parallel(self) -> bool:
        """Calls may run in worker processes."""
        return self.jobs > 1 and sys.platform.startswith("linux") and not multiprocessing.current_process().daemon

    @property
    def width(self) -> int:
        """Items that run at once."""
        return self.jobs if self.parallel else 1

    def _start(self) -> None:
        context = multiprocessing.get_context("fork")
        self._counter = context.Value("l", 0)
        for _ in range(self.jobs - 1):
            here, there = context.Pipe()
            process = context.Process(target=_serve, args=(there, self._counter, self.shared), daemon=True)
            process.start()
            there.close()
            self._processes.append(process)
            self._connections.append(here)

    def map(self, fn: Callable, common: Any, items: Sequence, keys: Sequence | None = None) -> list:
        """``[fn(shared, common, item) for item in items]`` (``fn`` a module-level function);
        ``keys``: a name (any hashable) for each item's kind of work, by which the longest are run
        first."""
        items = list(items)
        if len(items) < 2 or not self.parallel:
            return [fn(self.shared, common, item) for item in items]
        if not self._processes:
            with interrupts_held():  # (a process forked is one listed, to be ended)
                self._start()
        kinds = [(fn.__name__, key) for key in keys] if keys is not None else [None] * len(items)
        order = sorted(range(len(items)), key=lambda i: -max(_TASK_SECONDS.get(kinds[i], [float("inf")])))
        with self._counter.get_lock():
            self._counter.value = 0
        message = _dumps((fn, common, items, order), self.shared)
        for connection in self._connections:
            connection.send_bytes(message)
        out, seconds, failed = [None] * len(items), [0.0] * len(items), None
        try:
            while (at := _claim(self._counter, len(order))) is not None:
                i = order[at]
                out[i], seconds[i] = _timed(fn, self.shared, common, items[i])
        except BaseException:
            with self._counter.get_lock():      # (the workers stop after the item they run)
                self._counter.value = len(order)
            raise
        finally:        # (the workers' answers read in any case: the next call must not get them)
            for connection in self._connections:
                try:
                    answers = _loads(connection.recv_bytes(), self.shared)
                except EOFError:
                    answers, failed = [], "a worker process ended without answering"
                for i, value, took, error in answers:
                    out[i], seconds[i] = value, took
                    failed = failed or error
        if failed:
            raise RuntimeError(f"a worker process failed:\n{failed}")
        for kind, took in zip(kinds, seconds):
            if kind is not None:
                _TASK_SECONDS[kind] = (_TASK_SECONDS.get(kind, []) + [took])[-_TASKS_KEPT:]
        return out

    def release(self) -> None:
        """Lets the worker processes end (a later call forks new ones); :meth:`close` waits for
        them: what this process does in between overlaps their exit."""
        for connection in self._connections:
            try:
                connection.send_bytes(b"")
            except OSError:      # (a worker that ended already)
                pass
            connection.close()
        self._connections, self._counter = [], None
        self._ending, self._processes = self._ending + self._processes, []

    def close(self) -> None:
        """Ends the worker processes: waits for them, or kills them when the wait is
        interrupted (they ignore SIGTERM, which the interpreter's exit would send them)."""
        self.release()
        try:
            for process in self._ending:
                process.join()
        except BaseException:
            for process in self._ending:
                process.kill()
            for process in self._ending:
                process.join()
            raise
        finally:
            self._ending = []

    def __enter__(self) -> "Workers":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
