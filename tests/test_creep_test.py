"""The OIML R 60 creep test: limits, exact readings, targets, Monte Carlo yield, command line."""

import json

import numpy as np
import pytest

from creepcomp.analog.parts import PartsPlan, ThermistorUse, network_at
from creepcomp.errors import InputError
from creepcomp.io.jsonfiles import Design
from creepcomp.lti import lag_states
from creepcomp.model import CreepModel
from creepcomp.network import Cell, Network
from creepcomp.temperature import TemperatureLaw
from creepcomp.verify.creep_test import (C3_CREEP_LIMIT, CreepTestProgram, creep_limits, creep_test_yield,
                                         design_at, design_test, digital_test, lag_readings,
                                         model_test, parse_class, trapezoid_lag_response,
                                         variant_readings)

LAW = TemperatureLaw.arrhenius(43000.0, 20.0)
SENSOR = CreepModel((0.03,), (45.0,), temperature=LAW)
# the exact rule for 3 % at 45 s: R1 C = 45 s, R2 = R1 / beta0
FIXED = Network((Cell(3e6, 15e-6),), 100e6)


def test_c3_limits_and_their_derivation():
    lim = parse_class("C3")
    assert (lim.accuracy_class, lim.n_max, lim.label) == ("C", 3000, "C3")
    assert lim.creep_30min == 0.000245 == C3_CREEP_LIMIT
    assert lim.creep_20_30min == pytest.approx(5.25e-5, rel=1e-12)
    assert lim.dr == pytest.approx(0.5 / 3000, rel=1e-12)
    assert "0.7 x 0.7 x 1.5 / 3000 = 0.000245" in lim.derivation["creep_30min"]
    # the MPE steps at 2000 v for class C: at n_max = 2000 it is 1.0 v, so the limit is 2/3 as wide
    assert parse_class("C2").creep_30min == pytest.approx(0.7 * 0.7 * 1.0 / 2000)
    assert parse_class("C", n_max=6000).n_max == 6000 and parse_class("d").n_max == 1000
    from creepcomp.fleet.unit import OIML_C3_CREEP

    assert OIML_C3_CREEP == creep_limits("C", 3000).creep_30min


@pytest.mark.parametrize("text,n,needle", [("E3", None, "accuracy class"), ("C20", None, "500 to 10000"),
                                           ("A", 1000, "at least 50000"), ("C3x", None, "accuracy class")])
def test_bad_classes_are_refused(text, n, needle):
    with pytest.raises(InputError, match=needle):
        parse_class(text, n)


def test_trapezoid_response_is_the_exact_lag_response():
    program = CreepTestProgram(loading_time=10.0, hold=300.0, recovery=200.0)
    t = np.arange(0.0, program.dr_time + program.recovery + 1e-9, 0.5)     # breakpoints on the grid
    q = np.array([[0.3, 7.0, 45.0, 2000.0]])
    closed = trapezoid_lag_response(q, program, t)[0]
    recursion = lag_states(t, program.load(t), q[0], hold="linear")
    assert np.max(np.abs(closed - recursion.T)) < 1e-12


def test_sensor_readings_match_a_simulation_of_the_model():
    program = CreepTestProgram()
    result = model_test(SENSOR, [-10.0, 20.0], parse_class("C3"), program)
    t = np.round(np.arange(0.0, program.dr_time + program.recovery + 1e-6, 0.5), 9)
    for row in result.rows:
        m = SENSOR.at_temperature(row["temperature"])
        y = m.response(t, program.load(t), hold="linear")
        at = {s: int(np.flatnonzero(np.isclose(t, s))[0]) for s in
              (10.0, 1210.0, 1810.0, program.dr_time, program.dr_time + program.recovery)}
        # one term creeps monotonically: the largest change is the one at 30 min
        assert row["creep_30min"] == pytest.approx(y[at[1810.0]] - y[at[10.0]], rel=1e-9)
        assert row["creep_20_30min"] == pytest.approx(abs(y[at[1810.0]] - y[at[1210.0]]), rel=1e-6, abs=1e-15)
        assert row["dr"] == pytest.approx(y[at[program.dr_time]], rel=1e-9)
        assert row["dr_30min"] == pytest.approx(abs(y[-1]), rel=1e-6, abs=1e-15)
        assert not row["pass"]
    # tau grows 7.5-fold at -10 °C: creep is still going on between 20 and 30 min
    assert result.rows[0]["creep_20_30min"] > 1e-4 > result.rows[1]["creep_20_30min"]
    assert model_test(CreepModel((0.03,), (45.0,)), [0, 20], parse_class("C3")).notes


def test_design_readings_match_python_control():
    import control

    design = Design(SENSOR, FIXED, {"parts": PartsPlan().to_dict()})
    program = CreepTestProgram()
    result = design_test(design, [-10.0, 40.0], parse_class("C3"), program)
    t = np.arange(0.0, program.dr_time + 1e-9, 0.1)
    for row in result.rows:
        model, net = design_at(design, row["temperature"])
        sys = control.series(model.state_space(), net.state_space())
        y = control.forced_response(sys, t, program.load(t)).outputs / net.lag_expansion().hf_gain
        i0, i20, i30 = (int(round(s / 0.1)) for s in (10.0, 1210.0, 1810.0))
        # the largest change is inside the hold at 40 °C: the 0.1-s grid finds it within 1e-5
        assert row["creep_30min"] == pytest.approx(np.abs(y[i0:i30 + 1] - y[i0]).max(), rel=2e-5)
        assert row["creep_20_30min"] == pytest.approx(abs(y[i30] - y[i20]), rel=1e-4, abs=1e-12)
        assert row["dr"] == pytest.approx(abs(y[-1]), rel=1e-4)
        assert not row["pass"]                 # sized at 20 °C, far out at -10 and 40 °C


def test_fixed_design_passes_at_its_reference_and_the_leakage_is_there():
    design = Design(SENSOR, FIXED, {"parts": PartsPlan().to_dict()})
    row = design_test(design, [20.0], parse_class("C3")).rows[0]
    assert row["pass"] and 1e-7 < row["creep_30min"] < 5e-5
    _, net = design_at(design, 20.0)
    assert net.cells[0].leakage == pytest.approx(1e5 * (0.1 ** (-5 / 60)) / net.cells[0].C, rel=1e-9)


def test_digital_corrector_needs_the_temperature():
    result = digital_test(SENSOR, [-10.0, 20.0, 40.0], parse_class("C3"), rate=10.0)
    assert result.passed
    # zero hold on the 10-s loading ramp: a sampling residual of about beta dt / (2 tau)
    assert 1e-6 < result.rows[1]["creep_30min"] < 1e-4
    fixed = result.to_dict()["corrector_at_reference"]
    assert not fixed["pass"] and fixed["temperatures"][1]["pass"]
    assert fixed["temperatures"][0]["creep_30min"] > 100 * result.rows[0]["creep_30min"]


def test_variant_readings_are_the_scalar_readings_of_each_unit():
    plan = PartsPlan(thermistors={"R1": ThermistorUse("NTC", 2.32e6, 4500.0)})
    design = Design(SENSOR, FIXED, {"parts": plan.to_dict()})
    values = {"R1": np.array([3e6, 3.03e6]), "C1": np.array([15e-6, 14.9e-6]), "tau[0]": np.array([45.0, 46.0])}
    r = variant_readings(design, values, -10.0, None, 2)
    for i in range(2):
        model = CreepModel((0.03,), (values["tau[0]"][i],), temperature=LAW).at_temperature(-10.0)
        net = network_at(FIXED.with_parts([values["R1"][i], values["C1"][i], 100e6]), plan, -10.0)
        if i == 1:                                     # the thermistor keeps its drawn deviation
            net = net.with_parts([net.cells[0].R * 1.01, net.cells[0].C, net.R2])
        h = net.lag_expansion()
        from creepcomp.lti import cascade_lags

        D, R, q = cascade_lags(1.0, [model.beta], [model.tau], h.direct, [h.gains], [h.taus])
        one = lag_readings(R / D[:, None], q, CreepTestProgram())
        assert r.creep_30min[i] == pytest.approx(one.creep_30min[0], rel=1e-6)
        assert r.dr[i] == pytest.approx(one.dr[0], rel=1e-6)


def test_yield_counts_units_passing_at_every_temperature():
    design = Design(SENSOR, FIXED, {"parts": PartsPlan(resistor_tc=0.0, capacitor_tc=0.0).to_dict()})
    rng = np.random.default_rng(1)
    values = {"C1": 15e-6 * (1 + 0.03 * rng.standard_normal(400))}
    lim = parse_class("C3")
    at_ref = creep_test_yield(design, values, [20.0], lim)
    assert 0.3 < at_ref["yield"] < 1.0 and at_ref["n"] == 400
    both = creep_test_yield(design, values, [20.0, 40.0], lim)
    assert both["yield"] == 0.0 and both["temperatures"][0]["yield"] == at_ref["yield"]


def test_creep_test_command_json_and_plot(run_cli, tmp_path):
    model = tmp_path / "sensor.json"
    model.write_text(json.dumps(SENSOR.to_dict()))
    plot = tmp_path / "ct.png"
    status, out, err = run_cli("creep-test", model, "--class", "C3", "--temperatures", "-10,20,40",
                               "--digital", "--json", "--plot", plot)
    assert status == 0, err
    data = json.loads(out)
    assert {"class", "n_max", "limits", "temperatures", "pass"} <= set(data)
    assert data["class"] == "C3" and data["n_max"] == 3000 and data["pass"] is True
    assert {"creep_30min", "creep_20_30min", "dr", "derivation"} <= set(data["limits"])
    assert [r["temperature"] for r in data["temperatures"]] == [-10.0, 20.0, 40.0]
    assert all({"creep_30min", "creep_20_30min", "dr", "pass"} <= set(r) for r in data["temperatures"])
    assert data["corrector_at_reference"]["pass"] is False
    assert plot.stat().st_size > 10_000

    status, out, err = run_cli("creep-test", model, "--temperatures", "20")
    assert status == 0, err
    assert "0.7 x 0.7 x 1.5 / 3000 = 0.000245" in out and "FAIL" in out


@pytest.mark.parametrize("args,needle", [(["--class", "Q3"], "accuracy class"),
                                         (["--temperatures", "20,,40"], "--temperatures"),
                                         (["--n-max", "20000"], "500 to 10000"),
                                         (["--plot", "x.pdf"], "--plot")])
def test_creep_test_command_refuses_bad_input(run_cli, tmp_path, args, needle):
    model = tmp_path / "sensor.json"
    model.write_text(json.dumps(SENSOR.to_dict()))
    status, out, err = run_cli("creep-test", model, *args)
    assert status == 2 and needle in err and "Traceback" not in err


def test_mc_reports_the_creep_test_yield(run_cli, tmp_path):
    path = tmp_path / "design.json"
    path.write_text(json.dumps(Design(SENSOR, FIXED, {"parts": PartsPlan().to_dict()}).to_dict()))
    status, out, err = run_cli("mc", path, "--n", "2000", "--creep-test", "C3", "--temperature", "20",
                               "--cap-tol", "1%", "--dielectric", "polypropylene", "--spot-check", "0",
                               "--sensitivity-n", "0", "--no-worst-case", "--json", "--report",
                               tmp_path / "mc.html")
    assert status == 0, err
    ct = json.loads(out)["creep_test"]
    page = (tmp_path / "mc.html").read_text()
    assert "OIML R 60 creep test" in page and f"{100 * ct['yield']:.2f} %" in page
    assert ct["class"] == "C3" and ct["n"] == 2000 and 0.0 < ct["yield"] < 1.0
    assert ct["temperatures"][0]["temperature"] == 20.0
