"""Shared base of the circuit-side effects: a change of the built network itself.

A circuit effect is one module of this package holding ``EFFECT``, an instance of a subclass
of :class:`NetworkEffect` (or of :class:`CapacitorFault` when it sits on a capacitor). The
module says everything about the fault: how it changes a network (:meth:`~NetworkEffect.apply_fault`),
which part it sits on, which faults of other kinds change the network exactly alike, how the
diagnosis fits it, what values a built network can hold and how often it happens (its
:class:`FaultPrior`), what measurement tells it from another fault, and how the generator of
synthetic records draws it. The diagnosis (:mod:`creepcomp.diagnose.circuit`) and the generator
(:mod:`creepcomp.synth.circuit`) iterate over :func:`circuit_effects` and name none.
"""

from __future__ import annotations

import abc
import math
from dataclasses import dataclass, replace

from creepcomp.analog.faults import capacitor_cells, capacitor_label, largest_capacitor
from creepcomp.errors import InputError
from creepcomp.fit.structure import Param
from creepcomp.diagnose.effects import Effect

__all__ = ["PART_FACTOR", "FaultPrior", "NetworkEffect", "CapacitorFault", "circuit_effects", "circuit_effect",
           "apply_fault", "fault_part", "exact_equivalents", "positive", "off_design", "log_param",
           "resistance_scale", "resistance_level"]

#: A part (resistor or capacitor) off its nominal value by more than this factor either way
#: is not a fault of a built network (tolerance, drift, a neighbouring value placed) but
#: another design.
PART_FACTOR = 1.6


@dataclass(frozen=True)
class FaultPrior:
    """How often a circuit fault happens and what a built network can hold.

    Attributes
    ----------
    rate : float
        Share of built networks that carry it (assumed by the project, not measured).
    plausible : str
        The values a built network can hold (beyond them the fit is another design, see
        :meth:`NetworkEffect.implausible`).
    why : str
        What causes it.
    """

    rate: float
    plausible: str
    why: str

    def to_dict(self) -> dict:
        """JSON form."""
        return {"rate": self.rate, "plausible": self.plausible, "why": self.why}


class NetworkEffect(Effect):
    """A circuit-side effect: the network as built differs from its design.

    Subclasses set ``name``, ``parameters``, ``summary``, ``vocabulary_index`` and
    :attr:`prior`, and implement the abstract methods: :meth:`apply_fault` (the physical
    change), :meth:`network_params` (the fitted parameters), :meth:`implausible` (what a built
    network cannot hold), :meth:`random_fault` and :meth:`small_faults` (the generator's
    draws). The other members are hooks with defaults.

    Attributes
    ----------
    per_capacitor : bool
        Sits on a capacitor: fitted once per capacitor of the network.
    vocabulary_index : int
        (of :class:`~creepcomp.diagnose.effects.Effect`) Position in the circuit table of
        ``docs/diagnosis.md``: the order of :func:`circuit_effects`.
    fault_parts : tuple of str
        The physical parts its parameters describe, as the generator's precision rule judges
        them (default: its parameters).
    measured_out_of_circuit : bool
        Sits on a part that a meter measures out of circuit (named in
        :func:`~creepcomp.diagnose.circuit.separating_measurement`).
    alternatives_on_other_parts : bool
        The generator compares a fault of this kind with the same fault on every other part
        of the network (:func:`~creepcomp.synth.circuit.alternative_faults`).
    in_lag_networks : bool
        The generator also draws it in lag networks (an overshooting sensor), which have no
        series capacitor.
    """

    side = "circuit"
    needs = ("corrected",)
    per_capacitor = False
    measured_out_of_circuit = False
    alternatives_on_other_parts = False
    in_lag_networks = False

    @property
    @abc.abstractmethod
    def prior(self) -> FaultPrior:
        """How often the fault happens and what values a built network holds."""

    @property
    def fault_parts(self) -> tuple:
        """The physical parts its parameters describe (default: the parameters)."""
        return tuple(self.parameters)

    # -- the network ------------------------------------------------------------------------
    @abc.abstractmethod
    def apply_fault(self, network, params: dict, cell: int | None = None):
        """The network with this fault at ``params`` (natural units; ``cell``: which cell's
        capacitor, default the largest, for a capacitor's fault)."""

    def fault_part(self, network, cell: int | None = None, part: str | None = None) -> str | None:
        """The designator the fault sits on (None: none, as a source or load resistance)."""
        return None

    def network_settings(self, network) -> list[tuple]:
        """Where the effect may sit: one setting per capacitor, or a single one."""
        if self.per_capacitor:
            return [(("cell", k),) for k in capacitor_cells(network)]
        return [()]

    def part_of(self, network, settings: dict) -> str | None:
        """The designator the effect sits on with these fit settings (``cell`` or ``part``)."""
        return self.fault_part(network, settings.get("cell"), settings.get("part"))

    def placements(self, network) -> list:
        """The designators the effect may sit on (one for each of its settings)."""
        return [self.part_of(network, dict(s)) for s in self.network_settings(network)]

    def exact_twins(self, network, part: str | None) -> list[tuple]:
        """Faults of other kinds that change the network's ``H(s)`` exactly as this one on
        ``part`` does, whatever their values: ``(effect, part)`` pairs (effect objects).
        Declared by one of the two kinds only (see :func:`exact_equivalents`)."""
        return []

    # -- fitting ------------------------------------------------------------------------------
    @abc.abstractmethod
    def network_params(self, data, settings: dict) -> list[Param]:
        """The effect's nonlinear parameters (natural units, bounds)."""

    def network_starts(self, data, settings: dict) -> list[dict]:
        """Start values of its parameters."""
        return [{}]

    def apply_network(self, network, values: dict, settings: dict):
        """The network with this effect at ``values`` (the fit's settings)."""
        return self.apply_fault(network, values, settings.get("cell"))

    def report_network(self, values: dict, settings: dict) -> dict:
        """Reported parameters (natural units)."""
        return {k: float(values[k]) for k in self.parameters}

    # -- judging a fit ------------------------------------------------------------------------
    @abc.abstractmethod
    def implausible(self, network, values: dict, settings: dict) -> str | None:
        """Why fitted ``values`` are not a fault a built ``network`` can hold (see
        :attr:`prior`), or None."""

    def separating_measurement(self, other, own_part: str | None, other_part: str | None,
                               exact: bool) -> tuple[int, str] | None:
        """The measurement that tells this fault (on ``own_part``) from ``other`` (an effect,
        on ``other_part``; ``exact``: the output cannot tell them apart at all), with its
        precedence (the lowest of the two faults' wins), or None: this fault knows none."""
        return None

    # -- the generator ------------------------------------------------------------------------
    @abc.abstractmethod
    def random_fault(self, rng, network, duration: float) -> dict:
        """A random fault of this kind, large enough to matter, with its physical parameters
        (and ``cell`` or ``part`` where it sits); ``duration``: the record's (s)."""

    @abc.abstractmethod
    def small_faults(self, network, size: float, duration: float) -> list[tuple]:
        """Small faults of this kind on every part where it may sit, ``(part, network)``
        pairs: each one's signature is what this effect explains of another fault's to
        first order (``size``: relative size; ``duration``: the record's, s)."""

    def scaled_part(self, params: dict, part: str, h: float) -> dict:
        """The fault's parameters with one of its :attr:`fault_parts` multiplied by
        ``exp(h)``."""
        out = dict(params)
        out[part] = params[part] * math.exp(h)
        return out


class CapacitorFault(NetworkEffect):
    """A fault of a cell's capacitor: implement :meth:`changed_cell`."""

    per_capacitor = True

    @abc.abstractmethod
    def changed_cell(self, cell, params: dict):
        """The cell with this fault at ``params``."""

    def apply_fault(self, network, params: dict, cell: int | None = None):
        """The network with the capacitor of ``cell`` (default: the largest) changed."""
        if not capacitor_cells(network):
            raise InputError(f"{self.name}: the network has no capacitor in its series chain")
        k = largest_capacitor(network) if cell is None else cell
        cells = list(network.cells)
        cells[k] = self.changed_cell(cells[k], params)
        return replace(network, cells=tuple(cells))

    def fault_part(self, network, cell: int | None = None, part: str | None = None) -> str | None:
        """The capacitor of ``cell`` (``C1`` or ``C1.k``; None without a cell)."""
        return None if cell is None else capacitor_label(network, cell)

    def random_fault(self, rng, network, duration: float) -> dict:
        """A random fault on a random capacitor (:meth:`random_cell_fault`), with its ``cell``."""
        k = int(rng.choice(capacitor_cells(network)))
        return dict(self.random_cell_fault(rng, network.cells[k], duration), cell=k)

    @abc.abstractmethod
    def random_cell_fault(self, rng, cell, duration: float) -> dict:
        """The parameters of a random fault of ``cell``'s capacitor."""

    def small_faults(self, network, size: float, duration: float) -> list[tuple]:
        """:meth:`small_cell_faults` on every capacitor."""
        return [(capacitor_label(network, k), self.apply_fault(network, params, k)) for k in capacitor_cells(network)
                for params in self.small_cell_faults(network.cells[k], size, duration)]

    @abc.abstractmethod
    def small_cell_faults(self, cell, size: float, duration: float) -> list[dict]:
        """Parameters of small faults of ``cell``'s capacitor (see :meth:`small_faults`)."""


def circuit_effects() -> list[NetworkEffect]:
    """The circuit-side effects of the registry, in vocabulary order."""
    from creepcomp.diagnose.effects import effects_on

    return effects_on("circuit")


def circuit_effect(effect) -> NetworkEffect:
    """A circuit effect by identifier (an effect object is returned as it is)."""
    if isinstance(effect, NetworkEffect):
        return effect
    known = circuit_effects()
    for e in known:
        if e.name == effect:
            return e
    raise InputError(f"unknown circuit effect '{effect}' (known: {', '.join(e.name for e in known)})")


def apply_fault(network, effect, params: dict, cell: int | None = None):
    """The network with one circuit fault (``effect``: identifier or object; see its
    :meth:`~NetworkEffect.apply_fault`)."""
    return circuit_effect(effect).apply_fault(network, params, cell)


def fault_part(network, effect, cell: int | None = None, part: str | None = None) -> str | None:
    """The designator a fault sits on (see :meth:`NetworkEffect.fault_part`)."""
    return circuit_effect(effect).fault_part(network, cell, part)


def exact_equivalents(network, effect, part: str | None = None) -> list[tuple[str, str | None]]:
    """Other faults that change the network's ``H(s)`` in exactly the same way, whatever the
    record: ``(effect, part)`` pairs of identifiers (``part`` as :func:`fault_part` names it).
    The effects declare them (:meth:`NetworkEffect.exact_twins`), e.g. a load resistance
    ``RL`` and ``R2`` lower (``R2 || RL``), leakage ``RP`` across a cell's capacitor and that
    cell's resistor lower (``R1 || RP``), a source resistance and a higher plain series
    resistor (they add)."""
    me = circuit_effect(effect)
    own = [(e.name, p) for e, p in me.exact_twins(network, part)]
    declared = [(other.name, p) for other in circuit_effects() for p in other.placements(network)
                if any(e is me and q == part for e, q in other.exact_twins(network, p))]
    return own + declared


def positive(value, name: str) -> float:
    """``value`` as a positive finite float (else an :class:`~creepcomp.errors.InputError`)."""
    x = float(value)
    if not (math.isfinite(x) and x > 0):
        raise InputError(f"{name} = {value!r}: must be positive and finite")
    return x


def off_design(value: float, nominal: float, what: str) -> str | None:
    """Why a part fitted at ``value`` is not its design value ``nominal`` off by a fault (more
    than :data:`PART_FACTOR` either way), or None."""
    factor = value / nominal
    if not 1.0 / PART_FACTOR <= factor <= PART_FACTOR:
        return f"{what} fitted at {factor:.3g} times its design value"
    return None


def log_param(name: str, lower: float, upper: float, default: float) -> Param:
    """A positive parameter searched on its logarithm."""
    return Param(name, lower, upper, log=True, default=default)


def resistance_scale(network) -> float:
    """The network's resistance scale for start values and plausible values: the sum of its
    resistors (ohm)."""
    total = sum(c.R for c in network.cells) + (network.R2 or 0.0)
    return total if total > 0 else 1.0


def resistance_level(network) -> float:
    """The resistance level the generator sizes source and load resistances by: ``R2``, or
    the cells' resistors in series without it (ohm)."""
    return network.R2 if network.R2 is not None else sum(c.R for c in network.cells)
