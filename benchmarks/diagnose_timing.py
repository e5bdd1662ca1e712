"""Time ``diagnose`` on a 30-minute record sampled at 10 Hz (18,001 samples).

Three records are timed: a clean one, one hiding an extra retardation and one hiding
asymmetric recovery (the costliest effect: its creep term's time constant depends on its own
state). Each is diagnosed ``--repeat`` times; the best and the median wall time are printed,
with the process's CPU time (all its threads: what the diagnosis costs, whatever else the
machine runs) and the machine's load average (wall times are noisy on a shared machine).

Usage::

    python benchmarks/diagnose_timing.py [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import time

from creepcomp import synth
from creepcomp.diagnose.sensor import diagnose

CASES = {
    "clean": {},
    "extra_retardation": {"extra_retardation": {"tau": 400.0, "beta": 0.015}},
    "asymmetric_recovery": {"asymmetric_recovery": {"tau_recovery": 150.0}},
}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    print(f"load average before: {os.getloadavg()[0]:.2f}")
    for name, hidden in CASES.items():
        spec = synth.Spec(hidden=hidden, beta=(0.03,), tau=(45.0,), gain=1.0, rate=10.0, duration=1800.0,
                          program="staircase", noise=synth.NoiseSpec(white=5e-4), seed=30)
        record = synth.generate(spec).record
        times, cpu, cause = [], [], None
        for _ in range(args.repeat):
            t0, c0 = time.perf_counter(), time.process_time()
            cause = diagnose(record).cause
            times.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
        times.sort()
        cpu.sort()
        print(f"{name:20s} {len(record)} samples: cause {cause:20s} wall best {times[0]:.2f} s, "
              f"median {times[len(times) // 2]:.2f} s; CPU best {cpu[0]:.2f} s")
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
