"""Fit and diagnose a measured pressure insole: one capacitive taxel in an air chamber.

The records ship with creepcomp (``creepcomp.data.insole_left_steps()``: left insole, taxel
128, a pressure staircase up and down; ``insole_right_staircase()``: right insole, taxel 123,
~0.2 bar steps held 15-30 s), trimmed from the data of Belli et al., Sensors 2023 (BSD-3;
licence and source beside the files). ``load`` is the chamber pressure (bar), ``signal`` the
taxel's raw counts, which fall under pressure: the fitted gain is negative, and the creep
fraction ``beta`` keeps its meaning (creep relative to the instantaneous response).

For each record the script prints the model ``fit`` chooses by evidence (gain, creep terms,
residual), then the diagnosis: the verdict, findings, the residual before and after and the
gain. It writes into ``--out``: ``<record>-fit.png`` (measured, fitted, residual) and, per
record, ``<record>/report.html`` with ``diagnosis.json`` and the models.

Run it::

    python examples/real_insole.py                 # both records, whole length (~1-2 min)
    python examples/real_insole.py --record left   # one of them

``--fast`` keeps every 4th sample (12.5 Hz instead of 50 Hz, the whole length), fits at most
two terms and tries only ``extra_retardation`` in the diagnosis: a quick check that
everything runs; its figures are not the ones in the docs.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")  # the plots go to files

from creepcomp import data, diagnose
from creepcomp.fit import fit_prony, prepare, term_table
from creepcomp.report.common import save_axes
from creepcomp.report.diagnosis import plot_fit, write_report
from creepcomp.units import format_parameter, format_percent, format_quantity

RECORDS = {"left": data.insole_left_steps, "right": data.insole_right_staircase}
FAST_EVERY = 4


def main(argv: list[str] | None = None) -> int:
    """Fit and diagnose each insole record; print the figures, write plots and reports."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--record", choices=("left", "right", "both"), default="both")
    parser.add_argument("--out", type=Path, default=Path("examples-output/real_insole"),
                        help="folder for the plots and reports")
    parser.add_argument("--fast", action="store_true",
                        help="every 4th sample, at most two terms, one candidate effect")
    args = parser.parse_args(argv)
    names = list(RECORDS) if args.record == "both" else [args.record]
    for name in names:
        record = RECORDS[name]()
        if args.fast:
            record = record.with_columns(time=record.time[::FAST_EVERY], load=record.load[::FAST_EVERY],
                                         signal=record.signal[::FAST_EVERY])
        su, lu = record.unit("signal"), record.unit("load")
        print(f"\n{name}: {record.source.split('/')[-1]}, taxel {record.metadata['insole.taxel'].split()[0]}: "
              f"{len(record)} samples over {format_quantity(record.duration, 's')}"
              + (f" (--fast: every {FAST_EVERY}th sample)" if args.fast else ""))
        print(f"  channels: {record.metadata.get('insole.alignment', '')}")
        prony = fit_prony(prepare(record), max_terms=2 if args.fast else 6)
        fit = prony.fit
        gain = fit.estimate(lambda v: v["gain"])
        terms = term_table(fit)
        settled = gain[0] * (1 + sum(t["beta"] for t in terms))
        print(f"  fit: {fit.structure.n_terms} creep term(s) by evidence, gain {gain[0]:.4g} ± "
              f"{gain[1]:.2g} {su}/{lu}; settled sensitivity gain x (1 + beta0) = {settled:.4g} {su}/{lu}"
              + (" (negative: the counts fall under pressure)" if settled < 0 else ""))
        if gain[0] * settled < 0:
            print("    the instantaneous gain and the settled sensitivity differ in sign (beta0 < -1): "
                  "the record does not separate the two, this split is not physical")
        for t in terms:
            print(f"    beta = {format_percent(t['beta'], 3)} ± {format_percent(t['beta_sigma'], 2)}, "
                  f"tau = {format_quantity(t['tau'], 's')} ± {format_quantity(t['tau_sigma'], 's', 2)}")
        print(f"  residual RMS {fit.residual_rms:.3g} {su} ({format_percent(fit.residual_rms / prony.data.signal_scale)}"
              f" of the signal's range)")
        save_axes(plot_fit(prony.data, fit, record=record), args.out / f"{name}-fit.png")

        result = diagnose(record, candidates=["extra_retardation"] if args.fast else None)
        d = result.to_dict()
        b, e, g = d["baseline"], d["extended"], d["gain"]
        print(f"  diagnose: cause: {d['cause']}")
        for f in result.findings:
            print("    " + f.effect + ": " + "; ".join(f"{k} = {format_parameter(k, v)}"
                                                     for k, v in f.parameters.items()))
            if f.note:
                print(f"      note: {f.note}")
        print(f"    baseline residual RMS {b['residual_rms']:.3g} {su} "
              f"({format_percent(b['residual_rms_relative'])} of range), extended {e['residual_rms']:.3g} {su}")
        if d.get("noise_floor") is not None:
            print(f"    noise floor {d['noise_floor']:.3g} {su} ({d.get('noise_floor_method', '')}), misfit "
                  f"ratio {b.get('misfit_ratio', float('nan')):.3g} -> {e.get('misfit_ratio', float('nan')):.3g}")
        ratio = g.get("correction_error_ratio")
        print(f"    held-out RMS ratio {g['heldout_rms_ratio']:.3g}, correction-error ratio "
              + ("- (no extension)" if ratio is None else f"{ratio:.3g}"))
        paths = write_report(result, args.out / name, {"signal": su, "load": lu})
        print(f"  written: {args.out / f'{name}-fit.png'}, {paths['report']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
