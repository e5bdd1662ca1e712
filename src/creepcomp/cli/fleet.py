"""``creepcomp fleet``: fit and diagnose many records (one unit each) on Dask."""

from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer
from rich.table import Table

from creepcomp.units import format_percent
from creepcomp.cli.common import app, console, count_option, err_console, print_json, quantity


@app.command("fleet")
def fleet_command(
    records: List[str] = typer.Argument(..., metavar="RECORDS...",
                                        help="Record files, folders (their .csv/.tsv/.txt files) or "
                                             "glob patterns ('lot7/*.csv'); each record is one unit."),
    output: Path = typer.Option(..., "-o", "--output", metavar="DIR",
                                help="Output folder: fleet.parquet, fleet.csv, report.html, units/<unit>/."),
    workers: Optional[int] = typer.Option(None, "--workers", metavar="N", parser=count_option("--workers"),
                                          help="Worker processes of the local cluster (default: cores)."),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", metavar="ADDRESS",
                                            help="Use a running Dask cluster (tcp://host:8786) whose "
                                                 "workers see the records and DIR at the same paths; "
                                                 "'serial' runs in this process without Dask."),
    spec: str = typer.Option("0.0245%", "--spec", metavar="FRACTION",
                             help="Creep limit for the residual creep after correction (default: "
                                  "OIML R60 class C3)."),
    correct: bool = typer.Option(False, "--correct",
                                 help="Also correct each record with its unit's model "
                                      "(units/<unit>/corrected.csv) and measure the error."),
    unit_reports: bool = typer.Option(False, "--unit-reports",
                                      help="Also write each unit's diagnosis report with plots "
                                           "(units/<unit>/report.html; slower)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object (docs/cli.md)."),
) -> None:
    """Fit, diagnose (and correct) every record on Dask: one table, a lot report, resumable."""
    limit = quantity(spec, "fraction", "--spec", positive=True)
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    from creepcomp.fleet import run

    bar = Progress(TextColumn("fleet"), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn(),
                   TextColumn("{task.fields[last]}"), console=err_console, transient=True,
                   disable=as_json or not err_console.is_terminal)
    task = None

    def progress(done: int, total: int, row: dict) -> None:
        nonlocal task
        if task is None:
            task = bar.add_task("fleet", total=total, last="")
        bar.update(task, completed=done, last=f"{row['unit']}: {row['cause'] or row['status']}")

    # Ctrl-C: run() closes the cluster; the units finished are kept (the same command resumes)
    # and the command line's entry point prints one line and exits with 130.
    with bar:
        result = run(records, output, workers=workers, scheduler=scheduler, spec=limit,
                     correct=correct, unit_reports=unit_reports, progress=progress)
    if as_json:
        print_json(result.to_dict())
        return
    render_fleet(result, limit)


def render_fleet(result, limit: float) -> None:
    """Print the run's summary, the units to look at first and the failed units."""
    d = result.to_dict()
    s = result.summary
    done = d["n"] - d["skipped"]
    rate = f", {3600 * done / result.seconds:.0f} units per hour" if done else ""
    console.print(f"[bold]creepcomp fleet[/bold]: {d['n']} units ({d['skipped']} already done, "
                  f"skipped), {result.seconds:.1f} s on {d['workers']} worker(s), "
                  f"scheduler {d['scheduler']}{rate}")
    t = Table(title=f"Lot (spec: residual creep after correction <= {format_percent(limit)} of full scale)",
              title_justify="left")
    for col in ("processed", "failed", "in spec", "out of spec", "not judged"):
        t.add_column(col, justify="right")
    t.add_row(str(d["ok"]), str(len(d["failed"])), str(d["in_spec"]), str(d["out_of_spec"]),
              str(d["ok"] - d["in_spec"] - d["out_of_spec"]))
    console.print(t)
    if s.get("effects"):
        console.print("effects found: " + ", ".join(
            f"{k} {v} ({format_percent(v / max(d['ok'], 1))})" for k, v in s["effects"].items()))
    if s.get("look_first"):
        t = Table(title="Units to look at first", title_justify="left")
        for col in ("unit", "residual creep", "cause", "why"):
            t.add_column(col, justify="right" if col == "residual creep" else "left")
        for u in s["look_first"][:10]:
            r = u["row"]
            t.add_row(u["unit"], format_percent(r.get("residual_creep")), r.get("cause") or "-",
                      "; ".join(u["reasons"]))
        console.print(t)
    for f in d["failed"][:20]:
        console.print(f"failed {f['unit']}: {f['reason']}", markup=False, highlight=False)
    if len(d["failed"]) > 20:
        console.print(f"... and {len(d['failed']) - 20} more failed units (column 'error' of the table)")
    console.print(f"table written to {d['table']} and {d['csv']}")
    if d["report"]:
        console.print(f"lot report written to {d['report']}")
