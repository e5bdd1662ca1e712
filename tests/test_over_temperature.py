"""Design over a temperature range: the prediction at each temperature against an independent
computation, the ``size --temperature-range`` contract, and what NTC tracking buys."""

import json
import math

import numpy as np
import pytest

from creepcomp.analog.over_temperature import (compare_over_range, network_over, over_temperature,
                                               size_fixed_for_range)
from creepcomp.analog.parts import DIELECTRICS, PartsPlan, ThermistorUse
from creepcomp.model import CreepModel
from creepcomp.network import Cell, Network
from creepcomp.temperature import TemperatureLaw

EA = 43e3
R_GAS = 8.314462618
SENSOR = CreepModel((0.03,), (45.0,), temperature=TemperatureLaw.arrhenius(EA, 20.0))


def independent_peak(beta, tau_ref, t_c, r1, c1, r2, leak):
    """Peak |y - 1| of G(s) H(s) after a unit step, written out by hand and stepped with
    python-control: G = 1 + beta / (1 + s tau(T)), H = R2 / (R2 + Z1), Z1 = (R1 || leak) || C1."""
    import control

    tau = tau_ref * math.exp(EA / R_GAS * (1 / (t_c + 273.15) - 1 / 293.15))
    s = control.tf("s")
    g = 1 + beta / (1 + s * tau)
    r1_eff = r1 * leak / (r1 + leak)
    h = r2 * (1 + s * r1_eff * c1) / (r2 * (1 + s * r1_eff * c1) + r1_eff)
    sys = control.minreal(g * h, verbose=False)
    t = np.linspace(0, 40 * max(tau, r1_eff * c1), 20001)
    y = np.asarray(control.step_response(sys, t).outputs)
    return float(max(np.max(np.abs(y - 1.0)), abs(control.dcgain(sys) - 1.0)))


def test_fixed_network_at_minus_ten_against_python_control():
    net = Network((Cell(3e6, 15e-6),), 100e6)
    plan = PartsPlan()
    pred = over_temperature(SENSOR, net, plan, -10.0, 40.0)
    k = pred.temperatures.index(-10.0)
    dt = -10.0 - 25.0
    c1 = 15e-6 * (1 + plan.capacitor_tc * dt)
    leak = DIELECTRICS["polypropylene"].insulation_time(-10.0) / c1
    want = independent_peak(0.03, 45.0, -10.0, 3e6 * (1 + plan.resistor_tc * dt), c1,
                            100e6 * (1 + plan.resistor_tc * dt), leak)
    assert pred.peak_residual[k] == pytest.approx(want, rel=2e-4)
    assert pred.peak_residual[k] == pytest.approx(0.0186, abs=5e-4)   # the 1.86 %


def test_thermistor_network_at_forty_against_python_control():
    u1 = ThermistorUse("NTC a", 470.0, 3650.0, series=130.0)
    u2 = ThermistorUse("NTC b", 22e3, 3950.0, parallel=390e3)
    plan = PartsPlan(thermistors={"R1": u1, "R2": u2})
    net = Network((Cell(600.0, 68e-3),), 20.8e3)
    pred = over_temperature(SENSOR, net, plan, 40.0, 40.0)

    def ntc(r25, b, t):
        return r25 * math.exp(b * (1 / (t + 273.15) - 1 / 298.15))

    r1 = 130.0 + ntc(470.0, 3650.0, 40.0)
    n2 = ntc(22e3, 3950.0, 40.0)
    r2 = n2 * 390e3 / (n2 + 390e3)
    c1 = 68e-3 * (1 + plan.capacitor_tc * 15.0)
    leak = DIELECTRICS["polypropylene"].insulation_time(40.0) / c1
    assert pred.temperatures == (40.0,)
    assert pred.peak_residual[0] == pytest.approx(independent_peak(0.03, 45.0, 40.0, r1, c1, r2, leak),
                                                  rel=2e-4)
    assert pred.tracking["kind"] == "ntc" and pred.tracking["thermistors"]["R2"]["parallel"] == 390e3


def test_network_over_adds_the_insulation_resistance_across_each_capacitor():
    net = network_over(Network((Cell(3e6, 15e-6),), 100e6), PartsPlan(capacitor="polyester"), 85.0)
    c = net.cells[0]
    assert c.leakage == pytest.approx(1e3 / c.C)          # polyester: R_ins C = 1000 s at 85 °C


def test_a_model_without_a_law_sees_only_the_parts_drift():
    model = CreepModel((0.03,), (45.0,))
    pred = over_temperature(model, Network((Cell(3e6, 15e-6),), 100e6), PartsPlan(), -10, 40)
    assert not pred.model_has_law and "only the parts drift" in pred.note
    assert 0 < pred.worst < 2e-3                           # tens of ppm/K, not the creep's law


def test_fixed_parts_for_the_range_beat_the_reference_sizing():
    net, (t_eff, factor), n = size_fixed_for_range(SENSOR, -10, 40, cap_range=(10e-6, 22e-6))
    ref = over_temperature(SENSOR, Network((Cell(3e6, 15e-6),), 100e6), PartsPlan(), -10, 40)
    ranged = over_temperature(SENSOR, net, PartsPlan(), -10, 40)
    assert -10 <= t_eff <= 40 and 0.3 < factor <= 1 and n > 10
    assert ranged.worst < 0.7 * ref.worst


@pytest.mark.slow
def test_ntc_tracking_is_at_most_a_quarter_of_the_reference_sizing():
    comparison = compare_over_range(SENSOR, Network((Cell(3e6, 15e-6),), 100e6), -10, 40,
                                    tracking="ntc", topology="passive")
    a, b, c = (comparison.design(k).prediction for k in ("reference", "range", "ntc"))
    assert c.worst <= a.worst / 4
    assert c.worst < b.worst < a.worst
    assert comparison.chosen == "ntc"
    therm = comparison.design("ntc").plan.thermistors
    assert set(therm) == {"R1", "R2"}
    assert any("outside what polypropylene" in w for w in comparison.design("ntc").warnings)


def test_size_json_has_the_over_temperature_contract(run_cli, tmp_path):
    out = tmp_path / "d.json"
    status, stdout, err = run_cli("size", "--beta0", "3%", "--tau", "45s", "--activation-energy",
                                  "43kJ/mol", "--temperature-range", "-10:40", "--json", "-o", out)
    assert status == 0, err
    data = json.loads(stdout)
    ot = data["over_temperature"]
    temps = ot["temperatures"]
    assert temps[0] == -10 and temps[-1] == 40 and max(np.diff(temps)) <= 5
    assert len(ot["peak_residual"]) == len(temps)
    assert ot["worst"] == max(ot["peak_residual"]) and ot["worst_at"] in temps
    assert ot["tracking"] == "none"
    designs = data["temperature_designs"]["designs"]
    assert designs["range"]["worst"] == ot["worst"] < designs["reference"]["worst"]
    written = json.loads(out.read_text())
    assert written["cells"] == data["cells"] and written["creep"]["temperature"]["activation_energy"] == EA


@pytest.mark.parametrize("args, message", [
    (["--tracking", "ntc"], "--tracking needs --temperature-range"),
    (["--temperature-range", "40:-10"], "LOW must not exceed HIGH"),
    (["--temperature-range", "-10"], "expected LOW:HIGH"),
    (["--tracking", "ptc", "--temperature-range", "0:10"], "expected none or ntc"),
    (["--activation-energy", "hot"], "--activation-energy"),
])
def test_size_over_temperature_refuses_bad_input(run_cli, args, message):
    status, out, err = run_cli("size", "--beta0", "3%", "--tau", "45s", *args)
    assert status == 2 and not out
    assert message in err and "Traceback" not in err


def test_activation_energy_with_a_model_that_has_its_own_law(run_cli, tmp_path):
    model = tmp_path / "m.json"
    model.write_text(json.dumps(SENSOR.to_dict()))
    status, _, err = run_cli("size", "--model", model, "--activation-energy", "43k")
    assert status == 2 and "own temperature block" in err


@pytest.mark.slow
def test_size_tracking_ntc_writes_the_thermistors_and_the_plot(run_cli, tmp_path):
    out, plot = tmp_path / "d.json", tmp_path / "sizing.png"
    args = ("size", "--beta0", "3%", "--tau", "45s", "--activation-energy", "43k",
            "--temperature-range", "-10:40", "--tracking", "ntc", "--topology", "passive", "--json",
            "-o", out, "--plot", plot)
    # catalogue thermistors need a capacitor of tens of mF, which no film capacitor is
    status, stdout, err = run_cli(*args)
    refused = json.loads(stdout)
    assert status == 3 and not out.exists()
    assert not refused["practical"] and "capacitor" in refused["reasons"][0]
    assert refused["temperature_designs"]["designs"]["ntc"]["worst"] > 0
    status, stdout, err = run_cli(*args, "--allow-impractical")
    assert status == 0, err
    data = json.loads(stdout)
    tracking = data["over_temperature"]["tracking"]
    assert tracking["kind"] == "ntc" and set(tracking["thermistors"]) == {"R1", "R2"}
    assert all(t["R25"] > 0 and t["B"] > 3000 for t in tracking["thermistors"].values())
    designs = data["temperature_designs"]["designs"]
    assert data["over_temperature"]["worst"] == designs["ntc"]["worst"] <= designs["reference"]["worst"] / 4
    written = json.loads(out.read_text())
    assert written["parts"]["thermistors"] == tracking["thermistors"]
    assert (tmp_path / "sizing-over-temperature.png").stat().st_size > 10_000


def test_tracking_refuses_a_model_of_two_terms_before_sizing(run_cli):
    status, out, err = run_cli("size", "--term", "1%@10s", "--term", "2%@60s", "--activation-energy",
                               "43k", "--temperature-range", "-10:40", "--tracking", "ntc",
                               "--topology", "passive")
    assert status == 2 and not out and "one creep term" in err
