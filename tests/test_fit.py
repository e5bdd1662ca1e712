import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from creepcomp import programs
from creepcomp.errors import InputError
from creepcomp.fit.data import prepare
from creepcomp.fit.structure import Structure
from creepcomp.fit.noise import fit_noise, rows_for, whiten
from creepcomp.fit.solver import fit_structure
from creepcomp.fit.evidence import compare, heldout
from creepcomp.fit.starts import one_term_starts
from creepcomp.fit.prony import fit_prony, term_table
from creepcomp.lti import lag_states, varying_lag_states
from creepcomp.model import CreepModel
from creepcomp.io.records import Record


def _record(model, program, t, noise, seed=0, offset=0.0):
    rng = np.random.default_rng(seed)
    y = model.offset + model.gain * program.response(model.lag_expansion(), t)
    return Record(t, program.sample(t), y + rng.normal(0, noise, t.size))


def test_two_terms_recovered_and_chosen_by_evidence():
    """A staircase seen through two creep terms: the evidence asks for two terms, not one or
    three, and the parameters come back within a few of their standard deviations."""
    t = np.arange(0, 1800, 0.2)
    model = CreepModel((0.03, 0.015), (40.0, 350.0), gain=2.0, offset=0.1)
    prog = programs.staircase([1, 2, 3, 2, 1, 0, 2, 0], hold=220, start=30)
    result = fit_prony(prepare(_record(model, prog, t, 0.004)), max_terms=4)
    assert result.fit.structure.n_terms == 2
    assert len(result.steps) == 3                         # stopped at the first unsupported term
    assert not result.steps[2].evidence.supported
    terms = term_table(result.fit)
    for term, beta, tau in zip(terms, (0.03, 0.015), (40.0, 350.0)):
        assert abs(term["tau"] - tau) < 5 * term["tau_sigma"] + 0.02 * tau
        assert abs(term["beta"] - beta) < 5 * term["beta_sigma"] + 0.02 * beta
    assert result.fit.gain == pytest.approx(2.0, rel=1e-3)


@settings(max_examples=4)
@given(st.integers(0, 2**31 - 1))
def test_one_term_record_starting_loaded_irregular(seed):
    """Irregular sampling, a record that starts loaded and still creeping: one term, found."""
    rng = np.random.default_rng(seed)
    tau = rng.uniform(20, 80)
    model = CreepModel((rng.uniform(0.02, 0.05),), (tau,), gain=rng.uniform(0.5, 3), offset=rng.normal())
    prog = programs.LoadProgram((-tau, -tau, 300.0, 300.0, 900.0), (0.0, 1.0, 1.0, 2.5, 2.5))
    t = np.sort(rng.uniform(0, 900, 2500))
    rec = _record(model, prog, t, 1e-3, seed)
    result = fit_prony(prepare(rec), max_terms=3)
    assert result.fit.structure.n_terms == 1
    term = term_table(result.fit)[0]
    assert term["tau"] == pytest.approx(tau, rel=0.05)


def test_material_creep_test_with_step_before_first_sample():
    """Constant load, step at t = 0, first sample later: offset fixed at 0, terms found."""
    t = np.geomspace(0.2, 2000, 600)
    comp = 1.0 + 0.5 * -np.expm1(-t / 3.0) + 2.0 * -np.expm1(-t / 200.0)
    rec = Record(t, np.ones_like(t), 1e-6 * comp * (1 + 1e-4 * np.random.default_rng(1).normal(size=t.size)))
    data = prepare(rec, load_step_at=0.0)
    assert data.fixed_offset
    result = fit_prony(data, max_terms=4)
    assert result.fit.offset == 0.0
    taus = sorted(term["tau"] for term in term_table(result.fit))
    assert result.fit.structure.n_terms == 2
    assert taus[0] == pytest.approx(3.0, rel=0.05) and taus[1] == pytest.approx(200.0, rel=0.05)


def test_constant_load_needs_the_step_time():
    t = np.arange(100.0)
    creeping = 1.0 + 0.03 * -np.expm1(-t / 20.0)
    with pytest.raises(InputError, match="load-step-at"):
        prepare(Record(t, np.ones_like(t), creeping))
    with pytest.raises(InputError, match="must not be after"):
        prepare(Record(t + 5, np.ones_like(t), creeping), load_step_at=10.0)


def test_zero_load_and_short_record_are_refused():
    t = np.arange(100.0)
    with pytest.raises(InputError, match="zero throughout"):
        prepare(Record(t, np.zeros_like(t), t))
    with pytest.raises(InputError, match="too few"):
        prepare(Record(t[:4], t[:4], t[:4]))


def test_ar_noise_model_is_recovered():
    rng = np.random.default_rng(3)
    e = np.zeros(20000)
    w = rng.normal(size=e.size)
    for i in range(1, e.size):
        e[i] = 0.7 * e[i - 1] + w[i]
    t = np.arange(e.size, dtype=float)
    data = prepare(Record(t, np.sin(t / 50), e))
    noise = fit_noise(e, rows_for(data))
    assert noise.phi[0] == pytest.approx(0.7, abs=0.02)
    assert sum(abs(p) for p in noise.phi[1:]) < 0.05
    white = whiten(e, rows_for(data), noise)
    assert np.std(white) == pytest.approx(1.0, rel=0.03)


def test_gaps_break_the_noise_memory():
    t = np.concatenate([np.arange(100.0), 500 + np.arange(100.0)])
    data = prepare(Record(t, np.sin(t), np.cos(t)))
    rows = rows_for(data, order=2)
    assert 100 not in rows and 101 not in rows and 102 in rows


def test_heldout_flags_a_useless_term_and_keeps_a_real_one():
    t = np.arange(0, 1500, 0.5)
    model = CreepModel((0.04,), (60.0,), gain=1.0)
    prog = programs.staircase([1, 3, 0, 2, 0], hold=280, start=20)
    data = prepare(_record(model, prog, t, 2e-3, seed=5))
    one = fit_structure(data, Structure(1), one_term_starts(data))
    one = heldout(data, one)
    from creepcomp.fit.prony import fit_terms

    two = heldout(data, fit_terms(data, 2, one, one.noise))
    ev = compare(one, two)
    assert not ev.supported and ev.delta_bic > 0
    assert one.heldout.rms == pytest.approx(2e-3, rel=0.1)


def test_varying_lag_states_equals_lag_states_for_constant_time_constants():
    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(0.01, 3.0, 400))
    u = rng.normal(size=t.size)
    taus = np.array([0.05, 3.0, 300.0])
    ref = lag_states(t, u, taus, initial=np.array([0.3, -1.0, 2.0]))
    got = varying_lag_states(t, u, np.tile(taus, (t.size - 1, 1)), initial=np.array([0.3, -1.0, 2.0]))
    np.testing.assert_allclose(got, ref, atol=1e-10)


def test_varying_lag_states_switching_time_constant_is_exact():
    """tau = 2 s for 5 s, then 10 s: the closed form of a step response."""
    t = np.linspace(0, 20, 2001)
    taus = np.where(t[:-1] < 5.0, 2.0, 10.0)[:, None]
    c = varying_lag_states(t, np.ones_like(t), taus)[:, 0]
    c5 = 1 - np.exp(-5 / 2.0)
    exact = np.where(t <= 5, 1 - np.exp(-t / 2.0), 1 - (1 - c5) * np.exp(-(t - 5) / 10.0))
    np.testing.assert_allclose(c, exact, atol=1e-12)


def test_varying_lag_states_never_overflow_when_lags_alternate_fast_and_slow():
    t = np.arange(0, 1000, 0.1)
    u = np.sin(t / 10)
    fast_slow = np.where((np.arange(t.size - 1) // 500) % 2 == 0, 0.01, 1000.0)
    taus = np.column_stack([fast_slow, 1000.0 - fast_slow + 0.02])
    c = varying_lag_states(t, u, taus)
    assert np.all(np.isfinite(c)) and np.max(np.abs(c)) <= 1.0


def test_a_fit_with_every_linear_coefficient_held_keeps_them():
    """A held-out refit may hold every linear coefficient (none determined by what is kept)."""
    t = np.arange(0, 600, 0.5)
    model = CreepModel((0.03,), (40.0,), gain=2.0, offset=0.1)
    prog = programs.staircase([1, 2, 0], hold=180, start=30)
    data = prepare(_record(model, prog, t, 0.004))
    full = fit_structure(data, Structure(1), one_term_starts(data))
    linear = {n: full.values[n] for n in ("offset", "gain", "a[0]")}
    held = fit_structure(data, Structure(1), [full.values], fixed=linear, mask=t < 300)
    assert {n: held.values[n] for n in linear} == linear
    assert np.sqrt(np.mean(held.residual ** 2)) < 2 * 0.004


def test_load_halves_give_each_part_a_load_change():
    from creepcomp.fit.evidence import half_blocks, load_halves
    n = 1000
    step = np.zeros(n)
    step[100:300] = 1.0                         # a step and its release, both in the first half
    parts = load_halves(step)
    for b in (0, 1):
        assert np.any(np.diff(step[parts == b]) != 0)
    assert np.all(np.diff(parts) >= 0)          # two contiguous parts
    stairs = np.repeat([0.0, 1.0, 2.0, 1.0], n // 4)   # changes on both sides of the middle
    np.testing.assert_array_equal(load_halves(stairs), half_blocks(n))
    one = np.where(np.arange(n) >= 100, 1.0, 0.0)      # one change: no split gives both one
    np.testing.assert_array_equal(load_halves(one), half_blocks(n))
    early = np.zeros(n)
    early[2:4] = 1.0                            # a part of 3 samples would predict nothing
    np.testing.assert_array_equal(load_halves(early), half_blocks(n))


def test_halves_only_for_noise_that_carries_from_block_to_block():
    from dataclasses import dataclass
    from creepcomp.fit.evidence import (BLOCK_MEMORY, SLOW_NOISE_RATIO, HeldOut, block_memory,
                                        compare_with_halves, slow_noise_ratio)
    from creepcomp.synth.common import NoiseSpec, sample_noise
    rng = np.random.default_rng(3)
    t = np.arange(5000) * 0.1                   # 40 blocks of 12.5 s
    short = sample_noise(t, NoiseSpec(white=0.0, coloured=1.0, correlation_time=2.0), rng)
    walk = sample_noise(t, NoiseSpec(white=0.2, drift=3.0), rng)
    # both are slow by the spectrum; only the walk carries over into the next block
    assert slow_noise_ratio(short) > SLOW_NOISE_RATIO and slow_noise_ratio(walk) > SLOW_NOISE_RATIO
    assert block_memory(short) < BLOCK_MEMORY < block_memory(walk)
    assert abs(block_memory(rng.normal(size=5000))) < BLOCK_MEMORY
    blocks = np.arange(5000) // 125
    signature = np.sin(2 * np.pi * t / 37.0)

    @dataclass(frozen=True)
    class Fitted:                               # what the evidence reads of a fit
        bic: float
        residual: np.ndarray
        heldout: HeldOut

    def fits(noise):
        return (Fitted(0.0, noise + signature, HeldOut(noise + signature, blocks)),
                Fitted(-100.0, noise, HeldOut(noise, blocks)))

    asked = []

    def across(simple, rich):
        def run():
            asked.append(True)
            return simple.heldout, rich.heldout
        return run
    for noise, expected in ((short, False), (walk, True)):
        asked.clear()
        simple, rich = fits(noise)
        assert compare_with_halves(simple, rich, across(simple, rich)).supported
        assert bool(asked) is expected


@pytest.mark.parametrize("uniform", [True, False])
@pytest.mark.parametrize("hold", ["linear", "zero"])
def test_lag_tau_derivatives_match_finite_differences(uniform, hold):
    from creepcomp.lti import lag_tau_derivatives

    rng = np.random.default_rng(1)
    t = np.arange(0.0, 200.0, 0.1) if uniform else np.cumsum(rng.uniform(0.05, 0.3, 1500))
    u = np.sin(t / 7.0) + (t > 30.0)
    taus = np.array([0.05, 3.0, 40.0, 5000.0])
    c0 = np.array([0.3, -0.2, 1.0, 0.5])
    states = lag_states(t, u, taus, hold=hold, initial=c0)
    slope = lag_tau_derivatives(t, u, taus, states, hold)
    for j, tau in enumerate(taus):
        up, down = taus.copy(), taus.copy()
        up[j] *= 1.0 + 1e-5
        down[j] *= 1.0 - 1e-5
        fd = (lag_states(t, u, up, hold=hold, initial=c0)[:, j]
              - lag_states(t, u, down, hold=hold, initial=c0)[:, j]) / (2e-5 * tau)
        assert np.max(np.abs(slope[:, j] - fd)) <= 1e-6 * np.max(np.abs(fd))


@pytest.mark.parametrize("initial", ["free", "relaxed", "step"])
def test_projected_jacobian_matches_finite_differences(initial):
    """The analytic variable-projection Jacobian (lags' own derivative recursion, linear part
    projected out) equals central differences of the projected residual, with a mask and a
    held coefficient too."""
    from creepcomp.fit.solver import Problem

    t = np.arange(0.0, 600.0, 0.5)
    load = np.where(t >= 30.0, 1.0, 0.0) + 0.5 * (t >= 300.0)
    signal = load + lag_states(t, load, [8.0, 90.0]) @ np.array([0.02, 0.03])
    signal = signal + np.random.default_rng(0).normal(0.0, 1e-4, t.size)
    record = Record(t, load + 0.1, signal) if initial == "step" else Record(t, load, signal)
    data = (prepare(record, load_step_at=-5.0) if initial == "step" else prepare(record, initial=initial))
    for mask, fixed in ((None, None), (np.arange(t.size) % 7 != 0, {"offset": 0.001})):
        problem = Problem(data, Structure(2), mask=mask, fixed=fixed)
        x = problem.start_vector({"tau[0]": 5.0, "tau[1]": 70.0, "c0[0]": 0.1, "c0[1]": -0.2})
        jac = problem.jacobian(x)
        fd = np.column_stack([(problem.residual(x + 1e-5 * e) - problem.residual(x - 1e-5 * e)) / 2e-5
                              for e in np.eye(len(x))])
        assert np.all(np.max(np.abs(jac - fd), axis=0) <= 1e-5 * np.max(np.abs(fd), axis=0))


def test_free_start_gives_way_to_settled_on_a_record_that_starts_at_rest():
    """A record at rest before its load step: the settled start is kept (the free initial
    states do not earn their parameters) and the terms are found; one that starts creeping
    keeps its fitted initial states."""
    t = np.arange(0.0, 1800.0, 0.5)
    load = np.where(t >= 30.0, 1.0, 0.0)
    noise = np.random.default_rng(3).normal(0.0, 1e-4, t.size)
    signal = load + lag_states(t, load, [8.0, 300.0]) @ np.array([0.02, 0.04]) + noise
    result = fit_prony(prepare(Record(t, load, signal)))
    assert result.data.initial == "settled" and result.fit.structure.n_terms == 2
    assert sorted(result.fit.taus) == pytest.approx([8.0, 300.0], rel=0.05)
    creeping = load + lag_states(t, load, [300.0], initial=np.array([-0.5])) @ np.array([0.04]) + noise
    assert fit_prony(prepare(Record(t, load, creeping))).data.initial == "free"
