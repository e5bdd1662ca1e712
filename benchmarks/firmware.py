"""The generated C corrector: proven bound, measured error, speed and size; bound vs tau * rate.

    nice -n 10 .venv/bin/python benchmarks/firmware.py [--samples 360000] [--figure docs/images/firmware-bound.png]

1. The 3-term model (beta 1 %, 1 %, 1.5 %; tau 5 s, 50 s, 500 s) at 100 Hz over a record of
   ``--samples`` samples (steps between random levels up to full scale, held up to 10 min, a
   sweep and sample-to-sample full-scale swings): for float32 and q31, subtractive and
   supplemental, the proven ``bound_fs``, the measured ``max_error_fs`` against the float64
   corrector, ns per sample (host harness, gcc -O2, best of 5) and the object's size; and the
   naive float32 recursion (``c = e c + (1 - e) S``) on the same record. The same on a
   full-scale step held for twice as many samples (2 h at 360,000), where the naive
   recursion's states stall short of their target.
   And the dt step (``--max-interval 40ms``) on a jittered record: intervals uniform in
   [0.5, 1.5] / 100 Hz (whole microseconds) with 20 gaps of 40 ms, steps and swings.
2. One creep term (beta 1.5 %) at tau * rate from 3 to 3e6: the bound of both precisions, and
   the measured error of both and of the naive recursion over 200,000 samples of load steps
   (every 20,000 samples). Plotted into ``--figure``.

Prints Markdown tables for docs/firmware.md.
"""

from __future__ import annotations

import argparse
import platform
import sys
from pathlib import Path

import numpy as np

from creepcomp.digital.firmware import firmware_bound, generate_firmware, naive_float32
from creepcomp.digital.firmware_check import jittered_record, verify_firmware
from creepcomp.model import CreepModel

MODEL = CreepModel(beta=(0.01, 0.01, 0.015), tau=(5.0, 50.0, 500.0))
RATE = 100.0


def mixed_record(model: CreepModel, rate: float, n: int, seed: int = 0):
    """Steps, a sweep and full-scale swings (as tests/test_firmware.py), scaled to |x| <= 1."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / rate
    load = np.zeros(n)
    i, quarter = n // 20, n // 4
    while i < 2 * quarter:
        hold = int(rng.integers(5, int(600 * rate)))
        load[i:i + hold] = rng.choice([-1.0, 1.0, rng.uniform(-1, 1)])
        i += hold
    s = np.arange(2 * quarter, 3 * quarter)
    load[s] = np.sin(2 * np.pi * s / (0.3 * quarter)) * np.cos(2 * np.pi * s / 37.0)
    swing = np.arange(3 * quarter, n)
    load[swing] = np.where((swing // 2) % 2 == 0, 1.0, -1.0)
    signal = model.response(t, load, hold="zero")
    return t, signal, float(np.max(np.abs(signal - model.offset)))


def held_step(model: CreepModel, rate: float, n: int):
    """A full-scale step at 10 s, held to the end of the record."""
    t = np.arange(n) / rate
    signal = model.response(t, np.where(t >= 10.0, 1.0, 0.0), hold="zero")
    return t, signal, float(np.max(np.abs(signal - model.offset)))


def three_term_table(samples: int) -> list[str]:
    rows = ["| record | precision | method | bound_fs | measured max_error_fs | ns per sample | object bytes |",
            "|---|---|---|---|---|---|---|"]
    records = {f"mixed, {samples} samples": mixed_record(MODEL, RATE, samples),
               f"step held {2 * samples / RATE / 3600:.3g} h, {2 * samples} samples":
                   held_step(MODEL, RATE, 2 * samples)}
    for label, (t, signal, fs) in records.items():
        for precision in ("float32", "q31"):
            for method in ("subtractive", "supplemental"):
                fw = generate_firmware(MODEL, method, precision, RATE, fs)
                check = verify_firmware(fw, t, signal)
                assert check.passed, (precision, method)
                rows.append(f"| {label} | {precision} | {method} | {fw.bound.total_fs:.2e} | "
                            f"{check.max_error_fs:.2e} | {check.ns_per_sample:.1f} | {check.object_bytes} |")
        for method in ("subtractive", "supplemental"):
            check = verify_firmware(naive_float32(MODEL, method, RATE, fs), t, signal)
            rows.append(f"| {label} | naive float32 | {method} | none | {check.max_error_fs:.2e} "
                        f"| {check.ns_per_sample:.1f} | {check.object_bytes} |")
    return rows


def jittered_table(samples: int, max_interval: float = 0.04) -> list[str]:
    t, _, signal = jittered_record(MODEL, samples, seed=0, rate=RATE, max_interval=max_interval,
                                   max_hold=600.0)
    fs = float(np.max(np.abs(signal - MODEL.offset)))
    rows = []
    for precision in ("float32", "q31"):
        for method in ("subtractive", "supplemental"):
            fw = generate_firmware(MODEL, method, precision, full_scale=fs, max_interval=max_interval)
            check = verify_firmware(fw, t, signal)
            assert check.passed, (precision, method)
            rows.append(f"| jittered 100 Hz (dt step, max 40 ms), {samples} samples | {precision} | "
                        f"{method} | {fw.bound.total_fs:.2e} | {check.max_error_fs:.2e} | "
                        f"{check.ns_per_sample:.1f} | {check.object_bytes} |")
    return rows


def sweep_tau_rate(figure: Path | None) -> list[str]:
    rate, n = 100.0, 200_000
    t = np.arange(n) / rate
    load = np.where((np.arange(n) // 20_000) % 2 == 1, 1.0, 0.0)
    grid = np.logspace(np.log10(3), np.log10(3e6), 40)
    points = np.array([3, 30, 300, 3e3, 3e4, 3e5, 3e6])
    bounds = {p: [firmware_bound(CreepModel((0.015,), (g / rate,)), "subtractive", p, rate, 1.0).total_fs
                  for g in grid] for p in ("float32", "q31")}
    measured = {"float32": [], "q31": [], "naive float32": []}
    rows = ["| tau * rate | bound float32 | measured float32 | bound q31 | measured q31 | naive float32 measured |",
            "|---|---|---|---|---|---|"]
    for g in points:
        model = CreepModel((0.015,), (g / rate,))
        signal = model.response(t, load, hold="zero")
        fs = float(np.max(np.abs(signal)))
        row = [f"{g:.0e}"]
        for p in ("float32", "q31"):
            fw = generate_firmware(model, "subtractive", p, rate, fs)
            check = verify_firmware(fw, t, signal, repeats=1)
            assert check.passed, (p, g)
            measured[p].append(check.max_error_fs)
            row += [f"{fw.bound.total_fs:.2e}", f"{check.max_error_fs:.2e}"]
        naive = verify_firmware(naive_float32(model, "subtractive", rate, fs), t, signal, repeats=1)
        measured["naive float32"].append(naive.max_error_fs)
        rows.append("| " + " | ".join(row + [f"{naive.max_error_fs:.2e}"]) + " |")
    if figure is not None:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 4.2))
        ax.loglog(grid, bounds["float32"], "-", color="C0", label="bound, float32 (hi + lo states)")
        ax.loglog(grid, bounds["q31"], "-", color="C1", label="bound, q31 (64-bit states)")
        ax.loglog(points, measured["float32"], "o", color="C0", label="measured, float32")
        ax.loglog(points, measured["q31"], "s", color="C1", label="measured, q31")
        ax.loglog(points, measured["naive float32"], "x-", color="C3",
                  label="measured, naive float32 c = e c + (1 - e) S")
        ax.axhline(1e-5, color="0.5", ls=":", label="target 1e-5 FS")
        ax.set_xlabel("tau * rate (samples per time constant)")
        ax.set_ylabel("|C - float64 corrector| / full scale")
        ax.set_title("One creep term, beta = 1.5 %: 200,000 samples of load steps")
        ax.grid(True, which="major", alpha=0.3)
        ax.set_ylim(3e-10, 3e-4)
        ax.legend(fontsize=7, loc="upper left", ncol=2)
        fig.tight_layout()
        figure.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(figure, dpi=110)
        plt.close(fig)
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=360_000)
    parser.add_argument("--figure", type=Path, default=Path("docs/images/firmware-bound.png"))
    parser.add_argument("--only-jitter", action="store_true", help="only the dt step's rows")
    args = parser.parse_args(argv)
    print(f"{platform.processor() or platform.machine()}, Python {sys.version.split()[0]}")
    print("\n".join(jittered_table(args.samples)))
    if args.only_jitter:
        return 0
    print(f"\n3-term model at {RATE:g} Hz, {args.samples} samples:\n")
    print("\n".join(three_term_table(args.samples)))
    print("\nOne term (beta 1.5 %), bound and measured error vs tau * rate:\n")
    print("\n".join(sweep_tau_rate(args.figure)))
    print(f"\nfigure written to {args.figure}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
