"""``creepcomp netlist`` and ``creepcomp simulate``."""

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from creepcomp.verify import ngspice_engine
from creepcomp.data import default_sensor
from creepcomp.io.records import Record, write_record
from creepcomp.analog.sizing import ideal_network

REPO = Path(__file__).resolve().parents[1]
PAPER = REPO / "netlists" / "default-paper.json"


def measured(stdout: str) -> dict:
    return {m.group(1): float(m.group(2))
            for m in re.finditer(r"^(\w+)\s*=\s*([-+0-9.eE]+)", stdout, re.MULTILINE)}


def test_netlist_prints_or_writes_a_standalone_netlist(run_cli, tmp_path):
    status, out, err = run_cli("netlist", PAPER)
    assert status == 0, err
    assert out.startswith("creepcomp: design driven by synthetic creep, load step")
    assert "Bsensor emf 0" in out and out.rstrip().endswith(".end")
    path = tmp_path / "paper.cir"
    status, out, err = run_cli("netlist", PAPER, "--program", "staircase", "--signal", "1V",
                               "-o", path, "--json")
    assert status == 0, err
    info = json.loads(out)
    assert info["netlist"] == str(path) and info["bytes"] == path.stat().st_size < 3000
    text = path.read_text()
    assert "Eins ins 0 load 0 1\n" in text and "staircase" in text
    result = subprocess.run(["ngspice", "-b", path.name], cwd=tmp_path, capture_output=True,
                            text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    m = measured(result.stdout)
    assert 8e-4 < m["residual_creep_peak"] < 1e-3         # the paper's rule, staircase


def test_netlist_of_a_record_uses_a_file_source(run_cli, tmp_path):
    model = default_sensor()
    net = ideal_network(model, "paper", 10e-6)
    t = 5.0 + np.arange(3000) * 0.2
    load = np.where(t > 50, 2.0, 0.0)
    signal = 5e-5 * model.response(t, load)
    csv = tmp_path / "rec.csv"
    csv.write_text("tR,P,Ri\n" + "\n".join(f"{a:.17g},{b:.17g},{c:.17g}" for a, b, c in zip(t, load, signal)))
    out_cir = tmp_path / "run" / "rec.cir"
    status, out, err = run_cli("netlist", PAPER, "--record", csv, "--columns",
                               "time=tR,load=P,signal=Ri", "-o", out_cir)
    assert status == 0, err
    assert "rec-signal.txt" in out and "3000 samples" in out
    text = out_cir.read_text()
    assert 'file="rec-signal.txt"' in text and "PWL" not in text and len(text) < 2000
    assert (out_cir.parent / "rec-signal.txt").read_text().count("\n") == 3001   # the last sample held once more
    result = subprocess.run(["ngspice", "-b", out_cir.name], cwd=out_cir.parent,
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    final = net.lag_expansion().simulate(t - t[0], signal, hold="linear", initial="settled")[-1]
    assert measured(result.stdout)["output_final"] == pytest.approx(final, rel=1e-6)


def test_simulate_json_has_the_contract_keys_and_saves_a_plot(run_cli, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    status, out, err = run_cli("simulate", PAPER, "--json", "--netlist", "ran.cir")
    assert status == 0, err
    assert json.loads(out)["plot"] is None and not list(tmp_path.glob("*.png"))
    status, out, err = run_cli("simulate", PAPER, "--json", "--plot", "default-paper-step.png")
    assert status == 0, err
    d = json.loads(out)
    assert d["agreement_max_abs"] < 1e-6
    assert d["residual_creep_peak"] == pytest.approx(9.64e-4, rel=1e-3)
    assert d["residual_creep_final"] == pytest.approx(8.49e-4, rel=1e-3)
    assert d["ngspice"]["available"] and d["ngspice"]["seconds"] > 0
    assert d["plot"] == "default-paper-step.png"
    assert (tmp_path / "default-paper-step.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (tmp_path / "ran.cir").read_text().startswith("creepcomp: design driven")
    status, out, err = run_cli("simulate", PAPER, "--program", "sweep", "--plot",
                               tmp_path / "p" / "sweep.png", "--points", "500")
    assert status == 0, err
    assert "agreement, largest" in out and "time points in" in out
    assert (tmp_path / "p" / "sweep.png").exists()


def test_simulate_a_record(run_cli, tmp_path):
    model = default_sensor()
    t = np.arange(4000) * 0.25
    rec = Record(t, np.where(t > 100, 1.0, 0.0),
                 1e-4 * model.response(t, np.where(t > 100, 1.0, 0.0)))
    path = write_record(tmp_path / "r.csv", rec)
    status, out, err = run_cli("simulate", PAPER, "--record", path, "--json", "--no-plot")
    assert status == 0, err
    d = json.loads(out)
    assert d["agreement_max_abs"] < 2e-6 and d["residual_creep_peak"] is None
    assert d["plot"] is None
    status, out, err = run_cli("simulate", PAPER, "--record", path, "--plot", tmp_path / "r.png")
    assert status == 0, err
    assert "output at the end" in out and "of full scale" in out
    assert (tmp_path / "r.png").exists()


def test_simulate_without_ngspice_still_gives_python_control(run_cli, monkeypatch, tmp_path):
    def missing():
        raise ngspice_engine.NgspiceUnavailable("ngspice is not installed (no libngspice shared "
                                                f"library); install it with: {ngspice_engine.INSTALL_HINT}")

    monkeypatch.setattr(ngspice_engine, "_ENGINE", None)
    monkeypatch.setattr(ngspice_engine, "_load_shared", missing)
    status, out, err = run_cli("simulate", PAPER, "--json", "--plot", tmp_path / "p.png")
    assert status == 0
    assert len(err.strip().splitlines()) == 1
    assert "apt-get install ngspice libngspice0-dev" in err and "python-control" in err
    d = json.loads(out)
    assert d["agreement_max_abs"] is None and d["ngspice"]["available"] is False
    assert d["residual_creep_final"] == pytest.approx(8.49e-4, rel=1e-3)
    assert (tmp_path / "p.png").exists()
    status, out, err = run_cli("simulate", PAPER, "--no-plot")
    assert status == 0 and "ngspice not run" in out and "0.0849 %" in out


def test_simulate_in_a_fresh_process_prints_nothing_on_stderr(tmp_path):
    """PySpice's version warning and ngspice's notes are handled, not shown."""
    exe = Path(sys.executable).parent / "creepcomp"
    result = subprocess.run([str(exe), "simulate", str(PAPER), "--no-plot", "--points", "200"],
                            capture_output=True, text=True, timeout=120, cwd=tmp_path,
                            env={**os.environ, "COLUMNS": "120"})
    assert result.returncode == 0
    assert result.stderr == ""
    assert "residual creep" in result.stdout


@pytest.mark.parametrize("args,needle", [
    (["--program", "magic"], "--program 'magic'"),
    (["--signal", "-1"], "--signal"),
    (["--signal", "1A"], "--signal"),
    (["--duration", "0"], "--duration"),
    (["--points", "3"], "--points 3"),
    (["--columns", "time=t"], "--record"),
    (["--record", "/nonexistent.csv"], "no such file"),
])
@pytest.mark.parametrize("command", ["netlist", "simulate"])
def test_bad_input_is_one_line_and_status_2(run_cli, command, args, needle):
    status, out, err = run_cli(command, PAPER, *args)
    assert status == 2
    assert needle in err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_bad_design_and_record_without_output(run_cli, tmp_path):
    status, _, err = run_cli("simulate", tmp_path / "none.json")
    assert status == 2 and "no such file" in err
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"creep": {"beta": [0.03], "tau": [45]}, "cells": [], "R2": 1e8}))
    status, _, err = run_cli("netlist", bad)
    assert status == 2 and "cells" in err
    rec = tmp_path / "r.csv"
    rec.write_text("time,load,signal\n0,0,0\n1,1,1\n")
    status, _, err = run_cli("netlist", PAPER, "--record", rec)
    assert status == 2 and "-o FILE.cir" in err
