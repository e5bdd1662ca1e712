"""``creepcomp demo``: the main job on the bundled default sensor, end to end."""

from __future__ import annotations

from pathlib import Path

import typer

from creepcomp.cli.demo_steps import run_demo
from creepcomp.cli.common import app, console


@app.command("demo")
def demo_command(
    out: Path = typer.Option(Path("demo-output"), "--out", metavar="DIR",
                             help="Folder for the design files, plots and reports."),
) -> None:
    """Size the default sensor's network by both rules, snap it, compare, and write the results."""
    run_demo(out, console)
