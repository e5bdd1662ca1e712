"""``resistor_value``: a resistor is not its nominal value (parameter ``R``, ohm, with the
part: ``R1`` / ``R1.k`` of the series cells, ``R2``, ``R3`` / ``R3.j`` of the shunt branches)."""

from __future__ import annotations

from creepcomp.analog.faults import resistor_parts
from creepcomp.diagnose.effects._network import PART_FACTOR, FaultPrior, NetworkEffect, log_param, off_design, positive
from creepcomp.errors import InputError

__all__ = ["ResistorValue", "EFFECT"]


class ResistorValue(NetworkEffect):
    """A resistor of the network measures another value than its design (the wrong part
    placed, a part at or beyond its tolerance, drift with heat or humidity)."""

    name = "resistor_value"
    parameters = ("R",)
    summary = "a resistor is off its nominal value"
    vocabulary_index = 5
    measured_out_of_circuit = True
    alternatives_on_other_parts = True
    in_lag_networks = True
    prior = FaultPrior(0.05, f"within a factor {PART_FACTOR:g} of the design value",
                       "wrong value placed, a 5 % part at its limit, drift with heat or humidity: "
                       "the most common fault")

    def apply_fault(self, network, params, cell=None):
        """The resistor ``params["part"]`` (see :func:`~creepcomp.analog.faults.resistor_parts`)
        at ``params["R"]``."""
        parts = network.parts()
        labels = [p[0] for p in parts if p[1] == "R"]
        part = params.get("part")
        if part not in labels:
            raise InputError(f"{self.name}: part {part!r} is not a resistor of the network "
                             f"(its resistors: {', '.join(labels)})")
        values = [positive(params["R"], "R") if p[0] == part else p[2] for p in parts]
        return network.with_parts(values)

    def fault_part(self, network, cell=None, part=None):
        """The resistor ``part``."""
        return part

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
        return self.apply_fault(network, {"R": values["R"], "part": settings["part"]})

    def implausible(self, network, values, settings):
        """A resistor more than :data:`~creepcomp.diagnose.effects._network.PART_FACTOR` off
        its design value."""
        part = settings.get("part")
        return off_design(values["R"], resistor_parts(network)[part], part)

    def random_fault(self, rng, network, duration):
        """A random resistor 8-25 % off either way."""
        parts = resistor_parts(network)
        label = str(rng.choice(sorted(parts)))
        sign = rng.choice([-1.0, 1.0])
        return {"R": parts[label] * (1.0 + sign * rng.uniform(0.08, 0.25)), "part": label}

    def small_faults(self, network, size, duration):
        """Every resistor ``size`` high."""
        return [(label, self.apply_fault(network, {"R": r * (1.0 + size), "part": label}))
                for label, r in resistor_parts(network).items()]


EFFECT = ResistorValue()
