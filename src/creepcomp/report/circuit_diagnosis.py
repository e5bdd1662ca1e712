"""The circuit side of the diagnose report: plots and an HTML section (PNGs embedded)."""

from __future__ import annotations

import html

import matplotlib.pyplot as plt
import numpy as np

from creepcomp.report.common import format_cell, format_named, png_base64, thin
from creepcomp.diagnose.circuit import fault_prior
from creepcomp.fit.noise import MISFIT_LIMIT, autocorrelation
from creepcomp.units import format_quantity

__all__ = ["UNITS", "quantity", "elements", "circuit_figures", "circuit_html"]

#: Units of the circuit effects' parameters.
UNITS = {"C": "F", "R": "Ω", "tau": "s", "fraction": ""}


def quantity(name: str, value) -> str:
    """A circuit parameter with its unit (``fraction`` in %)."""
    if value is None or not np.isfinite(value):
        return "–"
    if name == "fraction":
        return f"{100 * value:.3g} %"
    return format_quantity(value, UNITS.get(name, ""))


def elements(network) -> dict:
    """Every element of a network by name, with its value (ohm or farad; None: absent),
    including the capacitors' leakage and absorption and the source and load resistances."""
    out = {label: (kind, v) for label, kind, v in network.parts()}
    for k, c in enumerate(network.cells):
        label = network.cell_label("C", k)
        out[f"{label} leakage"] = ("R", c.leakage)
        out[f"{label} absorption R"] = ("R", c.absorption_R)
        out[f"{label} absorption C"] = ("C", c.absorption_C)
    out["source resistance"] = ("R", network.source_resistance or None)
    out["load resistance"] = ("R", network.load_resistance)
    return out


def circuit_figures(cd, units: dict) -> list[tuple[str, str]]:
    """(title, base64 PNG): measured ``corrected`` against the nominal and as-built network,
    their residuals, the residual against the signal and its autocorrelation."""
    data, base, ext = cd.data, cd.baseline, cd.extended
    su = units.get("signal", "")
    ylab = f"corrected ({su})" if su else "corrected"
    idx = thin(data.n)
    t = data.time[idx] - data.time[0]
    xlabel = f"time since the first sample (s); first sample at {data.time[0]:g} s"
    figs = []
    fig, (ax, axr) = plt.subplots(2, 1, figsize=(11, 7), sharex=True, gridspec_kw={"height_ratios": [2, 1]})
    ax.plot(t, data.corrected[idx], ".", ms=2, color="0.5", label="measured corrected")
    ax.plot(t, (data.corrected - base.residual)[idx], "-", lw=1.0, color="C3", label="nominal network (simulated)")
    if ext is not base:
        ax.plot(t, (data.corrected - ext.residual)[idx], "-", lw=1.0, color="C0",
                label=f"as built ({ext.describe()})")
    ax.set_ylabel(ylab)
    ax.legend(fontsize=8)
    axr.plot(t, base.residual[idx], ".", ms=2, color="C3", label=f"nominal, RMS {base.rms:.3g} {su}")
    if ext is not base:
        axr.plot(t, ext.residual[idx], ".", ms=2, color="C0", label=f"as built, RMS {ext.rms:.3g} {su}")
    if cd.drift is not None and cd.drift.curve is not None:
        axr.plot(t, cd.drift.curve[idx], "-", lw=1.5, color="k",
                 label=f"output channel's drift (in the noise floor), RMS {cd.drift.rms:.3g} {su}")
    axr.axhline(0, color="0.3", lw=0.8)
    axr.set_ylabel(f"measured - simulated ({su})" if su else "measured - simulated")
    axr.set_xlabel(xlabel)
    axr.legend(fontsize=8)
    for a in (ax, axr):
        a.grid(True, alpha=0.3)
    fig.tight_layout()
    figs.append(("Circuit side: measured corrected against the network driven by the measured signal",
                 png_base64(fig, dpi=90)))
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4))
    a1.plot(data.signal[idx], base.residual[idx], ".", ms=2, color="C3", label="nominal")
    if ext is not base:
        a1.plot(data.signal[idx], ext.residual[idx], ".", ms=2, color="C0", label="as built")
    a1.set_xlabel(f"signal ({su})" if su else "signal")
    a1.set_ylabel(f"measured - simulated ({su})" if su else "measured - simulated")
    a1.legend(fontsize=8)
    lags = min(200, data.n // 4)
    a2.plot(autocorrelation(base.residual, lags), color="C3", label="nominal")
    if ext is not base:
        a2.plot(autocorrelation(ext.residual, lags), color="C0", label="as built")
    a2.axhline(0, color="0.3", lw=0.8)
    a2.set_xlabel("lag (samples)")
    a2.set_ylabel("residual autocorrelation")
    a2.legend(fontsize=8)
    for a in (a1, a2):
        a.grid(True, alpha=0.3)
    fig.tight_layout()
    figs.append(("Circuit side: residual against the signal, and its autocorrelation", png_base64(fig, dpi=90)))
    return figs


def _prior_table() -> str:
    """The circuit faults' prior (:func:`~creepcomp.diagnose.circuit.fault_prior`, from the
    effects' modules) as an HTML table."""
    rows = "".join(f"<tr><td>{html.escape(e)}</td><td>{100 * p['rate']:.3g} %</td><td>{html.escape(p['plausible'])}</td>"
                   f"<td>{html.escape(p['why'])}</td></tr>" for e, p in fault_prior().items())
    return ("<table><tr><th>fault</th><th>share of built networks (assumed)</th><th>plausible values</th>"
            "<th>why</th></tr>" + rows + "</table>")


def _element(kind: str, value) -> str:
    return "none" if value is None else format_quantity(value, "F" if kind == "C" else "Ω")


def circuit_html(cd, units: dict) -> str:
    """The circuit side's HTML section."""
    su = units.get("signal", "")
    out = cd.to_dict()
    rows, alt_rows = [], []
    for f in cd.findings:
        for a in f.alternatives:
            ap = ", ".join(f"{k} = {quantity(k, v)}" for k, v in a["parameters"].items())
            alt_rows.append(f"<tr><td>{html.escape(f.effect)} {html.escape(f.part or '')}</td>"
                            f"<td>{html.escape(a['effect'])} {html.escape(a['part'] or '')}</td><td>{ap}</td>"
                            f"<td>{format_cell(a['delta_bic'])}</td><td>{html.escape(a['measurement'])}</td></tr>")
        params = ", ".join(f"{k} = {quantity(k, v)} ± {quantity(k, f.uncertainty.get(k))}"
                           if k in UNITS else f"{k} = {format_named(k, v)}" for k, v in f.parameters.items())
        rows.append(f"<tr><td><b>{html.escape(f.effect)}</b></td><td>{html.escape(f.part or '–')}</td>"
                    f"<td>{params}{('<br/>' + html.escape(f.note)) if f.note else ''}</td><td>{format_cell(f.evidence.delta_bic)}</td>"
                    f"<td>{format_cell(f.evidence.heldout_rms_ratio)}</td><td>{format_cell(f.evidence.heldout_z)}</td></tr>")
    findings = ("<table><tr><th>effect</th><th>part</th><th>parameters (± 1 sigma)</th><th>ΔBIC</th>"
                "<th>held-out RMS ratio</th><th>held-out z</th></tr>" + "".join(rows) + "</table>"
                if rows else "<p>No circuit effect is supported: no candidate predicts held-out data better than "
                "the nominal network (that alone does not show the residual is noise).</p>")
    alternatives = ("<h3>Explanations the record cannot tell apart</h3><table><tr><th>named</th><th>fits as well"
                    "</th><th>its parameters</th><th>ΔBIC against the named</th><th>measurement that separates them"
                    "</th></tr>" + "".join(alt_rows) + "</table><p>The named one is the more probable under the "
                    "prior of the faults below.</p>" + _prior_table()) if alt_rows else ""
    floor = cd.floor
    misfit = (f"<p><b>{html.escape(cd.verdict())}</b>.</p><p>Noise floor {format_cell(floor.rms)} {html.escape(su)} "
              f"({html.escape(floor.method)}); misfit ratio (residual RMS / floor): nominal "
              f"{format_cell(cd.misfit(cd.baseline))}, as built {format_cell(cd.misfit(cd.extended))}; explained share "
              f"{format_cell(cd.explained_share)}. 'none' needs a misfit ratio of the nominal network up to "
              f"{MISFIT_LIMIT:g}.</p>") if floor is not None else ""
    design, built = elements(cd.baseline.network), elements(cd.extended.network)
    parts = "".join(f"<tr><td>{label}</td><td>{_element(*design[label])}</td><td>{_element(*built[label])}</td></tr>"
                    for label in design if design[label][1] is not None or built[label][1] is not None)
    rc = cd.residual_creep
    fixes = "".join(f"<tr><td>{html.escape(f.part)}</td><td>{format_quantity(f.value_from, 'F' if f.part.startswith('C') else 'Ω')}</td>"
                    f"<td>{format_quantity(f.value_to, 'F' if f.part.startswith('C') else 'Ω')} ({f.series})</td>"
                    f"<td>{100 * f.residual_creep_peak:.4f} %</td><td>{html.escape(f.note)}</td></tr>"
                    for f in cd.fixes)
    fix_table = ("<table><tr><th>part</th><th>as built</th><th>replace by</th><th>peak residual creep</th>"
                 "<th>note</th></tr>" + fixes + "</table>") if fixes else "<p>No single-part change is needed.</p>"
    tried = "".join(f"<tr><td>{t.step}</td><td>{html.escape(t.effect)}</td><td>{html.escape(t.part or '–')}</td>"
                    f"<td>{format_cell(t.evidence.delta_bic)}</td><td>{format_cell(t.evidence.heldout_rms_ratio)}</td>"
                    f"<td>{format_cell(t.evidence.heldout_z)}</td><td>{html.escape(t.outcome)}</td></tr>"
                    for t in cd.trials)
    check = out["spice_check"]
    if check is None:
        spice = "<p>ngspice check not run.</p>"
    elif "error" in check:
        spice = f"<p>ngspice check not available: {html.escape(check['error'])}</p>"
    else:
        spice = (f"<p>The as-built network in ngspice, driven by the measured signal: RMS difference from the "
                 f"measured corrected {format_cell(check['rms_ngspice_vs_measured'])} {html.escape(su)}, against the "
                 f"fit's residual RMS {format_cell(check['residual_rms_of_the_fit'])} {html.escape(su)} "
                 f"(ratio {format_cell(check['ratio'])}; 1 means: to the noise).</p>")
    g = out["gain"]
    figs = "".join(f"<h3>{html.escape(title)}</h3><img src='data:image/png;base64,{png}'/>"
                   for title, png in circuit_figures(cd, units))
    return f"""<h2>Circuit side: cause {html.escape(cd.cause)}</h2>
{misfit}
{findings}
{alternatives}
<p>Nominal network driven by the measured signal: residual RMS {format_cell(cd.baseline.rms)} {html.escape(su)}
(held out {format_cell(cd.baseline.heldout.rms if cd.baseline.heldout else None)}); as built:
{format_cell(cd.extended.rms)} {html.escape(su)} (held out {format_cell(cd.extended.heldout.rms if cd.extended.heldout else None)}).
Gain: held-out RMS ratio {format_cell(g['heldout_rms_ratio'])}, output error ratio {format_cell(g['correction_error_ratio'])}.</p>
<h3>As-built network</h3>
<table><tr><th>part</th><th>design</th><th>as built</th></tr>{parts}</table>
<p>Peak residual creep of a load step: design {100 * rc['nominal']:.4f} %, as built {100 * rc['as_built']:.4f} %.</p>
<h3>Fix</h3>
{fix_table}
{spice}
{figs}
<h3>Circuit candidates tried</h3>
<table><tr><th>step</th><th>effect</th><th>part</th><th>ΔBIC</th><th>held-out RMS ratio</th><th>held-out z</th>
<th>outcome</th></tr>{tried}</table>
"""
