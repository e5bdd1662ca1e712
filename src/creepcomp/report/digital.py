"""Plots of digital creep correction: a corrected record, the paper's scenarios (figs. 3-6)."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from creepcomp.analog.quality import sweep_branches
from creepcomp.report.common import plot_text

__all__ = ["ERROR_FLOOR", "plot_correction", "plot_step_outcomes", "plot_sweep_outcomes"]

#: Smallest error drawn on log axes (exact corrections sit at rounding level).
ERROR_FLOOR = 1e-16


def plot_correction(time, signal, compensated, reference, ax=None, title: str = "",
                    signal_unit: str = "", full_scale: float | None = None):
    """A corrected record: raw, compensated and reference signals; in a new figure also the
    error before and after below.

    Parameters
    ----------
    time, signal, compensated, reference : array_like
        Samples (signal units); ``reference`` is what an exact correction returns.
    ax : matplotlib Axes, optional
        Where to draw the signals; None: a new figure with the errors under them.
    title, signal_unit : str
        For the labels.
    full_scale : float, optional
        Full-scale output; errors are then drawn as a percentage of it.

    Returns
    -------
    matplotlib Axes
        The signals' Axes (nothing is closed).
    """
    t = np.asarray(time)
    signal_unit, title = plot_text(signal_unit), plot_text(title)
    bottom = None
    if ax is None:
        _, (top, bottom) = plt.subplots(2, 1, figsize=(11, 7), sharex=True)
    else:
        top = ax
    top.plot(t, signal, label="raw", lw=1.0)
    top.plot(t, compensated, label="compensated", lw=1.0)
    top.plot(t, reference, "k--", label="reference (from load)", lw=0.8)
    top.set_ylabel(f"signal ({signal_unit})" if signal_unit else "signal")
    top.set_title(title)
    top.legend(fontsize=8)
    top.grid(True, alpha=0.3)
    if bottom is None:
        top.set_xlabel("time (s)")
        return top
    scale, unit = ((100.0 / full_scale, "% of FS") if full_scale else (1.0, signal_unit or "signal units"))
    for values, label in ((signal, "raw"), (compensated, "compensated")):
        err = np.maximum(np.abs(np.asarray(values) - reference) * scale, ERROR_FLOOR)
        bottom.semilogy(t, err, label=f"{label} - reference", lw=0.8)
    bottom.set_ylabel(f"|error| ({unit})")
    bottom.set_xlabel("time (s)")
    bottom.legend(fontsize=8)
    bottom.grid(True, alpha=0.3)
    return top


def plot_step_outcomes(record, outcomes):
    """Loading and unloading steps (the paper's figs. 3-5): signals and creep errors, in a
    new figure of three panels; returns the first Axes (nothing is closed)."""
    from creepcomp.digital.correctors import reference

    t = record.time
    model = record.model
    _, axes = plt.subplots(3, 1, figsize=(11, 10), sharex=True)
    for ax, method in zip(axes[:2], ("subtractive", "supplemental")):
        ax.plot(t, record.signal, label="raw signal", lw=1.0)
        for o in outcomes:
            if o.method == method and o.label != "raw signal":
                ax.plot(t, o.values, label=o.label, lw=1.0)
        ax.plot(t, reference(record.load, model, method), "k:", lw=0.8,
                label="instantaneous (load)" if method == "subtractive" else "saturated (load)")
        ax.set_ylabel("signal")
        ax.set_title(f"{method} correction" + (" (fig. 3a, 4)" if method == "subtractive"
                                                else " (fig. 3b, 5)"))
        ax.legend(fontsize=8)
    ax = axes[2]
    for o in outcomes:
        err = np.abs(o.values - reference(record.load, model, o.method)) / o.error.full_scale
        ax.semilogy(t, np.maximum(100 * err, ERROR_FLOOR), lw=0.8, label=o.label)
    ax.set_ylabel("|creep error| (% of FS)")
    ax.set_xlabel("time (s)")
    ax.set_title("remaining creep error (exact correctors: rounding level)")
    ax.legend(fontsize=7, ncol=2)
    for ax in axes:
        ax.grid(True, alpha=0.3)
    return axes[0]


def plot_sweep_outcomes(record, outcomes):
    """Hysteresis loops of the triangular sweep (the paper's fig. 6), last period, in a new
    figure of two panels; returns the first Axes (nothing is closed)."""
    from creepcomp.digital.correctors import saturation_factor

    model, m = record.model, record.quarter_points
    fs = float(np.max(np.abs(record.load)))
    _, (loops, detail) = plt.subplots(1, 2, figsize=(13, 5))
    styles = ["-", "--", ":", "-."]
    for i, o in enumerate(outcomes):
        full = abs(model.gain) * saturation_factor(model, o.method) * fs
        y = (o.values[-(4 * m + 1):] - model.offset) / full
        load, up, down = sweep_branches(y, m)
        axes = (loops,) if o.label == "raw signal" else (loops, detail)
        for ax in axes:
            style = styles[i % len(styles)]
            ax.plot(load, 100 * (up - load), style, lw=1.0, color=f"C{i}",
                    label=f"{o.label}: {100 * o.hysteresis:.2g} %")
            ax.plot(load, 100 * (down - load), style, lw=1.0, color=f"C{i}")
    loops.set_title("sweep ±FS, last period (fig. 6); legend: hysteresis (of FS)")
    detail.set_title("corrected outputs only")
    for ax in (loops, detail):
        ax.set_xlabel("load (fraction of FS)")
        ax.set_ylabel("output - ideal output (% of FS output)")
        ax.legend(fontsize=7)
        ax.grid(True, alpha=0.3)
    return loops
