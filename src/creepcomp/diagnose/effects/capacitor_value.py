"""``capacitor_value``: a capacitor is not its nominal value (parameter ``C``, farad)."""

from __future__ import annotations

from creepcomp.diagnose.effects._network import NetworkEffect, log_param

__all__ = ["CapacitorValue", "EFFECT"]


class CapacitorValue(NetworkEffect):
    """The capacitor of a cell measures another value than its design."""

    name = "capacitor_value"
    parameters = ("C",)
    per_capacitor = True
    summary = "a capacitor is off its nominal value"

    def network_params(self, data, settings):
        """``C`` within a factor 3 of the design value."""
        c = data.design.network.cells[settings["cell"]].C
        return [log_param("C", c / 3.0, c * 3.0, c)]

    def network_starts(self, data, settings):
        """Around the design value."""
        c = data.design.network.cells[settings["cell"]].C
        return [{"C": c * f} for f in (0.8, 0.95, 1.05, 1.25)]


EFFECT = CapacitorValue()
