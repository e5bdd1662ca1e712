"""``rate_independent_hysteresis``: the output depends on the direction of the load history,
not on its speed (filler slip, friction): one play operator of a Prandtl-Ishlinskii model.

A play operator of ``width`` (load units: the full width of its dead band) follows the load
with a lag of half the width in the direction the load last moved, and holds while the load
reverses within the band. The model adds ``weight * (play(x) - x)`` to the signal (``weight``
in signal per load unit): on a branch that follows the load the slope is the gain, in the
dead band after a reversal it is ``gain - weight``; loading and unloading branches lie
``weight * width`` apart. The play starts from a virgin state at zero load.

A load that changes only by steps larger than the width (a staircase, load cycles) moves the
play by half the width after every step whatever the width is: the column is then the width
times a fixed shape, and only the loop height ``weight * width`` is determined. The widths
for which that holds are found from the load alone (:func:`undetermined_width`); a fitted
width among them is reported as not determined, with the loop height and the largest width
the record cannot tell apart. A sweep or small reversals (within the dead band) separate them.
"""

from __future__ import annotations

import numpy as np

from creepcomp.fit.data import Data
from creepcomp.fit.structure import Applied, Param
from creepcomp.fit.solver import Fit
from creepcomp.diagnose.effects import Effect

__all__ = ["REVERSAL_SHARE", "play", "one_way_reason", "undetermined_width", "RateIndependentHysteresis", "EFFECT"]

#: A load history "changes both ways" when its smaller direction (rises or falls, through a play of
#: 1 % of full scale) makes at least this share of its larger one.
REVERSAL_SHARE = 0.05


def play(x, width: float, initial: float = 0.0) -> np.ndarray:
    """Output of a play (backlash) operator of dead-band ``width`` for the input ``x``.

    ``y[n] = clip(y[n-1], x[n] - width/2, x[n] + width/2)`` from ``y[-1] = initial``, solved
    as a prefix composition of clip functions (a clip of a clip is a clip), in log2(N)
    vectorised passes.
    """
    x = np.asarray(x, float)
    r = 0.5 * float(width)
    lo, hi = x - r, x + r
    shift = 1
    while shift < len(x):
        # element i holds the composition over (i - shift, i]; compose it after (i - 2 shift, i - shift]
        new_lo = np.clip(lo[:-shift], lo[shift:], hi[shift:])
        new_hi = np.clip(hi[:-shift], lo[shift:], hi[shift:])
        lo[shift:], hi[shift:] = new_lo, new_hi
        shift *= 2
    return np.clip(initial, lo, hi)


def one_way_reason(data: Data) -> str | None:
    """Why a record's load history cannot show a direction-dependent effect (its load changes
    in one direction only, e.g. one step without release), or None."""
    x = data.load
    p = play(x, 0.01 * data.load_scale, initial=x[0])
    d = np.diff(np.abs(p))
    up, down = float(np.sum(d[d > 0])), float(-np.sum(d[d < 0]))
    if min(up, down) < REVERSAL_SHARE * max(up, down, 1e-300):
        return ("the load's magnitude only " + ("rises" if up > down else "falls") +
                ": a direction-dependent effect cannot be told from creep or an offset")
    return None


def undetermined_width(x, scale: float) -> float:
    """The largest width (load units) up to which the play's column ``play(x, w) - x`` is ``w``
    times one fixed shape for the load ``x`` (0: none), searched on a log grid from 1e-3 to 2
    times ``scale``: every width up to it fits the record equally with the weight scaled by
    its inverse."""
    x = np.asarray(x, float)
    grid = np.geomspace(1e-3, 2.0, 61) * scale
    shape = (play(x, grid[0]) - x) / grid[0]
    size = float(np.max(np.abs(shape))) or 1.0
    out = 0.0
    for w in grid[1:]:
        if np.max(np.abs((play(x, w) - x) / w - shape)) > 1e-6 * size:
            break
        out = float(w)
    return out


class RateIndependentHysteresis(Effect):
    name = "rate_independent_hysteresis"
    parameters = ("width", "weight")
    summary = "output that depends on the direction of the load history, not on time (play operator)"

    def applicable(self, data, structure):
        return super().applicable(data, structure) or one_way_reason(data)

    def settings(self, data: Data, base: Fit) -> tuple:
        return (("load_scale", data.load_scale),
                ("undetermined_width", undetermined_width(data.load, data.load_scale)))

    def nonlinear_params(self, data, applied):
        scale = applied.setting("load_scale")
        return [Param("width", 1e-3 * scale, 2.0 * scale, log=True)]

    def starts(self, data, base, applied):
        scale = applied.setting("load_scale")
        return [{"width": f * scale} for f in (0.02, 0.05, 0.1, 0.2, 0.4, 0.8)]

    def columns(self, data, s, h, lags, p, applied):
        return {"weight": play(s, p["width"]) - s}

    def report(self, fit: Fit, applied: Applied) -> dict:
        height = fit.estimate(lambda v: v["rate_independent_hysteresis.width"]
                              * v["rate_independent_hysteresis.weight"])
        bound = applied.setting("undetermined_width", 0.0)
        if self.width_undetermined(fit, applied):
            return {"width": (None, None), "weight": (None, None), "loop_height": height,
                    "width_at_most": (bound, None)}
        return {"width": fit.estimate(lambda v: v["rate_independent_hysteresis.width"]),
                "weight": fit.estimate(lambda v: v["rate_independent_hysteresis.weight"]),
                "loop_height": height}

    def width_undetermined(self, fit: Fit, applied: Applied) -> bool:
        """The fitted width is among those the record cannot tell apart (:func:`undetermined_width`)."""
        bound = applied.setting("undetermined_width", 0.0)
        return bool(bound) and fit.values["rate_independent_hysteresis.width"] <= bound * (1.0 + 1e-9)

    def note(self, fit: Fit, applied: Applied) -> str | None:
        if not self.width_undetermined(fit, applied):
            return None
        bound = applied.setting("undetermined_width", 0.0)
        return (f"the load changes only by steps larger than {bound:.4g} load units: every play width up to "
                f"that fits equally, so only the loop height (weight x width, the distance between the "
                f"loading and unloading branches) is determined; a sweep or small reversals would "
                f"separate width and weight")

    def extension(self, fit: Fit, applied: Applied) -> dict:
        return {"width": fit.values["rate_independent_hysteresis.width"],
                "weight": fit.values["rate_independent_hysteresis.weight"]}

    def restore(self, entry, model, data):
        return Applied(self, (("load_scale", data.load_scale),)), {
            "rate_independent_hysteresis.width": float(entry["width"]),
            "rate_independent_hysteresis.weight": float(entry["weight"])}

    def precondition(self, data, delta, load, values, applied):
        # the slope in load units is 1 on following branches and 1 - weight/gain in the dead
        # band: divide by the mean of the two (the defect correction then converges for any
        # weight/gain below 2 in size)
        ratio = values["rate_independent_hysteresis.weight"] / values["gain"]
        return delta / max(1.0 - 0.5 * ratio, 0.1)


EFFECT = RateIndependentHysteresis()
