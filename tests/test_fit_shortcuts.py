"""The order search's shortcuts choose as the full search does: a term the evidence rejects
refined only loosely, the free start's trial left out when it cannot win, and a text record
parsed while the fit's modules are imported."""

from dataclasses import replace

import numpy as np
import pytest

from creepcomp.errors import InputError
from creepcomp.fit import prony
from creepcomp.fit.data import prepare
from creepcomp.fit.prony import fit_prony, fit_terms
from creepcomp.fit.solver import refined_ftol
from creepcomp.fit.structure import Structure
from creepcomp.io.records import Record
from creepcomp.lti import lag_states


def _record(n_terms: int, samples: int = 12000, seed: int = 3) -> Record:
    """A load step at 20 s, creep terms of 3 %, 2 % at 15 s, 200 s, 5 Hz, white noise of
    0.01 % (long enough for the coarse search: more than four samples per coarse one)."""
    t = np.arange(samples) * 0.2
    load = np.where(t >= 20.0, 1.0, 0.0)
    betas, taus = [0.03, 0.02][:n_terms], [15.0, 200.0][:n_terms]
    y = load + lag_states(t, load, taus) @ np.array(betas)
    return Record(t, load, y + np.random.default_rng(seed).normal(0.0, 1e-4, t.size))


def _same_result(a, b) -> None:
    assert [s.n_terms for s in a.steps] == [s.n_terms for s in b.steps]
    assert a.chosen == b.chosen and a.data.initial == b.data.initial
    assert a.fit.values == b.fit.values
    np.testing.assert_array_equal(a.fit.cov, b.fit.cov)


def test_the_two_stage_search_is_fit_terms_search():
    """The coarse search kept for a loose first refinement, refined fully, is fit_terms' fit."""
    data = prepare(_record(2), initial="relaxed")
    one = fit_terms(data, 1, noise=prony._WHITE, with_cov=False, coarse_ftol=prony.ORDER_COARSE_FTOL)
    structure = Structure(2)
    spectrum = prony.spectrum_of(data)
    starts = prony._term_starts(data, structure, one, None, spectrum)
    searched = prony._coarse_search(data, structure, starts)
    assert searched is not None
    problem = searched.problem
    staged = prony._finish(problem, problem.refine(searched.x, None, refined_ftol(problem)),
                           prony._WHITE, False)
    direct = fit_terms(data, 2, one, prony._WHITE, with_cov=False, spectrum=spectrum,
                       coarse_ftol=prony.ORDER_COARSE_FTOL)
    assert staged.values == direct.values and staged.bic == direct.bic


@pytest.mark.parametrize("initial", ["relaxed", "free"])
def test_a_loosely_rejected_term_leaves_the_choice_and_the_model(monkeypatch, initial):
    data = prepare(_record(2), initial=initial)
    calls = []
    loose = prony._rejected_loosely
    monkeypatch.setattr(prony, "_rejected_loosely", lambda *a: calls.append(loose(*a)) or calls[-1])
    quick = fit_prony(data)
    assert calls and calls[-1] is not None              # the third term was rejected loosely
    assert quick.fit.structure.n_terms == 2 and len(quick.steps) == 3
    rejected = quick.steps[-1]
    assert rejected.fit.heldout is not None and not rejected.evidence.supported
    monkeypatch.setattr(prony, "_coarse_unpromising", lambda *a: False)
    _same_result(quick, fit_prony(data))


def test_a_loosely_rejected_term_is_held_out_when_read_as_it_would_have_been(monkeypatch):
    """The choice does not hold out the loosely rejected term; reading its step does, with the
    held-out prediction and evidence the fit would have had."""
    data = prepare(_record(2), initial="relaxed")
    held = []
    real = prony.heldout
    monkeypatch.setattr(prony, "heldout", lambda *a, **k: held.append(1) or real(*a, **k))
    result = fit_prony(data)
    during = len(held)
    rejected, previous = result.steps[-1], result.steps[-2]
    assert not rejected.evidence.supported                  # (read: held out now)
    assert len(held) == during + 1 and during == len(result.steps) - 1
    bare = replace(rejected.fit, heldout=None)
    again = real(data, bare, linearised=True)
    np.testing.assert_array_equal(rejected.fit.heldout.residual, again.heldout.residual)
    assert rejected.evidence == prony.compare(previous.fit, again)
    assert np.isfinite(rejected.evidence.heldout_z)
    rejected.fit
    assert len(held) == during + 1                          # (once)


def test_the_free_start_trial_is_left_out_only_where_it_cannot_win(monkeypatch):
    data = prepare(_record(2))
    asked = []
    may_win = prony._free_start_may_win
    monkeypatch.setattr(prony, "_free_start_may_win", lambda *a: asked.append(may_win(*a)) or asked[-1])
    quick = fit_prony(data)
    assert asked == [False] and quick.data.initial == "settled"     # (a record that starts at rest)
    monkeypatch.setattr(prony, "_free_start_may_win", lambda *a: True)
    _same_result(quick, fit_prony(data))


def test_a_record_that_starts_creeping_still_gets_the_free_trial(monkeypatch):
    t = np.arange(15000) * 0.2
    load = np.where((t >= 20.0) & (t < 2000.0), 1.0, 0.0)
    y = load + lag_states(t, load, [15.0, 200.0]) @ np.array([0.03, 0.02])
    y = y + np.random.default_rng(3).normal(0.0, 1e-4, t.size)
    cut = 1500                                          # (starts 280 s into the creep)
    data = prepare(Record(t[cut:], load[cut:], y[cut:]))
    asked = []
    may_win = prony._free_start_may_win
    monkeypatch.setattr(prony, "_free_start_may_win", lambda *a: asked.append(may_win(*a)) or asked[-1])
    result = fit_prony(data)
    assert asked == [True] and result.data.initial == "free"


def test_a_text_record_read_while_importing_equals_the_plain_reading(tmp_path):
    from creepcomp.cli.fit import load_reduced
    from creepcomp.fit.reduce import read_reduced

    record = _record(1, samples=3000)
    path = tmp_path / "r.csv"
    np.savetxt(path, np.column_stack([record.time, record.load, record.signal]), delimiter=",",
               header="time,load,signal", comments="")
    [(got, _)] = load_reduced(path, (1000,), None, None, "error", quiet=True)
    [(want, _)] = read_reduced(path, (1000,))
    for name in ("time", "load", "signal"):
        np.testing.assert_array_equal(getattr(got, name), getattr(want, name))
    bad = tmp_path / "bad.csv"
    bad.write_text("time,load,signal\n0,1,2\n1,1,x\n")
    with pytest.raises(InputError, match="bad.csv"):
        load_reduced(bad, (1000,), None, None, "error", quiet=True)


def test_a_record_read_in_pieces_is_read_and_reduced_while_importing(tmp_path, monkeypatch):
    import threading

    from creepcomp.cli.fit import load_reduced
    from creepcomp.fit import reduce as reduction
    from creepcomp.io import records

    record = _record(2, samples=3000)
    path = tmp_path / "r.csv"
    np.savetxt(path, np.column_stack([record.time, record.load, record.signal]), delimiter=",",
               header="time,load,signal", comments="")
    [(want, want_note)] = reduction.reduce_all(records.read_record(path), (1000,))
    monkeypatch.setattr(records, "WHOLE_PIECES", 0)             # (any file: in pieces)
    readers = []
    stream = reduction.open_record_stream
    monkeypatch.setattr(reduction, "open_record_stream",
                        lambda *a, **kw: readers.append(threading.current_thread()) or stream(*a, **kw))
    [(got, note)] = load_reduced(path, (1000,), None, None, "error", quiet=True)
    assert readers and threading.main_thread() not in readers
    assert note == want_note and got.metadata == want.metadata
    for name in ("time", "load", "signal"):
        np.testing.assert_allclose(getattr(got, name), getattr(want, name), rtol=1e-13, atol=1e-13)
