"""``mullins_softening``: loading beyond the largest load seen so far responds differently from
reloading below it (first-cycle, Mullins softening of filled elastomers).

Model: with ``m`` the largest |load| seen so far, the instantaneous response (load units) is
the load itself on the virgin curve (``|x| = m``) and ``x (1 - softening (1 - |x| / m))``
below it: reloading responds less by the fraction ``softening`` near zero load and joins the
virgin curve at the past maximum. Creep acts on the response as on a linear one.
"""

from __future__ import annotations

import numpy as np

from creepcomp.fit.structure import Applied, Param
from creepcomp.fit.solver import Fit
from creepcomp.diagnose.effects import Effect

__all__ = ["past_maximum", "MullinsSoftening", "EFFECT"]


def past_maximum(x) -> np.ndarray:
    """The largest |x| up to each sample."""
    return np.maximum.accumulate(np.abs(np.asarray(x, float)))


def _below(x, m):
    """``1 - |x| / m`` (0 where nothing was loaded yet)."""
    return np.where(m > 0, 1.0 - np.abs(x) / np.where(m > 0, m, 1.0), 0.0)


class MullinsSoftening(Effect):
    name = "mullins_softening"
    parameters = ("softening",)
    summary = "reloading below the largest load so far responds differently (first-cycle softening)"

    def applicable(self, data, structure):
        reason = super().applicable(data, structure)
        if reason:
            return reason
        x = np.abs(data.load)
        if np.max(past_maximum(x) - x) < 0.05 * data.load_scale:
            return "the load never returns below its largest value so far: no reloading to compare"
        return None

    def nonlinear_params(self, data, applied):
        return [Param("softening", -0.9, 0.9, scale=0.1)]

    def starts(self, data, base, applied):
        return [{"softening": f} for f in (-0.1, 0.0, 0.1, 0.3)]

    def instant(self, data, s, p, applied):
        return s * (1.0 - p["softening"] * _below(s, past_maximum(s)))

    def report(self, fit: Fit, applied: Applied) -> dict:
        return {"softening": fit.estimate(lambda v: v["mullins_softening.softening"])}

    def extension(self, fit: Fit, applied: Applied) -> dict:
        return {"softening": fit.values["mullins_softening.softening"]}

    def restore(self, entry, model, data):
        return Applied(self, ()), {"mullins_softening.softening": float(entry["softening"])}

    def precondition(self, data, delta, load, values, applied):
        m = past_maximum(load)
        slope = 1.0 - values["mullins_softening.softening"] * (2.0 * _below(load, m) - 1.0)
        slope = np.where(np.abs(load) >= m, 1.0, slope)
        return delta / np.maximum(slope, 0.1)


EFFECT = MullinsSoftening()
