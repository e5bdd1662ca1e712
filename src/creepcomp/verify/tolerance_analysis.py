"""The whole tolerance analysis of a design, as ``creepcomp mc`` reports it: Monte Carlo,
nominal, worst case, sensitivity, tighter parts and the ngspice spot check."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from creepcomp.display import Shown
from creepcomp.errors import InputError
from creepcomp.io.jsonfiles import Design
from creepcomp.verify.montecarlo import MonteCarloResult, nominal_metrics, run_monte_carlo, spot_check
from creepcomp.verify.sensitivities import sensitivity, tighter_parts
from creepcomp.verify.tolerances import ToleranceSpec
from creepcomp.verify.variants import Metrics
from creepcomp.verify.worstcase import WorstCase, worst_case

__all__ = ["ToleranceReport", "analyse", "sensitivity_count", "SENSITIVITY_WORK", "MIN_SENSITIVITY_SAMPLES"]


@dataclass(frozen=True, eq=False)
class ToleranceReport(Shown):
    """Everything ``creepcomp mc`` reports."""

    result: MonteCarloResult
    metric: str
    limit: float | None
    nominal: Metrics
    worst: WorstCase | None
    sensitivities: list
    tightenings: list
    sensitivity_samples: int = 0
    spot_check: dict | None = None
    creep_test: dict | None = None

    def __repr__(self) -> str:
        from creepcomp.units import format_percent

        r = self.result
        p99 = r.percentiles(self.metric)["p99"]
        spec = ""
        if self.limit is not None:
            spec = f", yield {100 * r.yield_against(self.limit, self.metric)[0]:.2f} % within {format_percent(self.limit)}"
        dominant = f", dominant {self.sensitivities[0].factor}" if self.sensitivities else ""
        return f"<ToleranceReport {r.n:,} samples: {self.metric} p99 {format_percent(p99)} of FS{spec}{dominant}>"

    def to_pandas(self):
        """The samples kept (:meth:`MonteCarloResult.to_pandas`)."""
        return self.result.to_pandas()

    def to_dict(self) -> dict:
        """``mc --json``: ``n``, ``residual_creep_peak`` percentiles, ``seconds`` and the rest."""
        r = self.result
        out = {"n": r.n, "seed": r.seed, "seconds": r.seconds,
               "residual_creep_peak": r.percentiles("peak"),
               "residual_creep_final": r.percentiles("final"),
               "hysteresis": r.percentiles("hysteresis"),
               "sweep_period": r.sweep_period,
               "nominal": {"residual_creep_peak": float(self.nominal.peak[0]),
                           "residual_creep_final": float(self.nominal.final[0]),
                           "hysteresis": float(self.nominal.hysteresis[0])},
               "factors": [{"name": f.name, "nominal": f.nominal, "low": f.low, "high": f.high,
                            "distribution": f.distribution} for f in r.box],
               "metric": self.metric}
        if r.kept < r.n:
            out["percentile_resolution"] = {
                key: r.resolution(m) for key, m in (("residual_creep_peak", "peak"),
                                                    ("residual_creep_final", "final"),
                                                    ("hysteresis", "hysteresis"))}
            out["samples_kept"] = r.kept
        if self.limit is not None:
            y, se = r.yield_against(self.limit, self.metric)
            out["spec"] = {"metric": self.metric, "limit": self.limit, "yield": y, "yield_standard_error": se}
        if self.worst is not None:
            out["worst_case"] = {"metric": self.worst.metric, "value": self.worst.value,
                                 "at": self.worst.at, "method": self.worst.method}
        out["sensitivity"] = [{"factor": s.factor, "share": s.share, "p99_alone": s.p99_alone}
                              for s in self.sensitivities]
        out["tighter_parts"] = [{"part": t.factor, "tolerance_from": t.tolerance_from,
                                 "tolerance_to": t.tolerance_to, "dielectric": t.dielectric,
                                 "p99_from": t.p99_from, "p99_to": t.p99_to,
                                 "samples": self.sensitivity_samples} for t in self.tightenings]
        if self.spot_check is not None:
            out["spot_check"] = self.spot_check
        if r.temperatures:
            out["over_temperature"] = self.over_temperature()
        if self.creep_test is not None:
            out["creep_test"] = self.creep_test
        return out

    def over_temperature(self) -> dict:
        """``mc --temperatures --json``'s ``over_temperature``: percentiles (and yield) at each
        temperature, and over the range (each unit's worst temperature)."""
        r = self.result
        over = r.spec.over_temperature
        rows = []
        for k, t in enumerate(r.temperatures):
            row = {"temperature": t,
                   "nominal": {"residual_creep_peak": float(self.nominal.per_temperature.peak[0, k]),
                               "residual_creep_final": float(self.nominal.per_temperature.final[0, k]),
                               "hysteresis": float(self.nominal.per_temperature.hysteresis[0, k])},
                   "residual_creep_peak": r.percentiles_at(k, "peak"),
                   "residual_creep_final": r.percentiles_at(k, "final"),
                   "hysteresis": r.percentiles_at(k, "hysteresis"),
                   "worst_for": r.worst_temperature_counts[k] / r.n}
            if self.limit is not None:
                y, se = r.yield_at(k, self.limit, self.metric)
                row["yield"], row["yield_standard_error"] = y, se
            rows.append(row)
        worst = {"residual_creep_peak": r.percentiles("peak"),
                 "residual_creep_final": r.percentiles("final"),
                 "hysteresis": r.percentiles("hysteresis")}
        if self.limit is not None:
            worst["yield"], worst["yield_standard_error"] = r.yield_against(self.limit, self.metric)
        return {"temperatures": list(r.temperatures), "lot_correlation": over.lot_correlation,
                "tracking": over.plan.tracking, "per_temperature": rows, "worst": worst}


#: Variant-lags (variants x factors x lags: cells, shunt branches and creep terms) the
#: sensitivity and tighter-part runs each evaluate at most: a few seconds on one core.
SENSITIVITY_WORK = 2_000_000
#: Fewest samples per factor those runs take (a p99 needs some hundreds beyond it).
MIN_SENSITIVITY_SAMPLES = 1000


def sensitivity_count(design: Design, factors: int, asked: int) -> int:
    """Samples per factor for the sensitivity runs: ``asked``, or fewer (at least
    :data:`MIN_SENSITIVITY_SAMPLES`) where :data:`SENSITIVITY_WORK` would be exceeded.

    Examples
    --------
    >>> from creepcomp.data import built_network_design
    >>> sensitivity_count(built_network_design(), 3, 20_000)
    20000
    """
    network = design.network
    lags = design.model.n_terms + len(getattr(network, "cells", ())) + len(getattr(network, "shunt", ()))
    lags += len(getattr(network, "terms", ()))
    affordable = SENSITIVITY_WORK // max(1, factors * lags)
    return int(min(asked, max(MIN_SENSITIVITY_SAMPLES, affordable)))


def analyse(design: Design, spec: ToleranceSpec, n: int, seed: int = 0, metric: str = "peak",
            limit: float | None = None, sweep_period: float | None = None, worst: bool = True,
            sensitivity_samples: int = 20_000, progress: Callable[[str, int, int], None] | None = None,
            workers: int | None = None, spot_check_samples: int = 0) -> ToleranceReport:
    """Monte Carlo, nominal, worst case, sensitivity and tighter-part figures of a design.

    Parameters
    ----------
    design : Design
    spec : ToleranceSpec
    n : int
        Monte Carlo samples.
    seed : int
        Random seed.
    metric : {"peak", "final", "hysteresis"}
        The figure the specification, the worst case and the sensitivity are about.
    limit : float, optional
        Specification limit of that metric (fraction), for the yield.
    sweep_period : float, optional
        Hysteresis sweep period (s).
    worst : bool
        Search the worst case over the tolerance box.
    sensitivity_samples : int
        Samples per factor for the sensitivity and tighter-part runs (0: skip them); fewer
        for a large design (:func:`sensitivity_count`), the report says how many.
    progress : callable, optional
        ``progress(stage, done, total)``.
    workers : int, optional
        Processes for the main run.
    spot_check_samples : int
        Samples to run through ngspice and compare (0: none).

    Returns
    -------
    ToleranceReport
    """
    if metric not in ("peak", "final", "hysteresis"):
        raise InputError(f"metric '{metric}': use peak, final or hysteresis")
    count = (lambda done: progress("Monte Carlo", done, n)) if progress else None
    result = run_monte_carlo(design, spec, n, seed, sweep_period, workers=workers, progress=count,
                             limit=limit, metric=metric)
    period = result.sweep_period
    nominal = nominal_metrics(design, spec, period)
    wc = worst_case(design, spec, metric, period) if worst else None
    sens, tight = [], []
    if sensitivity_samples:
        sensitivity_samples = sensitivity_count(design, len(result.box), sensitivity_samples)
        if progress:
            progress("sensitivity", 0, 1)
        sens = sensitivity(result, metric, sensitivity_samples)
        tight = tighter_parts(design, spec, sensitivity_samples, seed, metric, period)
        if progress:
            progress("sensitivity", 1, 1)
    spot = None
    if spot_check_samples:
        if progress:
            progress("ngspice spot-check", 0, 1)
        spot = spot_check(result, spot_check_samples)
        if progress:
            progress("ngspice spot-check", 1, 1)
    return ToleranceReport(result, metric, limit, nominal, wc, sens, tight, sensitivity_samples, spot)
