"""Size the RC network that cancels a sensor's creep, snap it to E-series parts, predict it.

The example sensor creeps with two terms (1.2 % at 8 s and 1.8 % at 60 s), has a 10 kΩ
output resistance and drives a next stage with 1 GΩ input resistance; the exact rule
accounts for both. The script sizes the network, snaps it to E24 resistors and E6
capacitors, prints every part (ideal value, chosen value, snap error) and the predicted
residual creep and hysteresis of the ideal parts, the chosen parts and the uncorrected
sensor, and writes into ``--out``:

- ``design.json``: the design file (``ngspice_proof.py --design``, ``tolerance_report.py
  --design`` and ``creepcomp netlist/simulate/mc`` read it);
- ``sizing.png``: residual creep after a load step, and the hysteresis loops of a ±FS sweep,
  of the corrected sensor (the uncorrected figures are in the printed table).

Run it::

    python examples/size_network.py                      # writes examples-output/size_network/
    python examples/size_network.py --model model.json   # your sensor (as creepcomp fit writes)

``--fast`` fixes the largest capacitor at 10 µF instead of searching the E6 values from
1 µF to 100 µF (a few hundred part combinations instead of about two thousand).
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")  # the plots go to files

from creepcomp import CreepModel, read_model, size, write_design
from creepcomp.report.common import save_axes
from creepcomp.report.design import plot_design_comparison
from creepcomp.units import format_percent, format_quantity

#: The example sensor: two creep terms (relative amplitude, retardation time in s).
SENSOR = CreepModel(beta=(0.012, 0.018), tau=(8.0, 60.0))
#: Output resistance of the sensor (ohm) and input resistance of the next stage (ohm).
SOURCE_RESISTANCE = 10e3
LOAD_RESISTANCE = 1e9
#: The largest capacitor with --fast (F).
FAST_CAPACITANCE = 10e-6


def unit_of(kind: str) -> str:
    """The unit symbol of a part kind, ``"R"`` or ``"C"``."""
    return "Ω" if kind == "R" else "F"


def main(argv: list[str] | None = None) -> int:
    """Size, snap and predict; write the design file and the plot."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", type=Path, help="model file (beta, tau lists) instead of "
                                                   "the example sensor")
    parser.add_argument("--out", type=Path, default=Path("examples-output/size_network"),
                        help="folder for design.json and sizing.png")
    parser.add_argument("--fast", action="store_true", help="fix the capacitor at 10 µF")
    args = parser.parse_args(argv)

    model = read_model(args.model) if args.model else SENSOR
    report = size(model, rule="exact", resistor_series="E24", capacitor_series="E6",
                  capacitance=FAST_CAPACITANCE if args.fast else None,
                  source_resistance=SOURCE_RESISTANCE, load_resistance=LOAD_RESISTANCE)

    terms = ", ".join(f"{format_percent(b)} at {format_quantity(t, 's')}" for b, t in zip(model.beta, model.tau))
    print(f"sensor: {model.n_terms} creep terms ({terms}); beta0 = {format_percent(model.beta0)}")
    print(f"source resistance {format_quantity(SOURCE_RESISTANCE, 'Ω')}, "
          f"load resistance {format_quantity(LOAD_RESISTANCE, 'Ω')}")
    print(f"\n{report.rule} rule, {report.chosen.topology} network, {report.resistor_series} "
          f"resistors and {report.capacitor_series} capacitors "
          f"({report.candidates_evaluated} part combinations searched)")
    print(f"  {'part':<6}{'ideal':>12}{'chosen':>12}{'snap error':>12}"
          f"   peak residual creep if only this part were snapped")
    for p in report.parts:
        print(f"  {p.label:<6}{format_quantity(p.ideal, unit_of(p.kind)):>12}"
              f"{format_quantity(p.chosen, unit_of(p.kind)):>12}{100 * p.deviation:>+10.2f} %"
              f"   {format_percent(p.residual_if_only_this)}")

    columns = [("ideal parts", report.ideal_quality), ("chosen parts", report.chosen_quality)]
    designs = {"ideal parts": report.ideal, "chosen parts": report.chosen}
    if report.nearest is not None:
        columns.append(("nearest values", report.nearest_quality))
        designs["nearest values"] = report.nearest
    columns.append(("uncorrected", report.uncorrected_quality))
    period = report.chosen_quality.sweep_period
    print("\npredicted (exact transfer functions), fractions of a load step / of full scale:")
    print(f"  {'':<34}" + "".join(f"{name:>16}" for name, _ in columns))
    for label, figure in (("residual creep, peak", lambda q: q.residual_creep_peak),
                          ("residual creep, final", lambda q: q.residual_creep_final),
                          (f"hysteresis, ±FS sweep of {format_quantity(period, 's')}",
                           lambda q: q.hysteresis)):
        print(f"  {label:<34}" + "".join(f"{format_percent(figure(q)):>16}" for _, q in columns))
    if report.nearest is not None:
        print("  nearest values: each part rounded to its nearest series value at C = "
              + format_quantity(max(v for _, k, v in report.nearest.parts() if k == "C"), "F"))
    for warning in report.warnings:
        print(f"warning: {warning}")

    design = write_design(args.out / "design.json", report.design_dict())
    plot = save_axes(plot_design_comparison(model, designs, sweep_period=period), args.out / "sizing.png")
    print(f"\ndesign written to {design}")
    print(f"plot written to {plot}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
