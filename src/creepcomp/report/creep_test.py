"""The plot of an OIML R 60 creep test: the 30-min creep curve and the return after unloading at
each temperature, against the class's limits."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

__all__ = ["plot_creep_test"]


def plot_creep_test(result, ax=None):
    """Plot a creep test (:class:`creepcomp.verify.creep_test.CreepTestResult`).

    Left: the change from the initial reading over the 30 min under load, in % of FS (right
    axis: in verification intervals v), with the creep limit as a band and the 20-30 min
    window marked. Right: the output after unloading (from the zero before the test), with the
    DR limit as a band and the DR reading marked.

    Parameters
    ----------
    result : CreepTestResult
    ax : matplotlib Axes, optional
        Where to draw the creep under load; None: a new figure with the return after
        unloading beside it.

    Returns
    -------
    matplotlib Axes
        The creep's Axes (nothing is closed).
    """
    lim = result.limits
    if ax is None:
        _, (ax_hold, ax_back) = plt.subplots(1, 2, figsize=(12, 4.6))
    else:
        ax_hold, ax_back = ax, None
    panels = [a for a in (ax_hold, ax_back) if a is not None]
    ax_hold.axhspan(-100 * lim.creep_30min, 100 * lim.creep_30min, color="#88ccee", alpha=0.35,
                    label=f"creep limit ±{100 * lim.creep_30min:.3g} % ({lim.label})")
    ax_hold.axvspan(20, 30, color="#ddcc77", alpha=0.25, label="20-30 min window")
    if ax_back is not None:
        ax_back.axhspan(-100 * lim.dr, 100 * lim.dr, color="#88ccee", alpha=0.35,
                        label=f"DR limit ±{100 * lim.dr:.3g} %")
    colours = ["#0077bb", "#009988", "#cc3311", "#ee7733", "#33bbee", "#ee3377", "#555555"]
    rows = {r["temperature"]: r for r in result.rows}
    for k, (temp, c) in enumerate(sorted(result.curves.items())):
        colour = colours[k % len(colours)]
        verdict = "pass" if rows[temp]["pass"] else "fail"
        ax_hold.plot(np.asarray(c["hold_time"]) / 60, 100 * np.asarray(c["change"]), color=colour,
                     label=f"{temp:g} °C ({verdict})")
        if ax_back is not None:
            ax_back.plot(np.asarray(c["return_time"]) / 60, 100 * np.asarray(c["return"]), color=colour,
                         label=f"{temp:g} °C: DR {100 * rows[temp]['dr']:.3g} %")
            ax_back.plot([0], [100 * rows[temp]["dr"] * np.sign(c["return"][0] or 1)], "o", color=colour)
    ax_hold.set_xlabel("time after the initial reading (min)")
    ax_hold.set_ylabel("change from the initial reading (% of FS)")
    ax_hold.set_title(f"Creep under full load ({result.target})")
    if ax_back is not None:
        ax_back.set_xlabel("time after unloading (min)")
        ax_back.set_ylabel("output minus zero before the test (% of FS)")
        ax_back.set_title("Dead-load output return (DR read at 0 min)")
    for ax in panels:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        top = max(abs(x) for x in ax.get_ylim())
        if top > 40 * 100 * lim.creep_30min:
            # far beyond the limit: a symmetric log scale keeps the band visible
            ax.set_yscale("symlog", linthresh=100 * lim.dr)
            ax.set_ylabel(ax.get_ylabel() + f"; 1 v = {100 * lim.interval:.3g} %")
        else:
            to_v = lim.n_max / 100.0
            ax.secondary_yaxis("right", functions=(lambda y, k=to_v: y * k, lambda v, k=to_v: v / k)
                               ).set_ylabel("verification intervals v")
    return ax_hold
