"""``viscous_flow``: creep that never saturates and is not recovered (Burgers: a dashpot in
series), ``rate`` in 1/s relative to the instantaneous signal."""

from __future__ import annotations

import numpy as np

from creepcomp.fit.data import Data
from creepcomp.fit.structure import Applied
from creepcomp.fit.solver import Fit
from creepcomp.diagnose.effects import Effect

__all__ = ["integral", "ViscousFlow", "EFFECT"]

#: The flow is approximated, for the linear creep correction, by a Prony term this many
#: record lengths long (over the record its lag equals the integral to within ~1/(2 x this)).
_EQUIVALENT_LENGTHS = 1000.0


def integral(data: Data, s: np.ndarray) -> np.ndarray:
    """Integral of ``s`` over time from the first sample (and from a known load step)."""
    dt = np.diff(data.time)
    if data.hold == "zero":
        steps = s[:-1] * dt
    else:
        steps = 0.5 * (s[:-1] + s[1:]) * dt
    out = np.concatenate([[0.0], np.cumsum(steps)])
    if data.initial == "step":
        out += s[0] * (data.t0 - data.load_step_at)
    return out


class ViscousFlow(Effect):
    name = "viscous_flow"
    parameters = ("rate",)
    summary = "creep that never saturates (a dashpot in series: Burgers model)"

    def settings(self, data: Data, base: Fit) -> tuple:
        return (("span", data.span),)

    def columns(self, data, s, h, lags, p, applied):
        return {"flow": integral(data, s)}

    def unphysical(self, fit: Fit, applied: Applied) -> str | None:
        rate = fit.values["viscous_flow.flow"] / fit.gain
        # flow of either sign (creep, or relaxation under imposed displacement); but a held
        # load's response cannot flow through zero within the record
        held = 1.0 + float(np.sum(fit.betas)) + rate * applied.setting("span")
        if held <= 0:
            return (f"rate = {rate:.3g} /s: under a held load the response would flow through zero "
                    f"within the record, which no passive material does")
        return None

    def report(self, fit: Fit, applied: Applied) -> dict:
        return {"rate": fit.estimate(lambda v: v["viscous_flow.flow"] / v["gain"])}

    def extension(self, fit: Fit, applied: Applied) -> dict:
        return {"rate": fit.values["viscous_flow.flow"] / fit.gain}

    def restore(self, entry, model, data):
        return Applied(self, ()), {"viscous_flow.flow": model.gain * float(entry["rate"])}

    def linear_terms(self, values, applied, data):
        tau = _EQUIVALENT_LENGTHS * max(data.duration, float(np.median(np.diff(data.time))))
        return [(values["viscous_flow.flow"] / values["gain"] * tau, tau)]


EFFECT = ViscousFlow()
