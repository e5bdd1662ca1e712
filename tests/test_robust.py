"""Nothing lost, nothing silently wrong: outputs checked before work, atomic files, absurd
parts refused, long records reduced, the fast record reader equal to the line parser."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from creepcomp.errors import InputError
from creepcomp.io import records as rec_io
from creepcomp.io.records import Record, parse_record, read_record, write_record

DATA = Path(__file__).resolve().parents[1] / "src" / "creepcomp" / "data"
DESIGN = DATA / "built_network.design.json"
RECORD = DATA / "hidden_effect.csv"


def one_line_error(status, err, needle):
    assert status == 2, err
    assert needle in err, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_output_equal_to_an_input_is_refused_and_the_input_kept(run_cli, tmp_path):
    rec = tmp_path / "rec.csv"
    rec.write_bytes(RECORD.read_bytes())
    model = tmp_path / "m.json"
    model.write_text(json.dumps({"beta": [0.03], "tau": [45.0], "gain": 1.0, "offset": 0.0}))
    design = tmp_path / "d.json"
    design.write_bytes(DESIGN.read_bytes())
    for args in (("fit", rec, "-o", rec), ("correct", rec, "--model", model, "-o", rec),
                 ("correct", rec, "--model", model, "-o", model),
                 ("netlist", design, "-o", design), ("mc", design, "--report", design),
                 ("fit", rec, "-o", tmp_path / "x.json", "--plot", tmp_path / "." / "x.json")):
        status, _, err = run_cli(*args)
        assert status == 2 and len(err.strip().splitlines()) == 1, (args, err)
    assert rec.read_bytes() == RECORD.read_bytes()
    assert design.read_bytes() == DESIGN.read_bytes()


def test_unwritable_outputs_refused_before_any_work(run_cli, tmp_path):
    afile = tmp_path / "afile"
    afile.write_text("x")
    folder = tmp_path / "folder"
    folder.mkdir()
    # a path under a file cannot be written, by root either; a folder is not a file
    one_line_error(*run_cli("size", "--beta0", "3%", "--tau", "45", "-o", afile / "d.json")[::2],
                   "is a file, not a folder")
    one_line_error(*run_cli("fit", RECORD, "-o", folder)[::2], "is a folder")
    one_line_error(*run_cli("diagnose", RECORD, "-o", afile)[::2], "is a file")
    one_line_error(*run_cli("simulate", DESIGN, "--plot", afile / "p.png")[::2], "not a folder")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile", "folder"]
    assert list(folder.iterdir()) == []


@pytest.mark.skipif(os.geteuid() == 0, reason="root ignores folder permissions")
def test_read_only_folder_refused(run_cli, tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        one_line_error(*run_cli("size", "--beta0", "3%", "--tau", "45", "-o", ro / "d.json")[::2],
                       "cannot write")
    finally:
        ro.chmod(0o700)


def test_design_without_a_capacitor_or_with_absurd_parts_is_refused(run_cli, tmp_path):
    base = json.loads(DESIGN.read_text())
    cases = {"C0": ({"cells": [{"R": 4.7e6, "C": 0}]}, "no capacitor"),
             "R300": ({"cells": [{"R": 1e300, "C": 1e-5}]}, "cells[0].R = 1e+300 Ω is outside"),
             "Cbig": ({"cells": [{"R": 1e3, "C": 1e3}]}, "cells[0].C = 1 kF is outside")}
    for name, (change, needle) in cases.items():
        path = tmp_path / f"{name}.json"
        path.write_text(json.dumps({**base, **change}))
        for command in ("simulate", "mc", "netlist"):
            one_line_error(*run_cli(command, path, "--no-plot" if command == "simulate" else "--json")[::2]
                           if command != "netlist" else run_cli(command, path)[::2], needle)


def test_absurd_options_are_one_line(run_cli, tmp_path):
    one_line_error(*run_cli("mc", DESIGN, "--res-tol", "200%")[::2], "--res-tol '200%'")
    one_line_error(*run_cli("fit", RECORD, "--delimiter", "xx")[::2], "delimiter 'xx'")
    one_line_error(*run_cli("size", "--beta0", "3%", "--tau", "1e300")[::2], "tau = 1e+300 s: its magnitude must be from 1e-09 s")
    one_line_error(*run_cli("simulate", DESIGN, "--points", "10000000")[::2], "--points 10000000")
    status, _, err = run_cli("size", "--beta0", "3%", "--tau", "45", "--cap-range", "1n:2n")
    one_line_error(status, err, "--capacitance 1.5µF")
    status, _, err = run_cli("size", "--beta0", "3", "--tau", "45", "--json")
    assert status == 0 and "beta0 = 300 %" in err and "warning" in err
    one = tmp_path / "one.csv"
    one.write_text("time,load,signal\n0,1,1\n")
    model = tmp_path / "m.json"
    model.write_text(json.dumps({"beta": [0.03], "tau": [45.0]}))
    one_line_error(*run_cli("correct", one, "--model", model)[::2], "1 samples is too few")
    one_line_error(*run_cli("correct", RECORD, "--model", DESIGN)[::2], "is a design file")


def test_bom_in_json_is_read(run_cli, tmp_path):
    path = tmp_path / "bom.json"
    path.write_bytes(b"\xef\xbb\xbf" + DESIGN.read_bytes())
    status, out, err = run_cli("netlist", path)
    assert status == 0, err


def test_csv_output_is_shortest_round_trip(tmp_path):
    t = np.arange(5) * 0.1
    r = Record(t, np.full(5, 0.2), t * 3, metadata={"units.signal": "V"})
    path = write_record(tmp_path / "r.csv", r, extra={"x": np.array([0.1 + 0.2, 1e-300, 5.0, -0.0, 1 / 3])})
    text = path.read_text()
    assert "0.2," in text and "0.20000000000000001" not in text
    back = read_record(path)
    assert np.array_equal(back.time, t) and np.array_equal(back.signal, t * 3)
    assert not list(tmp_path.glob(".*.part"))


def _both(text, tmp_path, **kw):
    path = tmp_path / "r.csv"
    path.write_text(text, encoding="utf-8")
    slow = parse_record(text, source=str(path), **kw)
    fast = rec_io._read_fast(path, {k.lower(): v for k, v in kw.get("columns", {}).items()},
                             kw.get("delimiter"), kw.get("duplicate_times", "error"))
    return slow, fast


def test_fast_reader_equals_the_line_parser(tmp_path):
    text = ("# units.signal: mV\nInstrument export\ntR;P;Ri\nmin;N;mV\n"
            + "".join(f"{i / 60:.6f};{i % 3};{1 + i * 1e-3!r}\n" for i in range(200)))
    slow, fast = _both(text, tmp_path, columns={"time": "tR", "load": "P", "signal": "Ri"})
    for c in ("time", "load", "signal"):
        assert np.array_equal(getattr(slow, c), getattr(fast, c))
    assert slow.metadata == fast.metadata
    blank = tmp_path / "blank.csv"
    blank.write_text("time,load,signal\n0,1,2\n1,,3\n")
    # a blank cell goes to the line parser, for its message
    assert rec_io._read_fast(blank, {}, None, "error") is None
    with pytest.raises(InputError, match="line 3, column 'load'"):
        (tmp_path / "bad.csv").write_text("time,load,signal\n0,1,2\n1,x,3\n")
        read_record(tmp_path / "bad.csv")


def test_reduce_record_keeps_steps_sharp():
    from creepcomp.fit.reduce import reduce_record

    n = 100_000
    t = np.arange(n) * 1e-3
    load = np.where(t >= 37.0123, 2.0, 0.0)
    signal = load + 1e-3 * t
    red, note = reduce_record(Record(t, load, signal), max_samples=1000)
    assert len(red) <= 1100 and "reduced from 100000" in note
    k = int(np.flatnonzero(red.load == 2.0)[0])
    step = int(np.flatnonzero(load == 2.0)[0])
    assert red.time[k] == t[step] and red.signal[k] == signal[step]   # the step's own sample
    assert np.all(red.load[:k] == 0)
    assert np.allclose(red.signal, red.load + 1e-3 * red.time)       # linear: exact means
    same, none = reduce_record(Record(t[:500], load[:500], signal[:500]), max_samples=1000)
    assert none is None and len(same) == 500


def _default_sigint():
    # a child of a background job inherits "SIGINT ignored"; a terminal's Ctrl-C is not ignored
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def test_ctrl_c_stops_mc_at_once_with_one_line_and_no_files(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1] / "src"),
           "TMPDIR": str(tmp_path)}
    report = tmp_path / "report.html"
    proc = subprocess.Popen([sys.executable, "-c", "import sys; from creepcomp.cli import main; "
                             "sys.exit(main(sys.argv[1:]))", "mc", str(DESIGN), "--n", "5000000",
                             "--report", str(report)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env, cwd=tmp_path,
                            preexec_fn=_default_sigint)
    time.sleep(3.0)
    sent = time.monotonic()
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=30)
    stopped = time.monotonic() - sent
    assert proc.returncode == 130, err
    assert err.strip() == "creepcomp: error: interrupted"
    assert stopped < 3.0
    assert list(tmp_path.iterdir()) == []          # no report, no .part, no temporary folder


def test_mc_of_an_n_beyond_an_hour_is_refused_with_the_estimate_and_the_n_that_fits(run_cli):
    # 1e12 samples once needed 72 TB; then it ran for an estimated 600 days: now a run beyond
    # an hour is refused at once, naming its estimate and the --n that fits
    started = time.perf_counter()
    status, out, err = run_cli("mc", DESIGN, "--n", "1000000000000", "--json")
    assert status == 2 and out == ""
    assert err.startswith("creepcomp: error: --n 1000000000000: about ") and "days" in err, err
    fits = int(err.rsplit("use --n ", 1)[1].split()[0].replace(",", ""))
    assert 1_000 < fits < 1_000_000_000_000
    assert time.perf_counter() - started < 60


def test_ctrl_c_halts_ngspice_and_removes_its_temporary_files(tmp_path):
    n = 400_000
    t = np.arange(n) * 1e-3
    path = write_record(tmp_path / "long.csv", Record(t, np.ones(n), 1e-4 * (1 + 0.03 * (1 - np.exp(-t / 45)))))
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1] / "src"),
           "TMPDIR": str(tmp)}
    proc = subprocess.Popen([sys.executable, "-c", "import sys; from creepcomp.cli import main; "
                             "sys.exit(main(sys.argv[1:]))", "simulate", str(DESIGN), "--record",
                             str(path), "--plot", str(tmp_path / "p.png")],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                            cwd=tmp_path, preexec_fn=_default_sigint)
    # wait until ngspice's data file exists: the simulation is running
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not any(tmp.glob("creepcomp-*/[!.]*")):
        time.sleep(0.05)
    time.sleep(0.3)
    sent = time.monotonic()
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 130, err
    assert err.strip() == "creepcomp: error: interrupted", err
    assert time.monotonic() - sent < 3.0
    assert list(tmp.iterdir()) == []
    assert not (tmp_path / "p.png").exists()


def test_block_weights_give_the_centre_of_a_parabola():
    from creepcomp.fit.reduce import block_weights
    starts = np.array([0, 1, 3, 7, 20])
    w = block_weights(starts, 33)
    assert np.allclose(np.add.reduceat(w, starts), 1.0)
    x = np.arange(33.0)
    y = 2.0 - 0.5 * x + 0.03 * x ** 2
    ends = np.append(starts[1:], 33)
    centres = 0.5 * (starts + ends - 1)
    got = np.add.reduceat(w * y, starts)
    assert np.allclose(got[2:], 2.0 - 0.5 * centres[2:] + 0.03 * centres[2:] ** 2)
    # pieces of the record give the same weights
    assert np.allclose(np.concatenate([block_weights(starts, 33, 0, 11), block_weights(starts, 33, 11, 33)]), w)


def test_a_reduced_one_term_record_stays_one_term():
    """Blocks of several seconds on creep of 45 s: a plain block mean is biased by the
    curvature and the fit then invents terms; the parabola's centre is not."""
    from creepcomp.fit.data import prepare
    from creepcomp.fit.prony import fit_prony
    from creepcomp.fit.reduce import reduce_record
    from creepcomp.model import CreepModel
    rng = np.random.default_rng(3)
    t = np.arange(400_000) / 10.0
    levels = rng.integers(0, 4, size=int(t[-1] // 600) + 2).astype(float)
    load = levels[(t // 600).astype(int)]
    signal = CreepModel((0.03,), (45.0,)).response(t, load) + rng.normal(0.0, 1e-5, t.size)
    reduced, note = reduce_record(Record(t, load, signal), max_samples=6000)
    assert "first and last sample" in note
    fit = fit_prony(prepare(reduced, initial="relaxed"), max_terms=3)
    model = fit.model()
    assert model.n_terms == 1
    assert abs(model.beta[0] - 0.03) < 2e-5 and abs(model.tau[0] - 45.0) < 0.05
