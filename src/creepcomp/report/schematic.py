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

__all__ = ["schematic_drawing", "active_drawing", "schematic_svg", "draw_network"]

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
    if getattr(network, "topology", None) == "active":
        return active_drawing(network, plan, canvas)
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


#: Vertical distance between the integrator loops of an active stage.
_LOOP_PITCH = 7.0


def active_drawing(stage, plan: PartsPlan | None = None, canvas: str = "svg"):
    """The active stage (:class:`~creepcomp.analog.active.ActiveStage`) as a
    ``schemdraw.Drawing``: per term the divider ``RA``/``RB``/``RG``, the integrator ``Uj``
    with ``RTj`` (a thermistor when the plan says so) and ``Cj``, its summing resistor
    ``RSj``; ``RS0`` from the input and the output follower ``U0``."""
    import schemdraw
    import schemdraw.elements as elm

    plan = plan or PartsPlan()
    d = schemdraw.Drawing(canvas=canvas, show=False)
    d.config(fontsize=10, unit=2.5)
    source = d.add(elm.SourceV().up().label("sensor", loc="bottom"))
    d.add(elm.Ground().at(source.start))
    if stage.source_resistance > 0:
        d.add(elm.Resistor().right().at(source.end)
              .label(f"Rs\n{format_quantity(stage.source_resistance, 'Ω')}"))
    else:
        d.add(elm.Line().right(1.0).at(source.end))
    if stage.input_buffer:
        d.add(elm.Line().right(0.5))
        buffer = d.add(elm.Opamp(leads=True).anchor("in2").label("Uin", loc="center", ofst=(-0.4, 0)))
        d.add(elm.Line().at(buffer.out).right(0.6))
        tap = d.here
        d.add(elm.Line().at(buffer.in1).up(1.2))
        d.add(elm.Line().to((tap[0], d.here[1])))
        d.add(elm.Line().to(tap))
        d.add(elm.Line().at(tap).right(0.4))
    node_in = d.add(elm.Dot().label("in", loc="top")).center
    bus_x = None
    outs = []
    for j, t in enumerate(stage.terms, 1):
        y = node_in[1] - (j - 1) * _LOOP_PITCH
        start = (node_in[0], y)
        if j > 1:
            d.add(elm.Line().at((node_in[0], y + _LOOP_PITCH)).to(start))
            d.add(elm.Dot().at(start))
        d.add(elm.Resistor().right().at(start).label(f"RA{j}\n{format_quantity(t.RA, 'Ω')}"))
        e = d.add(elm.Dot()).center
        d.add(elm.Resistor().down().at(e).label(f"RG{j}\n{format_quantity(t.RG, 'Ω')}", loc="bottom"))
        d.add(elm.Ground())
        text, thermistor = _value(f"RT{j}", "R", t.RT, plan)
        d.add((elm.Thermistor if thermistor else elm.Resistor)().right().at(e).label(text))
        minus = d.add(elm.Dot()).center
        op = d.add(elm.Opamp(leads=True).anchor("in1").at(minus).label(f"U{j}", loc="center",
                                                                         ofst=(-0.4, 0)))
        d.add(elm.Ground().at(op.in2))
        d.add(elm.Line().up(1.6).at(minus))
        top = d.here
        d.add(elm.Capacitor().right().to((op.out[0], top[1]))
              .label(f"C{j}\n{format_quantity(t.C, 'F')}"))
        d.add(elm.Line().to(op.out))
        d.add(elm.Line().up(3.4).at(e))
        d.add(elm.Resistor().right().to((op.out[0] + 0.8, e[1] + 3.4))
              .label(f"RB{j}\n{format_quantity(t.RB, 'Ω')}"))
        d.add(elm.Line().to((op.out[0] + 0.8, op.out[1])))
        d.add(elm.Dot().at((op.out[0] + 0.8, op.out[1])))
        d.add(elm.Line().at(op.out).right(0.8))
        d.add(elm.Resistor().right().label(f"RS{j}\n{format_quantity(t.RS, 'Ω')}"))
        outs.append(d.here)
        bus_x = d.here[0] if bus_x is None else max(bus_x, d.here[0])
    low = node_in[1] - (len(stage.terms) - 1) * _LOOP_PITCH - 4.5
    d.add(elm.Line().at((node_in[0], node_in[1] - (len(stage.terms) - 1) * _LOOP_PITCH))
          .to((node_in[0], low)))
    d.add(elm.Resistor().right().to((bus_x, low)).label(f"RS0\n{format_quantity(stage.RS0, 'Ω')}"))
    for p in outs:
        d.add(elm.Line().at(p).to((bus_x, p[1])))
    d.add(elm.Line().at((bus_x, outs[0][1])).to((bus_x, low)))
    s_node = d.add(elm.Dot().at((bus_x, low)).label("s", loc="top")).center
    d.add(elm.Line().right(0.8).at(s_node))
    follower = d.add(elm.Opamp(leads=True).anchor("in2").label("U0", loc="center", ofst=(-0.4, 0)))
    d.add(elm.Line().at(follower.out).right(0.8))
    out = d.add(elm.Dot().label("out", loc="top")).center
    d.add(elm.Line().at(follower.in1).up(1.2))
    d.add(elm.Line().to((out[0], d.here[1])))
    d.add(elm.Line().to(out))
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
