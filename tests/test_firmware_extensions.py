"""The C corrector of a model with an extension of the diagnosis: it compiles strictly without
libm, does what ``creepcomp correct`` does (the measured error against it stays within the
proven bound), keeps its extension's state words across a power cycle, and refuses by name
what it cannot write."""

from __future__ import annotations

import json
import re
import shutil
import subprocess

import numpy as np
import pytest

from creepcomp.diagnose.effects import compensate_extended, firmware_output, simulate_extended
from creepcomp.digital.firmware import generate_firmware
from creepcomp.digital.firmware_check import STRICT_FLAGS, compile_object, verify_firmware
from creepcomp.errors import InputError
from creepcomp.io.records import Record, write_record
from creepcomp.model import CreepModel

needs_gcc = pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is not installed")

#: One extension of every kind the C corrector writes, in model-file form.
EXTENSIONS = {
    "mullins_softening": {"softening": 0.2, "shape": 0.0},
    "mullins_softening/shaped": {"softening": 0.25, "shape": 4.0},
    "mullins_softening/stiffer": {"softening": -0.05, "shape": -3.9},
    "mullins_softening/peak": {"softening": 0.15, "form": "peak", "load_scale": 10.0},
    "rate_independent_hysteresis": {"width": 0.8, "weight": 0.004},
    "rate_independent_hysteresis/negative": {"width": 0.5, "weight": -0.01},
    "asymmetric_recovery": {"tau": 45.0, "tau_recovery": 150.0},
    "asymmetric_recovery/fast": {"tau": 45.0, "tau_recovery": 9.0},
    "transition_overshoot": {"amplitude": 0.002, "tau": 5.0, "exponent": 1.0, "load_scale": 10.0},
    "transition_overshoot/stretched": {"amplitude": -0.001, "tau": 3.0, "exponent": 0.7, "load_scale": 10.0},
}

RATE = 10.0
T = np.arange(0, 600, 1 / RATE)
#: Steps up and down (a partial unloading, a new largest load), a sweep through zero, swings.
LOAD = (np.select([T < 50, T < 150, T < 200, T < 260, T < 330, T < 420], [0.0, 10.0, 4.0, 7.0, 12.0, -6.0], 0.0)
        + 0.8 * np.sin(T / 7) * (T > 50) + np.where((T > 540) & (np.arange(len(T)) % 2 == 0), 3.0, 0.0))


def _model(key: str) -> CreepModel:
    return CreepModel.from_dict({"beta": [0.03, 0.01], "tau": [45.0, 5.0], "gain": 0.05, "offset": 0.002,
                                 "extensions": {key.split("/")[0]: EXTENSIONS[key]}})


def _linear(model: CreepModel) -> CreepModel:
    return CreepModel(model.beta, model.tau, model.gain, model.offset)


#: The load without the swings.
CALM = np.where(T > 540, 0.0, LOAD)


def _record(model: CreepModel, seed: int = 0, quiet_start: bool = False, load=LOAD):
    """The model's signal with noise (from the first load on only, ``quiet_start``)."""
    noise = 2e-5 * np.random.default_rng(seed).standard_normal(len(T))
    if quiet_start:
        noise[:np.argmax(load != 0)] = 0.0
    return simulate_extended(model, T, load, hold="zero") + noise


#: Each kind with its precisions: q31 carries all but the overshoot and a shaped reloading curve.
CASES = [(key, "float32") for key in sorted(EXTENSIONS)] + [
    (key, "q31") for key in sorted(EXTENSIONS)
    if not key.startswith("transition_overshoot") and key not in ("mullins_softening/shaped",
                                                                  "mullins_softening/stiffer")]


@needs_gcc
@pytest.mark.parametrize("key, precision", CASES)
def test_measured_error_against_correct_within_the_bound(key, precision):
    model = _model(key)
    # a recovery's state switch decides by the state's sign: noise at rest would leave it to chance
    # an overshoot's bound needs a load that turns seldom within its decay (not the swings)
    y = _record(model, quiet_start=key.startswith("asymmetric_recovery"),
                load=CALM if key.startswith("transition_overshoot") else LOAD)
    reference = compensate_extended(T, y, model, initial="relaxed", hold="zero", strict=True)
    full_scale = float(np.max(np.abs(y - model.offset)))
    fw = generate_firmware(_linear(model), precision=precision, rate=RATE, full_scale=full_scale,
                           extension=firmware_output(model))
    check = verify_firmware(fw, T, y, repeats=1, reference=reference)
    # a recovery's decisions near their threshold (the load held, the noise) add to its bound
    assert check.passed and 0 < check.max_error_fs <= check.bound_fs < 2e-5, (check, fw.bound.terms)
    assert fw.bound.total_fs < 2e-6
    # the extension matters: the linear corrector's output is far from correct's
    plain = verify_firmware(generate_firmware(_linear(model), precision=precision, rate=RATE,
                                              full_scale=full_scale), T, y, repeats=1, reference=reference)
    assert plain.max_error_fs > 100 * check.bound_fs
    if precision == "q31":
        assert check.bound_fs < 5e-8
    if key.startswith("asymmetric_recovery"):
        assert check.switching is not None and check.switching["steps"] >= 0
        assert check.bound_fs == pytest.approx(fw.bound.total_fs + check.switching["added_fs"])
    if key.startswith("transition_overshoot"):
        assert check.switching["events"] >= 1 and check.bound_fs >= fw.bound.total_fs


@needs_gcc
def test_an_overshoot_on_a_load_that_turns_every_sample_has_no_bound():
    model = _model("transition_overshoot")
    y = _record(model)
    reference = compensate_extended(T, y, model, initial="relaxed", hold="zero", strict=True)
    fw = generate_firmware(_linear(model), rate=RATE, full_scale=float(np.max(np.abs(y - model.offset))),
                           extension=firmware_output(model))
    with pytest.raises(InputError, match=r"the load turns [\d.]+ times, discounted, within its decay\): no error bound"):
        verify_firmware(fw, T, y, repeats=1, reference=reference)


@needs_gcc
@pytest.mark.parametrize("key", ["mullins_softening/shaped", "rate_independent_hysteresis", "asymmetric_recovery",
                                 "transition_overshoot/stretched"])
def test_compiles_strictly_without_libm_and_names_its_state_words(tmp_path, key):
    model = _model(key)
    fw = generate_firmware(_linear(model), rate=RATE, full_scale=1.0, extension=firmware_output(model))
    obj = compile_object(fw, tmp_path, flags=("-O0",))
    undefined = set(subprocess.run(["nm", "-u", obj], capture_output=True, text=True,
                                   check=True).stdout.split()) - {"U"}
    assert undefined <= {"memcpy"}, undefined
    assert "math.h" not in re.sub(r"/\*.*?\*/", "", fw.source, flags=re.S)
    out = firmware_output(model)
    words = 2 + len(out["overshoot"]["taus"]) if "overshoot" in out else 2 if "recovery" in out else 1
    assert f"#define CREEP_EXTENSION_WORDS {words}" in fw.header and "double ext[CREEP_EXTENSION_WORDS]" in fw.header
    assert f"{fw.bound.total_fs:.3e}" in fw.header


SAVE_RESTORE_TEST = r"""
#include <stdio.h>
#include "creep.h"
int main(void)
{
    creep_state a, b;
    creep_saved block;
    int i, bad = 0;
    creep_init(&a);
    for (i = 0; i < 500; ++i) (void)creep_step(&a, i < 100 ? 0.002f : 0.5f);
    for (i = 0; i < 50; ++i) (void)creep_step(&a, 0.2f);
    creep_save(&a, &block);
    creep_init(&b);
    if (creep_restore(&b, &block) != 0) return 10;
    for (i = 0; i < 3000; ++i) {
        const float x = (i / 40) % 2 ? 0.3f : 0.1f;
        bad |= creep_step(&a, x) != creep_step(&b, x);
    }
    printf("%d %d\n", bad, (int)CREEP_SAVED_WORDS);
    return 0;
}
"""


@needs_gcc
@pytest.mark.parametrize("key, precision", [
    ("mullins_softening", "float32"), ("rate_independent_hysteresis", "float32"),
    ("asymmetric_recovery", "float32"), ("transition_overshoot", "float32"), ("asymmetric_recovery", "q31"),
    ("rate_independent_hysteresis", "q31"), ("mullins_softening", "q31")])
def test_extension_state_saved_and_restored_across_a_power_cycle(tmp_path, key, precision):
    model = _model(key)
    fw = generate_firmware(_linear(model), precision=precision, rate=RATE, full_scale=1.0,
                           extension=firmware_output(model))
    obj = compile_object(fw, tmp_path)
    test = SAVE_RESTORE_TEST
    if precision == "q31":        # words: 2^30 per full scale
        for value in ("0.002f", "0.5f", "0.2f", "0.3f", "0.1f"):
            test = test.replace(value, str(round(float(value[:-1]) * 2 ** 30)))
        test = test.replace("const float x", "const int32_t x")
    (tmp_path / "main.c").write_text(test)
    exe = tmp_path / "main"
    subprocess.run(["gcc", *STRICT_FLAGS, "-I", tmp_path, tmp_path / "main.c", obj, "-o", exe], check=True)
    out = subprocess.run([exe], capture_output=True, text=True, check=True).stdout.split()
    words = {"asymmetric_recovery": 2, "transition_overshoot": 3}.get(key, 1)
    assert out == ["0", str(2 + 2 * 2 + 2 * words)]      # identical continuation


def test_recovery_decisions_near_their_threshold_add_to_the_bound():
    from creepcomp.digital.firmware_extension import recovery_ambiguity

    model = _model("asymmetric_recovery")
    fw = generate_firmware(_linear(model), rate=RATE, full_scale=1.0, extension=firmware_output(model))
    check = fw.extension
    assert check["margin"] > 0 and check["switch_gain"] > 0
    t = np.arange(30000) / RATE
    held = np.where(t > 10, 0.5, 0.0)
    # the state still moving towards the load: every decision clear
    clear = recovery_ambiguity(check, t[:3000], model.offset + held[:3000], model.offset)
    assert clear["steps"] == 0 and clear["added_fs"] == 0
    # held until the state reaches the load: decisions on a vanishing margin, each adding little
    settled = recovery_ambiguity(check, t, model.offset + held, model.offset)
    assert settled["steps"] > 1000 and 0 < settled["added_fs"] < 1e-5
    # noise at rest leaves the state's sign to chance: a step then may go either way
    noisy = held + np.where(t <= 10, 1e-6 * np.random.default_rng(0).standard_normal(len(t)), 0.0)
    chance = recovery_ambiguity(check, t, model.offset + noisy, model.offset)
    assert chance["largest"] >= 0.49 and chance["added_fs"] > 0.01


@pytest.mark.parametrize("kwargs, message", [
    ({"precision": "q31"}, "float32 only"),
    ({"method": "supplemental"}, "subtractive method only"),
    ({"max_interval": 0.2}, "fixed rate only")])
def test_other_variants_are_refused_by_name(kwargs, message):
    model = _model("transition_overshoot")
    with pytest.raises(InputError, match=message) as info:
        generate_firmware(_linear(model), **{"rate": RATE, "full_scale": 1.0, **kwargs},
                          extension=firmware_output(model))
    assert "decaying transient" in str(info.value)


def test_q31_refuses_a_shaped_reloading_curve_by_name():
    model = _model("mullins_softening/shaped")
    with pytest.raises(InputError, match="reloading curve is shaped .* float32 only"):
        generate_firmware(_linear(model), precision="q31", rate=RATE, full_scale=1.0,
                          extension=firmware_output(model))


def test_the_direction_switch_is_refused_by_name():
    model = CreepModel.from_dict({"beta": [0.03], "tau": [45.0], "gain": 0.05, "offset": 0.0,
                                  "extensions": {"asymmetric_recovery": {
                                      "tau": 45.0, "tau_recovery": 150.0, "switch": "direction"}}})
    with pytest.raises(InputError, match="'asymmetric_recovery' switched by the load's direction has no C corrector"):
        firmware_output(model)


def test_no_bound_when_the_inverse_gain_meets_the_creep_coupling():
    model = CreepModel.from_dict({"beta": [0.6], "tau": [45.0], "gain": 0.05, "offset": 0.0,
                                  "extensions": {"rate_independent_hysteresis": {"width": 0.5, "weight": 0.04}}})
    with pytest.raises(InputError, match="no error bound"):
        generate_firmware(_linear(model), rate=RATE, full_scale=1.0, extension=firmware_output(model))


@needs_gcc
def test_cli_verifies_an_extended_model_against_correct(run_cli, tmp_path):
    model = _model("mullins_softening/peak")
    y = _record(model, seed=2)
    write_record(tmp_path / "r.csv", Record(T, LOAD, y))
    (tmp_path / "m.json").write_text(json.dumps(model.to_dict()))
    status, out, err = run_cli("firmware", tmp_path / "m.json", "--verify", tmp_path / "r.csv",
                               "-o", tmp_path / "c", "--json")
    assert status == 0, err
    result = json.loads(out)
    assert result["extensions"] == ["mullins_softening"] and result["within_bound"]
    assert 0 < result["max_error_fs"] <= result["bound_fs"] < 5e-6
    assert "creep_solve" in (tmp_path / "c" / "creep.c").read_text()
    status, _, err = run_cli("firmware", tmp_path / "m.json", "--rate", "10", "--full-scale", "1",
                             "--precision", "q31", "--method", "supplemental")
    assert status == 2 and "subtractive method only" in " ".join(err.split()) and "Traceback" not in err


@needs_gcc
@pytest.mark.parametrize("key, says", [("asymmetric_recovery", "mode decisions within the switching margin"),
                                       ("transition_overshoot", "the load's turns within the overshoot's decay")])
def test_cli_prints_the_bound_on_the_record(run_cli, tmp_path, key, says):
    model = _model(key)
    y = _record(model, quiet_start=True, load=CALM)
    write_record(tmp_path / "r.csv", Record(T, CALM, y))
    (tmp_path / "m.json").write_text(json.dumps(model.to_dict()))
    status, out, err = run_cli("firmware", tmp_path / "m.json", "--verify", tmp_path / "r.csv",
                               "--precision", "q31" if key == "asymmetric_recovery" else "float32")
    text = " ".join(out.split())
    assert status == 0, err
    assert says in text and "bound on this record" in text and "within the bound" in text


def test_cli_keeps_the_temperature_law_of_a_model_with_an_extension(run_cli, tmp_path):
    """An extension map and a temperature law have no C corrector together: refused, not
    written without the law."""
    from creepcomp.io.jsonfiles import write_model
    from creepcomp.temperature import TemperatureLaw

    model = CreepModel((0.01,), (5.0,), 1.0, 0.0, {"mullins_softening": EXTENSIONS["mullins_softening"]},
                       temperature=TemperatureLaw.arrhenius(43000.0))
    path = write_model(tmp_path / "model.json", model)
    status, out, err = run_cli("firmware", path, "--rate", "100", "--full-scale", "1")
    assert status == 2 and out == "" and err.count("\n") == 1 and "temperature law" in err
