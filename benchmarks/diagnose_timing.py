"""Time ``diagnose`` on a 30-minute record sampled at 10 Hz (18,001 samples) and on a
100,000-sample record (2,000 s at 50 Hz), against the goals of 10 s and 30 s.

At each size, first three fixed records: a clean one, one hiding an extra retardation and one
hiding asymmetric recovery (its creep term's time constant depends on its own state). Then,
with ``--seeds N``, N random records (:func:`creepcomp.synth.sensor.random_spec` at that rate
and duration) of every kind the diagnosis must tell apart: clean, each hidden effect, each
``data_problem`` and each effect no template describes. Each record is diagnosed ``--repeat``
times with ``--jobs`` processes (default: one per core available, as ``creepcomp diagnose``);
the best and the median wall time are printed, with the CPU time of the process and of its
worker processes (all their threads: what the diagnosis costs, whatever else the machine
runs) and the machine's load average (wall times are noisy on a shared machine). Records longer than
:data:`~creepcomp.diagnose.sensor.DIAGNOSE_MAX_SAMPLES` are reduced by block means first (part
of the timed diagnosis). The summary gives, per size, the median and the largest time over all
records, against the goal. The process's first diagnosis (a short record, :func:`warm_up`)
is timed apart: it imports the modules the search uses and loads the compiled loops, a cost
of the process and not of the record that happens to come first; the times of its tasks,
which order the tasks of the next diagnoses, are forgotten
(:func:`~creepcomp.diagnose.workers.forget_task_times`: they are several times the later ones).

Usage::

    python benchmarks/diagnose_timing.py [--repeat 3] [--seeds 2] [--sizes 0,1] [--kinds clean,time_offset] [--jobs 1]

``--sizes``: which of :data:`SIZES` to run (by index, 0: the 30-minute record at 10 Hz);
``--kinds``: only records whose label starts with one of these (the fixed ones and the random
kinds alike).
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import time

from creepcomp import synth
from creepcomp.diagnose.sensor import diagnose
from creepcomp.diagnose.workers import available_cores, forget_task_times
from creepcomp.synth.sensor import DATA_PROBLEMS, EFFECTS, NO_TEMPLATE, random_spec

CASES = {
    "clean": {},
    "extra_retardation": {"extra_retardation": {"tau": 400.0, "beta": 0.015}},
    "asymmetric_recovery": {"asymmetric_recovery": {"tau_recovery": 150.0}},
}

#: (sample rate in Hz, duration in s, goal in s): a 30-minute record at 10 Hz, and 100,000
#: samples.
SIZES = ((10.0, 1800.0, 10.0), (50.0, 1999.98, 30.0))

#: Kinds of random record: (label, effect for random_spec, form).
RANDOM_KINDS = ([("clean", None, None)] + [(e, e, None) for e in EFFECTS]
                + [(f"data_problem/{k}", "data_problem", k) for k in DATA_PROBLEMS]
                + [(e, e, None) for e in NO_TEMPLATE])


def _records(rate: float, duration: float, seeds: int, kinds=None):
    """(label, record) of the fixed cases, then of ``seeds`` random records per kind (only
    labels starting with one of ``kinds``, when given)."""
    for label, record in _all_records(rate, duration, seeds):
        if kinds is None or label.startswith(tuple(kinds)):
            yield label, record


def _all_records(rate: float, duration: float, seeds: int):
    for name, hidden in CASES.items():
        spec = synth.Spec(hidden=hidden, beta=(0.03,), tau=(45.0,), gain=1.0, rate=rate, duration=duration,
                          program="staircase", noise=synth.NoiseSpec(white=5e-4), seed=30)
        yield name, synth.generate(spec).record
    for seed in range(seeds):
        for label, effect, form in RANDOM_KINDS:
            spec = random_spec(effect, 9000 + seed, rate=(rate, rate), duration=(duration, duration), form=form)
            yield f"{label} (seed {9000 + seed}, {spec.program})", synth.generate(spec).record


def warm_up(jobs: int) -> float:
    """Diagnose a 5-minute record once (the process's first diagnosis) and forget its tasks'
    times; its wall time in s."""
    spec = synth.Spec(beta=(0.03,), tau=(45.0,), gain=1.0, rate=10.0, duration=300.0, program="staircase",
                      noise=synth.NoiseSpec(white=5e-4), seed=31)
    record = synth.generate(spec).record
    t0 = time.perf_counter()
    diagnose(record, jobs=jobs)
    seconds = time.perf_counter() - t0
    forget_task_times()
    return seconds


def _cpu_seconds() -> float:
    """CPU time of this process and of its worker processes ended so far."""
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--seeds", type=int, default=0, help="random records per kind (0: the fixed three only)")
    ap.add_argument("--sizes", default=None, help="indices of the sizes to run, comma-separated (default: all)")
    ap.add_argument("--kinds", default=None, help="record labels to run (prefixes, comma-separated)")
    ap.add_argument("--jobs", type=int, default=available_cores(),
                    help="processes per diagnosis (default: one per core available)")
    args = ap.parse_args(argv)
    sizes_run = SIZES if args.sizes is None else [SIZES[int(i)] for i in args.sizes.split(",")]
    kinds = None if args.kinds is None else args.kinds.split(",")
    print(f"load average before: {os.getloadavg()[0]:.2f}; {args.jobs} process(es) per diagnosis")
    print(f"first diagnosis in this process (3,001 samples; imports, compiled loops loaded): "
          f"{warm_up(args.jobs):.2f} s, not counted")
    summary = []
    for rate, duration, goal in sizes_run:
        walls, cpus, sizes = [], [], set()
        for label, record in _records(rate, duration, args.seeds, kinds):
            n = len(record)
            sizes.add(n)
            times, cpu, cause = [], [], None
            for _ in range(args.repeat):
                t0, c0 = time.perf_counter(), _cpu_seconds()
                cause = diagnose(record, jobs=args.jobs).cause
                times.append(time.perf_counter() - t0)
                cpu.append(_cpu_seconds() - c0)
            times.sort()
            cpu.sort()
            walls.append(times[len(times) // 2])
            cpus.append(cpu[0])
            print(f"{label:52s} {n} samples: cause {cause:28s} wall best {times[0]:.2f} s, "
                  f"median {times[len(times) // 2]:.2f} s; CPU best {cpu[0]:.2f} s "
                  f"(load {os.getloadavg()[0]:.1f})", flush=True)
        size = f"{min(sizes)}" if len(sizes) == 1 else f"{min(sizes)}-{max(sizes)}"
        summary.append((size, goal, len(walls), walls, cpus))
    print(f"load average after: {os.getloadavg()[0]:.2f}")
    print("\n| record size | goal | records | wall median | wall largest | CPU median | CPU largest |")
    print("|---|---|---|---|---|---|---|")
    for size, goal, count, walls, cpus in summary:
        print(f"| {size} samples | {goal:g} s | {count} | {statistics.median(walls):.2f} s | {max(walls):.2f} s | "
              f"{statistics.median(cpus):.2f} s | {max(cpus):.2f} s |")


if __name__ == "__main__":
    main()
