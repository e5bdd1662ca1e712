"""What the command line and its tolerance report print: every value with its unit, residuals
in percent, the report naming what it assumed."""

import html
import re

import pytest

from creepcomp.analog.quality import step_peak
from creepcomp.analog.sizing import design_warnings, size
from creepcomp.io.jsonfiles import Design, write_design
from creepcomp.model import CreepModel
from creepcomp.network import Network
from creepcomp.units import format_parameter, format_time, parse_quantity

#: A number written as a bare exponent (``1.188e+07``): a raw value with no unit.
RAW = re.compile(r"(?<![\w.])-?\d+(?:\.\d+)?e[-+]\d+(?!\d)(?! ?%)")

#: A two-cell design (two creep terms, E24/E6 parts).
TWO_CELLS = {"creep": {"beta": [0.02, 0.01], "tau": [45.0, 600.0]},
             "cells": [{"R": 1.2e6, "C": 3.3e-5}, {"R": 6.8e6, "C": 1.0e-4}],
             "R2": 1.0e8, "source_resistance": 1000.0, "load_resistance": None}


@pytest.mark.parametrize("name,value,text", [
    ("R1.1", 1.188e7, "11.88 MΩ"), ("C1.1", 1.01e-4, "101 µF"), ("R2", 2.4e10, "24 GΩ"),
    ("C3.2", 1e-6, "1 µF"), ("source_resistance", 1e4, "10 kΩ"), ("C1.2.absorption", 5e-4, "0.05 %"),
    ("C1.2.absorption_tau", 31.62, "31.62 s"), ("beta[1]", 0.02, "2 %"), ("tau[0]", 45.0, "45 s"),
])
def test_parameters_are_printed_with_their_unit(name, value, text):
    assert format_parameter(name, value) == text


@pytest.mark.parametrize("seconds,text", [(30.0, "30 s"), (113.6, "113.6 s"), (1200.0, "20 min"),
                                          (5400.0, "90 min"), (9000.0, "2.5 h"), (259200.0, "3 d"),
                                          (0.15, "150 ms")])
def test_times_are_told_in_clock_units_that_read_back(seconds, text):
    assert format_time(seconds) == text
    assert parse_quantity(text.replace(" ", ""), "second") == pytest.approx(seconds)


#: A warning's statement of how a change moves the residual creep.
CHANGE = re.compile(r"would (raise|lower) the peak residual creep from ([\d.e+-]+) % to ([\d.e+-]+) %")


def high_impedance_warnings() -> list[str]:
    """The sizing warnings of two high-impedance networks: the load cell's (a 10 GΩ leak makes
    its residual worse) and a network whose R2 is too large by just what a 10 GΩ leak takes
    away (the leak makes it better)."""
    model = CreepModel(beta=(5e-4, 2e-4), tau=(1200.0, 30.0))
    texts = list(size(model, res_range=(10, 100e9), source_resistance=1e4).warnings)
    model = CreepModel.voigt(0.03, 45.0)
    ideal = size(model, capacitance=1e-6, resistor_series=None, capacitor_series=None,
                 res_range=(10, 1e12))
    net = ideal.ideal
    high = Network(net.cells, 1 / (1 / net.R2 - 1 / 10e9), net.shunt, net.source_resistance,
                   net.load_resistance)
    quality = ideal.chosen_quality.__class__(**{**vars(ideal.chosen_quality),
                                                "residual_creep_peak": step_peak(model, high)[0]})
    return texts + design_warnings(model, high, "exact", quality)


def test_sizing_warnings_give_residuals_in_percent_and_the_right_direction():
    texts = high_impedance_warnings()
    assert sum(t.startswith("high impedance") for t in texts) == 2
    for text in texts:
        assert not RAW.search(text), text
        # a stated change (with the practicality verdict, leakage may be judged elsewhere)
        for verb, before, after in CHANGE.findall(text):
            assert (verb == "raise") == (float(after) > float(before)), text


@pytest.fixture(scope="module")
def two_cell_run(tmp_path_factory):
    """``mc`` of a two-cell design with a dielectric and a temperature: its design file, stdout
    and the report's text."""
    from creepcomp.cli import main
    from creepcomp.cli.common import console, err_console

    folder = tmp_path_factory.mktemp("mc")
    design = write_design(folder / "two-cells.json", TWO_CELLS)
    console.width = err_console.width = 400
    with console.capture() as captured:
        status = main(["mc", str(design), "--n", "2k", "--sensitivity-n", "500", "--spot-check", "0",
                       "--dielectric", "polypropylene", "--temperature", "60",
                       "--report", str(folder / "r.html")])
    assert status == 0
    return design, captured.get(), (folder / "r.html").read_text(encoding="utf-8")


def test_mc_prints_the_worst_case_with_units(two_cell_run):
    design, out, _ = two_cell_run
    line = next(line for line in out.splitlines() if line.startswith("worst case"))
    assert re.search(r"R1\.1 = [\d.]+ MΩ, C1\.1 = [\d.]+ µF", line), line
    assert "C1.1.absorption = " in line and not RAW.search(line), line
    first = out.splitlines()[0]
    assert str(design) in first and "polypropylene capacitors at 60 °C" in first


def test_the_tolerance_report_names_its_design_and_conditions(two_cell_run):
    design, _, page = two_cell_run
    text = html.unescape(page)
    assert f"<td>{design}</td>" in text
    assert re.search(r"<td>capacitor dielectric</td><td>polypropylene", text)
    assert "<td>temperature</td><td>60 °C" in text
    assert "2 terms: 2 % at 45 s, 1 % at 10 min" in text
    assert "R1.1 1.2 MΩ, C1.1 33 µF, R1.2 6.8 MΩ, C1.2 100 µF, R2 100 MΩ" in text


def test_every_table_of_the_tolerance_report_has_units(two_cell_run):
    _, _, page = two_cell_run
    tables = re.findall(r"<table>(.*?)</table>", page, re.S)
    assert len(tables) >= 5
    for table in tables:
        header, *rows = re.findall(r"<tr>(.*?)</tr>", table, re.S)
        cells = [html.unescape(c) for row in rows for c in re.findall(r"<td>(.*?)</td>", row, re.S)]
        assert not [c for c in cells if RAW.search(c)], cells
        heads = html.unescape(header)
        numbers = [c for c in cells if re.fullmatch(r"-?[\d.]+(?: → [\d.]+)?", c)]
        # a column of bare numbers says its unit in its header
        if numbers:
            assert "%" in heads, heads
    # the cells of a multi-cell network with their units, in the worst case and the box
    assert re.search(r"<td>R1\.1</td><td>[\d.]+ MΩ</td>", page)
    assert re.search(r"<td>C1\.2</td><td>[\d.]+ µF</td>", page)
    assert re.search(r"<td>C1\.1\.absorption_tau</td><td>[\d.]+ s</td>", page)


def test_the_report_of_a_design_made_in_python_says_so(tmp_path):
    from creepcomp.report.tolerance import conditions
    from creepcomp.verify.montecarlo import run_monte_carlo
    from creepcomp.verify.tolerances import ToleranceSpec

    model = CreepModel.voigt(0.03, 45.0)
    design = Design(model, size(model).chosen)
    rows = dict(conditions(run_monte_carlo(design, ToleranceSpec(), 200, 0)))
    assert rows["design"] == "made in Python (no file)"
    assert rows["capacitor dielectric"].startswith("none given")
    assert rows["hysteresis sweep"] == "±FS triangle, period 4.712 min"
