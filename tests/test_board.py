"""From design to board: the practicality verdict and its way out, the BOM, the schematic,
the network for other simulators (a plain .subckt run in a bench written here, an LTspice
schematic read back with spicelib)."""

import csv
import io
import json
import re

import numpy as np
import pytest

from creepcomp.analog.bom import BOM_COLUMNS, bom_csv, bom_rows
from creepcomp.io.outputs import csv_cell
from creepcomp.analog.parts import DIELECTRICS, RESISTORS, PartsPlan, ThermistorUse
from creepcomp.analog.practicality import find_way_out, judge, judge_network, made_range
from creepcomp.analog.sizing import NoNetworkInRange, size
from creepcomp.model import CreepModel
from creepcomp.network import Branch, Cell, Network
from creepcomp.units import parse_quantity

DEFAULT = CreepModel.voigt(0.03, 45.0)
LOAD_CELL = CreepModel(beta=(0.0005, 0.0002), tau=(1200.0, 30.0))


# --- the verdict ------------------------------------------------------------------------

def test_default_sensor_is_practical():
    verdict = judge(size(DEFAULT))
    assert verdict.practical and verdict.reasons == ()
    assert verdict.leakage_peak < 0.01 * verdict.uncorrected_peak
    assert verdict.worst_case_peak < 0.1 * verdict.uncorrected_peak


def test_parts_not_made_and_leakage_are_named():
    wide = size(LOAD_CELL, res_range=(10, 100e9), source_resistance=1e4)
    verdict = judge(wide)
    assert not verdict.practical
    assert any(r.startswith("R2 = 24 GΩ is outside what resistors are made") for r in verdict.reasons)
    assert any("leakage path" in r for r in verdict.reasons)
    assert verdict.leakage_peak > verdict.uncorrected_peak
    huge = judge(size(LOAD_CELL, cap_range=(1e-6, 10.0), source_resistance=1e4, load_resistance=1e6))
    assert [r.split(" = ")[0] for r in huge.reasons] == ["C1.1", "C1.2"]


def test_loose_tolerances_are_judged_by_the_worst_corner():
    net = size(DEFAULT).chosen
    tight = judge_network(DEFAULT, net, PartsPlan(resistor_tolerance=0.01))
    loose = judge_network(DEFAULT, net, PartsPlan(resistor_tolerance=0.5, capacitor_tolerance=0.5))
    assert tight.practical and not loose.practical
    assert loose.worst_case_peak > loose.uncorrected_peak
    assert "worst corner" in loose.reasons[0] and loose.corners == 8


def test_way_out_is_a_buffer_when_the_load_is_too_low():
    options = {"load_resistance": 1e6}
    with pytest.raises(NoNetworkInRange) as exc:
        size(DEFAULT, **options)
    assert exc.value.fixable is False and "not made above 100 µF" in str(exc.value)
    way = find_way_out(DEFAULT, options)
    assert way.kind == "size" and way.changes == {"load_resistance": None}
    assert way.verdict.practical and way.report.chosen.load_resistance is None


def test_way_out_of_the_load_cell_is_the_firmware():
    way = find_way_out(LOAD_CELL, {"source_resistance": 1e4, "load_resistance": 1e6})
    assert way.kind == "firmware" and way.report is None


def test_way_out_may_drop_a_term():
    # the 1 h term needs R2 above 1 GΩ; the others are buildable
    model = CreepModel(beta=(0.02, 0.02, 0.00005), tau=(3.0, 30.0, 3600.0))
    way = find_way_out(model, {})
    assert way.kind == "size" and way.changes == {"terms": (0, 1)}
    assert way.verdict.practical


def test_capacitance_advice_never_names_parts_not_made():
    with pytest.raises(NoNetworkInRange) as exc:
        size(CreepModel.voigt(0.0005, 1200.0))
    text = str(exc.value)
    assert exc.value.fixable is False and "firmware" in text
    assert "--capacitance" not in text
    with pytest.raises(NoNetworkInRange) as ok:
        size(DEFAULT, cap_range=(1e-9, 2e-9))
    low, high = re.search(r"capacitor of (.+?) \.\. (.+?) brings", str(ok.value)).groups()
    lo_made, hi_made = DIELECTRICS["polypropylene"].value_range
    assert lo_made <= parse_quantity(low.replace(" ", ""), "farad") <= parse_quantity(
        high.replace(" ", ""), "farad") <= hi_made * (1 + 1e-9)


# --- BOM --------------------------------------------------------------------------------

def test_bom_rows_name_value_technology_and_escape_formulas():
    report = size(DEFAULT)
    rows = bom_rows(report.chosen, report.plan, {"R": "E24", "C": "E6"}, DEFAULT)
    assert [r.ref for r in rows] == ["R1", "C1", "R2"]
    r1, c1, r2 = rows
    assert (r1.value, r1.technology, r1.tolerance, r1.tc) == ("3 MΩ", "thin film", "1 %", "25")
    assert (c1.value, c1.technology, c1.tc) == ("15 µF", "polypropylene film", "-200")
    assert "dielectric absorption 0.05 % .. 0.1 %" in c1.note
    # 100 MΩ is above thin film's range: the next technology that makes it
    assert r2.technology == "high-ohmic thick film" and "8.87 MΩ" in r2.note
    table = list(csv.reader(io.StringIO(bom_csv(rows))))
    assert tuple(table[0]) == BOM_COLUMNS
    assert table[2][5] == "-200"      # a number stays a number
    assert all(cell[:1] not in "=+@" for line in table for cell in line if cell)
    assert csv_cell("=1+1") == "'=1+1" and csv_cell("@x") == "'@x" and csv_cell("3 MΩ") == "3 MΩ"
    assert csv_cell("-2+3") == "'-2+3" and csv_cell("\tx") == "'\tx" and csv_cell("-2e-4") == "-2e-4"
    assert csv_cell("-") == "-" and csv_cell("-x") == "'-x"


def test_bom_thermistor_row_gives_b_and_r25():
    net = Network((Cell(1e4, 1e-3),), 1e6)
    plan = PartsPlan(thermistors={"R1": ThermistorUse("Murata NCP18XH103", 1e4, 3380.0, series=470.0)})
    rows = bom_rows(net, plan)
    assert rows[0].technology == "NTC thermistor" and "B = 3380 K" in rows[0].note
    assert "R25 = 10 kΩ" in rows[0].note and rows[1].ref == "R1s" and rows[1].value == "470 Ω"
    assert float(rows[0].tc) == pytest.approx(-3380 / 298.15 ** 2 * 1e6, rel=1e-3)


def test_made_range_spans_the_technologies():
    assert made_range("R", PartsPlan()) == (1.0, 1e9)
    assert made_range("C", PartsPlan(capacitor="x7r")) == DIELECTRICS["x7r"].value_range
    assert set(RESISTORS) >= {"thin film", "high-ohmic thick film"}


# --- the command line ---------------------------------------------------------------------

def test_size_writes_design_bom_schematic_and_json(run_cli, tmp_path):
    out, bom, svg = tmp_path / "d.json", tmp_path / "b.csv", tmp_path / "n.svg"
    status, text, err = run_cli("size", "--beta0", "3%", "--tau", "45s", "-o", out, "--bom", bom,
                                "--schematic", svg, "--capacitor-tolerance", "2.5%",
                                "--dielectric", "polyester", "--json")
    assert status == 0, err
    data = json.loads(text)
    assert data["practical"] is True and data["reasons"] == [] and data["way_out"] is None
    assert [row["ref"] for row in data["bom"]] == ["R1", "C1", "R2"]
    parts = json.loads(out.read_text())["parts"]
    assert parts["capacitors"] == {"technology": "polyester", "tolerance": 0.025,
                                   "tc": DIELECTRICS["polyester"].tc}
    assert bom.read_text(encoding="utf-8").startswith("ref,value,series,tolerance,technology,tc,note")
    drawing = svg.read_text(encoding="utf-8")
    assert drawing.startswith("<svg") and "15 µF" in drawing and "100 MΩ" in drawing


def test_impractical_design_exits_3_with_the_way_out(run_cli, tmp_path):
    model = tmp_path / "lc.json"
    model.write_text(json.dumps({"beta": [0.0005, 0.0002], "tau": [1200, 30]}))
    out = tmp_path / "d.json"
    status, text, err = run_cli("size", "--model", model, "--source-resistance", "10k",
                                "--load-resistance", "1M", "--res-range", "10:100G", "-o", out)
    assert status == 3, err
    assert not out.exists()
    lines = text.strip().splitlines()
    assert lines[0].startswith("impractical: load resistance 1 MΩ is too low")
    assert lines[2].strip() == f"creepcomp firmware {model} --rate 10Hz --full-scale 1 -o {tmp_path / 'firmware'}"


def test_impractical_json_and_allow_impractical(run_cli, tmp_path):
    model = tmp_path / "lc.json"
    model.write_text(json.dumps({"beta": [0.0005, 0.0002], "tau": [1200, 30]}))
    out = tmp_path / "d.json"
    status, text, _ = run_cli("size", "--model", model, "--source-resistance", "10k",
                              "--res-range", "10:100G", "--json")
    data = json.loads(text)
    assert status == 3 and data["practical"] is False
    assert any("24 GΩ" in r for r in data["reasons"]) and data["way_out"]["kind"] == "firmware"
    status, _, err = run_cli("size", "--model", model, "--source-resistance", "10k",
                             "--res-range", "10:100G", "--allow-impractical", "-o", out)
    assert status == 0 and out.exists()


def test_way_out_command_is_complete_and_practical(run_cli, tmp_path):
    status, text, _ = run_cli("size", "--beta0", "3%", "--tau", "45s", "--load-resistance", "1M")
    assert status == 3
    command = text.strip().splitlines()[2].split()
    # the buffer: no --load-resistance (infinite, the default)
    assert command == ["creepcomp", "size", "--beta0", "3%", "--tau", "45s"]
    status, text, _ = run_cli(*command[1:], "--json")
    assert status == 0 and json.loads(text)["practical"] is True


def test_one_term_firmware_model_is_written_beside_the_output(run_cli, tmp_path):
    out = tmp_path / "lc.json"
    status, text, _ = run_cli("size", "--beta0", "0.05%", "--tau", "20min", "-o", out)
    assert status == 3 and not out.exists()
    written = tmp_path / "lc.model.json"  # the model the firmware command reads
    assert json.loads(written.read_text())["beta"] == [0.0005]
    assert f"creepcomp firmware {written} " in text


def test_mc_takes_the_design_parts_by_default(run_cli, tmp_path):
    out = tmp_path / "d.json"
    assert run_cli("size", "--beta0", "3%", "--tau", "45s", "-o", out, "--dielectric", "polyester",
                   "--resistor-tolerance", "0.5%", "--capacitor-tolerance", "10%")[0] == 0
    status, text, err = run_cli("mc", out, "--n", "2000", "--sensitivity-n", "0", "--spot-check", "0",
                                "--no-worst-case", "--json")
    assert status == 0, err
    factors = {f["name"]: f for f in json.loads(text)["factors"]}
    assert factors["R1"]["high"] / factors["R1"]["nominal"] - 1 == pytest.approx(0.005)
    assert factors["C1"]["high"] / factors["C1"]["nominal"] - 1 == pytest.approx(0.10)
    # polyester's dielectric absorption, 0.2 % .. 0.25 %
    assert (factors["C1.absorption"]["low"], factors["C1.absorption"]["high"]) == (0.002, 0.0025)


# --- schematic ----------------------------------------------------------------------------

def test_schematic_draws_every_part_and_thermistors(tmp_path):
    from creepcomp.report.schematic import draw_network, schematic_svg

    net = Network((Cell(3e6, 1e-6), Cell(1e4, 1e-5), Cell(4.7e6, 1e-4)), 3e8, (), 1e4, 1e6)
    plan = PartsPlan(thermistors={"R1.2": ThermistorUse("NCP18XH103", 1e4, 3380.0)})
    svg = schematic_svg(net, plan)
    for text in ("R1.1", "C1.3", "100 µF", "R2", "300 MΩ", "Rs", "RL", "R1.2 NTC", "B 3380 K",
                 ">in<", ">out<", ">gnd<"):
        assert text in svg, text
    png = draw_network(Network((Cell(1e6, 0.0),), None, (Branch(1e5, 1e-5),)), tmp_path / "n.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# --- the network for other simulators -----------------------------------------------------

NETWORKS = {
    "one cell, source and load": Network((Cell(3e6, 1.5e-5),), 1e8, (), 1e4, 1e9),
    "three cells": Network((Cell(3e6, 1e-6), Cell(3e6, 1e-5), Cell(3e6, 1e-4)), 3e8),
    "lag network": Network((Cell(1e6, 0.0),), None, (Branch(1e5, 1e-5), Branch(2e5, 1e-6)), 1e3),
}
#: ngspice's tolerances in the benches written here (its defaults allow 1e-3 of the step).
BENCH_OPTIONS = ".options reltol=1e-7 trtol=1 vntol=1e-10 abstol=1e-16 chgtol=1e-20"


def exact_ramp_step(network, times, rise):
    """Output of python-control's state-space H(s) of the network (source and load included)
    for an input rising linearly from 0 to 1 over ``rise``, then held: solved exactly."""
    from scipy.linalg import expm

    ss = network.state_space()
    a, b, c, d = (np.asarray(m, dtype=float) for m in (ss.A, ss.B, ss.C, ss.D))
    n = a.shape[0]
    ramp = np.zeros((n + 2, n + 2))
    ramp[:n, :n], ramp[:n, n:n + 1], ramp[n, n + 1] = a, b, 1.0 / rise
    hold = np.zeros((n + 1, n + 1))
    hold[:n, :n], hold[:n, n:] = a, b
    out = []
    for t in times:
        x = expm(ramp * min(t, rise))[:n, n + 1]
        u = min(t, rise) / rise
        if t > rise:
            e = expm(hold * (t - rise))
            x, u = e[:n, :n] @ x + e[:n, n], 1.0
        out.append((c @ x).item() + d.item() * u)
    return np.array(out)


def compare_with_control(network, netlist, rise, points=200):
    from creepcomp.verify.ngspice_engine import ngspice

    run = ngspice().run(netlist)
    pick = np.unique(np.linspace(0, len(run.time) - 1, points).astype(int))
    y = run.vectors["out"][pick]
    return float(np.max(np.abs(y - exact_ramp_step(network, run.time[pick], rise))))


def _time_constants(network):
    return [c.R * c.C for c in network.cells if c.C > 0] + [b.R * b.C for b in network.shunt]


@pytest.mark.parametrize("name", NETWORKS)
def test_subckt_runs_in_a_bench_and_agrees_with_python_control(name, tmp_path):
    from creepcomp.verify.netlist_export import subckt_text

    network = NETWORKS[name]
    lib = tmp_path / "net.lib"
    lib.write_text(subckt_text(network))
    text = lib.read_text()
    assert ".control" not in text and "Meg" not in text
    assert re.search(r"^\.subckt creepcomp_network in out gnd$", text, re.M)
    assert {line.split()[0][0] for line in text.splitlines()
            if line and line[0] not in "*."} <= {"R", "C"}
    rcs = _time_constants(network)
    stop, rise = 5 * max(rcs), 1e-3 * min(rcs)
    bench = ["* a step through the sensor's output resistance into the subcircuit",
             f".include {lib}", f"V1 src 0 PWL(0 0 {rise!r} 1)",
             f"Rsensor src in {network.source_resistance!r}" if network.source_resistance
             else "Vwire src in 0",
             "X1 in out 0 creepcomp_network"]
    if network.load_resistance is not None:
        bench.append(f"Rnext out 0 {network.load_resistance!r}")
    bench += [BENCH_OPTIONS, f".tran {stop / 1000!r} {stop!r} 0 {stop / 1000!r}", ".end"]
    assert compare_with_control(network, "\n".join(bench), rise) <= 1e-6


# LTspice's symbols: pins in the symbol's frame; R90 turns (x, y) into (-y, x)
PINS = {"res": ((16, 16), (16, 96)), "cap": ((16, 0), (16, 64)), "voltage": ((0, 16), (0, 96))}


def asc_netlist(path):
    """A SPICE netlist made here from an .asc file's geometry: wires join the points they end
    on, flags name nets, each symbol's pins land on the nets at their positions."""
    parent = {}

    def find(p):
        parent.setdefault(p, p)
        while parent[p] != p:
            p = parent[p]
        return p

    def union(p, q):
        parent[find(p)] = find(q)

    symbols, flags, tran = [], [], None
    for line in path.read_text().splitlines():
        w = line.split()
        if w[0] == "WIRE":
            union((int(w[1]), int(w[2])), (int(w[3]), int(w[4])))
        elif w[0] == "FLAG":
            flags.append(((int(w[1]), int(w[2])), w[3]))
        elif w[0] == "SYMBOL":
            symbols.append({"kind": w[1], "at": (int(w[2]), int(w[3])), "rot": w[4]})
        elif w[0] == "SYMATTR":
            symbols[-1][w[1]] = line.split(maxsplit=2)[2]
        elif w[0] == "TEXT" and "!.tran" in line:
            tran = line.split("!", 1)[1]
    names = {find(p): name for p, name in flags}
    lines = []
    for s in symbols:
        nodes = []
        for x, y in PINS[s["kind"]]:
            if s["rot"] == "R90":
                x, y = -y, x
            p = find((s["at"][0] + x, s["at"][1] + y))
            nodes.append(names.get(p, f"n{abs(hash(p)) % 10 ** 8}"))
        lines.append(f"{s['InstName']} {nodes[0]} {nodes[1]} {s['Value']}")
    return lines, tran


@pytest.mark.parametrize("name", NETWORKS)
def test_asc_reads_back_with_spicelib_and_simulates_the_design(name, tmp_path):
    from spicelib.editor.asc_editor import AscEditor

    from creepcomp.verify.netlist_export import asc_text, spice_name

    network = NETWORKS[name]
    path = tmp_path / "net.asc"
    path.write_text(asc_text(network))
    # spicelib looks for the symbols beside the schematic: minimal ones, pins as LTspice's
    for kind, prefix in (("res", "R"), ("cap", "C"), ("voltage", "V")):
        (a, b) = PINS[kind]
        (tmp_path / f"{kind}.asy").write_text(
            f"Version 4\nSymbolType CELL\nSYMATTR Prefix {prefix}\nPIN {a[0]} {a[1]} NONE 0\n"
            f"PINATTR PinName A\nPINATTR SpiceOrder 1\nPIN {b[0]} {b[1]} NONE 0\n"
            "PINATTR PinName B\nPINATTR SpiceOrder 2\n")
    editor = AscEditor(str(path))
    expected = {spice_name(label): value for label, _, value in network.parts()}
    if network.source_resistance:
        expected["Rs"] = network.source_resistance
    if network.load_resistance is not None:
        expected["RL"] = network.load_resistance
    found = {c: editor.get_component_value(c) for c in editor.get_components() if c != "V1"}
    assert set(found) == set(expected)
    for ref, value in expected.items():
        assert float(found[ref]) == pytest.approx(value, rel=1e-12), ref
    assert editor.get_component_value("V1").startswith("PULSE(0 1 0 ")
    # the wiring: the schematic's own netlist, simulated, is the design's step response
    lines, tran = asc_netlist(path)
    rise = float(editor.get_component_value("V1").split()[3])
    deck = "\n".join(["* from the .asc geometry", *lines, BENCH_OPTIONS, tran, ".end"])
    assert compare_with_control(network, deck, rise) <= 1e-6


def test_netlist_command_writes_subckt_and_asc(run_cli, tmp_path):
    design = tmp_path / "d.json"
    assert run_cli("size", "--beta0", "3%", "--tau", "45s", "-o", design)[0] == 0
    lib, asc = tmp_path / "n.lib", tmp_path / "n.asc"
    status, text, err = run_cli("netlist", design, "--subckt", lib, "--asc", asc, "--json")
    assert status == 0, err
    assert json.loads(text)["ports"] == ["in", "out", "gnd"]
    assert "R1 in out 3000000" in lib.read_text() and "R2 out gnd 100000000" in lib.read_text()
    assert asc.read_text().startswith("Version 4\nSHEET 1 ")
    status, _, err = run_cli("netlist", design, "--subckt", lib, "-o", tmp_path / "x.cir")
    assert status == 2 and "leave out -o" in err


def test_subckt_comments_thermistors():
    from creepcomp.verify.netlist_export import subckt_text

    plan = PartsPlan(thermistors={"R1": ThermistorUse("NCP18XH103", 1e4, 3380.0)})
    text = subckt_text(Network((Cell(1e4, 1e-3),), 1e6), plan=plan)
    assert "* R1 is an NTC thermistor" in text and "B = 3380 K" in text


def test_reports_carry_the_schematic(run_cli, tmp_path):
    design, page, plot = tmp_path / "d.json", tmp_path / "r.html", tmp_path / "p.png"
    assert run_cli("size", "--beta0", "3%", "--tau", "45s", "-o", design, "--plot", plot)[0] == 0
    assert plot.read_bytes()[:4] == b"\x89PNG"
    status, _, err = run_cli("mc", design, "--n", "2000", "--sensitivity-n", "0", "--spot-check", "0",
                             "--no-worst-case", "--report", page)
    assert status == 0, err
    text = page.read_text(encoding="utf-8")
    assert text.index("<h2>Network</h2>") < text.index("<h2>Summary</h2>")
    assert "<svg" in text and "15 µF" in text


def test_way_out_with_fewer_terms_is_a_term_command(run_cli):
    status, text, _ = run_cli("size", "--term", "2%@3s", "--term", "2%@30s", "--term", "0.005%@1h")
    assert status == 3
    command = text.strip().splitlines()[2].split()
    assert command == ["creepcomp", "size", "--term", "2%@3s", "--term", "2%@30s"]
