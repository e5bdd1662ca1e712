"""A fleet run: every record a unit, processed on Dask (``dask.distributed``), results in one
table, a lot report.

The client sends paths, never records: each worker reads its unit's record, writes the unit's
files and returns one small row. At most ``window`` units are in flight at a time, so the
client's memory does not grow with the number of records. A task whose worker dies is run
again on another (Dask reschedules it; ``retries`` more attempts after an exception), a record
that cannot be processed is one failed row, and a unit whose ``result.json`` is already there
(same record file, same settings) is not run again.

The output folder belongs to one run at a time and to one set of settings: a run holds the
lock file :data:`LOCK_FILE` while it works (a second run into the folder is refused), and the
folder keeps its settings in :data:`SETTINGS_FILE` (a later run with the same settings resumes,
one with other settings is refused rather than mixing two runs' files).
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import shutil
import signal
import tempfile
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
from creepcomp.io.atomic import write_text_atomic
from creepcomp.io.outputs import check_output_dir, free_lock, hold_lock

__all__ = ["SERIAL", "WORKER_CONFIG", "LOCK_FILE", "SETTINGS_FILE", "FleetResult", "run",
           "local_cluster", "folder_lock", "claim_folder"]

#: The lock file a run holds in its output folder while it works (removed at its end).
LOCK_FILE = ".fleet.lock"

#: The settings of the run whose results an output folder holds.
SETTINGS_FILE = "fleet-settings.json"

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
    check_output_dir(out, "-o", contents=("fleet.parquet", "fleet.csv", "report.html",
                                          SETTINGS_FILE))
    paths = find_records(records, exclude=out)
    names = unit_names(paths)
    (out / "units").mkdir(parents=True, exist_ok=True)
    settings = run_settings(spec, correct, unit_reports)
    with folder_lock(out):
        claim_folder(out, settings)
        result = _run_units(paths, names, out, settings, workers, scheduler, spec, correct,
                            unit_reports, report, progress, window, retries)
    result.seconds = _time.perf_counter() - start
    return result


@contextlib.contextmanager
def folder_lock(out: Path):
    """Hold the lock file :data:`LOCK_FILE` of the folder ``out`` (an advisory ``flock``, freed
    by the system when the process ends, however it ends: :func:`creepcomp.io.outputs.hold_lock`);
    the file is removed on release.

    Raises
    ------
    InputError
        When another process holds it.
    """
    path = out / LOCK_FILE
    fd = hold_lock(path, lambda holder: f"-o {out}: another fleet run (process {holder}) is "
                   "writing in this folder; wait for it to end or choose another folder")
    try:
        yield
    finally:
        free_lock(path, fd)


def claim_folder(out: Path, settings: dict) -> None:
    """Record ``settings`` in ``out``'s :data:`SETTINGS_FILE`, or refuse a folder that holds a
    run with other settings (the same settings: the run resumes).

    Raises
    ------
    InputError
        Naming the settings that differ.
    """
    path = out / SETTINGS_FILE
    try:
        earlier = json.loads(path.read_text(encoding="utf-8")).get("settings")
    except FileNotFoundError:
        earlier = None
    except (OSError, ValueError, AttributeError) as exc:
        raise InputError(f"-o {out}: {SETTINGS_FILE} cannot be read ({one_line(exc, 120)}); "
                         "remove it to start the folder afresh") from None
    # a new result layout (``version``) only recomputes the units, as it always did
    changed = ", ".join(f"{k} {earlier.get(k)!r} there, {settings.get(k)!r} now"
                        for k in sorted(set(earlier or {}) | set(settings))
                        if k != "version" and earlier is not None
                        and earlier.get(k) != settings.get(k))
    if changed:
        raise InputError(f"-o {out}: holds a fleet run with other settings ({changed}); choose "
                         f"another folder, or remove {SETTINGS_FILE} there to replace its results")
    if earlier != settings:
        write_text_atomic(path, json.dumps({"settings": settings}, indent=2) + "\n")


def _run_units(paths, names, out, settings, workers, scheduler, spec, correct, unit_reports,
               report, progress, window, retries) -> FleetResult:
    """The body of :func:`run`, with the folder locked and claimed."""
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
    return result


def local_cluster(workers: int | None = None, local_directory: str | Path | None = None):
    """A Dask cluster of ``workers`` single-threaded worker processes on this machine (default:
    its cores), with :data:`WORKER_CONFIG`, no dashboard, quiet logs, and the workers deaf to
    Ctrl-C. Close it (``with local_cluster(2) as cluster: ...``).

    ``local_directory``: the workers' scratch folder (default: Dask's, ``dask-scratch-space``
    in the temporary folder, left there)."""
    import dask
    from dask.distributed import LocalCluster

    # the workers start with Ctrl-C ignored (a disposition kept across the exec of a new
    # process): a terminal's SIGINT reaches the whole process group, and only this process
    # should react to it, by closing the cluster
    main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
    # a SIGTERM while the cluster starts is kept for when it has started (interrupted half-way,
    # the cluster could not be closed); the handler is not inherited by the new processes
    terms: list[int] = []
    previous_term = signal.signal(signal.SIGTERM, lambda s, f: terms.append(s)) if main else None
    try:
        config = dict(WORKER_CONFIG)
        if local_directory is not None:  # the scheduler's scratch folder too
            config["temporary-directory"] = str(local_directory)
        with dask.config.set(config):  # each nanny keeps the configuration it starts with
            cluster = LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1,
                                   processes=True, dashboard_address=None,
                                   local_directory=None if local_directory is None else str(local_directory),
                                   scheduler_kwargs={"dashboard_address": ":0"},
                                   silence_logs=logging.CRITICAL)
    finally:
        if main:
            signal.signal(signal.SIGINT, previous)
            signal.signal(signal.SIGTERM, previous_term)
    if terms:  # close it, then take the signal as it would have been taken
        cluster.close()
        signal.raise_signal(signal.SIGTERM)
    return cluster


def _run_dask(paths, names, todo, args, workers, scheduler, window, retries, finished):
    """Submit the units by path, at most ``window`` in flight; returns (workers, threads, where)."""
    from dask.distributed import Client, as_completed

    cluster = scratch = None
    if scheduler is None:
        # a scratch folder of the run's own, removed at its end
        scratch = tempfile.mkdtemp(prefix="creepcomp-dask-")
        try:
            cluster = local_cluster(workers, scratch)
        except BaseException:
            shutil.rmtree(scratch, ignore_errors=True)
            raise
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
        if scratch is not None:
            shutil.rmtree(scratch, ignore_errors=True)
