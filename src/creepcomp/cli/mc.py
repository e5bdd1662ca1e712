"""``creepcomp mc``: tolerance Monte Carlo, worst case and sensitivity of a design."""

from __future__ import annotations

import time
from pathlib import Path
from typing import List, Optional

import typer
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from creepcomp.verify.tolerance_analysis import ToleranceReport, analyse
from creepcomp.verify.tolerances import DIELECTRICS, Tolerance, ToleranceSpec
from creepcomp.errors import InputError
from creepcomp.io.outputs import check_outputs
from creepcomp.units import format_parameter, format_percent
from creepcomp.cli.common import (api_default, app, console, count_option, err_console, print_json,
                                  quantity, temperature_range_option, temperatures_option, value_range,
                                  read_checked_design)


def _tolerance(text: str, option: str, distribution: str) -> Tolerance:
    value = quantity(text, "fraction", option, non_negative=True)
    try:
        return Tolerance(value, distribution)
    except InputError as exc:
        raise InputError(f"{option} '{text}': {exc}") from None


def _part_tolerances(items: list[str], distribution: str) -> dict:
    out = {}
    for item in items or []:
        if "=" not in item:
            raise InputError(f"--tol '{item}': expected PART=TOL, e.g. C1=1%")
        label, tol = (s.strip() for s in item.split("=", 1))
        if label in out:
            raise InputError(f"--tol {label}: given twice; give each part's tolerance once")
        out[label] = _tolerance(tol, f"--tol {label}", distribution)
    return out


#: A Monte Carlo expected to take longer than this (s) gets a note with its expected duration.
LONG_RUN = 600.0
#: A Monte Carlo expected to take longer than this (s), at the pace of its first samples, is
#: stopped with the estimate and the --n that fits.
LONGEST_RUN = 3600.0


def _duration(seconds: float) -> str:
    for unit, size in (("days", 86400), ("hours", 3600), ("minutes", 60)):
        if seconds >= 2 * size:
            return f"{seconds / size:.3g} {unit}"
    return f"{seconds:.3g} s"


@app.command("mc")
def mc_command(
    design_file: Path = typer.Argument(..., metavar="DESIGN", help="Design file (creepcomp size -o)."),
    n: int = typer.Option(100_000, "--n", metavar="N", parser=count_option("--n"),
                          help="Number of Monte Carlo samples, e.g. 100k or 1e7."),
    seed: int = typer.Option(0, "--seed", metavar="S", parser=count_option("--seed", 0),
                             help="Random seed (same seed, same numbers)."),
    res_tol: Optional[str] = typer.Option(None, "--res-tol", metavar="TOL",
                                          help="Resistor tolerance (default: the design's parts "
                                               "block, else 1 %)."),
    cap_tol: Optional[str] = typer.Option(None, "--cap-tol", metavar="TOL",
                                          help="Capacitor tolerance (default: the design's parts "
                                               "block, else 5 % or the dielectric's tightest)."),
    tol: Optional[List[str]] = typer.Option(None, "--tol", metavar="PART=TOL",
                                            help="Tolerance of one part, e.g. C1=1% (repeatable)."),
    distribution: str = typer.Option(api_default(Tolerance, "distribution"), "--dist", metavar="normal|uniform",
                                     help="normal: TOL is 3 sigma; uniform: ±TOL."),
    dielectric: Optional[str] = typer.Option(None, "--dielectric",
                                             metavar="polypropylene|polyester|x7r",
                                             help="Capacitor technology: absorption and leakage "
                                                  "(default: the design's parts block)."),
    temperature: Optional[str] = typer.Option(
        None, "--temperature", metavar="T",
        help="Evaluate at T °C: the sensor (its temperature law), every part (TCs drawn per "
             "part, thermistors) and the capacitors' leakage. Default: the design as it is, "
             "leakage at 25 °C."),
    temperatures: Optional[str] = typer.Option(
        None, "--temperatures", metavar="T1,T2,...",
        help="Evaluate every unit at each temperature (°C), e.g. -10,20,40: yield and "
             "percentiles at each, and over the range (each unit's worst temperature)."),
    temperature_range: Optional[str] = typer.Option(
        None, "--temperature-range", metavar="LOW:HIGH",
        help="As --temperatures, every 5 K from LOW to HIGH °C (both included)."),
    lot_correlation: float = typer.Option(
        0.0, "--lot-correlation", metavar="RHO",
        help="Fraction (0..1) of the variance of the parts' TCs and thermistor B values "
             "common to all parts of a unit (one lot builds one unit)."),
    source_range: Optional[str] = typer.Option(None, "--source-resistance-range", metavar="LOW:HIGH",
                                               help="Sensor output resistance range (uniform)."),
    load_range: Optional[str] = typer.Option(None, "--load-resistance-range", metavar="LOW:HIGH",
                                             help="Next stage's input resistance range (log-uniform)."),
    beta_spread: Optional[str] = typer.Option(None, "--beta-spread", metavar="TOL",
                                              help="Sensor-to-sensor spread of each beta."),
    tau_spread: Optional[str] = typer.Option(None, "--tau-spread", metavar="TOL",
                                             help="Sensor-to-sensor spread of each tau."),
    spec: Optional[str] = typer.Option(None, "--spec", metavar="LIMIT",
                                       help="Specification limit for the yield, e.g. 0.0245% (OIML R60 C3)."),
    metric: str = typer.Option(api_default(analyse, "metric"), "--metric", metavar="peak|final|hysteresis",
                               help="What --spec, the worst case and the sensitivity are about."),
    sweep_period: Optional[str] = typer.Option(None, "--sweep-period", metavar="TIME",
                                               help="Hysteresis sweep period."),
    worst: bool = typer.Option(api_default(analyse, "worst"), "--worst-case/--no-worst-case",
                               help="Search the worst case."),
    sensitivity_n: int = typer.Option(api_default(analyse, "sensitivity_samples"), "--sensitivity-n",
                                      metavar="N",
                                      parser=count_option("--sensitivity-n", 0, 1_000_000),  # one block
                                      help="Samples for the part-alone and tighter-part runs (0: skip)."),
    spot_check: int = typer.Option(20, "--spot-check", metavar="N",
                                   parser=count_option("--spot-check", 0),
                                   help="Run the first N samples through ngspice and compare (0: skip)."),
    creep_test: Optional[str] = typer.Option(None, "--creep-test", metavar="CLASS",
                                             help="Yield against the OIML R 60 creep test, e.g. C3 "
                                                  "(sensor and parts at each --temperature(s), 25 °C without)."),
    report: Optional[Path] = typer.Option(None, "--report", metavar="FILE.html",
                                          help="Write the HTML report."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
) -> None:
    """Tolerance Monte Carlo, worst case and sensitivity of a design's residual creep."""
    check_outputs({"--report": report}, inputs=[design_file])
    design = read_checked_design(design_file)
    if distribution not in ("normal", "uniform"):
        raise InputError(f"--dist '{distribution}': use normal or uniform")
    if dielectric is not None and dielectric.lower() not in DIELECTRICS:
        raise InputError(f"--dielectric '{dielectric}': choose one of {', '.join(DIELECTRICS)}")
    dielectric = dielectric.lower() if dielectric else None
    # the parts the design assumed (its parts block) unless the command line says otherwise
    from creepcomp.analog.parts import plan_of

    plan = plan_of(design, str(design_file))
    if "parts" in design.extra:
        dielectric = dielectric or plan.capacitor
        if res_tol is None:
            res_tol = f"{100 * plan.resistor_tolerance:.6g}%"
        if cap_tol is None:
            cap_tol = f"{100 * plan.capacitor_tolerance:.6g}%"
    res_tol = "1%" if res_tol is None else res_tol
    if cap_tol is None:
        cap = Tolerance(min(DIELECTRICS[dielectric].tolerances) if dielectric else 0.05, distribution)
    else:
        cap = _tolerance(cap_tol, "--cap-tol", distribution)
    over = _over_temperature(design, temperature, temperatures, temperature_range, lot_correlation)
    tspec = ToleranceSpec(
        resistor=_tolerance(res_tol, "--res-tol", distribution), capacitor=cap,
        parts=_part_tolerances(tol, distribution), dielectric=dielectric,
        temperature=over.temperatures[0] if over is not None else 25.0, over_temperature=over,
        source_resistance=_range(source_range, "--source-resistance-range", allow_zero=True),
        load_resistance=_range(load_range, "--load-resistance-range"),
        beta=_tolerance(beta_spread, "--beta-spread", distribution) if beta_spread else None,
        tau=_tolerance(tau_spread, "--tau-spread", distribution) if tau_spread else None,
    )
    limit = quantity(spec, "fraction", "--spec", positive=True)
    test_limits = None
    if creep_test is not None:
        from creepcomp.verify.creep_test import parse_class

        test_limits = parse_class(creep_test, option="--creep-test")
    period = quantity(sweep_period, "second", "--sweep-period", positive=True)
    with Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                  TimeElapsedColumn(), console=err_console, transient=True,
                  disable=as_json or not err_console.is_terminal) as bar:
        tasks = {}
        started = time.perf_counter()

        def progress(stage, done, total):
            if stage not in tasks:
                tasks[stage] = bar.add_task(stage, total=total)
                if stage == "Monte Carlo":
                    tasks["estimate"] = None
            bar.update(tasks[stage], completed=done)
            if stage == "Monte Carlo" and tasks.get("estimate", 0) is None and done and done < total:
                expected = (time.perf_counter() - started) * total / done
                tasks["estimate"] = expected
                if expected > LONGEST_RUN:
                    fits = int(total * LONGEST_RUN / expected)
                    raise InputError(f"--n {total}: about {_duration(expected)} at the pace of the "
                                     f"first {done} samples, more than the {_duration(LONGEST_RUN)} "
                                     f"a run may take; use --n {fits:,} or fewer")
                if expected > LONG_RUN:
                    err_console.print(f"note: --n {total}: about {_duration(expected)} at the pace of "
                                      f"the first {done} samples (Ctrl-C stops it)", markup=False,
                                      soft_wrap=True)

        result = analyse(design, tspec, n, seed, metric, limit, period, worst, sensitivity_n, progress,
                         spot_check_samples=spot_check)
    if test_limits is not None:
        result = _with_creep_test(result, test_limits,
                                  list(over.temperatures) if over is not None else [25.0])
    if report is not None:
        from creepcomp.report.tolerance import tolerance_report_html

        tolerance_report_html(result, report, design_file=design_file)
    if as_json:
        out = result.to_dict()
        if report is not None:
            out["report"] = str(report)
        print_json(out)
        return
    render(result, design_file)
    if report is not None:
        console.print(f"report written to {report}")


def _over_temperature(design, temperature, temperatures, temperature_range, lot_correlation):
    """The temperatures asked for (one of the three options), with the design's parts plan."""
    from creepcomp.analog.parts import plan_of
    from creepcomp.temperature import temperature_grid
    from creepcomp.verify.tolerances import OverTemperature

    given = [o for o, v in (("--temperature", temperature), ("--temperatures", temperatures),
                            ("--temperature-range", temperature_range)) if v is not None]
    if len(given) > 1:
        raise InputError(f"{' and '.join(given)}: give one of them")
    if not 0.0 <= lot_correlation <= 1.0:
        raise InputError(f"--lot-correlation {lot_correlation:g}: must be in [0, 1]")
    if not given:
        if lot_correlation:
            raise InputError("--lot-correlation shares the parts' TCs over temperature: give "
                             "--temperature, --temperatures or --temperature-range")
        return None
    if temperature is not None:
        temps = temperatures_option(temperature, "--temperature")
        if len(temps) != 1:
            raise InputError(f"--temperature '{temperature}': one temperature; use --temperatures "
                             "for several")
    elif temperatures is not None:
        temps = temperatures_option(temperatures, "--temperatures")
    else:
        low, high = temperature_range_option(temperature_range)
        temps = [float(t) for t in temperature_grid(low, high)]
    return OverTemperature(tuple(temps), plan_of(design), lot_correlation)


def _with_creep_test(result: ToleranceReport, limits, temperatures) -> ToleranceReport:
    """The report with the yield of its Monte Carlo's kept samples against the R 60 creep test."""
    from dataclasses import replace

    from creepcomp.verify.creep_test import creep_test_yield

    r = result.result
    figures = creep_test_yield(r.design, r.values, temperatures, limits, r.spec.dielectric)
    return replace(result, creep_test=figures)


def _range(text, option, allow_zero=False):
    if text is None:
        return None
    if allow_zero and text.strip().startswith("0:"):
        return 0.0, quantity(text.split(":", 1)[1], "ohm", option, positive=True)
    return value_range(text, "ohm", option)


def render(report: ToleranceReport, design_file: Path | str | None = None) -> None:
    """Print a tolerance report as tables (``design_file``: the design file it read)."""
    r = report.result
    names = {"peak": "residual creep, peak", "final": "residual creep, final (abs)", "hysteresis": "hysteresis"}
    spec = r.spec
    where = f"{design_file}: " if design_file is not None else ""
    at = (", ".join(f"{t:g}" for t in r.temperatures) if r.temperatures else f"{spec.temperature:g}")
    capacitors = (f"{spec.dielectric} capacitors at {at} °C" if spec.dielectric
                  else "ideal capacitors (no --dielectric)")
    if r.temperatures:
        capacitors += "; sensor and parts at each temperature, figures the worst of each unit"
    console.print(f"[bold]creepcomp mc[/bold]: {where}{r.n:,} samples, seed {r.seed}, {r.seconds:.2f} s "
                  f"({1e6 * r.seconds / r.n:.2f} µs per sample); {capacitors}", markup=True, highlight=False)
    from creepcomp.report.results import distribution_table, sensitivity_table

    console.print(distribution_table(r, report.nominal).to_rich())
    if r.kept < r.n:
        console.print(f"percentiles from a {r.n:,}-sample streaming histogram, within "
                      f"{format_percent(r.resolution('peak'))} (peak); max exact; sensitivity from "
                      f"the first {r.kept:,} samples")
    if report.limit is not None:
        y, se = r.yield_against(report.limit, report.metric)
        console.print(f"yield against {names[report.metric]} ≤ {format_percent(report.limit)}: "
                      f"[bold]{100 * y:.2f} %[/bold] (± {100 * se:.2f} %)")
    if r.temperatures:
        _render_over_temperature(report, names)
    if report.worst is not None:
        w = report.worst
        at = ", ".join(f"{k} = {format_parameter(k, v)}" for k, v in w.at.items())
        console.print(f"worst case of {names[w.metric]}: [bold]{format_percent(w.value)}[/bold] at {at} ({w.method})")
    if report.sensitivities:
        console.print(sensitivity_table(report.sensitivities).to_rich())
        console.print(f"dominant: {report.sensitivities[0].factor}")
    sc = report.spot_check
    if sc is not None and "error" in sc:
        err_console.print(f"note: no ngspice spot-check: {sc['error']}", markup=False)
    elif sc is not None:
        console.print(f"ngspice spot-check: {sc['n']} samples agree with the engine to "
                      f"{format_percent(sc['agreement_max_abs'])} of the step ({1e3 * sc['seconds_per_transient']:.1f} ms "
                      f"per ngspice transient, {1e6 * r.seconds / r.n:.2f} µs per engine sample: "
                      f"{sc['seconds_per_transient'] / (r.seconds / r.n):,.0f}x)")
    if report.creep_test is not None:
        render_creep_test(report.creep_test)
    for t in report.tightenings:
        part = f"{t.factor} at {100 * t.tolerance_to:.3g} %" + (f" {t.dielectric}" if t.dielectric else "")
        console.print(f"{part} (now {100 * t.tolerance_from:.3g} %): p99 from {format_percent(t.p99_from)} to "
                      f"{format_percent(t.p99_to)} ({report.sensitivity_samples} samples each)")


def _render_over_temperature(report: ToleranceReport, names: dict) -> None:
    """The per-temperature table of ``mc --temperatures``."""
    r = report.result
    table = Table(title=f"Over temperature: {names['peak']} (% of FS)", title_justify="left")
    for col in ("temperature", "nominal", "p50", "p95", "p99", "max", "units worst here"):
        table.add_column(col, justify="right")
    if report.limit is not None:
        table.add_column(f"yield, {names[report.metric]} ≤ {format_percent(report.limit)}",
                         justify="right")
    nominal = report.nominal.per_temperature.peak[0]
    for k, t in enumerate(r.temperatures):
        row = [f"{t:g} °C", format_percent(nominal[k]),
               *[format_percent(v) for v in r.percentiles_at(k, "peak").values()],
               f"{100 * r.worst_temperature_counts[k] / r.n:.1f} %"]
        if report.limit is not None:
            y, se = r.yield_at(k, report.limit, report.metric)
            row.append(f"{100 * y:.2f} % (± {100 * se:.2f} %)")
        table.add_row(*row)
    row = ["worst of each unit", format_percent(report.nominal.peak[0]),
           *[format_percent(v) for v in r.percentiles("peak").values()], "100 %"]
    if report.limit is not None:
        y, se = r.yield_against(report.limit, report.metric)
        row.append(f"{100 * y:.2f} % (± {100 * se:.2f} %)")
    table.add_row(*row)
    console.print(table)
    over = r.spec.over_temperature
    console.print(f"every part's TC drawn about its technology's ({over.plan.resistor_tc * 1e6:g} ppm/K "
                  f"resistors, {over.plan.capacitor_tc * 1e6:g} ppm/K capacitors) by as much "
                  f"(3 sigma); lot correlation {over.lot_correlation:g}"
                  + (f"; thermistors {', '.join(over.plan.thermistors)}" if over.plan.thermistors else ""),
                  markup=False)


def render_creep_test(figures: dict) -> None:
    """Print the yield against the OIML R 60 creep test."""
    lim = figures["limits"]
    per = "; ".join(f"{row['temperature']:g} °C: {100 * row['yield']:.2f} % (p99 creep "
                    f"{format_percent(row['p99']['creep_30min'])}, DR {format_percent(row['p99']['dr'])})"
                    for row in figures["temperatures"])
    console.print(f"OIML R 60 creep test {figures['class']} (creep ≤ {format_percent(lim['creep_30min'])}, "
                  f"20-30 min ≤ {format_percent(lim['creep_20_30min'])}, DR ≤ {format_percent(lim['dr'])} "
                  f"of FS) over {figures['n']:,} samples: {per}; passing at every temperature: "
                  f"[bold]{100 * figures['yield']:.2f} %[/bold] (± {100 * figures['yield_standard_error']:.2f} %)")
