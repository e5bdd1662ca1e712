"""Fits that only rank candidates (``screening`` of ``fit_structure``, a diagnosis's quick fits)
stop at the likelihood tolerance; every other fit, and the held-out refits, keep theirs."""

import numpy as np
import pytest

from creepcomp.diagnose import sensor
from creepcomp.fit import solver
from creepcomp.fit.data import prepare
from creepcomp.fit.solver import Problem, fit_structure, refined_ftol
from creepcomp.fit.starts import one_term_starts
from creepcomp.fit.structure import Structure
from creepcomp.io.records import Record
from creepcomp.lti import lag_states


def _data(samples: int = 1500):
    """A load step at 20 s, creep of 3 % at 40 s, 2 Hz, white noise of 0.01 %."""
    t = np.arange(samples) * 0.5
    load = np.where(t >= 20.0, 1.0, 0.0)
    y = load + 0.03 * lag_states(t, load, [40.0])[:, 0]
    return prepare(Record(t, load, y + np.random.default_rng(5).normal(0.0, 1e-4, t.size)),
                   initial="relaxed")


def _tolerances(monkeypatch) -> list:
    seen = []
    refine = Problem.refine

    def spy(self, x0, max_nfev=None, ftol=1e-8):
        seen.append(ftol)
        return refine(self, x0, max_nfev, ftol)

    monkeypatch.setattr(Problem, "refine", spy)
    return seen


def test_only_a_screening_fit_stops_at_the_likelihood_tolerance(monkeypatch):
    data = _data()
    seen = _tolerances(monkeypatch)
    plain = fit_structure(data, Structure(1), one_term_starts(data), n_refine=1)
    assert seen and set(seen) == {1e-8}
    seen.clear()
    quick = fit_structure(data, Structure(1), one_term_starts(data), n_refine=1, screening=True)
    assert set(seen) == {0.01 / data.n} and 0.01 / data.n > 1e-8
    # a stop that far from the optimum costs well under the 0.005 of log-likelihood it allows
    assert abs(quick.loglik - plain.loglik) < 0.005
    seen.clear()
    fit_structure(data, Structure(1), one_term_starts(data), n_refine=1)
    assert set(seen) == {1e-8}


def test_a_quick_fit_screens_every_fit_it_makes_and_a_full_fit_none(monkeypatch):
    """The mode is the fit's own argument: a quick fit (:class:`QuickFit`) passes it on to the
    fits an effect makes besides its own (restarts from a grid of time constants), a full fit
    to none."""
    from creepcomp.diagnose import effects

    data = _data()
    base = fit_structure(data, Structure(1), one_term_starts(data))
    flags = []
    fit = solver.fit_structure

    def spy(*args, **kwargs):
        flags.append(kwargs.get("screening", False))
        return fit(*args, **kwargs)

    monkeypatch.setattr(effects, "fit_structure", spy)
    effect = effects.get("rate_independent_hysteresis")
    effect.fit_on(data, base, refine="own", quick_fit=effects.QuickFit())
    assert len(flags) > 1 and all(flags)
    flags.clear()
    effect.fit_on(data, base, refine="all")
    assert flags and not any(flags)


def test_the_diagnosis_screens_its_quick_fits_only(monkeypatch):
    """The quick fits of every candidate run screening, the full fits and held-out refits do
    not (their held-out prediction follows where the fit stopped)."""
    data = _data()
    flags = []
    fit = solver.fit_structure

    def spy(*args, **kwargs):
        flags.append((kwargs.get("screening", False), kwargs.get("mask") is not None))
        return fit(*args, **kwargs)

    monkeypatch.setattr(solver, "fit_structure", spy)
    for module in ("creepcomp.diagnose.effects", "creepcomp.diagnose.sensor", "creepcomp.fit.evidence"):
        monkeypatch.setattr(f"{module}.fit_structure", spy, raising=False)
    sensor.diagnose(Record(data.time, data.load, data.signal), candidates=["time_offset"],
                    correction=False)
    assert any(screen for screen, _ in flags)
    assert any(not screen for screen, _ in flags)
    assert not any(screen and masked for screen, masked in flags)


def test_refined_ftol_is_the_likelihood_tolerance():
    data = _data()
    problem = Problem(data, Structure(1))
    assert refined_ftol(problem) == pytest.approx(0.01 / data.n)
    assert refined_ftol(problem, 1.0) == 1.0


def test_a_quick_fit_refines_its_best_start_only(monkeypatch):
    """A fit of a candidate, from its grid of starts, refines one start, quick or full, with
    the creep term started afresh too."""
    from creepcomp.diagnose import effects

    data = _data()
    base = fit_structure(data, Structure(1), one_term_starts(data))
    calls = []
    fit = solver.fit_structure

    def spy(*args, **kwargs):
        refined = []
        refine = Problem.refine
        with monkeypatch.context() as m:
            m.setattr(Problem, "refine", lambda self, *a, **k: refined.append(1) or refine(self, *a, **k))
            out = fit(*args, **kwargs)
        calls.append((len(args[2]), len(refined)))
        return out

    monkeypatch.setattr(effects, "fit_structure", spy)

    def refinements(name, refine):
        calls.clear()
        quick_fit = effects.QuickFit() if refine == "own" else None
        effects.get(name).fit_on(data, base, refine=refine, quick_fit=quick_fit)
        assert calls and all(starts > 1 for starts, _ in calls)
        return [refined for _, refined in calls]

    assert set(refinements("asymmetric_recovery", "own")) == {1}
    assert refinements("viscous_flow", "own") == [1, 1]
    assert refinements("time_offset", "own") == [1, 1]  # plain, fresh
    assert refinements("time_offset", "all") == [1, 1]


def test_candidates_that_raise_the_likelihood_too_little_are_not_refined(monkeypatch):
    """Of the best quick fits, only those whose own parameters raise the log-likelihood by
    :data:`~creepcomp.diagnose.sensor.QUICK_HINT` are refined with every parameter free; the
    others keep their quick fit, and their trial says BIC does not support them."""
    from creepcomp import data as bundled

    quick, refined = [], []
    quick_fit, refine = sensor._quick, sensor._refined

    def spy_quick(data, current, effect, step, trials, fresh=None):
        c = quick_fit(data, current, effect, step, trials, fresh)
        if c is not None:
            quick.append((step, effect.name, c.fit.loglik - current.loglik, c.delta_bic))
        return c

    def spy_refined(data, current, candidate):
        refined.append((candidate.effect.name, candidate.fit.loglik - current.loglik))
        return refine(data, current, candidate)

    monkeypatch.setattr(sensor, "_quick", spy_quick)
    monkeypatch.setattr(sensor, "_refined", spy_refined)
    result = sensor.diagnose(bundled.hidden_effect(), correction=False)
    assert result.cause == "asymmetric_recovery"
    assert refined and all(gain >= sensor.QUICK_HINT for _, gain in refined)
    skipped = []
    for step in {s for s, *_ in quick}:
        best = sorted((q for q in quick if q[0] == step), key=lambda q: q[3])[:sensor.REFINED]
        skipped += [q for q in best if q[2] < sensor.QUICK_HINT]
    assert skipped                        # (the rule was put to use)
    outcomes = {(t.step, t.effect): t.outcome for t in result.trials}
    assert all(outcomes[(s, name)] == "not supported (BIC)" for s, name, *_ in skipped)


def _cost_sequence(stall, costs):
    """Feeds ``stall`` a refinement's evaluations: ``costs`` of accepted steps as floats, a
    rejected trial as ``("rejected", cost)``; returns whether it stalled and where."""
    for k, c in enumerate(costs):
        rejected = isinstance(c, tuple)
        stall.seen(np.array([float(k)]), np.array([np.sqrt(c[1] if rejected else c)]))
        if not rejected:
            try:
                stall.check()
            except solver._Stalled:
                return True, k
    return False, None


def test_a_refinement_stalls_where_rejected_steps_alternate_with_steps_that_gain_nothing():
    n = 2000                      # (a gain of 0.005 in log-likelihood: a cost lower by 5e-6)
    tiny = 1.0 - 1e-7
    stalled, at = _cost_sequence(solver._Stall(n), [1.0, 0.5, ("rejected", 0.6), 0.5 * tiny,
                                                    ("rejected", 0.7), 0.5 * tiny ** 2, 0.4])
    assert stalled and at == 5
    stall = solver._Stall(n)
    _cost_sequence(stall, [1.0, 0.5, ("rejected", 0.6), 0.5 * tiny, ("rejected", 0.7), 0.5 * tiny ** 2])
    assert stall.best_x[0] == 5.0 and stall.best_cost == pytest.approx(0.5 * tiny ** 2)
    # accepted one after the other (a trust region growing again), tiny gains are no stall
    assert not _cost_sequence(solver._Stall(n), [1.0, 0.5, 0.5 * tiny, 0.5 * tiny ** 2, 0.5 * tiny ** 3])[0]
    # nor are rejections while the steps gain
    assert not _cost_sequence(solver._Stall(n), [1.0, ("rejected", 2.0), 0.9, ("rejected", 2.0), 0.8, 0.7])[0]


def test_a_stalled_refinement_ends_at_its_best_point_near_where_the_optimiser_would(monkeypatch):
    """A hysteresis on the record with a hidden effect: its refinement stalls (the modes of
    the play switch), and stops within a hundredth of log-likelihood of the optimiser's own
    end."""
    from creepcomp import data as bundled
    from creepcomp.diagnose import effects

    data = prepare(bundled.hidden_effect())
    base = fit_structure(data, Structure(1), one_term_starts(data))
    effect = effects.get("rate_independent_hysteresis")
    stalls = []
    check = solver._Stall.check

    def spy(self):
        try:
            check(self)
        except solver._Stalled:
            stalls.append(len(self.accepted))
            raise

    monkeypatch.setattr(solver._Stall, "check", spy)
    stopped = effect.fit_on(data, base, refine="all")
    assert stalls
    monkeypatch.setattr(solver, "STALL_LOGLIK", 0.0)
    stalls.clear()
    full = effect.fit_on(data, base, refine="all")
    assert not stalls
    assert abs(stopped.loglik - full.loglik) < 0.01
