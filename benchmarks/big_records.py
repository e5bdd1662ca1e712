"""Big records: peak memory and wall time of fit, diagnose and correct on a 10 M-sample
record, and of ``mc --n 100000000`` (docs/benchmarks.md, "Big records").

    nice -n 10 python benchmarks/big_records.py [--samples 10000000] [--mc 100000000]
        [--only fit,diagnose,correct,mc]

Each command runs in its own process, one at a time; peak memory is that process's maximum
resident set, ``VmHWM`` of ``/proc/self/status`` read when it exits. (Not ``getrusage``: on
Linux a child's ``ru_maxrss`` keeps the resident size of the parent it was forked from, here
the benchmark holding the 10 M-sample arrays it wrote, about 500 MB, which would be the
floor of every peak.) The record and all outputs are written to a
temporary folder that is removed at the end.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def make_record(path: Path, n: int, rate: float = 1000.0) -> None:
    """A creep staircase sampled at ``rate``: load steps every 1/8 of the record, one creep
    term (beta 3 %, tau 45 s), white noise; written with the project's writer."""
    sys.path.insert(0, str(ROOT / "src"))
    from creepcomp.io.records import Record, write_record
    from creepcomp.model import CreepModel

    t = np.arange(n) / rate
    edges = np.linspace(0, t[-1], 9)[1:-1]
    levels = np.array([0, 1, 2, 3, 2, 1, 3, 0], float)
    load = levels[np.searchsorted(edges, t, side="right")]
    model = CreepModel((0.03,), (45.0,))
    # creep response: first-order lag of the load with gain beta
    a = np.exp(-1.0 / (rate * model.tau[0]))
    from scipy.signal import lfilter
    creep = lfilter([model.beta[0] * (1 - a)], [1, -a], load)
    signal = 2.0 * (load + creep) + 1e-3 * np.random.default_rng(0).standard_normal(n)
    write_record(path, Record(t, load, signal, metadata={"units.signal": "mV", "units.load": "N"}))


CHILD = ("import atexit, sys\n"
         "def peak():\n"
         "    hwm = [l for l in open('/proc/self/status') if l.startswith('VmHWM')][0]\n"
         "    open(sys.argv[1], 'w').write(hwm.split()[1])\n"
         "atexit.register(peak)\n"
         "from creepcomp.cli import main\n"
         "sys.exit(main(sys.argv[2:]))\n")


def run(args: list[str], cwd: Path) -> dict:
    """Run one command in a fresh process; its wall time and its own peak resident memory (kB
    read from VmHWM)."""
    peak_file = cwd / "peak.txt"
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", CHILD, str(peak_file), *args], cwd=cwd,
                          capture_output=True, text=True,
                          env={**os.environ, "PYTHONPATH": str(ROOT / "src")})
    seconds = time.perf_counter() - start
    peak = int(peak_file.read_text()) if peak_file.exists() else None
    return {"args": " ".join(args), "status": proc.returncode, "seconds": seconds,
            "peak_mb": peak * 1024 / 1e6 if peak else None,
            "last": (proc.stderr.strip().splitlines() or proc.stdout.strip().splitlines() or [""])[-1]}


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--samples", type=int, default=10_000_000)
    parser.add_argument("--mc", type=int, default=100_000_000)
    parser.add_argument("--only", default="fit,diagnose,correct,mc",
                        help="comma-separated cases to run (correct needs fit's model)")
    opts = parser.parse_args()
    only = set(opts.only.split(","))
    tmp = Path(tempfile.mkdtemp(prefix="creepcomp-bench-"))
    try:
        runs = []
        if only & {"fit", "diagnose", "correct"}:
            rec = tmp / "big.csv"
            t0 = time.perf_counter()
            make_record(rec, opts.samples)
            print(f"record: {opts.samples} samples, {rec.stat().st_size / 1e6:.0f} MB, float64 size "
                  f"{3 * 8 * opts.samples / 1e6:.0f} MB, written in {time.perf_counter() - t0:.1f} s")
            baseline = run(["size", "--beta0", "3%", "--tau", "45s"], tmp)
            print(f"baseline (size, imports only): {baseline['peak_mb']:.0f} MB")
            fit = run(["fit", str(rec), "-o", str(tmp / "model.json")], tmp)
            if "fit" in only:
                runs.append(fit)
            if "diagnose" in only:
                runs.append(run(["diagnose", str(rec), "--json"], tmp))
            if "correct" in only:
                runs.append(run(["correct", str(rec), "--model", str(tmp / "model.json"), "-o",
                                 str(tmp / "out.csv")], tmp))
        if opts.mc and "mc" in only:
            design = ROOT / "src" / "creepcomp" / "data" / "built_network.design.json"
            runs.append(run(["mc", str(design), "--n", str(opts.mc), "--spot-check", "0",
                             "--sensitivity-n", "0", "--no-worst-case"], tmp))
        data_mb = 3 * 8 * opts.samples / 1e6
        print(f"| command | exit | wall time | peak memory | of the record's float64 size "
              f"({data_mb:.0f} MB) | last line |")
        print("|---|---|---|---|---|---|")
        for r in runs:
            peak = f"{r['peak_mb']:.0f} MB" if r["peak_mb"] else "n/a"
            share = (f"{r['peak_mb'] / data_mb:.2f}x" if r["peak_mb"] and not r["args"].startswith("mc")
                     else "-")
            print(f"| `{r['args'].replace(str(tmp) + '/', '')}` | {r['status']} | {r['seconds']:.1f} s | "
                  f"{peak} | {share} | {r['last'][:100]} |")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
