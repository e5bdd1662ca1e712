"""``transition_overshoot``: every load change, up or down, adds a transient of one sign,
proportional to the size of the change, that decays (the "shoulder peak" of conductive-filler
elastomers: the filler network breaks on every change and re-forms).

Model: with ``v(t)`` the load's total variation (the sum of |load changes| so far, through a
play operator of 0.1 % of full scale so that noise on a measured load does not count), the
signal gets ``amplitude * (v - lag_tau(v))``: after a change of size ``dL`` a transient
``amplitude * |dL| * exp(-t / tau)``. ``amplitude`` is in signal units per unit load change.

The decay may be stretched, ``exp(-(t / tau)^exponent)`` with ``exponent`` fitted (1: the plain
exponential; below 1 a decay over a spread of times, as the re-forming of a filler network has
it), computed as a sum of exponentials whose weights fit the stretched decay
(:func:`stretched_weights`). When the stretched form is not supported, the plain one is tried.
"""

from __future__ import annotations

import functools

import numpy as np

from scipy.optimize import nnls

from creepcomp.errors import InputError
from creepcomp.fit.data import Data
from creepcomp.fit.structure import Applied, Param
from creepcomp.fit.solver import Fit
from creepcomp.lti import lag_states
from creepcomp.diagnose.effects import SensorEffect
from creepcomp.diagnose.effects.rate_independent_hysteresis import one_way_reason, play

__all__ = ["DEAD_BAND", "total_variation", "stretched_weights", "TransitionOvershoot", "EFFECT"]

#: Load changes smaller than this fraction of full scale (back and forth) do not count.
DEAD_BAND = 1e-3


def total_variation(x, dead_band: float = 0.0) -> np.ndarray:
    """The sum of |changes| of ``x`` up to each sample (through a play of ``dead_band``)."""
    x = np.asarray(x, float)
    p = play(x, dead_band, initial=x[0]) if dead_band > 0 else x
    return np.concatenate([[0.0], np.cumsum(np.abs(np.diff(p)))])


#: Time constants (relative to ``tau``) of the exponentials that make up a stretched decay.
STRETCH_GRID = np.geomspace(1e-3, 1e2, 21)


@functools.lru_cache(maxsize=16)
def stretched_weights(exponent: float) -> np.ndarray:
    """Non-negative weights ``w`` of :data:`STRETCH_GRID` with ``sum_i w_i exp(-x / g_i)`` close
    to ``exp(-x^exponent)`` for ``x`` (time over ``tau``) from 1e-3 to 30 (least squares on a log
    grid of ``x``; the weights sum to about 1, the decay's start). Read-only: the last few are
    kept (a fit evaluates the same exponent for every other parameter's step)."""
    x = np.concatenate([[0.0], np.geomspace(1e-3, 30.0, 120)])
    a = np.exp(-x[:, None] / STRETCH_GRID[None, :])
    w, _ = nnls(a, np.exp(-x ** exponent))
    w.flags.writeable = False
    return w


def _total_variation_of(data: Data, s: np.ndarray, dead_band: float) -> np.ndarray:
    """:func:`total_variation` of the load seen ``s``: of the record's own load (no effect
    before this one changed it) computed once per record (:meth:`~creepcomp.fit.data.Data.derived`),
    as every evaluation of a fit asks for it."""
    if np.array_equal(s, data.load):
        return data.derived(("total_variation", dead_band), lambda: total_variation(data.load, dead_band))
    return total_variation(s, dead_band)


class TransitionOvershoot(SensorEffect):
    name = "transition_overshoot"
    vocabulary_index = 9
    # exp(-t/tau); exp(-(t/tau)^b)
    forms = ("exponential", "stretched")
    programs = ("staircase", "step", "random", "cycles")
    unloads = True
    parameters = ("amplitude", "tau")
    parameter_units = {"amplitude": "signal/load"}
    summary = "a decaying transient of one sign after every load change, up or down"

    def applicable(self, data, structure):
        # on a load that only rises, an overshoot is a creep term of negative beta
        return super().applicable(data, structure) or one_way_reason(data)

    def settings(self, data: Data, base: Fit) -> tuple:
        return (("load_scale", data.load_scale), ("stretched", True))

    def plain_settings(self, data: Data, base: Fit) -> tuple:
        return (("load_scale", data.load_scale),)

    def fit_on(self, data, base, refine="all", start=None, settings=None, quick_fit=None):
        if refine == "own" and settings is None:
            # the screening fits the plain exponential (a stretched decay costs a dozen lags
            # per evaluation); the full fit starts from it with the exponent free
            settings = self.plain_settings(data, base)
        return super().fit_on(data, base, refine, start, settings, quick_fit)

    def nonlinear_params(self, data, applied):
        lo, hi = data.tau_limits()
        out = [Param("tau", lo, hi, log=True)]
        if applied.setting("stretched", False):
            out.append(Param("exponent", 0.3, 1.0, default=1.0))
        return out

    def starts(self, data, base, applied):
        lo, hi = data.tau_limits()
        shapes = (1.0, 0.7) if applied.setting("stretched", False) else (1.0,)
        return [{"tau": float(t), "exponent": b} for t in np.geomspace(2 * lo, min(hi, data.span) / 3, 7)
                for b in shapes]

    columns_from_lags = False

    def columns(self, data, s, h, lags, p, applied):
        v = _total_variation_of(data, s, DEAD_BAND * applied.setting("load_scale"))
        b = p.get("exponent", 1.0)
        if b >= 1.0:
            decay = v - lag_states(data.sampling, v, [p["tau"]], hold=data.hold, initial="settled")[:, 0]
        else:
            w = stretched_weights(b)
            used = w > 1e-9
            taus = p["tau"] * STRETCH_GRID[used]
            decay = (v[:, None] - lag_states(data.sampling, v, taus, hold=data.hold, initial="settled")) @ w[used]
        return {"amplitude": decay}

    def report(self, fit: Fit, applied: Applied) -> dict:
        out = {"amplitude": fit.estimate(lambda v: v["transition_overshoot.amplitude"]),
               "tau": fit.estimate(lambda v: v["transition_overshoot.tau"])}
        if "transition_overshoot.exponent" in fit.values:
            out["exponent"] = fit.estimate(lambda v: v["transition_overshoot.exponent"])
        return out

    def extension(self, fit: Fit, applied: Applied) -> dict:
        return {"amplitude": fit.values["transition_overshoot.amplitude"],
                "tau": fit.values["transition_overshoot.tau"],
                "exponent": fit.values.get("transition_overshoot.exponent", 1.0),
                "load_scale": applied.setting("load_scale")}

    def restore(self, entry, model, data):
        scale = ("load_scale", float(entry.get("load_scale", data.load_scale)))
        values = {"transition_overshoot.amplitude": float(entry["amplitude"]),
                  "transition_overshoot.tau": float(entry["tau"])}
        if float(entry.get("exponent", 1.0)) < 1.0:
            values["transition_overshoot.exponent"] = float(entry["exponent"])
            return Applied(self, (scale, ("stretched", True))), values
        return Applied(self, (scale,)), values

    def inverse(self, entry, model):
        return ("the transient amplitude (v - lag_tau(v)), v the total variation of the load found up to each "
                "sample, taken out of the signal")

    def firmware_output(self, entry, model):
        # in signal units X = gain x: amplitude v = (amplitude / |gain|) v_X, the play's half
        # width |gain| DEAD_BAND load_scale / 2; the decay a sum of lags (one unless stretched)
        if "load_scale" not in entry:
            raise InputError("the model's extension 'transition_overshoot' has no 'load_scale' (its "
                             "dead band's scale): no C corrector for it; give it in the model file")
        exponent = float(entry.get("exponent", 1.0))
        tau = float(entry["tau"])
        if exponent >= 1.0:
            weights, taus = [1.0], [tau]
        else:
            w = stretched_weights(exponent)
            used = w > 1e-9
            weights, taus = w[used].tolist(), (tau * STRETCH_GRID[used]).tolist()
        return {"overshoot": {"ratio": float(entry["amplitude"]) / abs(model.gain),
                              "half_width": 0.5 * abs(model.gain) * DEAD_BAND * float(entry["load_scale"]),
                              "weights": weights, "taus": taus}}

    # -- generator ---------------------------------------------------------------------------
    def draw(self, rng, scales, form):
        s = scales
        # 2 ... 8 % of the change, decaying 3 ... 30 times faster than the creep
        out = dict(amplitude=float(rng.choice([-1, 1], p=[0.3, 0.7]) * rng.uniform(0.02, 0.08) * abs(s.gain)),
                   tau=float(max(s.tau / rng.uniform(3.0, 30.0), 8.0 / s.rate)))
        if form == "stretched":
            out["exponent"] = float(rng.uniform(0.6, 0.85))
        return out

    def truth(self, p, synthetic):
        return {"amplitude": p["amplitude"], "tau": p["tau"]}

    def sim_sampled(self, path, p, out):
        return out + _overshoot(p, path.program, path.t_samples)


EFFECT = TransitionOvershoot()


def _overshoot(p: dict, program, t: np.ndarray) -> np.ndarray:
    """The generator's transient: the sum over the program's load changes of
    ``amplitude |dL| g(t - t_change)``; ramps are cut into 32 changes each. ``g``: exp(-x/tau)
    or, stretched, exp(-(x/tau)^b)."""
    bt, bu = np.array(program.times), np.array(program.loads)
    times, sizes = [], []
    for k in range(len(bt) - 1):
        du = bu[k + 1] - bu[k]
        if du == 0:
            continue
        if bt[k + 1] == bt[k]:
            times.append(bt[k])
            sizes.append(abs(du))
        else:
            pieces = 32
            times += list(bt[k] + (np.arange(pieces) + 0.5) / pieces * (bt[k + 1] - bt[k]))
            sizes += [abs(du) / pieces] * pieces
    out = np.zeros(len(t))
    tau, b = p["tau"], p.get("exponent", 1.0) if p.get("form") == "stretched" else 1.0
    for tj, sj in zip(times, sizes):
        after = t >= tj
        x = (t[after] - tj) / tau
        out[after] += p["amplitude"] * sj * np.exp(-x ** b)
    return out
