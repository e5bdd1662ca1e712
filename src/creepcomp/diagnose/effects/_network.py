"""Shared base of the circuit-side effects: a change of the built network itself."""

from __future__ import annotations

from creepcomp.analog.faults import apply_fault, capacitor_cells
from creepcomp.fit.structure import Param
from creepcomp.diagnose.effects import Effect

__all__ = ["NetworkEffect", "log_param", "geometric", "resistance_scale"]


class NetworkEffect(Effect):
    """A circuit-side effect: the network as built differs from its design.

    Subclasses set ``name``, ``parameters``, ``per_capacitor`` and implement
    :meth:`network_params` and :meth:`network_starts`; :meth:`apply_network` changes the
    network through :func:`creepcomp.analog.faults.apply_fault`.
    """

    side = "circuit"
    needs = ("corrected",)
    per_capacitor = False

    def network_settings(self, network) -> list[tuple]:
        """Where the effect may sit: one setting per capacitor, or a single one."""
        if self.per_capacitor:
            return [(("cell", k),) for k in capacitor_cells(network)]
        return [()]

    def network_params(self, data, settings: dict) -> list[Param]:
        """The effect's nonlinear parameters (natural units, bounds)."""
        raise NotImplementedError

    def network_starts(self, data, settings: dict) -> list[dict]:
        """Start values of its parameters."""
        return [{}]

    def apply_network(self, network, values: dict, settings: dict):
        """The network with this effect at ``values``."""
        return apply_fault(network, self.name, values, settings.get("cell"))

    def report_network(self, values: dict, settings: dict) -> dict:
        """Reported parameters (natural units)."""
        return {k: float(values[k]) for k in self.parameters}


def log_param(name: str, lower: float, upper: float, default: float) -> Param:
    """A positive parameter searched on its logarithm."""
    return Param(name, lower, upper, log=True, default=default)


def geometric(center: float, factors) -> list[float]:
    """Start values around ``center``."""
    return [center * f for f in factors]


def resistance_scale(network) -> float:
    """The network's resistance scale for start values: the sum of its resistors (ohm)."""
    total = sum(c.R for c in network.cells) + (network.R2 or 0.0)
    return total if total > 0 else 1.0
