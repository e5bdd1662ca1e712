"""How long ngspice takes: one transient of the default design, and a 10^5-sample record.

Run: .venv/bin/python benchmarks/ngspice_transient.py [--repeats N]

The transient time (median of N runs through PySpice's shared ngspice: load the netlist, run
the transient, read the vectors back) is the yardstick the Monte Carlo engine is measured
against. Also timed: the same netlist through ``ngspice -b`` (a new process each time), a
batch of networks through one engine, and a measured record of 10^5 samples driving the
network through an XSPICE file source.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

from creepcomp.verify import compare, drive, netlist, ngspice_engine
from creepcomp.data import default_sensor
from creepcomp.programs import staircase
from creepcomp.analog.sizing import size


def median_seconds(fn, repeats: int) -> tuple[float, float]:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=21)
    parser.add_argument("--record-samples", type=int, default=100_000)
    args = parser.parse_args()
    load = os.getloadavg()[0]
    model = default_sensor()
    design = size(model)                                   # the default design: exact, E24/E6
    net = design.chosen
    engine = ngspice_engine.ngspice()
    program = drive.synthetic_program(model, "step", net)
    duration = drive.default_duration(program, model, net)
    deck = netlist.program_deck(net, model, program, duration)
    inner, points = ngspice_engine.time_transient(net, model, args.repeats, engine)
    full, _ = median_seconds(lambda: compare.compare_program(net, model, "step", engine=engine), 7)

    with tempfile.TemporaryDirectory() as tmp:
        path = netlist.write_deck(Path(tmp) / "default.cir", deck)
        batch, _ = median_seconds(lambda: subprocess.run(["ngspice", "-b", path.name], cwd=tmp,
                                                         capture_output=True, check=True), 7)

    variants = [net.with_parts([v * f for _, _, v in net.parts()])
                for f in np.linspace(0.95, 1.05, 20)]
    times = drive.transient_times(drive.spice_program(program, model, net), duration,
                                  drive.DEFAULT_POINTS)
    t0 = time.perf_counter()
    ngspice_engine.run_batch(variants, model, program, times, engine=engine)
    per_network = (time.perf_counter() - t0) / len(variants)

    n = args.record_samples
    t = np.arange(n) * 0.05
    prog = staircase(hold=t[-1] / 7)
    rng = np.random.default_rng(1)
    signal = 1e-4 * model.response(t, prog.sample(t)) + 1e-8 * rng.standard_normal(n)
    t0 = time.perf_counter()
    record = compare.compare_record(net, t, signal, engine=engine)
    record_total = time.perf_counter() - t0
    netlist_bytes = len(record.deck.text().encode())
    data_bytes = len(netlist.record_data(t, signal).encode())

    print(f"ngspice {engine.version}, load average {load:.2f} when started, "
          f"{os.cpu_count()} cores")
    print(f"default design: {', '.join(f'{lab} {v:.4g}' for lab, _, v in net.parts())}; "
          f"load step, {duration:g} s, {drive.DEFAULT_POINTS} output points")
    print(f"one transient, shared ngspice (load + run + read back), median of {args.repeats}: "
          f"{inner * 1e3:.1f} ms ({points} ngspice time points)")
    print(f"compare_program() (python-control reference and comparison), median of 7: {full * 1e3:.1f} ms")
    print(f"same netlist through ngspice -b (new process), median of 7: {batch * 1e3:.1f} ms")
    print(f"run_batch of {len(variants)} networks through one engine: "
          f"{per_network * 1e3:.1f} ms per network")
    print(f"record of {n} samples ({t[-1]:g} s at {t[1]:g} s): netlist {netlist_bytes} bytes, "
          f"data file {data_bytes / 1e6:.1f} MB; ngspice {record.ngspice_seconds:.2f} s "
          f"({record.ngspice_points} time points), total with reference {record_total:.2f} s; "
          f"agreement {record.agreement_max_abs:.2e} of the signal's range")


if __name__ == "__main__":
    main()
