"""The corrector as an installable library: Arduino's layout (library.properties, src/,
examples/) and PlatformIO's library.json; its examples compiled for the ATmega328P against a
stub of the converter libraries and the Arduino core, and run on simavr."""

from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

from creepcomp.digital.firmware import generate_firmware
from creepcomp.digital.firmware_check import STRICT_FLAGS, run_firmware
from creepcomp.digital.firmware_library import LIBRARY_EXAMPLES, library_files, write_library
from creepcomp.digital.firmware_target import TOOLCHAINS, find_toolchain
from creepcomp.errors import CreepcompError, InputError
from creepcomp.io.jsonfiles import write_model
from creepcomp.model import CreepModel
from creepcomp.temperature import TemperatureLaw

STUBS = Path(__file__).parent / "firmware_stubs"
#: An HX711's codes: offset (the tare) 84210 counts, full scale 2^23 counts.
MODEL = CreepModel(beta=(0.01, 0.01, 0.015), tau=(5.0, 50.0, 500.0), gain=1.0, offset=84210.0)
FULL_SCALE = 8388608.0

try:
    find_toolchain("avr")
    AVR = True
except CreepcompError:
    AVR = False
needs_avr = pytest.mark.skipif(not AVR, reason="avr-gcc, avr-libc, simavr or libsimavr-dev is not "
                                               "installed (make toolchains installs them from Debian)")

#: The fields the Arduino library specification (1.5 format) requires in library.properties.
REQUIRED = ("name", "version", "author", "maintainer", "sentence", "paragraph", "category", "url",
            "architectures")
#: Its categories.
CATEGORIES = ("Display", "Communication", "Signal Input/Output", "Sensors", "Device Control",
              "Timing", "Data Storage", "Data Processing", "Other")


def properties(text: str) -> dict:
    return dict(line.split("=", 1) for line in text.splitlines() if line and not line.startswith("#"))


@pytest.mark.parametrize("precision", ["float32", "q31"])
def test_library_layout_follows_the_arduino_specification(tmp_path, precision):
    fw = generate_firmware(MODEL, "subtractive", precision, 80.0, FULL_SCALE, name="scale")
    written = write_library(fw, tmp_path / "lib")
    found = sorted(str(p.relative_to(tmp_path / "lib")) for p in (tmp_path / "lib").rglob("*") if p.is_file())
    assert found == sorted(str(p.relative_to(tmp_path / "lib")) for p in written)
    props = properties((tmp_path / "lib" / "library.properties").read_text())
    assert set(REQUIRED) <= props.keys()
    assert re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9 _.\-]*", props["name"])
    assert re.fullmatch(r"\d+\.\d+\.\d+", props["version"])
    assert props["category"] in CATEGORIES and props["architectures"] == "*"
    assert props["includes"] == "scale.h"
    # 1.5 layout: the sources in src/, each example in a folder of its sketch's name
    assert (tmp_path / "lib" / "src" / "scale.h").read_text() == fw.header
    assert (tmp_path / "lib" / "src" / "scale.c").read_text() == fw.source
    for folder, _, converter in LIBRARY_EXAMPLES:
        sketch = (tmp_path / "lib" / "examples" / folder / f"{folder}.ino").read_text()
        assert "#include <scale.h>" in sketch and "scale_step(&corrector" in sketch
    manifest = json.loads((tmp_path / "lib" / "library.json").read_text())
    assert manifest["name"] == props["name"] and manifest["version"] == props["version"]
    assert manifest["frameworks"] == ["arduino"] and manifest["headers"] == ["scale.h"]


def test_library_refuses_the_dt_step_and_maps_in_double():
    dt = generate_firmware(MODEL, "subtractive", "float32", 80.0, FULL_SCALE, max_interval=0.04)
    with pytest.raises(InputError, match="--library"):
        library_files(dt)
    poly = generate_firmware(MODEL, rate=80.0, full_scale=FULL_SCALE, output_polynomial=(1e-8, 0.0))
    with pytest.raises(InputError, match="double"):
        library_files(poly)


def build_example(folder: Path, lib: Path, example: str, name: str) -> Path:
    """The example compiled for the ATmega328P with avr-g++ against the stubs, linked with the
    corrector compiled strictly with avr-gcc."""
    flags = list(TOOLCHAINS["avr"].flags)
    obj = folder / f"{name}.o"
    subprocess.run(["avr-gcc", *STRICT_FLAGS, *flags, "-c", lib / "src" / f"{name}.c", "-o", obj],
                   check=True, capture_output=True)
    elf = folder / f"{example}.elf"
    subprocess.run(["avr-g++", *flags, "-Wall", "-Wextra", "-Werror", "-I", STUBS, "-I", lib / "src",
                    "-x", "c++", lib / "examples" / example / f"{example}.ino", "-x", "none",
                    STUBS / "arduino_stub.cpp", obj, "-Wl,--gc-sections", "-lm", "-o", elf],
                   check=True, capture_output=True, text=True)
    return elf


@needs_avr
@pytest.mark.parametrize("example", [folder for folder, _, _ in LIBRARY_EXAMPLES])
def test_library_examples_compile_for_the_uno_and_correct_on_simavr(tmp_path, example):
    from creepcomp.digital.firmware_target import _runner

    fw = generate_firmware(MODEL, "subtractive", "float32", 80.0, FULL_SCALE)
    lib = tmp_path / "lib"
    write_library(fw, lib)
    elf = build_example(tmp_path, lib, example, fw.name)
    size = subprocess.run(["avr-size", elf], check=True, capture_output=True, text=True).stdout
    text, data, bss = (int(v) for v in size.splitlines()[1].split()[:3])
    assert text + data < 32 * 1024 - 512 and data + bss < 2048      # the Uno: 32 KB, 2 KB
    t = np.arange(1200) / 80.0
    load = np.where((np.arange(1200) // 300) % 2 == 0, 0.9, -0.4)
    codes = np.round(MODEL.response(t, load * FULL_SCALE, hold="zero")).astype("<i4")
    codes.tofile(tmp_path / "in.bin")
    subprocess.run([_runner(), elf, tmp_path / "in.bin", tmp_path / "out.bin", "-", "relaxed"],
                   check=True, capture_output=True)
    on_uno = np.fromfile(tmp_path / "out.bin", "<f4").astype(float)
    host, _, _ = run_firmware(fw, codes.astype(float), "relaxed", repeats=1)
    assert np.array_equal(on_uno, host)
    # and it corrects: the creep of the held steps, over 1e-3 of full scale in the codes, is
    # removed to the codes' rounding
    truth = MODEL.offset + load * FULL_SCALE
    assert np.max(np.abs(codes - truth)) / FULL_SCALE > 1e-3
    assert np.max(np.abs(on_uno - truth)) / FULL_SCALE < 1e-6


@needs_avr
@pytest.mark.parametrize("precision", ["float32", "q31"])
def test_library_examples_of_every_kind_compile_for_the_uno(tmp_path, precision):
    law = CreepModel(MODEL.beta, MODEL.tau, MODEL.gain, MODEL.offset,
                     temperature=TemperatureLaw.arrhenius(43000.0))
    kinds = [(MODEL, "compensated"), (law, "compensated")]
    if precision == "float32":
        kinds.append((MODEL, "plain"))
    for model, state in kinds:
        fw = generate_firmware(model, "subtractive", precision, 10.0, FULL_SCALE, state=state)
        lib = tmp_path / f"lib-{model.temperature is not None}-{state}"
        write_library(fw, lib)
        for example, _, _ in LIBRARY_EXAMPLES:
            assert build_example(tmp_path, lib, example, fw.name).stat().st_size > 0


def test_cli_library(run_cli, tmp_path):
    model = write_model(tmp_path / "model.json", MODEL)
    status, out, err = run_cli("firmware", model, "--library", tmp_path / "lib", "--rate", "80",
                               "--full-scale", "8388608", "--json")
    assert status == 0, err
    files = json.loads(out)["files"]
    assert sorted(Path(f).relative_to(tmp_path / "lib").as_posix() for f in files) == sorted(
        ["library.properties", "library.json", "src/creep.h", "src/creep.c",
         "examples/HX711Scale/HX711Scale.ino", "examples/NAU7802Scale/NAU7802Scale.ino"])
    (tmp_path / "taken").write_text("x")
    status, out, err = run_cli("firmware", model, "--library", tmp_path / "taken", "--rate", "80",
                               "--full-scale", "8388608")
    assert status == 2 and "--library" in err
