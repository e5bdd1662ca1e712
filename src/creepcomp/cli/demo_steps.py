"""The demo: the main job on the bundled default sensor (the paper's accelerometer).

Each step prints what it found and writes its files into the output folder; later work adds
steps to :data:`STEPS`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable

from rich.console import Console

from creepcomp.data import default_sensor
from creepcomp.io.jsonfiles import write_design
from creepcomp.report.common import plot_design_comparison
from creepcomp.digital.scenarios import demo_step as step_digital_correction
from creepcomp.analog.sizing import size
from creepcomp.verify.spice import demo_step as step_ngspice


def step_sizing(out: Path, console: Console) -> None:
    """Size the default sensor by the paper's rule and exactly; snap; compare; write designs."""
    model = default_sensor()
    from creepcomp.cli.size import render_sizing  # presentation lives with the CLI

    reports = {rule: size(model, rule=rule) for rule in ("paper", "exact")}
    for rule, report in reports.items():
        render_sizing(report, title=f"Default sensor, {rule} rule")
        path = write_design(out / f"design-{rule}.json", report.design_dict())
        console.print(f"design written to {path}\n")
    plot = plot_design_comparison(model, {
        "uncorrected": None,
        "paper rule, ideal": reports["paper"].ideal,
        "paper rule, E24/E6": reports["paper"].chosen,
        "exact rule, E24/E6": reports["exact"].chosen,
        "exact rule, nearest values": reports["exact"].nearest,
    }, out / "sizing.png")
    console.print(f"plot written to {plot}\n")


def step_tolerances(out: Path, console: Console) -> None:
    """Monte Carlo of the default exact design: E24 1 % resistors, 5 % polyester capacitor,
    then a 1 % polypropylene one; yield against OIML R60 class C3 creep (0.0245 % of FS)."""
    from creepcomp.verify import montecarlo as mc
    from creepcomp.cli.mc import render
    from creepcomp.io.jsonfiles import Design
    from creepcomp.report.common import tolerance_report_html

    model = default_sensor()
    design = Design(model, size(model).chosen)
    limit = 0.000245
    for name, spec in (("polyester-5pct", mc.ToleranceSpec(capacitor=mc.Tolerance(0.05), dielectric="polyester")),
                       ("polypropylene-1pct", mc.ToleranceSpec(capacitor=mc.Tolerance(0.01),
                                                               dielectric="polypropylene"))):
        console.print(f"[bold]Tolerances of the default exact design, {name.replace('-', ' ').replace('pct', ' %')} "
                      "capacitor, E24 1 % resistors[/bold]")
        report = mc.analyse(design, spec, 200_000, seed=1, limit=limit, sensitivity_samples=20_000,
                            spot_check_samples=200)
        render(report)
        path = tolerance_report_html(report, out / f"tolerances-{name}.html")
        console.print(f"report written to {path}\n")


def step_diagnosis(out: Path, console: Console) -> None:
    """Diagnose the bundled record that hides an effect; write the HTML report and models."""
    from creepcomp.cli.diagnose import render_diagnosis
    from creepcomp.data import path
    from creepcomp.diagnose.sensor import diagnose
    from creepcomp.report.diagnosis import write_report
    from creepcomp.io.records import read_record

    record = read_record(path("hidden_effect.csv"))
    result = diagnose(record)
    render_diagnosis(record, result)
    units = {c: record.unit(c) for c in ("signal", "load")}
    for label, p in write_report(result, out / "diagnosis", units).items():
        console.print(f"{label.replace('_', ' ')} written to {p}")
    console.print()


def step_circuit_diagnosis(out: Path, console: Console) -> None:
    """Diagnose the bundled record of a built network with a hidden fault: what the simulated
    network gets wrong, the as-built network (design file, checked in ngspice) and the fix."""
    from creepcomp.cli.diagnose import render_circuit
    from creepcomp.data import path
    from creepcomp.diagnose.sensor import diagnose
    from creepcomp.diagnose.circuit import diagnose_circuit
    from creepcomp.report.diagnosis import write_report
    from creepcomp.io.jsonfiles import read_design
    from creepcomp.io.records import read_record

    record = read_record(path("built_network.csv"))
    console.print("[bold]Diagnosis of a built network[/bold] (data/built_network.csv: signal and measured "
                  "corrected output; its nominal design data/built_network.design.json)")
    circuit = diagnose_circuit(record, read_design(record.design_path()))
    render_circuit(circuit, record.unit("signal"))
    units = {c: record.unit(c) for c in ("signal", "load")}
    for label, p in write_report(diagnose(record), out / "circuit-diagnosis", units, circuit=circuit).items():
        console.print(f"{label.replace('_', ' ')} written to {p}")
    console.print()


STEPS: list[Callable[[Path, Console], None]] = [step_sizing, step_ngspice, step_tolerances,
                                                 step_digital_correction, step_diagnosis,
                                                 step_circuit_diagnosis]


def run_demo(out: Path, console: Console) -> None:
    """Run every demo step, writing into ``out``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    for step in STEPS:
        step(out, console)
