"""A fleet run: every record a unit, processed on Dask (``dask.distributed``), results in one
table, a lot report.

The client sends paths, never records: each worker reads its unit's record, writes the unit's
files and returns one small row. At most ``window`` units are in flight at a time, so the
client's memory does not grow with the number of records. A task whose worker dies is run
again on another (Dask reschedules it; ``retries`` more attempts after an exception), a record
that cannot be processed is one failed row, and a unit whose ``result.json`` is already there
(same record file, same settings) is not run again.
"""

from __future__ import annotations

import logging
import os
import signal
import threading
import time as _time
import uuid
from dataclasses import dataclass, field
from itertools import islice
from pathlib import Path
from typing import Callable, Iterable

from creepcomp.errors import InputError
from creepcomp.fleet.discover import find_records, unit_names
from creepcomp.fleet.table import arrow_table, write_table
from creepcomp.fleet.unit import OIML_C3_CREEP, done_row, empty_row, one_line, process_unit, run_settings

__all__ = ["SERIAL", "WORKER_CONFIG", "FleetResult", "run", "local_cluster"]

#: ``scheduler`` value that runs every unit in this process, one after the other, without Dask
#: (for debugging and as the reference a distributed run must reproduce).
SERIAL = "serial"

#: Dask settings of the workers of a local cluster. Dask's statistical profiler samples the
#: running task's stack every 10 ms and keeps each second's call tree for the last 1000 s
#: (``distributed.admin.low-level-log-length``), twice: the fit's deep numpy/scipy stacks make
#: that about 0.7 MiB per busy second, so a worker's memory grew by about 1 MiB per unit
#: (``docs/fleet.md``, Memory). Nothing of creepcomp reads the profile.
WORKER_CONFIG = {"distributed.worker.profile.enabled": False}

#: ``progress(done, total, row)``: called once per unit, ``row`` its table row.
Progress = Callable[[int, int, dict], None]


@dataclass
class FleetResult:
    """What :func:`run` returns.

    Attributes
    ----------
    table : pyarrow.Table
        One row per unit, in the order the records were given (columns:
        :data:`creepcomp.fleet.table.COLUMNS`).
    paths : dict
        ``parquet``, ``csv`` and (when written) ``report``: the files written.
    failed : list of dict
        ``file``, ``unit`` and ``reason`` of each unit that could not be processed.
    skipped : int
        Units already done by an earlier run, not run again.
    seconds : float
        Wall time of the run.
    workers : int
        Dask workers used (1 for a serial run).
    threads : int
        Tasks the workers run at once.
    scheduler : str
        ``local`` (a cluster started for the run), the address of an existing one, or ``serial``.
    """

    table: object
    paths: dict
    failed: list
    skipped: int
    seconds: float
    workers: int
    threads: int
    scheduler: str
    summary: dict = field(default_factory=dict, repr=False)

    @property
    def n(self) -> int:
        """Units (records) in the run."""
        return self.table.num_rows

    def to_dict(self) -> dict:
        """The ``creepcomp fleet --json`` object: ``n``, ``failed``, ``seconds``, ``workers``,
        ``table`` (the Parquet file) and more."""
        rows = self.table.to_pylist()
        return {"n": self.n, "failed": self.failed, "seconds": self.seconds, "workers": self.workers,
                "table": str(self.paths["parquet"]), "csv": str(self.paths["csv"]),
                "report": str(self.paths["report"]) if "report" in self.paths else None,
                "threads": self.threads, "scheduler": self.scheduler, "skipped": self.skipped,
                "ok": sum(r["status"] == "ok" for r in rows),
                "out_of_spec": sum(r["in_spec"] is False for r in rows),
                "in_spec": sum(r["in_spec"] is True for r in rows)}


def run(records: Iterable[str | Path], out_dir: str | Path, workers: int | None = None,
        scheduler: str | None = None, spec: float = OIML_C3_CREEP, correct: bool = False,
        unit_reports: bool = False, report: bool = True, progress: Progress | None = None,
        window: int | None = None, retries: int = 2) -> FleetResult:
    """Fit and diagnose every record (one unit each) and write the results table.

    Parameters
    ----------
    records : iterable of str or Path
        Files, folders and glob patterns (:func:`~creepcomp.fleet.discover.find_records`).
    out_dir : str or Path
        Output folder: ``fleet.parquet``, ``fleet.csv``, ``report.html`` and ``units/<unit>/``.
    workers : int, optional
        Worker processes of the local cluster (default: the machine's cores). Not with
        ``scheduler``.
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:8786``) whose workers can import
        creepcomp and read the records and ``out_dir`` at the same paths; or ``"serial"``
        (:data:`SERIAL`). Default: a local cluster of ``workers`` processes, started and
        closed by the run.
    spec : float
        Creep limit, fraction of full scale (default OIML R60 class C3, 0.0245 %).
    correct : bool
        Also correct each record with its unit's model (``units/<unit>/corrected.csv``).
    unit_reports : bool
        Also write each unit's diagnosis report (``units/<unit>/report.html``).
    report : bool
        Write the lot report ``report.html``.
    progress : callable, optional
        ``progress(done, total, row)`` after each unit (skipped ones included).
    window : int, optional
        Most units in flight at once (default: twice the workers' threads).
    retries : int
        Further attempts of a task that raised (a worker that dies is handled by Dask's own
        rescheduling).

    Returns
    -------
    FleetResult
    """
    start = _time.perf_counter()
    if not (spec > 0):
        raise InputError(f"spec = {spec!r}: the creep limit must be positive")
    if workers is not None and workers < 1:
        raise InputError(f"--workers {workers}: use 1 or more")
    if workers is not None and scheduler is not None:
        raise InputError("--workers is for the local cluster; an existing cluster (--scheduler) "
                         "brings its own workers")
    out = Path(out_dir)
    paths = find_records(records, exclude=out)
    names = unit_names(paths)
    if out.exists() and not out.is_dir():
        raise InputError(f"{out}: exists and is not a folder")
    (out / "units").mkdir(parents=True, exist_ok=True)
    settings = run_settings(spec, correct, unit_reports)
    total = len(paths)
    rows: list[dict | None] = [None] * total
    done = 0
    todo = []
    for i, (p, u) in enumerate(zip(paths, names)):
        row = done_row(p, out / "units" / u, settings)
        if row is None:
            todo.append(i)
            continue
        rows[i] = row
        done += 1
        if progress:
            progress(done, total, row)
    skipped = done
    args = {"out_dir": str(out), "spec": float(spec), "correct": bool(correct),
            "unit_reports": bool(unit_reports)}

    def finished(i: int, row: dict) -> None:
        nonlocal done
        rows[i] = row
        done += 1
        if progress:
            progress(done, total, row)

    if not todo:  # everything done by an earlier run: no cluster needed
        n_workers = n_threads = 0
        where = "none (every unit already done)"
    elif scheduler == SERIAL:
        for i in todo:
            finished(i, process_unit(str(paths[i]), names[i], **args))
        n_workers = n_threads = 1
        where = SERIAL
    else:
        n_workers, n_threads, where = _run_dask(paths, names, todo, args, workers, scheduler,
                                                window, retries, finished)
    table = arrow_table(rows)
    written = write_table(table, out)
    listed = table.to_pylist()
    from creepcomp.fleet.lot import lot_summary

    summary = lot_summary(listed)
    result = FleetResult(table, written,
                         [{"file": r["file"], "unit": r["unit"], "reason": r["error"]}
                          for r in listed if r["status"] != "ok"],
                         skipped, 0.0, n_workers, n_threads, where, summary)
    if report:
        from creepcomp.report.fleet import write_lot_report

        written["report"] = write_lot_report(summary, out / "report.html",
                                             {"spec": spec, "records": total, "workers": n_workers,
                                              "scheduler": where, "table": written["parquet"].name})
    result.seconds = _time.perf_counter() - start
    return result


def local_cluster(workers: int | None = None):
    """A Dask cluster of ``workers`` single-threaded worker processes on this machine (default:
    its cores), with :data:`WORKER_CONFIG`, no dashboard, quiet logs, and the workers deaf to
    Ctrl-C. Close it (``with local_cluster(2) as cluster: ...``)."""
    import dask
    from dask.distributed import LocalCluster

    # the workers start with Ctrl-C ignored (a disposition kept across the exec of a new
    # process): a terminal's SIGINT reaches the whole process group, and only this process
    # should react to it, by closing the cluster
    main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
    try:
        with dask.config.set(WORKER_CONFIG):  # each nanny keeps the configuration it starts with
            return LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1,
                                processes=True, dashboard_address=None,
                                scheduler_kwargs={"dashboard_address": ":0"},
                                silence_logs=logging.CRITICAL)
    finally:
        if main:
            signal.signal(signal.SIGINT, previous)


def _run_dask(paths, names, todo, args, workers, scheduler, window, retries, finished):
    """Submit the units by path, at most ``window`` in flight; returns (workers, threads, where)."""
    from dask.distributed import Client, as_completed

    cluster = None
    if scheduler is None:
        cluster = local_cluster(workers)
        client = Client(cluster)
        where = "local"
    else:
        try:
            client = Client(scheduler, timeout="20s")
        except (OSError, TimeoutError, ValueError) as exc:
            raise InputError(f"scheduler {scheduler}: cannot connect ({one_line(exc, 160)})") from None
        where = scheduler
    pending: dict[str, tuple] = {}
    try:
        n_threads = sum(client.nthreads().values())
        n_workers = len(client.nthreads())
        if n_threads == 0:
            raise InputError(f"scheduler {where}: the cluster has no workers")
        run_id = uuid.uuid4().hex[:8]
        queue = iter(todo)
        completed = as_completed()

        def submit(i: int) -> None:
            fut = client.submit(process_unit, str(paths[i]), names[i], **args, pure=False,
                                retries=retries, key=f"creepcomp-unit-{run_id}-{i}")
            pending[fut.key] = (fut, i)
            completed.add(fut)

        for i in islice(queue, window or max(2, 2 * n_threads)):
            submit(i)
        for fut in completed:
            i = pending.pop(fut.key)[1]
            try:
                row = fut.result()
            except Exception as exc:  # the task never returned: its workers died, or it raised
                row = empty_row(paths[i], names[i])
                row.update(status="failed", error=one_line(
                    f"not processed ({type(exc).__name__}: {exc}); run again to retry"))
            fut.release()
            finished(i, row)
            nxt = next(queue, None)
            if nxt is not None:
                submit(nxt)
        return n_workers, n_threads, where
    finally:
        if pending:  # interrupted: drop what is still queued or running
            client.cancel([f for f, _ in pending.values()], force=True)
        client.close()
        if cluster is not None:
            cluster.close()
