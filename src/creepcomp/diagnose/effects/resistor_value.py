"""``resistor_value``: a resistor is not its nominal value (parameter ``R``, ohm, with the
part: ``R1`` / ``R1.k`` of the series cells, ``R2``, ``R3`` / ``R3.j`` of the shunt branches)."""

from __future__ import annotations

from creepcomp.analog.faults import apply_fault, resistor_parts
from creepcomp.diagnose.effects._network import NetworkEffect, log_param

__all__ = ["ResistorValue", "EFFECT"]


class ResistorValue(NetworkEffect):
    """A resistor of the network measures another value than its design (the wrong part
    placed, a part at or beyond its tolerance, drift with heat or humidity)."""

    name = "resistor_value"
    parameters = ("R",)
    summary = "a resistor is off its nominal value"

    def network_settings(self, network) -> list[tuple]:
        """One setting per resistor of the design."""
        return [(("part", label),) for label in resistor_parts(network)]

    def network_params(self, data, settings):
        """``R`` within a factor 3 of the design value."""
        r = resistor_parts(data.design.network)[settings["part"]]
        return [log_param("R", r / 3.0, r * 3.0, r)]

    def network_starts(self, data, settings):
        """Around the design value."""
        r = resistor_parts(data.design.network)[settings["part"]]
        return [{"R": r * f} for f in (0.8, 0.95, 1.05, 1.25)]

    def apply_network(self, network, values: dict, settings: dict):
        """The network with the resistor ``settings["part"]`` at ``values["R"]``."""
        return apply_fault(network, self.name, {"R": values["R"], "part": settings["part"]})


EFFECT = ResistorValue()
