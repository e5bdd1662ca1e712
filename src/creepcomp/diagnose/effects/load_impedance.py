"""``load_impedance``: the next stage's input resistance loads the network (parameter ``R``,
ohm, in parallel with the design's load)."""

from __future__ import annotations

import math
from dataclasses import replace

from creepcomp.analog.faults import capacitor_cells
from creepcomp.diagnose.effects._network import (FaultPrior, NetworkEffect, log_param, positive, resistance_level,
                                                 resistance_scale)
from creepcomp.diagnose.effects.resistor_value import EFFECT as RESISTOR_VALUE

__all__ = ["LoadImpedance", "EFFECT"]


class LoadImpedance(NetworkEffect):
    """A load resistance the design does not have."""

    name = "load_impedance"
    parameters = ("R",)
    summary = "the next stage's input resistance loads the network"
    vocabulary_index = 2
    prior = FaultPrior(0.01, "at least the network's resistance level",
                       "the next stage's input resistance left out of the design")

    def apply_fault(self, network, params, cell=None):
        """``params["R"]`` in parallel with the design's load resistance."""
        r = positive(params["R"], "R")
        rl = r if network.load_resistance is None else 1.0 / (1.0 / r + 1.0 / network.load_resistance)
        return replace(network, load_resistance=rl)

    def exact_twins(self, network, part):
        """``R2`` lower (``R2 || RL``; R2 15 % low is a load of 5.7 R2)."""
        return [(RESISTOR_VALUE, "R2")] if network.R2 is not None else []

    def network_params(self, data, settings):
        """``R`` from a hundredth to 10^6 times the network's resistance level."""
        level = resistance_scale(data.design.network)
        return [log_param("R", level * 1e-2, level * 1e6, level * 10.0)]

    def network_starts(self, data, settings):
        """A decade grid."""
        level = resistance_scale(data.design.network)
        return [{"R": level * f} for f in (0.3, 3.0, 30.0, 300.0)]

    def implausible(self, network, values, settings):
        """A load below the network's resistance level."""
        level = resistance_scale(network)
        if values["R"] < level:
            return f"a load resistance of {values['R'] / level:.3g} times the network's resistance level"
        return None

    def separating_measurement(self, other, own_part, other_part, exact):
        """Against a resistor: measure R2 and the next stage's input resistance."""
        if other is not RESISTOR_VALUE:
            return None
        return 0, ("measure R2 out of circuit, and the next stage's input resistance with the network "
                   "unplugged" + (" (the output alone cannot: R2 || RL is all it sees)" if exact else ""))

    def random_fault(self, rng, network, duration):
        """1.5 to 30 times the network's resistance level (log-uniform). A capacitor is drawn
        first and not used, as for the capacitor's faults (the records stay as they were)."""
        rng.choice(capacitor_cells(network))
        return {"R": resistance_level(network) * math.exp(rng.uniform(math.log(1.5), math.log(30.0)))}

    def small_faults(self, network, size, duration):
        """A load of the resistance level over ``size``."""
        return [(None, self.apply_fault(network, {"R": resistance_level(network) / size}))]


EFFECT = LoadImpedance()
