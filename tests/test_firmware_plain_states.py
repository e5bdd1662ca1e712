"""The float32 corrector with plain states (``--state plain``): one float per creep state, its
rounding not carried. Its C compiles strictly, its measured error stays within its own proven
bound on the host and on the chips, the bound is not vacuous (a long hold, where each state
stalls once its increment falls below half its rounding step, reaches a good part of it), and
the default, compensated states are unchanged."""

from __future__ import annotations

import json
import re
import shutil

import numpy as np
import pytest

from creepcomp.digital.firmware import firmware_bound, generate_firmware
from creepcomp.digital.firmware_check import compile_object, run_firmware, verify_firmware
from creepcomp.digital.firmware_target import find_toolchain, run_on_target
from creepcomp.errors import CreepcompError, InputError
from creepcomp.io.jsonfiles import write_model
from creepcomp.io.records import Record, write_record
from creepcomp.model import CreepModel
from creepcomp.temperature import TemperatureLaw

needs_gcc = pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is not installed")

#: The benchmark's 3-term model (beta 1 %, 1 %, 1.5 %; tau 5 s, 50 s, 500 s) at 80 Hz.
MODEL = CreepModel(beta=(0.01, 0.01, 0.015), tau=(5.0, 50.0, 500.0), gain=1.0, offset=1e-3)
RATE = 80.0


def _installed(target: str) -> bool:
    try:
        find_toolchain(target)
    except CreepcompError:
        return False
    return True


def step_record(model: CreepModel, n: int = 1500, rate: float = RATE):
    """Steps between full scale and -half scale every 5 s, and sample-to-sample swings at the end."""
    t = np.arange(n) / rate
    load = np.where((np.arange(n) // 400) % 2 == 0, 1.0, -0.5)
    load[:50] = 0.0
    load[-200:] = np.where(np.arange(200) % 2 == 0, 1.0, -1.0)
    return t, model.response(t, load, hold="zero")


def test_plain_bound_is_the_update_rounding_through_the_state_gains():
    plain = firmware_bound(MODEL, "subtractive", "float32", RATE, 1.0, state="plain")
    compensated = firmware_bound(MODEL, "subtractive", "float32", RATE, 1.0)
    assert firmware_bound(MODEL, "subtractive", "float32", RATE, 1.0,
                          state="compensated") == compensated
    assert plain.total_fs > 100 * compensated.total_fs
    # dominated by u |c| per update times the state gains, about beta_k tau_k / T each
    rounding = plain.terms["state updates rounding"]
    assert rounding > 0.99 * (plain.total_fs - compensated.total_fs)
    u = 2.0 ** -24
    assert rounding == pytest.approx(u * plain.peak_fs * sum(plain.gains["state"]), rel=0.02)
    assert plain.total_fs == pytest.approx(3.89e-5, rel=0.01)
    # it grows with tau x rate: one term, ten times the rate, about ten times the rounding part
    one = CreepModel(beta=(0.015,), tau=(500.0,), offset=1e-3)
    slow, fast = (firmware_bound(one, "subtractive", "float32", r, 1.0, state="plain")
                  .terms["state updates rounding"] for r in (RATE, 10 * RATE))
    assert fast == pytest.approx(10 * slow, rel=0.05)


def test_default_states_are_the_compensated_ones_byte_for_byte():
    default = generate_firmware(MODEL, rate=RATE, full_scale=0.5)
    compensated = generate_firmware(MODEL, rate=RATE, full_scale=0.5, state="compensated")
    plain = generate_firmware(MODEL, rate=RATE, full_scale=0.5, state="plain")
    assert (default.header, default.source) == (compensated.header, compensated.source)
    assert default.state == "compensated" and plain.state == "plain"
    assert plain.to_dict()["state"] == "plain"
    assert "lo" not in re.sub(r"/\*.*?\*/", "", plain.source, flags=re.S).replace("float", "")
    assert "float c[CREEP_TERMS];" in plain.header and "--state plain" in plain.header
    model_id = re.compile(r"#define CREEP_MODEL_ID (\w+)")
    assert model_id.search(plain.header)[1] != model_id.search(default.header)[1]
    assert f"{plain.bound.total_fs:.3e}" in plain.header


@pytest.mark.parametrize("kwargs", [
    {"precision": "q31"},
    {"max_interval": 0.05},
    {"output_polynomial": (0.05, 0.0)},
])
def test_plain_states_refused_outside_the_float32_fixed_rate_step(kwargs):
    with pytest.raises(InputError, match="plain states are for the float32 corrector at a fixed rate"):
        generate_firmware(MODEL, rate=RATE, full_scale=1.0, state="plain", **kwargs)


def test_plain_states_refused_with_a_temperature_law_or_an_unknown_form():
    law = CreepModel(MODEL.beta, MODEL.tau, 1.0, MODEL.offset,
                     temperature=TemperatureLaw.arrhenius(43000.0))
    with pytest.raises(InputError, match="plain states are for"):
        generate_firmware(law, rate=RATE, full_scale=1.0, state="plain")
    with pytest.raises(InputError, match="state 'double': use compensated or plain"):
        generate_firmware(MODEL, rate=RATE, full_scale=1.0, state="double")


@needs_gcc
@pytest.mark.parametrize("method", ["subtractive", "supplemental"])
def test_plain_states_compile_strictly_and_stay_within_their_bound(tmp_path, method):
    t, signal = step_record(MODEL, 4000)
    fs = float(np.max(np.abs(signal - MODEL.offset)))
    fw = generate_firmware(MODEL, method, "float32", RATE, fs, state="plain")
    compile_object(fw, tmp_path, flags=("-O0",))
    check = verify_firmware(fw, t, signal, repeats=1)
    assert check.passed and 0 < check.max_error_fs <= fw.bound.total_fs


@needs_gcc
def test_plain_states_error_on_a_long_hold_is_a_good_part_of_the_bound():
    """Held at full scale, a state stops moving once ``a_k |S - c_k|`` is below half its
    rounding step: it stalls about ``u |c_k| / a_k`` from its target, the error the bound
    counts; the compensated states, whose carried error keeps them moving, stay far below."""
    model = CreepModel(beta=(0.015,), tau=(100.0,), offset=1e-3)
    rate, n = 100.0, 100_000
    t = np.arange(n) / rate
    load = np.where(np.arange(n) >= 10, 1.0, 0.0)
    signal = model.response(t, load, hold="zero")
    fs = float(np.max(np.abs(signal - model.offset)))
    errors = {}
    for state in ("compensated", "plain"):
        fw = generate_firmware(model, "subtractive", "float32", rate, fs, state=state)
        check = verify_firmware(fw, t, signal, repeats=1)
        assert check.max_error_fs <= fw.bound.total_fs
        errors[state] = (check.max_error_fs, fw.bound.total_fs)
    plain, plain_bound = errors["plain"]
    assert plain >= plain_bound / 4
    assert plain > 10 * errors["compensated"][0]


@pytest.mark.skipif(not _installed("avr"), reason="avr-gcc, avr-libc or simavr is not installed")
def test_avr_plain_states_within_their_bound_equal_the_host_and_meet_2500_cycles():
    t, signal = step_record(MODEL)
    fs = float(np.max(np.abs(signal - MODEL.offset)))
    fw = generate_firmware(MODEL, "subtractive", "float32", RATE, fs, state="plain")
    check = verify_firmware(fw, t, signal, target="avr")
    assert check.passed and check.max_error_fs <= fw.bound.total_fs
    run = check.on_target
    assert run.state_bytes == 4 * MODEL.n_terms
    assert run.per_sample <= 2500
    host, _, _ = run_firmware(fw, signal, "relaxed", repeats=1)
    assert np.array_equal(host, run_on_target(fw, signal, "relaxed", "avr").outputs)


@pytest.mark.skipif(not _installed("cortex-m0plus"), reason="arm-none-eabi-gcc or qemu is not installed")
@pytest.mark.parametrize("target", ["cortex-m0plus", "cortex-m4f"])
def test_cortex_m_plain_states_within_their_bound(target):
    t, signal = step_record(MODEL, 1200)
    fs = float(np.max(np.abs(signal - MODEL.offset)))
    fw = generate_firmware(MODEL, "supplemental", "float32", RATE, fs, state="plain")
    check = verify_firmware(fw, t, signal, target=target)
    assert check.passed and check.max_error_fs <= fw.bound.total_fs
    assert check.on_target.state_bytes == 4 * MODEL.n_terms
    host, _, _ = run_firmware(fw, signal, "settled", repeats=1)
    assert np.array_equal(host, run_on_target(fw, signal, "settled", target).outputs)


# ------------------------------------------------------------------------------- command line

def test_cli_state_plain_json_and_refusal(run_cli, tmp_path):
    model = write_model(tmp_path / "model.json", MODEL)
    status, out, err = run_cli("firmware", model, "--rate", "80Hz", "--full-scale", "1",
                               "--state", "plain", "--json")
    assert status == 0, err
    result = json.loads(out)
    assert result["state"] == "plain"
    assert result["bound_fs"] == pytest.approx(
        firmware_bound(MODEL, "subtractive", "float32", RATE, 1.0, state="plain").total_fs)
    status, out, err = run_cli("firmware", model, "--rate", "80Hz", "--full-scale", "1",
                               "--state", "plain", "--precision", "q31")
    assert status == 2 and out == "" and "plain states are for" in err
    status, out, err = run_cli("firmware", model, "--rate", "80Hz", "--full-scale", "1",
                               "--state", "loose")
    assert status == 2 and "--state 'loose'" in err


@needs_gcc
def test_cli_state_plain_writes_files_and_verifies(run_cli, tmp_path):
    t, signal = step_record(MODEL, 3000)
    rec = write_record(tmp_path / "rec.csv", Record(t, np.zeros_like(t), signal))
    model = write_model(tmp_path / "model.json", MODEL)
    status, out, err = run_cli("firmware", model, "-o", tmp_path / "fw", "--verify", rec,
                               "--state", "plain", "--json")
    assert status == 0, err
    result = json.loads(out)
    assert result["state"] == "plain" and 0 < result["max_error_fs"] <= result["bound_fs"]
    assert "typedef struct { float c[CREEP_TERMS]; }" in (tmp_path / "fw" / "creep.h").read_text()
