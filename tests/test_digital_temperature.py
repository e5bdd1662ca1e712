"""Digital correction over temperature: each step with its own tau_k(T), exact."""

import json
import re
import shutil
import subprocess

import numpy as np
import pytest

from creepcomp.data import default_sensor
from creepcomp.digital.correctors import Corrector, compensate
from creepcomp.digital.firmware import generate_firmware
from creepcomp.digital.firmware_check import STRICT_FLAGS, compile_object, run_firmware, verify_firmware
from creepcomp.digital.record_file import correct_record_file
from creepcomp.errors import InputError
from creepcomp.io.jsonfiles import write_model
from creepcomp.io.records import Record, read_record, write_record
from creepcomp.lti import varying_lag_states
from creepcomp.model import CreepModel
from creepcomp.temperature import TemperatureLaw

LAW = TemperatureLaw.arrhenius(43000.0, 20.0)
FULL_LOAD = 100.0


def ramp_sensor(beta_per_kelvin=()) -> CreepModel:
    """The default sensor with an Arrhenius law of 43 kJ/mol about 20 °C."""
    base = default_sensor()
    law = TemperatureLaw.arrhenius(43000.0, 20.0, beta_per_kelvin)
    return CreepModel(base.beta, base.tau, base.gain, base.offset, temperature=law)


def ramp_record(seed: int = 0, noise: bool = False, irregular: bool = False, n: int = 36_000):
    """Time, load and temperature of a 10 -> 40 °C ramp under a random staircase of loads
    (with ``noise``: load and temperature jitter at every sample)."""
    rng = np.random.default_rng(seed)
    t = (np.cumsum(rng.uniform(0.05, 0.15, n)) if irregular else np.arange(n) * 0.1)
    temperature = 10.0 + 30.0 * (t - t[0]) / (t[-1] - t[0])
    levels = rng.uniform(0.0, FULL_LOAD, n // 500 + 1)
    load = np.repeat(levels, 500)[:n]
    load[:200] = 0.0
    if noise:
        load = np.clip(load + rng.normal(0.0, 0.5, n), 0.0, FULL_LOAD)
        temperature = temperature + rng.normal(0.0, 0.2, n)
    return t, load, temperature


def exact_states(model, t, load, temperature, hold, initial="relaxed"):
    """Independent simulation of the sensor (the lag states of each term, then the signal)."""
    taus = np.array(model.tau) * model.temperature.shift(0.5 * (temperature[1:] + temperature[:-1]))[:, None]
    betas = np.array(model.beta) * model.temperature.beta_factor(temperature, model.n_terms)
    c = varying_lag_states(t, load, taus, hold=hold, initial=initial)
    return model.offset + model.gain * (load + np.sum(betas * c, axis=1))


@pytest.mark.parametrize("hold", ["zero", "linear"])
@pytest.mark.parametrize("noise", [False, True])
def test_ramp_10_to_40_C_is_corrected_exactly(hold, noise):
    model = ramp_sensor()
    t, load, temperature = ramp_record(seed=3, noise=noise)
    signal = model.response(t, load, hold=hold, temperature=temperature)
    np.testing.assert_allclose(signal, exact_states(model, t, load, temperature, hold), rtol=0, atol=1e-15)
    fs = model.gain * FULL_LOAD
    corrected = compensate(t, signal, model, "subtractive", hold=hold, temperature=temperature)
    assert np.max(np.abs(corrected - (model.offset + model.gain * load))) <= 1e-9 * fs
    # the model at its reference temperature leaves creep of the order of beta0 over the ramp
    at_reference = compensate(t, signal, CreepModel(model.beta, model.tau, model.gain, model.offset),
                              "subtractive", hold=hold)
    assert np.max(np.abs(at_reference - (model.offset + model.gain * load))) > 1e-3 * fs


@pytest.mark.parametrize("method,initial", [("subtractive", "relaxed"), ("supplemental", "settled"),
                                            ("supplemental", "relaxed")])
def test_both_methods_irregular_sampling_and_amplitude_law(method, initial):
    model = ramp_sensor(beta_per_kelvin=(0.004,))
    t, load, temperature = ramp_record(seed=5, irregular=True, n=8000)
    load[:200] = 40.0 if initial == "settled" else 0.0
    signal = model.response(t, load, hold="zero", initial=initial, temperature=temperature)
    corrected = compensate(t, signal, model, method, initial=initial, temperature=temperature)
    scale = 1.0 + model.beta0 if method == "supplemental" else 1.0
    expected = model.offset + scale * model.gain * load
    assert np.max(np.abs(corrected - expected)) <= 1e-9 * model.gain * FULL_LOAD


def test_streaming_in_pieces_equals_the_batch():
    model = ramp_sensor()
    t, load, temperature = ramp_record(seed=7, n=5000)
    signal = model.response(t, load, hold="zero", temperature=temperature)
    whole = compensate(t, signal, model, temperature=temperature)
    corrector = Corrector(model, dt=0.1)
    pieces = [corrector.process(signal[i:i + 333], temperature=temperature[i:i + 333])
              for i in range(0, len(t), 333)]
    np.testing.assert_allclose(np.concatenate(pieces), whole, rtol=0, atol=1e-13 * model.gain * FULL_LOAD)


def test_a_law_that_never_shifts_gives_the_time_invariant_numbers():
    model = CreepModel((0.02, 0.01), (5.0, 80.0), 2e-4, 0.01)
    t = np.arange(0.0, 200.0, 0.1)
    load = np.where(t > 5, 50.0, 0.0)
    signal = model.response(t, load, hold="zero")
    # a law with zero activation energy follows the per-step path to the same result
    flat = CreepModel(model.beta, model.tau, model.gain, model.offset,
                      temperature=TemperatureLaw.arrhenius(0.0, 20.0))
    np.testing.assert_allclose(compensate(t, signal, flat, temperature=37.0), compensate(t, signal, model),
                               rtol=0, atol=1e-15)


def test_temperature_and_law_must_come_together():
    t = np.arange(0.0, 10.0, 0.1)
    with pytest.raises(InputError, match="'temperature' column.*--temperature T"):
        compensate(t, t, ramp_sensor())
    with pytest.raises(InputError, match="no temperature law"):
        compensate(t, t, default_sensor(), temperature=20.0)
    with pytest.raises(InputError, match="99 temperatures for 100 samples|temperature has 99"):
        compensate(t, t, ramp_sensor(), temperature=np.full(99, 20.0))


@pytest.fixture
def ramp_files(tmp_path):
    model = ramp_sensor()
    t, load, temperature = ramp_record(seed=11, n=6000)
    signal = model.response(t, load, hold="zero", temperature=temperature)
    record = write_record(tmp_path / "ramp.csv", Record(t, load, signal, temperature=temperature))
    plain = write_record(tmp_path / "plain.csv", Record(t, load, signal))
    return tmp_path, model, write_model(tmp_path / "model.json", model), record, plain, load


def test_record_file_in_pieces_reads_the_temperature_column(ramp_files):
    tmp, model, _, record, plain, load = ramp_files
    done = correct_record_file(record, model, output=tmp / "out.csv", block_bytes=4096)
    assert done.temperature == "column"
    corrected = read_record(tmp / "out.csv")
    assert done.after.peak_fraction <= 1e-9
    with pytest.raises(InputError, match="--temperature"):
        correct_record_file(plain, model)
    with pytest.raises(InputError, match="give one of them"):
        correct_record_file(record, model, temperature=25.0)
    assert corrected.temperature is not None


def test_cli_correct_with_the_column_and_with_a_constant(run_cli, ramp_files):
    tmp, model, model_file, record, plain, load = ramp_files
    status, out, err = run_cli("correct", record, "--model", model_file, "--json")
    assert status == 0, err
    data = json.loads(out)
    assert data["temperature"]["source"] == "column"
    assert data["creep_error"]["after"]["peak_fraction"] <= 1e-9
    status, out, err = run_cli("correct", plain, "--model", model_file, "--temperature", "25C", "--json")
    assert status == 0, err
    assert json.loads(out)["temperature"] == {"source": "constant", "constant_C": 25.0}
    status, out, err = run_cli("correct", plain, "--model", model_file)
    assert status == 2 and "'temperature' column" in err and "--temperature T" in err
    plain_model = write_model(tmp / "plain_model.json", default_sensor())
    status, out, err = run_cli("correct", plain, "--model", plain_model, "--temperature", "25")
    assert status == 2 and "no temperature law" in err
    status, out, err = run_cli("correct", record, "--model", plain_model, "--json")
    assert status == 0 and json.loads(out)["temperature"]["source"] == "unused"
    status, out, err = run_cli("correct", record, "--model", plain_model)
    assert status == 0 and "'temperature' column is not used" in out
    status, out, err = run_cli("correct", plain, "--model", model_file, "--temperature", "hot")
    assert status == 2 and "°C" in err


# ------------------------------------------------------------------------ firmware over temperature

needs_gcc = pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is not installed")


@needs_gcc
@pytest.mark.parametrize("precision", ["float32", "q31"])
@pytest.mark.parametrize("method", ["subtractive", "supplemental"])
def test_firmware_on_the_ramp_record_is_within_its_bound(method, precision):
    model = ramp_sensor()
    t, load, temperature = ramp_record(seed=3, noise=True)
    signal = model.response(t, load, hold="zero", temperature=temperature)
    fw = generate_firmware(model, method, precision, 10.0, float(np.max(np.abs(signal))), "creep")
    check = verify_firmware(fw, t, signal, repeats=1, temperature=temperature)
    assert check.passed and check.max_error_fs <= fw.bound.total_fs
    limit = 1e-6 if precision == "float32" else 5e-9
    assert fw.bound.total_fs < limit and check.max_error_fs > limit / 100   # a real error, bounded
    assert fw.temperature_range == (-40.0, 85.0)
    assert "-40 to 85 °C" in fw.header and "clamps" in fw.header


@needs_gcc
def test_firmware_on_random_jumps_across_the_range_three_terms_and_wlf():
    rng = np.random.default_rng(4)
    laws = [(TemperatureLaw.arrhenius(80000.0, 25.0), (-40.0, 85.0)),
            (TemperatureLaw(20.0, "wlf", c1=8.86, c2=101.6), (0.0, 60.0))]
    for law, (low, high) in laws:
        model = CreepModel((0.02, 0.015, 0.01), (0.5, 30.0, 3000.0), 1.0, 0.3, temperature=law)
        n = 20_000
        t = np.arange(n) / 100.0
        load = np.repeat(rng.uniform(-1.0, 1.0, n // 50 + 1), 50)[:n]
        temperature = np.where(rng.random(n) < 0.5, low, high)
        temperature[n // 2:] = rng.uniform(low, high, n - n // 2)
        signal = model.response(t, load, hold="zero", temperature=temperature)
        fw = generate_firmware(model, "subtractive", "float32", 100.0,
                               float(np.max(np.abs(signal - model.offset))), temperature_range=(low, high))
        check = verify_firmware(fw, t, signal, repeats=1, temperature=temperature)
        assert check.passed, (law.law, check.max_error_fs, fw.bound.total_fs)


@needs_gcc
def test_q31_firmware_is_integer_only_and_clamps(tmp_path):
    model = ramp_sensor()
    fw = generate_firmware(model, "subtractive", "q31", 10.0, 100.0, temperature_range=(0.0, 50.0))
    assert "int32_t temperature_q8" in fw.header and "#define CREEP_TEMPERATURE_HIGH_Q8 (12800)" in fw.header
    obj = compile_object(fw, tmp_path, flags=("-O0",))
    undefined = set(subprocess.run(["nm", "-u", obj], capture_output=True, text=True,
                                   check=True).stdout.split()) - {"U"}
    assert not undefined, undefined
    code = re.sub(r"/\*.*?\*/", "", fw.source, flags=re.S)
    for banned in ("float", "double", "math.h"):
        assert banned not in code, banned
    n = 3000
    signal = np.where(np.arange(n) > 10, 80.0, 0.0)
    out_hot, _, _ = run_firmware(fw, signal, "relaxed", 1, temperatures=np.full(n, 50.0))
    out_above, _, _ = run_firmware(fw, signal, "relaxed", 1, temperatures=np.full(n, 120.0))
    np.testing.assert_array_equal(out_above, out_hot)
    cold, _, _ = run_firmware(fw, signal, "relaxed", 1, temperatures=np.full(n, 0.0))
    assert np.max(np.abs(cold - out_hot)) > 1e-3


@needs_gcc
def test_firmware_compiles_strictly_without_libm_clamps_and_keeps_a_nan(tmp_path):
    model = ramp_sensor()
    fw = generate_firmware(model, "subtractive", "float32", 10.0, 100.0, temperature_range=(0.0, 50.0))
    obj = compile_object(fw, tmp_path, flags=("-O0",))
    undefined = set(subprocess.run(["nm", "-u", obj], capture_output=True, text=True,
                                   check=True).stdout.split()) - {"U"}
    assert undefined <= {"memcpy"}, undefined
    code = re.sub(r"/\*.*?\*/", "", fw.source, flags=re.S)
    for banned in ("math.h", "exp(", "double"):
        assert banned not in code, banned
    n = 3000
    signal = np.where(np.arange(n) > 10, 80.0, 0.0)
    hot = np.full(n, 50.0)
    out_hot, _, _ = run_firmware(fw, signal, "relaxed", 1, temperatures=hot)
    out_above, _, _ = run_firmware(fw, signal, "relaxed", 1, temperatures=np.full(n, 120.0))
    with_nan = hot.copy()
    with_nan[100::7] = np.nan
    out_nan, _, _ = run_firmware(fw, signal, "relaxed", 1, temperatures=with_nan)
    np.testing.assert_array_equal(out_above, out_hot)        # clamped to the range's top
    np.testing.assert_array_equal(out_nan, out_hot)          # a NaN keeps the last temperature
    cold, _, _ = run_firmware(fw, signal, "relaxed", 1, temperatures=np.full(n, 0.0))
    assert np.max(np.abs(cold - out_hot)) > 1e-3             # the temperature is used


@needs_gcc
def test_inverse_shift_without_libm_is_within_its_stated_error(tmp_path):
    model = CreepModel((0.03,), (45.0,), temperature=TemperatureLaw.arrhenius(120000.0, 20.0))
    fw = generate_firmware(model, "subtractive", "float32", 10.0, 1.0)
    fw.write(tmp_path)
    (tmp_path / "probe.c").write_text(
        '#include <stdio.h>\n#include "creep.c"\nint main(void) { float t; '
        'while (scanf("%f", &t) == 1) printf("%.9e\\n", (double)creep_inverse_shift(t)); return 0; }\n')
    subprocess.run(["gcc", "-std=c99", "-O2", "-I", tmp_path, tmp_path / "probe.c", "-o",
                    tmp_path / "probe"], check=True)
    temps = np.linspace(-40.0, 85.0, 4001).astype(np.float32).astype(float)
    out = subprocess.run([tmp_path / "probe"], input="\n".join(f"{x:.9g}" for x in temps),
                         capture_output=True, text=True, check=True).stdout.split()
    exact = 1.0 / model.temperature.shift(temps)
    relative = np.abs(np.array(out, dtype=float) / exact - 1.0)
    assert np.max(relative) <= fw.coefficients["shift_relative_error"]
    assert np.max(exact) / np.min(exact) > 1e8               # 120 kJ/mol: far beyond one octave


def test_firmware_refusals_name_the_reason():
    model = ramp_sensor()
    with pytest.raises(InputError, match="q31 temperature step needs T/tau_k <= 1/2 at 85 °C"):
        generate_firmware(model, precision="q31", rate=0.5)
    with pytest.raises(InputError, match="dt step does not take a temperature"):
        generate_firmware(model, max_interval=0.1)
    with pytest.raises(InputError, match="no temperature law"):
        generate_firmware(default_sensor(), rate=10.0, temperature_range=(0.0, 40.0))
    with pytest.raises(InputError, match="beta_per_kelvin"):
        generate_firmware(ramp_sensor(beta_per_kelvin=(0.001,)), rate=10.0)
    with pytest.raises(InputError, match="narrow --temperature-range"):
        wlf = CreepModel((0.03,), (45.0,), temperature=TemperatureLaw(20.0, "wlf", c1=8.86, c2=101.6))
        generate_firmware(wlf, rate=100.0, temperature_range=(-40.0, 85.0))


def test_firmware_of_a_model_without_a_law_is_unchanged_by_the_temperature_step():
    plain = generate_firmware(default_sensor(), rate=10.0, full_scale=100.0)
    assert "temperature" not in plain.header + plain.source + plain.harness
    assert plain.temperature_range is None


@needs_gcc
def test_cli_firmware_verify_on_a_ramp_record(run_cli, ramp_files):
    tmp, model, model_file, record, plain, load = ramp_files
    status, out, err = run_cli("firmware", model_file, "--verify", record, "--json",
                               "--temperature-range", "0:50", "-o", tmp / "fw")
    assert status == 0, err
    data = json.loads(out)
    assert data["temperature_range"] == [0.0, 50.0] and data["within_bound"]
    assert data["max_error_fs"] <= data["bound_fs"]
    assert "float temperature_c" in (tmp / "fw" / "creep.h").read_text()
    status, out, err = run_cli("firmware", model_file, "--verify", plain)
    assert status == 2 and "'temperature' column" in err
    status, out, err = run_cli("firmware", model_file, "--verify", record, "--temperature-range", "20:30")
    assert status == 2 and "wider --temperature-range" in err
    status, out, err = run_cli("firmware", model_file, "--rate", "10", "--full-scale", "1",
                               "--temperature-range", "50:0")
    assert status == 2 and "LOW must be below HIGH" in err


@needs_gcc
def test_random_models_laws_and_temperature_histories_stay_within_the_bound():
    rng = np.random.default_rng(2024)
    for case in range(5):
        k = int(rng.integers(1, 4))
        taus = np.sort(10.0 ** rng.uniform(-0.5, 3.5, k))
        betas = rng.uniform(0.002, 0.05, k) * rng.choice([1.0, -0.3], k, p=[0.8, 0.2])
        low = float(rng.uniform(-40.0, 10.0))
        high = low + float(rng.uniform(15.0, 100.0))
        law = (TemperatureLaw.arrhenius(float(rng.uniform(20e3, 120e3)), float(rng.uniform(low, high)))
               if case % 2 == 0 else TemperatureLaw(20.0, "wlf", c1=8.86, c2=float(rng.uniform(120.0, 200.0))))
        model = CreepModel(tuple(betas), tuple(taus), 1.0, float(rng.uniform(-2, 2)), temperature=law)
        rate = float(rng.choice([10.0, 100.0, 1000.0]))
        n = 6000
        t = np.arange(n) / rate
        load = np.repeat(rng.uniform(-1.0, 1.0, n // 40 + 1), 40)[:n]
        temperature = np.clip(np.cumsum(rng.normal(0.0, 3.0, n)) + rng.uniform(low, high), low, high)
        temperature[rng.random(n) < 0.05] = rng.choice([low, high])
        signal = model.response(t, load, hold="zero", temperature=temperature)
        method = "supplemental" if case % 3 == 1 else "subtractive"
        for precision in ("float32", "q31"):
            try:
                fw = generate_firmware(model, method, precision, rate,
                                       float(np.max(np.abs(signal - model.offset))),
                                       temperature_range=(low, high))
            except InputError as exc:              # q31 needs T/tau <= 1/2 over the range
                assert precision == "q31" and "T/tau_k <= 1/2" in str(exc)
                continue
            check = verify_firmware(fw, t, signal, repeats=1, temperature=temperature)
            assert check.passed, (case, precision, check.max_error_fs, fw.bound.total_fs)
            assert fw.bound.total_fs < 1e-5


SAVE_RESTORE_OVER_TEMPERATURE = r"""
#include <stdio.h>
#include "creep.h"
int main(void)
{
    creep_state a, b;
    creep_saved block;
    int i, bad = 0, r;
    creep_init(&a);
    for (i = 0; i < 5000; ++i) (void)creep_step(&a, (kind)(i < 100 ? 0 : INPUT), (temp)(COLD + i % 7));
    creep_save(&a, &block);
    creep_init(&b);
    if (creep_restore(&b, &block) != 0) return 10;
    for (i = 0; i < 3000; ++i)
        bad |= creep_step(&a, (kind)INPUT, (temp)(COLD + i % 5)) != creep_step(&b, (kind)INPUT, (temp)(COLD + i % 5));
    block.w[2 + 2 * CREEP_TERMS] ^= 1u;          /* the saved temperature */
    r = creep_restore(&b, &block);
    printf("%d %d\n", bad, r);
    return 0;
}
"""


@needs_gcc
@pytest.mark.parametrize("precision", ["float32", "q31"])
def test_state_and_temperature_saved_and_restored(tmp_path, precision):
    fw = generate_firmware(ramp_sensor(), "subtractive", precision, 10.0, 1.0)
    obj = compile_object(fw, tmp_path)
    kind, value, temp, cold = (("float", "0.9f", "float", "-30.0f") if precision == "float32"
                               else ("int32_t", "900000000", "int32_t", "(-30 * 256)"))
    (tmp_path / "main.c").write_text(SAVE_RESTORE_OVER_TEMPERATURE.replace("(kind)", f"({kind})")
                                     .replace("INPUT", value).replace("(temp)", f"({temp})")
                                     .replace("COLD", cold))
    exe = tmp_path / "main"
    subprocess.run(["gcc", *STRICT_FLAGS, "-I", tmp_path, tmp_path / "main.c", obj, "-o", exe], check=True)
    out = subprocess.run([exe], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["0", "-2"]          # identical continuation (the temperature is saved too); corrupted


@needs_gcc
def test_a_k_series_of_each_term_is_within_its_stated_error(tmp_path):
    # each creep term takes only the Taylor terms its range of x = (T/tau_k)/a_T needs: fewer for
    # the slow terms; the computed a_k within the relative error the bound takes, up to the
    # range's largest x and down to a tiny one
    from creepcomp.digital.firmware_bound import temperature_scheme

    model = CreepModel((0.01, 0.01, 0.015), (5.0, 50.0, 500.0), temperature=TemperatureLaw.arrhenius(43000.0))
    scheme = temperature_scheme(model, 80.0, -40.0, 85.0)
    assert list(scheme.series) == sorted(scheme.series, reverse=True) and scheme.series[0] > scheme.series[-1]
    fw = generate_firmware(model, "subtractive", "float32", 80.0, 1.0)
    fw.write(tmp_path)
    (tmp_path / "probe.c").write_text(
        '#include <stdio.h>\n#include "creep.c"\nint main(void) { float x; int n; '
        'while (scanf("%f %d", &x, &n) == 2) printf("%.9e\\n", (double)creep_a_of(x, n)); return 0; }\n')
    subprocess.run(["gcc", "-std=c99", "-O2", "-I", tmp_path, tmp_path / "probe.c", "-o",
                    tmp_path / "probe"], check=True)
    for k, n in enumerate(scheme.series):
        x_hi = scheme.dt / scheme.tau_range[1][k]
        xs = np.geomspace(x_hi * 1e-6, x_hi, 2001).astype(np.float32).astype(float)
        out = subprocess.run([tmp_path / "probe"], input="\n".join(f"{x:.9g} {n}" for x in xs),
                             capture_output=True, text=True, check=True).stdout.split()
        relative = np.abs(np.array(out, dtype=float) / -np.expm1(-xs) - 1.0)
        assert np.max(relative) <= scheme.rel_a[k]
        assert np.max(relative) > 1e-8                       # float32's roundings are seen
