"""The normal equations solved in one place (creepcomp.fit.normal), and their users falling
back to a solver on the rows where they are not well-posed."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from creepcomp.fit.noise import fit_noise
from creepcomp.fit.normal import WELL_POSED, normal_solution
from creepcomp.fit.solver import _solve


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 12), st.integers(0, 2**31 - 1))
def test_a_well_posed_basis_is_solved_as_least_squares(n_cols, seed):
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(300, n_cols))
    y = rng.normal(size=300)
    x = normal_solution(a.T @ a, a.T @ y)
    assert x is not None
    np.testing.assert_allclose(x, np.linalg.lstsq(a, y, rcond=None)[0], rtol=1e-9, atol=1e-12)


def test_singular_ill_posed_and_nan_are_declined():
    a = np.random.default_rng(1).normal(size=(200, 3))
    singular = np.column_stack([a, a[:, 0]])
    assert normal_solution(singular.T @ singular, singular.T @ a[:, 1]) is None
    # columns 1e-5 apart: the unit-scaled normal equations have a condition number about 1e10
    close = np.column_stack([a[:, 0], a[:, 0] + 1e-5 * a[:, 1]])
    g = close.T @ close
    g = g / np.outer(np.sqrt(g.diagonal()), np.sqrt(g.diagonal()))
    assert 1.0 / np.linalg.cond(g, 1) < WELL_POSED
    assert normal_solution(g, np.ones(2)) is None
    nan = a.T @ a
    nan[0, 0] = np.nan
    assert normal_solution(nan, np.ones(3)) is None


def test_solve_falls_back_to_the_rows_where_the_normal_equations_decline():
    rng = np.random.default_rng(2)
    base = rng.normal(size=(500, 2))
    # nearly collinear columns: the rows' solver gives the least-squares answer the normal
    # equations cannot
    a = np.column_stack([base[:, 0], base[:, 0] + 1e-6 * base[:, 1]])
    truth = np.array([2.0, -1.0])
    y = a @ truth
    np.testing.assert_allclose(_solve(a, y), truth, rtol=1e-6)
    # a function for the rows is called only when they are needed
    calls = []
    x = _solve(base, lambda: calls.append(1) or base @ truth, gram=base.T @ base, rhs=base.T @ (base @ truth))
    assert calls == []
    np.testing.assert_allclose(x, truth)
    np.testing.assert_allclose(_solve(a, lambda: calls.append(1) or y, gram=a.T @ a, rhs=a.T @ y), truth, rtol=1e-6)
    assert calls == [1]


@pytest.mark.parametrize("phi", [0.0, 0.5, 0.99])
def test_ar_noise_orders_from_one_gram_matrix(phi):
    rng = np.random.default_rng(3)
    e = rng.normal(size=4000)
    x = np.empty_like(e)
    x[0] = e[0]
    for i in range(1, len(e)):
        x[i] = phi * x[i - 1] + e[i]
    rows = np.arange(5, len(x))
    noise = fit_noise(x, rows, 5)
    if phi == 0.0:
        assert len(noise.phi) <= 1
    else:
        assert abs(noise.phi[0] - phi) < 0.05
        assert len(noise.phi) <= 2
    # the coefficients are those of least squares on the rows
    p = len(noise.phi)
    if p:
        lagged = np.column_stack([x[rows - i] for i in range(1, p + 1)])
        np.testing.assert_allclose(noise.phi, np.linalg.lstsq(lagged, x[rows], rcond=None)[0], rtol=1e-8)
    # a residual of zeros: no AR term, no failure
    assert fit_noise(np.zeros(500), np.arange(5, 500), 5).phi == ()
