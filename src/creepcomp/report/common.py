"""Plots and reports (matplotlib, no screen needed)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from creepcomp.model import CreepModel  # noqa: E402
from creepcomp.network import Network  # noqa: E402
from creepcomp.analog.quality import step_residual, sweep_hysteresis  # noqa: E402


def plot_design_comparison(model: CreepModel, designs: dict[str, Network | None],
                           path: str | Path, sweep_period: float | None = None) -> Path:
    """Residual creep after a load step, and the sweep hysteresis loop, of several designs.

    Parameters
    ----------
    model : CreepModel
        The sensor's creep.
    designs : dict
        Label to network (None for the uncorrected sensor).
    path : str or Path
        PNG file to write.
    sweep_period : float, optional
        Period of the triangular sweep (s).

    Returns
    -------
    Path
    """
    fig, (ax_step, ax_loop) = plt.subplots(1, 2, figsize=(12, 4.8))
    for label, net in designs.items():
        t, e, _ = step_residual(model, net)
        ax_step.plot(t, 100 * e, label=label)
        _, load, up, down = sweep_hysteresis(model, net, sweep_period)
        (line,) = ax_loop.plot(load, 100 * (up - load), label=label)
        ax_loop.plot(load, 100 * (down - load), color=line.get_color())
    ax_step.set_xscale("symlog", linthresh=max(min(model.tau) / 10, 1e-3))
    ax_step.set_xlabel("time after a load step (s)")
    ax_step.set_ylabel("residual creep (% of step)")
    ax_step.set_title("Load step")
    ax_step.axhline(0, color="0.6", lw=0.8)
    ax_step.legend(fontsize=8)
    ax_loop.set_xlabel("load (fraction of full scale)")
    ax_loop.set_ylabel("output - ideal output (% of FS)")
    ax_loop.set_title("Triangular sweep ±FS, up and down branches")
    ax_loop.axhline(0, color="0.6", lw=0.8)
    for ax in (ax_step, ax_loop):
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    return save_figure(fig, path)


def finite_or_none(x: float) -> float | None:
    """A float for JSON, None when not finite."""
    return float(x) if np.isfinite(x) else None


def save_figure(fig, path, dpi: int = 110) -> Path:
    """Save a matplotlib figure to ``path`` (folders made as needed) and close it."""
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=dpi)
    plt.close(fig)
    return out


def png_base64(fig, dpi: int = 100) -> str:
    """A matplotlib figure as base64 PNG text (the figure is closed)."""
    import base64
    import io

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    plt.close(fig)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def figure_data_uri(fig) -> str:
    """A matplotlib figure as an inline PNG ``data:`` URI (the figure is closed)."""
    return "data:image/png;base64," + png_base64(fig)


def html_page(title: str, sections: list[tuple[str, str]]) -> str:
    """A self-contained HTML page: a title and ``(heading, html)`` sections."""
    import html

    body = "\n".join(f"<section><h2>{html.escape(h)}</h2>\n{content}\n</section>" for h, content in sections)
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>
body {{ font-family: system-ui, sans-serif; max-width: 1100px; margin: 2em auto; color: #222; }}
table {{ border-collapse: collapse; margin: 0.5em 0; }}
td, th {{ border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: right; }}
th {{ background: #f3f3f3; }} td:first-child, th:first-child {{ text-align: left; }}
img {{ max-width: 100%; }} .note {{ color: #555; font-size: 0.9em; }}
</style></head><body>
<h1>{html.escape(title)}</h1>
{body}
</body></html>
"""


def html_table(header: list[str], rows: list[list]) -> str:
    """An HTML table from a header and rows of already formatted cells."""
    import html

    head = "".join(f"<th>{html.escape(str(h))}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in row) + "</tr>"
                   for row in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def tolerance_report_html(report, path: str | Path) -> Path:
    """Write the HTML report of a tolerance analysis (:class:`montecarlo.ToleranceReport`):
    histograms with the specification, the sensitivity chart, worst case and tighter parts."""
    r = report.result
    names = {"peak": "peak residual creep", "final": "final residual creep (absolute)",
             "hysteresis": "sweep hysteresis"}
    fig, axes = plt.subplots(1, 3, figsize=(14, 3.8))
    for ax, metric in zip(axes, ("peak", "final", "hysteresis")):
        v = 100 * r.metrics.get(metric)
        ax.hist(v, bins=80, color="#4477aa")
        for q, style in ((50, ":"), (99, "--")):
            ax.axvline(np.percentile(v, q), color="k", ls=style, lw=1, label=f"p{q}")
        if report.limit is not None and metric == report.metric:
            ax.axvline(100 * report.limit, color="#cc3311", lw=2, label="spec")
        ax.axvline(100 * report.nominal.get(metric)[0], color="#228833", lw=1.5, label="nominal")
        ax.set_xlabel(f"{names[metric]} (% of FS)")
        ax.set_ylabel("samples")
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
    if report.limit is not None:
        y, se = r.yield_against(report.limit, report.metric)
        sections.append(("Yield", f"<p>{names[report.metric]} at or below {pct(report.limit)}: "
                                  f"<b>{100 * y:.2f} %</b> of samples (± {100 * se:.2f} %).</p>"))
    sections.append(("Distributions", f"<img alt='histograms' src='{hist}'>"))
    sections.append(("Sensitivity", f"<img alt='sensitivity chart' src='{sens_png}'>" +
                     html_table(["factor", "share of spread", f"p99 when only it varies"],
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
                                                          [[k, f"{v:.5g}"] for k, v in w.at.items()])))
    if report.spot_check is not None:
        sc = report.spot_check
        sections.append(("ngspice spot-check", "<p>" + ", ".join(f"{k}: {v}" for k, v in sc.items()) + "</p>"))
    factors_rows = [[f.name, f"{f.nominal:.5g}", f"{f.low:.5g}", f"{f.high:.5g}", f.distribution] for f in r.box]
    sections.append(("Tolerance box", html_table(["factor", "nominal", "low", "high", "distribution"], factors_rows)))
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(html_page("creepcomp tolerance analysis", sections), encoding="utf-8")
    return out
