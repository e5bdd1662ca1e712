"""The built network's parts, as its faults and their fixes name them, and how to fix it.

A built correction network never matches its design exactly: a capacitor off its value, a
source or load resistance, dielectric absorption, leakage, a resistor off its value. Each such
fault is a circuit effect of :mod:`creepcomp.diagnose.effects` (``docs/diagnosis.md``, circuit
side), which applies it to the nominal network; this module holds what they share about the
network's parts (its capacitors, resistors and their designators), none of them by name.

The fix: which single part to change, to what E-series value, and the residual creep that
leaves, computed for the sensor's creep model.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from creepcomp.analog import eseries
from creepcomp.errors import InputError
from creepcomp.model import CreepModel
from creepcomp.network import Network, modal_form, state_matrices
from creepcomp.analog.quality import screening_deviation, step_peak

__all__ = ["FIX_SPAN", "IMPROVEMENT", "capacitor_cells", "largest_capacitor", "resistor_parts",
           "capacitor_label", "series_resistor_label", "FixOption", "suggest_fixes"]

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


def capacitor_label(network: Network, cell: int) -> str:
    """The designator of ``cell``'s capacitor: ``C1``, or ``C1.k`` in a network of several cells."""
    return network.cell_label("C", cell)


def series_resistor_label(network: Network, cell: int) -> str:
    """The designator of ``cell``'s resistor: ``R1``, or ``R1.k`` in a network of several cells."""
    return network.cell_label("R", cell)


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
