"""Candidates fitted side by side in worker processes: the same results as in one process."""

import json
import multiprocessing
import os
import pickle
import sys
import time

import numpy as np
import pytest

from creepcomp import data
from creepcomp.diagnose import effects
from creepcomp.diagnose.sensor import diagnose
from creepcomp.diagnose.workers import Workers, _dumps, _loads
from creepcomp.fit.data import prepare
from creepcomp.fit.prony import fit_terms

linux = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="worker processes fork on Linux only")


def _where(shared, common, item):
    time.sleep(0.05)
    return item * common + shared, os.getpid()


def _fails_at(shared, common, item):
    if item == common:
        raise ValueError(f"item {item} fails")
    return item


@linux
def test_items_run_in_two_processes_and_come_back_in_order():
    with Workers(2, 1000) as workers:
        first = workers.map(_where, 2, range(5))    # (the worker starts: it may take none)
        out = workers.map(_where, 3, range(8), keys=[f"k{i % 3}" for i in range(8)])
    assert [v for v, _ in first] == [1000 + 2 * i for i in range(5)]
    assert [v for v, _ in out] == [1000 + 3 * i for i in range(8)]
    assert len({pid for _, pid in out}) == 2


def _sleeps(shared, common, item):
    time.sleep(item)
    return os.getpid()


@linux
def test_a_kind_of_task_is_known_by_the_longest_of_its_last_runs(monkeypatch):
    # a task once long is handed out first (started last, it would leave one process waiting
    # for all of it); the split of a test reads the last run
    from creepcomp.diagnose import workers as module
    from creepcomp.diagnose.workers import last_seconds

    monkeypatch.setattr(module, "_TASK_SECONDS", {})
    with Workers(2, 0) as workers:
        workers.map(_sleeps, None, [0.2, 0.01, 0.01], ["slow", "a", "b"])
        for _ in range(module._TASKS_KEPT - 1):
            workers.map(_sleeps, None, [0.01, 0.06, 0.06], ["slow", "a", "b"])
        assert last_seconds(_sleeps, "slow") < 0.05
        kept = module._TASK_SECONDS[("_sleeps", "slow")]
        assert len(kept) == module._TASKS_KEPT and max(kept) >= 0.2
        # handed out first: the kind known as longest, though short in its last runs
        orders = []
        dumps = module._dumps
        monkeypatch.setattr(module, "_dumps", lambda value, shared=None: orders.append(value[3]) or dumps(value, shared))
        workers.map(_sleeps, None, [0.06, 0.01, 0.06], ["a", "slow", "b"])
        assert orders[-1][0] == 1
        workers.map(_sleeps, None, [0.06, 0.01, 0.06], ["a", "slow", "b"])
        assert max(module._TASK_SECONDS[("_sleeps", "slow")]) < 0.05     # (the long run aged out)
        workers.map(_sleeps, None, [0.06, 0.01, 0.06], ["a", "slow", "b"])
        assert orders[-1][0] != 1


@linux
def test_forgotten_task_times_leave_the_items_in_the_order_given(monkeypatch):
    # a process's first diagnosis (modules and compiled loops loaded) times its tasks long:
    # forgotten, they order nothing, and unknown kinds run in the order given
    from creepcomp.diagnose import workers as module
    from creepcomp.diagnose.workers import forget_task_times, last_seconds

    monkeypatch.setattr(module, "_TASK_SECONDS", {})
    orders = []
    dumps = module._dumps
    with Workers(2, 0) as workers:
        workers.map(_sleeps, None, [0.01, 0.1], ["a", "b"])
        # (the order a call sends; the workers, forked already, answer as before)
        monkeypatch.setattr(module, "_dumps", lambda value, shared=None: orders.append(value[3]) or dumps(value, shared))
        workers.map(_sleeps, None, [0.01, 0.01], ["a", "b"])
        assert orders[-1] == [1, 0] and last_seconds(_sleeps, "b") < 0.05
        forget_task_times()
        assert last_seconds(_sleeps, "b") is None
        workers.map(_sleeps, None, [0.01, 0.01], ["a", "b"])
        assert orders[-1] == [0, 1]


@linux
def test_released_workers_end_while_this_process_goes_on_and_a_later_call_forks_anew():
    with Workers(2, 0) as workers:
        first = workers.map(_where, 1, range(6))
        ended = list(workers._processes)
        workers.release()
        again = workers.map(_where, 1, range(6))
        assert {p.pid for p in workers._processes}.isdisjoint({p.pid for p in ended})
    for p in ended:
        assert not p.is_alive()
    assert [v for v, _ in again] == [v for v, _ in first] == list(range(6))


def test_one_job_runs_every_item_here():
    with Workers(1, 0) as workers:
        out = workers.map(_where, 1, range(3))
    assert {pid for _, pid in out} == {os.getpid()}


def test_a_process_that_may_not_have_children_runs_every_item_itself(monkeypatch):
    class Daemon:
        daemon = True

    monkeypatch.setattr(multiprocessing, "current_process", lambda: Daemon())
    workers = Workers(2, 0)
    assert not workers.parallel and workers.width == 1
    assert {pid for _, pid in workers.map(_where, 1, range(3))} == {os.getpid()}


@linux
def test_a_failure_in_either_process_is_raised_and_the_next_call_gets_its_own_answers():
    with Workers(2, 0) as workers:
        for failing in (0, 9):       # (the first item: this process's; the last: a worker's)
            with pytest.raises((ValueError, RuntimeError), match=f"item {failing} fails"):
                workers.map(_fails_at, failing, range(10))
            assert workers.map(_fails_at, -1, range(6)) == list(range(6))


def _ends_if_not_in(shared, common, item):
    if os.getpid() != common:
        os._exit(1)
    time.sleep(0.05)
    return item


@linux
def test_a_worker_process_that_ends_without_answering_is_an_error_not_a_wait():
    workers = Workers(2, 0)
    workers.map(_where, 0, range(4))
    with pytest.raises(RuntimeError, match="ended without answering"):
        workers.map(_ends_if_not_in, os.getpid(), range(6))
    workers.close()


@linux
def test_workers_leave_sigterm_to_this_process_and_an_interrupted_close_kills_them():
    # a service manager's SIGTERM reaches the whole group: the workers ignore it (a worker gone
    # at once would fail the call before this process takes its own); the interpreter's exit
    # ends what is left with SIGTERM, so an interrupted close kills them instead
    import signal

    workers = Workers(2, 0)
    workers.map(_where, 0, range(4))
    process = workers._processes[0]
    os.kill(process.pid, signal.SIGTERM)
    assert [v for v, _ in workers.map(_where, 1, range(6))] == list(range(6))
    assert process.is_alive()
    with workers._counter.get_lock():      # the worker busy for 30 s
        workers._counter.value = 0
    workers._connections[0].send_bytes(_dumps((_sleeps, None, [30.0], [0])))
    joins = []
    join = process.join

    def interrupted_once(timeout=None):
        joins.append(timeout)
        if len(joins) == 1:
            raise KeyboardInterrupt
        return join(timeout)

    process.join = interrupted_once
    start = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        workers.close()
    assert process.exitcode == -signal.SIGKILL and time.monotonic() - start < 10
    assert workers._ending == []


def test_a_registered_effect_is_unpickled_as_the_registrys_own():
    for effect in effects.REGISTRY.values():
        assert pickle.loads(pickle.dumps(effect)) is effect


def test_a_fit_travels_with_its_covariance_deferred_and_the_same_once_read():
    record = data.hidden_effect()
    fit = fit_terms(prepare(record), 1)
    kept = fit.covariance._inputs[0].cache
    message = _dumps(fit)
    copy = pickle.loads(message)
    assert copy.covariance._value is None and copy.covariance._inputs is not None
    # the kept projection (the basis columns) stays here: it is computed again if read there
    assert kept and fit.covariance._inputs[0].cache is kept and not copy.covariance._inputs[0].cache
    assert len(message) < len(pickle.dumps(kept))
    np.testing.assert_array_equal(copy.cov, fit.cov)


def test_the_record_travels_as_a_reference_to_each_processs_own():
    import copy

    fitted = prepare(data.hidden_effect())
    fit = fit_terms(fitted, 1)
    message = _dumps(fit, fitted)
    assert len(message) < len(_dumps(fit)) - len(_dumps(fitted)) // 2
    theirs = copy.deepcopy(fitted)           # (what a forked process holds)
    back = _loads(message, theirs)
    assert back.covariance._inputs[0].data is theirs
    np.testing.assert_array_equal(back.cov, fit.cov)
    with pytest.raises(pickle.UnpicklingError):
        _loads(message, None)


def _plain(result) -> str:
    out = result.to_dict()
    out.pop("seconds")
    return json.dumps(out, sort_keys=True, default=float)


@linux
def test_a_diagnosis_in_two_processes_is_the_one_in_one_bit_for_bit():
    record = data.hidden_effect()
    assert _plain(diagnose(record, jobs=2)) == _plain(diagnose(record, jobs=1))


@pytest.mark.parametrize("jobs", [0, -2, 1.5, None, "2"])
def test_a_count_of_processes_below_one_or_not_whole_is_refused(jobs):
    from creepcomp.errors import InputError

    with pytest.raises(InputError, match="jobs"):
        diagnose(data.hidden_effect(), jobs=jobs)


@linux
def test_the_command_gives_the_same_diagnosis_with_one_process_and_with_two(run_cli, tmp_path):
    from creepcomp.io.records import write_record

    path = tmp_path / "r.csv"
    write_record(path, data.hidden_effect())
    runs = []
    for jobs in ("1", "2"):
        status, out, err = run_cli("diagnose", path, "--jobs", jobs, "--json")
        assert status == 0, err
        result = json.loads(out)
        result.pop("seconds")
        runs.append(result)
    assert runs[0] == runs[1]
    status, out, err = run_cli("diagnose", path, "--jobs", "0")
    assert status == 2 and "--jobs" in err and "Traceback" not in err


def test_a_diagnosis_fits_the_catch_all_once_on_each_model(monkeypatch):
    # the catch-all runs beside a step's first held-out tests (in either process): the step,
    # or the verdict after it, reads it from there rather than fitting it again
    from creepcomp.diagnose import sensor

    fitted_on = []
    real = sensor._generic

    def counted(data, current):
        fitted_on.append((current.bic, tuple(sorted(current.values.items()))))
        return real(data, current)

    monkeypatch.setattr(sensor, "_generic", counted)
    result = diagnose(data.hidden_effect(), jobs=1)      # (counted here: one process)
    steps = {t.step for t in result.trials}
    assert len(fitted_on) == len(set(fitted_on)) and len(fitted_on) >= len(steps)


def test_refining_ahead_of_the_ranks_changes_no_candidate(monkeypatch):
    # with two processes, a quick fit that raises BIC a little is refined in its own task,
    # before the ranks are known; kept only where the ranks ask for it, it leaves the
    # diagnosis as refining after them (here in one process, made to refine ahead)
    from creepcomp import synth
    from creepcomp.diagnose import sensor

    spec = synth.Spec(beta=(0.03,), tau=(45.0,), gain=1.0, rate=5.0, duration=600.0, program="staircase",
                      noise=synth.NoiseSpec(white=5e-4), seed=31)
    record = synth.generate(spec).record
    ahead_of_rank = []
    refined_ahead = sensor._refined_ahead

    def counted(current, candidate, ahead):
        out = refined_ahead(current, candidate, ahead)
        ahead_of_rank.append(out and candidate.delta_bic >= 0)
        return out

    monkeypatch.setattr(sensor, "_refined_ahead", counted)
    after = _plain(diagnose(record, jobs=1, correction=False))
    assert not any(ahead_of_rank)             # (one process: refined after the ranks)
    monkeypatch.setattr(sensor, "_refined_ahead", lambda current, candidate, ahead: counted(current, candidate, True))
    assert _plain(diagnose(record, jobs=1, correction=False)) == after
    assert any(ahead_of_rank)                 # (the rule was put to use)


def test_held_out_refits_side_by_side_are_those_made_one_after_the_other():
    import pickle

    from creepcomp.fit.evidence import FoldRefits, fold_refit, heldout

    fitted = prepare(data.hidden_effect())
    fit = fit_terms(fitted, 1)
    calls = []

    def refit_all(keeps):
        calls.append(len(keeps))
        refits = FoldRefits(fit)
        return [fold_refit(fitted, refits if i % 2 else pickle.loads(pickle.dumps(refits)), keep)
                for i, keep in enumerate(keeps[::-1])][::-1]

    side = heldout(fitted, fit, refit_all=refit_all)
    assert calls == [5]
    np.testing.assert_array_equal(side.heldout.residual, heldout(fitted, fit).heldout.residual)


@linux
def test_a_test_split_in_parts_is_the_test_in_one_task(monkeypatch):
    # a lone candidate's test beside the catch-all runs in parts (refit, held-out refits side
    # by side, evidence) when it is the longer: the same diagnosis, bit for bit
    from creepcomp.diagnose import sensor

    record = data.hidden_effect()
    whole = _plain(diagnose(record, jobs=1))
    split = []
    monkeypatch.setattr(sensor, "_test_is_longer", lambda name, beside: split.append(name) or True)
    assert _plain(diagnose(record, jobs=2)) == whole
    assert split


def test_the_verdict_run_beside_a_last_refinement_is_the_one_run_after_it(monkeypatch):
    # a step whose only refinements left cannot make a candidate testable likely ends: the
    # verdict's parts run beside them, and are used when it does (else computed again)
    from creepcomp.diagnose import sensor

    record = data.hidden_effect()
    used = []
    verdict = sensor._verdict

    def spy(data_, search, *args):
        (model, baseline), _ = search.verdict_on
        used.append(model is search.current and baseline is search.base)
        return verdict(data_, search, *args)

    monkeypatch.setattr(sensor, "_verdict", spy)
    ahead = _plain(diagnose(record, jobs=1))
    assert used == [True]
    screen = sensor._screen
    monkeypatch.setattr(sensor, "_screen", lambda *args: screen(*args[:6]))
    assert _plain(diagnose(record, jobs=1)) == ahead
    assert used == [True, False]


def test_a_polish_beside_the_first_tests_leaves_the_diagnosis_and_refits_no_candidate_twice(monkeypatch):
    # with processes side by side, the current model's refit from the best candidate (the
    # polish) runs beside the step's first held-out tests; the record's polish is kept, so
    # the candidates are chosen again against it, on the refits made already
    from creepcomp.diagnose import sensor

    record = data.hidden_effect()
    whole = _plain(diagnose(record, jobs=1))
    kept, restarted, beside = [], [], []
    polish_kept, restart_taus = sensor._polish_kept, sensor._restart_taus

    def deciding(data_, current, alt, workers):
        out = polish_kept(data_, current, alt, workers)
        kept.append(out is not current)
        return out

    def restarting(data_, fit):
        restarted.append(fit)
        return restart_taus(data_, fit)

    class Spied(_InProcess):
        def map(self, fn, common, items, keys=None):
            items = list(items)
            if fn is sensor._tested:
                beside.append({type(item).__name__ for item in items})
            return super().map(fn, common, items, keys)

    monkeypatch.setattr(sensor, "_polish_kept", deciding)
    monkeypatch.setattr(sensor, "_restart_taus", restarting)
    monkeypatch.setattr(sensor, "Workers", lambda jobs, shared: Spied(jobs, shared))
    assert _plain(diagnose(record, jobs=2)) == whole
    assert True in kept and {"_Test", "_PolishRefit"} <= beside[0]
    assert len({id(fit) for fit in restarted}) == len(restarted)


@linux
def test_fits_with_a_fresh_creep_term_run_beside_the_baseline_are_those_the_screen_makes(monkeypatch):
    # a time offset's and a flow's fits with the creep term started afresh read the record
    # only: with two processes they run beside the baseline's fit, the first screen takes them
    from creepcomp.diagnose import effects as effects_pkg, sensor

    record = data.hidden_effect()
    whole = _plain(diagnose(record, jobs=1))
    ahead = []
    fresh_fits_ahead = effects_pkg.fresh_fits_ahead

    def counted(data_, effect):
        out = fresh_fits_ahead(data_, effect)
        ahead.append((effect.name, sorted(key[0] for key in out)))
        return out

    fitted = []
    fresh_term_fit = effects_pkg.SensorEffect.fresh_term_fit

    def fitting(self, data_, base, refine, settings, quick, quick_fit=None):
        fitted.append((self.name, base is None, settings))
        return fresh_term_fit(self, data_, base, refine, settings, quick, quick_fit)

    monkeypatch.setattr(effects_pkg, "fresh_fits_ahead", counted)
    monkeypatch.setattr(effects_pkg.SensorEffect, "fresh_term_fit", fitting)
    monkeypatch.setattr(sensor, "Workers", lambda jobs, shared: _InProcess(jobs, shared))
    assert _plain(diagnose(record, jobs=2)) == whole
    assert sorted(ahead) == [("time_offset", ["time_offset"]), ("viscous_flow", ["viscous_flow"])]
    # the screen took them: no fit with the default settings made again on the baseline
    assert sorted(f for f in fitted if f[2] is None) == [("time_offset", True, None), ("viscous_flow", True, None)]


class _InProcess(Workers):
    """Workers that say they run side by side but run every item here (what a test counts
    stays in this process)."""

    @property
    def width(self) -> int:
        return self.jobs

    @property
    def parallel(self) -> bool:
        return False
