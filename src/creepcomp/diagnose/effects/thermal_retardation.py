"""``thermal_retardation``: retardation times that change with temperature.

Model: every term's time constant is ``tau_k exp(-kappa (T - T_ref))`` over each sample step
(T at the step's middle; ``tau_k`` is the value at the reference temperature, the record's
mean): ``kappa`` > 0 means faster creep when warmer (an Arrhenius law linearised around
``T_ref``: ``kappa = E_a / (R T_ref^2)``). ``kappa`` is kept >= 0: retardation in polymers
always speeds up with temperature (Arrhenius and WLF shift factors), and a negative value
would only be another effect (e.g. recovery slower than creep) seen through a temperature
history that happens to differ between loading and unloading. The extended model file
carries the Arrhenius law of the same slope as its ``temperature`` block too, with the
uncertainty of ``E_a`` from that of ``kappa``.

A strong temperature dependence (a WLF material near its glass transition: the time
constant changes by a decade over a few kelvin) can leave the baseline with a retardation
time where temperature cannot act (one far slower than the record, standing in for creep
whose speed follows temperature); the fit therefore also starts from a grid of retardation
times and ``kappa`` values, cheaply screened, and keeps that fit when it is better.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from creepcomp.fit.data import Data
from creepcomp.fit.structure import Applied, Param
from creepcomp.fit.solver import Fit
from creepcomp.temperature import GAS_CONSTANT, ZERO_CELSIUS, TemperatureLaw
from creepcomp.diagnose.effects import SensorEffect

__all__ = ["RESTART_KAPPAS", "ThermalRetardation", "EFFECT"]


#: ``kappa`` values (1/K) of the restarts from a grid of retardation times.
RESTART_KAPPAS = (0.05, 0.15, 0.45)


class ThermalRetardation(SensorEffect):
    name = "thermal_retardation"
    vocabulary_index = 6
    # shift factor Arrhenius; Williams-Landel-Ferry
    forms = ("arrhenius", "wlf")
    programs = ("staircase", "mixture", "random", "sweep")
    # the generator's factor on the retardation times comes before a load-dependent one's
    stage_order = 2.5
    parameters = ("kappa",)
    parameter_units = {"kappa": "1/K", "reference_temperature": "°C"}
    needs = ("temperature",)
    changes_lags = True
    summary = "retardation times that change with temperature"

    def settings(self, data: Data, base: Fit) -> tuple:
        return (("reference_temperature", float(np.mean(data.temperature))),)

    def nonlinear_params(self, data, applied):
        # retardation times of polymers shorten with temperature (Arrhenius, WLF): kappa >= 0
        return [Param("kappa", 0.0, 0.5, scale=0.01)]

    def starts(self, data, base, applied):
        return [{"kappa": k} for k in (0.005, 0.02, 0.06, 0.15)]

    def fit_on(self, data, base, refine="all", start=None, settings=None, quick_fit=None):
        fit = super().fit_on(data, base, refine, start, settings, quick_fit)
        if start is not None or refine == "none":
            return fit
        return self.with_tau_restarts(data, base, fit, [{"kappa": k} for k in RESTART_KAPPAS], settings, quick_fit)

    def tau_factor(self, data, h, lags, taus, p, applied):
        temp = 0.5 * (data.temperature[:-1] + data.temperature[1:])
        f = np.exp(-p["kappa"] * (temp - applied.setting("reference_temperature")))
        return np.repeat(f[:, None], len(taus), axis=1)

    def report(self, fit: Fit, applied: Applied) -> dict:
        return {"kappa": fit.estimate(lambda v: v["thermal_retardation.kappa"]),
                "reference_temperature": (applied.setting("reference_temperature"), 0.0)}

    def extension(self, fit: Fit, applied: Applied) -> dict:
        return {"kappa": fit.values["thermal_retardation.kappa"],
                "reference_temperature": applied.setting("reference_temperature")}

    def temperature_law(self, fit: Fit, applied: Applied) -> TemperatureLaw:
        # the Arrhenius law of the same slope at the reference: E_a = kappa R T_ref^2
        reference = applied.setting("reference_temperature")
        kappa, sd = fit.estimate(lambda v: v["thermal_retardation.kappa"])
        law = TemperatureLaw.from_kappa(kappa, reference)
        per_kappa = GAS_CONSTANT * (reference + ZERO_CELSIUS) ** 2
        return replace(law, uncertainty={"activation_energy": sd * per_kappa})

    def restore(self, entry, model, data):
        return (Applied(self, (("reference_temperature", float(entry["reference_temperature"])),)),
                {"thermal_retardation.kappa": float(entry["kappa"])})

    def inverse(self, entry, model):
        return ("every step's retardation times at the step's mid temperature, tau_k exp(-kappa (T - T_ref)), "
                "from the record's temperature column")

    # -- generator ---------------------------------------------------------------------------
    def draw_default(self, rng, scales, mixture):
        # activation energy 60 ... 150 kJ/mol: tau changes 7 ... 17 % per K near 300 K
        return {"activation": float(rng.uniform(60e3, 150e3) / 8.314)}

    def draw(self, rng, scales, form):
        if form == "wlf":
            return dict(c1=float(rng.uniform(8.0, 17.0)), c2=float(rng.uniform(50.0, 120.0)))
        return self.draw_default(rng, scales, False)

    def sim_tau_factor(self, path, p, factor):
        tm = 0.5 * (path.temperature[:-1] + path.temperature[1:])
        if p.get("form", "arrhenius") == "wlf":
            dT = tm - p["reference_temperature"]
            return factor * (10.0 ** (-p["c1"] * dT / (p["c2"] + dT)))[:, None]
        tk = tm + 273.15
        tref = p["reference_temperature"] + 273.15
        return factor * np.exp(p["activation"] * (1.0 / tk - 1.0 / tref))[:, None]


EFFECT = ThermalRetardation()
