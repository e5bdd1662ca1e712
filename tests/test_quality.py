import math

import control
import numpy as np
import pytest
from scipy import linalg
from hypothesis import given
from hypothesis import strategies as st

from creepcomp.model import CreepModel
from creepcomp.network import Cell, Network, modal_form, state_matrices
from creepcomp.analog.quality import (SWEEP_QUARTER_POINTS, corrected_system, predict,
                                      residual_curves, step_residual, sweep_branches,
                                      sweep_hysteresis)
from creepcomp.analog.sizing import ideal_network


def paper_closed_form(beta, tau, t):
    """Residual of the paper's rule: b^2/(1+2b) (1 - e^-x + x e^-x), x = t/tau (double pole)."""
    x = t / tau
    return beta ** 2 / (1 + 2 * beta) * (1 - np.exp(-x) + x * np.exp(-x))


def test_paper_rule_residual_matches_the_closed_form():
    model = CreepModel.voigt(0.03, 45.0)
    net = ideal_network(model, "paper", 10e-6)
    q = predict(model, net)
    assert q.residual_creep_final == pytest.approx(0.03 ** 2 / 1.06, rel=1e-9)      # 8.49e-4
    assert q.residual_creep_peak == pytest.approx(0.03 ** 2 / 1.06 * (1 + math.exp(-2)), rel=1e-9)
    assert q.residual_creep_peak_time == pytest.approx(90.0, rel=1e-6)
    t, e = step_residual(model, net)
    np.testing.assert_allclose(e, paper_closed_form(0.03, 45.0, t), atol=1e-14)


def test_exact_rule_cancels():
    model = CreepModel.voigt(0.03, 45.0)
    q = predict(model, ideal_network(model, "exact", 10e-6))
    assert q.residual_creep_peak < 1e-12 and q.hysteresis < 1e-12


def test_uncorrected_creep_and_hysteresis():
    model = CreepModel.voigt(0.03, 45.0)
    q = predict(model, None)
    assert q.residual_creep_peak == pytest.approx(0.03) and math.isinf(q.residual_creep_peak_time)
    # sinusoid estimate at omega tau = 1: loop width 2 |Im G| = beta; a triangle is close to it
    assert 0.6 * 0.03 < q.hysteresis < 0.03


@given(st.floats(0.001, 0.3), st.floats(0.1, 1e4), st.floats(0.7, 1.4), st.floats(0.7, 1.4))
def test_closed_form_agrees_with_python_control(beta, tau, fr1, fr2):
    model = CreepModel.voigt(beta, tau)
    ideal = ideal_network(model, "exact", 1e-6)
    net = Network((Cell(ideal.cells[0].R * fr1, 1e-6),), ideal.R2 * fr2)
    t, e = step_residual(model, net)
    ideal_gain = net.lag_expansion().hf_gain
    sys = corrected_system(model, net)
    checked = control.forced_response(sys, t[t <= t[-1] / 4], np.ones(np.sum(t <= t[-1] / 4)))
    np.testing.assert_allclose(e[t <= t[-1] / 4], checked.outputs / ideal_gain - 1.0, atol=1e-11)
    d, r, p = modal_form(*state_matrices(*net.as_arrays()))
    np.testing.assert_allclose(residual_curves(model, d, r, p, t)[0], e, atol=1e-15)


@pytest.mark.parametrize("model, rule", [(CreepModel.voigt(0.03, 45.0), "paper"),
                                         (CreepModel((0.02, 0.01), (5.0, 80.0)), "exact")])
@pytest.mark.parametrize("source, load", [(0.0, None), (2e3, 1e6)])
def test_sweep_hysteresis_agrees_with_python_control(model, rule, source, load):
    net = ideal_network(model, rule, 10e-6)
    net = Network(net.cells, net.R2, source_resistance=source, load_resistance=load)
    hysteresis, levels, up, down = sweep_hysteresis(model, net, 60.0)
    # python-control: one period from rest, then from the periodic state it implies
    sys = corrected_system(model, net)
    m = SWEEP_QUARTER_POINTS
    t = np.linspace(0.0, 60.0, 4 * m + 1)
    q = np.arange(4 * m + 1)
    u = np.where(q <= m, q / m, np.where(q <= 3 * m, 2.0 - q / m, q / m - 4.0))
    gamma = control.forced_response(sys, t, u, return_x=True).states[:, -1]
    x0 = np.linalg.solve(np.eye(sys.nstates) - linalg.expm(sys.A * 60.0), gamma)
    y = control.forced_response(sys, t, u, X0=x0).outputs / (net.lag_expansion().hf_gain)
    _, up_ref, down_ref = sweep_branches(y, m)
    np.testing.assert_allclose(up, up_ref, atol=1e-12)
    np.testing.assert_allclose(down, down_ref, atol=1e-12)
    assert hysteresis == pytest.approx(np.abs(down_ref - up_ref).max(), abs=1e-12)
