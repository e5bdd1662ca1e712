"""Speed of the tolerance Monte Carlo engine: 10^6 samples of the default design.

Run: .venv/bin/python benchmarks/mc_speed.py [--n 1000000] [--repeats 3]
Prints the median wall time over repeats (all cores), per-sample time, and, when ngspice is
available, the ratio against the median time of one ngspice transient of the same design.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

from creepcomp.verify.montecarlo import run_monte_carlo
from creepcomp.verify.ngspice_engine import time_transient
from creepcomp.verify.tolerances import ToleranceSpec
from creepcomp.data import default_sensor
from creepcomp.io.jsonfiles import Design
from creepcomp.analog.sizing import size


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--n", type=int, default=1_000_000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    model = default_sensor()
    design = Design(model, size(model).chosen)
    print(f"default design: {design.network.parts()}, {os.cpu_count()} cores, load {os.getloadavg()[0]:.2f}")
    per_sample = {}
    for label, spec in (("E24 1 % resistors, 5 % capacitor", ToleranceSpec()),
                        ("same, polyester dielectric (absorption, leakage)", ToleranceSpec(dielectric="polyester"))):
        times = []
        for r in range(args.repeats):
            start = time.perf_counter()
            result = run_monte_carlo(design, spec, args.n, seed=r)
            times.append(time.perf_counter() - start)
        med = statistics.median(times)
        per_sample[label] = med / args.n
        print(f"{label}: {args.n} samples in {med:.2f} s (median of {args.repeats}; "
              f"{[round(t, 2) for t in times]}), {1e6 * med / args.n:.2f} µs per sample; "
              f"p99 peak residual creep {100 * result.percentiles()['p99']:.4f} %")
    transient, _ = time_transient(design.network, model)
    for label, t in per_sample.items():
        print(f"{label}: {transient / t:,.0f}x faster per sample than one ngspice transient "
              f"({1e3 * transient:.1f} ms)")


if __name__ == "__main__":
    main()
