"""Plots of fits and the self-contained HTML report of a diagnosis (PNGs embedded)."""

from __future__ import annotations

import html
import json
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from creepcomp.io.atomic import write_text_atomic
from creepcomp.io.jsonfiles import to_json, write_design, write_json
from creepcomp.fit.data import Data
from creepcomp.fit.noise import autocorrelation, none_statement
from creepcomp.fit.solver import Fit
from creepcomp.report.common import format_cell, format_named, png_base64, save_figure, thin

__all__ = ["plot_fit", "diagnosis_figures", "render_html", "write_report"]

def _labels(data: Data, units: dict) -> tuple[str, str, str]:
    su = units.get("signal", "")
    lu = units.get("load", "")
    return (f"signal ({su})" if su else "signal"), (f"load ({lu})" if lu else "load"), su


def plot_fit(data: Data, fit: Fit, path, record=None) -> Path:
    """Measured and fitted signal against time, with the load, and the residual."""
    units = {c: record.unit(c) for c in ("signal", "load")} if record is not None else {}
    ylabel, loadlabel, su = _labels(data, units)
    idx = thin(data.n)
    t = data.time[idx] - data.time[0]
    fig, (ax, axr) = plt.subplots(2, 1, figsize=(11, 7), sharex=True,
                                  gridspec_kw={"height_ratios": [2, 1]})
    ax.plot(t, data.signal[idx], ".", ms=2, color="0.5", label="measured")
    ax.plot(t, fit.prediction[idx], "-", color="C0", lw=1.2, label=f"fit ({fit.structure.describe()})")
    ax.set_ylabel(ylabel)
    axl = ax.twinx()
    axl.plot(t, data.load[idx], color="C2", lw=0.8, alpha=0.6)
    axl.set_ylabel(loadlabel, color="C2")
    ax.legend(loc="upper left", fontsize=8)
    axr.plot(t, fit.residual[idx], ".", ms=2, color="C0")
    if fit.heldout is not None:
        axr.plot(t, fit.heldout.residual[idx], ".", ms=1, color="C1", alpha=0.5, label="held out")
        axr.legend(loc="upper right", fontsize=8)
    axr.axhline(0, color="0.4", lw=0.8)
    axr.set_ylabel(f"residual ({su})" if su else "residual")
    axr.set_xlabel(f"time since the first sample (s); first sample at {data.time[0]:g} s")
    if data.load_step_at is not None or data.duration / max(data.dt_small, 1e-300) > 1e4:
        if data.load_step_at is not None:
            for a in (ax, axr):
                a.set_xscale("symlog", linthresh=max(data.dt_small, 1e-6))
    for a in (ax, axr):
        a.grid(True, alpha=0.3)
    fig.tight_layout()
    return save_figure(fig, path, dpi=100)


def diagnosis_figures(diagnosis, units: dict) -> list[tuple[str, str]]:
    """(title, base64 PNG) of each plot of a diagnosis."""
    d = diagnosis
    data, base, ext = d.data, d.baseline, d.extended
    ylabel, loadlabel, su = _labels(data, units)
    rlabel = f"residual ({su})" if su else "residual"
    idx = thin(data.n)
    t = data.time[idx] - data.time[0]
    xlabel = f"time since the first sample (s); first sample at {data.time[0]:g} s"
    same = ext is base or ext.structure == base.structure
    figs = []

    fig, ax = plt.subplots(figsize=(11, 4.5))
    ax.plot(t, data.signal[idx], ".", ms=2, color="0.55", label="measured")
    ax.plot(t, base.prediction[idx], "-", lw=1.1, color="C3", label="baseline (1 creep term)")
    if not same:
        ax.plot(t, ext.prediction[idx], "-", lw=1.1, color="C0", label=f"extended ({ext.structure.describe()})")
    axl = ax.twinx()
    axl.plot(t, data.load[idx], color="C2", lw=0.8, alpha=0.5)
    axl.set_ylabel(loadlabel, color="C2")
    ax.set_ylabel(ylabel)
    ax.set_xlabel(xlabel)
    ax.legend(loc="upper left", fontsize=8)
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    figs.append(("Measured and simulated signal (load in green)", png_base64(fig, dpi=90)))

    fig, ax = plt.subplots(figsize=(11, 4))
    ax.plot(t, base.residual[idx], ".", ms=2, color="C3", alpha=0.6,
            label=f"baseline, RMS {base.residual_rms:.3g}")
    if not same:
        ax.plot(t, ext.residual[idx], ".", ms=2, color="C0", alpha=0.6,
                label=f"extended, RMS {ext.residual_rms:.3g}")
    ax.axhline(0, color="0.3", lw=0.8)
    if d.floor is not None and d.floor.rms > 0:
        ax.axhspan(-d.floor.rms, d.floor.rms, color="C2", alpha=0.15,
                   label=f"± noise floor {d.floor.rms:.3g}")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(rlabel)
    ax.legend(fontsize=8, markerscale=4)
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    figs.append(("Residual (measured minus simulated) against time", png_base64(fig, dpi=90)))

    if d.floor is not None and d.floor.rms > 0:
        figs.append(("Misfit against the noise floor", _misfit_figure(d, su)))

    ncols = 2 if data.temperature is not None else 1
    fig, axes = plt.subplots(1, ncols, figsize=(11 if ncols == 2 else 7, 4.2), squeeze=False)
    ax = axes[0, 0]
    sub = thin(data.n, 6000)
    ax.plot(data.load[sub], base.residual[sub], ".", ms=2, color="C3", alpha=0.5, label="baseline")
    if not same:
        ax.plot(data.load[sub], ext.residual[sub], ".", ms=2, color="C0", alpha=0.5, label="extended")
    ax.set_xlabel(loadlabel)
    ax.set_ylabel(rlabel)
    ax.legend(fontsize=8, markerscale=4)
    ax.grid(True, alpha=0.3)
    if ncols == 2:
        ax = axes[0, 1]
        ax.plot(data.temperature[sub], base.residual[sub], ".", ms=2, color="C3", alpha=0.5, label="baseline")
        if not same:
            ax.plot(data.temperature[sub], ext.residual[sub], ".", ms=2, color="C0", alpha=0.5, label="extended")
        ax.set_xlabel("temperature (°C)")
        ax.set_ylabel(rlabel)
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    figs.append(("Residual against load" + (" and temperature" if ncols == 2 else ""), png_base64(fig, dpi=90)))

    lags = int(min(data.n // 4, max(50, 0.2 * data.duration / data.dt_median), 5000))
    fig, ax = plt.subplots(figsize=(9, 3.8))
    lag_t = np.arange(lags + 1) * data.dt_median
    ax.plot(lag_t, autocorrelation(base.residual, lags), color="C3", label="baseline")
    if not same:
        ax.plot(lag_t, autocorrelation(ext.residual, lags), color="C0", label="extended")
    band = 2 / np.sqrt(data.n)
    ax.axhspan(-band, band, color="0.85", label="±2/√N (white noise)")
    ax.set_xlabel("lag (s, at the median sampling step)")
    ax.set_ylabel("autocorrelation")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    figs.append(("Autocorrelation of the residual", png_base64(fig, dpi=90)))

    corr = d.correction
    if corr:
        fig, ax = plt.subplots(figsize=(11, 4))
        ax.plot(t, corr["baseline_error"][idx], lw=0.8, color="C3",
                label=f"baseline model, RMS {corr['baseline_rms']:.3g}")
        ax.plot(t, corr["extended_error"][idx], lw=0.8, color="C0",
                label=f"extended model, RMS {corr['extended_rms']:.3g}")
        ax.axhline(0, color="0.3", lw=0.8)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(f"error ({su})" if su else "error")
        ax.legend(fontsize=8)
        ax.grid(True, alpha=0.3)
        fig.tight_layout()
        figs.append(("Creep-corrected signal minus the load scaled to it: before and after", png_base64(fig, dpi=90)))
    return figs


def _misfit_figure(d, su: str) -> str:
    """Bars of the residual RMS (all samples and held out) of the baseline and the extended
    model, against the noise floor and the limit of a misfit consistent with noise."""
    from creepcomp.fit.noise import MISFIT_LIMIT

    floor = d.floor.rms
    labels = ["baseline", "extended"]
    fits = [d.baseline, d.extended]
    fig, ax = plt.subplots(figsize=(9, 3.6))
    x = np.arange(2)
    ax.bar(x - 0.18, [f.residual_rms / floor for f in fits], 0.36, color=["C3", "C0"], label="all samples")
    held = [f.heldout.rms / floor if f.heldout else np.nan for f in fits]
    ax.bar(x + 0.18, held, 0.36, color=["C3", "C0"], alpha=0.45, hatch="//", label="held out")
    ax.axhline(1.0, color="C2", lw=1.2, label=f"noise floor ({floor:.3g} {su})".replace(" )", ")"))
    ax.axhline(MISFIT_LIMIT, color="C2", lw=1.0, ls="--", label=f"limit of 'consistent with noise' ({MISFIT_LIMIT:g})")
    ax.set_xticks(x, labels)
    ax.set_ylabel("residual RMS / noise floor")
    share = d.explained_share
    ax.set_title("explained share of the excess misfit: " + ("–" if share is None else f"{100 * share:.0f} %"),
                 fontsize=10)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.grid(True, axis="y", alpha=0.3)
    fig.tight_layout()
    return png_base64(fig, dpi=90)


def render_html(diagnosis, units: dict, title: str = "creepcomp diagnose",
                circuit=None) -> str:
    """The report as one self-contained HTML page (with the circuit side's section when a
    :class:`~creepcomp.diagnose.circuit.CircuitDiagnosis` is given)."""
    d = diagnosis
    result = d.to_dict()
    rows = []
    for f in d.findings:
        params = ", ".join(f"{k} = {format_named(k, v)}" + (f" ± {format_named(k, f.uncertainty[k])}" if k in f.uncertainty else "")
                           for k, v in f.parameters.items())
        ev = f.evidence
        rows.append(f"<tr><td><b>{html.escape(f.effect)}</b></td><td>{params or '–'}</td>"
                    f"<td>{format_cell(ev.delta_bic)}</td><td>{format_cell(ev.heldout_rms_ratio)}</td>"
                    f"<td>{format_cell(ev.heldout_z)}</td><td>{html.escape(f.note or '')}</td></tr>")
    findings = ("<table><tr><th>effect</th><th>parameters (± 1 sigma)</th><th>ΔBIC</th>"
                "<th>held-out RMS ratio</th><th>held-out z</th><th>note</th></tr>" + "".join(rows) + "</table>"
                if rows else f"<p>{html.escape(_sentence(none_statement(d.floor)))}</p>")
    floor_section = _floor_html(d, result, units.get("signal", ""))
    tried = "".join(f"<tr><td>{t.step}</td><td>{html.escape(t.effect)}</td><td>{format_cell(t.delta_bic)}</td>"
                    f"<td>{format_cell(t.evidence.heldout_rms_ratio if t.evidence else None)}</td>"
                    f"<td>{format_cell(t.evidence.heldout_z if t.evidence else None)}</td>"
                    f"<td>{html.escape(t.outcome)}</td></tr>" for t in d.trials)
    b, e, g = result["baseline"], result["extended"], result["gain"]
    su = units.get("signal", "")
    stats = "".join(
        f"<tr><td>{label}</td><td>{format_cell(b[key])}</td><td>{format_cell(e[key])}</td></tr>"
        for label, key in (("residual RMS (" + (su or "signal units") + ")", "residual_rms"),
                           ("held-out residual RMS", "heldout_residual_rms"),
                           ("residual RMS / signal range", "residual_rms_relative"),
                           ("BIC", "bic"), ("residual lag-1 autocorrelation", "residual_lag1_autocorrelation"),
                           ("Ljung-Box p of the prewhitened residual", "whitened_ljung_box_p")))
    noise = (f"baseline noise {b['noise']['model']}, memory {format_cell(b['noise']['memory_s'])} s; "
             f"extended {e['noise']['model']}, memory {format_cell(e['noise']['memory_s'])} s")
    figs = "".join(f"<h3>{html.escape(title_)}</h3><img src='data:image/png;base64,{png}'/>"
                   for title_, png in diagnosis_figures(d, units))
    if circuit is not None:
        from creepcomp.report.circuit_diagnosis import circuit_html

        circuit_section = circuit_html(circuit, units)
    else:
        circuit_section = ""
    rec = result["record"]
    catch = result["catch_all"]
    catch_text = ("not fitted" if not catch else
                  f"ΔBIC {format_cell(catch['delta_bic'])}, held-out z {format_cell(catch['heldout_z'])}")
    return f"""<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>body{{font-family:sans-serif;max-width:1150px;margin:auto;padding:1em}}
table{{border-collapse:collapse;margin:0.5em 0}}td,th{{border:1px solid #bbb;padding:3px 8px;text-align:right}}
td:first-child,th:first-child{{text-align:left}}img{{max-width:100%}}pre{{background:#f4f4f4;padding:0.6em}}</style>
</head><body>
<h1>{html.escape(title)}</h1>
<p>Record <code>{html.escape(rec['source'])}</code>: {rec['n_samples']} samples over {format_cell(rec['duration_s'])} s,
median step {format_cell(rec['sample_step_s'])} s ({'reduced to block means' if rec.get('reduced') else 'uniform' if rec['uniform'] else 'irregular'});
initial creep state: {html.escape(rec['initial_state'])}; temperature column: {'yes' if rec['temperature'] else 'no'}.</p>
{circuit_section}
<h2>Sensor side: cause {html.escape(d.cause)}</h2>
{findings}
{floor_section}
<p>Decision rule: an effect is added when BIC drops by at least {-result['decision_rule']['delta_bic_at_most']:g}
(likelihood with AR noise) and data held out of the fit are predicted better by at least
{result['decision_rule']['heldout_z_at_least']:g} standard deviations, and it explains more than a generic
extension (catch-all) would. Catch-all on top of the final model: {catch_text}.</p>
<h2>Gain</h2>
<table><tr><th></th><th>value</th></tr>
<tr><td>held-out residual RMS, baseline / extended</td><td>{format_cell(g.get('heldout_rms_ratio'))}</td></tr>
<tr><td>creep-corrected signal error, baseline / extended</td><td>{format_cell(g.get('correction_error_ratio'))}</td></tr>
<tr><td>creep-corrected signal error RMS, baseline model</td><td>{format_cell(g.get('correction_error_baseline'))}</td></tr>
<tr><td>creep-corrected signal error RMS, extended model</td><td>{format_cell(g.get('correction_error_extended'))}</td></tr></table>
<h2>Baseline and extended model</h2>
<table><tr><th></th><th>baseline</th><th>extended</th></tr>{stats}</table>
<p>{html.escape(noise)}</p>
{figs}
<h2>Candidates tried</h2>
<table><tr><th>step</th><th>effect</th><th>ΔBIC</th><th>held-out RMS ratio</th><th>held-out z</th><th>outcome</th></tr>{tried}</table>
<h2>Extended model file</h2>
<pre>{html.escape(json.dumps(json.loads(to_json(d.extended_model)), indent=2))}</pre>
</body></html>
"""


def _floor_html(d, result: dict, su: str) -> str:
    """The noise floor, the misfit ratios and the explained share, with what they say."""
    if d.floor is None:
        return ""
    from creepcomp.fit.noise import MISFIT_LIMIT

    unit = f" {su}" if su else ""
    b, e = result["baseline"]["misfit_ratio"], result["extended"]["misfit_ratio"]
    share = result["explained_share"]
    if b is not None and b <= MISFIT_LIMIT:
        verdict = "The baseline's misfit is consistent with the noise floor."
    elif e is not None and e <= MISFIT_LIMIT:
        verdict = "The baseline misses the record by more than its noise; the extended model brings it to the floor."
    else:
        verdict = (f"The extended model still misses the record by {format_cell(e)} times the noise floor: "
                   "part of the record is not explained (see <i>unexplained</i> in the findings).")
    if d.floor.rough:
        verdict += (f" The floor rests on only {d.floor.windows} windows: a rough estimate, and so are the "
                    "misfit ratios over it.")
    return f"""<h3>Noise floor and misfit</h3>
<table><tr><th></th><th>value</th></tr>
<tr><td>noise floor (RMS, measured without the model)</td><td>{format_cell(d.floor.rms)}{unit}</td></tr>
<tr><td>how</td><td style="text-align:left">{html.escape(d.floor.method)}</td></tr>
<tr><td>misfit ratio, baseline (residual RMS / floor)</td><td>{format_cell(b)}</td></tr>
<tr><td>misfit ratio, extended</td><td>{format_cell(e)}</td></tr>
<tr><td>consistent with noise up to</td><td>{MISFIT_LIMIT:g}</td></tr>
<tr><td>explained share of the baseline's excess misfit</td><td>{'–' if share is None else f'{100 * share:.1f} %'}</td></tr>
</table>
<p>{verdict}</p>"""


def _sentence(text: str) -> str:
    return text[:1].upper() + text[1:] + "."


def write_report(diagnosis, out_dir, units: dict | None = None, circuit=None) -> dict[str, Path]:
    """Write ``report.html``, ``diagnosis.json``, ``model.json`` (extended) and
    ``baseline-model.json`` into ``out_dir``; with the circuit side also
    ``as-built-design.json`` (the as-built network as a design file)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"report": out / "report.html", "diagnosis": out / "diagnosis.json",
             "model": out / "model.json", "baseline_model": out / "baseline-model.json"}
    write_text_atomic(paths["report"], render_html(diagnosis, units or {}, circuit=circuit))
    if circuit is not None:
        from creepcomp.diagnose.circuit import combine

        paths["as_built_design"] = write_design(out / "as-built-design.json", circuit.as_built)
        write_json(paths["diagnosis"], combine(diagnosis.to_dict(), circuit))
    else:
        write_json(paths["diagnosis"], diagnosis.to_dict())
    write_json(paths["model"], diagnosis.extended_model)
    write_json(paths["baseline_model"], diagnosis.baseline_model)
    return paths
