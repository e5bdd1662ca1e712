"""``capacitor_leakage``: a resistance in parallel with a capacitor (parameter ``R``, ohm)."""

from __future__ import annotations

from creepcomp.diagnose.effects._network import NetworkEffect, log_param

__all__ = ["CapacitorLeakage", "EFFECT"]


class CapacitorLeakage(NetworkEffect):
    """Leakage across a capacitor (its insulation resistance, or a board leakage path)."""

    name = "capacitor_leakage"
    parameters = ("R",)
    per_capacitor = True
    summary = "a leakage resistance across a capacitor"

    def network_params(self, data, settings):
        """``R`` from a tenth of the cell's resistor to 10^5 times it."""
        r = data.design.network.cells[settings["cell"]].R
        return [log_param("R", r / 10.0, r * 1e5, r * 100.0)]

    def network_starts(self, data, settings):
        """Leakage 1 to 1000 times the cell's resistor."""
        r = data.design.network.cells[settings["cell"]].R
        return [{"R": r * f} for f in (1.0, 10.0, 100.0, 1000.0)]


EFFECT = CapacitorLeakage()
