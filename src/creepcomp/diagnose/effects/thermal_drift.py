"""``thermal_drift``: an offset that follows temperature, ``coefficient`` in signal units per K."""

from __future__ import annotations

import numpy as np

from creepcomp.fit.data import Data
from creepcomp.fit.structure import Applied
from creepcomp.fit.solver import Fit
from creepcomp.diagnose.effects import Effect

__all__ = ["ThermalDrift", "EFFECT"]


class ThermalDrift(Effect):
    name = "thermal_drift"
    parameters = ("coefficient",)
    needs = ("temperature",)
    summary = "an offset that follows temperature"

    def settings(self, data: Data, base: Fit) -> tuple:
        return (("reference_temperature", float(np.mean(data.temperature))),)

    def columns(self, data, s, h, lags, p, applied):
        return {"coefficient": data.temperature - applied.setting("reference_temperature")}

    def report(self, fit: Fit, applied: Applied) -> dict:
        return {"coefficient": fit.estimate(lambda v: v["thermal_drift.coefficient"])}

    def extension(self, fit: Fit, applied: Applied) -> dict:
        return {"coefficient": fit.values["thermal_drift.coefficient"],
                "reference_temperature": applied.setting("reference_temperature")}

    def restore(self, entry, model, data):
        return (Applied(self, (("reference_temperature", float(entry["reference_temperature"])),)),
                {"thermal_drift.coefficient": float(entry["coefficient"])})


EFFECT = ThermalDrift()
