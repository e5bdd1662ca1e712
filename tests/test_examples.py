"""The examples run: each script in a fresh process with ``--fast``, writing its files and
printing its figures with their units."""

from __future__ import annotations

import ast
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from creepcomp.io.jsonfiles import read_design
from creepcomp.synth import DEMO_CIRCUIT_SPEC, DEMO_SPEC
from creepcomp.units import parse_quantity

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
SCRIPTS = ("size_network", "ngspice_proof", "tolerance_report", "correct_record",
           "diagnose_record", "diagnose_built_network", "firmware_corrector", "real_insole",
           "real_wood", "over_temperature")
#: A percentage as the examples print it, e.g. ``0.029 %``, ``-0.0262 %``, ``2.22e-14 %``.
PERCENT = r"(-?[0-9.]+(?:e[-+]\d+)?) %"
#: A value with an SI prefix and a unit, e.g. ``1.2 MΩ``, ``501.5 nV``.
QUANTITY = r"(-?[0-9.]+ [pnµmkMG]?{unit})"


def run_example(name: str, out: Path, *args: str) -> str:
    """Run ``examples/NAME.py --fast --out OUT ARGS`` in a new process; its stdout."""
    env = dict(os.environ)
    # the subprocess imports this checkout's package, as the tests do
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT / "src"), env.get("PYTHONPATH")) if p)
    proc = subprocess.run([sys.executable, str(EXAMPLES / f"{name}.py"), "--fast", "--out", str(out),
                           *args], capture_output=True, text=True, env=env, timeout=600)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout


def written(folder: Path, *names: str) -> None:
    """Every named file exists in ``folder`` and is not empty."""
    for name in names:
        assert (folder / name).is_file() and (folder / name).stat().st_size > 0, name


def percent(pattern: str, text: str) -> list[float]:
    """The fractions printed as percentages in the first line matching ``pattern``."""
    line = re.search(pattern + r".*", text)
    assert line, pattern
    return [float(v) / 100 for v in re.findall(PERCENT, line.group(0))]


def quantity(text: str, kind: str) -> float:
    """A printed quantity (``13.2 µF``) in SI units."""
    return parse_quantity(text.replace(" ", ""), kind)


@pytest.fixture(scope="module")
def sized(tmp_path_factory):
    """``size_network.py``: its output folder and stdout."""
    out = tmp_path_factory.mktemp("examples") / "size_network"
    return out, run_example("size_network", out)


def test_every_example_is_tested_documented_and_indexed():
    assert sorted(p.stem for p in EXAMPLES.glob("*.py")) == sorted(SCRIPTS)
    index = (EXAMPLES / "README.md").read_text(encoding="utf-8")
    for name in SCRIPTS:
        tree = ast.parse((EXAMPLES / f"{name}.py").read_text(encoding="utf-8"))
        doc = ast.get_docstring(tree)
        assert doc and "--fast" in doc and "Run it" in doc, name
        assert any(isinstance(n, ast.FunctionDef) and n.name == "main" for n in tree.body), name
        assert f"examples/{name}.py" in index, name


def test_size_network(sized):
    out, stdout = sized
    written(out, "design.json", "sizing.png")
    design = read_design(out / "design.json")
    assert len(design.network.cells) == 2
    assert design.network.source_resistance > 0 and design.network.load_resistance is not None
    for label, _, value in design.network.parts():
        row = re.search(rf"^  {re.escape(label)}\s+{QUANTITY.format(unit='[ΩF]')}\s+"
                        rf"{QUANTITY.format(unit='[ΩF]')}\s+[-+][0-9.]+ %", stdout, re.MULTILINE)
        assert row, label
        assert quantity(row.group(2), "ohm" if label.startswith("R") else "farad") == \
            pytest.approx(value, rel=1e-3)
    predicted = json.loads((out / "design.json").read_text())["predicted"]
    ideal, chosen, *_, uncorrected = percent(r"residual creep, peak", stdout)
    assert chosen == pytest.approx(predicted["residual_creep_peak"], rel=5e-3)
    assert ideal < chosen < uncorrected
    hysteresis = percent(r"hysteresis, ±FS sweep of [0-9.]+ s", stdout)
    assert hysteresis[1] == pytest.approx(predicted["hysteresis"], rel=5e-3)
    assert f"design written to {out / 'design.json'}" in stdout


def test_ngspice_proof_of_the_sized_design(sized, tmp_path):
    design_file = sized[0] / "design.json"
    stdout = run_example("ngspice_proof", tmp_path, "--design", str(design_file))
    written(tmp_path, "design-step.cir", "ngspice-step.png")
    netlist = (tmp_path / "design-step.cir").read_text()
    assert ".tran" in netlist and "meas tran residual_creep_peak" in netlist
    predicted = read_design(design_file).extra["predicted"]["residual_creep_peak"]
    peaks = percent(r"residual creep, peak:", stdout)
    assert peaks[0] == pytest.approx(predicted, rel=0.02)           # python-control
    if "ngspice not run" not in stdout:
        assert peaks[1] == pytest.approx(predicted, rel=0.02)       # ngspice
        agreement = re.search(r"largest \|ngspice - python-control\|: (\S+) of full scale", stdout)
        assert float(agreement.group(1)) < 1e-5


def test_tolerance_report_of_the_default_design(tmp_path):
    stdout = run_example("tolerance_report", tmp_path)
    written(tmp_path, "tolerances.html")
    assert "<img" in (tmp_path / "tolerances.html").read_text(encoding="utf-8")
    assert re.search(r"\b2000 samples, seed \d+", stdout)
    for metric in ("residual creep, peak", "residual creep, final", "hysteresis"):
        nominal, p50, p95, p99, largest = percent(rf"(?m)^  {metric}\s", stdout)
        assert p50 <= p95 <= p99 <= largest
    yield_ = re.search(r"\(OIML R60 C3\): ([0-9.]+) %", stdout)
    assert yield_ and 0 <= float(yield_.group(1)) <= 100
    worst = percent(r"worst case of the peak residual creep:", stdout)[0]
    assert worst >= percent(r"(?m)^  residual creep, peak\s", stdout)[4]


def test_correct_record(tmp_path):
    stdout = run_example("correct_record", tmp_path)
    written(tmp_path, "record.csv", "model.json", "corrected.csv", "correction-subtractive.png",
            "correction-supplemental.png")
    for method in ("subtractive", "supplemental"):
        raw = percent(rf"{method}, raw signal", stdout)
        corrected = percent(rf"{method}, corrected", stdout)
        assert re.search(rf"{method}, corrected\s+{QUANTITY.format(unit='V')}", stdout)
        assert corrected[0] < raw[0] / 10 and corrected[1] < raw[1] / 10   # peak and RMS
    streamed = re.search(r"blocks of \d+ samples: .* correction (\S+) V", stdout)
    assert float(streamed.group(1)) < 1e-12


@pytest.mark.slow
def test_diagnose_record_finds_the_hidden_effect(tmp_path):
    stdout = run_example("diagnose_record", tmp_path)
    written(tmp_path, "report.html", "diagnosis.json", "model.json", "baseline-model.json", "fit.png")
    (effect, truth), = DEMO_SPEC.hidden.items()
    assert f"cause: {effect}" in stdout
    for name, value in truth.items():
        fitted = re.search(rf"{name} = ([0-9.]+ m?s) ±", stdout)
        assert quantity(fitted.group(1), "second") == pytest.approx(value, rel=0.03)
    ratios = [float(r) for r in re.findall(r"\(ratio ([0-9.]+)\)", stdout)]
    assert len(ratios) == 2 and min(ratios) > 1
    assert json.loads((tmp_path / "diagnosis.json").read_text())["cause"] == effect


@pytest.mark.slow
def test_diagnose_built_network_finds_the_fault_and_the_fix(tmp_path):
    stdout = run_example("diagnose_built_network", tmp_path)
    written(tmp_path, "report.html", "diagnosis.json", "model.json", "baseline-model.json",
            "as-built-design.json")
    (effect, truth), = DEMO_CIRCUIT_SPEC.hidden.items()
    assert f"circuit cause: {effect}" in stdout
    fitted = re.search(rf"C = {QUANTITY.format(unit='F')} ±", stdout)
    assert quantity(fitted.group(1), "farad") == pytest.approx(truth["C"], rel=0.01)
    design, as_built = percent(r"peak residual creep of a load step:", stdout)
    assert as_built > design
    fix = re.search(rf"fix: (\S+) {QUANTITY.format(unit='[ΩF]')} -> {QUANTITY.format(unit='[ΩF]')} "
                    rf"\((E\d+)\): peak residual creep {PERCENT}", stdout)
    assert fix and float(fix.group(5)) / 100 < as_built
    built = read_design(tmp_path / "as-built-design.json")
    assert max(c.C for c in built.network.cells) == pytest.approx(truth["C"], rel=0.01)
    assert "ngspice, as-built network" not in stdout                 # --fast: not run


def test_firmware_corrector_sketch_within_its_bound(tmp_path):
    stdout = run_example("firmware_corrector", tmp_path)
    written(tmp_path, "model.json", "record.csv", "hx711_scale/creep.h", "hx711_scale/creep.c",
            "hx711_scale/hx711_scale.ino")
    bound = float(re.search(r"proven worst-case error (\S+) of full scale", stdout).group(1))
    assert 0 < bound <= 1e-5
    if "gcc not found" in stdout:
        return
    written(tmp_path, "sketch-output.csv")
    measured = float(re.search(r"largest difference from the float64 corrector (\S+) of full scale",
                               stdout).group(1))
    assert measured <= bound
    grams = [float(g) for g in re.findall(r"(\d+\.\d+) g ", stdout)]
    raw, corrected = grams[:2]
    assert corrected < raw / 100
    assert re.search(r"[0-9.]+ ns per sample \(gcc -O2\), object \d+ bytes", stdout)
    # over temperature: both sketches (thermistor, NAU7802's own sensor) within the float32 bound
    written(tmp_path, "record-temperature.csv", "hx711_scale_temperature/creep.c",
            "nau7802_scale/nau7802_scale.ino")
    bound_t = float(re.search(r"temperature per sample, .*?proven worst-case error (\S+) of full scale",
                              stdout).group(1))
    sketches = re.findall(r"(HX711|NAU7802) sketch, .*?largest difference from the float64 corrector "
                          r"(\S+) of full scale", stdout)
    assert [name for name, _ in sketches] == ["HX711", "NAU7802"]
    assert all(float(measured) <= bound_t for _, measured in sketches) and bound_t <= 1e-6
    raw_t, ignored, corrected_t = grams[2:5]
    assert ignored > raw_t / 20 and corrected_t < ignored / 100


@pytest.mark.slow
def test_real_insole(tmp_path):
    stdout = run_example("real_insole", tmp_path)
    for name, taxel in (("left", 128), ("right", 123)):
        written(tmp_path, f"{name}-fit.png", f"{name}/report.html", f"{name}/diagnosis.json")
        assert re.search(rf"^{name}: \S+, taxel {taxel}: \d+ samples over", stdout, re.MULTILINE)
        cause = json.loads((tmp_path / name / "diagnosis.json").read_text())["cause"]
        assert f"cause: {cause}" in stdout
    # the counts fall under pressure: the settled sensitivity is negative in both records
    settled = [float(v) for v in re.findall(r"settled sensitivity gain x \(1 \+ beta0\) = (\S+) counts/bar", stdout)]
    assert len(settled) == 2 and all(v < 0 for v in settled)
    assert "--fast: every 4th sample" in stdout


@pytest.mark.slow
def test_real_wood(tmp_path):
    stdout = run_example("real_wood", tmp_path)
    for level in ("0.3", "0.5"):
        written(tmp_path, f"wood-{level}-fit.png", f"wood-{level}/report.html")
    betas = [float(b) for b in re.findall(r"beta0 = ([-0-9.]+) % over", stdout)]
    assert len(betas) == 2 and all(0 < b < 100 for b in betas)          # creep, not relaxation
    compliances = [float(j) for j in re.findall(r"J_c\(50 h\) = (\S+) 1/MPa", stdout)]
    assert len(compliances) == 2 and all(1e-6 < j < 1e-3 for j in compliances)


def test_over_temperature(tmp_path):
    stdout = run_example("over_temperature", tmp_path)
    written(tmp_path, "design.json", "over-temperature.png")
    worst = [percent(rf"\({k}\) [^:]+: worst", stdout)[0] for k in "abc"]
    assert worst[2] < worst[1] < worst[0]
    assert worst[2] < worst[0] / 3.5                        # E12 in --fast; E24 gives a quarter
    design = read_design(tmp_path / "design.json", active=True)
    assert set(design.extra["parts"]["thermistors"]) == {"RT1"} and design.network.topology == "active"
    assert design.extra["over_temperature"]["worst"] == pytest.approx(worst[2], rel=5e-3)
