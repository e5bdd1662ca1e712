"""Only true findings: a load step's unknown time within its sample interval is part of every
fit's model of the record; bipolar load programs and the softening by the largest magnitude."""

import sys
from pathlib import Path

import numpy as np
import pytest

from creepcomp import data as bundled
from creepcomp import synth
from creepcomp.diagnose.effects import compensate_extended, simulate_extended
from creepcomp.diagnose.effects.mullins_softening import EFFECT as MULLINS, _new_peaks
from creepcomp.fit.data import prepare
from creepcomp.fit.solver import Problem, fit_structure
from creepcomp.fit.starts import one_term_starts
from creepcomp.fit.data import load_steps
from creepcomp.fit.structure import Structure, basis, with_step_times
from creepcomp.io.records import Record
from creepcomp.model import CreepModel
from creepcomp.programs import LoadProgram
from creepcomp.synth.loads import ALL_PROGRAMS, PROGRAMS, make_program

TAU, BETA = 20.0, 0.05


def _record(step_times, levels, rate=2.0, duration=400.0, noise=0.0, seed=0):
    """A one-term sensor driven by steps at the given times (anywhere within their sample
    intervals), sampled at ``rate``; its exact response."""
    times, loads = [0.0], [0.0]
    for at, level in zip(step_times, levels):
        times += [at, at]
        loads += [loads[-1], level]
    times.append(duration)
    loads.append(loads[-1])
    program = LoadProgram(tuple(times), tuple(loads))
    t = np.arange(0.0, duration + 1e-9, 1.0 / rate)
    clean = 0.01 + program.response(CreepModel((BETA,), (TAU,)).lag_expansion(), t)
    signal = clean + np.random.default_rng(seed).normal(0.0, noise, len(t)) if noise else clean
    return Record(t, program.sample(t), signal, source="steps between samples")


# steps at 0.1, 0.9, 0.5 and 0.95 of their half-second intervals: 0.2 s before the middle, then
# 0.2, 0 and 0.225 s after it
STEPS = ([40.05, 120.45, 200.25, 280.475], [1.0, 0.3, 0.8, 0.0])


def test_steps_found_and_ramps_not():
    data = prepare(_record(*STEPS))
    assert list(data.time[load_steps(data)]) == [40.0, 120.0, 200.0, 280.0]
    t = np.arange(0.0, 100.0, 0.5)
    ramp = prepare(Record(t, np.clip(t / 50.0, 0, 1), t, source="ramp"))
    assert len(load_steps(ramp)) == 0


def test_step_time_columns_and_bounds():
    data = prepare(_record(*STEPS))
    values = {"tau[0]": TAU, "c0[0]": 0.0}
    plain = basis(data, Structure(1), values)
    b = with_step_times(data, plain, np.array([TAU]))
    # the first step is the reference: one column per later step and term
    assert b.columns.shape[1] == plain.columns.shape[1] + 3
    assert [k for _, k, _ in b.step_bounds] == [0, 0, 0]
    assert all(half == pytest.approx(0.5) for _, _, half in b.step_bounds)
    # with the load held between samples the step times are not modelled
    zero = prepare(_record(*STEPS), hold="zero")
    assert with_step_times(zero, basis(zero, Structure(1), values), np.array([TAU])).columns.shape[1] \
        == plain.columns.shape[1]


def test_fit_absorbs_the_step_times_within_their_bounds():
    record = _record(*STEPS)
    data = prepare(record)
    fit = fit_structure(data, Structure(1), one_term_starts(data), with_cov=False)
    # the load taken linear between samples misses the exact response by much more
    linear = 0.01 + CreepModel((BETA,), (TAU,)).response(record.time, record.load)
    missed = np.sqrt(np.mean((record.signal - linear) ** 2))
    assert fit.residual_rms < 0.05 * missed
    assert fit.taus[0] == pytest.approx(TAU, rel=1e-3)
    a = fit.values["a[0]"]
    shifts = [fit.values[f"step_time[{j}][0]"] / a for j in (1, 2, 3)]
    # each later than the first (0.2 s before its interval's middle): within the two half intervals
    assert all(abs(s) <= 0.5 + 0.5 + 1e-9 for s in shifts)
    assert shifts == pytest.approx([0.4, 0.2, 0.425], abs=0.02)


def test_bounds_hold_whatever_the_data():
    # a signal that no step time explains: the step coefficients sit at their bounds
    record = _record(*STEPS)
    t = record.time
    bumped = Record(t, record.load, record.signal + 0.02 * np.exp(-np.clip(t - 120.5, 0, None) / TAU)
                    * (t > 120.5), source="bumped")
    data = prepare(bumped)
    problem = Problem(data, Structure(1))
    x = problem.start_vector({"tau[0]": TAU, "c0[0]": 0.0})
    b, coef, _ = problem.project(x)
    a = abs(coef[b.names.index("a[0]")])
    for col, _, half in b.step_bounds:
        assert abs(coef[col]) <= a * half * (1 + 1e-9) + 1e-15


@pytest.mark.slow
def test_built_network_sensor_side_has_no_finding():
    from creepcomp.diagnose.sensor import diagnose

    d = diagnose(bundled.built_network(), correction=False)
    assert d.cause == "none"
    assert d.baseline.residual_rms < 1.02 * d.floor.rms


def test_bipolar_program_crosses_zero_with_rising_magnitudes():
    assert "bipolar" in ALL_PROGRAMS and "bipolar" not in PROGRAMS
    for seed in range(5):
        p = make_program("bipolar", 1000.0, np.random.default_rng(seed), 2.0)
        loads = np.array(p.loads)
        assert loads.min() < -0.5 and loads.max() > 0.5
        peaks = np.maximum.accumulate(np.abs(loads))
        # a new largest magnitude after a release towards zero
        assert _new_peaks(loads)
        assert peaks[-1] == pytest.approx(np.max(np.abs(loads)))
        assert loads[-1] == 0.0


def test_new_peaks_needs_a_release_first():
    assert not _new_peaks(np.array([0.0, 0.3, 0.6, 1.0, 1.0]))
    assert _new_peaks(np.array([0.0, -0.5, -0.1, 0.9, 0.2]))


def _peak_model(softening, beta=BETA):
    return CreepModel((beta,), (TAU,), 2.0, 0.1,
                      {MULLINS.name: {"softening": softening, "form": "peak", "load_scale": 1.0}})


def test_peak_form_multiplies_the_response_by_the_largest_magnitude():
    t = np.arange(0.0, 10.0, 1.0)
    load = np.array([0, 0.5, 0.5, 0.1, -1.0, -1.0, 0.2, 0.2, 0.0, 0.0])
    plain = CreepModel((1e-9,), (TAU,), 2.0, 0.1)
    y = simulate_extended(_peak_model(0.1, 1e-9), t, load)
    y0 = simulate_extended(plain, t, load)
    m = np.maximum.accumulate(np.abs(load))
    assert np.allclose(y - 0.1, (y0 - 0.1) * (1 - 0.1 * m), rtol=0, atol=1e-6)


def test_peak_form_round_trip_and_correction():
    entry = {"softening": 0.15, "form": "peak", "load_scale": 2.0}
    from creepcomp.diagnose.effects import arrays_data
    applied, values = MULLINS.restore(entry, _peak_model(0.15), arrays_data([0, 1], [0, 1]))
    assert applied.setting("form") == "peak" and applied.setting("load_scale") == 2.0
    assert values == {"mullins_softening.softening": 0.15}
    # the extended correction inverts the model: the corrected signal follows the load
    t = np.arange(0.0, 600.0, 0.5)
    load = make_program("bipolar", 600.0, np.random.default_rng(3), 1.0).sample(t)
    model = _peak_model(0.15)
    y = simulate_extended(model, t, load)
    corrected = compensate_extended(t, y, model)
    assert np.max(np.abs(corrected - (0.1 + 2.0 * load))) < 1e-6


def test_generator_peak_form_matches_the_template():
    spec = synth.Spec(hidden={MULLINS.name: {"form": "peak", "softening": 0.15}}, beta=(BETA,), tau=(TAU,),
                      gain=2.0, offset=0.1, rate=2.0, duration=600.0, program="bipolar",
                      noise=synth.NoiseSpec(white=1e-12), seed=4)
    syn = synth.generate(spec)
    r = syn.record
    model = CreepModel((BETA,), (TAU,), 2.0, 0.1,
                       {MULLINS.name: {"softening": 0.15, "form": "peak",
                                       "load_scale": float(np.max(np.abs(r.load)))}})
    y = simulate_extended(model, r.time, r.load)
    without = simulate_extended(CreepModel((BETA,), (TAU,), 2.0, 0.1), r.time, r.load)
    # the template (softened input, creep following it) against the generator (the whole
    # response multiplied): they differ by the creep at each new peak only
    assert np.sqrt(np.mean((r.signal - y) ** 2)) < 0.1 * np.sqrt(np.mean((r.signal - without) ** 2))


def test_benchmark_classes_keep_their_seeds():
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import diagnose_confusion as bench

    classes = bench.all_classes()
    assert classes[-len(bench.LATER):] == list(bench.LATER)
    assert "mullins_softening/peak" in classes
    assert classes.index("data_problem/jump") == classes.index("mullins_softening/damage") + 1


def test_a_step_time_counts_once_whatever_the_terms():
    data = prepare(_record(*STEPS))
    one = fit_structure(data, Structure(1), one_term_starts(data), with_cov=False)
    two = fit_structure(data, Structure(2), [dict(one.values, **{"tau[1]": 5 * TAU, "c0[1]": 0.0})],
                        with_cov=False)
    steps = sum(n.startswith("step_time[") for n in two.values)
    assert steps == 6
    # a further term costs its time constant, initial state and amplitude, not the steps again
    assert two.n_params - one.n_params == 3


def test_every_model_file_diagnose_writes_can_be_read(run_cli, tmp_path):
    """A delayed signal's baseline is a term of beta below -1 standing in for the delay: no
    command could read it, so it is not written, and the output says why."""
    from creepcomp.io.jsonfiles import read_model
    from creepcomp.io.records import write_record

    record = synth.generate(synth.random_spec("time_offset", 1, max_samples=2500)).record
    write_record(tmp_path / "r.csv", record)
    (tmp_path / "d").mkdir()
    (tmp_path / "d" / "baseline-model.json").write_text("{}")      # from an earlier run
    status, out, err = run_cli("diagnose", tmp_path / "r.csv", "-o", tmp_path / "d", "--json")
    assert status == 0, err
    import json
    files = json.loads(out)["files"]
    for key in ("model", "baseline_model"):
        if key in files:
            read_model(files[key])
    if "baseline_model" not in files:
        assert "beta" in files["baseline_model_not_written"]
        assert not (tmp_path / "d" / "baseline-model.json").exists()


@pytest.mark.slow
@pytest.mark.parametrize("seed,relaxation", [(10, False), (11, True)])
def test_recovery_switched_by_the_state_magnitude_is_found_on_bipolar_records(seed, relaxation):
    # unloading is the creep state's magnitude falling, whichever the load's sign: on a
    # record that crosses zero, loading towards -1 is creep, and coming back towards 0 recovery
    from creepcomp.diagnose import diagnose
    s = synth.random_record("asymmetric_recovery", seed, programs=("bipolar",), max_samples=3000,
                            form="state", relaxation=relaxation)
    assert np.min(s.record.load) < 0 < np.max(s.record.load)
    d = diagnose(s.record, correction=False)
    assert d.cause == "asymmetric_recovery"
    finding = next(f for f in d.findings if f.effect == "asymmetric_recovery")
    truth = s.hidden["asymmetric_recovery"]["tau_recovery"]
    assert finding.parameters["tau_recovery"] == pytest.approx(truth, rel=0.3)
