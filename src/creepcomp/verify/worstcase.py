"""The worst case of a metric over a design's whole tolerance box, not only sampled points."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from creepcomp.io.jsonfiles import Design
from creepcomp.verify.tolerances import ToleranceSpec, factors
from creepcomp.verify.variants import evaluate, sweep_period_or_default

__all__ = ["WorstCase", "worst_case"]


@dataclass(frozen=True)
class WorstCase:
    """The largest metric over the tolerance box and where it is."""

    metric: str
    value: float
    at: dict
    corners: int
    method: str


#: Forward-difference step of the local search, in units of each factor's tolerance span
#: (L-BFGS-B's own default).
GRADIENT_STEP = 1e-8


def worst_case(design: Design, spec: ToleranceSpec, metric: str = "peak",
               sweep_period: float | None = None, max_corners: int = 4096, seed: int = 0) -> WorstCase:
    """Worst case of a metric over the whole tolerance box, not only sampled points.

    Every corner of the box is evaluated (a random subset when there are more than
    ``max_corners``), then a bounded local search (L-BFGS-B) starts from the worst corners
    and from the nominal point.
    """
    period = sweep_period_or_default(design.model, sweep_period)
    box = [f for f in factors(design, spec) if f.high > f.low]
    if not box:
        m = evaluate(design, {}, period, spec.dielectric, spec.temperature,
                     over=spec.over_temperature).get(metric)
        return WorstCase(metric, float(m[0]), {}, 1, "nominal (nothing varies)")
    m = len(box)
    lows = np.array([f.low for f in box])
    highs = np.array([f.high for f in box])
    if 2 ** m <= max_corners:
        bits = (np.arange(2 ** m)[:, None] >> np.arange(m)[None, :]) & 1
        method = f"all {2 ** m} corners"
    else:
        bits = np.random.default_rng(seed).integers(0, 2, (max_corners, m))
        method = f"{max_corners} random corners of {2 ** m}"
    corners = np.where(bits == 1, highs, lows)

    def metric_at(points: np.ndarray) -> np.ndarray:
        vals = {f.name: points[:, j] for j, f in enumerate(box)}
        return evaluate(design, vals, period, spec.dielectric, spec.temperature,
                        over=spec.over_temperature).get(metric)

    corner_values = metric_at(corners)
    starts = list(corners[np.argsort(corner_values)[-3:]]) + [np.array([f.nominal for f in box])]
    scale = highs - lows
    best_x, best_v = corners[np.argmax(corner_values)], float(corner_values.max())
    from scipy import optimize

    def negative_with_gradient(z: np.ndarray) -> tuple[float, np.ndarray]:
        # the point and its m forward-difference neighbours in one batch (a step back at the
        # upper bound): one evaluation per iteration, not m + 1
        step = np.where(z + GRADIENT_STEP <= 1.0, GRADIENT_STEP, -GRADIENT_STEP)
        points = np.vstack([z, z + np.diag(step)])
        v = metric_at(lows + points * scale)
        return -float(v[0]), -(v[1:] - v[0]) / step

    for x0 in starts:
        res = optimize.minimize(negative_with_gradient, (x0 - lows) / scale, jac=True,
                                method="L-BFGS-B", bounds=[(0, 1)] * m, options={"maxiter": 60})
        if -res.fun > best_v:
            best_v, best_x = float(-res.fun), lows + res.x * scale
    return WorstCase(metric, best_v, {f.name: float(v) for f, v in zip(box, best_x)},
                     len(corners), method + " + bounded local search")
