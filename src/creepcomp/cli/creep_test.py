"""``creepcomp creep-test``: the OIML R 60 load-cell creep test of a sensor, a digital corrector
or an analog design at several temperatures."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from creepcomp.errors import InputError
from creepcomp.cli.common import app, console, print_json, quantity, read_checked_design, temperatures_option


def _read_target(target: Path, digital: bool):
    """The design or the model in TARGET: a design file has a network (``cells``)."""
    from creepcomp.io.jsonfiles import read_json, read_model

    from creepcomp.active_stage import is_active

    data = read_json(target, "creep-test target")
    if "cells" in data or is_active(data):
        if digital:
            raise InputError(f"{target}: --digital needs a model file (beta, tau ...), not a design file")
        return "design", read_checked_design(target, active=True)
    return ("digital" if digital else "sensor"), read_model(target)


@app.command("creep-test")
def creep_test_command(
    target: Path = typer.Argument(..., metavar="TARGET",
                                  help="Design file (the analog network) or model file (the sensor; "
                                       "with --digital, the digital corrector)."),
    accuracy_class: str = typer.Option("C3", "--class", metavar="CLASS",
                                       help="Accuracy class and thousands of intervals, e.g. C3."),
    temperatures: Optional[str] = typer.Option(None, "--temperatures", metavar="T1,T2,...",
                                               help="Test temperatures (°C), e.g. -10,20,40 "
                                                    "(default: the model's reference, or 20)."),
    digital: bool = typer.Option(False, "--digital", help="Test the digital corrector of the model."),
    n_max: Optional[int] = typer.Option(None, "--n-max", metavar="N",
                                        help="Number of verification intervals (overrides the class's)."),
    loading_time: str = typer.Option("10s", "--loading-time", metavar="TIME",
                                     help="Time to apply (and remove) the full load."),
    rate: str = typer.Option("10", "--rate", metavar="HZ", help="Sampling rate of the digital corrector (Hz)."),
    plot: Optional[Path] = typer.Option(None, "--plot", metavar="FILE.png|svg",
                                        help="Plot the creep curves and the return."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
) -> None:
    """The OIML R 60 load-cell creep test at each temperature, against the class's limits.

    Full load held 30 min, then removed: the creep over 30 min, from 20 to 30 min, and the
    dead-load output return.
    """
    from creepcomp.io.outputs import check_outputs
    from creepcomp.verify.creep_test import (CreepTestProgram, design_test, digital_test, model_test,
                                             parse_class)

    if plot is not None and plot.suffix.lower() not in (".png", ".svg"):
        raise InputError(f"--plot {plot}: use a .png or .svg file")
    check_outputs({"--plot": plot}, inputs=[target])
    limits = parse_class(accuracy_class, n_max, option="--class")
    program = CreepTestProgram(loading_time=quantity(loading_time, "second", "--loading-time", positive=True))
    kind, obj = _read_target(target, digital)
    model = obj.model if kind == "design" else obj
    temps = temperatures_option(temperatures)
    if temps is None:
        temps = [model.temperature.reference if model.temperature is not None else 20.0]
    if kind == "design":
        result = design_test(obj, temps, limits, program)
    elif kind == "digital":
        result = digital_test(obj, temps, limits, program, quantity(rate, "number", "--rate", positive=True))
    else:
        result = model_test(obj, temps, limits, program)
    if plot is not None:
        from creepcomp.report.common import save_axes
        from creepcomp.report.creep_test import plot_creep_test

        save_axes(plot_creep_test(result), plot)
    if as_json:
        out = result.to_dict()
        out["file"] = str(target)
        out["plot"] = None if plot is None else str(plot)
        print_json(out)
        return
    render(result, str(target))
    if plot is not None:
        console.print(f"plot written to {plot}")


def render(result, name: str) -> None:
    """Print a creep test as tables, the limits with their derivation."""
    lim, p = result.limits, result.program
    what = {"sensor": "the uncorrected sensor", "digital": "the digital corrector",
            "design": "the analog network"}[result.target]
    console.print(f"[bold]creepcomp creep-test[/bold]: {name}, {what}; OIML R 60 class {lim.label} "
                  f"(n_max = {lim.n_max}, v = {100 * lim.interval:.4g} % of FS)")
    for key in ("mpe", "creep_30min", "creep_20_30min", "dr"):
        console.print(f"  {key}: {lim.derivation[key]}", markup=False)
    console.print(f"program: load ramped to full scale in {p.loading_time:g} s, initial reading then; "
                  f"held {p.hold / 60:g} min (readings at {p.late_reading / 60:g} and {p.hold / 60:g} min); "
                  f"removed in {p.loading_time:g} s, DR read then; return followed {p.recovery / 60:g} min",
                  markup=False)
    if result.target == "digital":
        s = result.settings
        console.print(f"corrector: {s['method']}, {s['hold']} hold, sampled at {s['rate']:g} Hz", markup=False)
    from creepcomp.report.results import creep_test_tables

    for table in creep_test_tables(result):
        console.print(table.to_rich())
    for note in result.notes:
        console.print(f"note: {note}", markup=False)
    console.print(f"creep test {lim.label}: " + ("[bold green]pass[/bold green] at every temperature"
                                                 if result.passed else "[bold red]FAIL[/bold red]"))
