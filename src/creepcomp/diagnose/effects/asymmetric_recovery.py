"""``asymmetric_recovery``: recovery runs with another retardation time than creep.

One creep term (the largest) relaxes with ``tau`` while its state grows in magnitude towards
the load (creep under loading) and with ``tau_recovery`` while it shrinks (recovery after
unloading): over each sample step the term is recovering when
``sign(c) * (h - c) < 0``. The mode depends on the state, so the lag is solved by iteration
(:func:`creepcomp.lti.varying_lag_states`).

The mode may instead be switched by the load's direction (``switch = "direction"``): the
term recovers from a fall of the load's magnitude until its next rise, whether or not the
state has caught up with the load. The two agree where the state settles before the load
turns; a partial unloading during creep tells them apart. Both are fitted, the better kept.
"""

from __future__ import annotations

import math

import numpy as np

from creepcomp.errors import InputError
from creepcomp.fit.data import Data
from creepcomp.fit.structure import Applied, Param
from creepcomp.fit.solver import Fit
from creepcomp.diagnose.effects import SensorEffect
from creepcomp.lti import lag_states

__all__ = ["AsymmetricRecovery", "EFFECT"]

#: What switches the term to recovery: its state's magnitude shrinking, or the load's last
#: move being a fall of its magnitude.
_SWITCHES = ("state", "direction")


class AsymmetricRecovery(SensorEffect):
    name = "asymmetric_recovery"
    vocabulary_index = 4
    # switched by the state's magnitude; by the load's direction
    forms = ("state", "direction")
    programs = ("staircase", "step", "mixture", "random")
    unloads = True
    parameters = ("tau_recovery",)
    changes_lags = True
    state_dependent = True
    summary = "recovery after unloading with another retardation time than creep"

    def settings(self, data: Data, base: Fit) -> tuple:
        return (("term", int(np.argmax(np.abs(base.betas)))),)

    def fit_on(self, data, base, refine="all", start=None, settings=None, quick_fit=None):
        if settings is not None:
            return super().fit_on(data, base, refine, start, settings, quick_fit)
        term = self.settings(data, base)
        switches = _SWITCHES if _switches_differ(data, float(base.taus[term[0][1]])) else _SWITCHES[:1]
        fit = SensorEffect.fit_on
        return min((fit(self, data, base, refine, start, term + (("switch", switch),), quick_fit) for switch in switches),
                   key=lambda f: f.bic)

    def nonlinear_params(self, data, applied):
        lo, hi = data.tau_limits()
        return [Param("tau_recovery", lo, hi * 10.0, log=True)]

    def starts(self, data, base, applied):
        tau = base.taus[applied.setting("term")]
        return [{"tau_recovery": tau * f} for f in (0.25, 0.5, 2.0, 4.0)]

    def tau_factor(self, data, h, lags, taus, p, applied):
        k = applied.setting("term")
        recovering = _shrinking(h, lags[:, k])
        if applied.setting("switch") == "direction":
            recovering = _after_fall(h, recovering)
        factor = np.ones((len(h) - 1, len(taus)))
        factor[recovering, k] = p["tau_recovery"] / taus[k]
        return factor

    def report(self, fit: Fit, applied: Applied) -> dict:
        k = applied.setting("term")
        return {"tau_recovery": fit.estimate(lambda v: v["asymmetric_recovery.tau_recovery"]),
                "tau": fit.estimate(lambda v: v[f"tau[{k}]"]),
                "switch": (applied.setting("switch", "state"), None)}

    def extension(self, fit: Fit, applied: Applied) -> dict:
        k = applied.setting("term")
        out = {"tau": float(fit.taus[k]), "tau_recovery": fit.values["asymmetric_recovery.tau_recovery"]}
        if applied.setting("switch", "state") != "state":
            out["switch"] = applied.setting("switch")
        return out

    def restore(self, entry, model, data):
        taus = np.array(model.tau)
        k = int(np.argmin(np.abs(np.log(taus / float(entry["tau"])))))
        switch = entry.get("switch", "state")
        if switch not in _SWITCHES:
            raise InputError(f"model extension 'asymmetric_recovery': unknown switch '{switch}' "
                             f"(known: {', '.join(_SWITCHES)})")
        return (Applied(self, (("term", k), ("switch", switch))),
                {"asymmetric_recovery.tau_recovery": float(entry["tau_recovery"])})

    def inverse(self, entry, model):
        if entry.get("switch", "state") == "direction":
            return ("the term's time constant tau_recovery after a fall of the load's magnitude (found up to each "
                    "sample; dead band 1 % of the record's largest load), tau otherwise")
        return "the term's time constant tau_recovery on the steps where its state shrinks, tau where it grows"

    def firmware_output(self, entry, model):
        if entry.get("switch", "state") != "state":
            raise InputError("the model's extension 'asymmetric_recovery' switched by the load's direction "
                             "has no C corrector: its dead band is 1 % of the largest load of the whole "
                             "record (of each 4096-sample segment), which a corrector running sample by "
                             "sample does not know; generate the firmware of the baseline model "
                             "(baseline-model.json), or correct records in Python with creepcomp correct")
        taus = np.array(model.tau)
        return {"recovery": {"term": int(np.argmin(np.abs(np.log(taus / float(entry["tau"]))))),
                             "tau_recovery": float(entry["tau_recovery"]),
                             "dead_band": _BAND}}

    # -- generator ---------------------------------------------------------------------------
    def draw_default(self, rng, scales, mixture):
        f = rng.uniform(2.5, 5.0)
        return {"tau_recovery": float(scales.tau * (f if rng.uniform() < 0.5 else 1 / f))}

    def draw(self, rng, scales, form):
        return self.draw_default(rng, scales, False)

    def truth(self, p, synthetic):
        return {"tau_recovery": p["tau_recovery"]}

    def sim_lags(self, path, p, lags):
        lag = _direction_lag if p.get("form", "state") == "direction" else _asymmetric_lag
        lags[:, 0] = lag(path.grid, path.h_before, path.h_after, path.taus[0], p["tau_recovery"],
                         path.h_after[0])
        return lags


EFFECT = AsymmetricRecovery()


#: Share of the sample steps on which the two switches must disagree (for the base's creep
#: term driven by the load) for the direction switch to be fitted as well: where the state
#: settles before the load turns, they are the same template.
_DIFFERENT_STEPS = 0.01


#: The dead band of the state switch, relative to the largest |input| of the lag.
_BAND = 1e-9


def _band(h: np.ndarray) -> float:
    # a state at its target is in neither mode: a small dead band keeps rounding from
    # flipping modes (and the fixed-point iteration from never settling)
    return _BAND * max(float(np.abs(h).max()), 1e-300)


def _shrinking(h: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Steps over which the state ``c`` shrinks in magnitude towards the input ``h``."""
    target = 0.5 * (h[:-1] + h[1:])
    return np.sign(c[:-1]) * (target - c[:-1]) < -_band(h)


def _switches_differ(data: Data, tau: float) -> bool:
    """Whether the two switches put a creep term of time constant ``tau``, driven by the
    load, in different modes on more than :data:`_DIFFERENT_STEPS` of the steps."""
    c = lag_states(data.sampling, data.load, [tau], hold=data.hold, initial="settled")[:, 0]
    by_state = _shrinking(data.load, c)
    return float(np.mean(by_state != _after_fall(data.load, by_state))) > _DIFFERENT_STEPS


#: Least change of the load's magnitude, relative to its largest, that turns its direction:
#: the creep correction simulates the model from a load estimated from a noisy signal, whose
#: sample-to-sample wiggles must not switch the mode at every sample.
_TURN = 0.01

#: Directions of recent inputs (the fit evaluates the same load many times).
_directions: dict = {}


def _falling(h: np.ndarray) -> np.ndarray:
    """Direction of ``|h|`` after each step: 1 falling, -1 rising, 0 not yet moved by
    :data:`_TURN` of its largest value (a dead band: it turns only on a move that large)."""
    key = (h.shape, hash(h.tobytes()))
    if key not in _directions:
        a = np.abs(h).tolist()
        turn = _TURN * max(max(a), 1e-300)
        out = [0] * (len(a) - 1)
        state, high, low = 0, a[0], a[0]
        for n in range(1, len(a)):
            x = a[n]
            high, low = (max(high, x) if state != 1 else high), (min(low, x) if state != -1 else low)
            if state != 1 and x < high - turn:
                state, low = 1, x
            elif state != -1 and x > low + turn:
                state, high = -1, x
            out[n - 1] = state
        if len(_directions) > 16:
            _directions.clear()
        _directions[key] = np.array(out, dtype=np.int8)
    return _directions[key]


def _after_fall(h: np.ndarray, before_any_move: np.ndarray) -> np.ndarray:
    """Steps after which the load's magnitude last fell (recovery switched by the load's
    direction, :func:`_falling`); steps before its first move keep ``before_any_move`` (the
    segment's history is unknown)."""
    direction = _falling(h)
    return np.where(direction == 0, before_any_move, direction > 0)


def _asymmetric_lag(grid, h_before, h_after, tau: float, tau_recovery: float, c0: float) -> np.ndarray:
    """A lag that relaxes with ``tau`` while its state grows in magnitude and with
    ``tau_recovery`` while it shrinks, stepped exactly on the generator's fine grid with the
    input held at each step's midpoint (a plain sequential loop, independent of the fitted
    discretisation)."""
    t = grid.tolist()
    hb, ha = h_before.tolist(), h_after.tolist()
    out = [c0]
    c = c0
    for n in range(len(t) - 1):
        target = 0.5 * (ha[n] + hb[n + 1])
        shrinking = (c > 0 and target < c) or (c < 0 and target > c)
        step = (t[n + 1] - t[n]) / (tau_recovery if shrinking else tau)
        c = target + (c - target) * math.exp(-step)
        out.append(c)
    return np.array(out)


def _direction_lag(grid, h_before, h_after, tau: float, tau_recovery: float, c0: float) -> np.ndarray:
    """A lag that runs with ``tau_recovery`` from a fall of the load's magnitude until the
    next rise, with ``tau`` otherwise (the mode switched by the load's direction)."""
    t = grid.tolist()
    hb, ha = h_before.tolist(), h_after.tolist()
    out = [c0]
    c, recovering = c0, False
    for n in range(len(t) - 1):
        # the load's last move, up to this step
        for a, b in ((hb[n], ha[n]), (ha[n], hb[n + 1])):
            if abs(b) < abs(a):
                recovering = True
            elif abs(b) > abs(a):
                recovering = False
        target = 0.5 * (ha[n] + hb[n + 1])
        step = (t[n + 1] - t[n]) / (tau_recovery if recovering else tau)
        c = target + (c - target) * math.exp(-step)
        out.append(c)
    return np.array(out)
