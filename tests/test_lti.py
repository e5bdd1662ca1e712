import math

import control
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from creepcomp.lti import LagExpansion, cascade_step, lag_states


def test_step_hold_zero_and_linear_are_exact_for_a_step():
    t = np.array([0.0, 0.3, 1.0, 2.5, 7.0, 30.0])
    u = np.ones_like(t)
    for hold in ("zero", "linear"):
        c = lag_states(t, u, [2.0], hold=hold)[:, 0]
        # relaxed start: the input jumped to 1 at t[0]
        np.testing.assert_allclose(c, -np.expm1(-t / 2.0), rtol=0, atol=1e-15)


def test_ramp_is_exact_with_linear_hold_on_irregular_times():
    rng = np.random.default_rng(1)
    t = np.cumsum(rng.uniform(0.01, 3.0, 300))
    t -= t[0]
    u = 0.7 * t
    c = lag_states(t, u, [5.0], hold="linear")[:, 0]
    exact = 0.7 * (t - 5.0 * -np.expm1(-t / 5.0))
    np.testing.assert_allclose(c, exact, rtol=0, atol=1e-12 * t.max())


def test_zero_hold_treats_samples_as_held():
    t = np.array([0.0, 1.0, 2.0, 3.0])
    u = np.array([0.0, 1.0, 1.0, 1.0])
    c = lag_states(t, u, [1.0], hold="zero")[:, 0]
    np.testing.assert_allclose(c, [0, 0, 1 - np.exp(-1), 1 - np.exp(-2)], atol=1e-15)


def test_uniform_matches_python_control_foh():
    t = np.linspace(0, 200, 2001)
    u = np.sin(t / 7.0) + (t > 50)
    lag = LagExpansion(1.0, (0.03, -0.01), (45.0, 5.0))
    y = lag.simulate(t, u)
    ref = control.forced_response(lag.state_space(), t, u).outputs
    np.testing.assert_allclose(y, ref, atol=1e-12)


@given(st.integers(0, 2**31), st.sampled_from(["linear", "zero"]))
def test_inserting_points_on_the_held_input_changes_nothing(seed, hold):
    """Exactness: states at the original times do not depend on extra samples taken on the
    input's own interpolant (linear ramp or held value)."""
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.01, 20.0, 60))
    u = rng.normal(size=t.size)
    taus = rng.uniform(0.3, 300, 3)
    extra_t = rng.uniform(t[0], t[-1], 200)
    idx = np.searchsorted(t, extra_t) - 1
    if hold == "linear":
        extra_u = np.interp(extra_t, t, u)
    else:
        extra_u = u[idx]
    both_t = np.concatenate([t, extra_t])
    both_u = np.concatenate([u, extra_u])
    order = np.argsort(both_t, kind="stable")
    both_t, both_u = both_t[order], both_u[order]
    keep = np.concatenate([[True], np.diff(both_t) > 0])
    both_t, both_u = both_t[keep], both_u[keep]
    dense = lag_states(both_t, both_u, taus, hold=hold)
    sparse = lag_states(t, u, taus, hold=hold)
    np.testing.assert_allclose(dense[np.searchsorted(both_t, t)], sparse, atol=1e-11)


@pytest.mark.parametrize("compiled", [False, True])
def test_irregular_scan_is_exact_against_per_step_recursion(compiled):
    """Numpy's blocks of cumulative sums and the compiled recursion (:mod:`creepcomp.recursions`)."""
    from contextlib import nullcontext

    from creepcomp.lti import compiled_loops

    rng = np.random.default_rng(7)
    dt = rng.uniform(0.001, 2.0, 5000)
    dt[100] = 1e4                       # a long gap
    t = np.concatenate([[0], np.cumsum(dt)])
    u = rng.normal(size=t.size)
    taus = np.array([0.05, 3.0, 400.0])
    with compiled_loops() if compiled else nullcontext():
        got = lag_states(t, u, taus, hold="linear", initial="settled")
    c = np.full(3, u[0])
    for n in range(len(dt)):
        x = dt[n] / taus
        e = np.exp(-x)
        g = -np.expm1(-x) / x
        c = e * c + (g - e) * u[n] + (1 - g) * u[n + 1]
        np.testing.assert_allclose(got[n + 1], c, rtol=1e-9, atol=1e-12)


def test_no_overflow_at_t_over_tau_a_million():
    t = np.linspace(0, 1e6 * 20.0, 200_001)
    t[1:] += np.random.default_rng(3).uniform(-1, 1, t.size - 1)   # irregular
    t.sort()
    u = np.ones_like(t)
    c = lag_states(t, u, [20.0])[:, 0]
    assert np.all(np.isfinite(c))
    np.testing.assert_allclose(c[-1000:], 1.0, atol=1e-12)


def test_cascade_step_handles_coincident_poles():
    g = LagExpansion(1.0, (0.03,), (45.0,))
    h = LagExpansion(1.0, (-0.03 / 1.06,), (45.0,))   # pole exactly on the creep's
    t = np.linspace(0, 900, 901)
    y = cascade_step(g, h, t)
    ref = control.step_response(control.series(g.state_space(), h.state_space()), t).outputs
    np.testing.assert_allclose(y, ref, atol=1e-13)


def test_lag_expansion_gains_and_forms_agree():
    lag = LagExpansion(0.9, (0.05, 0.02), (3.0, 40.0))
    assert lag.dc_gain == pytest.approx(0.97)
    w = np.logspace(-4, 2, 50)
    fr = lag.frequency_response(w)
    tf = lag.transfer_function()
    np.testing.assert_allclose(fr, tf(1j * w), rtol=1e-12)
    np.testing.assert_allclose(lag.step(np.array([0.0, 1e9])), [0.9, 0.97], atol=1e-15)


@pytest.mark.parametrize("rate", [0.0, 1e-9, 1e-3, 0.05, 0.5, 15.5, 29.9, 40.0, np.inf])
def test_first_order_filter_is_the_recursion(rate):
    """The blocked filter equals the plain recursion c[n+1] = e c[n] + drive[n] to rounding,
    from a decay slower than the record to one faster than a sample."""
    from creepcomp.lti import first_order_filter

    rng = np.random.default_rng(3)
    drive = rng.normal(size=5000) + (np.arange(5000) > 1000)
    e, c = math.exp(-rate), 0.7
    expected = np.empty(5000)
    for n, d in enumerate(drive):
        c = e * c + d
        expected[n] = c
    got = first_order_filter(e, drive, 0.7)
    assert np.max(np.abs(got - expected)) <= 1e-12 * np.max(np.abs(expected))


def test_inverse_ar_transpose_is_the_backward_all_pole_filter():
    from creepcomp.fit.noise import ARNoise
    from creepcomp.fit.solver import _inverse_ar_transpose

    phi = (1.2, -0.5, 0.1)
    z = np.random.default_rng(4).normal(size=(400, 3))
    y = np.zeros_like(z)
    for n in range(len(z) - 1, -1, -1):          # y[n] = z[n] + sum phi_i y[n + i]
        y[n] = z[n] + sum(p * y[n + i] for i, p in enumerate(phi, start=1) if n + i < len(z))
    assert np.allclose(_inverse_ar_transpose(z, ARNoise(phi=phi, sigma=1.0)), y, rtol=1e-12, atol=1e-12)


def test_varying_lag_states_with_a_vanishing_time_constant_follow_the_input():
    """A step decaying by more than a float can hold (dt / tau = inf) settles the lag at its
    input, as the exact recursion does, instead of spoiling the rest of the record."""
    from creepcomp.lti import varying_lag_states

    t = np.arange(12.0)
    u = np.linspace(0.0, 1.0, 12)
    taus = np.full((11, 1), 2.0)
    taus[4] = 1e-320
    out = varying_lag_states(t, u, taus, hold="zero", initial="relaxed")
    assert np.all(np.isfinite(out)) and out[5, 0] == pytest.approx(u[4])
    reference = varying_lag_states(t[5:], u[5:], taus[5:], hold="zero", initial=[out[5, 0]])
    assert np.allclose(out[5:], reference, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("compiled", [False, True])
def test_times_changed_in_place_are_checked_again(compiled):
    """The steps of a record's times are kept between calls (by the array's identity): times
    that stop increasing in the same array must still be refused, and times moved in it used."""
    import contextlib

    from creepcomp.errors import InputError
    from creepcomp.lti import compiled_loops, varying_lag_states

    t = np.linspace(0.0, 10.0, 101)
    u = np.ones_like(t)
    with compiled_loops() if compiled else contextlib.nullcontext():
        before = lag_states(t, u, [2.0])[:, 0]
        t *= 2.0                                   # the same array, every step twice as long
        assert np.allclose(lag_states(t, u, [2.0])[:, 0], lag_states(t.copy(), u, [2.0])[:, 0], rtol=0, atol=1e-14)
        assert not np.allclose(lag_states(t, u, [2.0])[:, 0], before)
        t[5] = t[4]
        with pytest.raises(InputError, match="strictly increasing"):
            lag_states(t, u, [2.0])
        with pytest.raises(InputError, match="strictly increasing"):
            varying_lag_states(t, u, np.full((len(t) - 1, 1), 2.0))


def test_a_sampling_keeps_what_its_times_give_and_agrees_with_plain_times():
    """Lags on a :class:`~creepcomp.lti.Sampling` are those on its times; it keeps the plans
    of its last time constants and the runs of its last inputs, by their values (an input
    changed in place is a new input), and pickles as its times only."""
    import pickle

    from creepcomp.lti import Sampling, lag_states, lag_tau_derivatives

    t = np.cumsum(np.random.default_rng(4).uniform(0.5, 1.5, 600))
    sampling = Sampling(t)
    u = np.where(np.arange(600) > 300, 2.0, 1.0)
    for _ in range(2):
        states = lag_states(sampling, u, [3.0, 40.0])
        np.testing.assert_array_equal(states, lag_states(t, u, [3.0, 40.0]))
    np.testing.assert_array_equal(lag_tau_derivatives(sampling, u, [3.0, 40.0], states),
                                  lag_tau_derivatives(t, u, [3.0, 40.0], states))
    np.testing.assert_array_equal(lag_states(sampling, np.sin(t), [3.0]), lag_states(t, np.sin(t), [3.0]))
    assert sampling._plans and sampling._runs
    changed = u.copy()
    changed[400:] = 5.0
    np.testing.assert_array_equal(lag_states(sampling, changed, [3.0, 40.0]), lag_states(t, changed, [3.0, 40.0]))
    again = pickle.loads(pickle.dumps(sampling))
    np.testing.assert_array_equal(again.time, t)
    assert not again._plans and not again.time.flags.writeable
