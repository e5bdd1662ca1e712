"""The ngspice check as a picture: python-control against ngspice, and the residual creep."""

from __future__ import annotations

import matplotlib.pyplot as plt

from creepcomp.verify.compare import Comparison

__all__ = ["plot_comparison"]


def plot_comparison(comparison: Comparison, ax=None):
    """Creeping input and corrected output from both simulators; in a new figure also the
    residual creep and the simulators' difference below.

    Parameters
    ----------
    comparison : Comparison
    ax : matplotlib Axes, optional
        Where to draw the signals; None: a new figure of all panels.

    Returns
    -------
    matplotlib Axes
        The signals' Axes (nothing is closed).
    """
    c = comparison
    ref, sp = c.reference, c.spice
    synthetic = ref.instantaneous is not None
    rows = 3 if synthetic else 2
    if ax is None:
        _, axes = plt.subplots(rows, 1, figsize=(10, 2.9 * rows + 0.6), sharex=True)
    else:
        axes = [ax]
    t = ref.time
    ax = axes[0]
    scale = c.full_scale if synthetic else 1.0
    if synthetic:
        ax.plot(t, ref.instantaneous / scale, color="0.6", ls="--", lw=1,
                label="instantaneous signal (no creep)")
    ax.plot(t, ref.sensor / scale, color="tab:red", lw=1.2, label="creeping sensor output (network input)")
    ax.plot(t, ref.output / (c.hf_gain * scale), color="tab:blue", lw=2.2, alpha=0.6,
            label="corrected output / H(inf), python-control")
    if sp is not None:
        ax.plot(sp.time, sp.output / (c.hf_gain * scale), color="black", lw=0.9, ls=(0, (4, 3)),
                label="corrected output / H(inf), ngspice")
    ax.set_ylabel("fraction of full scale" if synthetic else "signal (V)")
    ax.set_title(f"{c.drive}: sensor and corrected output")
    ax.legend(fontsize=8, loc="best")
    if len(axes) == 1:
        ax.set_xlabel("time (s)")
        ax.grid(True, alpha=0.3)
        return ax
    if synthetic:
        ax = axes[1]
        ax.plot(t, 100 * c.residual("reference"), color="tab:blue", lw=2.2, alpha=0.6,
                label="python-control")
        if sp is not None:
            ax.plot(t, 100 * c.residual("spice"), color="black", lw=0.9, ls=(0, (4, 3)),
                    label="ngspice")
        ax.axhline(0, color="0.6", lw=0.8)
        ax.set_ylabel("residual creep (% of FS)")
        ax.set_title("Residual creep of the corrected output, (y - H(inf) S_ins) / (H(inf) FS)")
        ax.legend(fontsize=8)
    ax = axes[-1]
    if sp is not None:
        ax.plot(t, 1e6 * (sp.output - ref.output) / (c.hf_gain * c.full_scale), lw=1,
                label="corrected output")
        if synthetic:
            ax.plot(t, 1e6 * (sp.sensor - ref.sensor) / c.full_scale, lw=1, label="sensor output")
        ax.set_title(f"ngspice - python-control: largest {c.agreement_max_abs:.2e} of full scale")
        ax.legend(fontsize=8)
    else:
        ax.text(0.5, 0.5, "ngspice not available: python-control only", ha="center",
                va="center", transform=ax.transAxes)
    ax.set_ylabel("difference (ppm of FS)")
    ax.set_xlabel("time (s)")
    for a in axes:
        a.grid(True, alpha=0.3)
    return axes[0]
