"""The lot report of a fleet run (HTML, plots embedded): how the fitted parameters spread,
outliers, how often each effect is found, units out of spec, and the units to look at first.

It renders the summary :func:`creepcomp.fleet.lot.lot_summary` computes; nothing here is a
computation of its own beyond drawing.
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib.pyplot as plt
from matplotlib.ticker import MaxNLocator
import numpy as np

from creepcomp.io.atomic import write_text_atomic
from creepcomp.report.common import figure_data_uri, render_template
from creepcomp.units import format_percent, format_time

__all__ = ["value_text", "parameter_figure", "effect_figure", "lot_report_html", "write_lot_report"]


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


def value_text(value, unit: str, record_units: dict | None = None) -> str:
    """A parameter's value with its unit (``PARAMETERS``' units): ``s`` as a time, ``FS`` as
    percent of full scale, a fraction as percent, ``signal`` and ``signal/load`` in the
    records' own units when the lot shares them (else "signal units", "load unit");
    ``–`` for a missing value."""
    if value is None or not math.isfinite(value):
        return "–"
    if unit == "s":
        return format_time(value)
    if unit == "FS":
        return f"{format_percent(value)} of full scale"
    if unit in ("", "fraction"):
        return format_percent(value)
    record_units = record_units or {}
    su = record_units.get("signal") or "signal units"
    if unit == "signal/load":
        return f"{value:.4g} {su}/{record_units.get('load') or 'load unit'}"
    if unit == "signal":
        return f"{value:.4g} {su}"
    return f"{value:.4g} {unit}".strip()


def _unit_row(r: dict) -> list:
    return [r["unit"], r.get("cause") or "–", r.get("findings") or "–",
            format_percent(r.get("residual_creep")), format_percent(r.get("creep_step")),
            format_percent(r.get("beta0")), r["file"]]


def lot_report_html(summary: dict, meta: dict) -> str:
    """The lot report page (``templates/fleet.html.j2``, every text escaped).

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
    effects = summary["effects"]
    parameters = summary["parameters"]
    record_units = summary.get("record_units")
    return render_template(
        "fleet.html.j2", title="creepcomp fleet: lot report",
        overview=[summary["n"], ok, len(summary["failed"]), n_in, len(summary["out_of_spec"]),
                  len(summary["not_judged"]), format_percent(spec)],
        table_path=str(meta.get("table")), workers=meta.get("workers"), scheduler=str(meta.get("scheduler")),
        look_first=[[u["unit"], "; ".join(u["reasons"]), u["row"]["file"]] for u in summary["look_first"]],
        effects=[[k, v, format_percent(v / max(ok, 1))] for k, v in effects.items()],
        effects_png=figure_data_uri(effect_figure(effects, ok)) if effects else "",
        parameters=[[k] + [value_text(p[q], p["unit"], record_units) for q in ("median", "p5", "p95")]
                    + [len(p["values"])] for k, p in parameters.items()],
        parameters_png=figure_data_uri(parameter_figure(parameters, spec)) if parameters else "",
        z_limit=f"{summary['z_limit']:g}",
        outliers=[[o["unit"], o["parameter"], value_text(o["value"], o["unit_of_value"], record_units),
                   f"{o['z']:+.1f}"]
                  for o in summary["outliers"]],
        units_header=["unit", "cause", "findings", "residual creep", "creep uncorrected", "beta0", "file"],
        out_of_spec=[_unit_row(r) for r in summary["out_of_spec"]],
        not_judged=[_unit_row(r) + [r.get("notes") or "–"] for r in summary["not_judged"]],
        failed=[[r["unit"], r.get("error"), r["file"]] for r in summary["failed"]])


def write_lot_report(summary: dict, path: str | Path, meta: dict) -> Path:
    """Write the lot report (:func:`lot_report_html`) to ``path`` atomically; returns the path."""
    return write_text_atomic(path, lot_report_html(summary, meta))
