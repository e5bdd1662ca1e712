"""``creepcomp demo``: the main job on the bundled default sensor (the paper's accelerometer).

Each step prints what it found and writes its files into the output folder; later work adds
steps to :data:`STEPS`.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Callable

import typer
from rich.console import Console

from creepcomp.cli.common import app, console


def step_sizing(out: Path, console: Console) -> None:
    """Size the default sensor by the paper's rule and exactly; snap; compare; write designs."""
    from creepcomp.analog.sizing import size
    from creepcomp.cli.common import print_summary
    from creepcomp.data import default_sensor
    from creepcomp.io.jsonfiles import write_design
    from creepcomp.report.common import save_axes
    from creepcomp.report.design import plot_design_comparison
    from creepcomp.report.results import sizing_summary

    model = default_sensor()

    reports = {rule: size(model, rule=rule) for rule in ("paper", "exact")}
    for rule, report in reports.items():
        print_summary(sizing_summary(report, title=f"Default sensor, {rule} rule"))
        path = write_design(out / f"design-{rule}.json", report.design_dict())
        console.print(f"design written to {path}\n")
    plot = save_axes(plot_design_comparison(model, {
        "uncorrected": None,
        "paper rule, ideal": reports["paper"].ideal,
        "paper rule, E24/E6": reports["paper"].chosen,
        "exact rule, E24/E6": reports["exact"].chosen,
        "exact rule, nearest values": reports["exact"].nearest,
    }), out / "sizing.png")
    console.print(f"plot written to {plot}\n")


def step_ngspice(out: Path, console: Console) -> None:
    """ngspice checks the default design (and the paper's rule) against python-control."""
    from creepcomp.cli.simulate import render_comparison
    from creepcomp.io.jsonfiles import read_design
    from creepcomp.report.common import save_axes
    from creepcomp.report.spice import plot_comparison
    from creepcomp.verify.compare import compare_program
    from creepcomp.verify.netlist import reference_designs

    designs = []
    sized = Path(out) / "design-exact.json"
    if sized.exists():
        designs.append(("design-exact", read_design(sized),
                        "the default design (exact rule, E24/E6 parts)"))
    for stem in ("default-paper", "default-exact"):
        design, description = reference_designs()[stem]
        designs.append((stem, design, description))
    for stem, design, description in designs:
        comparison = compare_program(design.network, design.model, "step")
        render_comparison(comparison, title=f"ngspice check, {description}")
        plot = save_axes(plot_comparison(comparison), Path(out) / f"ngspice-{stem}.png")
        console.print(f"plot written to {plot}\n")


def step_tolerances(out: Path, console: Console) -> None:
    """Monte Carlo of the default exact design: E24 1 % resistors, 5 % polyester capacitor,
    then a 1 % polypropylene one; yield against OIML R60 class C3 creep (0.0245 % of FS)."""
    from creepcomp.analog.sizing import size
    from creepcomp.cli.mc import render
    from creepcomp.data import default_sensor
    from creepcomp.io.jsonfiles import Design
    from creepcomp.report.tolerance import tolerance_report_html
    from creepcomp.verify.tolerance_analysis import analyse
    from creepcomp.verify.tolerances import Tolerance, ToleranceSpec

    model = default_sensor()
    design = Design(model, size(model).chosen)
    limit = 0.000245
    for name, spec in (("polyester-5pct", ToleranceSpec(capacitor=Tolerance(0.05), dielectric="polyester")),
                       ("polypropylene-1pct", ToleranceSpec(capacitor=Tolerance(0.01),
                                                            dielectric="polypropylene"))):
        console.print(f"[bold]Tolerances of the default exact design, {name.replace('-', ' ').replace('pct', ' %')} "
                      "capacitor, E24 1 % resistors[/bold]")
        report = analyse(design, spec, 200_000, seed=1, limit=limit, sensitivity_samples=20_000,
                         spot_check_samples=200)
        render(report)
        path = tolerance_report_html(report, out / f"tolerances-{name}.html")
        console.print(f"report written to {path}\n")


def step_digital_correction(out: Path, console: Console) -> None:
    """The paper's scenarios, raw vs corrected by each method, with plots."""
    from rich.table import Table

    from creepcomp.digital import scenarios
    from creepcomp.io.jsonfiles import write_model
    from creepcomp.io.records import write_record
    from creepcomp.report.common import save_axes
    from creepcomp.report.digital import plot_step_outcomes, plot_sweep_outcomes

    out = Path(out)
    model = scenarios.paper_model()
    console.print("[bold]Digital creep correction[/bold] (paper section III) on synthetic records; "
                  f"model: {model.n_terms} terms, beta = "
                  + ", ".join(f"{100 * b:.3g} %" for b in model.beta) + ", tau = "
                  + ", ".join(f"{t:g} s" for t in model.tau) + f"; beta0 = {100 * model.beta0:.3g} %")
    steps = scenarios.step_record(model)
    sweep = scenarios.sweep_record(model)
    for record, plot, name in ((steps, plot_step_outcomes, "digital-steps"),
                               (sweep, plot_sweep_outcomes, "digital-sweep")):
        results = scenarios.outcomes(record)
        dt = record.time[1] - record.time[0]
        table = Table(title=f"{record.name}: {len(record.time)} samples every {dt:.4g} s",
                      title_justify="left")
        table.add_column("signal")
        table.add_column("judged against", justify="left")
        table.add_column("peak creep error (of FS)", justify="right")
        table.add_column("RMS (of FS)", justify="right")
        if record.quarter_points:
            table.add_column("sweep hysteresis (of FS)", justify="right")
        for r in results:
            row = [r.label, "instantaneous" if r.method == "subtractive" else "saturated",
                   _percent(r.error.peak_fraction), _percent(r.error.rms_fraction)]
            if record.quarter_points:
                row.append(_percent(r.hysteresis))
            table.add_row(*row)
        console.print(table)
        if record.hold == "linear":
            console.print("the load ramps between samples: --hold linear is exact; --hold zero "
                          "(the paper's held loads) treats the ramp as steps")
        path = save_axes(plot(record, results), out / f"{name}.png")
        console.print(f"plot written to {path}")
    write_model(out / "paper-model.json", model)
    csv = write_record(out / "digital-steps.csv", steps.to_record())
    console.print(f"record {csv} and model {out / 'paper-model.json'} written: try "
                  f"creepcomp correct {csv} --model {out / 'paper-model.json'}")
    run = scenarios.long_run(model)
    console.print(f"long run: {run.samples} samples to t/tau = {run.elapsed_over_tau:.3g}: peak creep "
                  f"error {_percent(run.error_subtractive)} (subtractive), "
                  f"{_percent(run.error_supplemental)} (supplemental) of FS; the paper's eq. 9 "
                  + (f"turns to inf/nan at t/tau = {run.literal_first_nonfinite:.4g} "
                     f"({run.literal_warning})" if run.literal_first_nonfinite is not None
                     else "stayed finite") + "\n")


def step_diagnosis(out: Path, console: Console) -> None:
    """Diagnose the bundled record that hides an effect; write the HTML report and models."""
    from creepcomp.cli.diagnose import render_diagnosis
    from creepcomp.data import hidden_effect
    from creepcomp.diagnose import diagnose
    from creepcomp.report.diagnosis import write_report

    record = hidden_effect()
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
    from creepcomp.data import built_network, built_network_design
    from creepcomp.diagnose import diagnose, diagnose_circuit
    from creepcomp.report.diagnosis import write_report

    record = built_network()
    console.print("[bold]Diagnosis of a built network[/bold] (data/built_network.csv: signal and measured "
                  "corrected output; its nominal design data/built_network.design.json)")
    circuit = diagnose_circuit(record, built_network_design())
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


def _percent(x: float | None) -> str:
    if x is None or not math.isfinite(x):
        return "n/a"
    v = 100.0 * x
    return f"{v:.2e} %" if v != 0 and abs(v) < 1e-3 else f"{v:.4g} %"


@app.command("demo")
def demo_command(
    out: Path = typer.Option(Path("demo-output"), "-o", "--output", "--out", metavar="DIR",
                             help="Folder for the design files, plots and reports."),
) -> None:
    """Size the default sensor's network by both rules, snap it, compare, and write the results.

    The folder is locked while the demo writes it: a second demo into the same folder at the
    same time is refused (exit 2), as for every output of every command."""
    from creepcomp.io.outputs import check_outputs

    check_outputs(dirs={"-o": out})
    run_demo(out, console)
