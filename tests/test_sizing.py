import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from creepcomp.errors import InputError, NotRealisableError
from creepcomp.model import CreepModel
from creepcomp.analog.quality import step_peak
from creepcomp.analog.sizing import DEFAULT_RES_RANGE, ideal_network, size


@given(beta0=st.floats(0.001, 0.3), tau=st.floats(0.1, 1e4), cap=st.floats(1e-9, 1e-4),
       rs=st.one_of(st.just(0.0), st.floats(1.0, 1e6)),
       rl=st.one_of(st.none(), st.floats(1e5, 1e13)))
def test_exact_rule_cancels_creep_with_source_and_load(beta0, tau, cap, rs, rl):
    model = CreepModel.voigt(beta0, tau)
    try:
        net = ideal_network(model, "exact", cap, rs, rl)
    except InputError:
        assume(False)
    assert step_peak(model, net)[0] < 1e-9


def test_exact_rule_values_follow_physics():
    model = CreepModel.voigt(0.03, 45.0)
    net = ideal_network(model, "exact", 10e-6)
    assert net.cells[0].R == pytest.approx(4.5e6) and net.R2 == pytest.approx(150e6)
    net = ideal_network(model, "exact", 10e-6, 1e5, 1e9)
    r2p = net.R2 * 1e9 / (net.R2 + 1e9)
    assert net.cells[0].R * net.cells[0].C == pytest.approx(45.0)
    assert net.cells[0].R / (r2p + 1e5) == pytest.approx(0.03)


def test_paper_rule_is_the_papers_equations():
    model = CreepModel.voigt(0.03, 45.0)
    net = ideal_network(model, "paper", 10e-6)
    r1, c, r2 = net.cells[0].R, net.cells[0].C, net.R2
    assert c * r1 * r2 / (r1 + r2) == pytest.approx(45.0)
    assert r1 / r2 == pytest.approx(0.03 / 1.03)


def test_three_term_foster_chain_cancels():
    model = CreepModel((0.01, 0.01, 0.015), (5.0, 50.0, 500.0))
    net = ideal_network(model, "exact", 100e-6)
    assert len(net.cells) == 3
    assert max(c.C for c in net.cells) == pytest.approx(100e-6)
    assert step_peak(model, net)[0] < 1e-9
    assert step_peak(model, None)[0] == pytest.approx(0.035)


@pytest.mark.parametrize("rs,rl", [(0.0, None), (2e3, None), (0.0, 1e8), (5e3, 1e9)])
def test_negative_creep_is_cancelled_by_a_lag_network(rs, rl):
    model = CreepModel((-0.02, -0.01), (30.0, 3.0))
    net = ideal_network(model, "exact", 10e-6, rs, rl)
    assert net.topology == "lag" and net.R2 is None and len(net.shunt) == 2
    assert step_peak(model, net)[0] < 1e-9
    assert step_peak(model, None)[0] == pytest.approx(0.03)


def test_mixed_signs_explain_why():
    with pytest.raises(NotRealisableError, match="both signs.*complex poles"):
        ideal_network(CreepModel((0.03, -0.02), (45.0, 44.0)), "exact")
    with pytest.raises(NotRealisableError, match="both signs.*real poles"):
        ideal_network(CreepModel((0.03, -0.01), (45.0, 5.0)), "exact")


def test_paper_rule_refuses_what_it_does_not_cover():
    with pytest.raises(NotRealisableError, match="one creep term"):
        ideal_network(CreepModel((0.01, 0.02), (5.0, 50.0)), "paper")


def test_impossible_source_resistance_is_explained():
    with pytest.raises(InputError, match="source resistance"):
        ideal_network(CreepModel.voigt(0.03, 45.0), "exact", 10e-6, source_resistance=1e9)


def test_snapping_e24_e6_meets_5e4_and_beats_nearest():
    model = CreepModel.voigt(0.027, 37.0)
    rep = size(model, resistor_series="E24", capacitor_series="E6")
    assert rep.chosen_quality.residual_creep_peak <= 5e-4
    assert rep.uncorrected_quality.residual_creep_peak == pytest.approx(0.027)
    assert rep.nearest_quality.residual_creep_peak > rep.chosen_quality.residual_creep_peak
    from creepcomp.analog import eseries
    e24 = eseries.values_in_range("E24", 1, 1e10)
    e6 = eseries.values_in_range("E6", 1e-12, 1e-3)
    for label, kind, v in rep.chosen.parts():
        pool = e24 if kind == "R" else e6
        assert np.min(np.abs(pool / v - 1)) < 1e-9, label
    for p in rep.parts:
        assert p.residual_if_only_this >= 0 and abs(p.deviation) < 0.2


@settings(max_examples=15)
@given(st.floats(0.005, 0.1), st.floats(1.0, 1000.0))
def test_search_is_never_worse_than_nearest_at_the_same_capacitor(beta0, tau):
    model = CreepModel.voigt(beta0, tau)
    try:
        rep = size(model, capacitance=10e-6)
    except InputError as exc:
        assert "outside the resistor range" in str(exc)
        assume(False)
    in_range = all(DEFAULT_RES_RANGE[0] <= v <= DEFAULT_RES_RANGE[1]
                   for _, kind, v in rep.nearest.parts() if kind == "R")
    assume(in_range)        # otherwise the nearest values are not allowed parts
    assert rep.chosen_quality.residual_creep_peak <= rep.nearest_quality.residual_creep_peak + 1e-15


def test_warnings_name_impedance_and_capacitor_technology():
    model = CreepModel.voigt(0.03, 45.0)
    high = size(model, resistor_series=None, capacitor_series=None, capacitance=1e-6)
    text = " ".join(high.warnings)
    assert "high impedance" in text and "bias current" in text and "taring" in text
    big = size(model, resistor_series=None, capacitor_series=None, capacitance=470e-6)
    assert any("outside what film capacitors offer" in w for w in big.warnings)
    assert not any("high impedance" in w for w in big.warnings)
