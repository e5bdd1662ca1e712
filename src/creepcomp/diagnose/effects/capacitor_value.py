"""``capacitor_value``: a capacitor is not its nominal value (parameter ``C``, farad)."""

from __future__ import annotations

from dataclasses import replace

from creepcomp.diagnose.effects._network import PART_FACTOR, CapacitorFault, FaultPrior, log_param, off_design, positive

__all__ = ["CapacitorValue", "EFFECT"]


class CapacitorValue(CapacitorFault):
    """The capacitor of a cell measures another value than its design."""

    name = "capacitor_value"
    parameters = ("C",)
    summary = "a capacitor is off its nominal value"
    vocabulary_index = 0
    measured_out_of_circuit = True
    prior = FaultPrior(0.04, f"within a factor {PART_FACTOR:g} of the design value",
                       "capacitors are +-10 to +-20 % parts, and age")

    def changed_cell(self, cell, params):
        """The cell with its capacitor at ``params["C"]``."""
        return replace(cell, C=positive(params["C"], "C"))

    def network_params(self, data, settings):
        """``C`` within a factor 3 of the design value."""
        c = data.design.network.cells[settings["cell"]].C
        return [log_param("C", c / 3.0, c * 3.0, c)]

    def network_starts(self, data, settings):
        """Around the design value."""
        c = data.design.network.cells[settings["cell"]].C
        return [{"C": c * f} for f in (0.8, 0.95, 1.05, 1.25)]

    def implausible(self, network, values, settings):
        """A capacitor more than :data:`~creepcomp.diagnose.effects._network.PART_FACTOR` off
        its design value."""
        cell = settings.get("cell")
        return off_design(values["C"], network.cells[cell].C, self.fault_part(network, cell))

    def random_cell_fault(self, rng, cell, duration):
        """5-25 % off either way."""
        sign = rng.choice([-1.0, 1.0])
        return {"C": cell.C * (1.0 + sign * rng.uniform(0.05, 0.25))}

    def small_cell_faults(self, cell, size, duration):
        """The capacitor ``size`` high."""
        return [{"C": cell.C * (1.0 + size)}]


EFFECT = CapacitorValue()
