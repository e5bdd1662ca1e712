"""``nonlinear_creep``: creep that depends on the load level.

Model: the creep terms are driven by ``s (1 + growth |s| / load_scale)`` instead of ``s``,
i.e. each ``beta_k`` becomes ``beta_k (1 + growth |s| / load_scale)``: ``growth`` is the
relative increase of creep at full-scale load (``load_scale``, the record's largest |load|);
and their retardation times are ``tau_k / (1 + acceleration |h| / load_scale)`` (creep that
runs faster under a higher load: ``acceleration`` is the relative increase of the rate at
full scale; 0 in model files that do not give it).

Fully refined, the template is also fitted with only one of the two free (the other at 0) and
the best by BIC kept: a parameter the record does not need would otherwise count against
the effect when a simpler one competes with it.
"""

from __future__ import annotations

import numpy as np

from creepcomp.fit.data import Data
from creepcomp.fit.structure import Applied, Param
from creepcomp.fit.solver import Fit
from creepcomp.diagnose.effects import SensorEffect
from creepcomp.errors import InputError

__all__ = ["NonlinearCreep", "EFFECT"]

#: The parameters left free in each shape of the template (the others at 0).
_SHAPES = (("growth", "acceleration"), ("growth",), ("acceleration",))

#: Least share of the record with the load between levels (10 ... 90 % of its largest
#: magnitude) for a dependence on the level to be told apart (a step program has about none).
_LEVELS_SHARE = 0.1

#: Least relative speed of creep under load (a time constant at most this many times longer).
_SLOWEST = 0.1


class NonlinearCreep(SensorEffect):
    name = "nonlinear_creep"
    vocabulary_index = 3
    # amplitude ~ load; ~ |load|^m; load-dependent time
    forms = ("linear", "power", "time")
    programs = ("staircase", "mixture", "random", "sweep")
    parameters = ("growth", "acceleration")
    parameter_units = {"load_scale": "load"}
    changes_lags = True
    summary = "creep whose amplitude or speed depends on the load level"

    def applicable(self, data, structure):
        reason = super().applicable(data, structure)
        if reason is None and _between_levels(data) < _LEVELS_SHARE:
            # with the load at zero or at one level, creep that depends on the level is
            # creep of one speed under load and another unloaded: asymmetric recovery
            return (f"the load is at zero or at its one level for all but "
                    f"{100 * _between_levels(data):.2g} % of the record: a dependence on the load "
                    f"level cannot be told from recovery at another speed")
        return reason

    def settings(self, data: Data, base: Fit) -> tuple:
        return (("load_scale", data.load_scale),)

    def nonlinear_params(self, data, applied):
        free = applied.setting("free", _SHAPES[0])
        return [p for p in (Param("growth", -0.95, 50.0, scale=0.1), Param("acceleration", -0.9, 20.0, scale=0.1))
                if p.name in free]

    def fit_on(self, data, base, refine="all", start=None, settings=None, quick_fit=None):
        if refine == "own" and start is None:
            # the base's time constants sit where the loaded speeds average: faster creep
            # under load is found only with them free (its starts move them, see starts)
            refine = "all"
        fit = super().fit_on(data, base, refine, start, settings, quick_fit)
        if settings is not None or start is None or refine != "all":
            return fit
        scale = self.settings(data, base)
        for free in _SHAPES[1:]:
            try:
                nested = super().fit_on(data, base, refine, start, scale + (("free", free),), quick_fit)
            except (InputError, np.linalg.LinAlgError, ValueError):
                continue
            if nested.bic < fit.bic:
                fit = nested
        return fit

    def starts(self, data, base, applied):
        # acceleration a at the record's mean load level leaves the base's average speed
        level = float(np.mean(np.abs(data.load))) / applied.setting("load_scale")
        return [{"growth": g, "acceleration": 0.0} for g in (-0.5, 0.0, 0.5, 2.0)] + \
            [dict({f"tau[{k}]": float(t) * (1.0 + a * level) for k, t in enumerate(base.taus)},
                  growth=0.0, acceleration=a) for a in (1.0, 3.0)]

    def creep_input(self, data, h, p, applied):
        return h * (1.0 + p.get("growth", 0.0) * np.abs(h) / applied.setting("load_scale"))

    def tau_factor(self, data, h, lags, taus, p, applied):
        level = 0.5 * (np.abs(h[:-1]) + np.abs(h[1:])) / applied.setting("load_scale")
        # a slowing (acceleration < 0) saturates: the creep input may exceed full scale (growth,
        # a clipped or overshooting record), and a time constant never reaches zero or below
        speed = np.maximum(1.0 + p.get("acceleration", 0.0) * level, _SLOWEST)
        return np.repeat((1.0 / speed)[:, None], len(taus), axis=1)

    def report(self, fit: Fit, applied: Applied) -> dict:
        return {"growth": _estimate(fit, "growth"), "acceleration": _estimate(fit, "acceleration"),
                "load_scale": (applied.setting("load_scale"), 0.0)}

    def extension(self, fit: Fit, applied: Applied) -> dict:
        return {"growth": fit.values.get("nonlinear_creep.growth", 0.0),
                "acceleration": fit.values.get("nonlinear_creep.acceleration", 0.0),
                "load_scale": applied.setting("load_scale")}

    def restore(self, entry, model, data):
        return (Applied(self, (("load_scale", float(entry["load_scale"])),)),
                {"nonlinear_creep.growth": float(entry["growth"]),
                 "nonlinear_creep.acceleration": float(entry.get("acceleration", 0.0))})

    def inverse(self, entry, model):
        return ("the creep terms driven by s (1 + growth |s|/L), their speed 1 + acceleration |s|/L, "
                "from the load found up to each sample")

    # -- generator ---------------------------------------------------------------------------
    def draw_default(self, rng, scales, mixture):
        if mixture and rng.uniform() < 0.3:
            return {"form": "power", "exponent": float(rng.uniform(1.5, 2.5))}
        return {"growth": float(rng.choice([-1, 1]) * rng.uniform(0.5, 1.0)
                                if rng.uniform() < 0.2 else rng.uniform(0.6, 2.0))}

    def draw(self, rng, scales, form):
        if form == "linear":
            return {"growth": float(rng.uniform(0.6, 2.0))}
        if form == "power":
            return {"exponent": float(rng.uniform(1.5, 2.5))}
        return {"acceleration": float(rng.uniform(1.0, 3.0))}

    def sim_creep_input(self, path, p, h_after, h_before):
        form = p.get("form", "linear")
        if form == "time":
            return h_after, h_before
        fs = path.full_scale
        if form == "linear":
            c = p["growth"]
            return h_after * (1.0 + c * np.abs(h_after) / fs), h_before * (1.0 + c * np.abs(h_before) / fs)
        m = p["exponent"]                                 # power law: creep ~ |s|^m
        return fs * np.sign(h_after) * np.abs(h_after / fs) ** m, fs * np.sign(h_before) * np.abs(h_before / fs) ** m

    def sim_tau_factor(self, path, p, factor):
        if p.get("form") != "time":
            return None
        # creep that runs faster under a higher load (stress-accelerated retardation)
        hm = 0.5 * (np.abs(path.h_after[:-1]) + np.abs(path.h_before[1:]))
        return factor / (1.0 + p["acceleration"] * hm / path.full_scale)[:, None]


def _between_levels(data: Data) -> float:
    """Share of the samples whose load is between 10 and 90 % of the largest magnitude."""
    level = np.abs(data.load) / data.load_scale
    return float(np.mean((level > 0.1) & (level < 0.9)))


def _estimate(fit: Fit, name: str) -> tuple[float, float]:
    """A parameter's value and standard deviation; (0, 0) where the shape fitted holds it at 0."""
    key = f"nonlinear_creep.{name}"
    return fit.estimate(lambda v: v[key]) if key in fit.values else (0.0, 0.0)


EFFECT = NonlinearCreep()

