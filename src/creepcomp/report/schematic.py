"""A schematic of the correction network with its values, drawn with schemdraw.

The sensor (a voltage source behind its output resistance) drives the series cells (each
``R ‖ C``) from ``in`` to ``out``; from ``out`` to ground hang ``R2``, the shunt branches and
the next stage's input resistance. Thermistors are drawn as thermistors with ``R25`` and
``B``. SVG is drawn without matplotlib; PNG through matplotlib's file backend.
"""

from __future__ import annotations

from pathlib import Path

from creepcomp.analog.parts import PartsPlan
from creepcomp.io.atomic import atomic_path, write_text_atomic
from creepcomp.network import Network
from creepcomp.units import format_quantity

__all__ = ["schematic_drawing", "schematic_svg", "draw_network"]

#: Height of a parallel R ‖ C cell's arms above and below the signal line.
_ARM = 1.1
#: Horizontal spacing of the branches to ground.
_PITCH = 2.6


def _value(label: str, kind: str, value: float, plan: PartsPlan) -> tuple[str, bool]:
    """A part's label text and whether it is a thermistor."""
    if label in plan.thermistors:
        th = plan.thermistors[label]
        text = f"{label} NTC\n{format_quantity(th.r25, 'Ω')}, B {th.b:.0f} K"
        if th.series:
            text += f"\n+ {format_quantity(th.series, 'Ω')}"
        if th.parallel:
            text += f"\n‖ {format_quantity(th.parallel, 'Ω')}"
        return text, True
    return f"{label}\n{format_quantity(value, 'Ω' if kind == 'R' else 'F')}", False


def schematic_drawing(network: Network, plan: PartsPlan | None = None, canvas: str = "svg"):
    """The network as a ``schemdraw.Drawing`` (not yet drawn).

    Parameters
    ----------
    network : Network
        Part values at 25 °C.
    plan : PartsPlan, optional
        Which resistors are thermistors (default: none).
    canvas : {"svg", "matplotlib"}
        schemdraw's backend.

    Returns
    -------
    schemdraw.Drawing
    """
    import schemdraw
    import schemdraw.elements as elm

    plan = plan or PartsPlan()
    values = {label: (kind, v) for label, kind, v in network.parts()}
    d = schemdraw.Drawing(canvas=canvas, show=False)
    d.config(fontsize=11, unit=2.5)

    source = d.add(elm.SourceV().up().label("sensor", loc="bottom"))
    d.add(elm.Ground().at(source.start).label("gnd", loc="right", fontsize=10))
    if network.source_resistance > 0:
        d.add(elm.Resistor().right().at(source.end)
              .label(f"Rs\n{format_quantity(network.source_resistance, 'Ω')}")
              .label("(sensor)", loc="bottom", fontsize=9))
    else:
        d.add(elm.Line().right(1.0).at(source.end))
    d.add(elm.Dot().label("in", loc="top"))
    for k, cell in enumerate(network.cells):
        d.add(elm.Line().right(0.8))
        r_label = network.cell_label("R", k)
        r_text, thermistor = _value(r_label, "R", cell.R, plan)
        resistor = elm.Thermistor if thermistor else elm.Resistor
        start = d.here
        if cell.C <= 0:
            d.add(resistor().right().label(r_text))
        else:
            c_label = network.cell_label("C", k)
            d.add(elm.Line().up(_ARM).at(start))
            d.add(resistor().right().label(r_text))
            d.add(elm.Line().down(_ARM))
            d.add(elm.Line().down(_ARM).at(start))
            d.add(elm.Capacitor().right().label(_value(c_label, "C", values[c_label][1], plan)[0],
                                                loc="bottom"))
            d.add(elm.Line().up(_ARM))
            d.add(elm.Dot().at(start))
            d.add(elm.Dot().at((start[0] + d.unit, start[1])))
    d.add(elm.Line().right(0.8))
    node = d.add(elm.Dot().label("out", loc="top"))

    branches = []
    if network.R2 is not None:
        branches.append(("R2",) + _value("R2", "R", network.R2, plan))
    shunt_labels = [label for label, kind, _ in network.parts() if label.startswith("R3")]
    for j, b in enumerate(network.shunt):
        branches.append(("shunt", shunt_labels[j], b))
    if network.load_resistance is not None:
        branches.append(("RL", f"RL\n{format_quantity(network.load_resistance, 'Ω')}\n(next stage)",
                         False))
    top = node.center
    for i, branch in enumerate(branches):
        if i:
            d.add(elm.Line().right(_PITCH).at(top))
            top = d.here
            d.add(elm.Dot())
        if branch[0] == "shunt":
            _, r_label, b = branch
            c_label = "C" + r_label[1:]
            d.add(elm.Resistor().down().at(top).label(f"{r_label}\n{format_quantity(b.R, 'Ω')}",
                                                      loc="bottom"))
            d.add(elm.Capacitor().down().label(f"{c_label}\n{format_quantity(b.C, 'F')}",
                                               loc="bottom"))
        else:
            _, text, thermistor = branch
            resistor = elm.Thermistor if thermistor else elm.Resistor
            part = resistor().down().at(top).label(text, loc="bottom")
            if branch[0] == "RL":
                part = part.linestyle("--")
            d.add(part)
        d.add(elm.Ground())
    if not branches:
        d.add(elm.Line().right(1.0).at(top))
    return d


def schematic_svg(network: Network, plan: PartsPlan | None = None) -> str:
    """The schematic as SVG text (for HTML reports)."""
    d = schematic_drawing(network, plan, "svg")
    data = d.get_imagedata("svg")
    return data.decode() if isinstance(data, bytes) else data


def draw_network(network: Network, path: str | Path, plan: PartsPlan | None = None) -> Path:
    """Draw the network's schematic into ``path`` (``.svg`` or ``.png``), atomically."""
    path = Path(path)
    if path.suffix.lower() == ".svg":
        text = schematic_svg(network, plan)
        return write_text_atomic(path, text)
    d = schematic_drawing(network, plan, "matplotlib")
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as f:
            f.write(d.get_imagedata("png"))
    return path
