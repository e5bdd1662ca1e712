"""``dielectric_absorption``: the capacitor's dielectric adds a slow memory term (parameters
``fraction`` of its capacitance and ``tau``, s): a series R-C branch across it."""

from __future__ import annotations

from creepcomp.diagnose.effects._network import NetworkEffect, log_param

__all__ = ["DielectricAbsorption", "EFFECT"]


class DielectricAbsorption(NetworkEffect):
    """Dielectric absorption of a capacitor, as one series R-C branch across it."""

    name = "dielectric_absorption"
    parameters = ("fraction", "tau")
    per_capacitor = True
    summary = "the capacitor's dielectric absorbs charge (a slow memory term)"

    def network_params(self, data, settings):
        """``fraction`` 1e-5 to 0.1 of C (ceramics absorb a few %, electrolytics up to about
        10 %); ``tau`` from two sampling steps to the record's length (a slower memory is not
        told apart from drift of the measuring chain)."""
        return [log_param("fraction", 1e-5, 0.1, 1e-3),
                log_param("tau", 2.0 * data.dt_median, data.duration, 30.0)]

    def network_starts(self, data, settings):
        """A grid of absorption time constants across the record's time scales."""
        lo, hi = 5.0 * data.dt_median, data.duration
        taus = [lo * (hi / lo) ** (i / 3) for i in range(4)]
        return [{"fraction": f, "tau": t} for t in taus for f in (1e-4, 1e-3, 1e-2)]


EFFECT = DielectricAbsorption()
