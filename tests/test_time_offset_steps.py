"""A time offset on a record of load steps: the samples read inside a step's interval are left
free, and the offset is then named alone."""

import math

import numpy as np
import pytest

from creepcomp import synth
from creepcomp.diagnose.effects import time_offset as to
from creepcomp.diagnose.sensor import diagnose
from creepcomp.fit.data import abrupt_intervals, load_steps, prepare
from creepcomp.fit.reduce import reduce_record
from creepcomp.fit.solver import Problem, _counted_linear, fit_structure
from creepcomp.fit.structure import Applied, Structure
from creepcomp.io.records import Record


def _record(load, signal=None, dt=1.0):
    t = np.arange(len(load)) * dt
    return prepare(Record(time=t, load=np.asarray(load, float),
                          signal=np.asarray(load, float) if signal is None else signal, source="t"))


def test_abrupt_intervals_are_the_steps_and_a_step_split_over_two_intervals():
    data = _record([0, 0, 0, 1, 1, 1, 1, 0.7, 0.2, 0.2, 0.2, 0.2])
    assert list(load_steps(data)) == [2]
    # the step from 1 to 0.2 lies inside a block: its mean (0.7) is between the levels
    assert list(abrupt_intervals(data)) == [2, 6, 7]
    ramp = _record(np.linspace(0, 1, 12))
    assert len(abrupt_intervals(ramp)) == 0


def test_straddling_samples_read_inside_a_step_interval():
    data = _record([0.0] * 10 + [1.0] * 10)                # the step within interval 9 (9 s to 10 s)
    applied = Applied(to.EFFECT, ())
    # read 2.4 s early: sample 12 reads at 9.6 s, inside the step's interval
    assert list(to.EFFECT.straddling(data, {"delay": 2.4, "width": 0.0}, applied)) == [12]
    assert list(to.EFFECT.straddling(data, {"delay": -1.5, "width": 0.0}, applied)) == [8]
    # a whole number of samples reads on samples: none is free
    assert len(to.EFFECT.straddling(data, {"delay": 2.0, "width": 0.0}, applied)) == 0
    # a delay of next to nothing reads where the load is known
    assert len(to.EFFECT.straddling(data, {"delay": 0.05, "width": 0.0}, applied)) == 0
    # a window averages the unknown step time over its width
    assert len(to.EFFECT.straddling(data, {"delay": 2.4, "width": 3.0}, applied)) == 0


def _offset_record(program, seed, delay=0.43):
    spec = synth.Spec(hidden={"time_offset": {"delay": delay}}, beta=(0.03,), tau=(45.0,), gain=1.0,
                      rate=10.0, duration=600.0, program=program, noise=synth.NoiseSpec(white=5e-4),
                      seed=seed)
    return synth.generate(spec).record


def test_the_fit_leaves_straddling_samples_free_and_pays_for_each():
    data = prepare(_offset_record("staircase", 1))
    structure = Structure(1, (Applied(to.EFFECT, (("window", True),)),))
    fit = fit_structure(data, structure, [{"tau[0]": 45.0, "c0[0]": 0.0, "time_offset.delay": 0.43,
                                           "time_offset.width": 0.0}])
    problem = Problem(data, structure)
    x = problem.start_vector({p.name: fit.values[p.name] for p in fit.params})
    b, _, r = problem.project(x)
    free = problem.straddled(b)
    assert len(free) >= 3
    assert np.all(fit.residual[free] == 0.0) and np.all(r[free] == 0.0)
    # the search sees each free sample's price: the noise variance times log n
    search = problem.residual(x) * problem.scale
    kept = np.delete(r, free)
    price = math.sqrt(math.log(len(r)) * float(kept @ kept) / len(kept))
    assert search[free] == pytest.approx(price, rel=1e-9)
    # counted by the criterion: one parameter each; the step-time columns, empty where the
    # delayed creep input does not step (all of them here), are none
    empty = {n for n, col in zip(b.names, b.columns.T) if not col.any()}
    assert empty == {n for n in b.names if n.startswith("step_time[")}
    assert fit.extras["linear"] == _counted_linear(b.names, {}, empty) + len(free) == 3 + len(free)
    assert fit.residual_rms < 1.5 * 5e-4


@pytest.mark.parametrize("program, seed", [("staircase", 1), ("step", 2)])
def test_a_time_offset_on_load_steps_is_named_alone(program, seed):
    """Named alone, within a sample step (0.1 s) of the truth, and fitting the record as well
    as the true delay does: with the samples read across a step left free, the record tells
    the delay only to the sample interval the step is read in (on the one-step record, 0.37 s
    and 0.42 s fit with costs equal to 1e-13; which one a fit reaches follows rounding)."""
    record = _offset_record(program, seed)
    result = diagnose(record, correction=False)
    assert [f.effect for f in result.findings] == ["time_offset"]
    finding = result.findings[0]
    assert abs(finding.parameters["delay"] - 0.43) < 0.1
    fit = finding.fit
    data = prepare(reduce_record(record, 6_000)[0])
    truth = dict({p.name: fit.values[p.name] for p in fit.params}, **{"time_offset.delay": 0.43})
    at_truth = fit_structure(data, fit.structure, [truth], frozen={"time_offset.delay": 0.43}, with_cov=False)
    sse = float(fit.residual @ fit.residual)
    assert float(at_truth.residual @ at_truth.residual) == pytest.approx(sse, rel=1e-6)


def test_a_held_out_straddling_sample_is_predicted_by_the_template():
    data = prepare(_offset_record("staircase", 1))
    structure = Structure(1, (Applied(to.EFFECT, (("window", True),)),))
    values = {"tau[0]": 45.0, "c0[0]": 0.0, "time_offset.delay": 0.43, "time_offset.width": 0.0}
    whole = Problem(data, structure)
    b = whole.basis(whole.start_vector(values))
    free = b.straddling
    keep = np.ones(data.n, bool)
    keep[free[0]] = False                       # the first straddling sample held out
    part = Problem(data, structure, keep)
    x = part.start_vector(values)
    _, residual = part.full_residual(x)
    assert residual[free[0]] != 0.0             # predicted from the load, not fitted
    assert np.all(residual[free[1:]] == 0.0)    # the fitted ones each by their own parameter
    assert len(part.straddled(part.basis(x))) == len(free) - 1


def test_a_step_the_delayed_creep_input_does_not_take_has_an_empty_step_time_column():
    """The step-time columns sit at the load's step intervals: where the delayed creep input
    does not step, its change there is rounding and the column is exactly zero (not a column
    of rounding that a solver would fit)."""
    spec = synth.Spec(hidden={"time_offset": {"delay": 0.43}}, beta=(0.03,), tau=(45.0,), gain=1.0,
                      rate=10.0, duration=1800.0, program="staircase", noise=synth.NoiseSpec(white=5e-4),
                      seed=1)
    reduced, _ = reduce_record(synth.generate(spec).record, 3000)    # (block means: loads with rounding)
    data = prepare(reduced)
    structure = Structure(1, (Applied(to.EFFECT, (("window", True),)),))
    problem = Problem(data, structure)
    delayed = problem.basis(problem.start_vector({"tau[0]": 45.0, "time_offset.delay": 0.43,
                                                  "time_offset.width": 0.0}))
    on_time = problem.basis(problem.start_vector({"tau[0]": 45.0, "time_offset.delay": 0.0,
                                                  "time_offset.width": 0.0}))
    steps = [i for i, n in enumerate(delayed.names) if n.startswith("step_time[")]
    assert steps
    assert np.all(delayed.columns[:, steps] == 0.0)
    assert np.all(np.any(on_time.columns[:, steps] != 0.0, axis=0))


def test_the_fresh_term_search_over_the_best_offsets_finds_what_the_whole_cross_does(monkeypatch):
    """The time offset's creep term started afresh crosses the whole grid of time constants
    with only the best few of its 21 offset starts (ranked at a few time constants): it lands
    where crossing all of them does."""
    import creepcomp.diagnose.effects as effects
    from creepcomp.fit.starts import one_term_starts

    data = prepare(_offset_record("staircase", 2, delay=0.43))
    base = fit_structure(data, Structure(1), one_term_starts(data))
    counted = []
    real_cost = Problem.cost
    monkeypatch.setattr(Problem, "cost", lambda self, v: counted.append(1) or real_cost(self, v))

    def fresh():
        counted.clear()
        fit = to.EFFECT.fit_on(data, base, refine="own", quick_fit=effects.QuickFit())
        return fit, len(counted)

    few, ranked = fresh()
    monkeypatch.setattr(effects, "FRESH_OWN_STARTS", 100)
    whole, unranked = fresh()
    assert ranked > 0 and unranked == 0                 # the offsets were ranked first
    assert few.bic == pytest.approx(whole.bic, abs=0.5)
    assert few.values["time_offset.delay"] == pytest.approx(whole.values["time_offset.delay"], abs=0.01)


def test_held_out_refits_keep_a_delay_whose_interval_the_samples_do_not_resolve(monkeypatch):
    """Where the samples a delay reads across a step are left free, the fitted samples do not
    tell where in its sample interval the delay lies: every held-out refit keeps the fit's
    delay (a refit on part of the record would follow rounding out of the interval); a delay
    that leaves no sample free is refitted as any parameter."""
    from creepcomp.fit import evidence

    data = prepare(_offset_record("step", 2))
    structure = Structure(1, (Applied(to.EFFECT, (("window", True),)),))
    frozen = []
    real = evidence.fit_structure

    def spy(*args, **kwargs):
        if kwargs.get("mask") is not None:
            frozen.append(kwargs.get("frozen") or {})
        return real(*args, **kwargs)

    monkeypatch.setattr(evidence, "fit_structure", spy)
    fit = fit_structure(data, structure, [{"tau[0]": 45.0, "c0[0]": 0.0, "time_offset.delay": 0.43,
                                           "time_offset.width": 0.0}], refine=False)
    evidence.heldout(data, fit)
    assert len(frozen) == evidence.FOLDS
    assert all(f.get("time_offset.delay") == fit.values["time_offset.delay"] for f in frozen)
    applied = Applied(to.EFFECT, (("window", True),))
    assert to.EFFECT.held_in_refits(data, {"delay": 0.43, "width": 0.0}, applied) == ("delay",)
    assert to.EFFECT.held_in_refits(data, {"delay": 0.005, "width": 0.0}, applied) == ()
    assert to.EFFECT.held_in_refits(data, {"delay": 0.43, "width": 0.3}, applied) == ()


def test_a_load_that_wanders_by_converter_counts_has_only_its_real_steps():
    """A measured load read by a converter holds a count between most samples and moves by one
    or two now and then: such a move is ten times its held neighbours, but it is the
    converter's noise, not a step (each step is a nuisance column per creep term of a fit)."""
    rng = np.random.default_rng(4)
    level = np.repeat([0.0, 1.0, 2.0, 0.5], 500)
    load = np.round((level + rng.normal(0.0, 0.006, level.size)) / 0.01) * 0.01
    moves = np.abs(np.diff(load))
    lone = (moves[1:-1] > 0) & (moves[:-2] == 0) & (moves[2:] == 0)
    assert np.count_nonzero(lone) >= 50                  # one-count moves between held samples
    data = _record(load)
    assert list(load_steps(data)) == [499, 999, 1499]
    # (a step with a same-way count beside it may be a step split over two intervals)
    assert set(abrupt_intervals(data)) <= {499, 500, 999, 1000, 1499, 1500}
