"""What each factor does to a metric: its share of the Monte Carlo spread, the metric with
it alone varying, and what one standard tolerance tighter buys."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from creepcomp.io.jsonfiles import Design
from creepcomp.verify.montecarlo import MonteCarloResult, run_monte_carlo
from creepcomp.verify.tolerances import DIELECTRICS, ToleranceSpec
from creepcomp.verify.variants import evaluate

__all__ = ["RESISTOR_TOLERANCES", "Sensitivity", "first_order_index", "sensitivity",
           "Tightening", "tighter_parts"]


#: Standard tolerances that "a tighter part" steps to.
RESISTOR_TOLERANCES = (0.05, 0.01, 0.001)


@dataclass(frozen=True)
class Sensitivity:
    """What one factor does to the metric.

    Attributes
    ----------
    factor : str
    share : float
        First-order variance index ``Var(E[Y | X]) / Var(Y)`` from the Monte Carlo samples:
        the fraction of the spread this factor explains on its own.
    p99_alone : float
        p99 of the metric when only this factor varies (the others nominal).
    """

    factor: str
    share: float
    p99_alone: float


def first_order_index(x: np.ndarray, y: np.ndarray, bins: int = 50) -> float:
    """``Var(E[y | x]) / Var(y)`` estimated by averaging ``y`` in equal-count bins of ``x``,
    less the variance the bin means would show by chance."""
    var = float(np.var(y))
    if var == 0 or len(y) < 4 * bins:
        return 0.0
    groups = np.array_split(np.argsort(x, kind="stable"), bins)
    means = np.array([y[g].mean() for g in groups])
    chance = var / (len(y) / bins)
    return float(max(means.var() - chance, 0.0) / var)


def sensitivity(result: MonteCarloResult, metric: str = "peak", n_alone: int = 20_000) -> list[Sensitivity]:
    """Each factor's first-order share of the spread (from the Monte Carlo's kept samples: all
    of them, or its first block) and the p99 with that factor alone varying; largest share
    first."""
    y = result.metrics.get(metric)
    design, spec = result.design, result.spec
    out = []
    for f in result.box:
        if f.high <= f.low:
            continue
        share = first_order_index(result.values[f.name], y)
        alone = f.sample(np.random.default_rng(result.seed), n_alone)
        v = evaluate(design, {f.name: alone}, result.sweep_period, spec.dielectric,
                     spec.temperature, over=spec.over_temperature).get(metric)
        out.append(Sensitivity(f.name, share, float(np.percentile(v, 99))))
    return sorted(out, key=lambda s: -s.share)


@dataclass(frozen=True)
class Tightening:
    """What a tighter part buys."""

    factor: str
    tolerance_from: float
    tolerance_to: float
    p99_from: float
    p99_to: float
    dielectric: str | None = None


def tighter_parts(design: Design, spec: ToleranceSpec, n: int = 20_000, seed: int = 0,
                  metric: str = "peak", sweep_period: float | None = None) -> list[Tightening]:
    """For every part, the p99 of the metric with that part one standard tolerance tighter.

    Resistors step to 1 % then 0.1 %. Capacitors step to the next tolerance their dielectric
    is sold in; where there is none, to a 1 % polypropylene part (which also changes the
    absorption and leakage).
    """
    base = run_monte_carlo(design, spec, n, seed, sweep_period, workers=1).percentiles(metric)["p99"]
    out = []
    for label, kind, _ in design.network.parts():
        tol = spec.tolerance_of(label, kind)
        dielectric = spec.dielectric
        if kind == "C":
            offered = DIELECTRICS[dielectric].tolerances if dielectric else (0.2, 0.1, 0.05, 0.01)
            tighter = [t for t in offered if t < tol.rel - 1e-12]
            if not tighter and tol.rel > 0.01 + 1e-12:
                tighter, dielectric = [0.01], ("polypropylene" if dielectric else None)
        else:
            tighter = [t for t in RESISTOR_TOLERANCES if t < tol.rel - 1e-12]
        if not tighter:
            continue
        new = max(tighter)
        parts = dict(spec.parts)
        parts[label] = replace(tol, rel=new)
        tighter_spec = replace(spec, parts=parts, dielectric=dielectric)
        tighter_run = run_monte_carlo(design, tighter_spec, n, seed, sweep_period, workers=1)
        p99 = tighter_run.percentiles(metric)["p99"]
        out.append(Tightening(label, tol.rel, new, base, p99,
                              dielectric if dielectric != spec.dielectric else None))
    return sorted(out, key=lambda t: t.p99_to)
