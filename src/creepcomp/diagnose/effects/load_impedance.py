"""``load_impedance``: the next stage's input resistance loads the network (parameter ``R``,
ohm, in parallel with the design's load)."""

from __future__ import annotations

from creepcomp.diagnose.effects._network import NetworkEffect, log_param, resistance_scale

__all__ = ["LoadImpedance", "EFFECT"]


class LoadImpedance(NetworkEffect):
    """A load resistance the design does not have."""

    name = "load_impedance"
    parameters = ("R",)
    summary = "the next stage's input resistance loads the network"

    def network_params(self, data, settings):
        """``R`` from a hundredth to 10^6 times the network's resistance level."""
        level = resistance_scale(data.design.network)
        return [log_param("R", level * 1e-2, level * 1e6, level * 10.0)]

    def network_starts(self, data, settings):
        """A decade grid."""
        level = resistance_scale(data.design.network)
        return [{"R": level * f} for f in (0.3, 3.0, 30.0, 300.0)]


EFFECT = LoadImpedance()
