import json
import subprocess
import sys

import pytest

from creepcomp.io.jsonfiles import read_design


def test_size_json_contract_keys_and_paper_figures(run_cli):
    status, out, err = run_cli("size", "--beta0", "3%", "--tau", "45s", "--json")
    assert status == 0, err
    data = json.loads(out)
    for key in ("cells", "R2", "predicted", "ideal"):
        assert key in data
    for block in (data["predicted"], data["ideal"]["predicted"]):
        assert {"residual_creep_peak", "residual_creep_final"} <= set(block)
    assert {"cells", "R2", "predicted"} <= set(data["ideal"])
    assert data["ideal"]["predicted"]["residual_creep_peak"] < 1e-9

    status, out, _ = run_cli("size", "--beta0", "0.03", "--tau", "45", "--rule", "paper",
                             "--series", "none", "--json")
    paper = json.loads(out)["predicted"]
    assert paper["residual_creep_final"] == pytest.approx(8.49e-4, rel=0.01)
    assert paper["residual_creep_peak"] == pytest.approx(9.64e-4, rel=0.01)


def test_size_writes_a_design_file_per_contract(run_cli, tmp_path):
    path = tmp_path / "d" / "design.json"
    status, out, err = run_cli("size", "--beta0", "2.7%", "--tau", "37s", "--series", "E24",
                               "--cap-series", "E6", "--source-resistance", "1k", "-o", path)
    assert status == 0, err
    data = json.loads(path.read_text())
    assert set(data) >= {"creep", "cells", "R2", "source_resistance", "load_resistance"}
    assert data["creep"] == {"beta": [0.027], "tau": [37.0]}
    assert data["source_resistance"] == 1000.0 and data["load_resistance"] is None
    design = read_design(path)
    assert design.network.cells[0].R == data["cells"][0]["R"]
    assert "nearest values" in out and "snap error" in out


def test_size_reads_a_model_file(run_cli, tmp_path):
    model = tmp_path / "m.json"
    model.write_text(json.dumps({"beta": [0.01, 0.01, 0.015], "tau": [5, 50, 500]}))
    status, out, err = run_cli("size", "--model", model, "--series", "none", "--json")
    assert status == 0, err
    data = json.loads(out)
    assert len(data["cells"]) == 3 and data["predicted"]["residual_creep_peak"] < 1e-9


@pytest.mark.parametrize("args,needle", [
    (["--beta0", "0", "--tau", "45"], "beta0 = 0"),
    (["--beta0", "nan", "--tau", "45"], "--beta0"),
    (["--beta0", "3%", "--tau", "0"], "tau = 0"),
    (["--beta0", "3%", "--tau", "-5s"], "tau = -5"),
    (["--beta0", "3%", "--tau", "45", "--series", "E7"], "E7"),
    (["--beta0", "3%", "--tau", "45", "--source-resistance", "-1k"], "--source-resistance"),
    (["--beta0", "3%", "--tau", "45", "--load-resistance", "-1"], "--load-resistance"),
    (["--beta0", "3%", "--tau", "45 parsecs"], "--tau"),
    (["--beta0", "3 percent", "--tau", "45"], "--beta0"),
    (["--beta0", "3%"], "--tau"),
    (["--beta0", "3%", "--tau", "45", "--rule", "magic"], "magic"),
    (["--beta0", "3%", "--tau", "45", "--cap-range", "10u"], "LOW:HIGH"),
    (["--model", "/nonexistent/model.json"], "no such file"),
    (["--beta0", "3%", "--tau", "45", "--bogus"], "--bogus"),
])
def test_bad_input_is_one_line_and_status_2(run_cli, args, needle):
    status, out, err = run_cli("size", *args)
    assert status == 2
    assert needle in err
    assert len(err.strip().splitlines()) == 1
    assert "Traceback" not in err and out == ""


def test_mixed_sign_model_is_explained(run_cli, tmp_path):
    model = tmp_path / "m.json"
    model.write_text(json.dumps({"beta": [0.03, -0.02], "tau": [45, 44]}))
    status, _, err = run_cli("size", "--model", model)
    assert status == 2 and "complex poles" in err


def test_console_script_exit_status_and_no_traceback():
    proc = subprocess.run([sys.executable, "-c", "from creepcomp.cli import run; run()",
                           "size", "--beta0", "abc", "--tau", "45"], capture_output=True, text=True)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert proc.stderr.strip().count("\n") == 0
