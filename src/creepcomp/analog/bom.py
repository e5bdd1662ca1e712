"""The bill of materials of a network: one row per part, as a table, CSV or JSON.

Each row names the part (``ref``), its value with unit, the E-series it comes from, the
tolerance, technology and temperature coefficient bought (from the design's
:class:`~creepcomp.analog.parts.PartsPlan`; a resistor the plan's technology does not make
takes the first technology that does, :func:`~creepcomp.analog.practicality.resistor_technology`)
and a note: what the part does, a capacitor's dielectric absorption, a thermistor's ``B`` and
``R25``.
"""

from __future__ import annotations

import csv
import io
from dataclasses import asdict, dataclass
from pathlib import Path

from creepcomp.analog.parts import DIELECTRICS, RESISTORS, PART_REFERENCE, PartsPlan
from creepcomp.analog.practicality import part_tolerance, resistor_technology
from creepcomp.io.atomic import write_text_atomic
from creepcomp.io.outputs import csv_cell
from creepcomp.model import CreepModel
from creepcomp.network import Network
from creepcomp.temperature import ZERO_CELSIUS
from creepcomp.units import format_quantity

__all__ = ["BOM_COLUMNS", "BomRow", "bom_rows", "bom_csv", "write_bom"]

#: The columns of the CSV, in order.
BOM_COLUMNS = ("ref", "value", "series", "tolerance", "technology", "tc", "note")


@dataclass(frozen=True)
class BomRow:
    """One part: the text of each column (units included)."""

    ref: str
    value: str
    series: str
    tolerance: str
    technology: str
    tc: str
    note: str

    def to_dict(self) -> dict:
        return asdict(self)


def _percent(x: float) -> str:
    return f"{100 * x:.3g} %"


def _ppm(tc: float) -> str:
    return f"{tc * 1e6:.0f}"


def _dielectric_name(key: str) -> str:
    name = DIELECTRICS[key].name
    return name if "ceramic" in name else f"{name} film"


def _role(label: str, network: Network, model: CreepModel | None) -> str:
    """What a part does in the circuit."""
    rest = label[1:]
    if rest.startswith("2"):
        return "to ground: with the cells, sets the DC gain"
    if rest.startswith("3"):
        return "shunt branch to ground (lag network)"
    k = int(rest.split(".")[1]) - 1 if "." in rest else 0
    cell = network.cells[k]
    if cell.C <= 0:
        return "series resistor"
    text = f"cell {k + 1}: R·C = {format_quantity(cell.R * cell.C, 's')}"
    if model is not None and model.sign > 0 and k < model.n_terms:
        text += (f", cancels {100 * model.beta[k]:.3g} % of creep at "
                 f"{format_quantity(model.tau[k], 's')}")
    return text


def bom_rows(network: Network, plan: PartsPlan | None = None,
             series: dict | None = None, model: CreepModel | None = None) -> list[BomRow]:
    """The bill of materials of ``network``, one row per part in circuit order.

    Parameters
    ----------
    network : Network
        Part values at 25 °C.
    plan : PartsPlan, optional
        Technologies, tolerances and thermistors (default: the default plan).
    series : dict, optional
        E-series by kind, ``{"R": "E24", "C": "E6"}``; None or a missing kind: ``-``.
    model : CreepModel, optional
        The creep the network cancels, for the notes.

    Returns
    -------
    list of BomRow
    """
    plan = plan or PartsPlan()
    series = series or {}
    if getattr(network, "topology", None) == "active":
        return _active_rows(network, plan, series, model)
    rows = []
    for label, kind, value in network.parts():
        role = _role(label, network, model)
        rows += _part_rows(label, kind, value, role, plan, series)
    return rows


def _part_rows(label: str, kind: str, value: float, role: str, plan: PartsPlan,
               series: dict) -> list[BomRow]:
    """The rows of one part: a resistor, a capacitor, or a thermistor and its fixed resistors."""
    rows = []
    tol = _percent(part_tolerance(label, kind, value, plan))
    if label in plan.thermistors:
        th = plan.thermistors[label]
        t = PART_REFERENCE + ZERO_CELSIUS
        rows.append(BomRow(label, format_quantity(th.r25, "Ω"), "-", tol, "NTC thermistor",
                           _ppm(-th.b / t ** 2),
                           f"{th.part}: B = {th.b:.0f} K, R25 = {format_quantity(th.r25, 'Ω')} "
                           f"(±{_percent(th.b_tolerance)} on B); {role}"))
        for suffix, fixed, how in (("s", th.series, "in series with"),
                                   ("p", th.parallel, "in parallel with")):
            if fixed:
                rows.append(BomRow(f"{label}{suffix}", format_quantity(fixed, "Ω"),
                                   series.get("R") or "-", _percent(plan.resistor_tolerance),
                                   RESISTORS[plan.resistor].name, _ppm(plan.resistor_tc),
                                   f"fixed resistor {how} the thermistor {label}"))
        return rows
    if kind == "R":
        tech = resistor_technology(value, plan)
        if tech is None:
            technology, tc, note = "not made", plan.resistor_tc, f"no technology makes it; {role}"
        else:
            technology = RESISTORS[tech].name
            tc = plan.resistor_tc if tech == plan.resistor else RESISTORS[tech].tc
            note = role if tech == plan.resistor else (
                f"{RESISTORS[plan.resistor].name} is made up to "
                f"{format_quantity(RESISTORS[plan.resistor].value_range[1], 'Ω')}; {role}")
        rows.append(BomRow(label, format_quantity(value, "Ω"), series.get("R") or "-", tol,
                           technology, _ppm(tc), note))
    else:
        d = DIELECTRICS[plan.capacitor]
        lo, hi = d.absorption
        rows.append(BomRow(label, format_quantity(value, "F"), series.get("C") or "-", tol,
                           _dielectric_name(plan.capacitor), _ppm(plan.capacitor_tc),
                           f"dielectric absorption {_percent(lo)} .. {_percent(hi)}; {role}"))
    return rows


def _active_role(label: str, stage, model: CreepModel | None) -> str:
    """What a part of the active stage does."""
    if label == "RS0":
        return "output summer, from the input: with each RSj sets the amplitude RS0/RSj"
    j = int(label.lstrip("RTCABGS")) - 1
    t = stage.terms[j]
    k = j + 1
    return {"RT": f"integrator {k}'s input resistor: with C{k} and the divider sets the "
                  f"time constant {format_quantity(t.time_constant, 's')} (at 25 °C)",
            "C": f"integrator {k}'s capacitor (U{k} feedback)",
            "RA": f"divider {k}, from the input",
            "RB": f"divider {k}, from integrator {k}'s output",
            "RG": f"divider {k}, to ground: ratio {t.alpha:.4g}",
            "RS": f"output summer, from integrator {k}: amplitude RS0/RS{k}"}[label.rstrip("0123456789")]


def _active_rows(stage, plan: PartsPlan, series: dict, model: CreepModel | None) -> list[BomRow]:
    """The active stage's parts and its op amps (:data:`~creepcomp.analog.active.OP_AMP`)."""
    from creepcomp.analog.active import OP_AMP

    rows = []
    for label, kind, value in stage.parts():
        rows += _part_rows(label, kind, value, _active_role(label, stage, model), plan, series)
    for k in range(1, len(stage.terms) + 1):
        rows.append(BomRow(f"U{k}", "op amp", "-", "-", "op amp", "-",
                           f"integrator {k}: {OP_AMP.text()}" if k == 1 else
                           f"integrator {k}: as U1"))
    rows.append(BomRow("U0", "op amp", "-", "-", "op amp", "-", "output follower: as U1"))
    if stage.input_buffer:
        rows.append(BomRow("Uin", "op amp", "-", "-", "op amp", "-",
                           "input follower (the sensor has a source resistance): as U1"))
    return rows


def bom_csv(rows: list[BomRow]) -> str:
    """The BOM as CSV text (header :data:`BOM_COLUMNS`; ``tc`` in ppm/K)."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(BOM_COLUMNS)
    for row in rows:
        writer.writerow([csv_cell(getattr(row, c)) for c in BOM_COLUMNS])
    return buf.getvalue()


def write_bom(path: str | Path, rows: list[BomRow]) -> Path:
    """Write the BOM as CSV, atomically (check the path first with
    :func:`creepcomp.io.outputs.check_outputs`)."""
    return write_text_atomic(path, bom_csv(rows))
