"""How few samples a long record can be reduced to before its fit loses accuracy or
calibration: the three-term step record of ``benchmarks/peers.py`` (10 Hz, as long as needed)
reduced by :func:`~creepcomp.fit.reduce.reduce_record` to each target, then fitted with the
number of terms given (3) and chosen.

Printed per record length, noise (white, and AR(1) of phi 0.99 with the same variance) and
target: the samples fitted, the largest relative error of beta and of tau (median over seeds),
the share of |error| / stated sigma below 1 and 2 over every beta and tau and seed (ideal 68 %
and 95 %), how many seeds chose 3 terms (a fit that fails is named), and the median CPU
seconds of the fit with 3 terms given (reduction excluded).

Usage::

    python benchmarks/reduced_fit.py [--seeds 10] [--sizes 10000,100000,1000000]
        [--targets 50000,20000,15000,10000] [--phis 0,0.99] [--no-auto]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import peers  # noqa: E402


def fitted(record, n_terms):
    """(betas, taus, beta sigmas, tau sigmas, samples fitted, CPU s) of one fit."""
    from creepcomp.fit import fit_prony, prepare, term_table

    start = time.process_time()
    data = prepare(record)
    rows = term_table(fit_prony(data, n_terms=n_terms).fit)
    cpu = time.process_time() - start
    return (*(np.array([r[k] for r in rows]) for k in ("beta", "tau", "beta_sigma", "tau_sigma")),
            data.n, cpu)


def main(argv=None):
    from creepcomp.fit.reduce import reduce_record
    from creepcomp.io.records import Record

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--sizes", default="10000,100000,1000000")
    ap.add_argument("--targets", default="50000,20000,15000,10000")
    ap.add_argument("--phis", default="0,0.99")
    ap.add_argument("--no-auto", action="store_true", help="skip the fits that choose the terms")
    args = ap.parse_args(argv)
    truth_b, truth_t = np.array(peers.BETAS), np.array(peers.TAUS)
    print(f"{'samples':>9s} {'phi':>5s} {'target':>7s} {'fitted':>7s} {'beta err':>9s} {'tau err':>9s} "
          f"{'cover 1sd':>9s} {'cover 2sd':>9s} {'3 chosen':>8s} {'CPU s':>6s}")
    for n in (int(s) for s in args.sizes.split(",")):
        for phi in (float(p) for p in args.phis.split(",")):
            records = [Record(*peers.record(100 + seed, phi, duration=n / 10.0))
                       for seed in range(args.seeds)]
            for target in (int(s) for s in args.targets.split(",")):
                if target > n and target != max(int(s) for s in args.targets.split(",")):
                    continue
                z, eb, et, cpu, chosen, m, failed = [], [], [], [], 0, 0, []
                for seed, record in enumerate(records):
                    reduced = reduce_record(record, target)[0]
                    b, t, sb, st, m, c = fitted(reduced, 3)
                    z += list(np.abs(b - truth_b) / sb) + list(np.abs(t - truth_t) / st)
                    eb.append(np.max(np.abs(b / truth_b - 1)))
                    et.append(np.max(np.abs(t / truth_t - 1)))
                    cpu.append(c)
                    if not args.no_auto:
                        try:
                            chosen += len(fitted(reduced, None)[0]) == 3
                        except (ArithmeticError, ValueError) as exc:     # (counted, said)
                            failed.append(f"seed {100 + seed}: {type(exc).__name__}")
                z = np.array(z)
                print(f"{n:9d} {phi:5.2f} {target:7d} {m:7d} {np.median(eb):9.2%} {np.median(et):9.2%} "
                      f"{np.mean(z < 1):9.0%} {np.mean(z < 2):9.0%} "
                      f"{'-' if args.no_auto else f'{chosen}/{len(records)}':>8s} {np.median(cpu):6.2f}"
                      + (f"  failed: {', '.join(failed)}" if failed else ""),
                      flush=True)


if __name__ == "__main__":
    main()
