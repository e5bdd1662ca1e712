"""``creepcomp size``: size the correction network and snap it to E-series parts.

The command parses its options, calls :func:`creepcomp.analog.network_design.design_network`
and prints the result's tables (:mod:`creepcomp.report.results`). Each option's default is the
API's own, read from its signature (:data:`DEFAULTS`).
"""

from __future__ import annotations

import inspect
import shlex
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, List, Optional

import typer

from creepcomp.analog.network_design import NetworkDesign, design_network
from creepcomp.analog.parts import PartsPlan
from creepcomp.analog.sizing import size
from creepcomp.errors import InputError
from creepcomp.io.jsonfiles import read_model, write_design
from creepcomp.io.outputs import check_outputs
from creepcomp.model import CreepModel
from creepcomp.report.results import sizing_summary
from creepcomp.temperature import TemperatureLaw
from creepcomp.units import format_percent
from creepcomp.cli.common import (api_default, app, console, print_json, print_summary, quantity, si_text,
                                  temperature_range_option, value_range, warn_creep)


def _api_defaults() -> dict:
    """The command line's default text of each option, from the API's defaults."""
    sizing = {k: p.default for k, p in inspect.signature(size).parameters.items()}
    plan = PartsPlan()

    def text(value):
        return "none" if value is None else si_text(value) if isinstance(value, float) else value

    return {"rule": sizing["rule"], "series": text(sizing["resistor_series"]),
            "cap_series": text(sizing["capacitor_series"]),
            "cap_range": ":".join(si_text(v) for v in sizing["cap_range"]),
            "res_range": ":".join(si_text(v) for v in sizing["res_range"]),
            "capacitance": sizing["capacitance"], "source_resistance": text(sizing["source_resistance"]),
            "load_resistance": text(sizing["load_resistance"]), "sweep_period": sizing["sweep_period"],
            "tracking": api_default(design_network, "tracking"),
            "topology": api_default(design_network, "topology"),
            "allow_impractical": api_default(design_network, "allow_impractical"),
            "reference_temperature": f"{api_default(TemperatureLaw.arrhenius, 'reference'):g}",
            "resistor_technology": plan.resistor, "dielectric": plan.capacitor,
            "resistor_tolerance": plan.resistor_tolerance, "capacitor_tolerance": plan.capacitor_tolerance}


#: Each option's default as the command line shows it, read from the API.
DEFAULTS = _api_defaults()


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


Terms = Annotated[Optional[List[str]], typer.Option("--term", metavar="BETA@TAU",
                                                    help="One creep term, e.g. 0.05%@20min (repeatable).")]
Beta0 = Annotated[Optional[List[str]], typer.Option("--beta0", metavar="FRACTION",
                                                    help="One term's relative creep at infinite time, "
                                                         "e.g. 0.03 or 3%.")]
Tau = Annotated[Optional[List[str]], typer.Option("--tau", metavar="TIME",
                                                  help="One term's retardation time, e.g. 45s or 2min.")]
ModelFile = Annotated[Optional[Path], typer.Option("--model", metavar="FILE",
                                                   help="Model file with Prony terms (beta, tau lists).")]
Rule = Annotated[str, typer.Option("--rule", metavar="exact|paper",
                                   help="exact: pole-zero cancellation; paper: the 2008 paper's eq. 16.")]
Series = Annotated[str, typer.Option("--series", metavar="SERIES",
                                     help="Resistor E-series (E3 ... E192), or none for ideal values.")]
CapSeries = Annotated[str, typer.Option("--cap-series", metavar="SERIES", help="Capacitor E-series.")]
CapRange = Annotated[str, typer.Option("--cap-range", metavar="LOW:HIGH",
                                       help="Capacitor values to search, e.g. 1u:100u.")]
ResRange = Annotated[str, typer.Option("--res-range", metavar="LOW:HIGH", help="Resistor values allowed.")]
Capacitance = Annotated[Optional[str], typer.Option("--capacitance", metavar="FARAD",
                                                    help="Fix the largest capacitor instead of searching.")]
SourceResistance = Annotated[str, typer.Option("--source-resistance", metavar="OHM",
                                               help="Output resistance of the sensor.")]
LoadResistance = Annotated[str, typer.Option("--load-resistance", metavar="OHM",
                                             help="Input resistance of the next stage (none: infinite).")]
SweepPeriod = Annotated[Optional[str], typer.Option("--sweep-period", metavar="TIME",
                                                    help="Period of the hysteresis sweep "
                                                         "(default 2*pi*tau of the largest term).")]
Output = Annotated[Optional[Path], typer.Option("-o", "--output", metavar="design.json", help="Write the design file.")]
Plot = Annotated[Optional[Path], typer.Option("--plot", metavar="FILE.png",
                                              help="Save residual-creep and hysteresis plots.")]
AsJson = Annotated[bool, typer.Option("--json", help="Print one JSON object.")]
TemperatureRange = Annotated[Optional[str], typer.Option(
    "--temperature-range", metavar="LOW:HIGH",
    help="Design over this range (°C, e.g. -10:40): residual creep at every temperature, "
         "fixed parts sized for the range; with --plot also FILE-over-temperature.png.")]
Tracking = Annotated[str, typer.Option("--tracking", metavar="none|ntc",
                                       help="With --temperature-range: ntc makes R1 and R2 catalogue "
                                            "NTC thermistors that follow the creep.")]
Topology = Annotated[str, typer.Option("--topology", metavar="auto|passive|active",
                                       help="With --tracking ntc: passive lead network, active stage "
                                            "(integrators, one NTC per term, fixed gains), or auto: the "
                                            "passive one when it is practical, else the active one.")]
ActivationEnergy = Annotated[Optional[str], typer.Option(
    "--activation-energy", metavar="J/mol",
    help="Arrhenius law of the creep for --beta0/--tau, e.g. 43kJ/mol or 43k.")]
ReferenceTemperature = Annotated[str, typer.Option(
    "--reference-temperature", metavar="°C",
    help="Temperature at which --beta0/--tau hold (with --activation-energy).")]
ResistorTechnology = Annotated[str, typer.Option("--resistor-technology", metavar="TECH",
                                                 help="Resistor technology: thin film, thick film or "
                                                      "high-ohmic thick film (values it does not make "
                                                      "take the next technology that does).")]
Dielectric = Annotated[str, typer.Option("--dielectric", metavar="polypropylene|polyester|x7r",
                                         help="Capacitor technology.")]
ResistorTolerance = Annotated[Optional[str], typer.Option(
    "--resistor-tolerance", metavar="TOL",
    help=f"Resistor tolerance bought (default {format_percent(DEFAULTS['resistor_tolerance'])}).")]
CapacitorTolerance = Annotated[Optional[str], typer.Option(
    "--capacitor-tolerance", metavar="TOL",
    help=f"Capacitor tolerance bought (default {format_percent(DEFAULTS['capacitor_tolerance'])}).")]
Bom = Annotated[Optional[Path], typer.Option("--bom", metavar="FILE.csv", help="Write the bill of materials (CSV).")]
Schematic = Annotated[Optional[Path], typer.Option("--schematic", metavar="FILE.svg|.png",
                                                   help="Draw the network with its values.")]
AllowImpractical = Annotated[bool, typer.Option("--allow-impractical",
                                                help="Write a design judged impractical anyway "
                                                     "(the verdict becomes a warning).")]
D = DEFAULTS


@app.command("size")
def size_command(
    ctx: typer.Context, terms: Terms = None, beta0: Beta0 = None, tau: Tau = None, model_file: ModelFile = None,
    rule: Rule = D["rule"], series: Series = D["series"], cap_series: CapSeries = D["cap_series"],
    cap_range: CapRange = D["cap_range"], res_range: ResRange = D["res_range"],
    capacitance: Capacitance = D["capacitance"], source_resistance: SourceResistance = D["source_resistance"],
    load_resistance: LoadResistance = D["load_resistance"], sweep_period: SweepPeriod = D["sweep_period"],
    output: Output = None, plot: Plot = None, as_json: AsJson = False,
    temperature_range: TemperatureRange = None, tracking: Tracking = D["tracking"],
    topology: Topology = D["topology"], activation_energy: ActivationEnergy = None,
    reference_temperature: ReferenceTemperature = D["reference_temperature"],
    resistor_technology: ResistorTechnology = D["resistor_technology"], dielectric: Dielectric = D["dielectric"],
    resistor_tolerance: ResistorTolerance = None, capacitor_tolerance: CapacitorTolerance = None,
    bom: Bom = None, schematic: Schematic = None, allow_impractical: AllowImpractical = D["allow_impractical"],
) -> None:
    """Size the RC network that cancels the creep, snap it to E-series parts, predict its quality.

    A design that cannot be built, or that leakage or its parts' tolerances leave worse than
    no correction, ends with exit status 3, no files written, and the way out.
    """
    if schematic is not None and schematic.suffix.lower() not in (".svg", ".png"):
        raise InputError(f"--schematic {schematic}: give a .svg or .png file")
    check_outputs({"-o": output, "--plot": plot, "--bom": bom, "--schematic": schematic}, inputs=[model_file])
    model = with_temperature_law(model_from_options(beta0, tau, model_file, terms), activation_energy,
                                 reference_temperature)
    span = temperature_span(temperature_range, tracking)
    warn_creep(model, str(model_file) if model_file is not None else "--term" if terms else "--beta0")
    result = design_network(
        model, parts_plan(resistor_technology, dielectric, resistor_tolerance, capacitor_tolerance), span,
        tracking.strip().lower(), topology.strip().lower(), allow_impractical,
        **size_options(rule, series, cap_series, cap_range, res_range, capacitance, source_resistance,
                       load_resistance, sweep_period))
    if result.refused:
        refuse(result, GivenOptions.of_command(ctx, model, model_file, beta0, tau, output, terms), as_json)
    written = write_outputs(result, output, bom, schematic, plot)
    if as_json:
        print_json(result.to_dict())
        return
    render_design(result)
    for path, what in written:
        console.print(f"{what} written to {path}")


def size_options(rule: str, series: str, cap_series: str, cap_range: str, res_range: str,
                 capacitance: str | None, source_resistance: str, load_resistance: str,
                 sweep_period: str | None) -> dict:
    """:func:`~creepcomp.analog.sizing.size`'s arguments from the options' text (an empty
    range: the API's default)."""
    return dict(
        rule=rule.strip().lower(),
        resistor_series=series_option(series, "--series"),
        capacitor_series=series_option(cap_series, "--cap-series"),
        cap_range=value_range(cap_range, "farad", "--cap-range") if cap_range else api_default(size, "cap_range"),
        res_range=value_range(res_range, "ohm", "--res-range") if res_range else api_default(size, "res_range"),
        capacitance=quantity(capacitance, "farad", "--capacitance", positive=True),
        source_resistance=quantity(source_resistance, "ohm", "--source-resistance", non_negative=True),
        load_resistance=quantity(load_resistance, "ohm", "--load-resistance", allow_none=True,
                                 positive=True),
        sweep_period=quantity(sweep_period, "second", "--sweep-period", positive=True),
    )


def write_outputs(result: NetworkDesign, output: Path | None, bom: Path | None, schematic: Path | None,
                  plot: Path | None) -> list[tuple[Path, str]]:
    """Write the files asked for; ``(path, what)`` of each, in the order the command tells them."""
    from creepcomp.analog.bom import write_bom

    report = result.sizing
    if output is not None:
        write_design(output, result.design_dict())
    if bom is not None:
        write_bom(bom, list(result.bom))
    if schematic is not None:
        from creepcomp.report.schematic import draw_network

        draw_network(report.chosen, schematic, report.plan)
    written = []
    if plot is not None:
        from creepcomp.report.common import save_axes
        from creepcomp.report.design import plot_design_comparison, plot_over_temperature

        if result.comparison is not None:
            save_axes(plot_over_temperature(result.comparison), over_temperature_plot_path(plot))
            written.append((over_temperature_plot_path(plot), "plot"))
        designs = {"uncorrected": None, "ideal": report.ideal, "chosen parts": report.chosen}
        if report.nearest is not None:
            designs["nearest values"] = report.nearest
        save_axes(plot_design_comparison(result.model, designs, sweep_period=report.chosen_quality.sweep_period,
                                         schematic=report.chosen, plan=report.plan), plot)
    return written + [(path, what) for path, what in ((output, "design"), (bom, "bill of materials"),
                                                      (schematic, "schematic"), (plot, "plot"))
                      if path is not None]


def render_design(result: NetworkDesign) -> None:
    """Print a network design: the sizing (at the reference temperature), the designs over
    the range, the bill of materials and the verdict."""
    from creepcomp.report.results import bom_table, verdict_lines

    at_reference = result.at_reference
    law = at_reference.model.temperature
    title = (f"creepcomp size, (a) sized at the reference temperature {law.reference:g} °C"
             if result.comparison is not None and law else None)
    print_summary(sizing_summary(at_reference, title))
    if result.comparison is not None:
        render_over_range(result.comparison)
    console.print(bom_table(result.bom).to_rich())
    active = result.sizing.chosen.topology == "active"
    for line in verdict_lines(result):
        if result.verdict.practical:
            console.print(line, soft_wrap=active, markup=False)
        else:
            console.print(f"[yellow]warning:[/yellow] {line}", soft_wrap=False)


def render_over_range(comparison) -> None:
    """Print the designs over the range: worst cases, residual at every temperature, thermistors."""
    from creepcomp.report.results import over_range_summary

    print_summary(over_range_summary(comparison))


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

    @classmethod
    def of_command(cls, ctx: typer.Context, model: CreepModel, model_file: Path | None, beta0, tau,
                   output: Path | None, terms) -> "GivenOptions":
        """The running command's options: each of :data:`COMMAND_LINE_OPTIONS` with the text
        given and its default (from the command's context)."""
        by_flag = {flag: p for p in ctx.command.params for flag in p.opts}
        options = [(flag, ctx.params[by_flag[flag].name], by_flag[flag].default)
                   for flag in COMMAND_LINE_OPTIONS]
        return cls(model, model_file, once(beta0, "--beta0"), once(tau, "--tau"), output, options, terms)


#: The options a way out's command repeats (when not at their default), in its order.
COMMAND_LINE_OPTIONS = ("--rule", "--series", "--cap-series", "--cap-range", "--res-range", "--capacitance",
                        "--source-resistance", "--load-resistance", "--sweep-period",
                        "--resistor-technology", "--dielectric", "--resistor-tolerance",
                        "--capacitor-tolerance", "--activation-energy", "--reference-temperature",
                        "--temperature-range", "--tracking", "--topology")


def _arg(text) -> str:
    return shlex.quote(str(text))


def _model_file_beside(given: GivenOptions, model: CreepModel) -> Path:
    """Write ``model`` beside the requested output (``design.model.json`` for ``-o
    design.json``; ``creep.model.json`` in the current folder without ``-o``; the next free
    ``-2``, ``-3`` ... name when that file exists: it was not named by the user), for the
    firmware command, which reads a model file."""
    from creepcomp.io.jsonfiles import write_model
    from creepcomp.io.outputs import unnamed_output

    base = given.output if given.output is not None else Path("creep.json")
    path = unnamed_output(base.with_name(f"{base.stem}.model.json"))
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
                "--cap-range": (f"{si_text(changes['cap_range'][0])}:{si_text(changes['cap_range'][1])}"
                                if "cap_range" in changes else None),
                "--res-range": (f"{si_text(changes['res_range'][0])}:{si_text(changes['res_range'][1])}"
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


def refuse(result: NetworkDesign, given: GivenOptions, as_json: bool) -> None:
    """Say why the design is impractical and the way out; exit with status 3."""
    model, way, reasons = result.model, result.way_out, result.reasons
    if way.kind == "size":
        command = size_command_line(given, way.changes)
    else:
        model_path = (given.model_file if given.model_file is not None
                      else _model_file_beside(given, model))
        folder = (given.output.parent if given.output is not None else Path(".")) / "firmware"
        command = (f"creepcomp firmware {_arg(model_path)} --rate {FIRMWARE_RATE} --full-scale 1 "
                   f"-o {_arg(folder)}")
    if as_json:
        out = result.refusal_dict()
        out["way_out"]["command"] = command
        if way.kind == "firmware":
            out["way_out"]["model_file"] = str(model_path)
        print_json(out)
    else:
        if result.comparison is not None:
            render_over_range(result.comparison)
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


def over_temperature_plot_path(plot: Path) -> Path:
    """``FILE-over-temperature.png`` next to ``--plot FILE.png``."""
    return plot.with_name(f"{plot.stem}-over-temperature{plot.suffix or '.png'}")
