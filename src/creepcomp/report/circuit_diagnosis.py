"""The circuit side of the diagnose report: plots and an HTML section (PNGs embedded)."""

from __future__ import annotations

from markupsafe import Markup
import matplotlib.pyplot as plt
import numpy as np

from creepcomp.report.common import named_text, plot_text, png_base64, render_template, thin
from creepcomp.diagnose.circuit import fault_prior
from creepcomp.fit.noise import MISFIT_LIMIT, autocorrelation
from creepcomp.units import format_quantity

__all__ = ["UNITS", "quantity", "elements", "element_text", "circuit_figures", "circuit_html"]

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
    su = plot_text(units.get("signal", ""))
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


def element_text(kind: str, value) -> str:
    """An element's value in F or Ω, ``none`` when the network lacks it."""
    return "none" if value is None else format_quantity(value, "F" if kind == "C" else "Ω")


def circuit_html(cd, units: dict) -> Markup:
    """The circuit side's HTML section (``templates/circuit_diagnosis.html.j2``, every text
    escaped)."""
    su = units.get("signal", "")
    out = cd.to_dict()
    findings, alternatives = [], []
    for f in cd.findings:
        for a in f.alternatives:
            alternatives.append({
                "named": f"{f.effect} {f.part or ''}", "alternative": f"{a['effect']} {a['part'] or ''}",
                "parameters": ", ".join(f"{k} = {quantity(k, v)}" for k, v in a["parameters"].items()),
                "delta_bic": a["delta_bic"], "measurement": a["measurement"]})
        params = ", ".join(f"{k} = {quantity(k, v)} ± {quantity(k, f.uncertainty.get(k))}"
                           if k in UNITS else f"{k} = {named_text(k, v)}" for k, v in f.parameters.items())
        findings.append({"effect": f.effect, "part": f.part, "parameters": params, "note": f.note,
                         "delta_bic": f.evidence.delta_bic, "heldout_rms_ratio": f.evidence.heldout_rms_ratio,
                         "heldout_z": f.evidence.heldout_z})
    prior = [{"effect": e, "rate": f"{100 * p['rate']:.3g} %", "plausible": p["plausible"], "why": p["why"]}
             for e, p in fault_prior().items()] if alternatives else []
    design, built = elements(cd.baseline.network), elements(cd.extended.network)
    parts = [(label, element_text(*design[label]), element_text(*built[label]))
             for label in design if design[label][1] is not None or built[label][1] is not None]
    rc = cd.residual_creep

    def unit_of(part):
        return "F" if part.startswith("C") else "Ω"

    fixes = [{"part": f.part, "value_from": format_quantity(f.value_from, unit_of(f.part)),
              "value_to": f"{format_quantity(f.value_to, unit_of(f.part))} ({f.series})",
              "creep": f"{100 * f.residual_creep_peak:.4f} %", "note": f.note} for f in cd.fixes]
    base, ext = cd.baseline, cd.extended
    return Markup(render_template(
        "circuit_diagnosis.html.j2", cause=cd.cause, floor=cd.floor,
        verdict=cd.verdict() if cd.floor is not None else "", su=su,
        misfit_nominal=cd.misfit(base) if cd.floor is not None else None,
        misfit_built=cd.misfit(ext) if cd.floor is not None else None,
        explained_share=cd.explained_share, misfit_limit=f"{MISFIT_LIMIT:g}",
        findings=findings, alternatives=alternatives, prior=prior,
        baseline_rms=base.rms, baseline_heldout=base.heldout.rms if base.heldout else None,
        built_rms=ext.rms, built_heldout=ext.heldout.rms if ext.heldout else None, gain=out["gain"],
        parts=parts, creep_nominal=f"{100 * rc['nominal']:.4f} %", creep_built=f"{100 * rc['as_built']:.4f} %",
        fixes=fixes, spice=out["spice_check"], figures=circuit_figures(cd, units), trials=cd.trials))
