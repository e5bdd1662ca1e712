"""Hostile model, design and record files: one check of each kind of file for every command,
outputs that never replace an input or a file the user did not name, time units honoured."""

import json
import shutil
import tempfile
import subprocess
from pathlib import Path

import pytest

from creepcomp.errors import InputError
from creepcomp.io.jsonfiles import read_design, read_model
from creepcomp.model import CreepModel

DATA = Path(__file__).resolve().parents[1] / "src" / "creepcomp" / "data"
DESIGN = DATA / "built_network.design.json"
RECORD = DATA / "hidden_effect.csv"


def refused(status, out, err, needle):
    assert status == 2, err
    assert needle in err, err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err


def write(path, data):
    path.write_text(json.dumps(data) if not isinstance(data, str) else data)
    return path


@pytest.mark.parametrize("model, needle", [
    ({"beta": [0.03], "tau": [True]}, "tau = True is not a number"),
    ({"beta": [0.03], "tau": ["45"]}, "tau = '45' is not a number"),
    ({"beta": [0.03], "tau": [45], "offset": 1e300}, "offset = 1e+300"),
    ({"beta": [0.03], "tau": [45], "gain": 1e-40}, "gain = 1e-40"),
    ({"beta": [1e8], "tau": [45]}, "beta0 = 1e+08"),
    ({"beta": [0.03], "tau": [1e-300]}, "tau = 1e-300 s"),
    ({"beta": [0.03], "tau": [45], "extensions": [1, 2]}, "'extensions': expected an object"),
    ('{"beta": [0.03], "tau": [45], "gain": 1' + "0" * 5000 + "}", "cannot be read"),
])
def test_a_model_is_checked_once_for_every_command(tmp_path, run_cli, model, needle):
    path = write(tmp_path / "m.json", model)
    with pytest.raises(InputError, match=needle.replace("+", r"\+").replace("(", r"\(")):
        read_model(path)
    for args in (["firmware", path, "--rate", "100", "--full-scale", "1", "-o", tmp_path / "fw"],
                 ["correct", RECORD, "--model", path, "-o", tmp_path / "c.csv"],
                 ["size", "--model", path]):
        refused(*run_cli(*args), needle=needle)
    assert not (tmp_path / "fw").exists() and not (tmp_path / "c.csv").exists()


def test_every_model_the_check_accepts_gives_c_that_compiles(tmp_path, run_cli):
    if shutil.which("gcc") is None:
        pytest.skip("no gcc")
    path = write(tmp_path / "m.json", {"beta": [0.03], "tau": [45], "offset": 1e30, "gain": 1e-30})
    status, out, err = run_cli("firmware", path, "--rate", "100", "--full-scale", "1e30",
                               "-o", tmp_path / "fw")
    assert status in (0, 2), err
    if status == 0:
        c = (tmp_path / "fw" / "creep.c").read_text()
        assert "inf" not in c.replace("info", "")
        done = subprocess.run(["gcc", "-std=c99", "-c", "-o", str(tmp_path / "c.o"),
                               str(tmp_path / "fw" / "creep.c")], capture_output=True, text=True)
        assert done.returncode == 0, done.stderr


@pytest.mark.parametrize("change, needle", [
    ({"topology": "foo"}, "topology 'foo'"),
    ({"topology": "lag"}, "but the network is a lead network"),
    ({"cells": [{"R": True, "C": 1.5e-5}]}, "cells[0].R = True is not a number"),
    ({"parts": {"resistors": {"technology": "unobtainium"}}}, "technology 'unobtainium'"),
    ({"parts": {"capacitors": {"technology": "polypropylene", "tolerance": 5}}}, "tolerance 5.0"),
    ({"parts": {"thermistors": {"R1": {"R25": 1e4, "B": -3000}}}}, "must be positive"),
])
def test_a_design_and_its_parts_are_checked_once_for_every_command(tmp_path, run_cli, change,
                                                                      needle):
    path = write(tmp_path / "d.json", dict(json.loads(DESIGN.read_text()), **change))
    for args in (["netlist", path, "-o", tmp_path / "n.cir"], ["mc", path, "--n", "20"],
                 ["simulate", path, "--no-plot"], ["creep-test", path]):
        refused(*run_cli(*args), needle=needle)
    if "parts" not in change:
        with pytest.raises(InputError):
            read_design(path)


def test_a_model_from_the_python_api_is_checked_the_same_way():
    with pytest.raises(InputError, match="tau = True"):
        CreepModel((0.03,), (True,))
    with pytest.raises(InputError, match="extensions"):
        CreepModel((0.03,), (45.0,), extensions=[1])


def test_a_folder_output_never_replaces_an_input_of_the_run(tmp_path, run_cli):
    out = tmp_path / "out"
    out.mkdir()
    design = out / "as-built-design.json"
    design.write_text(DESIGN.read_text())
    record = out / "creep.c"
    record.write_text(RECORD.read_text())
    diagnosis = out / "diagnosis.json"
    diagnosis.write_text("{}")
    before = {p: p.read_bytes() for p in (design, record, diagnosis)}
    refused(*run_cli("diagnose", DATA / "built_network.csv", "--design", design, "-o", out),
            needle="as-built-design.json is an input")
    refused(*run_cli("diagnose", diagnosis, "-o", out), needle="diagnosis.json is an input")
    refused(*run_cli("firmware", DATA / "default_sensor.json", "--verify", record, "-o", out),
            needle="creep.c is an input")
    assert {p: p.read_bytes() for p in before} == before


def test_no_write_replaces_a_file_the_command_read():
    from creepcomp.io.jsonfiles import write_model
    from creepcomp.io.outputs import inputs_of_this_run

    folder = Path(tempfile.mkdtemp())
    path = folder / "m.json"
    write_model(path, CreepModel((0.03,), (45.0,)))
    with inputs_of_this_run():
        model = read_model(path)
        with pytest.raises(InputError, match="is a file this command reads"):
            write_model(path, model.with_terms((0.02,), (45.0,)))
        write_model(folder / "other.json", model)
    assert read_model(path) == model
    write_model(path, model.with_terms((0.02,), (45.0,)))  # outside a command: a notebook may
    assert read_model(path).beta == (0.02,)


def test_a_derived_output_name_never_replaces_a_file(tmp_path):
    from creepcomp.io.outputs import unnamed_output

    first = tmp_path / "creep.model.json"
    assert unnamed_output(first) == first
    first.write_text("{}")
    (tmp_path / "creep.model-2.json").write_text("{}")
    assert unnamed_output(first) == tmp_path / "creep.model-3.json"


def _in_milliseconds(path):
    out = []
    for line in RECORD.read_text().splitlines():
        if line[:1].isdigit():
            cells = line.split(",")
            cells[0] = repr(float(cells[0]) * 1000)
            line = ",".join(cells)
        elif line.startswith("time"):
            out.append("# units.time: ms")
        out.append(line)
    path.write_text("\n".join(out) + "\n")
    return path


def test_a_time_unit_in_the_metadata_is_honoured_by_every_reader(tmp_path, run_cli):
    from creepcomp.io.records import read_record, read_record_chunks, scan_record

    ms = _in_milliseconds(tmp_path / "ms.csv")
    seconds = read_record(RECORD).time
    assert read_record(ms).time == pytest.approx(seconds, rel=1e-12)
    assert read_record(ms).metadata["units.time"] == "s (converted from ms)"
    pieces = list(read_record_chunks(ms, block_bytes=4096))
    assert len(pieces) > 1
    assert __import__("numpy").concatenate([p.time for p in pieces]) == pytest.approx(seconds)
    assert scan_record(ms).last_time == pytest.approx(seconds[-1])
    fitted = [json.loads(run_cli("fit", r, "--terms", "1", "--json")[1])["tau"] for r in (RECORD, ms)]
    assert fitted[1] == pytest.approx(fitted[0], rel=1e-6)
    # a record written by creepcomp keeps saying where its seconds came from, and reads again
    status, out, err = run_cli("correct", ms, "--model", DATA / "default_sensor.json", "-o",
                               tmp_path / "c.csv")
    assert status == 0, err
    assert read_record(tmp_path / "c.csv").time == pytest.approx(seconds)


def test_an_unknown_time_unit_is_named(tmp_path):
    from creepcomp.io.records import read_record

    path = tmp_path / "weeks.csv"
    path.write_text("# units.time: fortnights\ntime,load,signal\n0,0,0\n1,1,1\n2,1,1\n")
    with pytest.raises(InputError, match="time unit 'fortnights'"):
        read_record(path)


def _noiseless(path, samples, step):
    import numpy as np

    t = np.arange(samples) * step
    load = (t >= 2 * step).astype(float)
    signal = load * (1 + 0.03 * (1 - np.exp(-np.clip(t - 2 * step, 0, None) / 45.0)))
    path.write_text("time,load,signal\n" + "\n".join(
        f"{a!r},{b!r},{c!r}" for a, b, c in zip(t.tolist(), load.tolist(), signal.tolist())) + "\n")
    return path


def test_fit_refuses_more_parameters_than_samples(tmp_path, run_cli):
    path = _noiseless(tmp_path / "twenty.csv", 20, 5.0)
    refused(*run_cli("fit", path, "--terms", "20", "-o", tmp_path / "m.json"),
            needle="usable samples: fewer terms")
    assert not (tmp_path / "m.json").exists()


def test_a_noiseless_record_gets_no_term_below_what_a_sensor_resolves(tmp_path, run_cli):
    from creepcomp.fit.prony import SMALLEST_BETA

    path = _noiseless(tmp_path / "clean.csv", 2000, 0.5)
    status, out, err = run_cli("fit", path, "-o", tmp_path / "m.json")
    assert status == 0, err
    model = read_model(tmp_path / "m.json")
    assert min(abs(b) for b in model.beta) >= SMALLEST_BETA
    assert model.tau[0] == pytest.approx(45.0, rel=1e-6)
    status, out, err = run_cli("size", "--model", tmp_path / "m.json")
    assert status == 0, err


def test_a_header_over_the_csv_field_limit_is_one_line(tmp_path, run_cli):
    lines = RECORD.read_text().splitlines()
    at = next(k for k, line in enumerate(lines) if line.startswith("time"))
    lines[at] += ",x" + "y" * 200_000
    path = tmp_path / "head.csv"
    path.write_text("\n".join(lines) + "\n")
    for args in (["fit", path], ["correct", path, "--model", DATA / "default_sensor.json"],
                 ["diagnose", path], ["fit", path, "--columns", "time=time,load=load,signal=signal"]):
        refused(*run_cli(*args), needle="field larger than field limit")


@pytest.mark.parametrize("entry, needle", [
    ({}, "missing parameter 'rate'"), ({"rate": "fast"}, "could not convert string to float"),
    ({"rate": True}, "rate = True is not a number")])
def test_an_extension_with_wrong_parameters_is_named(tmp_path, run_cli, entry, needle):
    path = write(tmp_path / "m.json", {"beta": [0.03], "tau": [45], "extensions": {"viscous_flow": entry}})
    refused(*run_cli("correct", RECORD, "--model", path), needle=needle)


def test_creep_test_refuses_a_rate_whose_arrays_do_not_fit(run_cli):
    for rate in ("1e9", "1e-3"):
        refused(*run_cli("creep-test", DATA / "default_sensor.json", "--digital", "--rate", rate),
                needle="Hz: the digital creep test samples")


def test_a_sweep_period_far_from_the_creep_is_named(run_cli):
    for period in ("1e-300", "1e300"):
        refused(*run_cli("size", "--term", "3%@45s", "--sweep-period", period),
                needle="sweep period")


def test_a_shunt_is_checked_as_the_cells_are(tmp_path, run_cli):
    design = json.loads(DESIGN.read_text())
    for shunt, needle in (([{"R": "1e6", "C": 1e-6}], "shunt[0].R = '1e6' is not a number"),
                          ({"R": 1e6, "C": 1e-6}, "'shunt' must be a list")):
        path = write(tmp_path / "d.json", dict(design, shunt=shunt))
        for command in ("simulate", "netlist", "mc"):
            refused(*run_cli(command, path), needle=needle)


@pytest.mark.slow
def test_sizing_twenty_terms_ends_in_seconds_within_bounded_memory(tmp_path):
    import resource
    import sys
    import time

    path = write(tmp_path / "m20.json", {"beta": [0.002] * 20, "tau": [10 ** (0.3 * k) for k in range(20)]})
    for extra in ([], ["--allow-impractical", "--series", "none"]):
        start = time.perf_counter()
        done = subprocess.run([sys.executable, "-c", "from creepcomp.cli import run; run()", "size",
                               "--model", str(path), *extra], capture_output=True, text=True,
                              timeout=120, preexec_fn=lambda: resource.setrlimit(
                                  resource.RLIMIT_AS, (3 << 30, 3 << 30)))
        assert done.returncode in (0, 3), done.stderr
        assert "Traceback" not in done.stderr
        assert time.perf_counter() - start < 60


def test_mc_refuses_a_run_longer_than_an_hour_with_the_estimate(run_cli):
    refused(*run_cli("mc", DESIGN, "--n", "1e12"), needle="more than the 60 minutes a run may take; use --n")


def test_the_closed_form_metrics_are_the_same_in_blocks():
    import numpy as np

    from creepcomp.verify import variants

    rng = np.random.default_rng(0)
    rel = rng.normal(0, 0.01, (50, 40))
    q = rng.uniform(1, 100, (50, 40))
    whole = variants._step_peak(rel, q)
    saved = variants.BLOCK_VALUES
    try:
        variants.BLOCK_VALUES = 40 * 28 * 7
        assert np.array_equal(variants._in_blocks(variants._step_peak, rel, q), whole)
    finally:
        variants.BLOCK_VALUES = saved


@pytest.mark.slow
def test_mc_of_a_twenty_cell_design_ends_within_a_minute(tmp_path):
    import resource
    import sys
    import time

    design = json.loads(DESIGN.read_text())
    design["cells"] = [{"R": 3e6 * (1 + k % 3), "C": 1.5e-5 / (1 + k)} for k in range(20)]
    design["creep"] = {"beta": [0.002] * 20, "tau": [45.0 * (1 + k) for k in range(20)]}
    path = write(tmp_path / "d20.json", design)
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", "from creepcomp.cli import run; run()", "mc", str(path),
                           "--n", "1000", "--spot-check", "0"], capture_output=True, text=True, timeout=180,
                          preexec_fn=lambda: resource.setrlimit(resource.RLIMIT_AS, (3 << 30, 3 << 30)))
    assert done.returncode == 0, done.stderr
    assert time.perf_counter() - start < 60
    assert "samples each" in done.stdout


def test_a_digital_creep_test_without_a_temperature_law_names_no_reference(run_cli):
    status, out, err = run_cli("creep-test", DATA / "default_sensor.json", "--digital")
    assert status == 0, err
    assert "None" not in out and "fixed at the reference temperature" not in out


def test_a_temperature_beyond_the_parts_data_is_named_for_every_command(run_cli):
    for args, option in ((["size", "--term", "3%@45s", "--temperature-range", "-40:10000"], "--temperature-range"),
                         (["netlist", DESIGN, "--temperature", "1e6"], "--temperature"),
                         (["mc", DESIGN, "--n", "100", "--temperature", "1e6"], "--temperature")):
        refused(*run_cli(*args), needle=f"{option}: ")
    refused(*run_cli("size", "--term", "3%@45s", "--activation-energy", "1e9", "--temperature-range",
                     "-40:85"), needle="activation_energy = 1e+09 J/mol; at most")


def test_options_given_twice_or_named_for_another_command_are_clear(tmp_path, run_cli):
    refused(*run_cli("mc", DESIGN, "--n", "100", "--tol", "C1=1%", "--tol", "C1=2%"),
            needle="--tol C1: given twice")
    status, out, err = run_cli("mc", DESIGN, "--n", "100", "--creep-test", "X3")
    refused(status, out, err, needle="--creep-test X3: expected an accuracy class")
    assert "--class" not in err
    status, out, err = run_cli("netlist", DESIGN, "-o", tmp_path / "a b;c.cir")
    assert status == 0, err
    assert f"ngspice -b '{tmp_path / 'a b;c.cir'}'" in out
