"""``source_impedance``: the sensor's output resistance loads the network (parameter ``R``,
ohm, added to the design's source resistance)."""

from __future__ import annotations

from creepcomp.diagnose.effects._network import NetworkEffect, log_param, resistance_scale

__all__ = ["SourceImpedance", "EFFECT"]


class SourceImpedance(NetworkEffect):
    """A source resistance the design does not have."""

    name = "source_impedance"
    parameters = ("R",)
    summary = "the sensor's output resistance loads the network"

    def network_params(self, data, settings):
        """``R`` from 1e-6 to 10 times the network's resistance level."""
        level = resistance_scale(data.design.network)
        return [log_param("R", level * 1e-6, level * 10.0, level * 1e-2)]

    def network_starts(self, data, settings):
        """A decade grid."""
        level = resistance_scale(data.design.network)
        return [{"R": level * f} for f in (1e-4, 1e-3, 1e-2, 1e-1)]


EFFECT = SourceImpedance()
