"""``capacitor_leakage``: a resistance in parallel with a capacitor (parameter ``R``, ohm)."""

from __future__ import annotations

import math
from dataclasses import replace

from creepcomp.analog.faults import capacitor_cells, capacitor_label, series_resistor_label
from creepcomp.diagnose.effects._network import CapacitorFault, FaultPrior, log_param, positive
from creepcomp.diagnose.effects.resistor_value import EFFECT as RESISTOR_VALUE

__all__ = ["CapacitorLeakage", "EFFECT"]


class CapacitorLeakage(CapacitorFault):
    """Leakage across a capacitor (its insulation resistance, or a board leakage path)."""

    name = "capacitor_leakage"
    parameters = ("R",)
    summary = "a leakage resistance across a capacitor"
    vocabulary_index = 4
    prior = FaultPrior(0.005, "at least the cell's own resistor", "contamination on the board, an electrolytic part")

    def changed_cell(self, cell, params):
        """The cell with a leakage ``params["R"]`` across its capacitor."""
        return replace(cell, leakage=positive(params["R"], "R"))

    def exact_twins(self, network, part):
        """The cell's resistor lower (``R1 || RP``; R1 20 % low is a leakage of 4 R1)."""
        return [(RESISTOR_VALUE, series_resistor_label(network, k)) for k in capacitor_cells(network)
                if capacitor_label(network, k) == part]

    def network_params(self, data, settings):
        """``R`` from a tenth of the cell's resistor to 10^5 times it."""
        r = data.design.network.cells[settings["cell"]].R
        return [log_param("R", r / 10.0, r * 1e5, r * 100.0)]

    def network_starts(self, data, settings):
        """Leakage 1 to 1000 times the cell's resistor."""
        r = data.design.network.cells[settings["cell"]].R
        return [{"R": r * f} for f in (1.0, 10.0, 100.0, 1000.0)]

    def implausible(self, network, values, settings):
        """A leakage below the cell's own resistor."""
        r = network.cells[settings.get("cell")].R
        if values["R"] < r:
            return f"a leakage of {values['R'] / r:.3g} times the cell's resistor"
        return None

    def separating_measurement(self, other, own_part, other_part, exact):
        """Against the resistor it mimics: measure that resistor, or a temperature step (a
        leakage grows with temperature); against any other fault, the temperature step."""
        if other is RESISTOR_VALUE:
            part = other_part if other_part is not None else "the resistor"
            return 0, (f"measure {part} out of circuit; or repeat the record after a temperature step (a leakage "
                       "grows with temperature, a film resistor hardly moves)"
                       + (" (the output alone cannot: R1 || leakage is all it sees)" if exact else ""))
        return 1, "repeat the record after a temperature step (a leakage grows with temperature)"

    def random_cell_fault(self, rng, cell, duration):
        """5 to 100 times the cell's resistor (log-uniform)."""
        return {"R": cell.R * math.exp(rng.uniform(math.log(5.0), math.log(100.0)))}

    def small_cell_faults(self, cell, size, duration):
        """A leakage of the cell's resistor over ``size``."""
        return [{"R": cell.R / size}]


EFFECT = CapacitorLeakage()
