"""``creepcomp simulate``: a design in python-control and in ngspice, their agreement and the
residual creep."""

from __future__ import annotations

import shlex

from pathlib import Path
from typing import Optional

import numpy as np
import typer
from rich.table import Table

from creepcomp.errors import InputError
from creepcomp.verify.compare import Comparison, compare_program, compare_record, compare_temperatures
from creepcomp.verify.drive import DEFAULT_POINTS, DEFAULT_SIGNAL
from creepcomp.verify.netlist import write_deck
from creepcomp.io.outputs import check_outputs
from creepcomp.units import format_percent, format_quantity
from creepcomp.cli.common import (app, console, count_option, err_console, print_json, progress_bar,
                                  si_text, temperatures_option)
from creepcomp.cli.netlist import PROGRAM_HELP, read_drive


def _sci(x: float | None) -> str:
    return "n/a" if x is None else f"{x:.3g}"


def render_comparison(c: Comparison, title: str | None = None) -> None:
    """Print a comparison as a table, with the ngspice run and its agreement."""
    d = c.to_dict()
    console.print(f"[bold]{title or 'creepcomp simulate'}[/bold]: {c.drive}; "
                  f"{format_quantity(d['duration'], 's')}, {d['points']} time points, "
                  f"full scale {format_quantity(c.full_scale, 'V')}, H(inf) = {c.hf_gain:.6g}")
    from creepcomp.report.results import comparison_table

    console.print(comparison_table(c).to_rich())
    if c.spice is not None:
        line = f"agreement, largest |ngspice - python-control|: {_sci(c.agreement_max_abs)} of full scale"
        if c.reference.instantaneous is not None:
            line += (f" (corrected output {_sci(c.agreement_output)}, "
                     f"sensor {_sci(c.agreement_sensor)})")
        console.print(line)
        console.print(f"ngspice {c.ngspice_version} (shared library via PySpice): "
                      f"{c.ngspice_points} time points in {c.ngspice_seconds * 1e3:.1f} ms; "
                      f"netlist {d['netlist_bytes']} bytes")
    else:
        console.print(f"ngspice not run: {c.unavailable}")
    console.print(f"reference: {c.reference_method}")


@app.command("simulate")
def simulate_command(
    design: Path = typer.Argument(..., metavar="DESIGN", help="Design file (creepcomp size -o)."),
    program: str = typer.Option("step", "--program", metavar="step|staircase|sweep",
                                help=PROGRAM_HELP),
    record: Optional[Path] = typer.Option(None, "--record", metavar="FILE.csv",
                                          help="Drive the network with a measured record's signal."),
    columns: Optional[str] = typer.Option(None, "--columns", metavar="MAP",
                                          help="Column mapping of the record, e.g. time=tR,signal=Ri."),
    duration: Optional[str] = typer.Option(None, "--duration", metavar="TIME",
                                           help="Simulated time (default: the program's, and 20 "
                                                "time constants after a final step)."),
    points: int = typer.Option(DEFAULT_POINTS, "--points", metavar="N", parser=count_option("--points"),
                               help="Time points compared (uniform within each program segment)."),
    signal: str = typer.Option(si_text(DEFAULT_SIGNAL), "--signal", metavar="VOLT",
                               help="Instantaneous sensor signal at full scale, e.g. 100u or 1V."),
    plot: Optional[Path] = typer.Option(None, "--plot", metavar="FILE.png",
                                        help="Save the plot there (default: no plot)."),
    no_plot: bool = typer.Option(False, "--no-plot", help="Do not save a plot (the default)."),
    netlist: Optional[Path] = typer.Option(None, "--netlist", metavar="FILE.cir",
                                           help="Also write the netlist that ran."),
    temperatures: Optional[str] = typer.Option(
        None, "--temperatures", metavar="T1,T2,...",
        help="Simulate at each temperature (°C), e.g. -10,20,40: the sensor at T (its "
             "temperature law), every part at T (TCs, thermistors), in both simulators."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
) -> None:
    """Simulate the design with python-control and with ngspice on the same time points.

    Reports their agreement (fraction of full scale: the step, for a step program), the
    residual creep, and ngspice's run time; with ``--plot`` saves a plot of the creeping
    input, the corrected output from both simulators, and the residual creep.
    """
    plot_path = None if no_plot else plot
    files = {"--plot": plot_path, "--netlist": netlist}
    if netlist is not None and record is not None:
        files["--netlist (its data file)"] = netlist.parent / f"{netlist.stem}-signal.txt"
    temps = temperatures_option(temperatures, "--temperatures")
    if temps is not None and record is not None:
        raise InputError("--temperatures applies to a synthetic drive (--program), not a record")
    if temps is not None and plot_path is not None and len(temps) > 1:
        files.update({f"--plot at {t:g} °C": _at(plot_path, t) for t in temps})
        del files["--plot"]
    check_outputs(files, inputs=[design, record])
    drive = read_drive(design, program, record, columns, duration, points, signal)
    net, model = drive.design.network, drive.design.model
    if temps is not None:
        _simulate_temperatures(drive, design, temps, plot_path, netlist, as_json)
        return
    if drive.record is not None:
        rec = drive.record
        with progress_bar(f"simulating {len(rec)} samples (python-control, ngspice)",
                          disable=as_json):
            comparison = compare_record(net, rec.time, rec.signal, name=f"record {rec.source}")
    else:
        comparison = compare_program(net, model, drive.program, drive.duration, drive.points,
                                     drive.signal)
    if comparison.unavailable:
        err_console.print(f"creepcomp: note: {comparison.unavailable}; showing the python-control "
                          "result only", markup=False, highlight=False, soft_wrap=True)
    if plot_path is not None:
        from creepcomp.report.common import save_axes
        from creepcomp.report.spice import plot_comparison

        save_axes(plot_comparison(comparison), plot_path)
    if netlist is not None:
        from creepcomp.cli.netlist import drive_deck

        deck, data = drive_deck(drive, f"{netlist.stem}-signal.txt")
        write_deck(netlist, deck, data)
    if as_json:
        out = comparison.to_dict()
        out["design"] = str(design)
        out["plot"] = None if plot_path is None else str(plot_path)
        out["netlist"] = None if netlist is None else str(netlist)
        print_json(out)
        return
    render_comparison(comparison)
    if plot_path is not None:
        console.print(f"plot written to {plot_path}")
    if netlist is not None:
        console.print(f"netlist written to {netlist}; run it with: ngspice -b {shlex.quote(str(netlist))}",
                      markup=False)


def _at(path: Path, temperature: float) -> Path:
    """``path`` with the temperature in its name (one plot per temperature)."""
    return path.with_name(f"{path.stem}-{temperature:g}C{path.suffix}")


def _simulate_temperatures(drive, design: Path, temps: list[float], plot_path: Path | None,
                           netlist: Path | None, as_json: bool) -> None:
    """``simulate --temperatures``: one comparison per temperature, a table each, and the
    largest disagreement and residual creep over them."""
    from creepcomp.analog.parts import plan_of

    d = drive.design
    plan = plan_of(d)
    with progress_bar(f"simulating at {len(temps)} temperatures (python-control, ngspice)",
                      disable=as_json):
        comparisons = compare_temperatures(d.network, d.model, plan, temps, drive.program,
                                           drive.duration, drive.points, drive.signal)
    unavailable = comparisons[0].unavailable
    if unavailable:
        err_console.print(f"creepcomp: note: {unavailable}; showing the python-control result "
                          "only", markup=False, highlight=False, soft_wrap=True)
    plots = {}
    if plot_path is not None:
        from creepcomp.report.common import save_axes
        from creepcomp.report.spice import plot_comparison

        for c in comparisons:
            plots[c.temperature] = plot_path if len(temps) == 1 else _at(plot_path, c.temperature)
            save_axes(plot_comparison(c), plots[c.temperature])
    if netlist is not None:
        from creepcomp.cli.netlist import drive_deck

        for t in temps:
            deck, _ = drive_deck(drive, temperature=t)
            write_deck(netlist if len(temps) == 1 else _at(netlist, t), deck)
    agreements = [c.agreement_max_abs for c in comparisons if c.agreement_max_abs is not None]
    peaks = [c.residual_creep_peak for c in comparisons]
    worst = int(np.argmax(peaks))
    if as_json:
        rows = []
        for c in comparisons:
            row = c.to_dict()
            row["plot"] = None if c.temperature not in plots else str(plots[c.temperature])
            rows.append(row)
        print_json({"agreement_max_abs": max(agreements) if agreements else None,
                    "residual_creep_peak": peaks[worst], "residual_creep_peak_at": temps[worst],
                    "tracking": plan.tracking, "temperatures": rows, "design": str(design),
                    "netlist": None if netlist is None else str(netlist)})
        return
    for c in comparisons:
        render_comparison(c, title=f"creepcomp simulate at {c.temperature:g} °C")
    table = Table(title="Over temperature", title_justify="left")
    for col in ("temperature", "residual creep, peak (of full scale)", "residual creep, final",
                "largest |ngspice - python-control| (of full scale)"):
        table.add_column(col, justify="right")
    for c in comparisons:
        table.add_row(f"{c.temperature:g} °C", format_percent(c.residual_creep_peak),
                      format_percent(c.residual_creep_final), _sci(c.agreement_max_abs))
    console.print(table)
    console.print(f"worst residual creep: {format_percent(peaks[worst])} at {temps[worst]:g} °C"
                  + (f"; largest disagreement {_sci(max(agreements))} of full scale"
                     if agreements else ""))
    for t, p in plots.items():
        console.print(f"plot at {t:g} °C written to {p}")
    if netlist is not None:
        console.print(f"netlist{'s' if len(temps) > 1 else ''} written "
                      f"({netlist if len(temps) == 1 else _at(netlist, temps[0]).name + ' ...'})")
