"""The C corrector of a model with a load filter: its step_load returns the moving average of
the load, within the proven bound of the float64 estimate_load with the filter."""

from __future__ import annotations

import dataclasses
import difflib
import json
import re
import shutil
import subprocess

import numpy as np
import pytest

from creepcomp.digital.correctors import default_initial, estimate_load
from creepcomp.digital.firmware import generate_firmware
from creepcomp.digital.firmware_check import (STRICT_FLAGS, compile_object, run_firmware,
                                              verify_firmware)
from creepcomp.digital.firmware_transfer import filter_rounding
from creepcomp.errors import InputError
from creepcomp.io.jsonfiles import write_model
from creepcomp.io.records import Record, write_record
from creepcomp.load_filter import LoadFilter
from creepcomp.model import CreepModel
from creepcomp.temperature import TemperatureLaw

from test_firmware_transfer import RECIPROCAL, SPLINE, STATIC, steps_record

needs_gcc = pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is not installed")

RATE = 100.0
#: 16 samples at 100 Hz: 0.16 s.
FILTER = LoadFilter(16, 0.01)
#: Creep terms alone (no maps): the filter is what brings it to the maps' step.
LINEAR = CreepModel((0.1, 0.05), (5.0, 60.0), 2.0, 0.1)


def filtered(model: CreepModel, load_filter: LoadFilter = FILTER) -> CreepModel:
    return dataclasses.replace(model, load_filter=load_filter)


def noisy_steps(model: CreepModel, n: int = 8000, seed: int = 3):
    """Load steps and the model's signal with 0.1 % of white noise: ``(time, signal)``."""
    t, _, signal = steps_record(model, n=n, seed=seed)
    rng = np.random.default_rng(seed)
    return t, signal * (1.0 + 1e-3 * rng.standard_normal(n))


@needs_gcc
@pytest.mark.parametrize("model,method", [(LINEAR, "subtractive"), (RECIPROCAL, "subtractive"),
                                          (SPLINE, "supplemental"), (STATIC, "subtractive")],
                         ids=["linear", "reciprocal", "spline-supplemental", "static"])
def test_step_load_is_the_filtered_load_within_the_bound(model, method):
    model = filtered(model)
    t, signal = noisy_steps(model)
    fw = generate_firmware(model, method, rate=RATE, full_scale=(signal.min(), signal.max()),
                           name="pad")
    assert fw.maps["load_filter"] == {"samples": 16, "window": pytest.approx(0.16)}
    assert "#define PAD_LOAD_SAMPLES 16" in fw.header
    check = verify_firmware(fw, t, signal, repeats=1)
    assert check.passed and check.load["compared"] == len(t)
    assert 0 < check.load["max_error"] <= check.load["bound"] == fw.maps["bound_load"]
    # the bound has the filter's rounding as a part, and the C averages: its load is far from
    # the unfiltered estimate (the noise), within the bound of the filtered one
    term = fw.maps["terms"]["load filter: float32 mean of 16 loads"]
    assert 0 < term < fw.maps["bound_load"]
    start = default_initial(method)
    unfiltered = estimate_load(t, signal, dataclasses.replace(model, load_filter=None), method,
                               initial=start)
    reference = estimate_load(t, signal, model, method, initial=start)
    assert np.max(np.abs(reference - unfiltered)) > 100 * check.load["bound"]
    loads = run_firmware(fw, signal, start, repeats=1)[0][len(t):]
    assert np.max(np.abs(loads - reference)) == pytest.approx(check.load["max_error"])


@needs_gcc
def test_the_window_fills_from_init_settle_and_restore(tmp_path):
    """The first outputs average those there are; settle and restore empty the window (the
    next load is the unfiltered one); restore keeps the creep states."""
    model = filtered(LINEAR, LoadFilter(4, 0.01))
    fw = generate_firmware(model, rate=RATE, full_scale=1.0, name="pad")
    obj = compile_object(fw, tmp_path)
    (tmp_path / "main.c").write_text(r"""
#include <stdio.h>
#include "pad.h"
int main(void)
{
    pad_state a, b, c;
    pad_saved block;
    const float raw[6] = {0.1f, 0.5f, 0.7f, 0.2f, 0.9f, 0.4f};
    int i;
    pad_init(&a);
    for (i = 0; i < 6; ++i) printf("%.9g ", pad_step_load(&a, raw[i], 0));
    pad_save(&a, &block);
    pad_init(&b);
    for (i = 0; i < 6; ++i) (void)pad_step_load(&b, 0.9f, 0);
    printf("%d ", pad_restore(&b, &block));
    c = a;
    printf("%.9g %.9g ", pad_step_load(&b, 0.3f, 0), pad_step_load(&c, 0.3f, 0));
    pad_settle(&c, 0.3f);
    printf("%.9g\n", pad_step_load(&c, 0.3f, 0));
    return 0;
}
""")
    exe = tmp_path / "main"
    subprocess.run(["gcc", *STRICT_FLAGS, "-I", tmp_path, tmp_path / "main.c", obj, "-o", exe],
                   check=True)
    out = [float(v) for v in subprocess.run([exe], capture_output=True, text=True,
                                            check=True).stdout.split()]
    raw = np.array([0.1, 0.5, 0.7, 0.2, 0.9, 0.4, 0.3], dtype=np.float32).astype(float)
    t = np.arange(7) / RATE
    load = estimate_load(t, raw, model)
    unfiltered = estimate_load(t, raw, dataclasses.replace(model, load_filter=None))
    bound = fw.maps["bound_load"]
    assert np.max(np.abs(np.array(out[:6]) - load[:6])) <= bound
    assert out[6] == 0                                     # restored
    assert abs(out[7] - unfiltered[6]) <= bound            # restored: the window afresh
    assert abs(out[8] - load[6]) <= bound                  # carried on: the mean of the last 4
    assert abs(out[7] - out[8]) > 100 * bound
    settled = estimate_load(t[:1], raw[6:], dataclasses.replace(model, load_filter=None),
                            initial="settled")
    assert abs(out[9] - settled[0]) <= bound               # settled: the window afresh


def test_the_window_follows_the_rate():
    model = filtered(LINEAR, LoadFilter(10, 0.01))           # 0.1 s
    for rate, samples in ((100.0, 10), (50.0, 5), (1000.0, 100), (30.0, 3)):
        fw = generate_firmware(model, rate=rate, full_scale=1.0, name="pad")
        assert fw.maps["load_filter"]["samples"] == samples
        assert f"#define PAD_LOAD_SAMPLES {samples}\n" in fw.header
        assert f"float load_window[PAD_LOAD_SAMPLES];" in fw.header
    assert "PAD_LOAD_SAMPLES 256" in generate_firmware(model, rate=1e5, full_scale=1.0,
                                                       name="pad").header
    # a window shorter than one and a half samples is no filter: the corrector without it
    slow = generate_firmware(model, rate=6.0, full_scale=1.0, name="pad")
    plain = generate_firmware(LINEAR, rate=6.0, full_scale=1.0, name="pad")
    assert (slow.header, slow.source, slow.maps) == (plain.header, plain.source, None)


def test_without_a_filter_the_code_is_unchanged_and_the_filter_only_adds():
    """The filter adds its window, its function and the emptying of the window; the one line
    it changes is step_load's return. The bound's lines and the model id change with it."""
    bare = generate_firmware(RECIPROCAL, rate=RATE, full_scale=(1000.0, 10000.0), name="pad")
    with_filter = generate_firmware(filtered(RECIPROCAL), rate=RATE, full_scale=(1000.0, 10000.0),
                                    name="pad")
    removed = [line for line in difflib.ndiff(bare.source.splitlines(), with_filter.source.splitlines())
               if line.startswith("- ")]
    assert removed == ["-     return pad_load_of(c);"]
    for fw, present in ((bare, False), (with_filter, True)):
        code = fw.header + fw.source
        assert all((word in code) == present for word in ("load_window", "LOAD_SAMPLES", "pad_filtered"))
    assert "load_filter" not in bare.maps
    assert bare.maps["bound_load"] < with_filter.maps["bound_load"]
    model_id = re.compile(r"#define PAD_MODEL_ID (\w+)")
    assert model_id.search(bare.header)[1] != model_id.search(with_filter.header)[1]
    # a model of creep terms alone keeps its corrector of the compensated signal
    assert generate_firmware(LINEAR, rate=RATE, full_scale=1.0).maps is None


def test_the_filter_rounding_bounds_float32_means():
    """The C's sum (in order, from 0) and division, in numpy's float32, against the exact mean
    of the same floats."""
    rng = np.random.default_rng(5)
    for n in (2, 16, 256):
        for _ in range(200):
            y = rng.uniform(-3.0, 3.0, n).astype(np.float32)
            total = np.float32(0.0)
            for v in y:
                total = np.float32(total + v)
            mean = float(np.float32(total / np.float32(n)))
            assert abs(mean - float(np.mean(y.astype(float)))) <= filter_rounding(n, 3.0)
    u = 2.0 ** -24
    assert filter_rounding(16, 1.0) == pytest.approx(16 * u, rel=1e-6)


@pytest.mark.parametrize("model,kwargs,message", [
    (LINEAR, {"precision": "q31"}, "float32 only"),
    (LINEAR, {"state": "plain"}, "compensated states only"),
    (LINEAR, {"max_interval": 0.02}, "--rate instead of --max-interval"),
    (RECIPROCAL, {"precision": "q31", "full_scale": (1000.0, 10000.0)}, "float32 only"),
    (dataclasses.replace(LINEAR, temperature=TemperatureLaw.arrhenius(43000.0)), {},
     "temperature law has no C corrector"),
    (LINEAR, {"output_polynomial": (0.05, 0.0)}, "extension map"),
    (LINEAR, {"extension": {"peak": {}}}, "extension map"),
])
def test_refusals_name_the_filter(model, kwargs, message):
    kwargs = {"rate": RATE, "full_scale": 1.0, **kwargs}
    with pytest.raises(InputError, match=message) as caught:
        generate_firmware(filtered(model), **kwargs)
    assert "a model with a load filter" in str(caught.value) and "\n" not in str(caught.value)


def test_cli_refusal_is_one_line_with_status_2(run_cli, tmp_path):
    path = write_model(tmp_path / "model.json", filtered(LINEAR))
    for extra in (["--precision", "q31"], ["--state", "plain"], ["--max-interval", "0.02"]):
        status, out, err = run_cli("firmware", path, "--rate", "100", "--full-scale", "1", *extra)
        assert status == 2 and out == "" and err.count("\n") == 1
        assert "load filter" in err and "remove 'load_filter'" in err


@needs_gcc
def test_cli_names_the_filter_and_verifies_it(run_cli, tmp_path):
    model = filtered(RECIPROCAL, LoadFilter(10, 0.02))
    t, signal = noisy_steps(model, n=3000)
    rec = write_record(tmp_path / "rec.csv", Record(t, np.zeros_like(t), signal))
    path = write_model(tmp_path / "model.json", model)
    status, out, err = run_cli("firmware", path, "--verify", rec, "--json")
    assert status == 0, err
    result = json.loads(out)
    assert result["maps"]["load_filter"] == {"samples": 20, "window": pytest.approx(0.2)}
    assert result["load"]["max_error"] <= result["load"]["bound"] == result["maps"]["bound_load"]
    status, out, err = run_cli("firmware", path, "--verify", rec)
    assert status == 0, err
    assert "load filter: the mean of the last 20 loads (200 ms)" in out
    # a record at another rate: the filter's N no longer the firmware's
    status, out, err = run_cli("firmware", path, "--rate", "50", "--full-scale",
                               f"{signal.min()}:{signal.max()}", "--verify", rec)
    assert status == 2 and "give --rate 100" in err


@pytest.mark.parametrize("target", ["avr", "cortex-m0plus"])
def test_on_the_chips_the_filtered_load_stays_within_its_bound(target):
    from creepcomp.digital.firmware_target import find_toolchain
    from creepcomp.errors import CreepcompError

    try:
        find_toolchain(target)
    except CreepcompError as exc:
        pytest.skip(str(exc))
    model = filtered(RECIPROCAL)
    t, signal = noisy_steps(model, n=1500)
    fw = generate_firmware(model, rate=RATE, full_scale=(signal.min(), signal.max()), name="pad")
    check = verify_firmware(fw, t, signal, target=target)
    assert check.passed and check.on_target.target == target
    assert 0 < check.load["max_error"] <= check.load["bound"]
    assert check.on_target.state_bytes >= 4 * 16 + 4
