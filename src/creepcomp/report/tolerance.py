"""The HTML report of a tolerance analysis (Monte Carlo, worst case, sensitivities)."""

from __future__ import annotations

import html
from pathlib import Path

import matplotlib.pyplot as plt

from creepcomp.io.atomic import write_text_atomic
from creepcomp.report.common import figure_data_uri, format_named, html_page, html_table
from creepcomp.units import format_quantity

__all__ = ["tolerance_report_html", "schematic_section"]


def schematic_section(design) -> str:
    """The design's schematic as inline SVG (thermistors from its ``parts`` block)."""
    from creepcomp.analog.parts import plan_of
    from creepcomp.report.schematic import schematic_svg

    svg = schematic_svg(design.network, plan_of(design))
    return f"<div class='schematic' style='max-width:100%;overflow-x:auto'>{svg}</div>"


def tolerance_report_html(report, path: str | Path, design=None) -> Path:
    """Write the HTML report of a tolerance analysis
    (:class:`creepcomp.verify.tolerance_analysis.ToleranceReport`): histograms with the
    specification, the sensitivity chart, worst case and tighter parts; with ``design``
    (:class:`creepcomp.io.jsonfiles.Design`), its schematic first."""
    r = report.result
    names = {"peak": "peak residual creep", "final": "final residual creep (absolute)",
             "hysteresis": "sweep hysteresis"}
    fig, axes = plt.subplots(1, 3, figsize=(14, 3.8))
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

    pct = lambda x: f"{100 * x:.4g} %"  # noqa: E731
    summary_rows = [[names[m], pct(report.nominal.get(m)[0])] +
                    [pct(v) for v in r.percentiles(m).values()] for m in ("peak", "final", "hysteresis")]
    sections = [("Summary", html_table(["", "nominal", "p50", "p95", "p99", "max"], summary_rows) +
                 f"<p class='note'>{r.n} samples, seed {r.seed}, {r.seconds:.2f} s; hysteresis of a "
                 f"±FS triangular sweep of period {r.sweep_period:.4g} s.</p>")]
    if design is not None:
        sections.insert(0, ("Network", schematic_section(design)))
    if report.limit is not None:
        y, se = r.yield_against(report.limit, report.metric)
        sections.append(("Yield", f"<p>{names[report.metric]} at or below {pct(report.limit)}: "
                                  f"<b>{100 * y:.2f} %</b> of samples (± {100 * se:.2f} %).</p>"))
    sections.append(("Distributions", f"<img alt='histograms' src='{hist}'>"))
    sections.append(("Sensitivity", f"<img alt='sensitivity chart' src='{sens_png}'>" +
                     html_table(["factor", "share of spread", "p99 when only it varies"],
                                [[s.factor, f"{100 * s.share:.1f} %", pct(s.p99_alone)] for s in sens])))
    if report.tightenings:
        sections.append(("What a tighter part buys", html_table(
            ["part", "tolerance", "p99 now", "p99 with it"],
            [[t.factor, f"{100 * t.tolerance_from:.3g} % → {100 * t.tolerance_to:.3g} %"
              + (f" ({t.dielectric})" if t.dielectric else ""),
              pct(t.p99_from), pct(t.p99_to)] for t in report.tightenings])))
    if report.worst is not None:
        w = report.worst
        sections.append(("Worst case over the tolerance box", f"<p>{names[w.metric]}: <b>{pct(w.value)}</b> "
                         f"({w.method})</p>" + html_table(["factor", "value"],
                                                          [[k, format_named(k, v)] for k, v in w.at.items()])))
    if report.spot_check is not None:
        sc = report.spot_check
        if "error" in sc:
            spot = f"<p>No ngspice spot-check: {html.escape(sc['error'])}</p>"
        else:
            per = sc.get("seconds_per_transient")
            spot = html_table(["", ""], [
                ["samples run through ngspice (a load step each)", str(sc["n"])],
                ["largest difference from the engine (of the step)", pct(sc["agreement_max_abs"])],
                ["time, all transients", format_quantity(sc["seconds"], "s")],
                ["time per ngspice transient", format_quantity(per, "s") if per else "–"],
                ["time per engine sample", format_quantity(r.seconds / r.n, "s")]])
        sections.append(("ngspice spot-check", spot))
    factors_rows = [[f.name, format_named(f.name, f.nominal), format_named(f.name, f.low),
                     format_named(f.name, f.high), f.distribution] for f in r.box]
    sections.append(("Tolerance box", html_table(["factor", "nominal", "low", "high", "distribution"], factors_rows)))
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out, html_page("creepcomp tolerance analysis", sections))
    return out
