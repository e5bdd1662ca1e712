"""The compiled recursions (numba, :mod:`creepcomp.recursions`) against numpy's blocks of
cumulative sums: the same lag states and derivatives to rounding, the same play bit for bit;
and the diagnosis runs them."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from creepcomp import lti
from creepcomp.diagnose.effects.rate_independent_hysteresis import play


def _record(seed: int, n: int, uniform: bool, changes: str, kinds: bool = False):
    """Sample times uniform, of a few step lengths (``kinds``: a reduced record's blocks) or
    irregular, and an input that changes at a few samples or at every one."""
    rng = np.random.default_rng(seed)
    if uniform:
        t = np.arange(n) * 0.1
    elif kinds:
        t = np.cumsum(rng.choice([0.1, 0.25, 0.4], n))
    else:
        t = np.cumsum(rng.uniform(0.01, 0.5, n))
    if changes == "few":             # a staircase: numpy solves it run by run
        u = np.repeat(rng.normal(size=4), -(-n // 4))[:n]
    else:
        u = np.cumsum(rng.normal(size=n)) * 0.1
    return t, u


def _both(function, *args, **kwargs):
    numpy_result = function(*args, **kwargs)
    with lti.compiled_loops():
        compiled_result = function(*args, **kwargs)
    return numpy_result, compiled_result


def _close(a, b, scale):
    assert a.shape == b.shape
    assert np.max(np.abs(a - b)) <= 1e-12 * scale


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**31), st.integers(2, 3000), st.sampled_from(["uniform", "kinds", "irregular"]),
       st.sampled_from(["few", "many"]), st.sampled_from(["linear", "zero"]),
       st.sampled_from(["relaxed", "settled", "given"]))
def test_lag_states_agree(seed, n, times, changes, hold, initial):
    t, u = _record(seed, n, times == "uniform", changes, kinds=times == "kinds")
    taus = np.array([0.03, 2.0, 700.0])
    start = np.array([0.5, -1.0, 2.0]) if initial == "given" else initial
    a, b = _both(lti.lag_states, t, u, taus, hold=hold, initial=start)
    _close(a, b, max(np.max(np.abs(u)), 2.0))


def test_lag_states_with_the_input_before_each_sample_agree():
    t, u = _record(4, 2000, False, "many")
    before = u + np.where(np.arange(len(u)) % 50 == 0, 0.3, 0.0)
    a, b = _both(lti.lag_states, t, u, [1.0, 30.0], u_before=before)
    _close(a, b, np.max(np.abs(before)))


@pytest.mark.parametrize("times", ["uniform", "kinds", "irregular"])
@pytest.mark.parametrize("changes", ["few", "many"])
@pytest.mark.parametrize("hold", ["linear", "zero"])
def test_time_constant_derivatives_agree(times, changes, hold):
    t, u = _record(8, 2500, times == "uniform", changes, kinds=times == "kinds")
    taus = np.array([0.5, 40.0])
    states = lti.lag_states(t, u, taus, hold=hold)
    a, b = _both(lti.lag_tau_derivatives, t, u, taus, states, hold, initial_slope=[0.1, -0.2])
    _close(a, b, np.max(np.abs(a)))


@pytest.mark.parametrize("hold", ["linear", "zero"])
def test_varying_lags_and_their_derivatives_agree(hold):
    t, u = _record(9, 3000, False, "many")
    steps = np.arange(len(t) - 1)
    taus = np.column_stack([np.where(steps % 700 < 350, 2.0, 9.0), np.full(len(steps), 60.0)])
    slopes = np.column_stack([taus[:, 0] * (steps % 700 < 350), taus[:, 1]])
    a, b = _both(lti.varying_lag_states, t, u, taus, hold=hold, initial=[0.3, -0.2])
    _close(a, b, np.max(np.abs(u)))
    da, db = _both(lti.varying_lag_derivatives, t, u, taus, a, slopes, hold, initial_slope=[0.5, 0.0])
    _close(da, db, np.max(np.abs(da)))


@pytest.mark.parametrize("hold", ["linear", "zero"])
def test_steps_of_the_same_decay_but_other_time_constants_keep_their_own_slopes(hold):
    # dt / tau is the same on every step, dt and tau are not: the compiled loops compute a
    # step's coefficients again only when its decay changes, its slopes when dt or tau do
    t = np.cumsum(np.tile([0.1, 0.3], 500))
    u = np.sin(t)
    dt = np.diff(t)
    taus = np.column_stack([dt * 10.0, np.full(len(dt), 5.0)])
    slopes = np.column_stack([np.ones(len(dt)), np.zeros(len(dt))])
    a, b = _both(lti.varying_lag_states, t, u, taus, hold=hold)
    _close(a, b, 1.0)
    da, db = _both(lti.varying_lag_derivatives, t, u, taus, a, slopes, hold)
    _close(da, db, np.max(np.abs(da)))
    assert np.max(np.abs(da[:, 0])) > 0.0


def test_a_vanishing_time_constant_settles_the_compiled_lag_at_its_input():
    t = np.arange(12.0)
    u = np.linspace(0.0, 1.0, 12)
    taus = np.full((11, 1), 2.0)
    taus[4] = 1e-320
    a, b = _both(lti.varying_lag_states, t, u, taus, hold="zero")
    assert np.all(np.isfinite(b)) and b[5, 0] == pytest.approx(u[4])
    _close(a, b, 1.0)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31), st.integers(1, 2000), st.floats(0.0, 3.0), st.floats(-2.0, 2.0))
def test_the_compiled_play_is_numpys_bit_for_bit(seed, n, width, initial):
    x = np.cumsum(np.random.default_rng(seed).normal(size=n))
    a, b = _both(play, x, width, initial)
    np.testing.assert_array_equal(a, b)


def test_compiled_loops_is_a_context():
    assert not lti.compiled_active()
    with pytest.raises(RuntimeError):
        with lti.compiled_loops():
            assert lti.compiled_active()
            raise RuntimeError("leaves")
    assert not lti.compiled_active()


def test_the_diagnosis_runs_its_lags_compiled(monkeypatch):
    """Every lag evaluation of a diagnosis's search runs inside :func:`~creepcomp.lti.compiled_loops`."""
    from creepcomp import data
    from creepcomp.diagnose.sensor import diagnose
    from creepcomp.fit import structure

    seen = []
    original = structure.lag_states

    def spy(*args, **kwargs):
        seen.append(lti.compiled_active())
        return original(*args, **kwargs)

    monkeypatch.setattr(structure, "lag_states", spy)
    diagnose(data.hidden_effect(), correction=False, max_effects=1)
    assert seen and all(seen)


def test_a_reduced_records_few_step_lengths_are_solved_by_kind():
    t, _ = _record(5, 3000, False, "many", kinds=True)
    lengths, kind = lti.Sampling(t).kinds
    # three lengths, and the few that summing the times rounds them to: each step's own exactly
    assert 3 <= len(lengths) < 50
    np.testing.assert_array_equal(lengths[kind], np.diff(t))


def test_decay_columns_agree_and_keep_their_zeros():
    """Each column zero before its first sample, where its scale is zero and beyond the decay
    floor; in between the decay, summed step by step when compiled."""
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.05, 0.2, 3000))
    first = np.array([10, 500, 2999, 2000])
    mids = t[first - 1] + 0.01
    taus = np.array([0.5, 30.0, 900.0])
    scales = rng.normal(size=(4, 3))
    scales[1, 2] = 0.0
    a, b = _both(lti.decay_columns, t, first, mids, taus, scales)
    _close(a, b, np.max(np.abs(scales)))
    np.testing.assert_array_equal(a == 0.0, b == 0.0)
    assert not b[:10].any() and not b[:, 5].any()
    assert b[-1, 0] == 0.0 and b[-1, 2] != 0.0        # tau 0.5 s has decayed past the floor, 900 s not
