"""The C corrector of models with static maps and of static calibrations: it compiles strictly,
and over synthetic records its compensated signal and its load stay within their proven bounds
of compensate and estimate_load."""

from __future__ import annotations

import json
import re
import shutil

import numpy as np
import pytest

from creepcomp.digital.correctors import estimate_load
from creepcomp.digital.firmware import generate_firmware
from creepcomp.digital.firmware_check import verify_firmware
from creepcomp.digital.firmware_library import library_files
from creepcomp.digital.firmware_transfer import evaluation_error, raw_range, spread
from creepcomp.errors import InputError
from creepcomp.io.jsonfiles import write_model
from creepcomp.io.records import Record, write_record
from creepcomp.model import CreepModel
from creepcomp.transfer import StaticMap, Transfer

needs_gcc = pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is not installed")

RATE = 100.0
#: A resistive pad read as a resistance: conductance linear in load, 20 % of creep at 5 s.
RECIPROCAL = CreepModel((0.2,), (5.0,), gain=1e-4, offset=1e-4,
                        transfer=Transfer(signal_map=StaticMap("reciprocal", {"origin": 0.0})))
#: A spline signal map, a saturating load map, creep of either sign.
SPLINE = CreepModel((0.15, -0.05), (2.0, 30.0), gain=0.8, offset=0.1, transfer=Transfer(
    signal_map=StaticMap("spline", {"x": [0.0, 0.5, 1.0, 2.0, 4.0], "y": [0.0, 0.8, 1.3, 1.9, 2.5]}),
    load_map=StaticMap("saturating", {"limit": 20.0})))
#: A static calibration: no creep terms, a logarithmic signal map.
STATIC = CreepModel((), (), gain=2.0, offset=0.5,
                    transfer=Transfer(signal_map=StaticMap("log", {"origin": -1.0})))
#: A decreasing spline (a pad's counts) with a log load map.
FALLING = CreepModel((0.3,), (3.0,), 1.0, 0.2, transfer=Transfer(
    signal_map=StaticMap("spline", {"x": [100.0, 150.0, 200.0, 260.0], "y": [3.0, 1.5, 0.6, 0.1]}),
    load_map=StaticMap("log", {"origin": -1.0})))
#: A saturating signal map below a negative limit, a reciprocal load map (its inverse is not
#: defined at the relaxed start's corrected value).
SATURATING = CreepModel((0.4,), (8.0,), 0.5, 0.1, transfer=Transfer(
    signal_map=StaticMap("saturating", {"limit": -5.0}),
    load_map=StaticMap("reciprocal", {"origin": -2.0})))
#: Power maps on both sides (powf in the C).
POWER = CreepModel((0.1,), (10.0,), gain=0.5, offset=0.2, transfer=Transfer(
    load_map=StaticMap("power", {"exponent": 0.7, "origin": 0.0}),
    signal_map=StaticMap("power", {"exponent": 1.5, "origin": -0.1})))


def steps_record(model: CreepModel, n: int = 12_000, seed: int = 1):
    """Load steps between random levels (0 to 3 load units) held 0.5 to 15 s after a relaxed
    lead-in, and the signal the model gives: ``(time, load, signal)``."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / RATE
    load = np.zeros(n)
    i = 300
    while i < n:
        hold = int(rng.integers(50, 1500))
        load[i:i + hold] = rng.uniform(0.0, 3.0)
        i += hold
    return t, load, model.response(t, load, hold="zero")


@needs_gcc
@pytest.mark.parametrize("model,method", [(RECIPROCAL, "subtractive"), (SPLINE, "subtractive"),
                                          (SPLINE, "supplemental"), (STATIC, "subtractive"),
                                          (POWER, "subtractive"), (FALLING, "supplemental"),
                                          (SATURATING, "subtractive"),
                                          (CreepModel((), (), 2.0, 0.5), "subtractive")],
                         ids=["reciprocal", "spline", "spline-supplemental", "static", "power",
                              "falling-spline", "saturating", "static-line"])
def test_outputs_match_estimate_load_within_the_bound(model, method):
    t, load, signal = steps_record(model)
    fw = generate_firmware(model, method, rate=RATE, full_scale=(signal.min(), signal.max()),
                           name="pad")
    check = verify_firmware(fw, t, signal, repeats=1)
    assert check.passed
    assert check.load["compared"] == len(t)      # every exact corrected value within the range
    assert check.max_error_fs <= check.bound_fs       # 0 for a line: the compensated signal is the raw one
    assert 0 < check.load["max_error"] <= check.load["bound"] == fw.maps["bound_load"]
    # the load the C gives back is the load that made the signal, to float32 precision
    reference = estimate_load(t, signal, model, method)
    assert np.max(np.abs(reference - load)) < 1e-9
    assert check.load["bound"] < 1e-3 * 3.0
    assert "#define PAD_BOUND_LOAD" in fw.header and f"{fw.maps['bound_load']:.3e}" in fw.header


@needs_gcc
def test_the_code_uses_libm_only_for_power_and_log(tmp_path):
    from creepcomp.digital.firmware_check import compile_object
    import subprocess

    for model, libm in ((RECIPROCAL, False), (SPLINE, False), (STATIC, True)):
        _, _, signal = steps_record(model, n=2000)
        fw = generate_firmware(model, rate=RATE, full_scale=(signal.min(), signal.max()), name="pad")
        obj = compile_object(fw, tmp_path, flags=("-O0",))
        undefined = set(subprocess.run(["nm", "-u", obj], capture_output=True, text=True,
                                       check=True).stdout.split()) - {"U"}
        assert bool(undefined & {"logf", "expf", "powf"}) == libm, undefined
        code = re.sub(r"/\*.*?\*/", "", fw.source, flags=re.S)
        assert ("math.h" in code) == libm and "double" not in code


def test_the_bound_grows_with_the_range_near_a_reciprocal_origin():
    near = generate_firmware(RECIPROCAL, rate=RATE, full_scale=(200.0, 10000.0)).maps
    far = generate_firmware(RECIPROCAL, rate=RATE, full_scale=(2000.0, 10000.0)).maps
    assert near["bound_load"] > far["bound_load"] > 0
    assert near["bound_signal"] > far["bound_signal"] > 0


def test_map_error_parts_bound_what_float32_does():
    """Each form's float32 evaluation (numpy's float32 arithmetic, the operations of the C)
    stays within evaluation_error, and an input error moves each map by at most spread."""
    f32 = np.float32
    x = np.linspace(300.0, 9000.0, 5001)
    h = StaticMap("reciprocal", {"origin": 0.0})
    c = (f32(1.0) / (x.astype(f32) - f32(0.0))).astype(float)
    assert np.max(np.abs(c - h.forward(x.astype(f32).astype(float)))) <= evaluation_error(h, "forward", 300.0, 9000.0)
    s = StaticMap("saturating", {"limit": 20.0})
    q = np.linspace(-1.0, 15.0, 5001).astype(f32)
    inv = f32(1.0 / 20.0)
    c = (q / (f32(1.0) + q * inv)).astype(float)
    assert np.max(np.abs(c - s.inverse(q.astype(float)))) <= evaluation_error(s, "inverse", -1.0, 15.0)
    moved = np.abs(h.forward(x + 0.5) - h.forward(x))
    assert np.max(moved) <= spread(h, "forward", 300.0, 9000.0, 0.5)
    # a spline with knots no float holds, evaluated as the C does (float32 table, the segment
    # of the stored knots, y_k + s_k (v - x_k)), over and past its knots
    knots = np.array([0.1, 1 / 3, 2 / 3, 1.1, 7 / 3])
    values = np.array([0.0, 0.7, 0.9, 1.7, 1.8])
    m = StaticMap("spline", {"x": knots, "y": values})
    v = np.linspace(-0.5, 3.0, 20001).astype(f32)
    xk, yk = knots.astype(f32), values.astype(f32)
    sk = (np.diff(values) / np.diff(knots)).astype(f32)
    seg = np.clip(np.searchsorted(xk, v, side="right") - 1, 0, len(knots) - 2)
    c = (yk[seg] + sk[seg] * (v - xk[seg])).astype(float)
    error = np.max(np.abs(c - m.forward(v.astype(float))))
    assert 0 < error <= evaluation_error(m, "forward", -0.5, 3.0)


def test_refusals_name_what_to_do():
    with pytest.raises(InputError, match="float32"):
        generate_firmware(RECIPROCAL, precision="q31", full_scale=(1000.0, 10000.0))
    with pytest.raises(InputError, match="--rate instead of --max-interval"):
        generate_firmware(RECIPROCAL, full_scale=(1000.0, 10000.0), max_interval=0.04)
    with pytest.raises(InputError, match="leaves the signal map's domain"):
        generate_firmware(RECIPROCAL, full_scale=(-5.0, 10000.0))
    with pytest.raises(InputError, match="LOW:HIGH"):
        raw_range(STATIC, 10.0)                     # log about -1, unloaded at 0.65: symmetric leaves
    with pytest.raises(InputError, match="static maps"):
        generate_firmware(CreepModel((0.1,), (5.0,)), full_scale=(0.0, 1.0))


def test_library_examples_print_the_load():
    fw = generate_firmware(RECIPROCAL, rate=80.0, full_scale=(1000.0, 10000.0), name="pad")
    files = library_files(fw)
    sketch = files["examples/HX711Scale/HX711Scale.ino"]
    assert "pad_step_load(&corrector" in sketch and "PAD_RAW_MIN" in sketch
    assert "load" in sketch.lower()


@needs_gcc
def test_cli_writes_and_verifies_a_static_calibration(run_cli, tmp_path):
    t, load, signal = steps_record(STATIC, n=3000)
    rec = write_record(tmp_path / "rec.csv", Record(t, load, signal))
    model = write_model(tmp_path / "model.json", STATIC)
    status, out, err = run_cli("firmware", model, "-o", tmp_path / "fw", "--verify", rec, "--json")
    assert status == 0, err
    result = json.loads(out)
    assert result["load"]["max_error"] <= result["load"]["bound"] == result["maps"]["bound_load"]
    assert result["maps"]["raw_range"] == [pytest.approx(signal.min()), pytest.approx(signal.max())]
    header = (tmp_path / "fw" / "creep.h").read_text()
    assert "float creep_step_load(creep_state *s, float raw, float *compensated);" in header
    status, out, err = run_cli("firmware", model, "--rate", "100", "--full-scale", "0.7:600")
    assert status == 0, err
    assert "load units" in out
    status, out, err = run_cli("firmware", model, "--rate", "100", "--full-scale", "600:0.7")
    assert status == 2 and "LOW must be below HIGH" in err


@pytest.mark.parametrize("target", ["avr", "cortex-m0plus"])
def test_on_the_chips_the_maps_stay_within_their_bounds(target):
    """The chips' libm (avr-libc, newlib) with a power and a log map, and the spline's table."""
    from creepcomp.digital.firmware_target import find_toolchain
    from creepcomp.errors import CreepcompError

    try:
        find_toolchain(target)
    except CreepcompError as exc:
        pytest.skip(str(exc))
    for model in (POWER, STATIC, SPLINE):
        t, _, signal = steps_record(model, n=1500)
        fw = generate_firmware(model, rate=RATE, full_scale=(signal.min(), signal.max()), name="pad")
        check = verify_firmware(fw, t, signal, target=target)
        assert check.passed and check.on_target.target == target
        assert 0 < check.load["max_error"] <= check.load["bound"]
        assert check.on_target.flash_bytes > 0


def test_cli_keeps_the_maps_of_a_model_with_an_extension(run_cli, tmp_path):
    """An extension map and static maps have no C corrector together: refused, naming the
    baseline model, rather than written without the maps."""
    model = CreepModel(RECIPROCAL.beta, RECIPROCAL.tau, RECIPROCAL.gain, RECIPROCAL.offset,
                       {"mullins_softening": {"softening": 0.2, "shape": 0.0}},
                       transfer=RECIPROCAL.transfer)
    path = write_model(tmp_path / "model.json", model)
    status, out, err = run_cli("firmware", path, "--rate", "100", "--full-scale", "1000:9000")
    assert status == 2 and out == "" and err.count("\n") == 1
    assert "static maps" in err and "baseline model" in err


@pytest.mark.parametrize("model,full_scale,message", [
    (STATIC, "1:2:3", "expected VALUE or LOW:HIGH"),
    (STATIC, "-2:600", "leaves the signal map's domain"),
    (CreepModel((0.1,), (5.0,)), "0:1", "for a model with static maps"),
])
def test_cli_bad_raw_range_is_one_line_with_status_2(run_cli, tmp_path, model, full_scale, message):
    path = write_model(tmp_path / "model.json", model)
    status, out, err = run_cli("firmware", path, "--rate", "100", "--full-scale", full_scale)
    assert status == 2 and out == "" and err.count("\n") == 1 and message in err
