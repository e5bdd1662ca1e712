"""The built network: its faults (the circuit side of ``docs/diagnosis.md``) and how to fix them.

A built correction network never matches its design exactly. The circuit-side effects are
changes of the :class:`~creepcomp.network.Network` itself, each with its physical parameters:
a capacitor off its value, a source resistance, a load resistance, dielectric absorption (a
series R-C branch across the capacitor), leakage (a resistance across it) and a resistor off
its value (any resistor of the design: R1 of each cell, R2, the shunt branches' R3). Applied to the
nominal network they give the as-built network; its simulation is the one exact ``H(s)``.

The fix: which single part to change, to what E-series value, and the residual creep that
leaves, computed for the sensor's creep model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from creepcomp.analog import eseries
from creepcomp.errors import InputError
from creepcomp.model import CreepModel
from creepcomp.network import Network, modal_form, state_matrices
from creepcomp.analog.quality import screening_deviation, step_peak

__all__ = ["CIRCUIT_EFFECTS", "FIX_SPAN", "IMPROVEMENT", "capacitor_cells", "largest_capacitor",
           "resistor_parts", "fault_part", "exact_equivalents", "apply_fault", "FixOption", "suggest_fixes"]

CIRCUIT_EFFECTS = ("capacitor_value", "source_impedance", "load_impedance",
                   "dielectric_absorption", "capacitor_leakage", "resistor_value")

#: Range searched around a part's value for its replacement (factor either way).
FIX_SPAN = 2.0
#: A fix must bring the residual creep below this fraction of the as-built one.
IMPROVEMENT = 0.99


def capacitor_cells(network: Network) -> list[int]:
    """Indices of the cells that hold a capacitor."""
    return [k for k, c in enumerate(network.cells) if c.C > 0]


def largest_capacitor(network: Network) -> int:
    """Index of the cell with the largest capacitor (where a capacitor's fault sits by default)."""
    caps = capacitor_cells(network)
    if not caps:
        raise InputError("the network has no capacitor in its series chain")
    return max(caps, key=lambda i: network.cells[i].C)


def resistor_parts(network: Network) -> dict[str, float]:
    """The network's resistors by designator (``R1`` or ``R1.k``, ``R2``, ``R3`` or ``R3.j``,
    as :meth:`~creepcomp.network.Network.parts` names them) with their values (ohm)."""
    return {label: value for label, kind, value in network.parts() if kind == "R"}


def fault_part(network: Network, effect: str, cell: int | None = None, part: str | None = None) -> str | None:
    """The designator a fault sits on: the resistor ``part`` of a ``resistor_value``, the
    capacitor of ``cell`` (``C1`` or ``C1.k``) of a capacitor's fault, None for the source and
    load resistances."""
    if effect == "resistor_value":
        return part
    if cell is None:
        return None
    return "C1" if len(network.cells) == 1 else f"C1.{cell + 1}"


def exact_equivalents(network: Network, effect: str, part: str | None = None) -> list[tuple[str, str | None]]:
    """Other faults that change the network's ``H(s)`` in exactly the same way, whatever the
    record: ``(effect, part)`` pairs (``part`` as :func:`fault_part` names it).

    - a load resistance ``RL`` and ``R2`` lower (``R2 || RL``; e.g. R2 15 % low is a load of
      5.7 R2);
    - leakage ``RP`` across a cell's capacitor and that cell's resistor lower (``R1 || RP``;
      R1 20 % low is a leakage of 4 R1);
    - a source resistance and a higher plain series resistor (a cell without capacitor, e.g.
      the series R1 of a lag network): they add.
    """
    many = len(network.cells) > 1
    resistor = {k: f"R1.{k + 1}" if many else "R1" for k in range(len(network.cells))}
    capacitor = {k: f"C1.{k + 1}" if many else "C1" for k in range(len(network.cells))}
    plain = [resistor[k] for k, c in enumerate(network.cells) if not c.C > 0]
    pairs = []
    if network.R2 is not None:
        pairs.append((("load_impedance", None), ("resistor_value", "R2")))
    for k, c in enumerate(network.cells):
        if c.C > 0:
            pairs.append((("capacitor_leakage", capacitor[k]), ("resistor_value", resistor[k])))
    pairs.extend((("source_impedance", None), ("resistor_value", r)) for r in plain)
    me = (effect, part)
    out = [b for a, b in pairs if a == me] + [a for a, b in pairs if b == me]
    return out


def apply_fault(network: Network, effect: str, params: dict, cell: int | None = None) -> Network:
    """The network with one circuit-side effect.

    Parameters
    ----------
    network : Network
        Nominal (or already faulted) network.
    effect : str
        One of :data:`CIRCUIT_EFFECTS`.
    params : dict
        ``capacitor_value``: ``C`` (F); ``source_impedance``: ``R`` (ohm, added to the
        design's source resistance); ``load_impedance``: ``R`` (ohm, in parallel with the
        design's load); ``dielectric_absorption``: ``fraction`` (of C) and ``tau`` (s);
        ``capacitor_leakage``: ``R`` (ohm across the capacitor); ``resistor_value``: ``R``
        (ohm, the resistor's value as built) and ``part`` (its designator, see
        :func:`resistor_parts`).
    cell : int, optional
        Which cell's capacitor (default: the one with the largest capacitance).

    Returns
    -------
    Network
    """
    if effect in ("capacitor_value", "dielectric_absorption", "capacitor_leakage"):
        if not capacitor_cells(network):
            raise InputError(f"{effect}: the network has no capacitor in its series chain")
        k = largest_capacitor(network) if cell is None else cell
        c = network.cells[k]
        if effect == "capacitor_value":
            new = replace(c, C=_positive(params["C"], "C"))
        elif effect == "capacitor_leakage":
            new = replace(c, leakage=_positive(params["R"], "R"))
        else:
            fraction, tau = _positive(params["fraction"], "fraction"), _positive(params["tau"], "tau")
            c_da = fraction * c.C
            new = replace(c, absorption_C=c_da, absorption_R=tau / c_da)
        cells = list(network.cells)
        cells[k] = new
        return replace(network, cells=tuple(cells))
    if effect == "resistor_value":
        parts = network.parts()
        labels = [p[0] for p in parts if p[1] == "R"]
        part = params.get("part")
        if part not in labels:
            raise InputError(f"resistor_value: part {part!r} is not a resistor of the network "
                             f"(its resistors: {', '.join(labels)})")
        values = [_positive(params["R"], "R") if p[0] == part else p[2] for p in parts]
        return network.with_parts(values)
    if effect == "source_impedance":
        return replace(network, source_resistance=network.source_resistance + _positive(params["R"], "R"))
    if effect == "load_impedance":
        r = _positive(params["R"], "R")
        rl = r if network.load_resistance is None else 1.0 / (1.0 / r + 1.0 / network.load_resistance)
        return replace(network, load_resistance=rl)
    raise InputError(f"unknown circuit effect '{effect}' (known: {', '.join(CIRCUIT_EFFECTS)})")


def _positive(value, name: str) -> float:
    x = float(value)
    if not (math.isfinite(x) and x > 0):
        raise InputError(f"{name} = {value!r}: must be positive and finite")
    return x


@dataclass(frozen=True)
class FixOption:
    """One way to fix a built network.

    Attributes
    ----------
    part : str
        Designator (``R1``, ``C1``, ``R2`` ...).
    value_from, value_to : float
        The part's value now (as built) and the series value to fit.
    series : str
        E-series of the new part.
    residual_creep_peak : float
        Peak residual creep of a load step with the change (fraction of the step).
    note : str
        What the change does (e.g. a new capacitor also drops the old one's absorption).
    """

    part: str
    value_from: float
    value_to: float
    series: str
    residual_creep_peak: float
    note: str = ""

    def to_dict(self) -> dict:
        """JSON form."""
        return {"part": self.part, "from": self.value_from, "to": self.value_to,
                "series": self.series, "residual_creep_peak": self.residual_creep_peak,
                "note": self.note}


def suggest_fixes(as_built: Network, model: CreepModel, resistor_series: str = "E24",
                  capacitor_series: str = "E6", count: int = 3) -> list[FixOption]:
    """The best single-part changes of a built network, by predicted residual creep.

    Every resistor may be replaced by a series value within a factor :data:`FIX_SPAN` of
    its value, keeping the capacitors as built (with their absorption and leakage); every
    capacitor may be replaced by a new part of the capacitor series, which drops the old
    part's absorption and leakage. Candidates are ranked with the closed form and the best
    re-checked with python-control.

    Returns
    -------
    list of FixOption
        Best first, at most ``count``; only changes that lower the residual creep by more
        than 1 % of its value (empty when no single part helps).
    """
    parts = as_built.parts()
    candidates: list[tuple[str, float, float, str, Network, str]] = []
    many = len(as_built.cells) > 1
    for j, (label, kind, value) in enumerate(parts):
        series = resistor_series if kind == "R" else capacitor_series
        for v in eseries.values_in_range(series, value / FIX_SPAN, value * FIX_SPAN):
            if abs(v / value - 1) < 1e-9 and not (kind == "C" and _has_faults(as_built, label)):
                continue
            values = [p[2] for p in parts]
            values[j] = float(v)
            net = as_built.with_parts(values)
            note = ""
            if kind == "C" and label.startswith("C1"):
                k = int(label.split(".")[1]) - 1 if many else 0
                cells = list(net.cells)
                cells[k] = cells[k].ideal()
                note = "a new capacitor (film, low absorption and leakage)"
                net = replace(net, cells=tuple(cells))
            candidates.append((label, value, float(v), series, net, note))
    if not candidates:
        return []
    scores = np.array([_screen_one(model, c[4]) for c in candidates])
    best = np.argsort(scores)[: max(count * 3, count)]
    checked = []
    for i in best:
        label, old, new, series, net, note = candidates[i]
        checked.append(FixOption(label, old, new, series, step_peak(model, net)[0], note))
    checked.sort(key=lambda f: f.residual_creep_peak)
    now = step_peak(model, as_built)[0]
    out, seen = [], set()
    for f in checked:
        if f.residual_creep_peak < IMPROVEMENT * now and f.part not in seen:
            out.append(f)
            seen.add(f.part)
    return out[:count]


def _has_faults(network: Network, label: str) -> bool:
    """True when the capacitor ``label`` carries absorption or leakage (a shunt branch's
    ``C3`` has neither)."""
    if not label.startswith("C1"):
        return False
    k = int(label.split(".")[1]) - 1 if "." in label else 0
    cell = network.cells[k]
    return cell != cell.ideal()


def _screen_one(model: CreepModel, network: Network) -> float:
    d, r, p = modal_form(*state_matrices(*network.as_arrays()))
    return float(screening_deviation(model, d, r, p)[0])
