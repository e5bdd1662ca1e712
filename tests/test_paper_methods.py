import warnings

import numpy as np
import pytest

from creepcomp.digital import paper_methods
from creepcomp.digital.correctors import compensate
from creepcomp.model import CreepModel

VOIGT = CreepModel.voigt(0.03, 45.0)
THREE = CreepModel((0.006, 0.015, 0.009), (6.0, 45.0, 150.0))


def staircase_record(model, dt=0.5, n=2400):
    t = np.arange(n) * dt
    load = np.select([t < 20, t < 300, t < 700, t < 900], [0.0, 1.0, 2.5, -1.0], 0.3)
    return t, load, model.response(t, load, hold="zero")


@pytest.mark.parametrize("model", [VOIGT, THREE], ids=["eq7", "eq9"])
def test_subtractive_as_printed_is_exact_for_held_loads_and_equals_production(model):
    t, load, raw = staircase_record(model)
    literal = paper_methods.subtractive(t, raw, model.beta, model.tau)
    assert np.max(np.abs(literal - load)) < 1e-12
    assert np.max(np.abs(literal - compensate(t, raw, model))) < 1e-12


@pytest.mark.parametrize("initial", ["relaxed", "settled"])
def test_eq11_solved_for_the_current_sample_equals_the_production_supplemental(initial):
    model = THREE
    t, load, raw = staircase_record(model)
    gains = np.array(model.beta) / (1 + model.beta0)
    literal = paper_methods.supplemental(t, raw, model.beta, model.tau, gains=gains, lag=False,
                                         initial=initial)
    assert np.max(np.abs(literal - compensate(t, raw, model, "supplemental", initial=initial))) < 1e-12
    assert np.max(np.abs(literal - (1 + model.beta0) * load)) < 1e-12


def test_supplemental_as_printed_lags_one_step():
    """At a step from a settled state the printed eq. 12 returns the raw sample: the creep
    still to come (beta0 times the step) arrives one sample late."""
    model = VOIGT
    t, load, raw = staircase_record(model)
    literal = paper_methods.supplemental(t, raw, model.beta, model.tau)
    step = int(np.flatnonzero(t >= 20)[0])
    assert literal[step] == pytest.approx(raw[step], abs=1e-15)
    assert (1 + model.beta0) * load[step] - literal[step] == pytest.approx(0.03 * 1.0, rel=1e-12)
    error = literal - (1 + model.beta0) * load
    assert np.max(np.abs(error)) == pytest.approx(0.03 * np.max(np.abs(np.diff(load))), rel=1e-3)
    # the exact gains alone do not remove the lag
    gains = np.array(model.beta) / (1 + model.beta0)
    assert np.max(np.abs(paper_methods.supplemental(t, raw, model.beta, model.tau, gains=gains)
                         - (1 + model.beta0) * load)) > 0.01


def test_supplemental_leaves_a_saturated_signal_alone_from_any_saturated_state():
    t = np.arange(0, 300.0, 1.0)
    raw = np.full(len(t), 1.03 * 0.6)
    np.testing.assert_array_equal(paper_methods.supplemental(t, raw, [0.03], [45.0]), raw)


def run_and_catch(function, *args):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = function(*args)
    return result, {str(w.message) for w in caught}


def test_the_printed_form_overflows_past_t_over_tau_709_and_production_does_not():
    model = THREE
    t = np.arange(2000) * 3.0                 # to t / tau_min = 1000
    load = np.repeat(np.random.default_rng(0).uniform(-1, 1, 40), 50)
    raw = model.response(t, load, hold="zero")
    literal, said = run_and_catch(paper_methods.subtractive, t, raw, model.beta, model.tau)
    assert "overflow encountered in exp" in said
    bad = np.flatnonzero(~np.isfinite(literal))
    assert bad.size and 700 < t[bad[0]] / 6.0 < 720
    assert np.all(np.isfinite(literal[t / 6.0 < 700]))
    assert np.max(np.abs(literal[t / 6.0 < 700] - load[t / 6.0 < 700])) < 1e-12
    assert np.max(np.abs(compensate(t, raw, model) - load)) < 1e-12
    sup, said = run_and_catch(paper_methods.supplemental, t, raw, model.beta, model.tau)
    assert "overflow encountered in exp" in said
    assert not np.all(np.isfinite(sup))


def test_bad_arguments():
    from creepcomp.errors import InputError

    with pytest.raises(InputError, match="equal"):
        paper_methods.subtractive([0, 1], [0.0], [0.03], [45.0])
    with pytest.raises(InputError, match="one gain per creep term"):
        paper_methods.supplemental([0, 1], [0, 0], [0.03], [45.0], gains=[0.1, 0.2])
    with pytest.raises(InputError, match="initial"):
        paper_methods.supplemental([0, 1], [0, 0], [0.03], [45.0], initial="warm")
