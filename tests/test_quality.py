import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from creepcomp.model import CreepModel
from creepcomp.network import Cell, Network, modal_form, state_matrices
from creepcomp.analog.quality import predict, residual_curves, step_residual
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
    t, e, _ = step_residual(model, net)
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
def test_closed_form_screen_agrees_with_python_control(beta, tau, fr1, fr2):
    model = CreepModel.voigt(beta, tau)
    ideal = ideal_network(model, "exact", 1e-6)
    net = Network((Cell(ideal.cells[0].R * fr1, 1e-6),), ideal.R2 * fr2)
    t, e, _ = step_residual(model, net)
    d, r, p = modal_form(*state_matrices(*net.as_arrays()))
    closed = residual_curves(model, d, r, p, t)[0]
    np.testing.assert_allclose(closed, e, atol=1e-11)
