"""The generated C corrector: it compiles strictly, needs no libm, keeps its state across a
power cycle, and its measured error against the float64 corrector stays within its proven bound
(steps, sweeps, full-scale swings, long holds, random models)."""

from __future__ import annotations

import json
import re
import shutil
import subprocess

import jinja2
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from creepcomp.digital.firmware import firmware_bound, generate_firmware, naive_float32
from creepcomp.digital.firmware_check import (STRICT_FLAGS, Verification, compile_object,
                                              jittered_record, step_intervals, verify_firmware)
from creepcomp.errors import InputError
from creepcomp.io.jsonfiles import write_model
from creepcomp.io.records import Record, write_record
from creepcomp.model import CreepModel

needs_gcc = pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is not installed")

#: A 3-term model (beta 1 %, 1 %, 1.5 %; tau 5 s, 50 s, 500 s), with an offset.
MODEL = CreepModel(beta=(0.01, 0.01, 0.015), tau=(5.0, 50.0, 500.0), gain=2e-3, offset=1e-3)
RATE = 100.0
VARIANTS = [(p, m) for p in ("float32", "q31") for m in ("subtractive", "supplemental")]


def mixed_record(model: CreepModel, rate: float, n: int, seed: int = 0):
    """Steps (held up to 600 s), a slow and a fast sweep and sample-to-sample full-scale swings."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / rate
    load = np.zeros(n)
    i = n // 20                                   # relaxed lead-in
    quarter = n // 4
    while i < 2 * quarter:                        # steps between random levels, incl. +-1
        hold = int(rng.integers(5, int(600 * rate)))
        load[i:i + hold] = rng.choice([-1.0, 1.0, rng.uniform(-1, 1)])
        i += hold
    s = np.arange(2 * quarter, 3 * quarter)
    load[s] = np.sin(2 * np.pi * s / (0.3 * quarter)) * np.cos(2 * np.pi * s / 37.0)
    swing = np.arange(3 * quarter, n)
    load[swing] = np.where((swing // rng.integers(1, 4)) % 2 == 0, 1.0, -1.0)
    signal = model.response(t, load, hold="zero")
    return t, load, signal


def full_scale(model, signal) -> float:
    return float(np.max(np.abs(signal - model.offset)))


@pytest.fixture(scope="module")
def record():
    return mixed_record(MODEL, RATE, 120_000)


@needs_gcc
@pytest.mark.parametrize("precision,method", VARIANTS)
def test_generated_code_compiles_strictly_and_calls_no_library_per_sample(tmp_path, precision, method):
    fw = generate_firmware(MODEL, method, precision, RATE, 0.01, name="scale_fix")
    obj = compile_object(fw, tmp_path, flags=("-O0",))
    assert {"-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic"} <= set(STRICT_FLAGS)
    undefined = set(subprocess.run(["nm", "-u", obj], capture_output=True, text=True,
                                   check=True).stdout.split()) - {"U"}
    # float32 copies state words with memcpy (save/restore only); nothing else is linked in
    assert undefined <= {"memcpy"}, undefined
    code = re.sub(r"/\*.*?\*/", "", fw.source, flags=re.S)      # the C without its comments
    for banned in ("malloc", "math.h", "exp", "double"):
        assert banned not in code, banned              # no heap, libm or doubles
    symbols = subprocess.run(["nm", obj], capture_output=True, text=True, check=True).stdout
    kinds = {line.split()[-2] for line in symbols.splitlines() if len(line.split()) >= 2}
    assert not kinds & set("BbDdCcGgSs"), symbols     # no writable (global) data: only code, constants
    assert "#define SCALE_FIX_BOUND_FS" in fw.header and f"{fw.bound.total_fs:.3e}" in fw.header
    # the derivation of each coefficient is written beside it
    assert "-expm1(-2e-05)" in fw.header and "tau = 500 s" in fw.header


@pytest.mark.parametrize("precision,method", VARIANTS)
def test_bound_of_the_three_term_model_meets_the_target(precision, method):
    bound = firmware_bound(MODEL, method, precision, RATE, 0.01)
    assert 0 < bound.total_fs <= 1e-5
    assert bound.total_fs == pytest.approx(sum(bound.terms.values()), rel=1e-5)
    assert bound.peak_fs > 1.0                      # the inverse filter overshoots a step


def test_float32_bound_counts_the_offset_and_q31_does_not():
    far = CreepModel(MODEL.beta, MODEL.tau, offset=1000.0)
    near = CreepModel(MODEL.beta, MODEL.tau, offset=0.0)
    f_far, f_near = (firmware_bound(m, "subtractive", "float32", RATE, 1.0).total_fs for m in (far, near))
    assert f_far > 100 * f_near                     # raw values of 1000 FS lose 10 bits in float32
    q_far, q_near = (firmware_bound(m, "subtractive", "q31", RATE, 1.0).total_fs for m in (far, near))
    assert q_far == pytest.approx(q_near, rel=1e-9)


@needs_gcc
@pytest.mark.parametrize("precision,method", VARIANTS)
def test_measured_error_within_the_bound_on_steps_sweeps_and_swings(record, precision, method):
    t, _, signal = record
    fw = generate_firmware(MODEL, method, precision, RATE, full_scale(MODEL, signal))
    check = verify_firmware(fw, t, signal, repeats=1)
    assert check.samples == len(t)
    assert 0 < check.max_error_fs <= fw.bound.total_fs
    assert check.passed and check.ns_per_sample > 0 and check.object_bytes > 0


@needs_gcc
def test_naive_float32_recursion_exceeds_the_bound(record):
    t, _, signal = record
    fs = full_scale(MODEL, signal)
    naive = verify_firmware(naive_float32(MODEL, "subtractive", RATE, fs), t, signal, repeats=1)
    bound = firmware_bound(MODEL, "subtractive", "float32", RATE, fs).total_fs
    assert naive.bound_fs is None and naive.passed
    assert naive.max_error_fs > 5 * bound


@needs_gcc
@pytest.mark.parametrize("precision,method", VARIANTS)
def test_long_hold_of_a_million_time_constants(precision, method):
    model = CreepModel(beta=(0.02, 0.01), tau=(0.01, 0.05), offset=-0.3)
    rate, n = 100.0, 1_000_001                      # 10^4 s = 10^6 x the shortest tau
    t = np.arange(n) / rate
    load = np.where(t >= 0.5, 1.0, 0.0)
    signal = model.response(t, load, hold="zero")
    fw = generate_firmware(model, method, precision, rate, full_scale(model, signal))
    check = verify_firmware(fw, t, signal, repeats=1)
    assert check.max_error_fs <= fw.bound.total_fs


@needs_gcc
@settings(max_examples=6, deadline=None)
@given(data=st.data())
def test_random_models_stay_within_their_bound(data):
    k = data.draw(st.integers(1, 3), label="terms")
    rate = data.draw(st.sampled_from([10.0, 100.0, 1000.0]), label="rate")
    tau_rate = sorted(data.draw(st.lists(st.floats(1.0, 1e5), min_size=k, max_size=k), label="tau*rate"))
    beta = data.draw(st.lists(st.floats(0.001, 0.06), min_size=k, max_size=k), label="beta")
    negative = data.draw(st.booleans(), label="overshoot")
    model = CreepModel(beta=tuple(-b if negative else b for b in beta),
                       tau=tuple(x / rate for x in tau_rate),
                       offset=data.draw(st.floats(-1.0, 1.0), label="offset"))
    precision = data.draw(st.sampled_from(["float32", "q31"]), label="precision")
    method = data.draw(st.sampled_from(["subtractive", "supplemental"]), label="method")
    t, _, signal = mixed_record(model, rate, 20_000, seed=data.draw(st.integers(0, 99), label="seed"))
    fw = generate_firmware(model, method, precision, rate, full_scale(model, signal))
    check = verify_firmware(fw, t, signal, repeats=1)
    assert check.max_error_fs <= fw.bound.total_fs


# --------------------------------------------------------------- irregular sampling (dt step)

MAX_INTERVAL = 0.04


@pytest.fixture(scope="module")
def jittered():
    return jittered_record(MODEL, 40_000)


@needs_gcc
@pytest.mark.parametrize("precision,method", VARIANTS)
def test_dt_step_compiles_strictly_without_libm(tmp_path, precision, method):
    fw = generate_firmware(MODEL, method, precision, full_scale=0.01, max_interval=MAX_INTERVAL)
    assert fw.irregular and fw.rate is None and "creep_step_dt" in fw.header
    obj = compile_object(fw, tmp_path, flags=("-O0",))
    undefined = set(subprocess.run(["nm", "-u", obj], capture_output=True, text=True,
                                   check=True).stdout.split()) - {"U"}
    assert undefined <= {"memcpy"}, undefined
    code = re.sub(r"/\*.*?\*/", "", fw.source, flags=re.S)
    for banned in ("malloc", "math.h", "exp(", "double"):
        assert banned not in code, banned
    assert f"{fw.bound.total_fs:.3e}" in fw.header and "relative error of computed a" in fw.header


@needs_gcc
@pytest.mark.parametrize("precision,method", VARIANTS)
def test_dt_step_error_within_its_bound_on_a_jittered_record(jittered, precision, method):
    t, _, signal = jittered
    fw = generate_firmware(MODEL, method, precision, full_scale=full_scale(MODEL, signal),
                           max_interval=MAX_INTERVAL)
    check = verify_firmware(fw, t, signal, repeats=1)
    assert check.samples == len(t)
    assert 0 < check.max_error_fs <= fw.bound.total_fs <= 1e-5


def test_dt_bound_covers_the_intervals_and_is_near_the_fixed_rate_one():
    for precision in ("float32", "q31"):
        fixed = firmware_bound(MODEL, "subtractive", precision, RATE, 0.01).total_fs
        dt = firmware_bound(MODEL, "subtractive", precision, full_scale=0.01, max_interval=0.04).total_fs
        assert fixed < dt < 2 * fixed
        parts = firmware_bound(MODEL, "subtractive", precision, full_scale=0.01, max_interval=0.04).terms
        assert parts["coefficients a_k(dt) (series, stored 1/tau)"] > 0


def test_dt_step_limits_are_refused_with_a_message():
    with pytest.raises(InputError, match="half the shortest time constant"):
        generate_firmware(MODEL, precision="q31", full_scale=0.01, max_interval=3.0)
    # float32 reduces the range by halving: long gaps are fine
    assert generate_firmware(MODEL, precision="float32", full_scale=0.01, max_interval=30.0).bound.total_fs < 1e-5
    with pytest.raises(InputError, match="max interval"):
        generate_firmware(MODEL, max_interval=1e-7)
    fw = generate_firmware(MODEL, precision="q31", full_scale=0.01, max_interval=MAX_INTERVAL)
    with pytest.raises(InputError, match="interval before sample 2 is 0.05 s"):
        step_intervals(fw, [0.0, 0.01, 0.06])


@needs_gcc
def test_dt_step_refuses_intervals_out_of_range_and_long_gaps_against_the_exact_corrector(tmp_path):
    """float32 with gaps of 4 tau of the fastest term (halving and doubling) stays in its bound;
    an interval beyond the maximum returns -1 and changes nothing."""
    t, _, signal = jittered_record(MODEL, 8_000, seed=5, max_interval=20.0)
    fw = generate_firmware(MODEL, "subtractive", "float32", full_scale=full_scale(MODEL, signal),
                           max_interval=20.0)
    check = verify_firmware(fw, t, signal, repeats=1)
    assert check.max_error_fs <= fw.bound.total_fs
    obj = compile_object(fw, tmp_path)
    (tmp_path / "main.c").write_text(DT_REFUSE_TEST)
    exe = tmp_path / "main"
    subprocess.run(["gcc", *STRICT_FLAGS, "-I", tmp_path, tmp_path / "main.c", obj, "-o", exe], check=True)
    assert subprocess.run([exe], capture_output=True, text=True, check=True).stdout.split() == ["0", "-1", "-1", "-1", "1"]


DT_REFUSE_TEST = r"""
#include <stdio.h>
#include <string.h>
#include "creep.h"
int main(void)
{
    creep_state s, before;
    float y = 0.0f, z = 7.0f;
    int r0, r1, r2, r3;
    creep_init(&s);
    r0 = creep_step_dt(&s, 0.005f, 0.01f, &y);
    before = s;
    r1 = creep_step_dt(&s, 0.005f, 21.0f, &z);
    r2 = creep_step_dt(&s, 0.005f, 0.0f, &z);
    r3 = creep_step_dt(&s, 0.005f, 1e-7f, &z);
    printf("%d %d %d %d %d\n", r0, r1, r2, r3, memcmp(&s, &before, sizeof s) == 0 && z == 7.0f);
    return 0;
}
"""


SAVE_RESTORE_TEST = r"""
#include <stdio.h>
#include "creep.h"
int main(void)
{
    creep_state a, b;
    creep_saved block;
    int i, bad = 0, r;
    creep_init(&a);
    for (i = 0; i < 5000; ++i) (void)creep_step(&a, (creep_input)(i < 100 ? 0 : INPUT));
    creep_save(&a, &block);
    creep_init(&b);
    if (creep_restore(&b, &block) != 0) return 10;
    for (i = 0; i < 3000; ++i) bad |= creep_step(&a, (creep_input)INPUT) != creep_step(&b, (creep_input)INPUT);
    block.w[2] ^= 1u;
    r = creep_restore(&b, &block);
    block.w[2] ^= 1u;
    block.w[0] ^= 1u;
    printf("%d %d %d\n", bad, r, creep_restore(&b, &block));
    return 0;
}
"""


@needs_gcc
@pytest.mark.parametrize("precision,state", [("float32", "compensated"), ("float32", "plain"),
                                             ("q31", "compensated")])
def test_state_saved_and_restored_across_a_power_cycle(tmp_path, precision, state):
    fw = generate_firmware(MODEL, "subtractive", precision, RATE, 0.01, state=state)
    obj = compile_object(fw, tmp_path)
    kind, value = ("float", "0.009f") if precision == "float32" else ("int32_t", "900000000")
    (tmp_path / "main.c").write_text(SAVE_RESTORE_TEST.replace("creep_input", kind)
                                     .replace("INPUT", value))
    exe = tmp_path / "main"
    subprocess.run(["gcc", *STRICT_FLAGS, "-I", tmp_path, tmp_path / "main.c", obj, "-o", exe], check=True)
    out = subprocess.run([exe], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["0", "-2", "-1"]          # identical continuation; corrupted; other model


def test_q31_refuses_a_model_outside_its_word_range():
    with pytest.raises(InputError, match="q31 needs -0.5 < beta0"):
        generate_firmware(CreepModel(beta=(-0.3, -0.3), tau=(1.0, 10.0)), precision="q31", rate=10.0)


def test_bad_arguments_are_refused_with_a_message():
    with pytest.raises(InputError, match="precision 'q15'"):
        generate_firmware(MODEL, precision="q15")
    with pytest.raises(InputError, match="rate"):
        generate_firmware(MODEL, rate=0.0)
    with pytest.raises(InputError, match="C identifier"):
        generate_firmware(MODEL, name="my-scale")
    with pytest.raises(InputError, match="C identifier"):
        generate_firmware(MODEL, name="")


# -------------------------------------------------------------------------------- the templates

def test_a_template_missing_a_value_fails():
    from creepcomp.digital import firmware

    with pytest.raises(RuntimeError, match="harness.c.j2 has no value for irregular"):
        firmware._render("harness.c.j2", name="creep", NAME="CREEP", precision="float32")
    with pytest.raises(jinja2.UndefinedError, match="irregular"):
        firmware._environment().get_template("harness.c.j2").render(
            name="creep", NAME="CREEP", precision="float32")


def test_a_value_the_template_does_not_use_fails():
    from creepcomp.digital import firmware

    harness = firmware._render("harness.c.j2", name="creep", NAME="CREEP", precision="q31",
                               irregular=True, temperature=False)
    assert "#define HARNESS_DT 1" in harness and "uint32_t *dts;" in harness
    with pytest.raises(RuntimeError, match="harness.c.j2 does not use rate"):
        firmware._render("harness.c.j2", name="creep", NAME="CREEP", precision="q31",
                         irregular=True, temperature=False, rate="100.0")


def test_every_template_file_is_used(monkeypatch):
    from importlib import resources

    from creepcomp.digital import firmware

    rendered = []
    render = firmware._render

    def recording(template, **values):
        rendered.append(template)
        return render(template, **values)

    monkeypatch.setattr(firmware, "_render", recording)
    for precision in ("float32", "q31"):
        for max_interval in (None, 0.04):
            generate_firmware(MODEL, "supplemental", precision, RATE, 1.0,
                              max_interval=max_interval)
    naive_float32(MODEL)
    from creepcomp.temperature import TemperatureLaw

    for precision in ("float32", "q31"):
        generate_firmware(CreepModel(MODEL.beta, MODEL.tau, MODEL.gain, MODEL.offset,
                                     temperature=TemperatureLaw.arrhenius(43000.0)),
                          precision=precision, rate=RATE)
    generate_firmware(MODEL, rate=RATE, full_scale=1.0,
                      extension={"play": {"ratio": 0.05, "half_width": 0.01}})
    generate_firmware(MODEL, "subtractive", "q31", RATE, 1.0,
                      extension={"recovery": {"term": 0, "tau_recovery": 20.0, "dead_band": 1e-9}})
    from creepcomp.transfer import StaticMap, Transfer

    pad = Transfer(signal_map=StaticMap("reciprocal", {"origin": 0.0}))
    for beta, tau in ((MODEL.beta, MODEL.tau), ((), ())):       # with creep, and a static calibration
        generate_firmware(CreepModel(beta, tau, 1e-4, 1e-4, transfer=pad), rate=RATE,
                          full_scale=(1000.0, 9000.0))
    for program in ("avr_program.c.j2", "arm_program.c.j2"):
        firmware.render_target_program(generate_firmware(MODEL, rate=RATE), program)
    from creepcomp.digital.firmware_library import library_files

    for precision in ("float32", "q31"):
        library_files(generate_firmware(MODEL, "subtractive", precision, RATE, 1.0))
    used = set().union(*(firmware._template_tree(t) for t in rendered))
    files = {f.name for f in resources.files("creepcomp.digital").joinpath("templates").iterdir()
             if f.is_file()}
    assert used == files


# ------------------------------------------------------------------------------- command line

@pytest.fixture
def cli_files(tmp_path):
    t, load, signal = mixed_record(MODEL, RATE, 30_000, seed=3)
    rec = write_record(tmp_path / "rec.csv", Record(t, load, signal))
    return tmp_path, rec, write_model(tmp_path / "model.json", MODEL)


@needs_gcc
def test_cli_json_writes_files_and_verifies(run_cli, cli_files):
    tmp, rec, model = cli_files
    status, out, err = run_cli("firmware", model, "-o", tmp / "fw", "--precision", "q31",
                               "--method", "supplemental", "--verify", rec, "--json")
    assert status == 0, err
    result = json.loads(out)
    assert result["files"] == [str(tmp / "fw" / "creep.h"), str(tmp / "fw" / "creep.c")]
    assert all((tmp / "fw" / f).is_file() for f in ("creep.h", "creep.c"))
    assert result["precision"] == "q31" and result["rate"] == pytest.approx(RATE)
    assert result["samples"] == 30_000
    assert 0 < result["max_error_fs"] <= result["bound_fs"] <= 1e-5
    assert result["ns_per_sample"] > 0


def test_cli_table_without_verify(run_cli, cli_files):
    tmp, _, model = cli_files
    status, out, err = run_cli("firmware", model, "--rate", "100Hz", "--full-scale", "10m")
    assert status == 0, err
    assert "Proven worst-case error" in out and "no files written" in out


@pytest.mark.parametrize("args,message", [
    (["--full-scale", "1"], "--rate"),
    (["--rate", "100Hz"], "--full-scale"),
    (["--rate", "fast", "--full-scale", "1"], "--rate"),
    (["--rate", "100", "--full-scale", "1", "--method", "additive"], "method 'additive'"),
])
def test_cli_bad_input_is_one_line_with_status_2(run_cli, cli_files, args, message):
    _, _, model = cli_files
    status, out, err = run_cli("firmware", model, *args)
    assert status == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("creepcomp: error:") and message in err


def test_cli_record_outside_the_full_scale_or_rate(run_cli, cli_files):
    _, rec, model = cli_files
    status, _, err = run_cli("firmware", model, "--verify", rec, "--full-scale", "1e-3")
    assert status == 2 and "beyond the full scale" in err and err.count("\n") == 1
    status, _, err = run_cli("firmware", model, "--verify", rec, "--rate", "50Hz")
    assert status == 2 and "--rate 100" in err and err.count("\n") == 1


def test_cli_measured_error_above_the_bound_fails_with_status_3(run_cli, cli_files, monkeypatch):
    from creepcomp.digital import firmware_check

    def too_large(fw, time, signal, **_):
        return Verification(samples=len(time), max_error_fs=2 * fw.bound.total_fs, worst_sample=7,
                            ns_per_sample=1.0, object_bytes=1, bound_fs=fw.bound.total_fs)

    monkeypatch.setattr(firmware_check, "verify_firmware", too_large)
    _, rec, model = cli_files
    status, out, err = run_cli("firmware", model, "--verify", rec, "--json")
    assert status == 3
    assert json.loads(out)["within_bound"] is False
    assert err.count("\n") == 1 and "exceeds the proven bound" in err


@needs_gcc
def test_cli_dt_step_on_a_jittered_record(run_cli, tmp_path):
    t, load, signal = jittered_record(MODEL, 10_000, seed=7)
    rec = write_record(tmp_path / "jitter.csv", Record(t, load, signal))
    model = write_model(tmp_path / "model.json", MODEL)
    status, _, err = run_cli("firmware", model, "--verify", rec)
    assert status == 2 and "--max-interval" in err and err.count("\n") == 1
    status, out, err = run_cli("firmware", model, "--verify", rec, "--max-interval", "40ms",
                               "--precision", "q31", "--json", "-o", tmp_path / "fw")
    assert status == 0, err
    result = json.loads(out)
    assert result["rate"] is None and result["max_interval"] == pytest.approx(0.04)
    assert result["samples"] == 10_000 and 0 < result["max_error_fs"] <= result["bound_fs"] <= 1e-5
    assert "creep_step_dt" in (tmp_path / "fw" / "creep.h").read_text()
    status, _, err = run_cli("firmware", model, "--verify", rec, "--max-interval", "20ms")
    assert status == 2 and "give a larger --max-interval" in err and err.count("\n") == 1


@needs_gcc
def test_float32_state_update_keeps_the_exact_rounding_error(tmp_path):
    """The state's update adds m = a (target - hi) + lo to hi and keeps the sum's rounding
    error in lo: exactly when |m| <= |hi| (Fast2Sum, hi first); when |m| > |hi| within the
    u (1 + 6u) |m| the bound counts, with |lo| <= 3.1 u |m|."""
    from fractions import Fraction

    from creepcomp.digital import firmware

    update = firmware._environment().get_template("macros.c.j2").make_module(
        {"name": "creep", "NAME": "CREEP", "method": "subtractive"}).float32_update("a", "target")
    (tmp_path / "update.c").write_text(f"""
#include <stdio.h>
#include <stdint.h>
#include <string.h>
typedef struct {{ float hi[1]; float lo[1]; }} state;
int main(void)
{{
    float in[4];
    while (fread(in, sizeof in, 1, stdin) == 1) {{
        state st, *s = &st;
        const float a = in[2], target = in[3];
        const int k = 0;
        st.hi[0] = in[0];
        st.lo[0] = in[1];
        {{
{update}
        }}
        fwrite(st.hi, sizeof(float), 1, stdout);
        fwrite(st.lo, sizeof(float), 1, stdout);
    }}
    return 0;
}}
""")
    exe = tmp_path / "update"
    subprocess.run(["gcc", *STRICT_FLAGS, "-O2", tmp_path / "update.c", "-o", exe], check=True)
    rng = np.random.default_rng(2)
    n = 20_000
    hi = (rng.uniform(-1, 1, n) * 10.0 ** rng.integers(-8, 2, n)).astype(np.float32)
    hi[::5] = 0.0
    lo = (hi * rng.uniform(-6e-8, 6e-8, n)).astype(np.float32)
    a = (10.0 ** rng.uniform(-7, 0, n)).astype(np.float32)
    target = (rng.uniform(-1, 1, n) * 10.0 ** rng.integers(-8, 2, n)).astype(np.float32)
    data = np.stack([hi, lo, a, target], axis=1).astype("<f4").tobytes()
    out = np.frombuffer(subprocess.run([exe], input=data, capture_output=True, check=True).stdout,
                        dtype="<f4").reshape(-1, 2)
    m = (a * (target - hi) + lo).astype(np.float32)       # numpy float32: each operation rounded
    assert np.array_equal(out[:, 0], (hi + m).astype(np.float32))
    larger_m = np.abs(m) > np.abs(hi)
    assert larger_m.sum() > 1000
    u = Fraction(1, 2 ** 24)
    inexact = 0
    for i in range(n):
        error = abs(Fraction(float(out[i, 0])) + Fraction(float(out[i, 1]))
                    - Fraction(float(hi[i])) - Fraction(float(m[i])))
        if larger_m[i]:
            assert error <= u * (1 + 6 * u) * abs(Fraction(float(m[i])))
            assert abs(Fraction(float(out[i, 1]))) <= Fraction(31, 10) * u * abs(Fraction(float(m[i])))
            inexact += error > 0
        else:
            assert error == 0
    assert inexact > 0          # the case the bound's term is for occurs


@needs_gcc
def test_temperature_step_reuses_its_a_k_only_for_the_same_mid_temperature():
    """The float32 temperature step keeps the a_k of the last mid temperature: its outputs are
    those of the step that computes them every sample, bit for bit, with the temperature held
    for a second at a time, changing every sample, and after a restore."""
    import dataclasses

    from creepcomp.digital.firmware_check import run_firmware
    from creepcomp.temperature import TemperatureLaw

    law = CreepModel(MODEL.beta, MODEL.tau, MODEL.gain, MODEL.offset,
                     temperature=TemperatureLaw.arrhenius(43000.0))
    fw = generate_firmware(law, "subtractive", "float32", 80.0, 1.0)
    kept = "if (!s->a_known || temperature_c != s->temperature_c || temperature_c != s->a_mid_c) {"
    assert fw.source.count(kept) == 1
    every = dataclasses.replace(fw, source=fw.source.replace(kept, "if (1) {").replace(
        "if (!s->a_known || mid != s->a_mid_c) {", "if (1) {"))
    n = 4000
    signal = MODEL.offset + np.where((np.arange(n) // 300) % 2 == 0, 0.8, -0.3)
    held = np.repeat(np.round(25 + 20 * np.sin(np.arange(n // 80 + 1) / 3.0), 1), 80)[:n]
    moving = 25 + 20 * np.sin(np.arange(n) / 70.0)
    for temperatures in (held, moving):
        a, _, _ = run_firmware(fw, signal, "relaxed", 1, temperatures=temperatures)
        b, _, _ = run_firmware(every, signal, "relaxed", 1, temperatures=temperatures)
        assert np.array_equal(a, b)


PRODUCT_TEST = r"""
#include <stdio.h>
#include "creep.c"

int main(void)
{
    static const int64_t v[] = {0, 1, -1, 65535, -65536, 2147483647, -2147483648LL, 4294967295LL,
                                -4294967295LL, 3000000001LL, -123456789012LL / 100, 1073741825};
    static const int32_t m[] = {1, -1, 65535, 1073741824, -1073741824, 2147483647, -2147483647,
                                1518500250, -987654321};
    unsigned i, j, n;
    for (i = 0; i < sizeof v / sizeof v[0]; ++i)
        for (j = 0; j < sizeof m / sizeof m[0]; ++j)
            for (n = 1; n < 64; ++n) {
                /* where v m + 2^(n-1) would overflow 64 bits the 64-bit shift cannot be had */
                const double p = (double)v[i] * (double)m[j];
                if ((p < 0 ? -p : p) + (double)((uint64_t)1 << (n - 1)) >= 9.2e18)
                    printf("-\n");
                else
                    printf("%lld\n", (long long)creep_product(v[i], m[j], n));
            }
    return 0;
}
"""


@needs_gcc
def test_q31_product_of_sixteen_bit_parts_equals_the_64_bit_product(tmp_path):
    # the Cortex-M0+'s product (four 16 x 16 -> 32 products, rounded in two words), forced on the
    # host, against shift(v m, n) in 64 bits: every shift, signs, the largest magnitudes, ties
    fw = generate_firmware(MODEL, "subtractive", "q31", RATE, 0.01)
    fw.write(tmp_path)
    (tmp_path / "main.c").write_text(PRODUCT_TEST)
    outputs = []
    for flags in ([], ["-DCREEP_PRODUCT16"]):
        exe = tmp_path / f"main{len(flags)}"
        subprocess.run(["gcc", *STRICT_FLAGS, *flags, "-Wno-unused-function", "-I", tmp_path,
                        tmp_path / "main.c", "-o", exe], check=True)
        outputs.append(subprocess.run([exe], capture_output=True, text=True, check=True).stdout.split())
    assert len(outputs[0]) == 12 * 9 * 63 and outputs[0] == outputs[1]
    assert outputs[0][:3] == ["0", "0", "0"] and "1" in outputs[0] and outputs[0].count("-") < 400
