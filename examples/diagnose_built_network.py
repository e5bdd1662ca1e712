"""Diagnose a built correction network from its record: what is wrong, the as-built network, the fix.

A record of a built network holds the sensor's ``signal`` (the network's input) and the
measured ``corrected`` output, and names the design file of the network as it was meant to be
(``# design: FILE``). The diagnosis drives the nominal network with the measured signal,
compares with the measured output, tries every circuit effect (a capacitor off its value,
source or load impedance, dielectric absorption, leakage, ...) and keeps what the evidence
supports; the fitted effects give the as-built network, and the best single-part changes
fix it. The script prints the verdict, each finding (part, fitted values ± 1 sigma,
evidence), the design and as-built element values, the peak residual creep of both, the
fixes and the gain; it also diagnoses the sensor side of the same record. It writes into
``--out``: ``report.html``, ``diagnosis.json``, ``model.json``, ``baseline-model.json`` and
``as-built-design.json`` (the as-built network as a design file: ``creepcomp simulate`` runs it).

Run it::

    python examples/diagnose_built_network.py          # the bundled built_network.csv
    python examples/diagnose_built_network.py my-record.csv --design my-design.json

The bundled record is a synthetic built network with one hidden fault. ``--fast`` skips the
ngspice run of the as-built network on the measured signal.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")  # the plots go to files

from creepcomp import diagnose, diagnose_circuit, read_design, read_record
from creepcomp.data import path as bundled
from creepcomp.report.circuit_diagnosis import elements, quantity
from creepcomp.report.diagnosis import write_report
from creepcomp.units import format_percent, format_quantity


def element(kind: str, value: float | None) -> str:
    """An element's value with its unit, or ``none`` when absent."""
    return "none" if value is None else format_quantity(value, "F" if kind == "C" else "Ω")


def main(argv: list[str] | None = None) -> int:
    """Diagnose the built network, print findings, as-built values and fixes, write the report."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("record", nargs="?", type=Path,
                        help="record CSV with a 'corrected' column (default: the bundled "
                             "built_network.csv)")
    parser.add_argument("--design", type=Path,
                        help="design file of the network (default: the record's '# design:' line)")
    parser.add_argument("--out", type=Path, default=Path("examples-output/diagnose_built_network"),
                        help="folder for the report, the models and the as-built design")
    parser.add_argument("--fast", action="store_true",
                        help="no ngspice run of the as-built network")
    args = parser.parse_args(argv)

    record = read_record(args.record or bundled("built_network.csv"))
    design_path = record.design_path(args.design)
    unit = record.unit("signal")
    circuit = diagnose_circuit(record, read_design(design_path), spice_check=not args.fast)
    print(f"record {record.source}: {len(record)} samples over {record.duration:.4g} s; "
          f"design {design_path}")
    b, e = circuit.baseline, circuit.extended
    print(f"nominal network driven by the measured signal, against the measured output: residual "
          f"RMS {format_quantity(b.rms, unit)} ({format_percent(b.rms / circuit.data.scale)} of its range)")
    print(f"\ncircuit cause: {circuit.cause}")
    for f in circuit.findings:
        fitted = "; ".join(f"{k} = {quantity(k, v)} ± {quantity(k, f.uncertainty.get(k))}"
                           for k, v in f.parameters.items())
        print(f"  {f.effect} ({f.part or 'network'}): {fitted} (ΔBIC {f.evidence.delta_bic:.1f}, "
              f"held-out RMS ratio {f.evidence.heldout_rms_ratio:.3g}, "
              f"held-out z {f.evidence.heldout_z:.1f})")
    if circuit.findings:
        nominal, built = elements(b.network), elements(e.network)
        print(f"\n  {'element':<22}{'design':>12}{'as built':>12}")
        for label, (kind, value) in nominal.items():
            if value is not None or built[label][1] is not None:
                print(f"  {label:<22}{element(kind, value):>12}{element(*built[label]):>12}")
    creep = circuit.residual_creep
    print(f"\npeak residual creep of a load step: design {format_percent(creep['nominal'])}, "
          f"as built {format_percent(creep['as_built'])}")
    for fix in circuit.fixes:
        unit_of_part = "F" if fix.part.startswith("C") else "Ω"
        print(f"  fix: {fix.part} {format_quantity(fix.value_from, unit_of_part)} -> "
              f"{format_quantity(fix.value_to, unit_of_part)} ({fix.series}): peak residual creep "
              f"{format_percent(fix.residual_creep_peak)}; {fix.note}")
    gain = circuit.gain
    if e is not b:
        print(f"gain: held-out residual RMS {format_quantity(b.heldout.rms, unit)} -> "
              f"{format_quantity(e.heldout.rms, unit)} (ratio {gain['heldout_rms_ratio']:.3g})")
    check = circuit.spice_check
    if check is not None and "error" in check:
        print(f"ngspice check of the as-built network: not run ({check['error']})")
    elif check is not None:
        print(f"ngspice, as-built network on the measured signal: RMS difference from the measured "
              f"output {format_quantity(check['rms_ngspice_vs_measured'], unit)}, "
              f"{check['ratio']:.3f} x the fit's residual RMS")

    sensor = diagnose(record)
    print(f"\nsensor side (signal against load): cause {sensor.cause}")
    units = {c: record.unit(c) for c in ("signal", "load")}
    print()
    for label, p in write_report(sensor, args.out, units, circuit=circuit).items():
        print(f"{label.replace('_', ' ')} written to {p}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
