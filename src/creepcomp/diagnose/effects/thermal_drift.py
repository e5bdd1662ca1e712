"""``thermal_drift``: an offset that follows temperature, ``coefficient`` in signal units per K.

The sensor's temperature may lag the thermometer's: the offset follows the recorded
temperature through a first-order lag of ``lag`` seconds (searched from two sample steps,
i.e. none, to a tenth of the record; 0 in model files that do not give it)."""

from __future__ import annotations

import numpy as np

from creepcomp.fit.data import Data
from creepcomp.fit.structure import Applied, Param
from creepcomp.fit.solver import Fit
from creepcomp.lti import lag_states
from creepcomp.diagnose.effects import Effect

__all__ = ["ThermalDrift", "EFFECT"]


class ThermalDrift(Effect):
    name = "thermal_drift"
    parameters = ("coefficient", "lag")
    needs = ("temperature",)
    summary = "an offset that follows temperature"

    def settings(self, data: Data, base: Fit) -> tuple:
        return (("reference_temperature", float(np.mean(data.temperature))),)

    def nonlinear_params(self, data, applied):
        lo = 2.0 * data.dt_median
        return [Param("lag", lo, max(0.1 * data.duration, 2.0 * lo), log=True)]

    def starts(self, data, base, applied):
        lo = 2.0 * data.dt_median
        return [{"lag": lo}] + [{"lag": f * data.duration} for f in (0.01, 0.04) if f * data.duration > lo]

    def columns(self, data, s, h, lags, p, applied):
        dT = data.temperature - applied.setting("reference_temperature")
        lag = p.get("lag", 0.0)
        if lag > 0:
            dT = lag_states(data.time, dT, [lag], hold=data.hold, initial="settled")[:, 0]
        return {"coefficient": dT}

    def report(self, fit: Fit, applied: Applied) -> dict:
        return {"coefficient": fit.estimate(lambda v: v["thermal_drift.coefficient"]),
                "lag": fit.estimate(lambda v: v["thermal_drift.lag"])}

    def extension(self, fit: Fit, applied: Applied) -> dict:
        return {"coefficient": fit.values["thermal_drift.coefficient"],
                "reference_temperature": applied.setting("reference_temperature"),
                "lag": fit.values["thermal_drift.lag"]}

    def restore(self, entry, model, data):
        return (Applied(self, (("reference_temperature", float(entry["reference_temperature"])),)),
                {"thermal_drift.coefficient": float(entry["coefficient"]),
                 "thermal_drift.lag": float(entry.get("lag", 0.0))})


EFFECT = ThermalDrift()
