"""``creepcomp data``: the records shipped with the package: ``list`` them, or ``export`` one as
a CSV file that every other command reads (:mod:`creepcomp.data`)."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from creepcomp.errors import InputError
from creepcomp.io.outputs import check_outputs
from creepcomp.cli.common import app, console, print_json

ACTIONS = ("list", "export")


@app.command("data")
def data_command(
    action: str = typer.Argument(..., metavar="list|export",
                                 help="list: the bundled records; export: write one as CSV."),
    name: Optional[str] = typer.Argument(None, metavar="NAME",
                                         help="The record to export (a name from `data list`)."),
    folder: Path = typer.Argument(Path("."), metavar="DIR",
                                  help="Folder to write into (made when missing; default: here)."),
    force: bool = typer.Option(False, "--force", help="Replace files of the same names."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
) -> None:
    """The records shipped with creepcomp: `data list`, `data export NAME [DIR]`."""
    from creepcomp import data

    verb = action.strip().lower()
    if verb not in ACTIONS:
        raise InputError(f"data '{action}': use list or export (creepcomp data export NAME [DIR])")
    if verb == "list":
        if name is not None:
            raise InputError("data list takes no NAME")
        rows = [{"name": r.name, "description": r.description, "samples": len(r.read()),
                 "licence": r.licence} for r in data.records()]
        if as_json:
            print_json({"records": rows})
        else:
            render_list(rows)
        return
    if name is None:
        raise InputError("data export: give the NAME of a record (creepcomp data list names them)")
    entry = data.record(name)
    check_outputs(dirs={"DIR": folder}, contents={"DIR": entry.export_names()})
    written = data.export(name, folder, force=force)
    if as_json:
        print_json({"record": name, "written": [str(p) for p in written]})
        return
    for p in written:
        console.print(f"written {p}", soft_wrap=True)


def render_list(rows: list[dict]) -> None:
    """Print the bundled records as a table."""
    from rich.table import Table

    table = Table(title="Bundled records (creepcomp data export NAME [DIR] writes one as CSV)",
                  title_justify="left")
    for col, justify in (("name", "left"), ("what it is", "left"), ("samples", "right"),
                         ("licence", "left")):
        table.add_column(col, justify=justify)
    for row in rows:
        table.add_row(row["name"], row["description"], str(row["samples"]), row["licence"])
    console.print(table)
