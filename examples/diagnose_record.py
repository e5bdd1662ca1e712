"""Diagnose a measured record: what the paper's creep model misses, why, and what it gains.

The diagnosis fits the paper's one-term creep model (the baseline), tries every named effect
of the vocabulary (``diagnosis.md``: a further creep term, viscous flow, asymmetric
recovery, ...), keeps the ones the evidence supports (information criterion and data held out
of the fit) and measures the gain. The script prints the verdict (the cause), each finding
with its fitted parameters (± 1 sigma) and evidence, and the gain: the held-out residual and
the error of the creep-corrected signal, baseline against extended model. It writes into
``--out``: ``report.html`` (figures and tables), ``diagnosis.json``, ``model.json`` (the
extended model), ``baseline-model.json`` and ``fit.png`` (the extended fit and its residual).

Run it::

    python examples/diagnose_record.py                 # the bundled hidden_effect.csv
    python examples/diagnose_record.py my-record.csv   # your record (data-format.md)

The bundled record is a synthetic force sensor that hides one effect. ``--fast`` changes
nothing here: the bundled record diagnoses in a few seconds; the option is accepted so that
every example takes the same ones.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")  # the plots go to files

from creepcomp import diagnose, read_record
from creepcomp.data import path as bundled
from creepcomp.report.common import save_axes
from creepcomp.report.diagnosis import plot_fit, write_report
from creepcomp.units import format_parameter, format_percent, format_quantity



def main(argv: list[str] | None = None) -> int:
    """Diagnose the record, print the verdict, findings and gain, write the report."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("record", nargs="?", type=Path,
                        help="record CSV (default: the bundled hidden_effect.csv)")
    parser.add_argument("--out", type=Path, default=Path("examples-output/diagnose_record"),
                        help="folder for the report, the models and the plot")
    parser.add_argument("--fast", action="store_true", help="accepted; changes nothing here")
    args = parser.parse_args(argv)

    record = read_record(args.record or bundled("hidden_effect.csv"))
    unit = record.unit("signal")
    result = diagnose(record)
    base = result.residual_summary(result.baseline)
    print(f"record {record.source}: {len(record)} samples over {record.duration:.4g} s")
    print(f"baseline (the paper's model, one creep term): residual RMS "
          f"{format_quantity(base['residual_rms'], unit)} ({format_percent(base['residual_rms_relative'])} of "
          f"the signal's range), held out {format_quantity(base['heldout_residual_rms'], unit)}")
    print(f"\ncause: {result.cause}")
    for f in result.findings:
        fitted = "; ".join(f"{k} = {format_parameter(k, v)} ± {format_parameter(k, f.uncertainty.get(k))}"
                           for k, v in f.parameters.items()) or "-"
        ev = f.evidence
        print(f"  {f.effect}: {fitted} (ΔBIC {ev.delta_bic:.1f}, held-out RMS ratio "
              f"{ev.heldout_rms_ratio:.3g}, held-out z {ev.heldout_z:.1f})")
    if not result.findings:
        print("  no effect is supported by the evidence: no candidate predicts held-out data better "
              "than the baseline (that alone does not show the residual is noise)")
    extended = result.residual_summary(result.extended)
    gain = result.gain
    print(f"\ngain: held-out residual RMS {format_quantity(base['heldout_residual_rms'], unit)} -> "
          f"{format_quantity(extended['heldout_residual_rms'], unit)} "
          f"(ratio {gain['heldout_rms_ratio']:.3g})")
    if gain.get("correction_error_ratio") is not None:
        print(f"      creep-corrected signal against the load, RMS error "
              f"{format_quantity(gain['correction_error_baseline'], unit)} -> "
              f"{format_quantity(gain['correction_error_extended'], unit)} "
              f"(ratio {gain['correction_error_ratio']:.3g})")

    units = {c: record.unit(c) for c in ("signal", "load")}
    paths = write_report(result, args.out, units)
    paths["fit_plot"] = save_axes(plot_fit(result.data, result.extended, record=record), args.out / "fit.png")
    print()
    for label, p in paths.items():
        print(f"{label.replace('_', ' ')} written to {p}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
