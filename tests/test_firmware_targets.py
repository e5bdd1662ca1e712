"""The generated corrector on the chips it runs on: cross-compiled, run in a simulator over a
record, its error within the proven bound, its flash, RAM and cycles per sample measured."""

from __future__ import annotations

import json
import shutil
import subprocess

import numpy as np
import pytest

from creepcomp.digital.firmware import generate_firmware
from creepcomp.digital.firmware_check import jittered_record, run_firmware, verify_firmware
from creepcomp.digital.firmware_target import find_toolchain, run_on_target
from creepcomp.errors import CreepcompError, InputError
from creepcomp.io.jsonfiles import write_model
from creepcomp.io.records import Record, write_record
from creepcomp.model import CreepModel
from creepcomp.temperature import TemperatureLaw


def _installed(target: str) -> bool:
    try:
        find_toolchain(target)
    except CreepcompError:
        return False
    return True


needs_avr = pytest.mark.skipif(not _installed("avr"),
                               reason="avr-gcc, avr-libc, simavr or libsimavr-dev is not installed "
                                      "(make toolchains installs them from Debian)")

MODEL = CreepModel(beta=(0.01, 0.01, 0.015), tau=(5.0, 50.0, 500.0), gain=2e-3, offset=1e-3)
RATE = 80.0


def step_record(model: CreepModel, n: int = 2000, rate: float = RATE):
    """Steps between full scale and -half scale every 5 s, and sample-to-sample swings at the end."""
    t = np.arange(n) / rate
    load = np.where((np.arange(n) // 400) % 2 == 0, 1.0, -0.5)
    load[:50] = 0.0
    swings = min(200, n // 4)
    load[-swings:] = np.where(np.arange(swings) % 2 == 0, 1.0, -1.0)
    return t, load, model.response(t, load, hold="zero")


@needs_avr
@pytest.mark.parametrize("precision", ["float32", "q31"])
@pytest.mark.parametrize("method", ["subtractive", "supplemental"])
def test_avr_error_within_the_bound_and_costs_measured(precision, method):
    t, _, signal = step_record(MODEL)
    fs = float(np.max(np.abs(signal - MODEL.offset)))
    fw = generate_firmware(MODEL, method, precision, RATE, fs)
    check = verify_firmware(fw, t, signal, target="avr")
    assert check.passed and check.max_error_fs <= fw.bound.total_fs
    run = check.on_target
    assert run.target == "avr" and run.counts == "cycles"
    # float32: hi and lo per term; q31: one 64-bit word per term
    assert run.state_bytes == 8 * MODEL.n_terms
    assert 0 < run.stack_bytes < 128 and run.ram_bytes >= run.state_bytes + run.stack_bytes
    assert 200 < run.flash_bytes < 8000
    assert 500 < run.per_sample <= run.largest < 20_000
    out = check.to_dict()
    assert out["target"] == "avr" and out["cycles_per_sample"] == run.per_sample
    assert {"flash_bytes", "ram_bytes"} <= out.keys()


@needs_avr
@pytest.mark.parametrize("precision", ["float32", "q31"])
def test_avr_outputs_equal_the_host_outputs_bit_for_bit(precision):
    """IEEE binary32 rounded to nearest with no fused operation on both, integers alike: the
    ATmega's outputs are the host's."""
    t, _, signal = step_record(MODEL, 1500)
    fw = generate_firmware(MODEL, "subtractive", precision, RATE, 0.0021)
    host, _, _ = run_firmware(fw, signal, "relaxed", repeats=1)
    avr = run_on_target(fw, signal, "relaxed", "avr").outputs
    assert np.array_equal(host, avr)


@needs_avr
def test_avr_float_arithmetic_is_ieee_binary32_rounded_to_nearest(tmp_path):
    """The bound takes each float operation as IEEE binary32 rounded to nearest (even), with
    gradual underflow: avr-libc's soft float gives exactly numpy's float32 on random operands
    over 60 binades, cancelling pairs and subnormal results."""
    program = tmp_path / "arith.c"
    program.write_text("""
#include <avr/io.h>
#include <avr/interrupt.h>
#include <avr/sleep.h>
#include <stdint.h>
struct mailbox { uint8_t command, settled, spare[2]; float raw, aux, out; uint8_t status; };
static volatile struct mailbox box;
int main(void)
{
    uint8_t op = 0;
    GPIOR1 = (uint8_t)(uint16_t)&box;
    GPIOR2 = (uint8_t)((uint16_t)&box >> 8);
    for (;;) {
        float a, b;
        GPIOR0 = 1;
        if (!box.command) break;
        a = box.raw;
        b = box.aux;
        GPIOR0 = 2;
        box.out = op == 0 ? a + b : op == 1 ? a * b : a - b;
        GPIOR0 = 3;
        box.status = 0;
        op = (uint8_t)((op + 1) % 3);
        GPIOR0 = 4;
    }
    GPIOR0 = 5;
    cli();
    sleep_enable();
    sleep_cpu();
    return 0;
}
""")
    from creepcomp.digital.firmware_target import _runner

    elf = tmp_path / "arith.elf"
    subprocess.run(["avr-gcc", "-mmcu=atmega328p", "-Os", "-std=gnu99", program, "-lm", "-o", elf],
                   check=True)
    rng = np.random.default_rng(1)
    n = 12_000

    def operands():
        return (rng.uniform(1, 2, n) * rng.choice([-1, 1], n) * 2.0 ** rng.integers(-30, 30, n))

    a, b = operands().astype(np.float32), operands().astype(np.float32)
    b[::7] = (a[::7] * (1 + rng.uniform(-1e-6, 1e-6, len(a[::7])))).astype(np.float32)
    a[::11] *= np.float32(2.0 ** -120)
    a.astype("<f4").tofile(tmp_path / "a.bin")
    b.astype("<f4").tofile(tmp_path / "b.bin")
    subprocess.run([_runner(), elf, tmp_path / "a.bin", tmp_path / "o.bin",
                    tmp_path / "b.bin", "relaxed"], check=True, capture_output=True)
    got = np.fromfile(tmp_path / "o.bin", "<f4")
    op = np.arange(n) % 3
    with np.errstate(all="ignore"):
        want = np.where(op == 0, a + b, np.where(op == 1, a * b, a - b)).astype(np.float32)
    subnormal = (np.abs(want) < np.finfo(np.float32).tiny) & (want != 0)
    assert subnormal.sum() > 50
    assert np.array_equal(got.view("<u4"), want.view("<u4"))


@needs_avr
@pytest.mark.parametrize("precision", ["float32", "q31"])
def test_avr_temperature_and_dt_steps_within_their_bounds(precision):
    law = CreepModel(MODEL.beta, MODEL.tau, MODEL.gain, MODEL.offset,
                     temperature=TemperatureLaw.arrhenius(43000.0))
    t, _, signal = step_record(MODEL, 600)
    temperature = 25.0 + 20.0 * np.sin(np.arange(len(t)) / 90.0)
    fw = generate_firmware(law, "subtractive", precision, RATE, 0.0021)
    check = verify_firmware(fw, t, signal, temperature=temperature, target="avr")
    # the terms, the temperature (and the float32 step's previous input): within 64 bytes
    assert check.passed and 8 * law.n_terms + 4 <= check.on_target.state_bytes <= 64
    tj, _, sj = jittered_record(MODEL, 600, rate=RATE, max_interval=0.04)
    dt = generate_firmware(MODEL, "subtractive", precision, RATE, 0.0021, max_interval=0.04)
    assert verify_firmware(dt, tj, sj, target="avr").passed


def test_unknown_or_missing_toolchain_is_named(monkeypatch):
    with pytest.raises(InputError, match="target 'pic'"):
        find_toolchain("pic")
    monkeypatch.setattr(shutil, "which", lambda name: None)
    with pytest.raises(CreepcompError, match="gcc-avr avr-libc simavr libsimavr-dev.*make toolchains"):
        find_toolchain("avr")
    fw = generate_firmware(MODEL, rate=RATE)
    with pytest.raises(CreepcompError, match="qemu-system-arm"):
        verify_firmware(fw, *step_record(MODEL, 20)[::2], target="cortex-m4f")
    with pytest.raises(InputError, match="target 'z80'"):
        verify_firmware(fw, *step_record(MODEL, 20)[::2], target="z80")


def test_target_arithmetic_refuses_double_where_it_is_binary32():
    from creepcomp.digital.firmware_bound import TARGET_ARITHMETIC, check_target_arithmetic

    with pytest.raises(InputError, match="avr's double has 24 bits"):
        check_target_arithmetic("avr", uses_double=True)
    assert check_target_arithmetic("avr", uses_double=False).float_unit_roundoff == 2.0 ** -24
    assert check_target_arithmetic("cortex-m0plus", uses_double=True).double_bits == 53
    assert set(TARGET_ARITHMETIC) == {"host", "avr", "cortex-m0plus", "cortex-m4f"}


@needs_avr
def test_avr_refuses_a_map_computed_in_double():
    fw = generate_firmware(MODEL, rate=RATE, full_scale=1.0, output_polynomial=(0.05, 0.0))
    with pytest.raises(InputError, match="binary64"):
        run_on_target(fw, [0.0, 0.5], "relaxed", "avr")


@pytest.fixture
def cli_files(tmp_path):
    """A record of 700 samples and the model's file."""
    t, load, signal = step_record(MODEL, 700)
    return (write_record(tmp_path / "rec.csv", Record(t, load, signal)),
            write_model(tmp_path / "model.json", MODEL))


@needs_avr
def test_cli_target_avr_json(run_cli, cli_files):
    rec, model = cli_files
    status, out, err = run_cli("firmware", model, "--verify", rec, "--target", "avr",
                               "--precision", "q31", "--json")
    assert status == 0, err
    result = json.loads(out)
    assert result["target"] == "avr" and result["within_bound"]
    assert result["max_error_fs"] <= result["bound_fs"]
    for key in ("flash_bytes", "ram_bytes", "cycles_per_sample"):
        assert result[key] > 0
    status, out, err = run_cli("firmware", model, "--target", "avr", "--rate", "80")
    assert status == 2 and "give --verify RECORD" in err
    status, out, err = run_cli("firmware", model, "--verify", rec, "--target", "8051")
    assert status == 2 and "--target '8051'" in err


needs_qemu = pytest.mark.skipif(not _installed("cortex-m4f"),
                                reason="arm-none-eabi-gcc, newlib or qemu-system-arm is not installed "
                                       "(make toolchains installs them from Debian)")


@needs_qemu
@pytest.mark.parametrize("target", ["cortex-m0plus", "cortex-m4f"])
@pytest.mark.parametrize("precision", ["float32", "q31"])
def test_cortex_m_error_within_the_bound_and_outputs_equal_the_host(target, precision):
    t, _, signal = step_record(MODEL, 1200)
    fw = generate_firmware(MODEL, "supplemental", precision, RATE, 0.0021)
    check = verify_firmware(fw, t, signal, target=target)
    assert check.passed
    run = check.on_target
    assert run.counts == "instructions" and run.largest is None
    assert run.state_bytes == 8 * MODEL.n_terms and run.flash_bytes > 100
    assert 20 < run.per_sample < 20_000
    # the M4F's float32 step is in its FPU: far fewer instructions than the M0+'s soft float
    if target == "cortex-m4f" and precision == "float32":
        assert run.per_sample < 200
    start = "settled"
    host, _, _ = run_firmware(fw, signal, start, repeats=1)
    assert np.array_equal(host, run_on_target(fw, signal, start, target).outputs)


@needs_qemu
def test_cli_target_cortex_m_json_counts_instructions(run_cli, cli_files):
    rec, model = cli_files
    status, out, err = run_cli("firmware", model, "--verify", rec, "--target", "cortex-m0plus",
                               "--json")
    assert status == 0, err
    result = json.loads(out)
    assert result["target"] == "cortex-m0plus" and result["within_bound"]
    assert result["instructions_per_sample"] > 0 and "cycles_per_sample" not in result
    assert result["ns_per_sample"] is None and result["flash_bytes"] > 0
