"""``asymmetric_recovery``: recovery runs with another retardation time than creep.

One creep term (the largest) relaxes with ``tau`` while its state grows in magnitude towards
the load (creep under loading) and with ``tau_recovery`` while it shrinks (recovery after
unloading): over each sample step the term is recovering when
``sign(c) * (h - c) < 0``. The mode depends on the state, so the lag is solved by iteration
(:func:`creepcomp.lti.varying_lag_states`).
"""

from __future__ import annotations

import numpy as np

from creepcomp.fit.data import Data
from creepcomp.fit.structure import Applied, Param
from creepcomp.fit.solver import Fit
from creepcomp.diagnose.effects import Effect

__all__ = ["AsymmetricRecovery", "EFFECT"]


class AsymmetricRecovery(Effect):
    name = "asymmetric_recovery"
    parameters = ("tau_recovery",)
    changes_lags = True
    state_dependent = True
    summary = "recovery after unloading with another retardation time than creep"

    def settings(self, data: Data, base: Fit) -> tuple:
        return (("term", int(np.argmax(np.abs(base.betas)))),)

    def nonlinear_params(self, data, applied):
        lo, hi = data.tau_limits()
        return [Param("tau_recovery", lo, hi * 10.0, log=True)]

    def starts(self, data, base, applied):
        tau = base.taus[applied.setting("term")]
        return [{"tau_recovery": tau * f} for f in (0.25, 0.5, 2.0, 4.0)]

    def tau_factor(self, data, h, lags, taus, p, applied):
        k = applied.setting("term")
        c = lags[:-1, k]
        target = 0.5 * (h[:-1] + h[1:])
        # a state at its target is in neither mode: a small dead band keeps rounding from
        # flipping modes (and the fixed-point iteration from never settling)
        band = 1e-9 * max(float(np.max(np.abs(h))), 1e-300)
        recovering = np.sign(c) * (target - c) < -band
        factor = np.ones((len(h) - 1, len(taus)))
        factor[recovering, k] = p["tau_recovery"] / taus[k]
        return factor

    def report(self, fit: Fit, applied: Applied) -> dict:
        k = applied.setting("term")
        return {"tau_recovery": fit.estimate(lambda v: v["asymmetric_recovery.tau_recovery"]),
                "tau": fit.estimate(lambda v: v[f"tau[{k}]"])}

    def extension(self, fit: Fit, applied: Applied) -> dict:
        k = applied.setting("term")
        return {"tau": float(fit.taus[k]), "tau_recovery": fit.values["asymmetric_recovery.tau_recovery"]}

    def restore(self, entry, model, data):
        taus = np.array(model.tau)
        k = int(np.argmin(np.abs(np.log(taus / float(entry["tau"])))))
        return Applied(self, (("term", k),)), {"asymmetric_recovery.tau_recovery": float(entry["tau_recovery"])}


EFFECT = AsymmetricRecovery()
