"""Fit the rheojax polystyrene creep record (130 C) with the number of terms the evidence asks
for, with and without viscous flow, and diagnose it.

Data: ``tests/data/rheojax/creep_ps130_data.csv`` (imewei/rheojax, commit b79e79e7, MIT
licence, shipped with it): tab-separated ``Time`` and ``Creep Compliance`` after a stress step at
t = 0; 13,542 rows share a rounded time stamp and are averaged (``duplicate_times="mean"``).

Usage::

    python benchmarks/rheojax_fit.py [PATH]
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from creepcomp.diagnose.sensor import diagnose
from creepcomp.diagnose import effects
from creepcomp.fit.data import prepare
from creepcomp.fit.structure import Applied
from creepcomp.fit.prony import fit_prony, term_table
from creepcomp.io.records import parse_columns, read_record

DEFAULT = Path(__file__).resolve().parents[1] / "tests" / "data" / "rheojax" / "creep_ps130_data.csv"


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    path = Path(argv[0]) if argv else DEFAULT
    record = read_record(path, parse_columns("time=Time,signal=Creep Compliance,load=1"),
                         duplicate_times="mean")
    print(f"{path.name}: {len(record)} samples after merging "
          f"{record.metadata['merged_duplicate_times']} repeated time stamps")
    data = prepare(record, load_step_at=0.0)
    for flow in (False, True):
        t0 = time.perf_counter()
        result = fit_prony(data, max_terms=8, effects=(Applied(effects.get("viscous_flow")),) if flow else ())
        fit = result.fit
        print(f"\n{'with' if flow else 'without'} viscous flow ({time.perf_counter() - t0:.1f} s): "
              f"{fit.structure.n_terms} terms chosen; residual RMS {fit.residual_rms:.3g} 1/Pa = "
              f"{100 * fit.residual_rms / data.signal_scale:.3g} % of the compliance's range, held out "
              f"{fit.heldout.rms:.3g} 1/Pa ({100 * fit.heldout.rms / data.signal_scale:.3g} %); BIC {fit.bic:.1f}")
        for s in result.steps:
            ev = s.evidence
            print(f"  {s.n_terms} terms: RMS {s.fit.residual_rms:.3g}, held out {s.fit.heldout.rms:.3g}"
                  + (f", dBIC {ev.delta_bic:+.1f}, held-out z {ev.heldout_z:.1f}" if ev else ""))
        print(f"  J0 = {fit.gain:.4g} 1/Pa; terms (tau s, J_k 1/Pa): " + ", ".join(
            f"({t['tau']:.4g}, {t['beta'] * fit.gain:.3g})" for t in term_table(fit)))
        if flow:
            print(f"  flow: {fit.values['viscous_flow.flow']:.4g} 1/(Pa s) (1/viscosity)")
    t0 = time.perf_counter()
    d = diagnose(record, load_step_at=0.0, correction=False)
    print(f"\ndiagnose ({time.perf_counter() - t0:.1f} s): cause {d.cause}; findings "
          + "; ".join(f"{f.effect} {f.parameters}" for f in d.findings))


if __name__ == "__main__":
    main()
