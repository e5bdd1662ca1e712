"""``creepcomp size``: size the correction network and snap it to E-series parts."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, List, Optional

import typer
from rich.table import Table

from creepcomp.errors import InputError
from creepcomp.io.jsonfiles import read_model, write_design
from creepcomp.io.outputs import check_outputs
from creepcomp.model import CreepModel
from creepcomp.units import format_percent, format_quantity, format_time
from creepcomp.cli.common import app, console, print_json, quantity, value_range, warn_creep

if TYPE_CHECKING:
    from creepcomp.analog.sizing import SizingReport


def model_from_options(beta0: str | list[str] | None, tau: str | list[str] | None,
                       model_file: Path | None, terms: list[str] | None = None) -> CreepModel:
    """The creep model from ``--term BETA@TAU`` (repeatable), ``--beta0/--tau`` (one term,
    each given once) or ``--model``."""
    beta0, tau = once(beta0, "--beta0"), once(tau, "--tau")
    given = [name for name, value in (("--term", terms), ("--beta0", beta0), ("--tau", tau),
                                      ("--model", model_file)) if value]
    if terms and len(given) > 1:
        raise InputError(f"--term gives the whole creep model: drop {' and '.join(given[1:])}")
    if terms:
        return creep_terms(terms)
    if model_file is not None:
        if beta0 is not None or tau is not None:
            raise InputError("give either --model FILE or --beta0 and --tau, not both")
        return read_model(model_file)
    if beta0 is None or tau is None:
        raise InputError("give the sensor's creep: --term BETA@TAU (repeatable, e.g. --term 3%@45s), "
                         "--beta0 X --tau T, or --model FILE")
    return CreepModel.voigt(quantity(beta0, "fraction", "--beta0"),
                            quantity(tau, "second", "--tau"))


def once(values: str | list[str] | None, option: str) -> str | None:
    """The one value of an option that may not be repeated (click keeps the last silently)."""
    if values is None or isinstance(values, str):
        return values
    if len(values) > 1:
        raise InputError(f"{option} given {len(values)} times ({', '.join(values)}): it takes one "
                         "creep term; give several as --term BETA@TAU, e.g. --term 0.05%@20min "
                         "--term 0.02%@30s")
    return values[0] if values else None


def creep_terms(terms: list[str]) -> CreepModel:
    """The creep model of ``--term BETA@TAU`` options, one term each."""
    beta, tau = [], []
    for text in terms:
        parts = str(text).split("@")
        if len(parts) != 2:
            raise InputError(f"--term '{text}': expected BETA@TAU, e.g. 3%@45s or 0.05%@20min")
        beta.append(quantity(parts[0], "fraction", f"--term '{text}': BETA"))
        tau.append(quantity(parts[1], "second", f"--term '{text}': TAU"))
    try:
        return CreepModel(beta=tuple(beta), tau=tuple(tau))
    except InputError as exc:
        raise InputError(f"--term: {exc}") from None


def series_option(text: str, option: str) -> str | None:
    """An E-series name, or None for ``none`` (keep ideal values)."""
    return None if text.strip().lower() in ("none", "ideal") else text.strip().upper()


@app.command("size")
def size_command(
    terms: Optional[List[str]] = typer.Option(None, "--term", metavar="BETA@TAU",
                                              help="One creep term, e.g. 0.05%@20min (repeatable)."),
    beta0: Optional[List[str]] = typer.Option(None, "--beta0", metavar="FRACTION",
                                              help="One term's relative creep at infinite time, "
                                                   "e.g. 0.03 or 3%."),
    tau: Optional[List[str]] = typer.Option(None, "--tau", metavar="TIME",
                                            help="One term's retardation time, e.g. 45s or 2min."),
    model_file: Optional[Path] = typer.Option(None, "--model", metavar="FILE",
                                              help="Model file with Prony terms (beta, tau lists)."),
    rule: str = typer.Option("exact", "--rule", metavar="exact|paper",
                             help="exact: pole-zero cancellation; paper: the 2008 paper's eq. 16."),
    series: str = typer.Option("E24", "--series", metavar="SERIES",
                               help="Resistor E-series (E3 ... E192), or none for ideal values."),
    cap_series: str = typer.Option("E6", "--cap-series", metavar="SERIES",
                                   help="Capacitor E-series."),
    cap_range: str = typer.Option("1u:100u", "--cap-range", metavar="LOW:HIGH",
                                  help="Capacitor values to search, e.g. 1u:100u."),
    res_range: str = typer.Option("10:1G", "--res-range", metavar="LOW:HIGH",
                                  help="Resistor values allowed."),
    capacitance: Optional[str] = typer.Option(None, "--capacitance", metavar="FARAD",
                                              help="Fix the largest capacitor instead of searching."),
    source_resistance: str = typer.Option("0", "--source-resistance", metavar="OHM",
                                          help="Output resistance of the sensor."),
    load_resistance: str = typer.Option("none", "--load-resistance", metavar="OHM",
                                        help="Input resistance of the next stage (none: infinite)."),
    sweep_period: Optional[str] = typer.Option(None, "--sweep-period", metavar="TIME",
                                               help="Period of the hysteresis sweep "
                                                    "(default 2*pi*tau of the largest term)."),
    output: Optional[Path] = typer.Option(None, "-o", "--output", metavar="design.json",
                                          help="Write the design file."),
    plot: Optional[Path] = typer.Option(None, "--plot", metavar="FILE.png",
                                        help="Save residual-creep and hysteresis plots."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
) -> None:
    """Size the RC network that cancels the creep, snap it to E-series parts, predict its quality."""
    from creepcomp.analog.sizing import DEFAULT_CAP_RANGE, DEFAULT_RES_RANGE, size

    check_outputs({"-o": output, "--plot": plot}, inputs=[model_file])
    model = model_from_options(beta0, tau, model_file, terms)
    warn_creep(model, str(model_file) if model_file is not None else "--term" if terms else "--beta0")
    rule = rule.strip().lower()
    report = size(
        model, rule=rule,
        resistor_series=series_option(series, "--series"),
        capacitor_series=series_option(cap_series, "--cap-series"),
        cap_range=value_range(cap_range, "farad", "--cap-range") if cap_range else DEFAULT_CAP_RANGE,
        res_range=value_range(res_range, "ohm", "--res-range") if res_range else DEFAULT_RES_RANGE,
        capacitance=quantity(capacitance, "farad", "--capacitance", positive=True),
        source_resistance=quantity(source_resistance, "ohm", "--source-resistance", non_negative=True),
        load_resistance=quantity(load_resistance, "ohm", "--load-resistance", allow_none=True,
                                 positive=True),
        sweep_period=quantity(sweep_period, "second", "--sweep-period", positive=True),
    )
    if output is not None:
        write_design(output, report.design_dict())
    if plot is not None:
        designs = {"uncorrected": None, "ideal": report.ideal, "chosen parts": report.chosen}
        if report.nearest is not None:
            designs["nearest values"] = report.nearest
        from creepcomp.report.design import plot_design_comparison

        plot_design_comparison(model, designs, plot, report.chosen_quality.sweep_period)
    if as_json:
        print_json(report.to_dict())
        return
    render_sizing(report)
    if output is not None:
        console.print(f"design written to {output}")
    if plot is not None:
        console.print(f"plot written to {plot}")


def describe_model(model: CreepModel) -> str:
    """One line: the creep terms."""
    terms = ", ".join(f"{format_percent(b)} at {format_time(t)}" for b, t in zip(model.beta, model.tau))
    return f"{model.n_terms} creep term{'s' if model.n_terms > 1 else ''} ({terms}); beta0 = {format_percent(model.beta0)}"


def _peak_time(q) -> str:
    if q.residual_creep_peak < 1e-12:
        return "-"
    return "settled" if math.isinf(q.residual_creep_peak_time) else f"{q.residual_creep_peak_time:.4g} s"


def _unit(kind: str) -> str:
    return "Ω" if kind == "R" else "F"


def render_sizing(report: SizingReport, title: str | None = None) -> None:
    """Print a sizing report as tables."""
    net = report.chosen
    console.print(f"[bold]{title or 'creepcomp size'}[/bold]: {report.rule} rule, "
                  f"{net.topology} network; {describe_model(report.model)}")
    console.print(f"source resistance {format_quantity(net.source_resistance, 'Ω')}, "
                  f"load resistance {format_quantity(net.load_resistance, 'Ω')}")
    snapped = report.resistor_series is not None
    parts = Table(title="Parts", title_justify="left")
    parts.add_column("part")
    parts.add_column("ideal", justify="right")
    if snapped:
        parts.add_column(f"chosen ({report.resistor_series} R, {report.capacitor_series} C)", justify="right")
        parts.add_column("snap error", justify="right")
        parts.add_column("peak residual creep if only this part snapped", justify="right")
        for p in report.parts:
            parts.add_row(p.label, format_quantity(p.ideal, _unit(p.kind)),
                          format_quantity(p.chosen, _unit(p.kind)), f"{100 * p.deviation:+.2f} %",
                          format_percent(p.residual_if_only_this))
    else:
        for label, kind, v in net.parts():
            parts.add_row(label, format_quantity(v, _unit(kind)))
    console.print(parts)

    columns = [("ideal parts", report.ideal_quality)]
    if snapped:
        columns.append(("chosen parts", report.chosen_quality))
        if report.nearest_quality is not None:
            c_near = max(v for _, k, v in report.nearest.parts() if k == "C")
            columns.append((f"nearest values (C = {format_quantity(c_near, 'F')})", report.nearest_quality))
    columns.append(("uncorrected", report.uncorrected_quality))
    table = Table(title="Predicted (exact transfer functions)", title_justify="left")
    table.add_column("")
    for name, _ in columns:
        table.add_column(name, justify="right")
    table.add_row("residual creep, peak (of a load step)", *[format_percent(q.residual_creep_peak) for _, q in columns])
    table.add_row("  at (s after the step)",
                  *[_peak_time(q) for _, q in columns])
    table.add_row("residual creep, final", *[format_percent(q.residual_creep_final) for _, q in columns])
    table.add_row(f"hysteresis, ±FS sweep of {report.chosen_quality.sweep_period:.4g} s (of FS)",
                  *[format_percent(q.hysteresis) for _, q in columns])
    console.print(table)
    if report.nearest is not None and snapped:
        console.print(f"searched {report.candidates_evaluated} part combinations; nearest-value "
                      f"parts: " + ", ".join(f"{label} {format_quantity(v, _unit(k))}"
                                             for label, k, v in report.nearest.parts()))
    for w in report.warnings:
        console.print(f"[yellow]warning:[/yellow] {w}", soft_wrap=False)
