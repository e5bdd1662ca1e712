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
    # --- over temperature ---
    temperature_range: Optional[str] = typer.Option(
        None, "--temperature-range", metavar="LOW:HIGH",
        help="Design over this range (°C, e.g. -10:40): residual creep at every temperature, "
             "fixed parts sized for the range; with --plot also FILE-over-temperature.png."),
    tracking: str = typer.Option("none", "--tracking", metavar="none|ntc",
                                 help="With --temperature-range: ntc makes R1 and R2 catalogue "
                                      "NTC thermistors that follow the creep."),
    activation_energy: Optional[str] = typer.Option(
        None, "--activation-energy", metavar="J/mol",
        help="Arrhenius law of the creep for --beta0/--tau, e.g. 43kJ/mol or 43k."),
    reference_temperature: str = typer.Option(
        "20", "--reference-temperature", metavar="°C",
        help="Temperature at which --beta0/--tau hold (with --activation-energy)."),
) -> None:
    """Size the RC network that cancels the creep, snap it to E-series parts, predict its quality."""
    from creepcomp.analog.sizing import DEFAULT_CAP_RANGE, DEFAULT_RES_RANGE, size

    check_outputs({"-o": output, "--plot": plot}, inputs=[model_file])
    model = model_from_options(beta0, tau, model_file, terms)
    model = with_temperature_law(model, activation_energy, reference_temperature)
    span = temperature_span(temperature_range, tracking)
    if span is not None:
        from creepcomp.analog.over_temperature import check_tracking

        check_tracking(model, tracking.strip().lower())
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
    comparison, at_reference = None, report
    if span is not None:
        report, comparison = size_over_range(report, span, tracking.strip().lower(), rule)
    if output is not None:
        design = report.design_dict()
        if comparison is not None:
            design["over_temperature"] = comparison.written.prediction.to_dict()
        write_design(output, design)
    if comparison is not None and plot is not None:
        from creepcomp.report.design import plot_over_temperature

        plot_over_temperature(comparison, over_temperature_plot_path(plot))
    if plot is not None:
        designs = {"uncorrected": None, "ideal": report.ideal, "chosen parts": report.chosen}
        if report.nearest is not None:
            designs["nearest values"] = report.nearest
        from creepcomp.report.design import plot_design_comparison

        plot_design_comparison(model, designs, plot, report.chosen_quality.sweep_period)
    if as_json:
        out = report.to_dict()
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
        if plot is not None:
            console.print(f"plot written to {over_temperature_plot_path(plot)}")
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
    parts = text.replace("°C", "").replace("C", "").split(":")
    if len(parts) != 2:
        raise InputError(f"--temperature-range = '{text}': expected LOW:HIGH in °C, e.g. -10:40")
    low, high = (quantity(p, "number", "--temperature-range") for p in parts)
    if low > high:
        raise InputError(f"--temperature-range = '{text}': LOW is above HIGH")
    return low, high


def size_over_range(report: SizingReport, span: tuple[float, float], tracking: str, rule: str):
    """The comparison over the range, and the sizing report of the design to write."""
    import dataclasses

    from creepcomp.analog.over_temperature import compare_over_range
    from creepcomp.analog.quality import predict

    comparison = compare_over_range(report.model, report.chosen, *span, plan=report.plan,
                                    tracking=tracking, rule=rule,
                                    resistor_series=report.resistor_series or "E24",
                                    capacitor_series=report.capacitor_series or "E6",
                                    reference_warnings=report.warnings)
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
