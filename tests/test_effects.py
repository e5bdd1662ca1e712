import numpy as np
import pytest

from creepcomp.diagnose import effects
from creepcomp import programs
from creepcomp import synth
from creepcomp.diagnose.effects import compensate_extended, simulate_extended
from creepcomp.errors import InputError
from creepcomp.model import CreepModel

VOCABULARY = ("extra_retardation", "viscous_flow", "nonlinear_creep", "asymmetric_recovery",
              "thermal_drift", "thermal_retardation", "static_nonlinearity", "time_offset",
              "transition_overshoot", "rate_independent_hysteresis", "mullins_softening",
              "data_problem")


def test_registry_holds_the_sensor_vocabulary():
    names = [e.name for e in effects.sensor_effects()]
    assert names[:len(VOCABULARY)] == list(VOCABULARY)
    for e in effects.sensor_effects():
        assert e.side == "sensor" and e.summary
    with pytest.raises(InputError, match="unknown effect"):
        effects.get("gremlins")


def _staircase(t):
    prog = programs.staircase([1.0, 2.0, 0.5, 2.0, 0.0], hold=160.0, start=20.0)
    return prog, prog.sample(t)


EXTENSIONS = {
    "viscous_flow": {"rate": 2e-5},
    "nonlinear_creep": {"growth": 0.8, "load_scale": 2.0},
    "asymmetric_recovery": {"tau": 40.0, "tau_recovery": 120.0},
    "thermal_drift": {"coefficient": 0.003, "reference_temperature": 25.0},
    "thermal_retardation": {"kappa": 0.05, "reference_temperature": 25.0},
    "static_nonlinearity": {"a2": 0.02, "a3": -0.01, "load_scale": 2.0},
    "time_offset": {"delay": 0.7},
    "transition_overshoot": {"amplitude": 0.06, "tau": 60.0, "load_scale": 2.0},
    "rate_independent_hysteresis": {"width": 0.3, "weight": 0.12},
    "mullins_softening": {"softening": 0.2},
}


@pytest.mark.parametrize("name", sorted(EXTENSIONS))
def test_extended_model_simulation_matches_the_independent_generator(name):
    """The effect's simulation (sample-level, exact lags) against synth's fine-grid one."""
    entry = EXTENSIONS[name]
    t = np.arange(0, 820, 0.25)
    prog, u = _staircase(t)
    temp = 25.0 + 3.0 * np.sin(2 * np.pi * t / 500.0) if name.startswith("thermal") else None
    model = CreepModel((0.04,), (40.0,), gain=1.5, offset=0.2, extensions={name: entry})
    got = simulate_extended(model, t, u, temp)
    hidden = {"viscous_flow": {"rate": 2e-5}, "nonlinear_creep": {"growth": 0.8},
              "asymmetric_recovery": {"tau_recovery": 120.0},
              "thermal_drift": {"coefficient": 0.003, "reference_temperature": 25.0},
              "static_nonlinearity": {"a2": 0.02, "a3": -0.01},
              "time_offset": {"delay": 0.7},
              "transition_overshoot": {"amplitude": 0.06, "tau": 60.0},
              "rate_independent_hysteresis": {"form": "play", "width": 0.3, "weight": 0.12},
              "mullins_softening": {"form": "chord", "softening": 0.2}}.get(name)
    if name == "thermal_retardation":       # synth uses Arrhenius: match kappa at 25 C
        kappa = 0.05
        hidden = {"activation": kappa * (298.15 ** 2), "reference_temperature": 25.0}
    spec = synth.Spec(hidden={name: hidden}, beta=(0.04,), tau=(40.0,), gain=1.5, offset=0.2,
                      rate=4.0, full_scale=2.0)
    ref = synth.simulate_signal(spec, prog, t, (lambda x: 25.0 + 3.0 * np.sin(2 * np.pi * x / 500.0))
                                if temp is not None else None)
    # away from the steps (where the sampled load cannot say when, within a sample step, the
    # load changed) the two agree to the discretisation error of a few samples' creep
    steps = np.array(prog.times)[np.flatnonzero(np.diff(prog.times) == 0)]
    away = np.all(np.abs(t[:, None] - 0.7 - steps[None, :]) > 1.0, axis=1)
    tol = 3e-4 if name != "thermal_retardation" else 3e-3    # linearised vs Arrhenius law
    assert np.max(np.abs(got - ref)[away]) < tol * np.ptp(ref)
    assert np.mean(away) > 0.95


def test_simulation_without_extensions_is_the_creep_model():
    t = np.arange(0, 600, 0.5)
    _, u = _staircase(t)
    model = CreepModel((0.03, 0.01), (30.0, 200.0), gain=2.0, offset=-0.1)
    np.testing.assert_allclose(simulate_extended(model, t, u), model.response(t, u), atol=1e-12)


@pytest.mark.parametrize("name", sorted(EXTENSIONS) + [None])
def test_compensation_inverts_the_extended_model(name):
    """Correction with the extended model returns offset + gain * load."""
    t = np.arange(0, 820, 0.25)
    _, u = _staircase(t)
    temp = 25.0 + 3.0 * np.sin(2 * np.pi * t / 500.0)
    ext = {name: EXTENSIONS[name]} if name else {}
    model = CreepModel((0.04,), (40.0,), gain=1.5, offset=0.2, extensions=ext)
    y = simulate_extended(model, t, u, temp)
    comp = compensate_extended(t, y, model, temp)
    err = comp - (0.2 + 1.5 * u)
    if name == "time_offset":            # the first samples precede the delayed signal
        err = err[t > 2.0]
    assert np.sqrt(np.mean(err ** 2)) < 1e-3 * 1.5 * 2.0


def test_missing_temperature_for_a_thermal_extension_is_an_error():
    model = CreepModel((0.04,), (40.0,), extensions={"thermal_drift": EXTENSIONS["thermal_drift"]})
    with pytest.raises(InputError, match="temperature"):
        simulate_extended(model, np.arange(10.0), np.ones(10))


def test_extension_written_by_a_fit_reads_back(tmp_path):
    from creepcomp.io.jsonfiles import read_model, write_json
    from creepcomp.fit.data import prepare
    from creepcomp.fit.structure import Structure
    from creepcomp.fit.solver import fit_structure
    from creepcomp.fit.starts import one_term_starts

    syn = synth.generate(synth.Spec(hidden={"viscous_flow": {"rate": 3e-5}}, duration=1200, rate=4,
                                    program="staircase", seed=3))
    data = prepare(syn.record)
    base = fit_structure(data, Structure(1), one_term_starts(data))
    fit = effects.get("viscous_flow").fit_on(data, base)
    applied = fit.structure.effects[0]
    entry = applied.effect.extension(fit, applied)
    assert entry["rate"] == pytest.approx(3e-5, rel=0.1)
    model = fit.creep_model({"viscous_flow": entry})
    write_json(tmp_path / "m.json", model.to_dict())
    back = read_model(tmp_path / "m.json")
    t = syn.record.time
    decay = fit.values["a[0]"] * fit.values["c0[0]"] * np.exp(-(t - t[0]) / fit.values["tau[0]"])
    np.testing.assert_allclose(simulate_extended(back, t, syn.record.load) + decay,
                               fit.prediction - fit.step_times_part(data),
                               atol=1e-9 * np.ptp(fit.prediction))


def test_recovery_switched_by_the_load_direction_matches_the_generator():
    """A partial unloading while the state still creeps up: the state's switch keeps creeping,
    the load's direction switches to recovery; the model file's ``switch`` picks the latter."""
    t = np.arange(0, 200, 0.25)
    prog = programs.staircase([2.0, 1.5, 1.8, 0.0], hold=20.0, start=20.0)
    u = prog.sample(t)
    spec = synth.Spec(hidden={"asymmetric_recovery": {"form": "direction", "tau_recovery": 120.0}},
                      beta=(0.04,), tau=(40.0,), gain=1.5, offset=0.2, rate=4.0, full_scale=2.0)
    ref = synth.simulate_signal(spec, prog, t)
    entry = {"tau": 40.0, "tau_recovery": 120.0}
    by_state, by_direction = (simulate_extended(CreepModel((0.04,), (40.0,), gain=1.5, offset=0.2,
                                                           extensions={"asymmetric_recovery": e}), t, u)
                              for e in (entry, dict(entry, switch="direction")))
    steps = np.array(prog.times)[np.flatnonzero(np.diff(prog.times) == 0)]
    away = np.all(np.abs(t[:, None] - steps[None, :]) > 1.0, axis=1)
    assert np.max(np.abs(by_direction - ref)[away]) < 3e-4 * np.ptp(ref)
    assert np.max(np.abs(by_state - ref)[away]) > 10 * np.max(np.abs(by_direction - ref)[away])
    with pytest.raises(InputError, match="unknown switch"):
        simulate_extended(CreepModel((0.04,), (40.0,), gain=1.5, offset=0.2,
                                     extensions={"asymmetric_recovery": dict(entry, switch="moon")}), t, u)


def test_nonlinear_creep_needs_more_than_one_load_level():
    """Between zero and one level, creep that depends on the level is recovery at another
    speed: the template is not tried; a staircase through several levels allows it."""
    from creepcomp.fit.structure import Structure

    t = np.arange(0, 820, 0.25)
    one = programs.staircase([2.0, 0.0, 2.0, 0.0], hold=160.0, start=20.0).sample(t)
    effect = effects.get("nonlinear_creep")
    assert "one level" in effect.applicable(effects.arrays_data(t, one), Structure(1))
    assert effect.applicable(effects.arrays_data(t, _staircase(t)[1]), Structure(1)) is None


def test_an_extra_term_at_a_base_terms_time_constant_is_refused():
    """An extra term within 5 % of the base term's tau is one term, not a finding; one a decade
    away is a finding."""
    from creepcomp.fit.data import prepare
    from creepcomp.fit.prony import fit_terms
    from creepcomp.fit.solver import fit_structure
    from creepcomp.fit.structure import Applied
    from creepcomp.io.records import Record
    from creepcomp.lti import lag_states

    t = np.arange(0.0, 600.0, 0.5)
    load = np.where(t >= 20.0, 1.0, 0.0)
    signal = load + 0.03 * lag_states(t, load, [45.0])[:, 0]
    signal = signal + np.random.default_rng(1).normal(0.0, 1e-4, t.size)
    data = prepare(Record(t, load, signal), initial="relaxed")
    base = fit_terms(data, 1)
    effect = effects.get("extra_retardation")
    applied = Applied(effect, effect.settings(data, base))
    structure = effect.extend(base.structure, applied)
    reasons = {}
    for extra in (1.02 * base.taus[0], 4.5):
        start = {"tau[0]": float(base.taus[0]), "tau[1]": float(extra)}
        fit = fit_structure(data, structure, [start], refine=False, with_cov=False)
        reasons[extra] = effect.unphysical(fit, applied)
    close, far = reasons.values()
    assert close is not None and "within 5 %" in close
    assert far is None
