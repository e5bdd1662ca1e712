"""Cold ``creepcomp fit`` from the command line: a fresh process that starts, reads a CSV
record and fits it, on records of 10,000, 100,000 and 1,000,000 samples (the three-term
step record of ``benchmarks/peers.py`` at 10 Hz, as long as needed), against the goal of 1 s
each; and the start-up alone (``from creepcomp.cli import run``).

Printed per size: the median wall time over ``--repeat`` runs and the CPU time of the
process (user + system; on a busy machine the wall time grows, the CPU time much less).
Records longer than :data:`~creepcomp.fit.reduce.MAX_FIT_SAMPLES` are reduced by block
means while they are read (part of the timed run).

Usage::

    OPENBLAS_NUM_THREADS=1 python benchmarks/cold_fit.py [--repeat 3] [--sizes 10000,100000,1000000]
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import peers  # noqa: E402

CLI = [sys.executable, "-c", "from creepcomp.cli import run; run()"]


def timed(command: list[str]) -> tuple[float, float]:
    """Wall and CPU seconds (user + system) of one run of ``command`` (a failure stops)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def write_record(path: Path, n: int) -> None:
    t, load, y = peers.record(0, duration=n / 10.0)
    np.savetxt(path, np.column_stack([t, load, y]), delimiter=",", header="time,load,signal",
               comments="", fmt=("%.6f", "%.6g", "%.9g"))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--sizes", default="10000,100000,1000000")
    args = ap.parse_args(argv)
    print(f"load average {os.getloadavg()[0]:.2f}")
    print(f"{'run':28s} {'wall median':>12s} {'CPU median':>11s}")
    runs = [("start-up (import)", [sys.executable, "-c", "from creepcomp.cli import run"])]
    with tempfile.TemporaryDirectory(prefix="creepcomp-cold-") as folder:
        for n in (int(s) for s in args.sizes.split(",")):
            path = Path(folder) / f"step_{n}.csv"
            write_record(path, n)
            runs.append((f"fit, {n:,} samples", CLI + ["fit", str(path)]))
        for label, command in runs:
            timed(command)                          # warm the file cache
            walls, cpus = zip(*(timed(command) for _ in range(args.repeat)))
            print(f"{label:28s} {statistics.median(walls):11.2f}s {statistics.median(cpus):10.2f}s",
                  flush=True)
    print(f"load average {os.getloadavg()[0]:.2f}; goal: each fit 1 s or less, start-up included")


if __name__ == "__main__":
    main()
