"""``creepcomp correct`` applies the extensions the diagnosis writes, each undone by its effect."""

import json

import numpy as np
import pytest

from creepcomp.diagnose.effects import (REGISTRY, SensorEffect, compensate_extended, extension_inverses,
                                        simulate_extended)
from creepcomp.errors import InputError
from creepcomp.io.records import Record, write_record
from creepcomp.model import CreepModel

#: One extension of every kind the diagnosis writes (``direction``: the second switch).
EXTENSIONS = {
    "static_nonlinearity": {"a2": 0.02, "a3": -0.01, "load_scale": 10.0},
    "nonlinear_creep": {"growth": 0.2, "acceleration": 0.3, "load_scale": 10.0},
    "asymmetric_recovery": {"tau": 45.0, "tau_recovery": 150.0},
    "asymmetric_recovery/direction": {"tau": 45.0, "tau_recovery": 150.0, "switch": "direction"},
    "viscous_flow": {"rate": 1e-5},
    "time_offset": {"delay": 0.7},
    "transition_overshoot": {"amplitude": 0.002, "tau": 5.0, "load_scale": 10.0},
    "rate_independent_hysteresis": {"width": 0.5, "weight": 0.01},
    "mullins_softening": {"softening": 0.2},
    "mullins_softening/stiffer": {"softening": -0.05, "shape": -3.9},
    "thermal_drift": {"coefficient": 1e-4, "reference_temperature": 25.0, "lag": 30.0},
    "thermal_retardation": {"kappa": 0.05, "reference_temperature": 25.0},
}

T = np.arange(0, 600, 0.5)
LOAD = np.select([T < 100, T < 250, T < 330, T < 450], [0.0, 10.0, 4.0, 7.0], 0.0) + 0.5 * np.sin(T / 13) * (T > 100)
TEMPERATURE = 25 + 10 * np.sin(T / 200)


def _model(key: str) -> CreepModel:
    return CreepModel.from_dict({"beta": [0.03, 0.01], "tau": [45.0, 5.0], "gain": 0.05, "offset": 0.002,
                                 "extensions": {key.split("/")[0]: EXTENSIONS[key]}})


@pytest.mark.parametrize("key", sorted(EXTENSIONS))
@pytest.mark.parametrize("hold", ["zero", "linear"])
def test_every_extension_is_undone_exactly_and_causally(key, hold):
    model = _model(key)
    y = simulate_extended(model, T, LOAD, TEMPERATURE, "relaxed", hold)
    comp = compensate_extended(T, y, model, TEMPERATURE, "relaxed", hold, strict=True)
    load = (comp - model.offset) / model.gain
    # a delay's last samples are answered after the record ends (its latency)
    known = T <= T[-1] - (1.0 if key == "time_offset" else 0.0)
    assert np.max(np.abs(load - LOAD)[known]) < 1e-7
    # causal: the first part of the record corrected alone gives the same samples
    part = compensate_extended(T[:700], y[:700], model, TEMPERATURE[:700], "relaxed", hold, strict=True)
    settled = T[:700] <= T[699] - (1.0 if key == "time_offset" else 0.0)
    assert np.max(np.abs(part - comp[:700])[settled]) < 1e-9 * np.ptp(y)


@pytest.mark.parametrize("key", sorted(EXTENSIONS))
def test_every_extension_is_undone_exactly_from_a_settled_start(key):
    model = _model(key)
    loaded = LOAD + 3.0
    y = simulate_extended(model, T, loaded, TEMPERATURE, "settled", "linear")
    comp = compensate_extended(T, y, model, TEMPERATURE, "settled", "linear", strict=True)
    known = T <= T[-1] - (1.0 if key == "time_offset" else 0.0)
    assert np.max(np.abs((comp - model.offset) / model.gain - loaded)[known]) < 1e-7


def test_a_flow_from_a_settled_start_is_undone_in_a_few_steps():
    # the flow's equivalent term starts relaxed (a dashpot has no settled state): the linear
    # inverse then matches the model and the steps settle at once
    model = _model("viscous_flow")
    loaded = LOAD + 3.0
    y = simulate_extended(model, T, loaded, None, "settled", "linear")
    comp = compensate_extended(T, y, model, None, "settled", "linear", strict=True, max_iterations=5)
    assert np.max(np.abs((comp - model.offset) / model.gain - loaded)) < 1e-12


def test_every_extension_the_diagnosis_writes_says_how_it_is_undone():
    for key in EXTENSIONS:
        how = extension_inverses(_model(key))
        assert set(how) == {key.split("/")[0]} and all(len(h) > 20 for h in how.values())


@pytest.mark.parametrize("name, entry", [
    ("static_nonlinearity", {"a2": 0.6, "a3": 0.0, "load_scale": 1.0}),     # falls beyond 0.8 FS
    ("mullins_softening", {"softening": 1.2}),                             # reloading reverses
    ("rate_independent_hysteresis", {"width": 0.01, "weight": 0.06}),       # dead band falls
])
def test_an_extension_that_cannot_be_undone_is_refused_by_name(name, entry):
    model = CreepModel((0.03,), (45.0,), gain=0.05, offset=0.0, extensions={name: entry})
    with pytest.raises(InputError, match=f"extension '{name}' cannot be inverted.*baseline-model.json"):
        extension_inverses(model)


class _Unknowable(SensorEffect):
    """An effect without an inverse (the default of the hook)."""
    name = "unknowable_test_effect"
    vocabulary_index = 99
    forms = ("plain",)

    def draw(self, rng, scales, form):
        return {}

    def restore(self, entry, model, data):
        from creepcomp.fit.structure import Applied
        return Applied(self, ()), {}


def test_an_effect_without_an_inverse_is_refused_on_one_line(run_cli, tmp_path):
    from creepcomp.diagnose.effects import register, unregister

    register(_Unknowable())
    try:
        write_record(tmp_path / "r.csv", Record(T, LOAD, 0.05 * LOAD))
        model = tmp_path / "m.json"
        model.write_text(json.dumps({"beta": [0.03], "tau": [45.0], "gain": 0.05, "offset": 0.0,
                                     "extensions": {"unknowable_test_effect": {}}}))
        status, out, err = run_cli("correct", tmp_path / "r.csv", "--model", model)
    finally:
        unregister("unknowable_test_effect")
    assert status == 2 and "Traceback" not in err
    message = " ".join(err.split())
    assert "'unknowable_test_effect' cannot be inverted" in message and "--model baseline-model.json" in message


def test_correct_with_the_extended_model_beats_the_baseline(run_cli, tmp_path):
    """A sensor that recovers slower than it creeps: the extended model corrects it to the
    noise, the linear model fitted to it cannot; the printed figures are those of the exact
    inverse (shared with the diagnosis's correction errors)."""
    from creepcomp.digital.correctors import fitted_reference_error

    model = _model("asymmetric_recovery")
    rng = np.random.default_rng(3)
    y = simulate_extended(model, T, LOAD, hold="zero") + 2e-5 * rng.standard_normal(len(T))
    write_record(tmp_path / "r.csv", Record(T, LOAD, y, metadata={"units.signal": "V"}))
    (tmp_path / "model.json").write_text(json.dumps(model.to_dict()))
    (tmp_path / "baseline-model.json").write_text(json.dumps(
        {"beta": [0.035], "tau": [60.0], "gain": 0.05, "offset": 0.002}))
    figures = {}
    for name in ("model", "baseline-model"):
        status, out, err = run_cli("correct", tmp_path / "r.csv", "--model", tmp_path / f"{name}.json", "--json")
        assert status == 0, err
        figures[name] = json.loads(out)
    ext, base = figures["model"], figures["baseline-model"]
    assert ext["extensions"] and not base["extensions"]
    assert base["creep_error"]["after"]["rms"] / ext["creep_error"]["after"]["rms"] > 2.5
    assert ext["creep_error"]["after"]["rms"] < 3e-5
    comp = compensate_extended(T, y, model, initial="relaxed", hold="zero")
    assert ext["fitted_reference_rms"]["after"] == pytest.approx(
        float(np.sqrt(np.mean(fitted_reference_error(comp, LOAD) ** 2))), rel=1e-5)


def test_a_temperature_extension_needs_the_records_temperature(run_cli, tmp_path):
    write_record(tmp_path / "r.csv", Record(T, LOAD, 0.05 * LOAD))
    (tmp_path / "m.json").write_text(json.dumps(_model("thermal_retardation").to_dict()))
    status, _, err = run_cli("correct", tmp_path / "r.csv", "--model", tmp_path / "m.json")
    assert status == 2 and "temperature" in err and "Traceback" not in err


def test_a_diagnosed_thermal_retardation_model_is_corrected_by_its_extension(run_cli, tmp_path):
    """The diagnosis writes the temperature block of the same slope beside the extension: the
    correction applies the extension (the form fitted) and not the block as well."""
    from creepcomp.temperature import TemperatureLaw

    base = _model("thermal_retardation")
    law = TemperatureLaw.from_kappa(0.05, 25.0)
    model = CreepModel.from_dict({**base.to_dict(), "temperature": law.to_dict()})
    assert model.temperature is not None and set(extension_inverses(model)) == {"thermal_retardation"}
    y = simulate_extended(base, T, LOAD, TEMPERATURE, "relaxed", "zero")
    write_record(tmp_path / "r.csv", Record(T, LOAD, y, temperature=TEMPERATURE))
    (tmp_path / "m.json").write_text(json.dumps(model.to_dict()))
    status, out, err = run_cli("correct", tmp_path / "r.csv", "--model", tmp_path / "m.json",
                               "--hold", "zero", "--initial", "relaxed", "--json")
    assert status == 0, err
    result = json.loads(out)
    assert result["temperature"]["source"] == "column"
    assert result["creep_error"]["after"]["peak"] < 1e-6 * result["creep_error"]["before"]["peak"]
    # a block that restates no extension still cannot go with one
    other = CreepModel.from_dict({**_model("viscous_flow").to_dict(), "temperature": law.to_dict()})
    with pytest.raises(InputError, match="temperature law cannot be applied together"):
        extension_inverses(other)


@pytest.mark.slow
def test_the_demo_records_extended_model_corrects_as_the_diagnosis_says(run_cli, tmp_path):
    from importlib.resources import files

    record = files("creepcomp.data") / "hidden_effect.csv"
    status, _, err = run_cli("diagnose", record, "-o", tmp_path, "--json")
    assert status == 0, err
    gain = json.loads((tmp_path / "diagnosis.json").read_text())["gain"]
    figures = {}
    for name in ("model", "baseline-model"):
        status, out, err = run_cli("correct", record, "--model", tmp_path / f"{name}.json", "--json")
        assert status == 0, err
        figures[name] = json.loads(out)
    ext, base = figures["model"], figures["baseline-model"]
    assert base["creep_error"]["after"]["peak"] / ext["creep_error"]["after"]["peak"] >= 2.5
    assert base["creep_error"]["after"]["rms"] / ext["creep_error"]["after"]["rms"] >= 2.5
    assert ext["fitted_reference_rms"]["after"] == pytest.approx(gain["correction_error_extended"], rel=0.01)
    assert base["fitted_reference_rms"]["after"] == pytest.approx(gain["correction_error_baseline"], rel=0.01)


def test_every_effect_that_writes_an_extension_is_checked_here():
    """A new effect that writes a model-file entry must say how the correction undoes it."""
    from creepcomp.diagnose.effects import Effect

    writers = {name for name, effect in REGISTRY.items()
               if effect.side == "sensor" and type(effect).extension is not Effect.extension
               and not getattr(effect, "describes_record", False)}
    assert writers == {key.split("/")[0] for key in EXTENSIONS}


@pytest.mark.parametrize("key", ["thermal_retardation"])
def test_firmware_refuses_an_extension_it_cannot_write_by_name(run_cli, tmp_path, key):
    (tmp_path / "m.json").write_text(json.dumps(_model(key).to_dict()))
    status, _, err = run_cli("firmware", tmp_path / "m.json", "-o", tmp_path / "c")
    message = " ".join(err.split())
    assert status == 2 and "Traceback" not in err
    assert f"extension '{key}' has no C corrector" in message and "baseline-model.json" in message
    assert not (tmp_path / "c").exists()


def test_firmware_of_a_static_nonlinearity_matches_correct_within_its_bound(run_cli, tmp_path):
    from creepcomp.digital.firmware import generate_firmware

    t = np.arange(0, 200, 0.01)
    load = np.select([t < 20, t < 80, t < 120], [0.0, 10.0, 4.0], 7.0) + 0.5 * np.sin(t / 3)
    model = CreepModel.from_dict({"beta": [0.03, 0.01], "tau": [45.0, 5.0], "gain": 0.05, "offset": 0.002,
                                  "extensions": {"static_nonlinearity": {"a2": 0.03, "a3": -0.02,
                                                                         "load_scale": 10.0}}})
    y = simulate_extended(model, t, load, hold="zero") + 1e-5 * np.random.default_rng(1).standard_normal(len(t))
    write_record(tmp_path / "r.csv", Record(t, load, y))
    (tmp_path / "m.json").write_text(json.dumps(model.to_dict()))
    status, out, err = run_cli("firmware", tmp_path / "m.json", "--verify", tmp_path / "r.csv", "-o",
                               tmp_path / "c", "--json")
    assert status == 0, err
    result = json.loads(out)
    assert result["extensions"] == ["static_nonlinearity"] and result["within_bound"]
    assert 0 < result["max_error_fs"] <= result["bound_fs"] < 1e-6
    assert "creep_root" in (tmp_path / "c" / "creep.c").read_text()
    # the linear part alone would be off by the polynomial: the check compares with correct
    linear = generate_firmware(CreepModel(model.beta, model.tau, model.gain, model.offset),
                               rate=100.0, full_scale=result["full_scale"])
    assert linear.bound.total_fs < result["bound_fs"]
