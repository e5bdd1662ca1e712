"""Cold ``creepcomp fit`` from the command line: a fresh process that starts, reads a CSV
record and fits it, on records of 10,000, 100,000 and 1,000,000 samples (the three-term
step record of ``benchmarks/peers.py`` at 10 Hz, as long as needed), against the goal of 1 s
each; and the start-up alone (``from creepcomp.cli import run``).

Printed per size: the median wall time over ``--repeat`` runs and the CPU time of the
process (user + system; on a busy machine the wall time grows, the CPU time much less).
Records longer than :data:`~creepcomp.fit.reduce.MAX_FIT_SAMPLES` are reduced by blocks
while they are read (part of the timed run; to :data:`~creepcomp.fit.reduce.GROWN_FIT_SAMPLES`
where the blocks grow). With ``--phases``, one more run per size says where its time went:
start-up imports, reading and reducing the record (in a thread, while the fit's modules are
imported), the fit (``prepare`` and ``fit_prony``),
the rest (option parsing, the command's own imports, the output), and the interpreter's own
start and exit (the run's wall time less the others; wall only).

The runs use compiled byte-code as an installed package does
(:func:`startup.installed_environment`): no run compiles creepcomp's modules from source.

Usage::

    OPENBLAS_NUM_THREADS=1 python benchmarks/cold_fit.py [--repeat 3] [--phases]
        [--sizes 10000,100000,1000000]
"""

from __future__ import annotations

import argparse
import json
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
from startup import ENV  # noqa: E402

CLI = [sys.executable, "-c", "from creepcomp.cli import run; run()"]


#: A fresh process that runs ``creepcomp fit`` (its arguments after the script's) and prints
#: wall and CPU seconds of each phase as JSON.
PHASES = """
import json, sys, time
marks = [("start", time.perf_counter(), time.process_time())]
def mark(label):
    marks.append((label, time.perf_counter(), time.process_time()))
from creepcomp.cli import main
import creepcomp.cli.fit as cli_fit, creepcomp.fit as fit
mark("start-up imports")
spent = {"read and reduce + imports": [0.0, 0.0], "fit": [0.0, 0.0]}
def timing(phase, function):
    def run(*args, **kwargs):
        wall, cpu = time.perf_counter(), time.process_time()
        try:
            return function(*args, **kwargs)
        finally:
            spent[phase][0] += time.perf_counter() - wall
            spent[phase][1] += time.process_time() - cpu
    return run
cli_fit.load_reduced = timing("read and reduce + imports", cli_fit.load_reduced)
import importlib
def late(module, name):      # (looked up when called: the fit's modules are imported while reading)
    return lambda *args, **kwargs: getattr(importlib.import_module(module), name)(*args, **kwargs)
fit.prepare = timing("fit", late("creepcomp.fit.data", "prepare"))
fit.fit_prony = timing("fit", late("creepcomp.fit.prony", "fit_prony"))
status = main(sys.argv[1:])
mark("command")
import gc
gc.freeze()             # (as the console script's run does)
(_, w0, c0), (_, w1, c1), (_, w2, c2) = marks
out = {"start-up imports": [w1 - w0, c1 - c0], **spent}
out["the rest"] = [w2 - w1 - sum(v[0] for v in spent.values()), c2 - c1 - sum(v[1] for v in spent.values())]
print(json.dumps(out), file=sys.stderr)
sys.exit(status)
"""




def timed(command: list[str]) -> tuple[float, float]:
    """Wall and CPU seconds (user + system) of one run of ``command`` (a failure stops)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                   env=ENV)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def write_record(path: Path, n: int) -> None:
    t, load, y = peers.record(0, duration=n / 10.0)
    np.savetxt(path, np.column_stack([t, load, y]), delimiter=",", header="time,load,signal",
               comments="", fmt=("%.6f", "%.6g", "%.9g"))


def print_phases(arguments: list[str], folder: Path) -> None:
    """Run the command once more, writing the model file, split into its phases; print them
    and the model's creep terms (a fast fit is only worth its time when it finds them)."""
    model = folder / "model.json"
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", PHASES] + arguments + ["-o", str(model)],
                          check=True, env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                          text=True)
    total = time.perf_counter() - start
    phases = json.loads(done.stderr.strip().splitlines()[-1])
    for phase, (wall, cpu) in phases.items():
        print(f"  {phase:26s} {wall:11.2f}s {cpu:10.2f}s")
    print(f"  {'interpreter start and exit':26s} {total - sum(w for w, _ in phases.values()):11.2f}s")
    fitted = json.loads(model.read_text())
    terms = ", ".join(f"{100 * b:.3g} % at {t:.4g} s" for b, t in zip(fitted["beta"], fitted["tau"]))
    print(f"  model: {len(fitted['tau'])} term(s): {terms} (true: "
          + ", ".join(f"{100 * b:.3g} % at {t:.4g} s" for b, t in zip(peers.BETAS, peers.TAUS)) + ")")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--sizes", default="10000,100000,1000000")
    ap.add_argument("--phases", action="store_true",
                    help="one more run per size: where its time went")
    args = ap.parse_args(argv)
    print(f"load average {os.getloadavg()[0]:.2f}")
    if "PYTHONPYCACHEPREFIX" in ENV and "PYTHONPYCACHEPREFIX" not in os.environ:
        print(f"byte-code written and reused in {ENV['PYTHONPYCACHEPREFIX']} (as installed)")
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
            if args.phases and command[:len(CLI)] == CLI:
                print_phases(command[len(CLI):], Path(folder))
    print(f"load average {os.getloadavg()[0]:.2f}; goal: each fit 1 s or less, start-up included")


if __name__ == "__main__":
    main()
