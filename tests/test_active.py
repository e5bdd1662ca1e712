"""The active NTC-tracking stage: H(s), sizing, verdict, BOM, netlist, creep test, files."""

from __future__ import annotations

import json

import numpy as np
import pytest

from creepcomp.active_stage import ActiveStage, ActiveTerm
from creepcomp.analog.active import (ideal_active, inverse_lags, lag_batch, output_offset,
                                     size_active_tracking, stage_over)
from creepcomp.analog.over_temperature import over_temperature
from creepcomp.analog.parts import NTC_THERMISTORS, PartsPlan, ThermistorUse
from creepcomp.analog.practicality import judge_network
from creepcomp.analog.quality import step_peak
from creepcomp.errors import InputError
from creepcomp.model import CreepModel
from creepcomp.temperature import TemperatureLaw

EA = 43e3
SENSOR = CreepModel((0.03,), (45.0,), temperature=TemperatureLaw.arrhenius(EA, 20.0))


def stage_for_default() -> tuple[ActiveStage, PartsPlan]:
    use = ThermistorUse("Murata NCP18WM154", 150e3, 4500.0, tolerance=0.05, b_tolerance=0.03)
    stage = ActiveStage((ActiveTerm(150e3, 10e-6, 100e3, 100e3, 4.7e3, 620e3),), 18e3)
    return stage, PartsPlan(thermistors={"RT1": use})


@pytest.mark.parametrize("model", [SENSOR, CreepModel((0.01, 0.01, 0.015), (5.0, 50.0, 500.0))])
def test_ideal_stage_cancels_the_creep_at_the_reference(model):
    stage = ideal_active(model)
    sensor = model.at_temperature(20.0) if model.temperature else model
    assert step_peak(sensor, stage)[0] < 1e-12
    # H G is a constant: H(s) = (1/G(s)) / (1 + sum c_j) at a few frequencies
    _, c, _ = inverse_lags(model)
    h, g = stage.lag_expansion(), model.lag_expansion()
    for s in (1e-3j, 0.05j, 2j):
        hs = h.direct + sum(r / (1 + s * p) for r, p in zip(h.gains, h.taus))
        gs = g.direct + sum(r / (1 + s * p) for r, p in zip(g.gains, g.taus))
        assert abs(hs * gs * (1 + c.sum()) - 1) < 1e-12


def test_inverse_lags_of_one_term_and_refusal_of_overshoot():
    k, c, p = inverse_lags(SENSOR)
    assert k == pytest.approx(1.0) and c[0] == pytest.approx(0.03 / 1.03)
    assert p[0] == pytest.approx(45.0 / 1.03)
    with pytest.raises(InputError, match="positive creep"):
        inverse_lags(CreepModel((-0.02,), (20.0,)))


def test_closed_form_batch_equals_the_nodal_analysis():
    stage = ActiveStage((ActiveTerm(220e3, 4.7e-6, 82e3, 91e3, 3.3e3, 510e3, leakage=2e9),), 15e3)
    t = stage.terms[0]
    d, r, p = lag_batch(*(np.array([v]) for v in (t.RT, t.C, t.RA, t.RB, t.RG, t.RS, stage.RS0)),
                        leakage=np.array([t.leakage]))
    lag = stage.lag_expansion()
    assert d[0] == pytest.approx(lag.direct, rel=1e-12)
    assert r[0, 0] == pytest.approx(lag.gains[0], rel=1e-10)
    assert p[0, 0] == pytest.approx(lag.taus[0], rel=1e-10)
    # the time constant of the description, without leakage
    assert ActiveStage((t.__class__(*(getattr(t, k) for k in ("RT", "C", "RA", "RB", "RG", "RS"))),),
                       15e3).lag_expansion().taus[0] == pytest.approx(t.time_constant, rel=1e-12)


def test_a_source_resistance_enters_h_and_vanishes_continuously():
    stage = ideal_active(SENSOR)
    near = ActiveStage(stage.terms, stage.RS0, 1e-9).lag_expansion()
    far = ActiveStage(stage.terms, stage.RS0, 1e3).lag_expansion()
    assert near.direct == pytest.approx(stage.lag_expansion().direct, rel=1e-12)
    assert abs(far.direct - near.direct) > 1e-3


def test_parts_round_trip_and_file_keys():
    stage, _ = stage_for_default()
    assert [lab for lab, _, _ in stage.parts()] == ["RT1", "C1", "RA1", "RB1", "RG1", "RS1", "RS0"]
    values = [v * 1.01 for _, _, v in stage.parts()]
    assert [v for _, _, v in stage.with_parts(values).parts()] == pytest.approx(values)
    data = stage.to_dict()
    assert data["topology"] == "active" and "cells" not in data
    assert ActiveStage.from_dict(data) == stage
    with pytest.raises(InputError, match="active term 1 needs numbers"):
        ActiveStage.from_dict({"active": {"terms": [{"RT": 1}], "RS0": 1}})
    with pytest.raises(InputError, match="leakage = -1.0 must be positive"):
        ActiveStage.from_dict({"active": {"terms": [dict(data["active"]["terms"][0], leakage=-1)],
                                          "RS0": 1e4}})


def test_stage_over_temperature_follows_the_thermistor_and_the_insulation():
    stage, plan = stage_for_default()
    cold, hot = stage_over(stage, plan, -10.0), stage_over(stage, plan, 40.0)
    assert cold.terms[0].RT / hot.terms[0].RT == pytest.approx(
        np.exp(4500 * (1 / 263.15 - 1 / 313.15)), rel=1e-12)
    assert cold.terms[0].leakage > hot.terms[0].leakage > 0
    # the divider's fixed resistors keep their ratio (one technology, one TC)
    assert cold.terms[0].alpha == pytest.approx(stage.terms[0].alpha, rel=1e-12)


def test_default_sensor_tracking_meets_a_quarter_of_the_reference_sizing():
    stage, plan, worst = size_active_tracking(SENSOR, -10, 40)
    assert worst < 0.0035
    assert set(plan.thermistors) == {"RT1"}
    assert plan.thermistors["RT1"].part.startswith("Murata NCP18")
    assert all(t.C <= 10e-6 for t in stage.terms)
    # (a) of the same sensor is 1.86 % at -10 °C: the stage is under a quarter of it
    assert worst <= 0.0186 / 4
    ot = over_temperature(SENSOR, stage, plan, -10, 40)
    assert ot.worst == pytest.approx(worst, rel=1e-9)
    assert ot.tracking["topology"] == "active"


def test_two_creep_terms_get_two_tracking_loops_with_one_summer():
    model = CreepModel((0.01, 0.02), (10.0, 60.0), temperature=TemperatureLaw.arrhenius(EA, 20.0))
    stage, plan, worst = size_active_tracking(model, -10, 40)
    assert len(stage.terms) == 2 and set(plan.thermistors) == {"RT1", "RT2"}
    _, c, p = inverse_lags(model)
    # the amplitudes share RS0 and each is within an E24 step of its c_j
    assert np.allclose([stage.RS0 / t.RS for t in stage.terms], c, rtol=0.05)
    assert stage.terms[0].time_constant < stage.terms[1].time_constant
    assert worst < 0.1 * model.beta0


def test_shape_resistances_are_the_thermistor_law():
    from creepcomp.analog.active import _shape_resistances, _shapes

    shapes = _shapes(NTC_THERMISTORS[:2], "E6")
    grid = np.array([-10.0, 25.0, 40.0])
    fast = _shape_resistances(shapes, grid)
    for k in (0, 7, len(shapes) - 1):
        th, ser, par = shapes[k]
        use = ThermistorUse(th.part, th.r25, th.b, ser, None if np.isinf(par) else par)
        assert np.allclose(fast[k], use.resistance(grid), rtol=1e-13)


def test_verdict_bom_and_offset_of_the_active_stage():
    from creepcomp.analog.bom import bom_rows

    stage, plan = stage_for_default()
    verdict = judge_network(SENSOR, stage, plan)
    assert verdict.practical and verdict.corners == 2 ** 7
    assert verdict.worst_case_peak < verdict.uncorrected_peak
    assert verdict.to_dict()["op_amp"]["bias_current"] == verdict.to_dict()["bias_current"]
    big = stage.with_parts([v if k == "R" else 1.0 for _, k, v in stage.parts()])
    bad = judge_network(SENSOR, big, plan)
    assert not bad.practical and "C1 = 1 F is outside" in bad.reasons[0]
    rows = {r.ref: r for r in bom_rows(stage, plan, {"R": "E24", "C": "E6"}, SENSOR)}
    assert rows["RT1"].technology == "NTC thermistor" and "NCP18WM154" in rows["RT1"].note
    assert "bias current" in rows["U1"].note and rows["U0"].value == "op amp"
    # the offset grows with the thermistor's resistance: largest when cold
    assert output_offset(stage, plan, -10.0) > output_offset(stage, plan, 40.0) > 0


def test_schematic_names_the_op_amps_and_the_thermistor():
    from creepcomp.report.schematic import schematic_svg

    stage, plan = stage_for_default()
    svg = schematic_svg(stage, plan)
    assert "U1" in svg and "U0" in svg and "RT1 NTC" in svg and "RS0" in svg and "Uin" not in svg
    buffered = ActiveStage(stage.terms, stage.RS0, 1e3, None, True)
    assert "Uin" in schematic_svg(buffered, plan)


def test_netlist_has_the_op_amps_and_agrees_with_python_control_when_cold():
    from creepcomp.verify.compare import compare_program

    stage, plan = stage_for_default()
    c = compare_program(stage, SENSOR, "step", points=400, temperature=-10.0, plan=plan)
    text = c.deck.text()
    assert "EU1 w1 0 0 m1" in text and "EU0 out 0 s out" in text and "RT1 e1 m1 R={" in text
    if c.unavailable:
        pytest.skip(c.unavailable)
    assert c.agreement_max_abs < 1e-6


def test_design_file_is_read_by_the_commands_that_take_it(run_cli, tmp_path):
    from creepcomp.io.jsonfiles import Design, read_design, write_design

    stage, plan = stage_for_default()
    path = tmp_path / "a.json"
    write_design(path, dict(Design(SENSOR, stage).to_dict(), parts=plan.to_dict()))
    with pytest.raises(InputError, match="an active stage"):
        read_design(path)
    assert read_design(path, active=True).network == stage
    status, out, err = run_cli("mc", path)
    assert status == 2 and "an active stage" in err and "Traceback" not in err
    status, out, err = run_cli("creep-test", path, "--class", "C3", "--temperatures", "-10,20,40",
                               "--json")
    assert status == 0, err
    data = json.loads(out)
    assert [r["temperature"] for r in data["temperatures"]] == [-10, 20, 40]
    assert data["topology"] == "active" and data["tracking"] == "ntc"


@pytest.mark.slow
def test_size_tracking_ntc_writes_the_active_stage(run_cli, tmp_path):
    out, bom, sch = tmp_path / "d.json", tmp_path / "bom.csv", tmp_path / "s.svg"
    status, stdout, err = run_cli("size", "--beta0", "3%", "--tau", "45s", "--activation-energy", "43k",
                                  "--temperature-range", "-10:40", "--tracking", "ntc", "--json",
                                  "-o", out, "--bom", bom, "--schematic", sch)
    assert status == 0, err
    data = json.loads(stdout)
    designs = data["temperature_designs"]["designs"]
    assert data["temperature_designs"]["chosen"] == "active" and data["practical"]
    assert designs["active"]["worst"] <= designs["reference"]["worst"] / 4
    assert designs["active"]["worst"] < designs["ntc"]["worst"]
    written = json.loads(out.read_text())
    assert written["topology"] == "active" and set(written["parts"]["thermistors"]) == {"RT1"}
    assert "U0" in bom.read_text() and "U1" in sch.read_text()


def test_a_source_resistance_gets_an_input_follower():
    from creepcomp.analog.bom import bom_rows
    from creepcomp.verify.drive import synthetic_program
    from creepcomp.verify.netlist import program_deck

    stage = ideal_active(SENSOR, source_resistance=1e3)
    assert stage.input_buffer and ActiveStage.from_dict(stage.to_dict()) == stage
    assert step_peak(SENSOR.at_temperature(20.0), stage)[0] < 1e-12
    assert "Uin" in {r.ref for r in bom_rows(stage)}
    deck = program_deck(stage, SENSOR, synthetic_program(SENSOR), 100.0)
    assert "EUin buf 0 sensor buf" in deck.circuit and "RA1 buf e1" in deck.circuit
