"""The lot report of a fleet run (HTML, plots embedded): how the fitted parameters spread,
outliers, how often each effect is found, units out of spec, and the units to look at first.

It renders the summary :func:`creepcomp.fleet.lot.lot_summary` computes; nothing here is a
computation of its own beyond drawing.
"""

from __future__ import annotations

import html
import math
from pathlib import Path

import matplotlib.pyplot as plt
from matplotlib.ticker import MaxNLocator
import numpy as np

from creepcomp.io.atomic import write_text_atomic
from creepcomp.report.common import figure_data_uri, format_cell, html_page, html_table
from creepcomp.units import format_percent

__all__ = ["parameter_figure", "effect_figure", "lot_report_html", "write_lot_report"]


def _label(name: str, unit: str) -> str:
    if unit == "FS":
        return f"{name} (% of full scale)"
    return f"{name} ({unit})" if unit and unit not in ("signal", "signal/load") else name


def parameter_figure(parameters: dict, spec: float | None = None):
    """Histograms of the fitted parameters across the lot (log axes where marked), with the
    median, the 5th and 95th percentiles, and ``spec`` on the residual creep."""
    items = list(parameters.items())
    cols = 3
    rows = max(1, math.ceil(len(items) / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(13, 3.3 * rows), squeeze=False)
    for ax in axes.ravel()[len(items):]:
        ax.set_visible(False)
    for ax, (name, p) in zip(axes.ravel(), items):
        scale = 100.0 if p["unit"] == "FS" else 1.0
        v = np.asarray(p["values"]) * scale
        floor = None
        if p["key"] == "residual_creep" and spec is not None:
            # corrected creep spans decades down to rounding: log axis, tiny values at a floor
            floor = spec * scale * 1e-3
            v = np.maximum(v, floor)
        if p["log"] or floor is not None:
            lo, hi = v.min(), v.max()
            bins = np.geomspace(lo, hi * 1.0001, 31) if hi > lo else 30
            ax.set_xscale("log")
        else:
            bins = 30
        ax.hist(v, bins=bins, color="#4477aa")
        ax.axvline(p["median"] * scale, color="k", lw=1.2, label="median")
        for q in ("p5", "p95"):
            ax.axvline(p[q] * scale, color="k", ls=":", lw=1)
        if spec is not None and p["key"] == "residual_creep":
            ax.axvline(spec * 100.0, color="#cc3311", lw=2, label="spec")
        ax.set_xlabel(_label(name, p["unit"]) + ("\n(below spec/1000 drawn at spec/1000)" if floor else ""))
        ax.set_ylabel("units")
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))
        ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def effect_figure(effects: dict, n_ok: int):
    """Bar chart: share of the processed units in which each effect is found."""
    names = list(effects)[::-1]
    fig, ax = plt.subplots(figsize=(8, 0.42 * max(len(names), 2) + 1.2))
    ax.barh(names, [100.0 * effects[n] / max(n_ok, 1) for n in names], color="#ee7733")
    ax.set_xlabel("share of the processed units (%)")
    ax.grid(axis="x", alpha=0.3)
    fig.tight_layout()
    return fig


def _units_table(rows: list[dict], extra: list[tuple[str, callable]] | None = None) -> str:
    header = ["unit", "cause", "findings", "residual creep", "creep uncorrected", "beta0", "file"]
    body = []
    for r in rows:
        body.append([r["unit"], r.get("cause") or "–", r.get("findings") or "–",
                     format_percent(r.get("residual_creep")), format_percent(r.get("creep_step")),
                     format_percent(r.get("beta0")), r["file"]] +
                    [f(r) for _, f in (extra or [])])
    return html_table(header + [h for h, _ in (extra or [])], body)


def lot_report_html(summary: dict, meta: dict) -> str:
    """The lot report page.

    Parameters
    ----------
    summary : dict
        From :func:`creepcomp.fleet.lot.lot_summary`.
    meta : dict
        ``spec`` (fraction of full scale), ``records``, ``workers``, ``scheduler``, ``table``.
    """
    spec = meta.get("spec")
    ok = summary["ok"]
    n_in = ok - len(summary["out_of_spec"]) - len(summary["not_judged"])
    overview = html_table(
        ["records", "processed", "failed", "in spec", "out of spec", "not judged", "spec"],
        [[summary["n"], ok, len(summary["failed"]), n_in, len(summary["out_of_spec"]),
          len(summary["not_judged"]), format_percent(spec)]])
    overview += (
        "<p class='note'>Residual creep: a load step to the record's largest load, held for the "
        "record's length, is simulated with the unit's extended model (the diagnosis: fitted "
        "creep plus the effects found) and corrected digitally (subtractive) with the unit's "
        "fitted model; the largest change of the corrected indication after the step, as a "
        "fraction of the step's instantaneous output, is compared with the spec. A unit is not "
        "judged when its diagnosis leaves structure unexplained (the model predicting its step "
        "is then known to be incomplete) or the step could not be simulated. It is a prediction "
        f"from fitted models, not a measured step. Results table: {html.escape(str(meta.get('table')))}; "
        f"{meta.get('workers')} worker(s), scheduler {html.escape(str(meta.get('scheduler')))}.</p>")
    sections = [("Lot", overview)]
    if summary["look_first"]:
        sections.append(("Units to look at first", html_table(
            ["unit", "why", "file"],
            [[u["unit"], "; ".join(u["reasons"]), u["row"]["file"]] for u in summary["look_first"]])))
    if summary["effects"]:
        sections.append(("How often each effect is found",
                         f"<img alt='effects' src='{figure_data_uri(effect_figure(summary['effects'], ok))}'>" +
                         html_table(["effect", "units", "share"],
                                    [[k, v, format_percent(v / max(ok, 1))] for k, v in summary["effects"].items()]) +
                         "<p class='note'>A unit may show several effects; <i>none</i>: no effect "
                         "supported by the evidence.</p>"))
    if summary["parameters"]:
        fig = parameter_figure(summary["parameters"], spec)
        sections.append(("Fitted parameters across the lot",
                         f"<img alt='parameter distributions' src='{figure_data_uri(fig)}'>" +
                         html_table(["parameter", "median", "5th percentile", "95th percentile", "units"],
                                    [[k, format_cell(p["median"]), format_cell(p["p5"]),
                                      format_cell(p["p95"]), len(p["values"])]
                                     for k, p in summary["parameters"].items()]) +
                         "<p class='note'>gain in signal units per load unit, offset in signal "
                         "units, beta0 and creep as fractions, tau in seconds. Lines: median, "
                         "5th and 95th percentiles; red: the spec.</p>"))
    outliers = summary["outliers"]
    sections.append((f"Outliers (robust z-score above {summary['z_limit']:g})",
                     (html_table(["unit", "parameter", "value", "z"],
                                 [[o["unit"], o["parameter"], format_cell(o["value"]), f"{o['z']:+.1f}"]
                                  for o in outliers]) if outliers else "<p>none</p>") +
                     "<p class='note'>z = 0.6745 (x - median) / MAD over the processed units, "
                     "for gain, offset, beta0 and tau (tau on a log scale); at least 5 units "
                     "with a value needed. The creep figures are judged against the spec.</p>"))
    sections.append(("Units out of spec", _units_table(summary["out_of_spec"])
                     if summary["out_of_spec"] else "<p>none</p>"))
    if summary["not_judged"]:
        sections.append(("Units not judged against the spec",
                         _units_table(summary["not_judged"], [("why", lambda r: r.get("notes") or "–")])))
    if summary["failed"]:
        sections.append(("Failed units", html_table(["unit", "reason", "file"],
                                                    [[r["unit"], r.get("error"), r["file"]]
                                                     for r in summary["failed"]])))
    return html_page("creepcomp fleet: lot report", sections)


def write_lot_report(summary: dict, path: str | Path, meta: dict) -> Path:
    """Write the lot report (:func:`lot_report_html`) to ``path`` atomically; returns the path."""
    return write_text_atomic(path, lot_report_html(summary, meta))
