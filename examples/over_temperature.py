"""Design a creep correction over a temperature range: fixed parts, and NTC thermistors that track.

The default sensor (3 % of creep at a retardation time of 45 s at 20 °C) with an Arrhenius law
of 43 kJ/mol, so that its retardation time goes from about 340 s at -10 °C to 15 s at 40 °C.
The script compares over -10 .. 40 °C (every 5 K):

- (a) the usual design, E24/E6 parts sized at 20 °C;
- (b) fixed E24/E6 parts sized for the range (smallest worst case);
- (c-passive) a lead network whose R1 and R2 are catalogue NTC thermistors
  (``analog.parts.NTC_THERMISTORS``) with a fixed resistor in series or across: it needs a
  capacitor of tens of mF;
- (c) the active stage: an integrator loop whose time constant is set by one catalogue NTC
  thermistor and a 10 uF film capacitor, the correction's amplitude by fixed resistors,

prints the worst peak residual creep of each and where, and the residual at every temperature,
and writes into ``--out``:

- ``design.json``: the design ``size --tracking ntc`` writes, the active stage (its ``parts``
  block names the thermistor);
- ``over-temperature.png``: peak residual creep against temperature, worst cases marked.

Run it::

    python examples/over_temperature.py          # writes examples-output/over_temperature/

``--fast`` shapes the thermistors and snaps the fixed parts with E12 resistors instead of E24
(fewer combinations; the figures move by a few hundredths of a percent).
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")  # the plots go to files

from creepcomp import CreepModel, size, write_design
from creepcomp.analog.over_temperature import compare_over_range
from creepcomp.report.common import save_axes
from creepcomp.report.design import plot_over_temperature
from creepcomp.temperature import TemperatureLaw
from creepcomp.units import format_percent, format_quantity

#: The default sensor with the activation energy reported for RTV silicone (J/mol), at 20 °C.
SENSOR = CreepModel(beta=(0.03,), tau=(45.0,), temperature=TemperatureLaw.arrhenius(43e3, 20.0))
#: The temperature range (°C).
RANGE = (-10.0, 40.0)


def main(argv: list[str] | None = None) -> int:
    """Size the three designs, compare them over the range, write the tracking design and plot."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("examples-output/over_temperature"),
                        help="folder for design.json and over-temperature.png")
    parser.add_argument("--fast", action="store_true", help="E12 resistors instead of E24")
    args = parser.parse_args(argv)
    series = "E12" if args.fast else "E24"

    reference = size(SENSOR, resistor_series=series)
    comparison = compare_over_range(SENSOR, reference.chosen, *RANGE, plan=reference.plan,
                                    tracking="ntc", resistor_series=series)
    print(f"sensor: 3 % at 45 s (20 °C), E_a = 43 kJ/mol; range {RANGE[0]:g} .. {RANGE[1]:g} °C")
    for d in comparison.designs:
        p = d.prediction
        parts = ", ".join(f"{label} {format_quantity(v, 'Ω' if k == 'R' else 'F')}"
                          for label, k, v in d.network.parts())
        print(f"{d.label}: worst {format_percent(p.worst)} at {p.worst_at:g} °C ({parts})")
    print("°C     " + "  ".join(f"{d.label.split()[0]:>11}" for d in comparison.designs))
    for k, t in enumerate(comparison.designs[0].prediction.temperatures):
        print(f"{t:>5g}  " + "  ".join(f"{format_percent(d.prediction.peak_residual[k]):>11}"
                                       for d in comparison.designs))
    ntc = comparison.written
    for label, use in ntc.plan.thermistors.items():
        extra = (f" + {format_quantity(use.series, 'Ω')} in series" if use.series else "") + \
                (f", {format_quantity(use.parallel, 'Ω')} across" if use.parallel else "")
        print(f"{label}: {use.part} (R25 = {format_quantity(use.r25, 'Ω')}, B = {use.b:g} K){extra}")
    for w in ntc.warnings:
        print(f"warning: {w}")

    args.out.mkdir(parents=True, exist_ok=True)
    design = reference.design_dict()
    for key in ("cells", "R2", "shunt"):
        design.pop(key, None)
    design.update({k: v for k, v in ntc.network.to_dict().items()})
    design["parts"] = ntc.plan.to_dict()
    design["over_temperature"] = ntc.prediction.to_dict()
    design.pop("predicted", None)
    write_design(args.out / "design.json", design)
    save_axes(plot_over_temperature(comparison), args.out / "over-temperature.png")
    print(f"design written to {args.out / 'design.json'}")
    print(f"plot written to {args.out / 'over-temperature.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
