"""Fleet on Dask: speed-up on 1 and 2 workers, equality with a serial run, and bounded memory.

(a) ``--units`` synthetic units (randomised hidden effects and load programs from
``synth.random_spec``, 600-1200 s at 1-2 Hz) are written to a temporary folder and run
serially (in this process, no Dask), on a local cluster of 1 worker and on one of 2 workers:
wall time of each, speed-up, the mean processing time of a unit on its worker (throughput per
core), units per core-hour, and whether each table equals the serial one (every column but
``seconds``). ``--runs`` chooses the runs (e.g. ``--runs "2 workers"`` alone).

(b) Memory (``--skip-speed``): 50 and 500 short records (300-450 s at 1 Hz) are written, each
batch is run in a fresh Python process on a local cluster of 2 workers, and the peak resident
memory of that process (client and scheduler) and of each worker process is read
(``VmHWM``) at the end. The folders are removed afterwards.

(c) ``--unit-cost``: CPU time and peak memory of one unit on production-sized records.

The machine's load average is printed before and after each part: other work on the cores
slows the runs (wall times are then noisy; the equality checks are not affected).

Usage::

    OPENBLAS_NUM_THREADS=1 nice -n 10 python benchmarks/fleet.py [--units 200] [--skip-speed] [--skip-memory]
        [--runs "serial,1 worker,2 workers"]
    OPENBLAS_NUM_THREADS=1 nice -n 10 python benchmarks/fleet.py --unit-cost
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

EFFECTS = (None, "extra_retardation", "viscous_flow", "nonlinear_creep", "asymmetric_recovery",
           "thermal_drift", "thermal_retardation", "static_nonlinearity", "time_offset")


def write_records(folder: Path, n: int, duration: tuple, rate: tuple, seed0: int = 0) -> None:
    """``n`` synthetic records with randomised effects and programs."""
    from creepcomp.io.records import write_record
    from creepcomp.synth.sensor import generate, random_spec

    folder.mkdir(parents=True, exist_ok=True)
    for i in range(n):
        spec = random_spec(EFFECTS[i % len(EFFECTS)], seed0 + i, rate=rate, duration=duration)
        write_record(folder / f"U{i:05d}.csv", generate(spec).record, digits=12)


def load() -> str:
    return "load average {:.2f} {:.2f} {:.2f}".format(*os.getloadavg())


#: The runs of the speed part: label -> keyword arguments of ``fleet.run``.
RUNS = {"serial": "serial", "1 worker": 1, "2 workers": 2}


def speed(n: int, runs=tuple(RUNS)) -> dict:
    from creepcomp.fleet import SERIAL, run

    base = Path(tempfile.mkdtemp(prefix="creepcomp-fleet-bench-"))
    try:
        t = time.perf_counter()
        write_records(base / "records", n, duration=(600.0, 1200.0), rate=(1.0, 2.0))
        print(f"{n} records written in {time.perf_counter() - t:.1f} s; {load()}", flush=True)
        out, tables = {}, {}
        for label in runs:
            kw = {"scheduler": SERIAL} if RUNS[label] == "serial" else {"workers": RUNS[label]}
            print(f"{label}: {load()}", flush=True)
            r = run([base / "records"], base / label.replace(" ", "_"), report=False, **kw)
            rows = r.table.to_pylist()
            seconds = [x["seconds"] for x in rows]
            tables[label] = r.table.drop_columns(["seconds"]).to_pylist()
            cores = 1 if RUNS[label] == "serial" else RUNS[label]
            out[label] = {"wall_s": round(r.seconds, 1), "failed": len(r.failed),
                          "unit_mean_s": round(sum(seconds) / len(seconds), 3),
                          "units_per_hour": round(3600 * n / r.seconds),
                          "units_per_core_hour": round(3600 * n / r.seconds / cores)}
            print(f"  {out[label]}; {load()}", flush=True)
        if "1 worker" in out and "2 workers" in out:
            out["speedup_2_vs_1"] = round(out["1 worker"]["wall_s"] / out["2 workers"]["wall_s"], 2)
        if "serial" in out:
            out["identical_to_serial"] = {k: tables[k] == tables["serial"] for k in tables if k != "serial"}
        causes = {}
        for row in tables[runs[0]]:
            causes[row["cause"]] = causes.get(row["cause"], 0) + 1
        out["causes"] = causes
        return out
    finally:
        shutil.rmtree(base, ignore_errors=True)


def peak_rss_mib() -> float:
    """Peak resident memory of this process since it started its program (``VmHWM``; unlike
    ``ru_maxrss`` it does not carry the peak of the process it was forked from)."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def memory_child(records: str, out_dir: str) -> None:
    """Run one batch on a local cluster of 2 workers (``creepcomp.fleet.local_cluster``, the one
    ``run`` starts); print the peak RSS (MiB) of this process (client and scheduler) and of
    each worker, and the size of the records on disk."""
    from dask.distributed import Client

    from creepcomp.fleet import local_cluster, run

    with local_cluster(2) as cluster:
        t = time.perf_counter()
        r = run([records], out_dir, scheduler=cluster.scheduler_address)
        wall = time.perf_counter() - t
        with Client(cluster) as client:
            workers = client.run(peak_rss_mib)
    client_mib = peak_rss_mib()
    on_disk = sum(p.stat().st_size for p in Path(records).iterdir()) / 2 ** 20
    print(json.dumps({"n": r.n, "failed": len(r.failed), "wall_s": round(wall, 1),
                      "records_on_disk_mib": round(on_disk, 1),
                      "client_peak_mib": round(client_mib, 1),
                      "worker_peak_mib": sorted(round(v, 1) for v in workers.values())}))


def memory(sizes=(50, 500)) -> dict:
    out = {}
    for n in sizes:
        base = Path(tempfile.mkdtemp(prefix="creepcomp-fleet-mem-"))
        try:
            write_records(base / "records", n, duration=(300.0, 450.0), rate=(1.0, 1.0), seed0=10_000)
            print(f"memory, {n} records: {load()}", flush=True)
            res = subprocess.run([sys.executable, __file__, "--memory-child", str(base / "records"),
                                  str(base / "out")], capture_output=True, text=True, check=True)
            out[n] = json.loads(res.stdout.strip().splitlines()[-1])
            print(f"  {out[n]}; {load()}", flush=True)
        finally:
            shutil.rmtree(base, ignore_errors=True)
    return out


def unit_cost() -> list:
    """CPU time and peak memory of one unit (``process_unit``, in this process, one BLAS
    thread as on a Dask worker) on production-sized records: 30 min at 10 Hz (three records,
    those of ``benchmarks/diagnose_timing.py``) and 2 h at 12 Hz."""
    from creepcomp import synth
    from creepcomp.fleet.unit import process_unit
    from creepcomp.io.records import write_record

    cases = [("clean, 30 min at 10 Hz", {}, 10.0, 1800.0),
             ("extra_retardation, 30 min at 10 Hz", {"extra_retardation": {"tau": 400.0, "beta": 0.015}}, 10.0, 1800.0),
             ("asymmetric_recovery, 30 min at 10 Hz", {"asymmetric_recovery": {"tau_recovery": 150.0}}, 10.0, 1800.0),
             ("extra_retardation, 2 h at 12 Hz", {"extra_retardation": {"tau": 400.0, "beta": 0.015}}, 12.0, 7200.0)]
    base = Path(tempfile.mkdtemp(prefix="creepcomp-fleet-unit-"))
    out = []
    try:
        for label, hidden, rate, duration in cases:
            spec = synth.Spec(hidden=hidden, beta=(0.03,), tau=(45.0,), gain=1.0, rate=rate,
                              duration=duration, program="staircase",
                              noise=synth.NoiseSpec(white=5e-4), seed=30)
            path = write_record(base / "u.csv", synth.generate(spec).record)
            c0, w0 = time.process_time(), time.perf_counter()
            row = process_unit(str(path), "u", str(base / "out"))
            out.append({"record": label, "samples": row["n_samples"], "cause": row["cause"],
                        "cpu_s": round(time.process_time() - c0, 2),
                        "wall_s": round(time.perf_counter() - w0, 1),
                        "peak_rss_mib": round(peak_rss_mib()), "load": round(os.getloadavg()[0], 1)})
            print(out[-1], flush=True)
    finally:
        shutil.rmtree(base, ignore_errors=True)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--units", type=int, default=200)
    ap.add_argument("--skip-speed", action="store_true")
    ap.add_argument("--skip-memory", action="store_true")
    ap.add_argument("--runs", default=",".join(RUNS),
                    help=f"runs of the speed part, comma-separated, of: {', '.join(RUNS)}")
    ap.add_argument("--unit-cost", action="store_true",
                    help="only the CPU time and memory of one unit on production-sized records "
                         "(run it with OPENBLAS_NUM_THREADS=1)")
    ap.add_argument("--memory-child", nargs=2, metavar=("RECORDS", "OUT"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.memory_child:
        memory_child(*args.memory_child)
        return
    print(f"{os.cpu_count()} cores; {load()}")
    result = {}
    if args.unit_cost:
        print(json.dumps({"unit_cost": unit_cost()}, indent=1))
        return
    if not args.skip_speed:
        runs = tuple(r.strip() for r in args.runs.split(","))
        unknown = [r for r in runs if r not in RUNS]
        if unknown:
            ap.error(f"--runs: unknown {', '.join(unknown)}; use {', '.join(RUNS)}")
        result["speed"] = speed(args.units, runs)
    if not args.skip_memory:
        result["memory"] = memory()
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
