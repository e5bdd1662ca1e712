"""Long clean records for the reduction of ``fit`` and ``diagnose``: a staircase of eight load
levels (as :mod:`big_records`) at 10 Hz, one creep term (beta 3 %, tau 45 s) or a second one,
white noise; written with the project's writer.

    python benchmarks/long_one_term.py OUT.csv [--samples 3000000] [--noise 1e-5]
        [--second BETA@TAU]

Then time the commands on it, e.g. ``/usr/bin/time -v creepcomp diagnose OUT.csv --json``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy.signal import lfilter

ROOT = Path(__file__).resolve().parents[1]


def make_record(n: int, noise: float, terms, rate: float = 10.0):
    """The staircase record (load levels 0, 1, 2, 3, 2, 1, 3, 0 over eighths of the record)."""
    sys.path.insert(0, str(ROOT / "src"))
    from creepcomp.io.records import Record

    t = np.arange(n) / rate
    edges = np.linspace(0, t[-1], 9)[1:-1]
    levels = np.array([0, 1, 2, 3, 2, 1, 3, 0], float)
    load = levels[np.searchsorted(edges, t, side="right")]
    signal = load.copy()
    for beta, tau in terms:
        a = np.exp(-1.0 / (rate * tau))
        signal += lfilter([beta * (1 - a)], [1, -a], load)    # first-order lag of the load
    signal += noise * np.random.default_rng(0).standard_normal(n)
    return Record(t, load, signal, metadata={"units.signal": "mV", "units.load": "N"})


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("out")
    parser.add_argument("--samples", type=float, default=3e6)
    parser.add_argument("--noise", type=float, default=1e-5)
    parser.add_argument("--second", default=None, help="a second term, BETA@TAU (e.g. 0.01@4)")
    opts = parser.parse_args()
    terms = [(0.03, 45.0)]
    if opts.second:
        beta, tau = opts.second.split("@")
        terms.append((float(beta), float(tau)))
    from creepcomp.io.records import write_record

    write_record(opts.out, make_record(int(opts.samples), opts.noise, terms))


if __name__ == "__main__":
    main()
