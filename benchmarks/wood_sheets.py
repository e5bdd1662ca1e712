"""Sparse records: ``fit`` on every shipped spruce creep specimen (``creepcomp.data``, 16-58
samples each), and the choice of the number of terms judged by held-out prediction.

Per specimen: the samples, whether ``fit_prony`` fits it (or the reason it refuses), the
terms it chooses, and the held-out error of two rules for the number of terms, each applied
to the first half of the record (by time) and simulated over the second half from the load:
creepcomp's (on these sparse records the small-sample corrected AIC) and a plain BIC choice
over 1 ... 4 terms (the lowest
BIC of the fits creepcomp makes with the number given). Held-out error: RMS of the second
half's residual, relative to the signal's range. The summary gives the number fitted and on
how many specimens each rule predicts better.

With ``--workbook``, every sheet of the source workbook instead (the 34 specimens of
``LR_samples_results.xlsx`` at 30, 65 and 90 % RH, read by :mod:`creepcomp.io.wood` with the
elastic strain added as for the shipped ones).

With ``--rules``, other rules for a sparse record's number of terms, each adding a term while
its criterion drops by more than a margin (BIC by 0, 2, 4, 6, 10; AICc by 0): the median
held-out error of each on the specimens, and how often each takes more than one term on
one-term sparse creep tests (``tests/test_sparse_fit.py``'s record, 30 seeds at 6-19 samples),
where every further term is noise.

Usage::

    python benchmarks/wood_sheets.py [--workbook ../shared/data/wood/LR_samples_results.xlsx] [--rules]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from creepcomp import data
from creepcomp.errors import InputError
from creepcomp.fit import fit_prony, prepare
from creepcomp.fit.prony import corrected_aic
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
    fits = _orders(d)
    if not fits:
        raise InputError("no number of terms could be fitted")
    return min(fits, key=lambda f: f.bic)


def _specimens(workbook: str | None):
    """(name, record) of the shipped specimens, or of every sheet of ``workbook``."""
    if workbook is None:
        for level in (0.3, 0.5):
            for name in data.wood_specimens(level):
                yield name, data.wood_creep(level, name)
        return
    from creepcomp.io.wood import read_wood_sheet, wood_record, wood_sheets

    for name in wood_sheets(workbook):
        yield name, wood_record(read_wood_sheet(workbook, name))


#: Rules of :func:`rules`: name -> (criterion of a fit, margin by which it must drop).
RULES = {**{f"BIC lower by {m}": (lambda f: f.bic, m) for m in (0, 2, 4, 6, 10)},
         "AICc lower": (corrected_aic, 0)}


def _orders(d) -> list:
    """Fits of 1 ... MAX_TERMS terms (as many as can be fitted)."""
    fits = []
    for n in range(1, MAX_TERMS + 1):
        try:
            fits.append(fit_prony(d, n_terms=n).fit)
        except InputError:
            break
    return fits


def _chosen(fits: list, criterion, margin: float) -> int:
    """Index of the fit a rule keeps: terms added while the criterion drops by more than
    ``margin``."""
    best = 0
    for k in range(1, len(fits)):
        if not criterion(fits[k]) < criterion(fits[best]) - margin:
            break
        best = k
    return best


def rules(workbook: str | None) -> None:
    """Median held-out error of each rule on the specimens, and its choices of more than one
    term on one-term sparse records."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from test_sparse_fit import creep_test

    errors = {name: [] for name in RULES}
    for _, r in _specimens(workbook):
        fits = _orders(prepare(_half(r), load_step_at=0.0))
        for name, (criterion, margin) in RULES.items():
            errors[name].append(_heldout_error(r, fits[_chosen(fits, criterion, margin)]))
    sizes = (6, 8, 10, 12, 16, 19)
    print("| rule | median held-out error (specimens) | " + " | ".join(f"one-term, {n} samples" for n in sizes) + " |")
    print("|---|---|" + "---|" * len(sizes))
    extra = {name: [] for name in RULES}
    for n in sizes:
        counts = dict.fromkeys(RULES, 0)
        for seed in range(30):
            fits = _orders(prepare(creep_test(n, seed), load_step_at=0.0))
            for name, (criterion, margin) in RULES.items():
                counts[name] += _chosen(fits, criterion, margin) > 0
        for name in RULES:
            extra[name].append(counts[name])
    for name in RULES:
        print(f"| {name} | {np.median(errors[name]):.2%} | " + " | ".join(f"{c} of 30" for c in extra[name]) + " |")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--workbook", default=None, help="every sheet of this workbook (default: the shipped specimens)")
    ap.add_argument("--rules", action="store_true", help="compare rules for the number of terms")
    args = ap.parse_args(argv)
    if args.rules:
        rules(args.workbook)
        return
    print("| specimen | samples | fit | terms | held-out, creepcomp | held-out, BIC rule | terms (half): creepcomp / BIC |")
    print("|---|---|---|---|---|---|---|")
    fitted = better = worse = compared = total = 0
    errors = []
    start = time.process_time()
    for name, r in _specimens(args.workbook):
        total += 1
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
        errors.append((e_ours, e_bic))
        better += e_ours < e_bic * (1 - 1e-6)
        worse += e_bic < e_ours * (1 - 1e-6)
        print(f"| {name} | {len(r)} | {status} | {chosen} | {e_ours:.3%} | {e_bic:.3%} | "
              f"{ours.structure.n_terms} / {plain.structure.n_terms} |")
    print(f"\nfitted {fitted} of {total}; held-out comparison on {compared}: creepcomp's choice better on "
          f"{better}, the BIC rule better on {worse}, equal on {compared - better - worse}; "
          f"CPU {time.process_time() - start:.1f} s")
    if errors:
        ours, bic = np.median(np.array(errors), axis=0)
        print(f"median held-out error: creepcomp's choice {ours:.2%}, the BIC rule {bic:.2%} of the signal's range")


if __name__ == "__main__":
    main()
