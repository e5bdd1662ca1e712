"""Each result's ``plot(ax=None)``: one function per result type, drawing into the caller's
Axes (a new figure when None) and returning the Axes; nothing is closed or saved.

The pattern of every function here: ``ax = ax if ax is not None else new_axes()``, draw,
label with units, return ``ax``. The multi-panel plots of the command line's files
(:mod:`creepcomp.report.design`, :mod:`creepcomp.report.spice` ...) draw their main panel
into a given Axes the same way; :func:`creepcomp.report.common.save_axes` writes a file.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from creepcomp.report.common import plot_text, thin

__all__ = ["new_axes", "record_plot", "model_plot", "fit_result_plot", "diagnosis_plot", "circuit_plot",
           "correction_plot", "sizing_plot", "network_design_plot", "design_plot", "comparison_plot",
           "monte_carlo_plot", "tolerance_plot", "creep_test_plot", "firmware_plot", "verification_plot"]


def new_axes(figsize=(9, 4.5)):
    """The Axes of a new figure (pyplot's, so a notebook shows it)."""
    return plt.subplots(figsize=figsize)[1]


def _label(name: str, unit: str) -> str:
    unit = plot_text(unit)
    return f"{name} ({unit})" if unit else name


def record_plot(record, ax=None):
    """A record's signal against time, its load on a second axis."""
    ax = ax if ax is not None else new_axes()
    idx = thin(len(record))
    t = record.time[idx]
    ax.plot(t, record.signal[idx], lw=1.0, color="C0", label="signal")
    ax.set_xlabel("time (s)")
    ax.set_ylabel(_label("signal", record.unit("signal")))
    axl = ax.twinx()
    axl.plot(t, record.load[idx], lw=0.8, color="C2", alpha=0.7)
    axl.set_ylabel(_label("load", record.unit("load")), color="C2")
    ax.set_title(plot_text(record.source))
    ax.grid(True, alpha=0.3)
    return ax


def model_plot(model, ax=None):
    """The creep of a unit load step: the signal's rise over its instantaneous value (%)."""
    from creepcomp.analog.quality import step_residual

    ax = ax if ax is not None else new_axes()
    t, creep = step_residual(model, None)
    ax.plot(t, 100 * creep, label=f"beta0 {100 * model.beta0:.3g} %")
    ax.set_xscale("symlog", linthresh=max(min(model.tau) / 10, 1e-3))
    ax.set_xlabel("time after a load step (s)")
    ax.set_ylabel("creep (% of the instantaneous signal)")
    ax.axhline(100 * model.beta0, color="0.6", lw=0.8, ls="--")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    return ax


def fit_result_plot(result, ax=None, record=None):
    """A Prony fit: measured and fitted signal with the load (``record``: for the units)."""
    from creepcomp.report.diagnosis import plot_fit

    return plot_fit(result.data, result.fit, ax=ax if ax is not None else new_axes(), record=record)


def diagnosis_plot(diagnosis, ax=None, record=None):
    """A diagnosis: measured signal and the extended model's fit, with the load."""
    from creepcomp.report.diagnosis import plot_fit

    return plot_fit(diagnosis.data, diagnosis.extended, ax=ax if ax is not None else new_axes(),
                    record=record)


def circuit_plot(cd, ax=None):
    """A circuit diagnosis: the residual of the nominal and of the as-built network (V)."""
    ax = ax if ax is not None else new_axes()
    idx = thin(len(cd.data.time))
    t = cd.data.time[idx]
    ax.plot(t, cd.baseline.residual[idx], ".", ms=2, color="0.5", label="nominal network")
    ax.plot(t, cd.extended.residual[idx], ".", ms=2, color="C0", label=f"as built ({cd.extended.describe()})")
    ax.axhline(0, color="0.4", lw=0.8)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("residual, measured minus simulated (V)")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    return ax


def correction_plot(correction, ax=None):
    """A corrected record: raw, compensated and reference signals."""
    from creepcomp.digital.correctors import reference
    from creepcomp.report.digital import plot_correction

    c = correction
    return plot_correction(c.record.time, c.record.signal, c.compensated,
                           reference(c.record.load, c.model, c.method),
                           ax=ax if ax is not None else new_axes(),
                           title=f"{c.record.source}: {c.method} correction",
                           signal_unit=c.record.unit("signal"))


def sizing_plot(report, ax=None):
    """A sizing report: residual creep after a load step of the designs it compares."""
    from creepcomp.report.design import plot_design_comparison

    designs = {"uncorrected": None, "ideal": report.ideal, "chosen parts": report.chosen}
    if report.nearest is not None:
        designs["nearest values"] = report.nearest
    return plot_design_comparison(report.model, designs, ax=ax if ax is not None else new_axes())


def network_design_plot(design, ax=None):
    """A network design: residual creep after a load step of its sizing's designs (no
    network in range: the sensor's creep it was asked to cancel)."""
    if design.sizing is None:
        return model_plot(design.model, ax=ax)
    return sizing_plot(design.sizing, ax=ax)


def design_plot(design, ax=None):
    """A design: residual creep after a load step, with and without the network."""
    from creepcomp.report.design import plot_design_comparison

    return plot_design_comparison(design.model, {"uncorrected": None, "design": design.network},
                                  ax=ax if ax is not None else new_axes())


def comparison_plot(comparison, ax=None):
    """An ngspice comparison: the sensor and the corrected output of both simulators."""
    from creepcomp.report.spice import plot_comparison

    return plot_comparison(comparison, ax=ax if ax is not None else new_axes())


def _histogram(ax, values, nominal=None, limit=None, name="residual creep, peak"):
    ax.hist(100 * np.asarray(values), bins=60, color="C0", alpha=0.8)
    if nominal is not None:
        ax.axvline(100 * nominal, color="k", lw=1, label=f"nominal {100 * nominal:.3g} %")
    if limit is not None:
        ax.axvline(100 * limit, color="C3", lw=1, ls="--", label=f"limit {100 * limit:.3g} %")
    ax.set_xlabel(f"{name} (% of FS)")
    ax.set_ylabel("units")
    if nominal is not None or limit is not None:
        ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    return ax


def monte_carlo_plot(result, ax=None, metric: str = "peak"):
    """A Monte Carlo run: the histogram of a metric over the samples kept."""
    ax = ax if ax is not None else new_axes()
    return _histogram(ax, result.metrics.get(metric), limit=result.limit if metric == result.limit_metric else None,
                      name={"peak": "residual creep, peak", "final": "residual creep, final",
                            "hysteresis": "hysteresis"}[metric])


def tolerance_plot(report, ax=None):
    """A tolerance analysis: the histogram of its metric, the nominal design and the limit."""
    ax = ax if ax is not None else new_axes()
    r = report.result
    return _histogram(ax, r.metrics.get(report.metric), float(report.nominal.get(report.metric)[0]),
                      report.limit, name={"peak": "residual creep, peak", "final": "residual creep, final",
                                          "hysteresis": "hysteresis"}[report.metric])


def creep_test_plot(result, ax=None):
    """A creep test: the change over the hold at each temperature against the class's limit."""
    from creepcomp.report.creep_test import plot_creep_test

    return plot_creep_test(result, ax=ax if ax is not None else new_axes())


def firmware_plot(firmware, ax=None):
    """Generated firmware: the parts of its proven error bound (of full scale)."""
    ax = ax if ax is not None else new_axes()
    if firmware.bound is None:
        ax.text(0.5, 0.5, "no proven bound (the naive recursion)", ha="center", va="center",
                transform=ax.transAxes)
        return ax
    parts = dict(firmware.bound.terms, bound=firmware.bound.total_fs)
    ax.barh(list(parts), [max(v, 1e-300) for v in parts.values()], color="C0")
    ax.set_xscale("log")
    ax.set_xlabel("worst-case error (of full scale)")
    ax.set_title(f"{firmware.name}: {firmware.method}, {firmware.precision}")
    ax.grid(True, axis="x", alpha=0.3)
    return ax


def verification_plot(verification, ax=None):
    """A firmware check: the measured largest error beside the proven bound (of full scale)."""
    ax = ax if ax is not None else new_axes()
    bars = {"measured": verification.max_error_fs}
    if verification.bound_fs is not None:
        bars["proven bound"] = verification.bound_fs
    ax.barh(list(bars), [max(v, 1e-300) for v in bars.values()], color=["C0", "C1"][:len(bars)])
    ax.set_xscale("log")
    ax.set_xlabel("largest error against the float64 corrector (of full scale)")
    ax.grid(True, axis="x", alpha=0.3)
    return ax
