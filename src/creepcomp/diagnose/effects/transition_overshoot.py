"""``transition_overshoot``: every load change, up or down, adds a transient of one sign,
proportional to the size of the change, that decays (the "shoulder peak" of conductive-filler
elastomers: the filler network breaks on every change and re-forms).

Model: with ``v(t)`` the load's total variation (the sum of |load changes| so far, through a
play operator of 0.1 % of full scale so that noise on a measured load does not count), the
signal gets ``amplitude * (v - lag_tau(v))``: after a change of size ``dL`` a transient
``amplitude * |dL| * exp(-t / tau)``. ``amplitude`` is in signal units per unit load change.
"""

from __future__ import annotations

import numpy as np

from creepcomp.fit.data import Data
from creepcomp.fit.structure import Applied, Param
from creepcomp.fit.solver import Fit
from creepcomp.lti import lag_states
from creepcomp.diagnose.effects import Effect
from creepcomp.diagnose.effects.rate_independent_hysteresis import one_way_reason, play

__all__ = ["DEAD_BAND", "total_variation", "TransitionOvershoot", "EFFECT"]

#: Load changes smaller than this fraction of full scale (back and forth) do not count.
DEAD_BAND = 1e-3


def total_variation(x, dead_band: float = 0.0) -> np.ndarray:
    """The sum of |changes| of ``x`` up to each sample (through a play of ``dead_band``)."""
    x = np.asarray(x, float)
    p = play(x, dead_band, initial=x[0]) if dead_band > 0 else x
    return np.concatenate([[0.0], np.cumsum(np.abs(np.diff(p)))])


class TransitionOvershoot(Effect):
    name = "transition_overshoot"
    parameters = ("amplitude", "tau")
    summary = "a decaying transient of one sign after every load change, up or down"

    def applicable(self, data, structure):
        # on a load that only rises, an overshoot is a creep term of negative beta
        return super().applicable(data, structure) or one_way_reason(data)

    def settings(self, data: Data, base: Fit) -> tuple:
        return (("load_scale", data.load_scale),)

    def nonlinear_params(self, data, applied):
        lo, hi = data.tau_limits()
        return [Param("tau", lo, hi, log=True)]

    def starts(self, data, base, applied):
        lo, hi = data.tau_limits()
        return [{"tau": float(t)} for t in np.geomspace(2 * lo, min(hi, data.span) / 3, 7)]

    def columns(self, data, s, h, lags, p, applied):
        v = total_variation(s, DEAD_BAND * applied.setting("load_scale"))
        return {"amplitude": v - lag_states(data.time, v, [p["tau"]], hold=data.hold,
                                            initial="settled")[:, 0]}

    def report(self, fit: Fit, applied: Applied) -> dict:
        return {"amplitude": fit.estimate(lambda v: v["transition_overshoot.amplitude"]),
                "tau": fit.estimate(lambda v: v["transition_overshoot.tau"])}

    def extension(self, fit: Fit, applied: Applied) -> dict:
        return {"amplitude": fit.values["transition_overshoot.amplitude"],
                "tau": fit.values["transition_overshoot.tau"],
                "load_scale": applied.setting("load_scale")}

    def restore(self, entry, model, data):
        return Applied(self, (("load_scale", float(entry.get("load_scale", data.load_scale))),)), {
            "transition_overshoot.amplitude": float(entry["amplitude"]),
            "transition_overshoot.tau": float(entry["tau"])}


EFFECT = TransitionOvershoot()
