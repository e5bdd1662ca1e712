"""``source_impedance``: the sensor's output resistance loads the network (parameter ``R``,
ohm, added to the design's source resistance)."""

from __future__ import annotations

import math
from dataclasses import replace

from creepcomp.analog.faults import capacitor_cells, series_resistor_label
from creepcomp.diagnose.effects._network import (FaultPrior, NetworkEffect, log_param, positive, resistance_level,
                                                 resistance_scale)
from creepcomp.diagnose.effects.resistor_value import EFFECT as RESISTOR_VALUE

__all__ = ["SourceImpedance", "EFFECT"]


class SourceImpedance(NetworkEffect):
    """A source resistance the design does not have."""

    name = "source_impedance"
    parameters = ("R",)
    summary = "the sensor's output resistance loads the network"
    vocabulary_index = 1
    prior = FaultPrior(0.01, "at most half the network's resistance level",
                       "the sensor's output resistance left out of the design")

    def apply_fault(self, network, params, cell=None):
        """``params["R"]`` added to the design's source resistance."""
        return replace(network, source_resistance=network.source_resistance + positive(params["R"], "R"))

    def exact_twins(self, network, part):
        """A higher plain series resistor (a cell without capacitor, e.g. the series R1 of a
        lag network): the two add."""
        return [(RESISTOR_VALUE, series_resistor_label(network, k)) for k, c in enumerate(network.cells)
                if not c.C > 0]

    def network_params(self, data, settings):
        """``R`` from 1e-6 to 10 times the network's resistance level."""
        level = resistance_scale(data.design.network)
        return [log_param("R", level * 1e-6, level * 10.0, level * 1e-2)]

    def network_starts(self, data, settings):
        """A decade grid."""
        level = resistance_scale(data.design.network)
        return [{"R": level * f} for f in (1e-4, 1e-3, 1e-2, 1e-1)]

    def implausible(self, network, values, settings):
        """A source resistance above half the network's resistance level."""
        level = resistance_scale(network)
        if values["R"] > 0.5 * level:
            return f"a source resistance of {values['R'] / level:.3g} times the network's resistance level"
        return None

    def separating_measurement(self, other, own_part, other_part, exact):
        """Against a resistor: measure it and the sensor's output resistance."""
        if other is not RESISTOR_VALUE:
            return None
        return 0, (f"measure {other_part} out of circuit, and the sensor's output resistance"
                   + (" (the output alone cannot: the two add)" if exact else ""))

    def random_fault(self, rng, network, duration):
        """0.01 to 0.2 times the network's resistance level (log-uniform). A capacitor is
        drawn first and not used, as for the capacitor's faults (the records stay as they
        were)."""
        rng.choice(capacitor_cells(network))
        return {"R": resistance_level(network) * math.exp(rng.uniform(math.log(0.01), math.log(0.2)))}

    def small_faults(self, network, size, duration):
        """A source of ``size`` times the resistance level."""
        return [(None, self.apply_fault(network, {"R": size * resistance_level(network)}))]


EFFECT = SourceImpedance()
