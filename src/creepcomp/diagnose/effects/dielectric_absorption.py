"""``dielectric_absorption``: the capacitor's dielectric adds a slow memory term (parameters
``fraction`` of its capacitance and ``tau``, s): a series R-C branch across it."""

from __future__ import annotations

import math
from dataclasses import replace

from creepcomp.diagnose.effects._network import CapacitorFault, FaultPrior, log_param, positive

__all__ = ["DielectricAbsorption", "EFFECT"]

#: Time constants of the generator's small absorptions, times the cell's own R C.
SMALL_TAUS = (0.7, 2.2, 7.0)


class DielectricAbsorption(CapacitorFault):
    """Dielectric absorption of a capacitor, as one series R-C branch across it."""

    name = "dielectric_absorption"
    parameters = ("fraction", "tau")
    fault_parts = ("C", "R")
    summary = "the capacitor's dielectric absorbs charge (a slow memory term)"
    vocabulary_index = 3
    prior = FaultPrior(0.01, "up to 10 % of the capacitance",
                       "a ceramic or electrolytic placed where a film part was designed")

    def changed_cell(self, cell, params):
        """The cell with a branch ``fraction * C`` in series with ``tau / (fraction * C)``."""
        fraction, tau = positive(params["fraction"], "fraction"), positive(params["tau"], "tau")
        c_da = fraction * cell.C
        return replace(cell, absorption_C=c_da, absorption_R=tau / c_da)

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

    def implausible(self, network, values, settings):
        """An absorption of more than 10 % of the capacitance."""
        if values["fraction"] > 0.1:
            return f"an absorption of {100 * values['fraction']:.3g} % of the capacitance"
        return None

    def separating_measurement(self, other, own_part, other_part, exact):
        """A second record with holds longer than the absorption's time constant."""
        return 2, ("a second record with another load program: holds longer than the absorption's time "
                   "constant, then a step back (absorption recovers slowly, a wrong part does not)")

    def random_cell_fault(self, rng, cell, duration):
        """Film capacitors absorb 0.05-0.25 % (docs/physics.md): a fault is a dielectric that
        absorbs more, as ceramic X7R does (0.6-2.5 %): 0.5-3 %. Its memory is slow: from 0.7
        to 7 times the cell's own R C (absorption much faster than that only adds capacitance,
        and is told apart from a larger capacitor by nothing in the output), at most half
        the record's ``duration`` so that the record shows it."""
        return {"fraction": math.exp(rng.uniform(math.log(0.005), math.log(0.03))),
                "tau": min(cell.R * cell.C * math.exp(rng.uniform(math.log(0.7), math.log(7.0))), duration / 2)}

    def small_cell_faults(self, cell, size, duration):
        """Absorptions of ``size`` at three time constants (:data:`SMALL_TAUS` times the
        cell's R C, at most half the ``duration``), standing for the family of them."""
        return [{"fraction": size, "tau": min(f * cell.R * cell.C, duration / 2)} for f in SMALL_TAUS]

    def scaled_part(self, params, part, h):
        """The branch's ``C`` is ``fraction`` times the capacitor, its ``R`` is ``tau / C``:
        either scaled by ``exp(h)`` scales ``tau``, ``C`` also ``fraction``."""
        out = dict(params)
        out["tau"] = params["tau"] * math.exp(h)
        if part == "C":
            out["fraction"] = params["fraction"] * math.exp(h)
        return out


EFFECT = DielectricAbsorption()
