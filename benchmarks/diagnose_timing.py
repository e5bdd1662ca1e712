"""Time ``diagnose`` on a 30-minute record sampled at 10 Hz (18,001 samples) and on a
100,000-sample record (2,000 s at 50 Hz).

At each size three records are timed: a clean one, one hiding an extra retardation and one
hiding asymmetric recovery (the costliest effect: its creep term's time constant depends on
its own state). Each is diagnosed ``--repeat`` times; the best and the median wall time are
printed, with the process's CPU time (all its threads: what the diagnosis costs, whatever else
the machine runs) and the machine's load average (wall times are noisy on a shared machine).
Records longer than :data:`~creepcomp.diagnose.sensor.DIAGNOSE_MAX_SAMPLES` are reduced by
block means first (part of the timed diagnosis).

Usage::

    python benchmarks/diagnose_timing.py [--repeat 3]
"""

from __future__ import annotations

import argparse
import itertools
import os
import time

from creepcomp import synth
from creepcomp.diagnose.sensor import diagnose

CASES = {
    "clean": {},
    "extra_retardation": {"extra_retardation": {"tau": 400.0, "beta": 0.015}},
    "asymmetric_recovery": {"asymmetric_recovery": {"tau_recovery": 150.0}},
}

#: (sample rate in Hz, duration in s): a 30-minute record at 10 Hz, and 100,000 samples.
SIZES = ((10.0, 1800.0), (50.0, 1999.98))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    print(f"load average before: {os.getloadavg()[0]:.2f}")
    for (name, hidden), (rate, duration) in itertools.product(CASES.items(), SIZES):
        spec = synth.Spec(hidden=hidden, beta=(0.03,), tau=(45.0,), gain=1.0, rate=rate, duration=duration,
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
