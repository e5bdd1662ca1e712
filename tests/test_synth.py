from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from creepcomp import synth
from creepcomp.diagnose.circuit import diagnose_circuit
from creepcomp.fit.circuit import prepare
from creepcomp.synth.circuit import residual_at
from creepcomp.errors import InputError
from creepcomp.model import CreepModel


def test_same_seed_same_record_other_seed_other_record():
    a = synth.random_record("viscous_flow", 11, max_samples=3000)
    b = synth.random_record("viscous_flow", 11, max_samples=3000)
    c = synth.random_record("viscous_flow", 12, max_samples=3000)
    np.testing.assert_array_equal(a.record.signal, b.record.signal)
    assert a.hidden == b.hidden
    assert len(a.record) != len(c.record) or not np.array_equal(a.record.signal, c.record.signal)


@settings(max_examples=30)
@given(st.sampled_from(synth.ALL_PROGRAMS), st.integers(0, 2**31 - 1), st.booleans())
def test_programs_change_the_load_within_the_record(kind, seed, loaded):
    rng = np.random.default_rng(seed)
    prog = synth.make_program(kind, 1800.0, rng, 2.0, loaded, 45.0)
    t = np.linspace(0, 1800, 2000)
    u = prog.sample(t)
    assert np.ptp(u) > 0.1                      # the record sees the load change
    assert np.max(np.abs(u)) <= 2.0 + 1e-12
    if loaded:
        assert u[0] != 0


def test_clean_record_is_the_creep_model_plus_noise():
    spec = synth.Spec(beta=(0.03,), tau=(45.0,), gain=2.0, offset=0.5, rate=5.0, duration=900,
                      program="staircase", noise=synth.NoiseSpec(white=1e-3), seed=4)
    syn = synth.generate(spec)
    r = syn.record
    model = CreepModel((0.03,), (45.0,), gain=2.0, offset=0.5)
    exact = model.offset + model.gain * syn.program.response(model.lag_expansion(), r.time)
    resid = r.signal - exact
    assert np.std(resid) == pytest.approx(1e-3, rel=0.1)
    assert abs(np.mean(resid)) < 2e-4


def test_irregular_sampling_and_gaps():
    spec = synth.Spec(rate=10.0, duration=1200, jitter=0.3, gaps=2, seed=5)
    t = synth.generate(spec).record.time
    dt = np.diff(t)
    assert np.all(dt > 0)
    assert dt.max() > 5.0                       # a gap of several seconds
    assert np.std(dt[dt < 1.0]) > 0.01          # jittered


def test_noise_colour_and_drift():
    rng = np.random.default_rng(0)
    t = np.arange(0, 3600, 0.1)
    e = synth.sample_noise(t, synth.NoiseSpec(white=0.0, coloured=1.0, correlation_time=2.0), rng)
    r1 = np.corrcoef(e[:-1], e[1:])[0, 1]
    assert r1 == pytest.approx(np.exp(-0.1 / 2.0), abs=0.01)
    d = synth.sample_noise(t, synth.NoiseSpec(white=0.0, drift=1.0), rng)
    assert 0.2 < abs(d[-1] - d[0]) < 5.0        # about one unit after an hour


def test_thermal_effects_bring_a_temperature_column():
    syn = synth.generate(synth.Spec(hidden={"thermal_drift": {"coefficient": 0.01}}, duration=600, seed=1))
    assert syn.record.temperature is not None
    assert np.ptp(syn.record.temperature) > 1.0
    assert "reference_temperature" in syn.hidden["thermal_drift"]


def test_random_spec_respects_its_ranges():
    for seed in range(20):
        spec = synth.random_spec("time_offset", seed, rate=(2, 50), max_samples=4000)
        assert 2 <= spec.rate <= 50
        assert spec.duration * spec.rate <= 4000 + 1
        assert spec.program in synth.PROGRAMS_FOR["time_offset"]
        assert spec.hidden["time_offset"]["delay"] >= 2.0 / spec.rate


def test_unknown_names_are_refused():
    with pytest.raises(InputError, match="unknown effect"):
        synth.random_spec("gremlins", 0)
    with pytest.raises(InputError, match="load program"):
        synth.make_program("zigzag", 100.0, np.random.default_rng(0))


def test_a_hidden_effect_is_kept_detectable_by_scaling_the_noise():
    faint = synth.Spec(hidden={"extra_retardation": {"tau": 200.0, "beta": 1e-4}}, tau=(20.0,), rate=2.0,
                       duration=1200.0, noise=synth.NoiseSpec(white=1e-2), seed=3, detectable_z=10.0)
    assert synth.generate(faint).spec.noise.white < 1e-3
    clear = replace(faint, hidden={"extra_retardation": {"tau": 200.0, "beta": 0.02}},
                    noise=synth.NoiseSpec(white=1e-4))
    assert synth.generate(clear).spec.noise.white == 1e-4


def test_detectable_beyond_what_the_refitted_baseline_absorbs():
    # a load-dependent retardation time: the fitted baseline's tau moves far from the true
    # one and absorbs much more than the linearisation at the truth says (benchmark record
    # 210006: z 14 linearised, 4 with the baseline refitted, before the refit counted)
    from creepcomp.synth.common import DETECTABLE_Z, heldout_z
    from creepcomp.synth.sensor import _baseline_residual
    syn = synth.generate(synth.random_spec("nonlinear_creep", 210006, form="time", max_samples=5000))
    clean = synth.simulate_signal(syn.spec, syn.program, syn.record.time, None)
    noise = syn.record.signal - clean
    absorbed = _baseline_residual(syn.record.time, syn.record.load, clean)
    assert heldout_z(absorbed, noise) > 0.9 * DETECTABLE_Z


def test_a_circuit_fault_is_kept_detectable_distinct_and_measurable():
    base = synth.CircuitSpec(hidden={"dielectric_absorption": {"fraction": 0.01, "tau": 60.0, "cell": 0}},
                             rate=4.0, duration=1200.0, noise=synth.NoiseSpec(white=1e-3),
                             corrected_noise=synth.NoiseSpec(white=1e-3), seed=4)
    assert synth.generate_circuit(base).noise_factor == {}
    for rule in ("detectable_z", "distinct_z", "precise_to"):
        syn = synth.generate_circuit(replace(base, **{rule: {"precise_to": 0.03}.get(rule, 10.0)}))
        (_, factor), = syn.noise_factor.items()
        assert 0 < factor < 1, (rule, factor)
        assert syn.spec.corrected_noise.white == pytest.approx(1e-3 * factor)
    both = synth.generate_circuit(replace(base, detectable_z=10.0, distinct_z=5.0, precise_to=0.03))
    assert both.spec.noise.white == pytest.approx(1e-3 * min(both.noise_factor.values()))
    # absorption is hard to tell apart and to measure: it asks for less noise than detection
    assert both.noise_factor["precision"] < both.noise_factor["detectability"]
    # two faults at once: detectable together; the other rules judge one fault
    two = replace(base, hidden={**base.hidden, "capacitor_leakage": {"R": 1e8, "cell": 0}}, detectable_z=10.0)
    assert set(synth.generate_circuit(two).noise_factor) == {"detectability"}
    with pytest.raises(ValueError, match="one hidden fault"):
        synth.generate_circuit(replace(two, precise_to=0.03))


def test_precision_of_a_fault_agrees_with_the_fits_own_uncertainty():
    spec = synth.CircuitSpec(hidden={"capacitor_value": {"C": 14e-6}}, rate=4.0, duration=900.0, seed=2,
                             corrected_noise=synth.NoiseSpec(white=2e-4), drive="samples")
    syn = synth.generate_circuit(spec)
    data = prepare(syn.record, syn.design)

    def residual(part, h):
        return residual_at(data, "capacitor_value", synth.scaled_part("capacitor_value", {"C": 14e-6}, part, h))

    noise = np.random.default_rng(0).normal(0, 2e-4, data.n)
    one = synth.circuit_precision(residual, ("C",), noise)["C"]
    assert synth.circuit_precision(residual, ("C",), 2 * noise)["C"] == pytest.approx(2 * one, rel=1e-9)
    # the same spread from the diagnosis's fit (its Jacobian at the optimum, residual variance)
    d = diagnose_circuit(syn.record, syn.design, spice_check=False, candidates=["capacitor_value"])
    found = d.findings[0]
    assert found.uncertainty["C"] / found.parameters["C"] == pytest.approx(one, rel=0.2)
    assert synth.fault_parts("dielectric_absorption") == ("C", "R")
    branch = synth.scaled_part("dielectric_absorption", {"fraction": 0.01, "tau": 50.0}, "C", np.log(2))
    assert branch == pytest.approx({"fraction": 0.02, "tau": 100.0})   # R = tau / C unchanged
    # source, load, leakage, absorption at three time constants and R1, R2 off their values:
    # not a capacitor's value
    others = synth.alternative_faults(syn.design.network, "capacitor_value", 900.0)
    assert len(others) == 8 and all(n.cells[0].C == syn.design.network.cells[0].C for n in others)


def test_bundled_hidden_effect_record_is_current(tmp_path):
    from creepcomp.data import path as data_path

    written = synth.write_demo_record(tmp_path)
    assert written.read_text() == data_path("hidden_effect.csv").read_text(), "regenerate data/hidden_effect.csv"
