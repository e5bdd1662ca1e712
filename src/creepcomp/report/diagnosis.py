"""Plots of fits and the self-contained HTML report of a diagnosis (PNGs embedded)."""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from creepcomp.io.atomic import write_text_atomic
from creepcomp.io.jsonfiles import to_json, write_design, write_json
from creepcomp.fit.data import Data
from creepcomp.fit.noise import autocorrelation, none_statement
from creepcomp.fit.solver import Fit
from creepcomp.report.common import (format_cell, plot_text, png_base64, render_template,
                                     thin)

__all__ = ["plot_fit", "diagnosis_figures", "render_html", "write_report"]

def _labels(data: Data, units: dict) -> tuple[str, str, str]:
    su = plot_text(units.get("signal", ""))
    lu = plot_text(units.get("load", ""))
    return (f"signal ({su})" if su else "signal"), (f"load ({lu})" if lu else "load"), su


def plot_fit(data: Data, fit: Fit, ax=None, record=None):
    """Measured and fitted signal against time, with the load, and (in a new figure) the
    residual below.

    Parameters
    ----------
    data : Data
        The record as fitted.
    fit : Fit
    ax : matplotlib Axes, optional
        Where to draw the signals; None: a new figure with the residual under them.
    record : Record, optional
        For the units of the labels.

    Returns
    -------
    matplotlib Axes
        The signals' Axes (nothing is closed).
    """
    units = {c: record.unit(c) for c in ("signal", "load")} if record is not None else {}
    ylabel, loadlabel, su = _labels(data, units)
    idx = thin(data.n)
    t = data.time[idx] - data.time[0]
    axr = None
    if ax is None:
        _, (ax, axr) = plt.subplots(2, 1, figsize=(11, 7), sharex=True,
                                    gridspec_kw={"height_ratios": [2, 1]})
    ax.plot(t, data.signal[idx], ".", ms=2, color="0.5", label="measured")
    ax.plot(t, fit.prediction[idx], "-", color="C0", lw=1.2, label=f"fit ({fit.structure.describe()})")
    ax.set_ylabel(ylabel)
    axl = ax.twinx()
    axl.plot(t, data.load[idx], color="C2", lw=0.8, alpha=0.6)
    axl.set_ylabel(loadlabel, color="C2")
    ax.legend(loc="upper left", fontsize=8)
    xlabel = f"time since the first sample (s); first sample at {data.time[0]:g} s"
    panels = [ax]
    if axr is not None:
        axr.plot(t, fit.residual[idx], ".", ms=2, color="C0")
        if fit.heldout is not None:
            axr.plot(t, fit.heldout.residual[idx], ".", ms=1, color="C1", alpha=0.5, label="held out")
            axr.legend(loc="upper right", fontsize=8)
        axr.axhline(0, color="0.4", lw=0.8)
        axr.set_ylabel(f"residual ({su})" if su else "residual")
        axr.set_xlabel(xlabel)
        panels.append(axr)
    else:
        ax.set_xlabel(xlabel)
    if data.load_step_at is not None:
        for a in panels:
            a.set_xscale("symlog", linthresh=max(data.dt_small, 1e-6))
    for a in panels:
        a.grid(True, alpha=0.3)
    return ax


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
        if "extended_error" in corr:    # (none when the extended model's correction is not found)
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
    :class:`~creepcomp.diagnose.circuit.CircuitDiagnosis` is given); rendered from
    ``templates/diagnosis.html.j2``, every text escaped."""
    d = diagnosis
    result = d.to_dict()
    findings = [{"effect": f.effect, "note": f.note or "",
                 "parameters": f.parameters_text(units),
                 "delta_bic": f.evidence.delta_bic, "heldout_rms_ratio": f.evidence.heldout_rms_ratio,
                 "heldout_z": f.evidence.heldout_z} for f in d.findings]
    trials = [{"step": t.step, "effect": t.effect, "delta_bic": t.delta_bic, "outcome": t.outcome,
               "heldout_rms_ratio": t.evidence.heldout_rms_ratio if t.evidence else None,
               "heldout_z": t.evidence.heldout_z if t.evidence else None} for t in d.trials]
    b, e = result["baseline"], result["extended"]
    su = units.get("signal", "")
    stats = [(label, b[key], e[key])
             for label, key in (("residual RMS (" + (su or "signal units") + ")", "residual_rms"),
                                ("held-out residual RMS (" + (su or "signal units") + ")",
                                 "heldout_residual_rms"),
                                ("residual RMS / signal range", "residual_rms_relative"),
                                ("BIC", "bic"), ("residual lag-1 autocorrelation", "residual_lag1_autocorrelation"),
                                ("Ljung-Box p of the prewhitened residual", "whitened_ljung_box_p"))]
    noise = (f"baseline noise {b['noise']['model']}, memory {format_cell(b['noise']['memory_s'])} s; "
             f"extended {e['noise']['model']}, memory {format_cell(e['noise']['memory_s'])} s")
    if circuit is not None:
        from creepcomp.report.circuit_diagnosis import circuit_html

        circuit_section = circuit_html(circuit, units)
    else:
        circuit_section = ""
    catch = result["catch_all"]
    catch_text = ("not fitted" if not catch else
                  f"ΔBIC {format_cell(catch['delta_bic'])}, held-out z {format_cell(catch['heldout_z'])}")
    rule = result["decision_rule"]
    return render_template(
        "diagnosis.html.j2", title=title, rec=result["record"], circuit_section=circuit_section,
        cause=d.cause, findings=findings, none_sentence=_sentence(none_statement(d.floor)),
        floor=_floor(d, result), signal_unit=su,
        rule={"delta_bic": f"{-rule['delta_bic_at_most']:g}", "heldout_z": f"{rule['heldout_z_at_least']:g}"},
        catch_text=catch_text, gain=result["gain"], stats=stats, noise=noise,
        figures=diagnosis_figures(d, units), trials=trials,
        model_json=json.dumps(json.loads(to_json(d.extended_model)), indent=2))


def _floor(d, result: dict) -> dict | None:
    """The noise floor, the misfit ratios and the explained share, with what they say."""
    if d.floor is None:
        return None
    from creepcomp.fit.noise import MISFIT_LIMIT

    b, e = result["baseline"]["misfit_ratio"], result["extended"]["misfit_ratio"]
    share = result["explained_share"]
    unexplained = False
    if b is not None and b <= MISFIT_LIMIT:
        verdict = "The baseline's misfit is consistent with the noise floor."
    elif e is not None and e <= MISFIT_LIMIT:
        verdict = "The baseline misses the record by more than its noise; the extended model brings it to the floor."
    else:
        verdict = (f"The extended model still misses the record by {format_cell(e)} times the noise floor: "
                   "part of the record is not explained")
        unexplained = True
    return {"rms": d.floor.rms, "method": d.floor.method, "baseline": b, "extended": e,
            "limit": f"{MISFIT_LIMIT:g}", "share": "–" if share is None else f"{100 * share:.1f} %",
            "verdict": verdict, "unexplained": unexplained, "rough": d.floor.rough,
            "windows": d.floor.windows_text}


def _sentence(text: str) -> str:
    return text[:1].upper() + text[1:] + "."


def write_report(diagnosis, out_dir, units: dict | None = None, circuit=None,
                 recommendation=None) -> dict[str, Path]:
    """Write ``report.html``, ``diagnosis.json``, ``model.json`` (the recommended model:
    :func:`creepcomp.diagnose.recommend.recommend`; the extended one without a
    recommendation), ``extended-model.json`` and ``baseline-model.json`` into ``out_dir``;
    with the circuit side also ``as-built-design.json`` (the as-built network as a design
    file)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"report": out / "report.html", "diagnosis": out / "diagnosis.json",
             "model": out / "model.json", "extended_model": out / "extended-model.json",
             "baseline_model": out / "baseline-model.json"}
    write_text_atomic(paths["report"], render_html(diagnosis, units or {}, circuit=circuit))
    if circuit is not None:
        from creepcomp.diagnose.circuit import combine

        paths["as_built_design"] = write_design(out / "as-built-design.json", circuit.as_built)
        write_json(paths["diagnosis"], combine(diagnosis.to_dict(), circuit))
    else:
        write_json(paths["diagnosis"], diagnosis.to_dict())
    if recommendation is not None:
        write_json(paths["diagnosis"], {**json.loads(paths["diagnosis"].read_text(encoding="utf-8")),
                                        "recommended": recommendation.to_dict()})
    write_json(paths["model"], diagnosis.extended_model if recommendation is None else recommendation.model)
    write_json(paths["extended_model"], diagnosis.extended_model)
    if unreadable_baseline(diagnosis) is None:
        write_json(paths["baseline_model"], diagnosis.baseline_model)
    else:
        # a model file no command could read is not written, and none left from an earlier run
        stale = paths.pop("baseline_model")
        if stale.is_file() and not stale.is_symlink():
            stale.unlink()
    return paths


def unreadable_baseline(diagnosis) -> str | None:
    """Why the diagnosis's baseline model is not a model file (e.g. a term of beta below -1
    standing in for a delay, whose correction has no causal inverse), or None."""
    from creepcomp.errors import InputError
    from creepcomp.model import CreepModel

    try:
        CreepModel.from_dict(diagnosis.baseline_model, where="baseline model")
    except InputError as exc:
        return str(exc)
    return None
