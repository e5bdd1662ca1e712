"""The network for other simulators: a plain SPICE ``.subckt`` and an LTspice schematic.

* :func:`subckt_text`: the network alone, ``.subckt NAME in out gnd``, with only R and C
  elements written by the same code as the ngspice netlists
  (:mod:`creepcomp.verify.netlist`), numbers in plain exponent notation (SPICE's ``M`` is
  milli, ``Meg`` is not read by every simulator), no control language: ngspice, LTspice and
  Xyce read it as it is. The sensor's source resistance and the next stage's load are not
  part of it (the test bench has them).
* :func:`asc_text`: an LTspice schematic (``.asc``, version 4) of the network with a step
  test bench: a unit step behind the sensor's source resistance, the next stage's load, and
  ``.tran``.

Thermistors: no temperature-dependent resistor syntax is common to ngspice (``temper`` in a
behavioural ``r=`` expression), LTspice (``temp``) and Xyce (``TEMP``), so a thermistor is
written as a plain resistor at its 25 °C value with a comment giving its law.
"""

from __future__ import annotations

import logging
import math
from contextlib import contextmanager

from creepcomp.analog.parts import PART_REFERENCE, PartsPlan
from creepcomp.network import Network
from creepcomp.verify.drive import spice_number
from creepcomp.verify.netlist import _Lines, _network_lines, ascii_text

__all__ = ["SUBCKT_NAME", "spice_name", "subckt_text", "asc_text", "step_stop_time"]

#: Name of the subcircuit.
SUBCKT_NAME = "creepcomp_network"


def spice_name(label: str) -> str:
    """The SPICE element name of a design's part (``R1.2`` -> ``R1_2``)."""
    return label.replace(".", "_")


@contextmanager
def _quiet_pyspice():
    """PySpice warns that a node named ``in`` is a Python keyword; the port is meant."""
    logger = logging.getLogger("PySpice")
    level = logger.level
    logger.setLevel(logging.ERROR)
    try:
        yield
    finally:
        logger.setLevel(level)


def _thermistor_comments(network: Network, plan: PartsPlan | None) -> list[str]:
    if plan is None or not plan.thermistors:
        return []
    out = []
    for label, th in plan.thermistors.items():
        law = f"R25*exp(B*(1/(T+273.15)-1/298.15)), R25 = {th.r25:g} ohm, B = {th.b:g} K"
        if th.series:
            law = f"({law}) + {th.series:g} ohm in series"
        if th.parallel:
            law = f"({law}) || {th.parallel:g} ohm"
        out.append(f"* {spice_name(label)} is an NTC thermistor ({ascii_text(th.part)}), written at "
                   f"its {PART_REFERENCE:g} C value; R(T) = {law}. ngspice: r={{...temper...}}; "
                   "LTspice and Xyce: their own temperature syntax")
    return out


def subckt_text(network: Network, name: str = SUBCKT_NAME, plan: PartsPlan | None = None,
                title: str = "creepcomp correction network") -> str:
    """The network alone as a plain SPICE subcircuit with ports ``in``, ``out``, ``gnd``.

    Parameters
    ----------
    network : Network
        The design's network; its source and load resistances are left out.
    name : str
        Subcircuit name.
    plan : PartsPlan, optional
        For the comments on thermistors.
    title : str
        First comment line.

    Returns
    -------
    str
    """
    alone = Network(network.cells, network.R2, network.shunt, 0.0, None)
    lines = _Lines(name)
    with _quiet_pyspice():
        _network_lines(lines, alone, "in", ground="gnd")
    body = [f"* {ascii_text(title)}",
            "* ports: in (from the sensor, behind its source resistance), out (to the next "
            "stage), gnd",
            f"* source resistance {spice_number(network.source_resistance)} ohm and load "
            f"{'none' if network.load_resistance is None else spice_number(network.load_resistance) + ' ohm'}"
            " were assumed by the design and are not part of the subcircuit",
            *_thermistor_comments(network, plan),
            f".subckt {name} in out gnd", lines.text().rstrip("\n"), f".ends {name}"]
    return "\n".join(body) + "\n"


def step_stop_time(network: Network) -> float:
    """A transient long enough to see the network settle: 10 of its longest R·C."""
    rc = [c.R * c.C for c in network.cells if c.C > 0] + [b.R * b.C for b in network.shunt]
    return 10.0 * max(rc or [1.0])


class _Sheet:
    """LTspice schematic text: wires, flags, symbols with their attributes."""

    def __init__(self):
        self.lines = ["Version 4", "SHEET 1 0 0"]
        self.parts: list[tuple[str, str]] = []

    def wire(self, a, b):
        if a != b:
            self.lines.append(f"WIRE {a[0]} {a[1]} {b[0]} {b[1]}")

    def flag(self, at, name):
        self.lines.append(f"FLAG {at[0]} {at[1]} {name}")

    def symbol(self, kind, at, rotation, name, value):
        self.lines += [f"SYMBOL {kind} {at[0]} {at[1]} {rotation}", f"SYMATTR InstName {name}",
                       f"SYMATTR Value {value}"]
        self.parts.append((name, value))

    # pin positions of LTspice's symbols: res (16,16)-(16,96), cap (16,0)-(16,64); R90 maps
    # (x, y) to (-y, x)
    def horizontal(self, kind, left, name, value):
        """A resistor or capacitor from ``left`` to the right; returns its right pin."""
        x, y = left
        if kind == "res":
            self.symbol("res", (x + 96, y - 16), "R90", name, value)
            return x + 80, y
        self.symbol("cap", (x + 64, y - 16), "R90", name, value)
        return x + 64, y

    def vertical(self, kind, top, name, value):
        """A resistor or capacitor from ``top`` down; returns its bottom pin."""
        x, y = top
        if kind == "res":
            self.symbol("res", (x - 16, y - 16), "R0", name, value)
            return x, y + 80
        self.symbol("cap", (x - 16, y), "R0", name, value)
        return x, y + 64


def asc_text(network: Network, stop_time: float | None = None) -> str:
    """An LTspice schematic of the network with a step test bench.

    A 1 V step (``PULSE``, rising in a thousandth of the fastest time constant) behind the
    sensor's source resistance ``Rs`` drives the network; the next stage's input resistance
    ``RL`` loads ``out``. Part names are :func:`spice_name` of the design's labels.

    Parameters
    ----------
    network : Network
    stop_time : float, optional
        End of ``.tran`` (s); default :func:`step_stop_time`.

    Returns
    -------
    str
    """
    n = spice_number
    sheet = _Sheet()
    stop = stop_time or step_stop_time(network)
    rcs = [c.R * c.C for c in network.cells if c.C > 0] + [b.R * b.C for b in network.shunt]
    rise = 10.0 ** math.floor(math.log10(1e-3 * min(rcs or [1.0])))
    sheet.symbol("voltage", (0, -16), "R0", "V1",
                 f"PULSE(0 1 0 {n(rise)} {n(rise)} {n(10 * stop)} {n(20 * stop)})")
    sheet.flag((0, 80), "0")
    here = (0, 0)
    if network.source_resistance > 0:
        sheet.wire(here, (32, 0))
        here = sheet.horizontal("res", (32, 0), "Rs", n(network.source_resistance))
    sheet.wire(here, (here[0] + 48, 0))
    here = (here[0] + 48, 0)
    sheet.flag(here, "in")
    for k, cell in enumerate(network.cells):
        sheet.wire(here, (here[0] + 32, 0))
        x0 = here[0] + 32
        r_name = spice_name(network.cell_label("R", k))
        if cell.C <= 0:
            here = sheet.horizontal("res", (x0, 0), r_name, n(cell.R))
            continue
        top, bottom = -64, 64
        sheet.wire((x0, 0), (x0, top))
        sheet.wire((x0, 0), (x0, bottom))
        end = sheet.horizontal("res", (x0, top), r_name, n(cell.R))
        sheet.wire((end[0], top), (end[0], 0))
        sheet.wire((end[0], 0), (end[0], bottom))
        c_end = sheet.horizontal("cap", (x0 + 8, bottom),
                                 spice_name(network.cell_label("C", k)), n(cell.C))
        sheet.wire((x0, bottom), (x0 + 8, bottom))
        sheet.wire(c_end, (end[0], bottom))
        here = (end[0], 0)
    sheet.wire(here, (here[0] + 48, 0))
    here = (here[0] + 48, 0)
    sheet.flag(here, "out")
    branches = []
    if network.R2 is not None:
        branches.append([("res", "R2", network.R2)])
    shunt_labels = [label for label, _, _ in network.parts() if label.startswith("R3")]
    for label, b in zip(shunt_labels, network.shunt):
        branches.append([("res", spice_name(label), b.R), ("cap", spice_name("C" + label[1:]), b.C)])
    if network.load_resistance is not None:
        branches.append([("res", "RL", network.load_resistance)])
    for i, branch in enumerate(branches):
        if i:
            sheet.wire(here, (here[0] + 96, 0))
            here = (here[0] + 96, 0)
        pin = here
        for kind, name, value in branch:
            pin = sheet.vertical(kind, pin, name, n(value))
        sheet.flag(pin, "0")
    sheet.lines.append(f"TEXT 0 200 Left 2 !.tran {n(stop / 1000)} {n(stop)} 0 {n(stop / 1000)}")
    sheet.lines.append("TEXT 0 232 Left 2 ;creepcomp: step response of the correction network "
                       "(in -> out)")
    return "\n".join(sheet.lines) + "\n"
