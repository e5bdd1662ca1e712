"""``thermal_drift``: an offset that follows temperature, ``coefficient`` in signal units per K.

The offset follows the temperature the sensor element has, which may lag the one measured (a
thermocouple on the housing, the element inside it): the offset is
``coefficient`` times ``T - T_ref`` through a first-order lag of time constant ``lag`` (s;
fitted, from a tenth of a sample step, which is no lag at all, up to the record's length; 0 in
model files that do not give it). When the lagged form is not supported, the plain one
(no lag) is tried.
"""

from __future__ import annotations

import numpy as np

from creepcomp.fit.data import Data
from creepcomp.fit.structure import Applied, Param
from creepcomp.fit.solver import Fit
from creepcomp.lti import lag_states
from creepcomp.diagnose.effects import SensorEffect

__all__ = ["ThermalDrift", "EFFECT"]


def _shortest(data: Data) -> float:
    """A lag too short to matter (a tenth of the sample step)."""
    return 0.1 * data.dt_median


class ThermalDrift(SensorEffect):
    name = "thermal_drift"
    vocabulary_index = 5
    # offset ~ T; ~ T through the sensor's thermal lag
    forms = ("linear", "lagged")
    parameters = ("coefficient", "lag")
    parameter_units = {"coefficient": "signal/K", "lag": "s", "reference_temperature": "°C"}
    needs = ("temperature",)
    summary = "an offset that follows temperature (possibly through a thermal lag)"

    def settings(self, data: Data, base: Fit) -> tuple:
        return (("reference_temperature", float(np.mean(data.temperature))), ("lagged", True))

    def plain_settings(self, data: Data, base: Fit) -> tuple:
        return (("reference_temperature", float(np.mean(data.temperature))),)

    def nonlinear_params(self, data, applied):
        if not applied.setting("lagged", False):
            return []
        return [Param("lag", _shortest(data), max(data.span, 2.0 * _shortest(data)), log=True)]

    def starts(self, data, base, applied):
        if not applied.setting("lagged", False):
            return [{}]
        return [{"lag": _shortest(data)}] + [{"lag": f * data.span} for f in (0.01, 0.03, 0.1)
                                              if f * data.span > _shortest(data)]

    columns_from_lags = False

    def columns(self, data, s, h, lags, p, applied):
        dT = data.temperature - applied.setting("reference_temperature")
        lag = p.get("lag", 0.0)
        if lag > 0:
            dT = lag_states(data.sampling, dT, [lag], hold=data.hold, initial="settled")[:, 0]
        return {"coefficient": dT}

    def report(self, fit: Fit, applied: Applied) -> dict:
        out = {"coefficient": fit.estimate(lambda v: v["thermal_drift.coefficient"])}
        if "thermal_drift.lag" in fit.values:
            out["lag"] = fit.estimate(lambda v: v["thermal_drift.lag"])
        return out

    def extension(self, fit: Fit, applied: Applied) -> dict:
        return {"coefficient": fit.values["thermal_drift.coefficient"],
                "reference_temperature": applied.setting("reference_temperature"),
                "lag": fit.values.get("thermal_drift.lag", 0.0)}

    def restore(self, entry, model, data):
        lag = float(entry.get("lag", 0.0))
        reference = ("reference_temperature", float(entry["reference_temperature"]))
        values = {"thermal_drift.coefficient": float(entry["coefficient"])}
        if lag > 0:
            values["thermal_drift.lag"] = lag
            return Applied(self, (reference, ("lagged", True))), values
        return Applied(self, (reference,)), values

    def inverse(self, entry, model):
        lag = " through its first-order lag" if float(entry.get("lag", 0.0)) > 0 else ""
        return f"the offset coefficient (T - T_ref){lag}, from the record's temperature column, taken out of the signal"

    # -- generator ---------------------------------------------------------------------------
    def draw_default(self, rng, scales, mixture):
        # 0.02 ... 0.1 % of full scale per K
        return {"coefficient": float(rng.choice([-1, 1]) * rng.uniform(2e-4, 1e-3) * scales.signal_scale)}

    def draw(self, rng, scales, form):
        out = self.draw_default(rng, scales, False)
        if form == "lagged":
            out["lag"] = float(rng.uniform(0.01, 0.05) * scales.duration)
        return out

    def truth(self, p, synthetic):
        return {"coefficient": p["coefficient"]}

    def sim_output(self, path, p, y):
        dT = path.temperature - p["reference_temperature"]
        if p.get("form", "linear") == "lagged":
            dT = lag_states(path.grid, dT, [p["lag"]], hold="linear", initial="settled")[:, 0]
        return y + p["coefficient"] * dT


EFFECT = ThermalDrift()
