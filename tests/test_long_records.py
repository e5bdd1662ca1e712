"""Long records reduced by blocks that grow after each load change, each sample weighted by
what it holds: a clean one-term record stays one term, a real second term is still found."""

import numpy as np
import pytest

from creepcomp.diagnose.sensor import diagnose
from creepcomp.fit.data import BLOCK_SAMPLES, BLOCK_VARIANCE, gaps, prepare
from creepcomp.fit.reduce import block_variance, reduce_record
from creepcomp.io.records import Record
from creepcomp.lti import lag_states


def _staircase(n_per_stretch, rate, terms, noise, levels=(1.0, 3.0, 0.0, 2.0), seed=1):
    t = np.arange(n_per_stretch * len(levels)) / rate
    load = np.repeat(levels, n_per_stretch)
    taus = [tau for _, tau in terms]
    creep = lag_states(t, load, taus) @ np.array([beta for beta, _ in terms])
    return Record(t, load, load + creep + np.random.default_rng(seed).normal(0.0, noise, t.size))


def test_growing_blocks_hold_every_sample_and_are_no_gaps():
    record = _staircase(10_000, 1.0, [(0.03, 45.0)], 1e-5)
    t = record.time.copy()
    t[25_000:] += 300.0                                   # a real gap in the sampling
    record = Record(t, record.load, record.signal)
    reduced, note = reduce_record(record, 1500)
    assert "grow with the time since" in note
    h = np.array(reduced.metadata[BLOCK_SAMPLES])
    assert h.sum() == len(record) and h.min() == 1 and h.max() > 20
    assert np.array_equal(reduced.metadata[BLOCK_VARIANCE], block_variance(h))
    data = prepare(reduced)
    assert data.dt_resolved == pytest.approx(1.0)
    after = np.flatnonzero(gaps(reduced.time, h))
    # the block that holds the gap (its centre lies in it) or the first after it
    assert len(after) == 1 and reduced.time[after[0] - 1] < 25_000 <= reduced.time[after[0]] <= 25_400


def test_a_long_one_term_record_is_diagnosed_none():
    """Blocks as long as the creep's time constant (27 s on 45 s, the equal blocks the
    reduction made before) invent a jump, nonlinear creep and a further term; blocks that
    grow after each step, weighted, leave one term at the noise floor."""
    record = _staircase(10_000, 1.0, [(0.03, 45.0)], 1e-5)
    d = diagnose(record, max_samples=1500)
    assert "grow with the time since" in d.reduced
    assert d.cause == "none"
    assert d.baseline.taus[0] == pytest.approx(45.0, rel=1e-3)
    assert d.baseline.betas[0] == pytest.approx(0.03, rel=1e-3)
    assert d.floor.rms == pytest.approx(1e-5, rel=0.2)    # the full record's noise
    assert d.baseline.residual_rms == pytest.approx(1e-5, rel=0.2)


@pytest.mark.slow
def test_a_real_fast_second_term_of_a_long_record_is_found():
    record = _staircase(10_000, 1.0, [(0.03, 45.0), (0.01, 4.0)], 1e-5)
    d = diagnose(record, max_samples=1500)
    assert d.cause == "extra_retardation"
    assert sorted(d.extended.taus) == pytest.approx([4.0, 45.0], rel=0.01)


@pytest.mark.slow
def test_a_ten_million_sample_one_term_record_stays_one_term():
    from creepcomp.fit.prony import fit_prony

    record = _staircase(2_500_000, 10.0, [(0.03, 45.0)], 1e-4)
    assert diagnose(record).cause == "none"
    model = fit_prony(prepare(reduce_record(record)[0]), max_terms=3).model()
    assert model.n_terms == 1 and model.tau[0] == pytest.approx(45.0, rel=1e-3)


def test_a_jittered_record_reduces_with_its_times_in_order():
    """Irregular sampling: each block's time is its mean, so blocks stay in order (the
    parabola-centre weights, negative at a block's ends, put jittered times out of order)."""
    from creepcomp import synth
    from creepcomp.synth.sensor import random_spec

    spec = random_spec("rate_independent_hysteresis", 9001, rate=(50.0, 50.0), duration=(2000.0, 2000.0))
    record = synth.generate(spec).record
    assert np.ptp(np.diff(record.time)) > 0.1 * np.median(np.diff(record.time))     # jittered
    reduced, _ = reduce_record(record, 6000)
    assert np.all(np.diff(reduced.time) > 0)
    assert reduced.time[0] == record.time[0] and reduced.time[-1] == record.time[-1]
