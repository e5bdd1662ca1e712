"""``time_offset``: signal and load are not sampled at the same instant; ``delay`` in s,
signal later than load. The load the sensor saw at ``t`` is the load record at ``t - delay``
(interpolated linearly; held at its first value before the record)."""

from __future__ import annotations

import numpy as np

from creepcomp.fit.structure import Applied, Param
from creepcomp.fit.solver import Fit
from creepcomp.diagnose.effects import Effect

__all__ = ["shifted", "TimeOffset", "EFFECT"]


def shifted(time, values, delay: float) -> np.ndarray:
    """``values`` at ``time - delay`` (linear interpolation, ends held)."""
    return np.interp(np.asarray(time) - delay, time, values)


class TimeOffset(Effect):
    name = "time_offset"
    parameters = ("delay",)
    summary = "signal and load sampled at different instants"

    def nonlinear_params(self, data, applied):
        limit = min(0.1 * data.duration, 500.0 * data.dt_median)
        return [Param("delay", -limit, limit, scale=data.dt_median)]

    def starts(self, data, base, applied):
        dt = data.dt_median
        limit = min(0.1 * data.duration, 500.0 * dt)
        steps = [0.3, 1, 2, 4, 8, 16, 32, 64, 128]
        return [{"delay": sign * f * dt} for f in steps for sign in (1, -1) if f * dt < limit]

    def load_transform(self, data, x, p, applied):
        return shifted(data.time, x, p["delay"])

    def report(self, fit: Fit, applied: Applied) -> dict:
        return {"delay": fit.estimate(lambda v: v["time_offset.delay"])}

    def extension(self, fit: Fit, applied: Applied) -> dict:
        return {"delay": fit.values["time_offset.delay"]}

    def restore(self, entry, model, data):
        return Applied(self, ()), {"time_offset.delay": float(entry["delay"])}

    def precondition(self, data, delta, load, values, applied):
        return shifted(data.time, delta, -values["time_offset.delay"])


EFFECT = TimeOffset()
