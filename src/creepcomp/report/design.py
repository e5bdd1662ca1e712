"""The design comparison plot: residual creep after a step and the sweep loop of several designs."""

from __future__ import annotations

import matplotlib.pyplot as plt

from creepcomp.analog.quality import step_residual, sweep_hysteresis
from creepcomp.model import CreepModel
from creepcomp.network import Network

__all__ = ["plot_design_comparison", "plot_over_temperature"]


def plot_design_comparison(model: CreepModel, designs: dict[str, Network | None], ax=None,
                           sweep_period: float | None = None, schematic: Network | None = None,
                           plan=None):
    """Residual creep after a load step, and (in a new figure) the sweep hysteresis loop, of
    several designs.

    Parameters
    ----------
    model : CreepModel
        The sensor's creep.
    designs : dict
        Label to network (None for the uncorrected sensor).
    ax : matplotlib Axes, optional
        Where to draw the step's residual creep; None: a new figure with the sweep's loop
        beside it (and ``schematic`` above).
    sweep_period : float, optional
        Period of the triangular sweep (s).
    schematic : Network, optional
        A network drawn above the plots of a new figure (the chosen design), with ``plan``'s
        thermistors.

    Returns
    -------
    matplotlib Axes
        The step's Axes (nothing is closed).
    """
    ax_loop = None
    if ax is not None:
        ax_step = ax
    elif schematic is None:
        _, (ax_step, ax_loop) = plt.subplots(1, 2, figsize=(12, 4.8))
    else:
        fig = plt.figure(figsize=(12, 9.0))
        grid = fig.add_gridspec(2, 2, height_ratios=(1.0, 1.1))
        _draw_schematic(fig.add_subplot(grid[0, :]), schematic, plan)
        ax_step, ax_loop = fig.add_subplot(grid[1, 0]), fig.add_subplot(grid[1, 1])
    for label, net in designs.items():
        t, e = step_residual(model, net)
        ax_step.plot(t, 100 * e, label=label)
        if ax_loop is not None:
            _, load, up, down = sweep_hysteresis(model, net, sweep_period)
            (line,) = ax_loop.plot(load, 100 * (up - load), label=label)
            ax_loop.plot(load, 100 * (down - load), color=line.get_color())
    ax_step.set_xscale("symlog", linthresh=max(min(model.tau) / 10, 1e-3))
    ax_step.set_xlabel("time after a load step (s)")
    ax_step.set_ylabel("residual creep (% of step)")
    ax_step.set_title("Load step")
    ax_step.axhline(0, color="0.6", lw=0.8)
    ax_step.legend(fontsize=8)
    ax_step.grid(True, alpha=0.3)
    if ax_loop is not None:
        ax_loop.set_xlabel("load (fraction of full scale)")
        ax_loop.set_ylabel("output - ideal output (% of FS)")
        ax_loop.set_title("Triangular sweep ±FS, up and down branches")
        ax_loop.axhline(0, color="0.6", lw=0.8)
        ax_loop.grid(True, alpha=0.3)
    return ax_step


def plot_over_temperature(comparison, ax=None):
    """Peak residual creep (%) against temperature of the designs compared over a range
    (:class:`creepcomp.analog.over_temperature.RangeComparison`), the uncorrected creep for
    reference, each design's worst case marked.

    Returns
    -------
    matplotlib Axes
        ``ax``, or a new figure's (nothing is closed).
    """
    if ax is None:
        _, ax = plt.subplots(figsize=(8, 4.8))
    bare = comparison.designs[0].prediction
    ax.plot(bare.temperatures, [100 * x for x in bare.uncorrected], color="0.5", ls="--",
            label="uncorrected")
    for d in comparison.designs:
        p = d.prediction
        (line,) = ax.plot(p.temperatures, [100 * x for x in p.peak_residual], marker="o", ms=3,
                          label=f"{d.label}: worst {100 * p.worst:.3g} % at {p.worst_at:g} °C"
                          + (" (written)" if d.key == comparison.chosen else ""))
        ax.plot([p.worst_at], [100 * p.worst], marker="v", ms=10, color=line.get_color())
    ax.set_xlabel("temperature (°C)")
    ax.set_ylabel("peak residual creep (% of the step)")
    ax.set_title(f"Residual creep of a full-scale step over {comparison.low:g} .. {comparison.high:g} °C")
    ax.set_ylim(bottom=0)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    return ax


def _draw_schematic(ax, network: Network, plan) -> None:
    """The network's schematic as an image in ``ax``."""
    import io

    import matplotlib.image as mpimg

    from creepcomp.report.schematic import schematic_drawing

    png = schematic_drawing(network, plan, "matplotlib").get_imagedata("png")
    ax.imshow(mpimg.imread(io.BytesIO(png)))
    ax.set_axis_off()
    ax.set_title("Chosen parts")
