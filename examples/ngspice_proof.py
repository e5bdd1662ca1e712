"""Prove a design in ngspice: its netlist, and ngspice against python-control on the same points.

For each load program (a load step, the paper's staircase of loading and unloading steps,
a triangular ±FS sweep) the script writes the design's standalone ngspice netlist (the
creeping sensor, the network, ``.tran`` and ``.meas`` lines), simulates the same experiment
with python-control and with ngspice (through PySpice's shared library), and prints the
residual creep each measures and their largest difference as a fraction of full scale. When
the ``ngspice`` program is installed it also runs the netlist on its own (``ngspice -b``) and
prints what the netlist's ``.meas`` lines report. Without ngspice it shows python-control's
result alone and says why.

It writes into ``--out``, for each program P:

- ``design-P.cir``: the netlist (run it with ``ngspice -b design-P.cir``);
- ``ngspice-P.png``: creeping input, corrected output from both simulators, residual creep,
  and their difference.

Run it::

    python examples/ngspice_proof.py --design examples-output/size_network/design.json
    python examples/ngspice_proof.py          # the bundled default sensor, sized here

Without ``--design`` it sizes the bundled default sensor (beta0 = 3 %, tau = 45 s) by the
exact rule with E24/E6 parts. ``--fast`` simulates the load step only, on 400 time points
instead of 2000, and does not run the ``ngspice`` program on the netlist.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")  # the plots go to files

from creepcomp import Design, default_sensor, read_design, size
from creepcomp.report.common import save_axes
from creepcomp.report.spice import plot_comparison
from creepcomp.units import format_percent, format_quantity
from creepcomp.verify.compare import compare_program
from creepcomp.verify.drive import DEFAULT_POINTS, default_duration, synthetic_program
from creepcomp.verify.netlist import program_deck, write_deck

PROGRAMS = ("step", "staircase", "sweep")
FAST_POINTS = 400
#: A ``.meas`` result line of ngspice's batch output, e.g. ``residual_creep_final=  8.49e-04``.
MEASURED = re.compile(r"^(\w+)\s*=\s*([-+0-9.eE]+)", re.MULTILINE)


def load_design(path: Path | None) -> Design:
    """The design file at ``path``, or the default sensor sized by the exact rule."""
    if path is not None:
        return read_design(path)
    model = default_sensor()
    return Design(model, size(model).chosen)


def run_standalone(netlist: Path) -> dict[str, float]:
    """Run a netlist with the ``ngspice`` program; its ``.meas`` results by name."""
    result = subprocess.run(["ngspice", "-b", netlist.name], cwd=netlist.parent,
                            capture_output=True, text=True, timeout=300, check=True)
    return {name: float(value) for name, value in MEASURED.findall(result.stdout)}


def peak_text(comparison, which: str) -> str:
    """The peak residual creep of one simulator and when it occurs."""
    residual = comparison.residual(which)
    k = int(abs(residual).argmax())
    peak = abs(float(residual[k]))
    return format_percent(peak) if peak < 1e-12 else f"{format_percent(peak)} at {comparison.reference.time[k]:.4g} s"


def main(argv: list[str] | None = None) -> int:
    """Write the netlists, compare ngspice with python-control, plot."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--design", type=Path,
                        help="design file (default: the bundled default sensor, sized here)")
    parser.add_argument("--out", type=Path, default=Path("examples-output/ngspice_proof"),
                        help="folder for the netlists and plots")
    parser.add_argument("--fast", action="store_true",
                        help="load step only, 400 time points, no standalone ngspice run")
    args = parser.parse_args(argv)

    design = load_design(args.design)
    network, model = design.network, design.model
    points = FAST_POINTS if args.fast else DEFAULT_POINTS
    standalone = not args.fast and shutil.which("ngspice") is not None
    print(f"design: {args.design or 'bundled default sensor, exact rule, E24/E6 parts'}; parts "
          + ", ".join(f"{label} {format_quantity(v, 'Ω' if kind == 'R' else 'F')}"
                      for label, kind, v in network.parts()))
    for name in PROGRAMS[:1] if args.fast else PROGRAMS:
        program = synthetic_program(model, name, network)
        duration = default_duration(program, model, network)
        deck = program_deck(network, model, program, duration, points,
                            title=f"creepcomp example: design driven by synthetic creep, {program.name}")
        netlist = write_deck(args.out / f"design-{name}.cir", deck)
        comparison = compare_program(network, model, program, duration, points)
        print(f"\n{program.name}: {duration:.4g} s, {points} time points; "
              f"netlist {netlist} ({format_quantity(netlist.stat().st_size, 'B')})")
        print(f"  residual creep, peak:  python-control {peak_text(comparison, 'reference')}", end="")
        if comparison.spice is None:
            print(f"\n  ngspice not run: {comparison.unavailable}")
        else:
            print(f", ngspice {peak_text(comparison, 'spice')}")
            print(f"  residual creep, final: ngspice {format_percent(comparison.residual_creep_final)}")
            print(f"  agreement, largest |ngspice - python-control|: "
                  f"{comparison.agreement_max_abs:.3g} of full scale "
                  f"(ngspice {comparison.ngspice_version}, {comparison.ngspice_points} time points "
                  f"in {1e3 * comparison.ngspice_seconds:.1f} ms)")
        if standalone:
            measured = run_standalone(netlist)
            print("  ngspice -b on the netlist alone: "
                  + ", ".join(f"{key.replace('_', ' ')} {format_percent(value)}" for key, value in measured.items()
                              if key != "at"))
        plot = save_axes(plot_comparison(comparison), args.out / f"ngspice-{name}.png")
        print(f"  plot written to {plot}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
