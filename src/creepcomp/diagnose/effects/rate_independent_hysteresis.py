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
that fit as well as the fitted one are found from the load's column shapes
(:class:`PlayShapes`); when they reach beyond 20 % either way, the width and the weight are
reported as not determined, with the loop height and the range of widths that fit as well,
and the model file holds the widest of them (the smallest weight for the loop height: the
dead band's slope ``gain - weight`` nearest the gain, so the correction's inverse of the play
is the best conditioned of the models that fit as well). A sweep or small reversals (within
the dead band) separate them.
"""

from __future__ import annotations

import numpy as np

from creepcomp.lti import compiled_active
from creepcomp.fit.data import Data
from creepcomp.fit.structure import Applied, Param
from creepcomp.fit.solver import Fit
from creepcomp.diagnose.effects import SensorEffect

__all__ = ["REVERSAL_SHARE", "WIDTH_CHI2", "WIDTH_DETERMINED", "play", "play_loop", "one_way_reason", "PlayShapes", "RateIndependentHysteresis", "EFFECT"]

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
    if compiled_active():           # (the same values: a clip picks one of its bounds)
        from creepcomp import recursions

        out = np.empty(len(x))
        recursions.play(x, float(width), float(initial), out)
        return out
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


#: Widths whose column, at the fitted loop height and with nothing else refitted, moves the
#: fit's sum of squares by at most this many noise variances fit the record as well.
WIDTH_CHI2 = 4.0
#: A fitted width is reported when the widths that fit as well stay within this factor of it.
WIDTH_DETERMINED = 1.2
#: A play no wider than this many RMS of the reference load's own noise is that noise's dead
#: band (white noise stays within about 3 RMS either way), not the sensor's hysteresis: a
#: model driven by a noisy reference is helped by any operator that smooths it.
REFERENCE_WIDTH = 6.0


class PlayShapes:
    """The play's column per unit width, ``(play(x, w) - x) / w``, on one load history over a
    log grid of widths from 1e-3 to 2 times ``scale`` (about 8 % apart; computed when first
    asked). A load that changes only by steps larger than ``w`` gives the same shape for
    every such ``w``: the column is the width times it."""

    def __init__(self, load, scale: float):
        self.load = np.asarray(load, float)
        self.widths = np.geomspace(1e-3, 2.0, 97) * scale
        self._shapes = None

    def shape(self, width: float) -> np.ndarray:
        """The column per unit width at one width."""
        return (play(self.load, width) - self.load) / width

    def as_good(self, width: float, height: float, sigma: float) -> tuple[float, float]:
        """The smallest and largest grid width (or ``width``) whose column of the same loop
        height ``height`` differs from the fitted one by at most :data:`WIDTH_CHI2` noise
        variances ``sigma**2`` in sum of squares (an upper bound: nothing else refitted)."""
        if self._shapes is None:
            self._shapes = np.array([self.shape(w) for w in self.widths])
        change = height ** 2 * np.sum((self._shapes - self.shape(width)) ** 2, axis=1)
        close = self.widths[change <= WIDTH_CHI2 * sigma ** 2]
        return (float(min(width, close.min())) if len(close) else width,
                float(max(width, close.max())) if len(close) else width)


class RateIndependentHysteresis(SensorEffect):
    name = "rate_independent_hysteresis"
    vocabulary_index = 10
    # one play on the output; several on the load, before creep
    forms = ("play", "distributed")
    programs = ("sweep", "staircase", "mixture", "cycles")
    parameters = ("width", "weight")
    parameter_units = {"width": "load", "width_range": "load", "weight": "signal/load", "loop_height": "signal"}
    summary = "output that depends on the direction of the load history, not on time (play operator)"

    def applicable(self, data, structure):
        return super().applicable(data, structure) or one_way_reason(data)

    def settings(self, data: Data, base: Fit) -> tuple:
        return (("load_scale", data.load_scale),
                ("shapes", PlayShapes(data.load, data.load_scale)),
                ("reference_noise", data.reference_noise))

    def nonlinear_params(self, data, applied):
        scale = applied.setting("load_scale")
        return [Param("width", 1e-3 * scale, 2.0 * scale, log=True)]

    def starts(self, data, base, applied):
        scale = applied.setting("load_scale")
        return [{"width": f * scale} for f in (0.02, 0.05, 0.1, 0.2, 0.4, 0.8)]

    def fit_on(self, data, base, refine="all", start=None, settings=None, quick_fit=None):
        fit = super().fit_on(data, base, refine, start, settings, quick_fit)
        if start is not None or refine == "none" or base.structure.effects:
            return fit
        # on the baseline alone: its one term may have taken the hysteresis's place (a play of
        # negative weight on a sweep looks like a fast relaxing term)
        own = self.starts(data, base, Applied(self, (("load_scale", data.load_scale),)))
        return self.with_tau_restarts(data, base, fit, own, settings, quick_fit)

    columns_from_lags = False

    def columns(self, data, s, h, lags, p, applied):
        return {"weight": play(s, p["width"]) - s}

    def unphysical(self, fit: Fit, applied: Applied) -> str | None:
        noise = applied.setting("reference_noise")
        width = fit.values["rate_independent_hysteresis.width"]
        if noise and width <= REFERENCE_WIDTH * noise:
            return (f"a play {width:.3g} load units wide is within the reference load's own noise "
                    f"({noise:.3g} RMS): a dead band that smooths the reference's noise, not hysteresis")
        return None

    def report(self, fit: Fit, applied: Applied) -> dict:
        height = fit.estimate(lambda v: v["rate_independent_hysteresis.width"]
                              * v["rate_independent_hysteresis.weight"])
        span = self.widths_as_good(fit, applied)
        if span is not None:
            return {"width": (None, None), "weight": (None, None), "loop_height": height,
                    "width_range": ([span[0], span[1]], None)}
        return {"width": fit.estimate(lambda v: v["rate_independent_hysteresis.width"]),
                "weight": fit.estimate(lambda v: v["rate_independent_hysteresis.weight"]),
                "loop_height": height}

    def widths_as_good(self, fit: Fit, applied: Applied) -> tuple[float, float] | None:
        """The range of widths that fit the record as well as the fitted one
        (:meth:`PlayShapes.as_good`) when it reaches beyond :data:`WIDTH_DETERMINED` times it
        either way (the width is not determined), else None."""
        shapes = applied.setting("shapes")
        if shapes is None:
            return None
        width = fit.values["rate_independent_hysteresis.width"]
        height = width * fit.values["rate_independent_hysteresis.weight"]
        lo, hi = shapes.as_good(width, height, fit.residual_rms)
        return (lo, hi) if lo < width / WIDTH_DETERMINED or hi > width * WIDTH_DETERMINED else None

    def note(self, fit: Fit, applied: Applied) -> str | None:
        span = self.widths_as_good(fit, applied)
        if span is None:
            return None
        return (f"only the loop height (weight x width, the distance between the loading and unloading "
                f"branches) is determined: any play width from {span[0]:.4g} to {span[1]:.4g} load units "
                f"fits as well (the load moves by steps larger than the dead band, so the play only "
                f"shifts by half its width); a sweep or small reversals would separate width and weight")

    def extension(self, fit: Fit, applied: Applied) -> dict:
        width = fit.values["rate_independent_hysteresis.width"]
        weight = fit.values["rate_independent_hysteresis.weight"]
        span = self.widths_as_good(fit, applied)
        if span is not None:
            # only the loop height is determined; the width the optimiser stopped at is
            # arbitrary, and a narrow one gives weight >> gain, a dead band whose slope runs
            # against the load and a correction that diverges. Of the widths that fit as well,
            # the widest: the same loop, the dead band's slope nearest the gain.
            height = width * weight
            width = span[1]
            weight = height / width
        return {"width": width, "weight": weight}

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

    def inverse(self, entry, model):
        if float(entry["weight"]) / model.gain >= 1.0:
            # in the dead band after a reversal the slope gain - weight is not of the gain's
            # sign: one signal, several loads
            return None
        return "weight (play(x) - x), the play operator run on the load found up to each sample, taken out of the signal"

    def firmware_output(self, entry, model):
        # in signal units X = gain x: weight (play(x) - x) = ratio (play(X) - X), the play's
        # half width |gain| width / 2; it starts virgin at zero
        return {"play": {"ratio": float(entry["weight"]) / model.gain,
                         "half_width": 0.5 * abs(model.gain) * float(entry["width"])}}

    # -- generator ---------------------------------------------------------------------------
    def draw(self, rng, scales, form):
        s = scales
        out = dict(width=float(rng.uniform(0.05, 0.25) * s.signal_scale / abs(s.gain)),
                   weight=float(rng.choice([-1, 1], p=[0.2, 0.8]) * rng.uniform(0.03, 0.1) * s.gain))
        if form == "distributed":
            out["spread"] = float(rng.uniform(0.3, 0.7))
        return out

    def truth(self, p, synthetic):
        return {"width": p["width"], "weight": p["weight"], "loop_height": p["width"] * p["weight"]}

    def sim_instant(self, path, p, s_after, s_before):
        if p.get("form") != "distributed":
            return s_after, s_before
        # friction in the mechanics: several plays on the load, before creep
        extra = p["weight"] / path.gain * _plays(p, path.u_after, path.u_before)
        return s_after + extra[1], s_before + extra[0]

    def sim_output(self, path, p, y):
        if p.get("form", "play") != "play":
            return y
        return y + p["weight"] * _plays(p, path.u_after, path.u_before)[1]


EFFECT = RateIndependentHysteresis()


def play_loop(x, width: float, initial: float = 0.0) -> np.ndarray:
    """A play (backlash) operator of dead-band ``width``, stepped sample by sample (the
    generator's reference for :func:`play`)."""
    r = 0.5 * width
    y, out = initial, []
    for v in np.asarray(x, float).tolist():
        y = min(max(y, v - r), v + r)
        out.append(y)
    return np.array(out)


def _plays(p: dict, u_after, u_before) -> np.ndarray:
    """The generator's hysteresis: the mean of ``play(u) - u`` over the hidden operators'
    widths, before and after each grid time (shape (2, N)); the grid holds every breakpoint,
    so the plays are exact there."""
    widths = [p["width"]] if p.get("form", "play") == "play" else \
        list(p["width"] * np.linspace(1.0 - p["spread"], 1.0 + p["spread"], 5))
    # interleave before/after values so that steps at grid points are followed exactly
    x = np.column_stack([u_before, u_after]).ravel()
    acc = np.zeros_like(x)
    for w in widths:
        acc += play_loop(x, w) - x
    acc /= len(widths)
    return acc.reshape(-1, 2).T
