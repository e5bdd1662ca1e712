"""The fast paths of the fit agree with the general ones: lags of a rarely changing input in
closed form, the linearised held-out refit, the covariance added after the fit."""

import numpy as np
import pytest

from creepcomp import lti
from creepcomp.fit.data import prepare
from creepcomp.fit.evidence import heldout
from creepcomp.fit.prony import fit_terms
from creepcomp.fit.solver import with_covariance
from creepcomp.io.records import Record


def _recursion(monkeypatch, fn, *args, **kwargs):
    """``fn`` with the run-by-run closed form switched off (the plain recursion)."""
    with monkeypatch.context() as m:
        m.setattr(lti, "_RUNS_SHARE", -1.0)
        return fn(*args, **kwargs)


@pytest.mark.parametrize("uniform", [True, False])
@pytest.mark.parametrize("initial", ["relaxed", "settled", "array"])
def test_lags_of_a_stepped_input_in_closed_form_equal_the_recursion(monkeypatch, uniform, initial):
    rng = np.random.default_rng(4)
    t = np.arange(0.0, 3000.0, 0.25) if uniform else np.cumsum(rng.uniform(0.05, 0.45, 12000))
    u = np.zeros(t.size)
    for at, size in ((10, 1.0), (4000, -0.4), (4001, 0.7), (9000, -1.3)):   # (two in a row)
        u[at:] += size
    taus = np.array([1e-3, 0.7, 8.0, 90.0, 900.0, 1e5])
    init = np.linspace(-0.5, 0.5, taus.size) if initial == "array" else initial
    assert lti._input_changes(u, "linear") is not None          # the closed form runs
    got = lti.lag_states(t, u, taus, initial=init)
    want = _recursion(monkeypatch, lti.lag_states, t, u, taus, initial=init)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    slope0 = np.linspace(0.0, 0.01, taus.size)
    got_d = lti.lag_tau_derivatives(t, u, taus, got, initial_slope=slope0)
    want_d = _recursion(monkeypatch, lti.lag_tau_derivatives, t, u, taus, want, initial_slope=slope0)
    np.testing.assert_allclose(got_d, want_d, rtol=0, atol=1e-11 * np.max(np.abs(want_d)))


def test_kept_runs_follow_an_input_changed_in_place():
    """The runs of an input are kept by the arrays' identity: the same array with other
    levels, or its steps elsewhere, gives its own lags."""
    t = np.arange(0.0, 100.0, 0.5)
    u = np.zeros(t.size)
    u[50:] = 1.0
    first = lti.lag_states(t, u, [5.0]).copy()
    u[50:] = 2.0                                    # same steps, another level
    np.testing.assert_allclose(lti.lag_states(t, u, [5.0]), 2.0 * first, rtol=0, atol=1e-12)
    u[:] = 0.0
    u[120:] = 2.0                                   # the step elsewhere
    moved = lti.lag_states(t, u, [5.0])
    np.testing.assert_array_equal(moved, lti.lag_states(t.copy(), u.copy(), [5.0]))   # (not kept)
    assert np.all(moved[:120] == 0.0) and moved[-1, 0] > 1.9


def test_decay_is_the_exponential_and_zero_past_its_floor():
    since = np.linspace(0.0, 1000.0, 10001)
    got = lti.decay(since, 2.0)
    live = since < lti.DECAY_FLOOR * 2.0
    np.testing.assert_allclose(got[live], np.exp(-since[live] / 2.0), rtol=1e-14)
    assert np.all(got[~live] == 0.0) and (~live).any()
    assert list(lti.decay(np.array([0.0, 1.0]), 0.0)) == [1.0, 0.0]


def _two_term_record(seed=2, release=True):
    t = np.arange(0.0, 1200.0, 0.5)
    load = np.where(t >= 30.0, 1.0, 0.0) - (0.6 * (t >= 700.0) if release else 0.0)
    signal = load + lti.lag_states(t, load, [12.0, 150.0]) @ np.array([0.03, 0.02])
    signal = signal + np.random.default_rng(seed).normal(0.0, 1e-4, t.size)
    return prepare(Record(t, load, signal), initial="settled")


def test_linearised_heldout_lands_where_the_iterative_refit_does_when_the_model_holds():
    data = _two_term_record(release=False)
    fit = fit_terms(data, 2, with_cov=False)
    step = heldout(data, fit, linearised=True).heldout
    iterated = heldout(data, fit).heldout
    assert step.rms == pytest.approx(iterated.rms, rel=1e-3)
    # the predictions of each held-out sample differ by far less than the noise
    assert np.max(np.abs(step.residual - iterated.residual)) < 0.1 * 1e-4
    again = heldout(data, fit, linearised=True).heldout
    assert np.array_equal(again.residual, step.residual)


def test_a_fit_with_step_times_is_held_out_iteratively():
    data = _two_term_record()
    fit = fit_terms(data, 2, with_cov=False)
    assert any(name.startswith("step_time[") for name in fit.values)
    step = heldout(data, fit, linearised=True).heldout
    assert np.array_equal(step.residual, heldout(data, fit).heldout.residual)


def test_covariance_added_after_the_fit_is_the_fits_own():
    data = _two_term_record(5)
    with_cov = fit_terms(data, 2)
    later = with_covariance(data, fit_terms(data, 2, with_cov=False))
    assert later.cov is not None
    np.testing.assert_allclose(later.cov, with_cov.cov, rtol=1e-10, atol=0)


def test_two_terms_at_one_time_constant_are_not_a_second_term():
    """The left insole record (every 4th sample), fitted as starting settled: the best two-term
    fit puts both terms at about 10 ks with amplitudes of +-6e7 and opposite sign, and lowers
    BIC by 98; it is one term and the t·exp(-t/tau) shape, so the search keeps one term."""
    from dataclasses import replace

    from creepcomp import data
    from creepcomp.fit.prony import coalesced, fit_prony

    assert coalesced([10262.4, 10262.9]) and coalesced([1.0, 3.0, 3.1])
    assert not coalesced([8.0, 90.0, 900.0]) and not coalesced([45.0])
    record = data.insole_left_steps()
    record = record.with_columns(time=record.time[::4], load=record.load[::4], signal=record.signal[::4])
    result = fit_prony(replace(prepare(record), initial="settled"), max_terms=2)
    assert len(result.steps) == 2 and coalesced(result.steps[1].fit.taus)
    assert result.fit.structure.n_terms == 1
    orders = result.to_dict()["fit"]["orders"]
    assert [o.get("coalesced", False) for o in orders] == [False, True]


def test_a_linearised_held_out_step_beyond_a_bound_stops_at_the_bound():
    # a 250,000-sample step record (three terms at 8, 90 and 900 s) reduced to 50,000: a fold's
    # Gauss-Newton step for a term the fold hardly sees is huge, and from a log-scaled time
    # constant it overflowed (OverflowError from math.exp) instead of ending at the bound
    from creepcomp.fit import fit_prony
    from creepcomp.fit.reduce import reduce_record

    t = np.arange(0.0, 25000.0, 0.1)
    load = np.where(t >= 30.0, 1.0, 0.0)
    noise = np.random.default_rng(104).normal(0.0, 1e-4, t.size)
    signal = load + lti.lag_states(t, load, [8.0, 90.0, 900.0]) @ np.array([0.02, 0.03, 0.04]) + noise
    reduced, _ = reduce_record(Record(t, load, signal, source="step-250k"), 50_000)
    fit = fit_prony(prepare(reduced)).fit
    assert fit.structure.n_terms == 3
    assert np.sort(fit.taus) == pytest.approx([8.0, 90.0, 900.0], rel=0.02)


def test_kept_lag_plans_follow_times_changed_in_place():
    """What the lags take from the sample times alone is kept for the times' array: the same
    array with other times gives the lags of those times."""
    rng = np.random.default_rng(5)
    t = np.cumsum(rng.uniform(0.1, 0.9, 3000))
    u = rng.normal(size=t.size)
    first = lti.lag_states(t, u, [2.0, 40.0]).copy()
    np.testing.assert_array_equal(lti.lag_states(t, u, [2.0, 40.0]), first)     # (kept)
    np.testing.assert_array_equal(lti.lag_states(t, 3.0 * u, [2.0, 40.0]), lti.lag_states(t.copy(), 3.0 * u, [2.0, 40.0]))
    t *= 2.0                                        # other times, the same array
    np.testing.assert_array_equal(lti.lag_states(t, u, [2.0, 40.0]), lti.lag_states(t.copy(), u, [2.0, 40.0]))
    assert not np.allclose(lti.lag_states(t, u, [2.0, 40.0]), first)


def test_an_empty_column_is_solved_as_the_minimum_norm_solution_would():
    """A column that is all zero (a load step the delayed creep input does not take) gets the
    coefficient 0 and leaves the others as the rank-revealing solver finds them."""
    from scipy import linalg

    from creepcomp.fit.solver import _solve

    rng = np.random.default_rng(6)
    a = rng.normal(size=(400, 5))
    a[:, 2] = 0.0
    y = a @ np.array([1.0, -2.0, 0.0, 0.5, 3.0]) + 0.01 * rng.normal(size=400)
    got = _solve(a, y)
    want, *_ = linalg.lstsq(a, y, lapack_driver="gelsy")
    assert got[2] == 0.0
    np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(_solve(a[:, [0, 1, 3, 4]], y), np.delete(got, 2), rtol=1e-12)


def test_deferred_covariance_is_the_one_computed_at_once():
    """A fit's covariance is computed when first read; the fitting problem it keeps (pruned to
    the projection at the optimum) gives the matrix that a fresh problem gives, bit for bit."""
    import pickle
    from dataclasses import replace

    from creepcomp.diagnose import effects
    from creepcomp.fit.solver import DeferredCovariance, Problem, _fit_covariance

    data = _two_term_record(3)
    base = fit_terms(data, 1, with_cov=False)
    fit = effects.get("time_offset").fit_on(data, base)     # every parameter refined: with covariance
    deferred = fit.covariance
    assert isinstance(deferred, DeferredCovariance)
    _, x, coef, at = deferred._inputs
    fresh = _fit_covariance(Problem(data, fit.structure), x, coef, at)
    got = fit.cov
    assert got is not None and got.shape == (len(fit.vector_names),) * 2
    np.testing.assert_array_equal(got, fresh)
    assert fit.cov is got and replace(fit, heldout=None).cov is got      # computed once
    np.testing.assert_array_equal(pickle.loads(pickle.dumps(fit)).cov, got)
    assert fit.estimate(lambda v: v["time_offset.delay"])[1] > 0


def test_a_diagnosis_computes_the_covariances_it_reads_only(monkeypatch):
    from creepcomp import data
    from creepcomp.diagnose.sensor import diagnose
    from creepcomp.fit import solver

    made, computed = [], []
    init, compute = solver.DeferredCovariance.__init__, solver._fit_covariance

    def counted_init(self, *args):
        made.append(self)
        init(self, *args)

    def counted_compute(*args):
        computed.append(args)
        return compute(*args)

    monkeypatch.setattr(solver.DeferredCovariance, "__init__", counted_init)
    monkeypatch.setattr(solver, "_fit_covariance", counted_compute)
    result = diagnose(data.hidden_effect())
    assert result.cause == "asymmetric_recovery"
    sigmas = [v for v in result.findings[0].uncertainty.values() if isinstance(v, float)]
    assert sigmas and all(np.isfinite(v) and v > 0 for v in sigmas)
    assert 0 < len(computed) < len(made) / 2


def _with_input(b, h):
    from dataclasses import replace

    return replace(b, creep_input=h)


def test_step_time_columns_are_the_decay_after_each_step():
    """Each later load step's column of each term is ``-dh / tau exp(-(t - mid) / tau)`` after
    it and zero before it, bit for bit; a step the creep input does not take (a change of
    rounding size) is an empty column; the columns follow another input in the same problem."""
    from creepcomp.fit.data import load_steps
    from creepcomp.fit.structure import Structure, basis, with_step_times

    t = np.arange(0.0, 600.0, 0.5)
    load = np.zeros(t.size)
    for at, level in ((20, 1.0), (300, 0.4), (700, 1.3), (900, 0.0)):
        load[at:] = level
    data = prepare(Record(time=t, load=load, signal=load.copy(), source="steps"), initial="relaxed")
    steps = load_steps(data)
    assert len(steps) == 4
    taus = np.array([3.0, 40.0])
    values = {"tau[0]": 3.0, "tau[1]": 40.0}
    cache: dict = {}
    plain = basis(data, Structure(2), values, cache)
    for h in (plain.creep_input, 2.0 * plain.creep_input):
        b = with_step_times(data, _with_input(plain, h), taus, cache)
        first = plain.columns.shape[1]
        assert b.names[first:] == tuple(f"step_time[{j}][{k}]" for j in (1, 2, 3) for k in (0, 1))
        for j, i in enumerate(steps[1:], start=1):
            mid, dh = 0.5 * (t[i] + t[i + 1]), h[i + 1] - h[i]
            for k, tau in enumerate(taus):
                want = np.zeros(t.size)
                want[i + 1:] = -dh / tau * lti.decay(t[i + 1:] - mid, tau)
                col = b.columns[:, first + 2 * (j - 1) + k]
                np.testing.assert_array_equal(col, want)
                assert b.step_bounds[2 * (j - 1) + k][:2] == (first + 2 * (j - 1) + k, k)
                assert b.step_mids[2 * (j - 1) + k] == mid


def test_a_step_of_rounding_size_is_an_empty_column():
    from creepcomp.fit.data import load_steps
    from creepcomp.fit.structure import Structure, basis, with_step_times

    t = np.arange(0.0, 200.0, 0.5)
    load = np.zeros(t.size)
    load[20:], load[200:] = 1.0, 0.5
    data = prepare(Record(time=t, load=load, signal=load.copy(), source="steps"), initial="relaxed")
    i = load_steps(data)[1]
    plain = basis(data, Structure(1), {"tau[0]": 10.0})
    h = np.where(np.arange(t.size) > i, 1.0 + 1e-14, 1.0)    # the delayed input: no second step
    h[:20] = 0.0
    b = with_step_times(data, _with_input(plain, h), np.array([10.0]))
    assert b.names[-1] == "step_time[1][0]" and not b.columns[:, -1].any()


def test_a_parameter_the_record_does_not_see_is_held_in_every_fold():
    # a column of rounding size (a window's width at zero, on which the model does not depend)
    # is held in every fold whatever its rounding; the pseudo-inverse gave it a variance of zero
    # plus rounding, and a fold froze it or not as the rounding fell
    from creepcomp.fit.evidence import _undetermined

    rng = np.random.default_rng(7)
    jac = rng.normal(size=(400, 4))
    jac[:, 3] *= 1e6                  # (a linear column in other units does not set the scale)
    for size in (0.0, 1e-17, 1e-12):
        jac[:, 1] = size * rng.normal(size=400)
        for fold in range(5):
            keep = np.arange(400) % 5 != fold
            frozen = _undetermined(jac, keep, ["a", "b", "c"], {"a": 1.0, "b": 2.0, "c": 3.0})
            assert frozen == {"b": 2.0}


def test_a_time_offsets_width_at_zero_is_held_out_alike_with_either_lags():
    # the held-out prediction of a fit with a plain delay does not follow the rounding of the
    # lag loops: the width, on which the model does not depend, is held in every refit
    from creepcomp import synth
    from creepcomp.diagnose.effects import time_offset as to
    from creepcomp.fit.evidence import heldout
    from creepcomp.fit.solver import fit_structure
    from creepcomp.fit.structure import Applied, Structure

    spec = synth.Spec(hidden={"time_offset": {"delay": 0.43}}, beta=(0.03,), tau=(45.0,), gain=1.0,
                      rate=10.0, duration=300.0, program="random", noise=synth.NoiseSpec(white=5e-4),
                      seed=3)
    data = prepare(synth.generate(spec).record)
    structure = Structure(1, (Applied(to.EFFECT, (("window", True),)),))
    fit = fit_structure(data, structure, [{"tau[0]": 45.0, "c0[0]": 0.0, "time_offset.delay": 0.43,
                                           "time_offset.width": 0.0}])
    assert fit.values["time_offset.width"] <= to.NARROW * data.dt_median
    plain = heldout(data, fit)
    with lti.compiled_loops():
        compiled = heldout(data, fit)
    np.testing.assert_allclose(compiled.heldout.residual, plain.heldout.residual, rtol=0, atol=1e-9)


def test_a_prepared_records_sampling_is_its_own_frozen_copy():
    """A prepared record's times, and the :class:`~creepcomp.lti.Sampling` that keeps what the
    lags compute from them, are read-only copies: the record's array changed afterwards changes
    nothing kept; a copy of the record with another signal shares its sampling."""
    t = np.arange(0.0, 200.0, 0.5)
    load = np.where(t > 20.0, 1.0, 0.0)
    record = Record(t, load, load + 0.01 * np.exp(-t / 30.0))
    data = prepare(record)
    assert data.time is not record.time and record.time.flags.writeable
    assert not data.time.flags.writeable and not data.sampling.time.flags.writeable
    u = np.sin(t)
    before = lti.lag_states(data.sampling, u, [3.0])
    record.time[:] *= 2.0
    np.testing.assert_array_equal(lti.lag_states(data.sampling, u, [3.0]), before)
    assert data.with_signal(load).sampling is data.sampling


def test_a_delay_kept_for_a_fitting_problem_gives_the_basis_bit_for_bit():
    """The delayed load (and the samples it leaves free) kept by a fitting problem for the last
    few delays gives the same basis as one made afresh, and nobody can change what is kept."""
    from creepcomp import synth
    from creepcomp.diagnose.effects import get
    from creepcomp.fit.structure import Applied, Structure, basis

    spec = synth.Spec(hidden={"time_offset": {"delay": 0.35}}, beta=(0.03,), tau=(20.0,), gain=1.0,
                      rate=10.0, duration=300.0, program="staircase", noise=synth.NoiseSpec(white=5e-4), seed=3)
    data = prepare(synth.generate(spec).record)
    structure = Structure(1).with_effect(Applied(get("time_offset"), ()))
    cache = {}
    for delay in (0.35, 0.2, 0.35, 0.35):
        for tau in (5.0, 20.0):
            values = {"tau[0]": tau, "c0[0]": 0.0, "time_offset.delay": delay}
            kept, fresh = basis(data, structure, values, cache), basis(data, structure, values)
            np.testing.assert_array_equal(kept.columns, fresh.columns)
            np.testing.assert_array_equal(kept.straddling, fresh.straddling)
    assert not kept.load_seen.flags.writeable
    assert len(cache["staged"]) == 4             # two delays, each its load and its free samples
