import json

import numpy as np
import pytest

from creepcomp import synth
from creepcomp.data import path as data_path, wood_creep
from creepcomp.io.jsonfiles import read_model
from creepcomp.io.records import Record, write_record



@pytest.fixture(scope="module")
def two_term_record(tmp_path_factory):
    spec = synth.Spec(hidden={"extra_retardation": {"tau": 300.0, "beta": 0.012}}, beta=(0.03,),
                      tau=(30.0,), gain=2.0, offset=0.1, rate=4.0, duration=1800, program="staircase",
                      noise=synth.NoiseSpec(white=1e-3), seed=21)
    p = tmp_path_factory.mktemp("rec") / "two.csv"
    write_record(p, synth.generate(spec).record)
    return p


def test_fit_writes_a_model_that_size_reads(run_cli, two_term_record, tmp_path):
    model_path = tmp_path / "model.json"
    status, out, err = run_cli("fit", two_term_record, "-o", model_path, "--plot", tmp_path / "fit.png")
    assert status == 0, err
    assert "chosen" in out and "tau[1]" in out
    model = read_model(model_path)
    assert model.n_terms == 2
    assert sorted(model.tau)[1] == pytest.approx(300.0, rel=0.1)
    data = json.loads(model_path.read_text())
    assert {"uncertainty", "fit"} <= set(data)
    assert data["fit"]["orders"][1]["chosen"]
    assert (tmp_path / "fit.png").stat().st_size > 1000
    status, out, err = run_cli("size", "--model", model_path, "--json")
    assert status == 0, err
    assert len(json.loads(out)["cells"]) == 2


def test_fit_json_and_fixed_terms(run_cli, two_term_record):
    status, out, err = run_cli("fit", two_term_record, "--terms", "1", "--json")
    assert status == 0, err
    data = json.loads(out)
    assert len(data["beta"]) == 1 and data["fit"]["structure"] == "1 term"


def test_fit_an_instrument_export_with_a_column_mapping(run_cli, tmp_path):
    # the shipped spruce creep record, laid out as a rheometer's tab-separated export: a
    # preamble, long column names, a units row (time in minutes, strain in %)
    r = wood_creep(0.3)
    rows = "".join(f"{t / 60:.10g}\t{100 * e:.10g}\t{s:.10g}\n" for t, e, s in zip(r.time, r.signal, r.load))
    p = tmp_path / "creep.txt"
    p.write_text("Filename\tcreep.txt\n[File Parameters]\nName\tcreep\n\n[step]\nCreep\n"
                 "Step time\tStrain\tStress\nmin\t%\tMPa\n" + rows)
    status, out, err = run_cli("fit", p, "--columns", "time=Step time,signal=Strain,load=Stress",
                               "--load-step-at", "0", "--json")
    assert status == 0, err
    data = json.loads(out)
    assert data["fit"]["offset_note"].startswith("the load is constant")
    assert data["fit"]["residual_rms_relative"] < 0.1
    assert all(b > 0 for b in data["beta"])                 # creep: the strain grows under load


def test_rounded_time_stamps_need_the_merge_option(run_cli, tmp_path):
    p = tmp_path / "rounded.csv"
    p.write_text("Time,Creep Compliance\n" + "".join(f"{t},{1 + 0.01 * i}\n" for i, t in
                                                     enumerate([0.5, 1, 2, 3, 3, 4, 5, 6])))
    args = ("fit", p, "--columns", "time=Time,signal=Creep Compliance,load=1", "--load-step-at", "0")
    status, _, err = run_cli(*args)
    assert status == 2 and "line 6, column 'time': 3 repeats the previous time" in err


@pytest.mark.parametrize("args,needle", [
    (("--terms", "many"), "--terms 'many'"),
    (("--initial", "warm"), "--initial 'warm'"),
    (("--duplicate-times", "drop"), "--duplicate-times 'drop'"),
])
def test_fit_bad_options(run_cli, two_term_record, args, needle):
    status, _, err = run_cli("fit", two_term_record, *args)
    assert status == 2 and needle in err


def test_fit_constant_load_without_step_time(run_cli, tmp_path):
    t = np.arange(0.0, 100.0)
    p = write_record(tmp_path / "c.csv", Record(t, np.ones_like(t), 1 + 0.01 * t))
    status, _, err = run_cli("fit", p)
    assert status == 2 and "--load-step-at" in err


def test_fit_missing_column(run_cli, tmp_path):
    p = tmp_path / "bad.csv"
    p.write_text("time,force,signal\n0,1,2\n1,1,2\n")
    status, _, err = run_cli("fit", p)
    assert status == 2 and "missing required column 'load'" in err and "bad.csv" in err


def test_diagnose_the_bundled_record(run_cli, tmp_path):
    status, out, err = run_cli("diagnose", data_path("hidden_effect.csv"), "--json", "-o", tmp_path / "d")
    assert status == 0, err
    result = json.loads(out)
    assert result["cause"] == "asymmetric_recovery"
    assert result["gain"]["heldout_rms_ratio"] > 1.5
    html = (tmp_path / "d" / "report.html").read_text()
    assert html.count("data:image/png;base64,") >= 5
    assert "asymmetric_recovery" in html
    model = read_model(tmp_path / "d" / "model.json")
    assert "asymmetric_recovery" in model.extensions
    assert read_model(tmp_path / "d" / "baseline-model.json").n_terms == 1


def test_diagnose_text_output_and_bad_effect(run_cli, two_term_record):
    status, out, err = run_cli("diagnose", two_term_record, "--effects", "extra_retardation,viscous_flow")
    assert status == 0, err
    assert "cause: extra_retardation" in out and "Gain" in out
    status, _, err = run_cli("diagnose", two_term_record, "--effects", "gremlins")
    assert status == 2 and "unknown effect 'gremlins'" in err


def test_diagnose_corrected_column_needs_a_design(run_cli, tmp_path):
    t = np.arange(0.0, 200.0)
    u = (t > 20).astype(float)
    p = write_record(tmp_path / "c.csv", Record(t, u, u, corrected=u))
    status, _, err = run_cli("diagnose", p)
    assert status == 2 and "names no design" in err
    status, _, err = run_cli("diagnose", p, "--design", tmp_path / "missing.json")
    assert status == 2 and "no such file" in err
