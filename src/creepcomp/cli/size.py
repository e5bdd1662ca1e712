"""``creepcomp size``: size the correction network and snap it to E-series parts."""

from __future__ import annotations

import math
import shlex
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, List, Optional

import typer
from rich.table import Table

from creepcomp.errors import InputError
from creepcomp.io.jsonfiles import read_model, write_design
from creepcomp.io.outputs import check_outputs
from creepcomp.model import CreepModel
from creepcomp.units import format_percent, format_quantity, format_time
from creepcomp.cli.common import (app, console, print_json, quantity, temperature_range_option, value_range,
                                  warn_creep)

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
    # --- over temperature ---
    temperature_range: Optional[str] = typer.Option(
        None, "--temperature-range", metavar="LOW:HIGH",
        help="Design over this range (°C, e.g. -10:40): residual creep at every temperature, "
             "fixed parts sized for the range; with --plot also FILE-over-temperature.png."),
    tracking: str = typer.Option("none", "--tracking", metavar="none|ntc",
                                 help="With --temperature-range: ntc makes R1 and R2 catalogue "
                                      "NTC thermistors that follow the creep."),
    topology: str = typer.Option("auto", "--topology", metavar="auto|passive|active",
                                 help="With --tracking ntc: passive lead network, active stage "
                                      "(integrators, one NTC per term, fixed gains), or auto: the "
                                      "passive one when it is practical, else the active one."),
    activation_energy: Optional[str] = typer.Option(
        None, "--activation-energy", metavar="J/mol",
        help="Arrhenius law of the creep for --beta0/--tau, e.g. 43kJ/mol or 43k."),
    reference_temperature: str = typer.Option(
        "20", "--reference-temperature", metavar="°C",
        help="Temperature at which --beta0/--tau hold (with --activation-energy)."),
    # --- from design to board: the parts bought, the verdict, BOM and schematic ---
    resistor_technology: str = typer.Option("thin film", "--resistor-technology", metavar="TECH",
                                            help="Resistor technology: thin film, thick film or "
                                                 "high-ohmic thick film (values it does not make "
                                                 "take the next technology that does)."),
    dielectric: str = typer.Option("polypropylene", "--dielectric",
                                   metavar="polypropylene|polyester|x7r",
                                   help="Capacitor technology."),
    resistor_tolerance: Optional[str] = typer.Option(None, "--resistor-tolerance", metavar="TOL",
                                                     help="Resistor tolerance bought (default 1 %)."),
    capacitor_tolerance: Optional[str] = typer.Option(None, "--capacitor-tolerance", metavar="TOL",
                                                      help="Capacitor tolerance bought (default 5 %)."),
    bom: Optional[Path] = typer.Option(None, "--bom", metavar="FILE.csv",
                                       help="Write the bill of materials (CSV)."),
    schematic: Optional[Path] = typer.Option(None, "--schematic", metavar="FILE.svg|.png",
                                             help="Draw the network with its values."),
    allow_impractical: bool = typer.Option(False, "--allow-impractical",
                                           help="Write a design judged impractical anyway "
                                                "(the verdict becomes a warning)."),
) -> None:
    """Size the RC network that cancels the creep, snap it to E-series parts, predict its quality.

    A design that cannot be built, or that leakage or its parts' tolerances leave worse than
    no correction, ends with exit status 3, no files written, and the way out.
    """
    from creepcomp.analog.sizing import DEFAULT_CAP_RANGE, DEFAULT_RES_RANGE, NoNetworkInRange, size

    if schematic is not None and schematic.suffix.lower() not in (".svg", ".png"):
        raise InputError(f"--schematic {schematic}: give a .svg or .png file")
    check_outputs({"-o": output, "--plot": plot, "--bom": bom, "--schematic": schematic},
                  inputs=[model_file])
    model = model_from_options(beta0, tau, model_file, terms)
    model = with_temperature_law(model, activation_energy, reference_temperature)
    span = temperature_span(temperature_range, tracking)
    if span is not None:
        from creepcomp.analog.over_temperature import check_tracking

        from creepcomp.analog.over_temperature import TOPOLOGIES

        if topology.strip().lower() not in TOPOLOGIES:
            raise InputError(f"--topology '{topology}': expected {', '.join(TOPOLOGIES)}")
        check_tracking(model, tracking.strip().lower(), topology.strip().lower())
    warn_creep(model, str(model_file) if model_file is not None else "--term" if terms else "--beta0")
    rule = rule.strip().lower()
    plan = parts_plan(resistor_technology, dielectric, resistor_tolerance, capacitor_tolerance)
    options = dict(
        rule=rule,
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
    given = GivenOptions(model, model_file, once(beta0, "--beta0"), once(tau, "--tau"), output, [
        ("--rule", rule, "exact"), ("--series", series, "E24"), ("--cap-series", cap_series, "E6"),
        ("--cap-range", cap_range, "1u:100u"), ("--res-range", res_range, "10:1G"),
        ("--capacitance", capacitance, None), ("--source-resistance", source_resistance, "0"),
        ("--load-resistance", load_resistance, "none"), ("--sweep-period", sweep_period, None),
        ("--resistor-technology", resistor_technology, "thin film"),
        ("--dielectric", dielectric, "polypropylene"),
        ("--resistor-tolerance", resistor_tolerance, None),
        ("--capacitor-tolerance", capacitor_tolerance, None),
        ("--activation-energy", activation_energy, None),
        ("--reference-temperature", reference_temperature, "20"),
        ("--temperature-range", temperature_range, None), ("--tracking", tracking, "none"),
        ("--topology", topology, "auto")], terms)
    try:
        report = size(model, plan=plan, **options)
    except NoNetworkInRange as exc:
        if allow_impractical or exc.fixable:
            raise
        refuse(model, options, plan, (str(exc),), None, given, as_json)
    comparison, at_reference = None, report
    if span is not None:
        report, comparison = size_over_range(report, span, tracking.strip().lower(), rule,
                                             topology.strip().lower())
    from creepcomp.analog.practicality import judge

    verdict = judge(report)
    # ideal values (--series none) are a calculation, not parts to order: judged, not refused
    ideal_values = report.resistor_series is None
    if not verdict.practical and not allow_impractical and not ideal_values:
        extra = {}
        if comparison is not None:
            # the comparison still tells the engineer what each design would leave
            extra = {"temperature_designs": comparison.to_dict()}
            if not as_json:
                render_over_range(comparison)
        way = fixed_for_range(comparison, report) if comparison is not None else None
        refuse(model, options, plan, verdict.reasons, verdict, given, as_json, extra, way)
    from creepcomp.analog.bom import bom_rows, write_bom

    rows = bom_rows(report.chosen, report.plan, {"R": report.resistor_series,
                                                 "C": report.capacitor_series}, model)
    if output is not None:
        design = report.design_dict()
        if comparison is not None:
            design["over_temperature"] = comparison.written.prediction.to_dict()
        write_design(output, design)
    if bom is not None:
        write_bom(bom, rows)
    if schematic is not None:
        from creepcomp.report.schematic import draw_network

        draw_network(report.chosen, schematic, report.plan)
    if comparison is not None and plot is not None:
        from creepcomp.report.common import save_axes
        from creepcomp.report.design import plot_over_temperature

        save_axes(plot_over_temperature(comparison), over_temperature_plot_path(plot))
    if plot is not None:
        designs = {"uncorrected": None, "ideal": report.ideal, "chosen parts": report.chosen}
        if report.nearest is not None:
            designs["nearest values"] = report.nearest
        from creepcomp.report.common import save_axes
        from creepcomp.report.design import plot_design_comparison

        save_axes(plot_design_comparison(model, designs, sweep_period=report.chosen_quality.sweep_period,
                                         schematic=report.chosen, plan=report.plan), plot)
    if as_json:
        out = report.to_dict()
        out.update(practical=verdict.practical, reasons=list(verdict.reasons), way_out=None,
                   verdict=verdict.to_dict(), bom=[r.to_dict() for r in rows])
        if comparison is not None:
            out["parts"] = report.plan.to_dict()
            out["over_temperature"] = comparison.written.prediction.to_dict()
            out["temperature_designs"] = comparison.to_dict()
        print_json(out)
        return
    if comparison is None:
        render_sizing(report)
    else:
        render_sizing(at_reference, "creepcomp size, (a) sized at the reference temperature "
                      f"{at_reference.model.temperature.reference:g} °C" if at_reference.model.temperature
                      else None)
        render_over_range(comparison)
    render_bom(rows)
    if verdict.practical and report.chosen.topology == "active":
        render_active_verdict(verdict, report, span)
    elif verdict.practical:
        console.print(f"practical: every part is made; with a {format_quantity(verdict.to_dict()['leakage_to_ground'], 'Ω')} "
                      f"leakage path the peak residual creep is {format_percent(verdict.leakage_peak)}, "
                      f"at the worst tolerance corner {format_percent(verdict.worst_case_peak)} "
                      f"(uncorrected {format_percent(verdict.uncorrected_peak)})")
    else:
        for reason in verdict.reasons:
            why = "ideal values" if ideal_values else "--allow-impractical"
            console.print(f"[yellow]warning:[/yellow] impractical ({why}): {reason}",
                          soft_wrap=False)
    if comparison is not None and plot is not None:
        console.print(f"plot written to {over_temperature_plot_path(plot)}")
    for path, what in ((output, "design"), (bom, "bill of materials"), (schematic, "schematic"),
                       (plot, "plot")):
        if path is not None:
            console.print(f"{what} written to {path}")


def parts_plan(technology: str, dielectric: str, resistor_tolerance: str | None,
               capacitor_tolerance: str | None):
    """The :class:`~creepcomp.analog.parts.PartsPlan` of the command line's options."""
    from creepcomp.analog.parts import DIELECTRICS, RESISTORS, PartsPlan

    tech = " ".join(technology.strip().lower().replace("-", " ").split())
    tech = "high-ohmic thick film" if tech == "high ohmic thick film" else tech
    if tech not in RESISTORS:
        raise InputError(f"--resistor-technology '{technology}': choose one of {', '.join(RESISTORS)}")
    diel = dielectric.strip().lower()
    if diel not in DIELECTRICS:
        raise InputError(f"--dielectric '{dielectric}': choose one of {', '.join(DIELECTRICS)}")
    default = PartsPlan()
    rtol = quantity(resistor_tolerance, "fraction", "--resistor-tolerance", non_negative=True)
    ctol = quantity(capacitor_tolerance, "fraction", "--capacitor-tolerance", non_negative=True)
    for value, option in ((rtol, "--resistor-tolerance"), (ctol, "--capacitor-tolerance")):
        if value is not None and value >= 1:
            raise InputError(f"{option}: {format_percent(value)} is not a tolerance (below 100 %)")
    return PartsPlan(tech, diel,
                     default.resistor_tolerance if rtol is None else rtol,
                     default.capacitor_tolerance if ctol is None else ctol,
                     RESISTORS[tech].tc, DIELECTRICS[diel].tc)


@dataclass
class GivenOptions:
    """The options of a ``size`` call as the user wrote them, to print a changed command."""

    model: CreepModel
    model_file: Path | None
    beta0: str | None
    tau: str | None
    output: Path | None
    options: list          # (flag, text given, default text)
    terms: list | None = None


def _eng(value: float) -> str:
    return format_quantity(value, "").replace(" ", "").replace("µ", "u")


def _arg(text) -> str:
    return shlex.quote(str(text))


def _model_file_beside(given: GivenOptions, model: CreepModel) -> Path:
    """Write ``model`` beside the requested output (``design.model.json`` for ``-o
    design.json``; ``creep.model.json`` in the current folder without ``-o``), for the
    firmware command, which reads a model file."""
    from creepcomp.io.jsonfiles import write_model

    base = given.output if given.output is not None else Path("creep.json")
    path = base.with_name(f"{base.stem}.model.json")
    check_outputs({"(model file of the way out)": path}, inputs=[given.model_file])
    write_model(path, model)
    return path


def model_args(given: GivenOptions, model: CreepModel) -> list[str]:
    """The options naming ``model``: the user's own, ``--beta0/--tau`` for one term, else one
    ``--term BETA@TAU`` per term."""
    if model is given.model:
        if given.model_file is not None:
            return ["--model", _arg(given.model_file)]
        if given.beta0 is not None:
            return ["--beta0", _arg(given.beta0), "--tau", _arg(given.tau)]
        if given.terms:
            return [w for t in given.terms for w in ("--term", _arg(t))]
    if model.n_terms == 1:
        return ["--beta0", f"{100 * model.beta[0]:.6g}%", "--tau", f"{model.tau[0]:.6g}s"]
    words = []
    for b, t in zip(model.beta, model.tau):
        words += ["--term", f"{100 * b:.6g}%@{t:.6g}s"]
    return words


def size_command_line(given: GivenOptions, changes: dict) -> str:
    """The ``creepcomp size`` command of the user's options with ``changes`` applied."""
    from creepcomp.model import CreepModel as Model

    model = given.model
    if "terms" in changes:
        model = Model(beta=tuple(model.beta[k] for k in changes["terms"]),
                      tau=tuple(model.tau[k] for k in changes["terms"]))
    words = ["creepcomp", "size"] + model_args(given, model)
    replaced = {"--load-resistance": "none" if "load_resistance" in changes else None,
                "--tracking": changes.get("tracking"),
                "--cap-range": (f"{_eng(changes['cap_range'][0])}:{_eng(changes['cap_range'][1])}"
                                if "cap_range" in changes else None),
                "--res-range": (f"{_eng(changes['res_range'][0])}:{_eng(changes['res_range'][1])}"
                                if "res_range" in changes else None)}
    dropped = {"--capacitance"} if "capacitance" in changes else set()
    for flag, text, default in given.options:
        if flag in dropped:
            continue
        value = replaced.get(flag) or text
        if value is not None and value != default:
            words += [flag, _arg(value)]
    if given.output is not None:
        words += ["-o", _arg(given.output)]
    return " ".join(words)


#: Sample rate put in the firmware command of a way out (the user sets their ADC's).
FIRMWARE_RATE = "10Hz"


def fixed_for_range(comparison, report):
    """The way out of an impractical tracking design: the fixed parts sized for the range,
    when they are practical (else None)."""
    import dataclasses

    from creepcomp.analog.practicality import WayOut, judge

    if comparison.chosen != "ntc":
        return None
    fixed = comparison.design("range")
    candidate = dataclasses.replace(report, chosen=fixed.network, plan=fixed.plan)
    verdict = judge(candidate)
    if not verdict.practical:
        return None
    return WayOut("size", {"tracking": "none"},
                  f"fixed parts sized for the range (worst {format_percent(fixed.prediction.worst)} "
                  f"at {fixed.prediction.worst_at:g} °C)", candidate, verdict)


def refuse(model: CreepModel, options: dict, plan, reasons, verdict, given: GivenOptions,
           as_json: bool, extra: dict | None = None, way=None) -> None:
    """Say why the design is impractical and the way out; exit with status 3."""
    from creepcomp.analog.practicality import find_way_out

    way = way or find_way_out(model, options, plan)
    if way.kind == "size":
        command = size_command_line(given, way.changes)
    else:
        model_path = (given.model_file if given.model_file is not None
                      else _model_file_beside(given, model))
        folder = (given.output.parent if given.output is not None else Path(".")) / "firmware"
        command = (f"creepcomp firmware {_arg(model_path)} --rate {FIRMWARE_RATE} --full-scale 1 "
                   f"-o {_arg(folder)}")
    if as_json:
        out = {"practical": False, "reasons": list(reasons),
               "way_out": dict(way.to_dict(), command=command)}
        if way.kind == "firmware":
            out["way_out"]["model_file"] = str(model_path)
        if verdict is not None:
            out["verdict"] = verdict.to_dict()
        out.update(extra or {})
        print_json(out)
    else:
        more = f" (and {len(reasons) - 1} more: see --json)" if len(reasons) > 1 else ""
        console.print(f"impractical: {reasons[0]}{more}", soft_wrap=True, markup=False)
        if way.kind == "size":
            v = way.verdict
            console.print(f"way out: {way.description}: peak residual creep "
                          f"{format_percent(v.leakage_peak)} with leakage, "
                          f"{format_percent(v.worst_case_peak)} at the worst tolerance corner "
                          f"(uncorrected {format_percent(v.uncorrected_peak)}):",
                          soft_wrap=True, markup=False)
        else:
            console.print(f"way out: {way.description} (set --rate to your ADC's sample rate "
                          "and --full-scale to its range in signal units):",
                          soft_wrap=True, markup=False)
        console.print(f"  {command}", soft_wrap=True, markup=False, highlight=False)
        if way.kind == "firmware" and given.model_file is None:
            console.print(f"(the model file it reads was written to {model_path})", markup=False,
                          soft_wrap=True)
        console.print("nothing written (--allow-impractical writes the design anyway)",
                      markup=False)
    raise typer.Exit(IMPRACTICAL)


#: Exit status of a design judged impractical.
IMPRACTICAL = 3


def render_bom(rows) -> None:
    """Print the bill of materials as a table."""
    from creepcomp.analog.bom import BOM_COLUMNS

    table = Table(title="Bill of materials (tc in ppm/K)", title_justify="left")
    for c in BOM_COLUMNS:
        table.add_column(c, justify="right" if c in ("value", "tolerance", "tc") else "left")
    for r in rows:
        table.add_row(*[getattr(r, c) for c in BOM_COLUMNS])
    console.print(table)


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


# --- over temperature -------------------------------------------------------------------------

def with_temperature_law(model: CreepModel, activation_energy: str | None,
                         reference_temperature: str) -> CreepModel:
    """The model with an Arrhenius law from ``--activation-energy`` (none given: as it is)."""
    from creepcomp.temperature import TemperatureLaw

    if activation_energy is None:
        return model
    if model.temperature is not None:
        raise InputError("--activation-energy: the model file has its own temperature block; "
                         "give one or the other")
    text = activation_energy.strip()
    text = text[:-len("J/mol")] if text.lower().endswith("j/mol") else text
    ea = quantity(text, "number", "--activation-energy", non_negative=True)
    ref = quantity(reference_temperature, "number", "--reference-temperature")
    law = TemperatureLaw.arrhenius(ea, ref)
    return CreepModel(model.beta, model.tau, model.gain, model.offset, dict(model.extensions), law)


def temperature_span(text: str | None, tracking: str) -> tuple[float, float] | None:
    """``--temperature-range LOW:HIGH`` in °C (None without it)."""
    if tracking.strip().lower() not in ("none", "ntc"):
        raise InputError(f"--tracking = '{tracking}': expected none or ntc")
    if text is None:
        if tracking.strip().lower() != "none":
            raise InputError("--tracking needs --temperature-range LOW:HIGH (°C)")
        return None
    return temperature_range_option(text)


def render_active_verdict(verdict, report: SizingReport, span) -> None:
    """The verdict line of an active stage: leakage, tolerance corner, the op amps and the
    constant output offset they give at the range's ends."""
    from creepcomp.analog.active import OP_AMP, output_offset

    temps = span if span is not None else (25.0,)
    offset = max(output_offset(report.chosen, report.plan, t) for t in temps)
    console.print(f"practical: every part is made; with the capacitors' insulation and a "
                  f"{format_quantity(verdict.to_dict()['leakage_to_ground'], 'Ω')} board path "
                  f"across each the peak residual creep is {format_percent(verdict.leakage_peak)}, "
                  f"at the worst tolerance corner {format_percent(verdict.worst_case_peak)} "
                  f"(uncorrected {format_percent(verdict.uncorrected_peak)})", soft_wrap=True)
    console.print(f"op amps: {OP_AMP.text()}; at those limits their constant output offset is at "
                  f"most {format_quantity(offset, 'V')} over the range (tared, not creep)",
                  soft_wrap=True, markup=False)


def size_over_range(report: SizingReport, span: tuple[float, float], tracking: str, rule: str,
                    topology: str = "auto"):
    """The comparison over the range, and the sizing report of the design to write."""
    import dataclasses

    from creepcomp.analog.over_temperature import compare_over_range
    from creepcomp.analog.quality import predict

    comparison = compare_over_range(report.model, report.chosen, *span, plan=report.plan,
                                    tracking=tracking, rule=rule,
                                    resistor_series=report.resistor_series or "E24",
                                    capacitor_series=report.capacitor_series or "E6",
                                    reference_warnings=report.warnings, topology=topology)
    chosen = comparison.written
    if chosen.key == "reference":
        return report, comparison
    quality = predict(report.model, chosen.network, report.chosen_quality.sweep_period)
    warnings = tuple(w for w in report.warnings if not w.startswith("high impedance")) + chosen.warnings
    written = dataclasses.replace(report, chosen=chosen.network, chosen_quality=quality, plan=chosen.plan,
                                  nearest=None, nearest_quality=None, parts=(), warnings=warnings)
    return written, comparison


def over_temperature_plot_path(plot: Path) -> Path:
    """``FILE-over-temperature.png`` next to ``--plot FILE.png``."""
    return plot.with_name(f"{plot.stem}-over-temperature{plot.suffix or '.png'}")


def render_over_range(comparison) -> None:
    """Print the designs over the range: worst cases, residual at every temperature, thermistors."""
    designs = comparison.designs
    console.print(f"[bold]Over {comparison.low:g} .. {comparison.high:g} °C[/bold]: "
                  f"{designs[0].prediction.note}")
    table = Table(title="Worst case over the range", title_justify="left")
    for col in ("design", "worst peak residual creep", "at", "written"):
        table.add_column(col, justify="left" if col == "design" else "right")
    for d in designs:
        table.add_row(d.label, format_percent(d.prediction.worst), f"{d.prediction.worst_at:g} °C",
                      "yes" if d.key == comparison.chosen else "")
    bare = designs[0].prediction
    worst_bare = max(range(len(bare.uncorrected)), key=bare.uncorrected.__getitem__)
    table.add_row("uncorrected", format_percent(bare.uncorrected[worst_bare]),
                  f"{bare.temperatures[worst_bare]:g} °C", "")
    console.print(table)
    per_t = Table(title="Peak residual creep of a full-scale step at each temperature", title_justify="left")
    per_t.add_column("°C", justify="right")
    for d in designs:
        per_t.add_column(d.label.split(")")[0] + ")", justify="right")
    per_t.add_column("uncorrected", justify="right")
    for k, t in enumerate(bare.temperatures):
        per_t.add_row(f"{t:g}", *[format_percent(d.prediction.peak_residual[k]) for d in designs],
                      format_percent(bare.uncorrected[k]))
    console.print(per_t)
    written = comparison.written
    parts = Table(title=f"Written design: {written.label}", title_justify="left")
    for col in ("part", "value at 25 °C", "made of"):
        parts.add_column(col, justify="left" if col != "value at 25 °C" else "right")
    for label, kind, v in written.network.parts():
        use = written.plan.thermistors.get(label)
        if use is None:
            made = f"{written.plan.resistor if kind == 'R' else written.plan.capacitor}"
        else:
            made = f"NTC {use.part} (R25 = {format_quantity(use.r25, 'Ω')}, B = {use.b:g} K)"
            if use.series:
                made += f" + {format_quantity(use.series, 'Ω')} in series"
            if use.parallel is not None:
                made += f", {format_quantity(use.parallel, 'Ω')} across"
        parts.add_row(label, format_quantity(v, _unit(kind)), made)
    console.print(parts)
    for w in written.warnings:
        console.print(f"[yellow]warning:[/yellow] {w}", soft_wrap=False)
