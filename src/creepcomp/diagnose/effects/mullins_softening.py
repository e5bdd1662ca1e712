"""``mullins_softening``: loading beyond the largest load seen so far responds differently from
reloading below it (first-cycle, Mullins softening of filled elastomers).

Model: with ``m`` the largest |load| seen so far, the instantaneous response (load units) is
the load itself on the virgin curve (``|x| = m``) and ``x (1 - softening (1 - |x| / m))``
below it: reloading responds less by the fraction ``softening`` near zero load and joins the
virgin curve at the past maximum. Creep acts on the response as on a linear one.

The reloading curve's shape is fitted too: the factor is ``1 - softening g(1 - |x| / m)`` with
``g(z) = (1 - exp(-shape z)) / (1 - exp(-shape))`` (``shape`` 0: ``g(z) = z``, the chord above;
above 0 the softening saturates away from the past maximum and fades only close to it, as
damage models of filled rubber have it; reported beside ``softening``, 0 in model files that
do not give it). When the shaped form is not supported, the chord is tried.

A sensor loaded either way (an accelerometer over +-1 g) may instead soften with the largest
load magnitude it has seen, from either side, on the virgin curve as below it (``form =
"peak"``): the response is multiplied by ``1 - softening m / M``, ``M`` the record's largest
|load| (``load_scale`` in model files). It is fitted beside the reloading form when the
record reaches a new largest magnitude after a release (only then can it be told from the
gain), the better kept.
"""

from __future__ import annotations

import numpy as np

from creepcomp.fit.structure import Applied, Param
from creepcomp.fit.solver import Fit
from creepcomp.diagnose.effects import SensorEffect

__all__ = ["past_maximum", "MullinsSoftening", "EFFECT"]


def past_maximum(x) -> np.ndarray:
    """The largest |x| up to each sample."""
    return np.maximum.accumulate(np.abs(np.asarray(x, float)))


def _below(x, m):
    """``1 - |x| / m`` (0 where nothing was loaded yet)."""
    return np.where(m > 0, 1.0 - np.abs(x) / np.where(m > 0, m, 1.0), 0.0)


def _new_peaks(load) -> bool:
    """The load's magnitude reaches a new largest value, by 5 % of the record's largest, after
    it has been released by as much: a softening by the largest magnitude then shows apart
    from the gain."""
    x = np.abs(np.asarray(load, float))
    scale = float(np.max(x)) if len(x) else 0.0
    if scale <= 0:
        return False
    m = past_maximum(x)
    released = np.maximum.accumulate(m - x >= 0.05 * scale)
    rise = np.concatenate([[0.0], np.diff(m)])
    return bool(np.sum(rise[released]) >= 0.05 * scale)


def _peak_factor(x, scale: float, softening: float) -> np.ndarray:
    """``1 - softening m / scale``, ``m`` the largest |x| so far."""
    return 1.0 - softening * past_maximum(x) / scale


#: A shape closer to 0 than this is the chord (``g(z) = z``).
_CHORD = 1e-6


def _shaped(z, shape: float):
    """``g(z)``, the reloading curve's shape, and its derivative, for ``z`` in [0, 1]."""
    if abs(shape) < _CHORD:
        return z, np.ones_like(z)
    return np.expm1(-shape * z) / np.expm1(-shape), -shape * np.exp(-shape * z) / np.expm1(-shape)


class MullinsSoftening(SensorEffect):
    name = "mullins_softening"
    vocabulary_index = 11
    # linear reloading curve; tanh-shaped damage; softening by the largest magnitude so far
    forms = ("chord", "damage", "peak")
    programs = ("cycles",)
    # the generator softens the load's own response before a distributed hysteresis adds to it
    stage_order = 9.5
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

    def settings(self, data, base):
        return (("shaped", True),)

    def fit_on(self, data, base, refine="all", start=None, settings=None, quick_fit=None):
        if settings is not None or not _new_peaks(data.load):
            return super().fit_on(data, base, refine, start, settings, quick_fit)
        peak = (("form", "peak"), ("load_scale", data.load_scale))
        forms = (self.settings(data, base), peak)
        if start is not None:
            # a refinement from a fit of one form (the shaped one has a shape): that form only
            forms = forms[:1] if f"{self.name}.shape" in start else forms[1:]
        return min((super(MullinsSoftening, self).fit_on(data, base, refine, start, s, quick_fit) for s in forms),
                   key=lambda f: f.bic)

    def plain_settings(self, data, base):
        return ()

    def nonlinear_params(self, data, applied):
        out = [Param("softening", -0.9, 0.9, scale=0.1)]
        if applied.setting("shaped", False):
            out.append(Param("shape", -5.0, 20.0))
        return out

    def starts(self, data, base, applied):
        if applied.setting("form") == "peak":
            return [{"softening": f} for f in (-0.2, -0.05, 0.05, 0.2)]
        plain = [{"softening": f, "shape": 0.0} for f in (-0.1, 0.0, 0.1, 0.3)]
        if not applied.setting("shaped", False):
            return plain
        return plain + [{"softening": f, "shape": a} for f in (0.1, 0.3) for a in (2.0, 6.0)]

    def instant(self, data, s, p, applied):
        if applied.setting("form") == "peak":
            return s * _peak_factor(s, applied.setting("load_scale"), p["softening"])
        return s * (1.0 - p["softening"] * _shaped(_below(s, past_maximum(s)), p.get("shape", 0.0))[0])

    def report(self, fit: Fit, applied: Applied) -> dict:
        out = {"softening": fit.estimate(lambda v: v["mullins_softening.softening"])}
        if "mullins_softening.shape" in fit.values:
            out["shape"] = fit.estimate(lambda v: v["mullins_softening.shape"])
        if applied.setting("form") == "peak":
            out["form"] = ("peak", None)
        return out

    def extension(self, fit: Fit, applied: Applied) -> dict:
        if applied.setting("form") == "peak":
            return {"softening": fit.values["mullins_softening.softening"], "form": "peak",
                    "load_scale": float(applied.setting("load_scale"))}
        return {"softening": fit.values["mullins_softening.softening"],
                "shape": fit.values.get("mullins_softening.shape", 0.0)}

    def restore(self, entry, model, data):
        values = {"mullins_softening.softening": float(entry["softening"])}
        if entry.get("form", "reloading") == "peak":
            return Applied(self, (("form", "peak"), ("load_scale", float(entry["load_scale"])))), values
        if float(entry.get("shape", 0.0)) != 0.0:
            values["mullins_softening.shape"] = float(entry["shape"])
            return Applied(self, (("shaped", True),)), values
        return Applied(self, ()), values

    def precondition(self, data, delta, load, values, applied):
        m = past_maximum(load)
        if applied.setting("form") == "peak":
            sigma = values["mullins_softening.softening"] / applied.setting("load_scale")
            # d/dx of x (1 - sigma m): on the virgin curve m = |x| moves with x
            slope = np.where(np.abs(load) >= m, 1.0 - 2.0 * sigma * m, 1.0 - sigma * m)
            return delta / np.maximum(slope, 0.1)
        z = _below(load, m)
        g, dg = _shaped(z, values.get("mullins_softening.shape", 0.0))
        sigma = values["mullins_softening.softening"]
        # d/dx of x (1 - sigma g(z)), z = 1 - |x| / m
        slope = 1.0 - sigma * g + sigma * (1.0 - z) * dg
        slope = np.where(np.abs(load) >= m, 1.0, slope)
        return delta / np.maximum(slope, 0.1)

    def inverse(self, entry, model):
        # the reloading curve x (1 - softening g(z)), z = 1 - |x|/m, must rise in |x| for
        # one load per signal: its slope 1 - softening (g(z) - (1 - z) g'(z)) above 0
        z = np.linspace(0.0, 1.0, 201)
        g, dg = _shaped(z, float(entry.get("shape", 0.0)))
        if np.min(1.0 - float(entry["softening"]) * (g - (1.0 - z) * dg)) <= 0:
            return None
        return ("each sample's load from the reloading curve x (1 - softening g(1 - |x|/m)), m the running "
                "maximum of the load found so far")

    def firmware_output(self, entry, model):
        softening = float(entry["softening"])
        if entry.get("form", "reloading") == "peak":
            # x (1 - softening m / M) in signal units: m and M scale with |gain|
            return {"peak": {"softening": softening, "scale": abs(model.gain) * float(entry["load_scale"])}}
        return {"reloading": {"softening": softening, "shape": float(entry.get("shape", 0.0)),
                              "chord": _CHORD}}

    # -- generator ---------------------------------------------------------------------------
    def draw(self, rng, scales, form):
        if form == "peak":
            return {"softening": float(rng.choice([-1, 1]) * rng.uniform(0.05, 0.2))}
        out = {"softening": float(rng.uniform(0.1, 0.3))}
        if form == "damage":
            out["shape"] = float(rng.uniform(0.2, 0.6))
        return out

    def truth(self, p, synthetic):
        return {"softening": p["softening"]}

    def program_choices(self, p, tau, choices, given):
        if p.get("form") == "peak" and not given:
            # new largest magnitudes after releases, from one side or from both
            return ["cycles", "bipolar"]
        return choices

    def sim_response(self, path, p, y):
        if p.get("form") != "peak":
            return y
        # the whole response multiplied, by the largest |load| so far over the record's largest
        u = np.column_stack([path.u_before, path.u_after]).ravel()
        m = past_maximum(u).reshape(-1, 2)[:, 1]
        return y * (1.0 - p["softening"] * m / float(np.max(np.abs(u))))

    def sim_instant(self, path, p, s_after, s_before):
        if p.get("form") == "peak":
            return s_after, s_before
        # the response to the load itself, softened below the largest |load| so far
        x = np.column_stack([path.u_before, path.u_after]).ravel()
        below = _below(x, past_maximum(x))
        sigma = p["softening"]
        if p.get("form", "chord") == "damage":
            b = p["shape"]
            factor = 1.0 - sigma * np.tanh(below / b) / np.tanh(1.0 / b)
        else:
            factor = 1.0 - sigma * below
        s = (x * factor).reshape(-1, 2).T
        return s[1], s[0]


EFFECT = MullinsSoftening()
