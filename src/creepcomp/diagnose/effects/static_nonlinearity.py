"""``static_nonlinearity``: the instantaneous response is not linear in load.

Model: the instantaneous signal (load units) is ``x + a2 x^2 / L + a3 x^3 / L^2`` with ``L``
the full-scale load (``load_scale``, the record's largest |load|); creep acts on it as on a
linear one. ``a2`` and ``a3`` are the deviations at full scale relative to full scale.
"""

from __future__ import annotations

import numpy as np

from creepcomp.fit.data import Data
from creepcomp.fit.structure import Applied, Param
from creepcomp.fit.solver import Fit
from creepcomp.diagnose.effects import SensorEffect

__all__ = ["deviation", "StaticNonlinearity", "EFFECT"]


def deviation(x, a2: float, a3: float, scale: float):
    """The nonlinear part ``a2 x^2 / L + a3 x^3 / L^2``."""
    r = np.asarray(x, float) / scale
    return scale * (a2 * r ** 2 + a3 * r ** 3)


class StaticNonlinearity(SensorEffect):
    name = "static_nonlinearity"
    vocabulary_index = 7
    # polynomial; saturating
    forms = ("poly", "tanh")
    programs = ("staircase", "sweep", "mixture", "random")
    parameters = ("a2", "a3")
    parameter_units = {"load_scale": "load"}
    summary = "an instantaneous response that is not linear in load"

    def settings(self, data: Data, base: Fit) -> tuple:
        return (("load_scale", data.load_scale),)

    def nonlinear_params(self, data, applied):
        return [Param("a2", -0.5, 0.5, scale=0.01), Param("a3", -0.5, 0.5, scale=0.01)]

    def starts(self, data, base, applied):
        return [{"a2": 0.0, "a3": 0.0}]

    def instant(self, data, s, p, applied):
        return s + deviation(s, p["a2"], p["a3"], applied.setting("load_scale"))

    def report(self, fit: Fit, applied: Applied) -> dict:
        return {"a2": fit.estimate(lambda v: v["static_nonlinearity.a2"]),
                "a3": fit.estimate(lambda v: v["static_nonlinearity.a3"]),
                "load_scale": (applied.setting("load_scale"), 0.0)}

    def extension(self, fit: Fit, applied: Applied) -> dict:
        return {"a2": fit.values["static_nonlinearity.a2"], "a3": fit.values["static_nonlinearity.a3"],
                "load_scale": applied.setting("load_scale")}

    def restore(self, entry, model, data):
        return (Applied(self, (("load_scale", float(entry["load_scale"])),)),
                {"static_nonlinearity.a2": float(entry["a2"]), "static_nonlinearity.a3": float(entry["a3"])})

    def precondition(self, data, delta, load, values, applied):
        a2, a3 = values["static_nonlinearity.a2"], values["static_nonlinearity.a3"]
        r = load / applied.setting("load_scale")
        slope = 1.0 + 2 * a2 * r + 3 * a3 * r ** 2
        return delta / np.where(np.abs(slope) > 0.1, slope, 0.1)

    def inverse(self, entry, model):
        # the polynomial must rise over the loads a record can hold (1.5 times full scale,
        # either sign) for each signal to have one load
        r = np.linspace(-1.5, 1.5, 301)
        if np.min(1.0 + 2 * float(entry["a2"]) * r + 3 * float(entry["a3"]) * r ** 2) <= 0:
            return None
        return "each sample's load from its instantaneous response x + a2 x^2/L + a3 x^3/L^2 (rising: one root)"

    def firmware_output(self, entry, model):
        scale = model.gain * float(entry["load_scale"])
        return {"polynomial": (float(entry["a2"]) / scale, float(entry["a3"]) / scale ** 2)}

    # -- generator ---------------------------------------------------------------------------
    def draw_default(self, rng, scales, mixture):
        if mixture and rng.uniform() < 0.3:
            return {"form": "tanh", "saturation": float(rng.uniform(0.15, 0.35))}
        return self.draw(rng, scales, "poly")

    def draw(self, rng, scales, form):
        if form == "tanh":
            return {"saturation": float(rng.uniform(0.15, 0.35))}
        return dict(a2=float(rng.choice([-1, 1]) * rng.uniform(0.005, 0.02)),
                    a3=float(rng.choice([-1, 1]) * rng.uniform(0.0, 0.02)))

    def sim_instant(self, path, p, s_after, s_before):
        fs = path.full_scale
        if p.get("form", "poly") == "poly":
            return tuple(u + deviation(u, p["a2"], p["a3"], fs) for u in (path.u_after, path.u_before))
        k = p["saturation"]               # tanh: compressive, 1 - tanh(k) / k at full scale
        return tuple(fs * np.tanh(k * u / fs) / k for u in (path.u_after, path.u_before))


EFFECT = StaticNonlinearity()
