"""Sparse records: ``fit`` on every shipped spruce creep specimen (``creepcomp.data``, 16-58
samples each), and the choice of the number of terms judged by held-out prediction.

Per specimen: the samples, whether ``fit_prony`` fits it (or the reason it refuses), the
terms it chooses, and the held-out error of two rules for the number of terms, each applied
to the first half of the record (by time) and simulated over the second half from the load:
creepcomp's (BIC and held-out blocks) and a plain BIC choice over 1 ... 4 terms (the lowest
BIC of the fits creepcomp makes with the number given). Held-out error: RMS of the second
half's residual, relative to the signal's range. The summary gives the number fitted and on
how many specimens each rule predicts better.

Usage::

    python benchmarks/wood_sheets.py
"""

from __future__ import annotations

import time

import numpy as np

from creepcomp import data
from creepcomp.errors import InputError
from creepcomp.fit import fit_prony, prepare
from creepcomp.io.records import Record

MAX_TERMS = 4


def _half(record: Record) -> Record:
    """The record's first half by time."""
    t = record.time
    keep = t <= t[0] + 0.5 * (t[-1] - t[0])
    return Record(t[keep], record.load[keep], record.signal[keep])


def _heldout_error(record: Record, fit) -> float:
    """RMS of the second half's residual of ``fit`` (fitted on the first half), relative to
    the record's signal range."""
    full = prepare(Record(record.time, record.load, record.signal), load_step_at=0.0)
    rest = record.time > record.time[0] + 0.5 * (record.time[-1] - record.time[0])
    residual = full.signal - fit.simulate(full)
    return float(np.sqrt(np.mean(residual[rest] ** 2)) / np.ptp(full.signal))


def _bic_choice(d):
    """The fit of least BIC over 1 ... MAX_TERMS terms (the orders that could be fitted)."""
    fits = []
    for n in range(1, MAX_TERMS + 1):
        try:
            fits.append(fit_prony(d, n_terms=n).fit)
        except InputError:
            break
    if not fits:
        raise InputError("no number of terms could be fitted")
    return min(fits, key=lambda f: f.bic)


def main():
    print("| specimen | samples | fit | terms | held-out, creepcomp | held-out, BIC rule | terms (half): creepcomp / BIC |")
    print("|---|---|---|---|---|---|---|")
    fitted = better = worse = compared = 0
    start = time.process_time()
    for level in (0.3, 0.5):
        for name in data.wood_specimens(level):
            r = data.wood_creep(level, name)
            try:
                chosen = fit_prony(prepare(r, load_step_at=0.0)).fit.structure.n_terms
                fitted += 1
                status = "fitted"
            except InputError as exc:
                print(f"| {name} | {len(r)} | refused: {exc} | | | | |")
                continue
            try:
                half = prepare(_half(r), load_step_at=0.0)
                ours = fit_prony(half).fit
                plain = _bic_choice(half)
            except InputError as exc:
                print(f"| {name} | {len(r)} | {status} | {chosen} | first half refused: {exc} | | |")
                continue
            e_ours, e_bic = _heldout_error(r, ours), _heldout_error(r, plain)
            compared += 1
            better += e_ours < e_bic * (1 - 1e-6)
            worse += e_bic < e_ours * (1 - 1e-6)
            print(f"| {name} | {len(r)} | {status} | {chosen} | {e_ours:.3%} | {e_bic:.3%} | "
                  f"{ours.structure.n_terms} / {plain.structure.n_terms} |")
    total = len(data.wood_specimens())
    print(f"\nfitted {fitted} of {total}; held-out comparison on {compared}: creepcomp's choice better on "
          f"{better}, the BIC rule better on {worse}, equal on {compared - better - worse}; "
          f"CPU {time.process_time() - start:.1f} s")


if __name__ == "__main__":
    main()
