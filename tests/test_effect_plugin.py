"""A sensor effect defined outside the package, as one class registered at run time, is made by
the generator and found by the diagnosis: a new effect is one new module."""

from dataclasses import replace

import numpy as np
import pytest

from creepcomp import synth
from creepcomp.diagnose import effects
from creepcomp.diagnose.effects import SensorEffect
from creepcomp.diagnose.sensor import diagnose
from creepcomp.errors import InputError

NAME = "step_ratchet"


def _changes(load: np.ndarray, scale: float) -> np.ndarray:
    """How many times the load has changed (by more than 1 % of ``scale``) up to each sample."""
    moved = np.abs(np.diff(load, prepend=load[0])) > 0.01 * scale
    return np.cumsum(moved).astype(float)


class StepRatchet(SensorEffect):
    """Every load change moves the signal's zero by ``shift`` (signal units), for good: a
    ratchet no other template describes (not a jump without a load change, not proportional
    to the change's size, not decaying)."""

    name = NAME
    parameters = ("shift",)
    summary = "a zero that moves by the same amount at every load change"
    vocabulary_index = 100
    forms = ("constant",)
    programs = ("staircase",)

    # -- diagnosis template: one linear column --------------------------------------------------
    def settings(self, data, base):
        return (("load_scale", data.load_scale),)

    def columns(self, data, s, h, lags, p, applied):
        return {"shift": _changes(data.load, applied.setting("load_scale"))}

    def report(self, fit, applied):
        return {"shift": fit.estimate(lambda v: v[f"{NAME}.shift"])}

    # -- generator ----------------------------------------------------------------------------
    def draw(self, rng, scales, form):
        return {"shift": float(rng.choice([-1, 1]) * rng.uniform(0.01, 0.02) * scales.signal_scale)}

    def truth(self, p, synthetic):
        return {"shift": p["shift"]}

    def sim_output(self, path, p, y):
        stepped = path.u_after != path.u_before
        return y + p["shift"] * np.cumsum(stepped)


@pytest.fixture
def ratchet():
    effect = effects.register(StepRatchet())
    try:
        yield effect
    finally:
        effects.unregister(NAME)


def test_a_registered_effect_is_generated_and_diagnosed(ratchet):
    assert ratchet in effects.sensor_effects() and effects.sensor_effects()[-1] is ratchet
    syn = synth.random_record(NAME, 3, max_samples=1500, duration=(600.0, 1200.0), noise=(2e-4, 5e-4))
    truth = synth.reported_truth(syn)[NAME]
    assert syn.spec.program == "staircase" and truth["shift"] != 0.0
    # the generator applied the effect's own forward model: the zero moves at each load change
    t = syn.record.time
    made = synth.simulate_signal(syn.spec, syn.program, t) - \
        synth.simulate_signal(replace(syn.spec, hidden={}), syn.program, t)
    steps = _changes(syn.record.load, syn.spec.full_scale)
    np.testing.assert_allclose(made - made[0], truth["shift"] * steps, rtol=1e-9, atol=1e-12)
    d = diagnose(syn.record)
    assert [f.effect for f in d.findings] == [NAME]
    # the shift is recovered to 2 %
    assert d.findings[0].parameters["shift"] == pytest.approx(truth["shift"], rel=0.02)


def test_registering_refuses_a_duplicate_and_cleans_up(ratchet):
    with pytest.raises(InputError, match="registered already"):
        effects.register(StepRatchet())
    with pytest.raises(InputError, match="registered already"):
        effects.register(effects.get("viscous_flow"))


def test_a_sensor_side_effect_must_be_a_sensor_effect():
    class Plain(effects.Effect):
        name = "plain_sensor_effect"

    with pytest.raises(InputError, match="a sensor-side effect is a SensorEffect"):
        effects.register(Plain())
    assert "plain_sensor_effect" not in effects.REGISTRY


def test_the_plugin_leaves_no_trace():
    assert NAME not in effects.REGISTRY
    with pytest.raises(InputError, match="unknown effect"):
        synth.random_spec(NAME, 0)


def test_a_sensor_effect_must_give_its_interface():
    class Incomplete(SensorEffect):
        name = "incomplete"

    with pytest.raises(TypeError, match="abstract"):
        Incomplete()
