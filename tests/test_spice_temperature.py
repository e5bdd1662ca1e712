"""Netlists over temperature (ngspice against python-control at -10, 20, 40 °C) and the
ngspice spot-check of stiff designs."""

import json

import numpy as np
import pytest

from creepcomp.analog.parts import PartsPlan, ThermistorUse, network_at, ntc_resistance
from creepcomp.analog.sizing import size
from creepcomp.io.jsonfiles import Design, write_design
from creepcomp.model import CreepModel
from creepcomp.network import Cell, Network
from creepcomp.temperature import TemperatureLaw
from creepcomp.verify.compare import compare_temperatures
from creepcomp.verify.drive import RAMP_STEP_FRACTION, largest_step, rise_time, synthetic_program
from creepcomp.verify.montecarlo import run_monte_carlo, spot_check
from creepcomp.verify.netlist import program_deck
from creepcomp.verify.tolerances import ToleranceSpec
from creepcomp.verify.variants import step_residual

LAW = TemperatureLaw.arrhenius(43_000.0, 20.0, beta_per_kelvin=(0.002,))
MODEL = CreepModel((0.03,), (45.0,), temperature=LAW)
NETWORK = Network((Cell(3e6, 15e-6),), 1e8)
#: A tracking design made by hand: both resistors NTC thermistors of one B, at their design
#: values at 20 °C; R2 with fixed resistors in series and in parallel.
AT_20 = float(ntc_resistance(1.0, 4250.0, 20.0))
TRACKING = PartsPlan(thermistors={
    "R1": ThermistorUse("NTC", 3e6 / AT_20, 4250.0),
    "R2": ThermistorUse("NTC", 1e8 / AT_20, 4250.0, series=1e3, parallel=1e12)})
TEMPERATURES = (-10.0, 20.0, 40.0)


@pytest.mark.parametrize("plan", [PartsPlan(), TRACKING], ids=["fixed", "tracking"])
def test_ngspice_agrees_with_python_control_at_each_temperature(plan):
    comparisons = compare_temperatures(NETWORK, MODEL, plan, TEMPERATURES, points=500)
    for c in comparisons:
        assert c.agreement_max_abs < 1e-6, c.temperature
    # what each simulator ran is the design at that temperature: the network's values and
    # the sensor's tau follow it
    cold, ref, hot = comparisons
    assert cold.hf_gain == pytest.approx(network_at(NETWORK, plan, -10.0).lag_expansion().direct)
    assert ".options" in cold.deck.text() and "temp=-10" in cold.deck.text()
    # fixed parts sized at 20 °C leave most of the creep back at the limits; NTCs track
    assert ref.residual_creep_peak < 1e-4
    if plan.thermistors:
        assert max(cold.residual_creep_peak, hot.residual_creep_peak) < 0.01
        assert "temper" in cold.deck.text() and "R1 emf out R={" in cold.deck.text()
    else:
        assert cold.residual_creep_peak > 0.015 and hot.residual_creep_peak > 0.01


def test_netlist_at_a_temperature_carries_tcs_the_law_and_thermistors():
    prog = synthetic_program(MODEL, "step")
    text = program_deck(NETWORK, MODEL, prog, 900.0, 200, temperature=40.0, plan=TRACKING).text()
    assert "tnom=25" in text and "temp=40" in text
    assert "C1 emf out 1.5e-05 tc1=-0.0002" in text
    assert "R2s out ntc2 1000" in text and "R2p out 0 1e+12" in text
    assert "Rcreep1 ins creep1 R={exp(" in text and "*(1+0.002*(temper-20))*V(creep1)" in text
    # without a temperature the netlist is the design at its values, as before
    plain = program_deck(NETWORK, MODEL, prog, 900.0, 200).text()
    assert "temper" not in plain and "tc1" not in plain and "tnom" not in plain


def test_cli_simulate_temperatures_json(run_cli, tmp_path):
    design = Design(MODEL, NETWORK, {"parts": TRACKING.to_dict()})
    path = write_design(tmp_path / "tracking.json", design)
    status, out, err = run_cli("simulate", path, "--temperatures", "-10,20,40", "--no-plot",
                               "--points", "400", "--json")
    assert status == 0, err
    data = json.loads(out)
    rows = data["temperatures"]
    assert [r["temperature"] for r in rows] == list(TEMPERATURES) and data["tracking"] == "ntc"
    assert data["agreement_max_abs"] == max(r["agreement_max_abs"] for r in rows) < 1e-6
    assert data["residual_creep_peak"] == max(r["residual_creep_peak"] for r in rows)
    status, out, err = run_cli("simulate", path, "--temperatures", "-10,x", "--no-plot")
    assert status == 2 and "--temperatures" in err


def test_cli_netlist_temperature(run_cli, tmp_path):
    path = write_design(tmp_path / "d.json", Design(MODEL, NETWORK))
    status, out, err = run_cli("netlist", path, "--temperature", "-10")
    assert status == 0 and "temp=-10" in out and "tc1=2.5e-05" in out
    status, out, err = run_cli("netlist", path, "--temperature", "-10,20")
    assert status == 2 and "one temperature" in err


def test_ramp_response_is_exact_after_the_ramp():
    rel, q = np.array([[0.3, -0.2]]), np.array([[2.0, 50.0]])
    t = np.array([[1e-3, 1.0, 10.0]])
    rise = 1e-3
    # the response to a ramp is the step response averaged over the ramp's delays
    s = np.linspace(0.0, rise, 20001)
    averaged = np.trapezoid(step_residual(rel, q, t[0][:, None] - s[None, :]), s, axis=1) / rise
    np.testing.assert_allclose(step_residual(rel, q, t, rise)[0], averaged, rtol=1e-8, atol=1e-15)


def test_ramps_fit_ngspice_smallest_step():
    model = CreepModel((0.0005, 0.0002), (1.0, 3600.0))
    max_step = largest_step(43_200.0, 400)
    assert rise_time(model, NETWORK) < RAMP_STEP_FRACTION * max_step
    assert rise_time(model, NETWORK, max_step) >= RAMP_STEP_FRACTION * max_step


MATRIX = {"1 cell, 1 s": (1.0,), "1 cell, 1 h": (3600.0,), "2 cells": (1.0, 3600.0),
          "3 cells": (1.0, 60.0, 3600.0), "4 cells": (1.0, 15.0, 240.0, 3600.0)}


@pytest.mark.slow
@pytest.mark.parametrize("taus", list(MATRIX.values()), ids=list(MATRIX))
def test_spot_check_passes_for_stiff_designs(taus):
    """Designs of 1-4 cells with time constants from 1 s to 1 h, 10 kΩ source, polypropylene
    capacitors at 60 °C (absorption, leakage): ngspice runs and agrees with the engine."""
    model = CreepModel(tuple(np.linspace(5e-4, 2e-4, len(taus))), taus)
    design = Design(model, size(model, source_resistance=10e3, res_range=(10, 1e14)).chosen)
    assert len(design.network.cells) == len(taus)
    result = run_monte_carlo(design, ToleranceSpec(dielectric="polypropylene", temperature=60.0),
                             50, seed=1, workers=1)
    check = spot_check(result, n=2)
    assert "error" not in check, check.get("error")
    assert check["n"] == 2 and check["agreement_max_abs"] < 1e-8
