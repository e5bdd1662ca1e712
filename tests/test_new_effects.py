"""Transition overshoot, rate-independent hysteresis (play operator),
Mullins softening and data problems, hidden by the generator in short records: named, their
parameters near the truth, their extension read back from the model file; records with an
effect no template describes are not called ``none``."""

import numpy as np
import pytest

from creepcomp import synth
from creepcomp.diagnose import effects
from creepcomp.diagnose.effects import simulate_extended
from creepcomp.diagnose.effects.data_problem import find_jumps, screen
from creepcomp.diagnose.effects.rate_independent_hysteresis import PlayShapes, play
from creepcomp.diagnose.sensor import diagnose
from creepcomp.fit.data import prepare
from creepcomp.fit.solver import fit_structure
from creepcomp.fit.starts import one_term_starts
from creepcomp.fit.structure import Structure
from creepcomp.io.jsonfiles import read_model, write_json
from creepcomp.io.records import Record

SHORT = dict(max_samples=1500, duration=(600.0, 1500.0), noise=(2e-4, 1e-3))


def test_play_operator_is_the_sample_by_sample_backlash():
    x = np.cumsum(np.random.default_rng(1).normal(size=3000))
    for width, start in ((0.5, 0.0), (4.0, 3.0), (40.0, -2.0)):
        np.testing.assert_array_equal(play(x, width, start), synth.play_loop(x, width, start))


@pytest.mark.parametrize("effect, seed", [("transition_overshoot", 1), ("rate_independent_hysteresis", 1),
                                          pytest.param("mullins_softening", 0, marks=pytest.mark.slow)])
def test_new_effect_is_named_recovered_and_read_back(effect, seed, tmp_path):
    syn = synth.random_record(effect, seed, **SHORT)
    d = diagnose(syn.record, correction=False)
    assert d.cause == effect, [t.to_dict() for t in d.trials]
    truth = synth.reported_truth(syn)[effect]
    for name, value in truth.items():
        assert d.findings[0].parameters[name] == pytest.approx(value, rel=0.2), name
        assert d.findings[0].uncertainty[name] > 0
    # the extension through the model file simulates the fit (less the free initial creep state)
    write_json(tmp_path / "m.json", d.extended_model)
    back = read_model(tmp_path / "m.json")
    assert set(back.extensions) == {f.effect for f in d.findings if f.effect != "unexplained"}
    fit, t = d.extended, syn.record.time
    decay = sum(fit.values[f"a[{k}]"] * fit.values[f"c0[{k}]"] * np.exp(-(t - t[0]) / fit.values[f"tau[{k}]"])
                for k in range(fit.structure.n_terms))
    if effect == "mullins_softening":       # the free state decays through the same lags
        np.testing.assert_allclose(simulate_extended(back, t, syn.record.load) + decay,
                                   fit.prediction - fit.step_times_part(d.data),
                                   atol=1e-6 * np.ptp(fit.prediction))
    else:
        np.testing.assert_allclose(simulate_extended(back, t, syn.record.load) + decay,
                                   fit.prediction - fit.step_times_part(d.data),
                                   atol=1e-6 * np.ptp(fit.prediction))


def test_signal_jumps_no_load_explains_are_a_data_problem():
    syn = synth.random_record("data_problem", 0, form="jump", **SHORT)
    d = diagnose(syn.record, correction=False)
    assert d.cause == "data_problem"
    f = d.findings[0]
    assert f.parameters["kind"] == "jump"
    truth = syn.hidden["data_problem"]
    assert len(f.parameters["where"]) == len(truth["where"])
    dt = np.median(np.diff(syn.record.time))
    np.testing.assert_allclose(f.parameters["where"], truth["where"], atol=1.5 * dt)
    np.testing.assert_allclose(f.parameters["size"], truth["size"], rtol=0.2)


def test_a_load_step_is_not_a_jump():
    syn = synth.generate(synth.Spec(duration=600, rate=5, program="staircase", seed=3,
                                    noise=synth.NoiseSpec(white=1e-3)))
    data = prepare(syn.record)
    # the signal steps with the load: a residual that steps there too is not a data problem
    assert find_jumps(data, syn.record.signal - np.mean(syn.record.signal)) == []


def _screened(syn):
    data = prepare(syn.record)
    base = fit_structure(data, Structure(1), one_term_starts(data))
    return {p["kind"]: p for p in screen(data, base)}


@pytest.mark.parametrize("kind", ["clipping", "out_of_step", "quantisation"])
def test_screened_data_problems_are_found_where_they_are(kind):
    syn = synth.random_record("data_problem", 2, form=kind, **SHORT)
    found = _screened(syn)
    assert kind in found, found
    truth = syn.hidden["data_problem"]["where"]
    where = np.ravel(found[kind]["where"])
    if kind == "out_of_step":                # the slip lies in the interval found
        assert where[0] <= truth[0] <= where[1]
    else:
        assert where.min() >= truth[0] - 1e-9 and where.max() <= truth[-1] + 1e-9


def test_a_quantised_record_at_its_minimum_is_not_clipped():
    """A relaxing record on a 0.11 grid with noise correlated over about 5 samples (0.25 s at
    21 Hz, benchmark record relaxation+extra_retardation 203006) holds its smallest value for 3
    samples where the model stays inside: no clipping (it was named the cause before)."""
    spec = synth.random_spec("extra_retardation", 203006, relaxation=True, max_samples=5000)
    syn = synth.generate(spec)
    assert syn.spec.noise.lsb > 0 and np.sum(syn.record.signal == syn.record.signal.min()) >= 3
    assert "clipping" not in _screened(syn)


def test_clean_records_are_not_screened():
    for seed in range(3):
        assert _screened(synth.random_record(None, seed, **SHORT)) == {}


@pytest.mark.parametrize("kind, seed", [pytest.param("sensitivity_drift", 1, marks=pytest.mark.slow),
                                        ("periodic_disturbance", 1), ("aging_retardation", 2)])
def test_a_record_no_template_describes_is_not_none(kind, seed):
    # (aging_retardation seed 1 is 'none'-free but lacks 'unexplained': its fast creep, 4.6 s,
    # after 20 steps lifts the noise floor to 13 times the true noise; see the report)
    syn = synth.random_record(kind, seed, **SHORT)
    d = diagnose(syn.record, correction=False)
    assert d.cause != "none"
    assert "unexplained" in [f.effect for f in d.findings]


def test_every_formulation_is_generated_and_differs_from_the_first():
    for effect in synth.EFFECTS:
        # (recovery by the state's magnitude and by the load's direction agree wherever the
        # state settles before the load turns: after steps held long; they differ on ramps)
        size = dict(max_samples=600, programs=("mixture",) if effect == "asymmetric_recovery" else None)
        first = synth.random_record(effect, 5, form=synth.FORMS[effect][0], **size)
        for form in synth.FORMS[effect][1:]:
            other = synth.random_record(effect, 5, form=form, **size)
            assert other.hidden[effect]["form"] == form
            assert not np.allclose(other.record.signal, first.record.signal), (effect, form)
    with pytest.raises(Exception, match="unknown form"):
        synth.random_spec("mullins_softening", 0, form="sticky")


def test_relaxation_records_have_negative_creep():
    spec = synth.random_spec("extra_retardation", 4, relaxation=True, **SHORT)
    assert spec.beta[0] < 0 and spec.hidden["extra_retardation"]["beta"] < 0
    assert effects.get("mullins_softening").parameters == ("softening",)


def test_steps_larger_than_the_play_leave_its_width_undetermined():
    # a staircase whose smallest step is 0.5: every width below it gives the same column shape
    x = np.repeat([0.0, 1.0, 0.4, 0.9, 0.0, 0.6], 50)
    lo, hi = PlayShapes(x, 1.0).as_good(0.2, 0.05, 1e-3)
    assert lo < 0.01 and 0.45 < hi < 0.5
    # a sweep moves the play through its dead band at every reversal: the width shows
    sweep = np.concatenate([np.linspace(0, 1, 200), np.linspace(1, 0, 200)] * 3)
    lo, hi = PlayShapes(sweep, 1.0).as_good(0.2, 0.05, 1e-3)
    assert 0.18 < lo <= 0.2 <= hi < 0.22


def test_hysteresis_on_load_steps_reports_the_loop_height_not_a_width():
    syn = synth.generate(synth.random_spec("rate_independent_hysteresis", 4, programs=("staircase",), **SHORT))
    d = diagnose(syn.record, correction=False)
    f = next(f for f in d.findings if f.effect == "rate_independent_hysteresis")
    truth = synth.reported_truth(syn)["rate_independent_hysteresis"]
    assert f.parameters["width"] is None and f.parameters["weight"] is None, f.parameters
    lo, hi = f.parameters["width_range"]
    assert lo <= truth["width"] <= hi and hi > 1.2 * lo
    assert f.parameters["loop_height"] == pytest.approx(truth["loop_height"], rel=0.2)
    assert "loop height" in f.note
    # the model file: the widest width that fits as well, the loop height kept (a narrow width
    # would give a weight many times the gain, whose dead band no correction can undo)
    entry = d.extended_model["extensions"]["rate_independent_hysteresis"]
    assert entry["width"] == pytest.approx(hi)
    assert entry["width"] * entry["weight"] == pytest.approx(f.parameters["loop_height"], rel=1e-9)
    assert abs(entry["weight"] / d.extended_model["gain"]) < 1.0


def test_jumps_on_a_noisy_ramping_load_are_found_when_the_load_cannot_explain_them():
    rng = np.random.default_rng(4)
    n = 600
    t = np.arange(n) * 0.05
    load = np.linspace(0.0, 0.2, n) + rng.normal(0.0, 0.004, n)   # moves 1 % of scale in 20 samples
    signal = -12.0 * load + rng.normal(0.0, 0.5, n)
    signal[300:] -= 20.0                                         # the load could move it by < 1
    data = prepare(Record(t, load, signal))
    residual = signal - np.polyval(np.polyfit(load, signal, 1), load)
    assert find_jumps(data, residual) == []                      # the load moves: no verdict
    found = find_jumps(data, residual, sensitivity=12.0)
    assert len(found) == 1 and abs(found[0] - 300) <= 1
    # a load step the size of the jump explains it even so
    stepped = np.where(np.arange(n) >= 300, 20.0 / 12.0, 0.0) + load
    assert find_jumps(prepare(Record(t, stepped, signal)), residual, sensitivity=12.0) == []


def test_jumps_that_worsen_the_correction_stay_the_cause_and_say_why():
    # the left insole record: two jumps of the signal where the pressure ramps slowly; the
    # creep model fitted around them corrects the record worse than the baseline
    from creepcomp import data as shipped
    d = diagnose(shipped.insole_left_steps(), candidates=["data_problem"])
    f = d.findings[0]
    assert d.cause == "data_problem" and f.parameters["kind"] == "jump"
    assert len(f.parameters["where"]) == 2
    assert f.worsens_correction
    assert "jumps are in the record" in f.note and "does not remove them" in f.note
    assert f"correction-error ratio {f.correction_error_ratio:.3g}" in f.note
    without = float(f.note.rsplit("the ratio is ", 1)[1].split()[0])
    assert without > 1.0                     # with the jumps taken out the correction gains


def test_an_extension_that_worsens_the_correction_is_never_the_cause():
    from creepcomp.diagnose.decision import order
    from creepcomp.diagnose.sensor import Finding
    from creepcomp.fit.evidence import Evidence
    nan = Evidence(float("nan"), float("nan"), float("nan"))
    worse_flow = Finding("viscous_flow", {}, {}, nan, 10.0, correction_error_ratio=0.8)
    worse_jump = Finding("data_problem", {"kind": "jump"}, {}, nan, 5.0, correction_error_ratio=0.8)
    rest = Finding("unexplained", {}, {}, nan, 1.0)
    assert [f.effect for f in order([worse_flow, worse_jump], rest)] == \
        ["data_problem", "unexplained", "viscous_flow"]
    assert [f.effect for f in order([worse_flow], rest)] == ["unexplained", "viscous_flow"]


def test_effects_below_half_a_quantisation_step_leave_the_grid_the_cause():
    # a record on a grid 7 times its noise: what its quantisation error lets a candidate fit
    # (an asymmetric recovery of a quarter step at most) is not measured by the record
    spec = synth.random_spec("data_problem", 230016, form="quantisation", max_samples=5000)
    d = diagnose(synth.generate(spec).record, correction=False)
    assert d.cause == "data_problem" and d.findings[0].parameters["kind"] == "quantisation"
    step = d.findings[0].parameters["step"]
    reach = float(np.max(np.abs(d.extended.prediction - d.baseline.prediction)))
    named = [f for f in d.findings[1:] if f.effect not in ("unexplained", "data_problem")]
    assert named and reach < 0.5 * step
    assert all("quantisation step" in f.note for f in named)


@pytest.mark.parametrize("name, seed, effect, form", [
    ("relaxation+extra_retardation", 203011, "extra_retardation", None),   # one step, early
    ("time_offset/average", 220019, "time_offset", "average")])
def test_held_out_halves_each_hold_a_load_change(name, seed, effect, form):
    # benchmark records the held-out test across halves once refused: one half had no load
    # change, so neither model could predict the other half from it (load_halves)
    kw = dict(relaxation=True) if name.startswith("relaxation") else dict(form=form)
    spec = synth.random_spec(effect, seed, max_samples=5000, **kw)
    d = diagnose(synth.generate(spec).record, correction=False)
    assert d.cause == effect, [t.to_dict() for t in d.trials]


def test_the_kept_total_variation_is_the_records_and_follows_another_load():
    """The total variation of the record's own load is kept on the record; a load another
    effect changed is its own."""
    from creepcomp.diagnose.effects.transition_overshoot import _total_variation_of, total_variation
    from creepcomp.fit.data import prepare
    from creepcomp.io.records import Record

    load = np.concatenate([np.zeros(10), np.ones(10), np.zeros(10)])
    data = prepare(Record(np.arange(30.0), load, load.copy()))
    assert _total_variation_of(data, data.load, 0.0)[-1] == 2.0
    assert _total_variation_of(data, data.load, 0.0) is _total_variation_of(data, data.load.copy(), 0.0)
    s = data.load.copy()
    s[15:] = 3.0
    assert np.array_equal(_total_variation_of(data, s, 0.0), total_variation(s, 0.0))
    assert _total_variation_of(data, s, 0.0)[-1] == 3.0