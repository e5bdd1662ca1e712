"""Calibration of the stated uncertainties of ``fit_prony`` under strongly correlated noise.

Records: a sensor with two creep terms (beta 3 % and 2 % at 40 s and 400 s), 10 Hz for
1800 s, driven by a single load step (at 30 s) or by a staircase of load steps up and down
(where the record's step times are estimated too), with AR(1) noise of phi 0.99 (0.01 % of
full scale) plus a little white noise. The number of terms is given (2), so that every seed
gives the same parameters. Printed per program: the share of the estimates (every beta and
tau over the seeds) within one and within two stated standard deviations of the truth
(ideal: 68 % and 95 %), the median stated sigma of beta, and the fit's CPU time.

Usage::

    python benchmarks/fit_coverage.py [--seeds 20]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

BETAS = (0.03, 0.02)
TAUS = (40.0, 400.0)
RATE = 10.0
DURATION = 1800.0
PHI = 0.99
SIGMA = 1e-4


def load_program(t: np.ndarray, program: str) -> np.ndarray:
    """The load (full scale 1): one step at 30 s, or a staircase up and down."""
    if program == "step":
        return np.where(t >= 30.0, 1.0, 0.0)
    levels = np.array([0.0, 0.4, 1.0, 0.6, 0.2, 0.8, 0.0])
    edges = np.array([30.0, 250.0, 500.0, 800.0, 1100.0, 1400.0])
    return levels[np.searchsorted(edges, t, side="right")]


def record(seed: int, program: str):
    """(time, load, signal) of one record."""
    from creepcomp.lti import lag_states

    rng = np.random.default_rng(seed)
    t = np.arange(0.0, DURATION, 1.0 / RATE)
    load = load_program(t, program)
    e = rng.normal(0.0, SIGMA * np.sqrt(1.0 - PHI ** 2), t.size)
    ar = np.empty_like(e)
    ar[0] = rng.normal(0.0, SIGMA)
    for i in range(1, t.size):          # (a plain loop: the benchmark's own noise, once)
        ar[i] = PHI * ar[i - 1] + e[i]
    signal = load + lag_states(t, load, list(TAUS)) @ np.array(BETAS) + ar + rng.normal(0.0, 1e-5, t.size)
    return t, load, signal


def fitted(t, load, signal):
    """(betas, taus, beta sigmas, tau sigmas) sorted by tau, with 2 terms given."""
    from creepcomp.fit import fit_prony, prepare, term_table
    from creepcomp.io.records import Record

    rows = term_table(fit_prony(prepare(Record(t, load, signal)), n_terms=2).fit)
    return tuple(np.array([r[k] for r in rows]) for k in ("beta", "tau", "beta_sigma", "tau_sigma"))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=20)
    args = ap.parse_args(argv)
    print(f"AR(1) noise phi {PHI}, sigma {SIGMA:g} (full scale 1); beta {BETAS}, tau {TAUS} s; "
          f"{args.seeds} seeds; 2 terms given")
    print(f"{'program':10s} {'within 1 sd':>11s} {'within 2 sd':>11s} {'median sd(beta)':>16s} "
          f"{'median |err beta|':>18s} {'CPU s/fit':>10s}")
    for program in ("step", "staircase"):
        z, sds, errs, cpu = [], [], [], 0.0
        for seed in range(args.seeds):
            t, load, y = record(1000 + seed, program)
            start = time.process_time()
            betas, taus, sb, st = fitted(t, load, y)
            cpu += time.process_time() - start
            z += list(np.abs(betas - BETAS) / sb) + list(np.abs(taus - TAUS) / st)
            sds += list(sb)
            errs += list(np.abs(betas - BETAS))
        z = np.array(z)
        print(f"{program:10s} {np.mean(z < 1):11.0%} {np.mean(z < 2):11.0%} "
              f"{100 * np.median(sds):15.3f}% {100 * np.median(errs):17.3f}% {cpu / args.seeds:10.2f}")


if __name__ == "__main__":
    main()
