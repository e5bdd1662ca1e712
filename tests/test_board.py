"""From design to board: the practicality verdict and its way out, the BOM, the schematic,
the network for other simulators (a plain .subckt run in a bench written here, an LTspice
schematic read back with spicelib)."""

import csv
import io
import json
import re

import numpy as np
import pytest

from creepcomp.analog.bom import BOM_COLUMNS, bom_csv, bom_rows, csv_cell
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
    assert way.kind == "size" and way.changes["terms"] == (0, 1)
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
    assert table[2][5] == "'-200"
    assert all(cell[:1] not in "=+-@" for line in table for cell in line if cell)
    assert csv_cell("=1+1") == "'=1+1" and csv_cell("@x") == "'@x" and csv_cell("3 MΩ") == "3 MΩ"


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
    written = tmp_path / "lc.model.json"
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
