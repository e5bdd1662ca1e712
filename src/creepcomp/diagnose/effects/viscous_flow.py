"""``viscous_flow``: creep that never saturates and is not recovered (Burgers: a dashpot in
series), ``rate`` in 1/s relative to the instantaneous signal.

The dashpot may be Newtonian (flow rate proportional to the load) or follow a power law
(Norton: proportional to ``s |s / L|^(exponent - 1)``, ``L`` the record's full-scale load,
so that ``rate`` is the rate at full scale). The diagnosis fits the ``exponent`` (1 to 5);
a plain Burgers fit (``creepcomp fit --flow``) applies the effect without settings, Newtonian.
"""

from __future__ import annotations

import numpy as np

from creepcomp.fit.data import Data
from creepcomp.fit.structure import Applied, Param
from creepcomp.fit.solver import Fit
from creepcomp.diagnose.effects import SensorEffect

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


class ViscousFlow(SensorEffect):
    name = "viscous_flow"
    vocabulary_index = 2
    flow = True
    # Newtonian dashpot; power-law (Norton) flow
    forms = ("linear", "norton")
    one_sided = True
    parameters = ("rate",)
    summary = "creep that never saturates (a dashpot in series: Burgers model)"
    fresh_ahead = "all"       # (its quick fit frees the base's time constants, see fit_on)

    def settings(self, data: Data, base: Fit) -> tuple:
        return (("span", data.span), ("load_scale", data.load_scale))

    def fit_on(self, data, base, refine="all", start=None, settings=None, quick_fit=None):
        screening = refine == "own"
        if screening and start is None:
            # a long creep term of the base absorbs flow (and its exponent costs a parameter):
            # the screening frees the base's time constants too, or flow never ranks
            refine = "all"
        fit = super().fit_on(data, base, refine, start, settings, quick_fit)
        return self.with_fresh_term(data, base, fit, refine, start, settings, screening=screening,
                                    quick_fit=quick_fit)

    def plain_settings(self, data, base):
        return (("span", data.span),)

    def nonlinear_params(self, data, applied):
        if applied.setting("load_scale") is None:
            return []
        return [Param("exponent", 1.0, 5.0)]

    def starts(self, data, base, applied):
        if applied.setting("load_scale") is None:
            return [{}]
        return [{"exponent": m} for m in (1.0, 2.0, 3.0)]

    columns_from_lags = False

    def columns(self, data, s, h, lags, p, applied):
        m = p.get("exponent", 1.0)
        if m != 1.0:
            s = s * np.abs(s / applied.setting("load_scale")) ** max(m - 1.0, 0.0)
        return {"flow": integral(data, s)}

    def unphysical(self, fit: Fit, applied: Applied) -> str | None:
        rate = fit.values["viscous_flow.flow"] / fit.gain
        # flow of either sign (creep, or relaxation under imposed displacement); but a held
        # load's response cannot flow through zero within the record
        held = 1.0 + float(np.sum(fit.betas)) + rate * (applied.setting("span") or 0.0)
        if held <= 0:
            return (f"rate = {rate:.3g} /s: under a held load the response would flow through zero "
                    f"within the record, which no passive material does")
        return None

    def rate(self, fit: Fit) -> tuple[float, float]:
        """The fitted flow rate (1/s, relative to the instantaneous signal) and its standard
        deviation."""
        return fit.estimate(lambda v: v["viscous_flow.flow"] / v["gain"])

    def report(self, fit: Fit, applied: Applied) -> dict:
        out = {"rate": self.rate(fit)}
        if "viscous_flow.exponent" in fit.values:
            out["exponent"] = fit.estimate(lambda v: v["viscous_flow.exponent"])
        return out

    def extension(self, fit: Fit, applied: Applied) -> dict:
        out = {"rate": fit.values["viscous_flow.flow"] / fit.gain}
        if "viscous_flow.exponent" in fit.values:
            out.update(exponent=fit.values["viscous_flow.exponent"], load_scale=applied.setting("load_scale"))
        return out

    def restore(self, entry, model, data):
        values = {"viscous_flow.flow": model.gain * float(entry["rate"])}
        if "exponent" in entry:
            values["viscous_flow.exponent"] = float(entry["exponent"])
            return Applied(self, (("load_scale", float(entry["load_scale"])),)), values
        return Applied(self, ()), values

    def linear_terms(self, values, applied, data):
        tau = _EQUIVALENT_LENGTHS * max(data.duration, float(np.median(np.diff(data.time))))
        return [(values["viscous_flow.flow"] / values["gain"] * tau, tau)]

    def inverse(self, entry, model):
        return "the flow, the integral of the load found up to each sample (times rate), taken out of the signal"

    # -- generator ---------------------------------------------------------------------------
    def draw_default(self, rng, scales, mixture):
        # flow that adds 0.5 ... 3 times the creep over the record
        return {"rate": float(scales.beta * rng.uniform(0.5, 3.0) / scales.duration)}

    def draw(self, rng, scales, form):
        out = self.draw_default(rng, scales, False)
        if form == "norton":
            out["exponent"] = float(rng.uniform(1.5, 3.0))
        return out

    def truth(self, p, synthetic):
        rate = p["rate"]
        if p.get("form") == "norton":
            # the diagnosis gives the rate at the record's largest load, not at the
            # generator's full scale
            largest = float(np.max(np.abs(synthetic.record.load)))
            rate *= (largest / synthetic.spec.full_scale) ** (p["exponent"] - 1.0)
        return {"rate": rate}

    def sim_response(self, path, p, y):
        fs = path.full_scale
        drive_a, drive_b = path.s_after, path.s_before
        if p.get("form", "linear") == "norton":
            n = p["exponent"]
            drive_a = path.s_after * np.abs(path.s_after / fs) ** (n - 1.0)
            drive_b = path.s_before * np.abs(path.s_before / fs) ** (n - 1.0)
        steps = 0.5 * (drive_a[:-1] + drive_b[1:]) * np.diff(path.grid)
        return y + p["rate"] * np.concatenate([[0.0], np.cumsum(steps)])


EFFECT = ViscousFlow()
