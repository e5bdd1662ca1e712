"""The HTML report of a tolerance analysis (Monte Carlo, worst case, sensitivities)."""

from __future__ import annotations

import html
from pathlib import Path

import matplotlib.pyplot as plt
from matplotlib.ticker import MaxNLocator

from creepcomp.io.atomic import write_text_atomic
from creepcomp.report.common import figure_data_uri, format_named, html_page, html_table
from creepcomp.report.results import distribution_table, sensitivity_table
from creepcomp.units import format_parameter, format_percent, format_quantity, format_time

__all__ = ["tolerance_report_html", "conditions", "schematic_section", "over_temperature_block"]


def schematic_section(design) -> str:
    """The design's schematic as inline SVG (thermistors from its ``parts`` block)."""
    from creepcomp.analog.parts import plan_of
    from creepcomp.report.schematic import schematic_svg

    svg = schematic_svg(design.network, plan_of(design))
    return f"<div class='schematic' style='max-width:100%;overflow-x:auto'>{svg}</div>"


def _percent(x: float) -> str:
    """A fraction in percent without the sign, for a column whose header says ``%``."""
    return format_percent(x).removesuffix(" %")


def _tolerance(tol) -> str:
    how = "3 sigma, normal" if tol.distribution == "normal" else "uniform"
    return f"±{format_percent(tol.rel)} ({how})"


def conditions(result, design_file: str | Path | None = None) -> list[tuple[str, str]]:
    """What a tolerance analysis assumed, as ``(item, value)`` rows with units: the design
    (its file), the sensor's creep, the parts, the tolerances, the capacitor dielectric and
    the temperature.

    Parameters
    ----------
    result : MonteCarloResult
        The run (its ``design`` and ``spec``).
    design_file : str or Path, optional
        The design file read; None for a design made in Python.
    """
    design, spec = result.design, result.spec
    model = design.model
    terms = ", ".join(f"{format_percent(b)} at {format_time(t)}" for b, t in zip(model.beta, model.tau))
    rows = [("design", str(design_file) if design_file is not None else "made in Python (no file)"),
            ("sensor creep", f"{model.n_terms} term{'s' if model.n_terms > 1 else ''}: {terms}"),
            ("parts", ", ".join(f"{label} {format_parameter(label, value)}"
                                for label, _, value in design.network.parts())),
            ("source resistance", format_quantity(design.network.source_resistance, "Ω")),
            ("load resistance", format_quantity(design.network.load_resistance, "Ω")
             if design.network.load_resistance is not None else "none (open)"),
            ("resistor tolerance", _tolerance(spec.resistor)),
            ("capacitor tolerance", _tolerance(spec.capacitor))]
    rows += [(f"{label} tolerance", _tolerance(tol)) for label, tol in spec.parts.items()]
    temperature = getattr(spec, "temperature", None)
    if spec.dielectric is None:
        rows.append(("capacitor dielectric", "none given: ideal capacitors (no absorption, no leakage)"))
    else:
        rows.append(("capacitor dielectric", f"{spec.dielectric}: absorption and leakage of every cell capacitor"))
    over = getattr(spec, "over_temperature", None)
    if over is not None:
        several = len(over.temperatures) > 1
        rows.append(("temperatures" if several else "temperature",
                     ", ".join(f"{t:g}" for t in over.temperatures) + " °C: sensor, parts (TCs drawn "
                     "per part) and leakage" + (" at each; figures the worst of each unit" if several else "")))
    elif temperature is not None:
        rows.append(("temperature", f"{temperature:g} °C" + (" (capacitor leakage)" if spec.dielectric else
                                                             " (acts through a dielectric's leakage: none given)")))
    rows.append(("hysteresis sweep", f"±FS triangle, period {format_time(result.sweep_period)}"))
    return rows


def tolerance_report_html(report, path: str | Path, design_file: str | Path | None = None) -> Path:
    """Write the HTML report of a tolerance analysis
    (:class:`creepcomp.verify.tolerance_analysis.ToleranceReport`): the design and conditions
    (:func:`conditions`), histograms with the specification, the sensitivity chart, worst case
    and tighter parts, with the design's schematic; ``design_file`` names the design file read."""
    r = report.result
    names = {"peak": "peak residual creep", "final": "final residual creep (absolute)",
             "hysteresis": "sweep hysteresis"}
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2))
    for ax, metric in zip(axes, ("peak", "final", "hysteresis")):
        v = 100 * r.metrics.get(metric)
        ax.hist(v, bins=80, color="#4477aa")
        figures = r.percentiles(metric)
        for q, style in ((50, ":"), (99, "--")):
            ax.axvline(100 * figures[f"p{q}"], color="k", ls=style, lw=1, label=f"p{q}")
        if report.limit is not None and metric == report.metric:
            ax.axvline(100 * report.limit, color="#cc3311", lw=2, label="spec")
        ax.axvline(100 * report.nominal.get(metric)[0], color="#228833", lw=1.5, label="nominal")
        ax.set_xlabel(f"{names[metric]} (% of FS)")
        # few ticks, slanted: percentages of small residuals have long labels
        ax.xaxis.set_major_locator(MaxNLocator(nbins=4))
        ax.tick_params(axis="x", labelrotation=30)
        ax.set_ylabel("samples" if r.kept == r.n else f"samples (first {r.kept:,} of {r.n:,})")
        ax.legend(fontsize=8)
    fig.tight_layout()
    hist = figure_data_uri(fig)

    sens = report.sensitivities
    fig, ax = plt.subplots(figsize=(8, 0.45 * max(len(sens), 2) + 1.2))
    labels = [s.factor for s in sens][::-1]
    ax.barh(labels, [100 * s.share for s in sens][::-1], color="#ee7733")
    ax.set_xlabel(f"share of the spread of the {names[report.metric]} explained alone (%)")
    ax.grid(axis="x", alpha=0.3)
    fig.tight_layout()
    sens_png = figure_data_uri(fig)

    pct = format_percent
    sections = [("Design and conditions", html_table(["item", "value (with its unit)"], conditions(r, design_file))),
                ("Summary", distribution_table(r, report.nominal).to_html() +
                 f"<p class='note'>{r.n:,} samples, seed {r.seed}, {format_quantity(r.seconds, 's')}; "
                 f"hysteresis of a ±FS triangular sweep of period {format_time(r.sweep_period)}.</p>")]
    if getattr(r, "design", None) is not None:
        sections.insert(1, ("Network", schematic_section(r.design)))
    if report.limit is not None:
        y, se = r.yield_against(report.limit, report.metric)
        sections.append(("Yield", f"<p>{names[report.metric]} at or below {pct(report.limit)}: "
                                  f"<b>{100 * y:.2f} %</b> of samples (± {100 * se:.2f} %).</p>"))
    if len(r.temperatures or ()) > 1:     # one temperature is the summary's figures
        sections.append(("Over temperature", over_temperature_block(report)))
    sections.append(("Distributions", f"<img alt='histograms' src='{hist}'>"))
    sections.append(("Sensitivity", f"<img alt='sensitivity chart' src='{sens_png}'>" +
                     sensitivity_table(sens).to_html()))
    if getattr(report, "creep_test", None) is not None:
        sections.append(("OIML R 60 creep test", _creep_test_section(report.creep_test, pct)))
    if report.tightenings:
        sections.append(("What a tighter part buys", html_table(
            ["part", "tolerance (%)", "p99 now (% of FS)", "p99 with it (% of FS)"],
            [[t.factor, f"{100 * t.tolerance_from:.3g} → {100 * t.tolerance_to:.3g}"
              + (f" ({t.dielectric})" if t.dielectric else ""),
              _percent(t.p99_from), _percent(t.p99_to)] for t in report.tightenings])))
    if report.worst is not None:
        w = report.worst
        sections.append(("Worst case over the tolerance box", f"<p>{names[w.metric]}: <b>{pct(w.value)}</b> "
                         f"({w.method})</p>" + html_table(["factor", "value at the worst case (with its unit)"],
                                                          [[k, format_named(k, v)] for k, v in w.at.items()])))
    if report.spot_check is not None:
        sc = report.spot_check
        if "error" in sc:
            spot = ("<p style='overflow-wrap:anywhere;white-space:pre-wrap'>No ngspice "
                    f"spot-check: {html.escape(sc['error'])}</p>")
        else:
            per = sc.get("seconds_per_transient")
            spot = html_table(["quantity", "value (with its unit)"], [
                ["samples run through ngspice (a load step each)", str(sc["n"])],
                ["largest difference from the engine (of the step)", pct(sc["agreement_max_abs"])],
                ["time, all transients", format_quantity(sc["seconds"], "s")],
                ["time per ngspice transient", format_quantity(per, "s") if per else "–"],
                ["time per engine sample", format_quantity(r.seconds / r.n, "s")]])
        sections.append(("ngspice spot-check", spot))
    factors_rows = [[f.name, format_named(f.name, f.nominal), format_named(f.name, f.low),
                     format_named(f.name, f.high), f.distribution] for f in r.box]
    sections.append(("Tolerance box", html_table(["factor", "nominal (with its unit)", "low", "high", "distribution"],
                                                 factors_rows)))
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out, html_page("creepcomp tolerance analysis", sections))
    return out


def over_temperature_block(report) -> str:
    """The report's over-temperature section: the peak residual creep's percentiles at each
    temperature (plot and table, with the yield against the limit) and over the range."""
    r = report.result
    temps = list(r.temperatures)
    rows = [r.percentiles_at(k, "peak") for k in range(len(temps))]
    nominal = report.nominal.per_temperature.peak[0]
    fig, ax = plt.subplots(figsize=(8, 3.6))
    ax.fill_between(temps, [100 * p["p50"] for p in rows], [100 * p["p99"] for p in rows],
                    color="#4477aa", alpha=0.25, label="p50 to p99")
    ax.plot(temps, [100 * p["max"] for p in rows], "k:", lw=1, label="max")
    ax.plot(temps, 100 * nominal, "o-", color="#228833", label="nominal")
    if report.limit is not None and report.metric == "peak":
        ax.axhline(100 * report.limit, color="#cc3311", lw=2, label="spec")
    ax.set_xlabel("temperature (°C)")
    ax.set_ylabel("peak residual creep (% of FS)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    png = figure_data_uri(fig)
    pct = lambda x: f"{100 * x:.4g} %"  # noqa: E731
    header = ["temperature", "nominal", "p50", "p95", "p99", "max", "units worst here"]
    if report.limit is not None:
        header.append(f"yield, {report.metric} ≤ {pct(report.limit)}")
    table = []
    for k, t in enumerate(temps):
        row = [f"{t:g} °C", pct(nominal[k])] + [pct(v) for v in rows[k].values()] + [
            f"{100 * r.worst_temperature_counts[k] / r.n:.1f} %"]
        if report.limit is not None:
            y, se = r.yield_at(k, report.limit, report.metric)
            row.append(f"{100 * y:.2f} % (± {100 * se:.2f} %)")
        table.append(row)
    row = ["worst of each unit", pct(report.nominal.peak[0])] + [
        pct(v) for v in r.percentiles("peak").values()] + ["100 %"]
    if report.limit is not None:
        y, se = r.yield_against(report.limit, report.metric)
        row.append(f"{100 * y:.2f} % (± {100 * se:.2f} %)")
    table.append(row)
    over = r.spec.over_temperature
    note = (f"<p class='note'>Each unit's parts drawn once at 25 °C; each part's temperature "
            f"coefficient drawn about its technology's ({over.plan.resistor_tc * 1e6:g} ppm/K "
            f"resistors, {over.plan.capacitor_tc * 1e6:g} ppm/K capacitors) by as much (3 sigma)"
            + (f"; thermistors {html.escape(', '.join(over.plan.thermistors))} with their R25 and "
               "B tolerances" if over.plan.thermistors else "")
            + f"; lot correlation {over.lot_correlation:g}. The sensor follows its temperature "
            "law, the capacitors' leakage their insulation resistance at each temperature.</p>")
    return f"<img alt='residual creep over temperature' src='{png}'>" + html_table(header, table) + note

def _creep_test_section(figures: dict, pct) -> str:
    """The yield against the OIML R 60 creep test: limits with their derivation, per temperature."""
    lim = figures["limits"]
    rows = [[f"{row['temperature']:g} °C", f"{100 * row['yield']:.2f} %", pct(row["p99"]["creep_30min"]),
             pct(row["p99"]["creep_20_30min"]), pct(row["p99"]["dr"])] for row in figures["temperatures"]]
    rows.append(["limit", "", pct(lim["creep_30min"]), pct(lim["creep_20_30min"]), pct(lim["dr"])])
    derivation = "".join(f"<li>{html.escape(k)}: {html.escape(v)}</li>" for k, v in lim["derivation"].items())
    return (f"<p>Class {html.escape(figures['class'])}: units passing at every temperature: "
            f"<b>{100 * figures['yield']:.2f} %</b> of {figures['n']:,} "
            f"(± {100 * figures['yield_standard_error']:.2f} %).</p>"
            + html_table(["temperature", "yield", "creep 30 min, p99", "creep 20-30 min, p99", "DR, p99"], rows)
            + f"<ul class='note'>{derivation}</ul>")
