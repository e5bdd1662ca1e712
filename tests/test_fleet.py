"""creepcomp fleet: a batch on a local Dask cluster of 2 worker processes survives a broken
record and a killed worker, a re-run skips what is done, and results equal a serial run."""

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from creepcomp.cli import main
from creepcomp.errors import InputError
from creepcomp.fleet import SERIAL, find_records, local_cluster, robust_z, run, unit_names
from creepcomp.fleet.table import COLUMN_NAMES
from creepcomp.fleet.unit import OIML_C3_CREEP, done_row, empty_row, row_from, run_settings
from creepcomp.io.records import write_record
from creepcomp.synth.sensor import random_spec, generate

EFFECTS = (None, "extra_retardation", "viscous_flow", "nonlinear_creep", "asymmetric_recovery")
BROKEN = "S9_broken.csv"


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    folder = tmp_path_factory.mktemp("lot")
    for i, effect in enumerate(EFFECTS):
        spec = random_spec(effect, 100 + i, rate=(1.0, 2.0), duration=(300.0, 450.0), max_samples=350)
        write_record(folder / f"S{i}.csv", generate(spec).record, digits=10)
    (folder / BROKEN).write_text("time,load,signal\n0,0,1\n1,1,x\n", encoding="utf-8")
    return folder


@pytest.fixture(scope="module")
def serial(records, tmp_path_factory):
    out = tmp_path_factory.mktemp("serial")
    return run([records], out, scheduler=SERIAL), out


@pytest.fixture(scope="module")
def cluster():
    with local_cluster(2) as c:
        yield c


def compared(table):
    """Rows without what differs between runs (processing times)."""
    return table.drop_columns(["seconds"]).to_pylist()


@pytest.mark.slow
def test_broken_record_is_one_failed_row_and_the_others_have_results(serial, records):
    result, out = serial
    rows = {r["unit"]: r for r in result.table.to_pylist()}
    assert len(rows) == len(EFFECTS) + 1
    bad = rows[BROKEN[:-4]]
    assert bad["status"] == "failed" and "\n" not in bad["error"]
    assert BROKEN in bad["error"] and "line 3" in bad["error"]
    assert result.failed == [{"file": str(records / BROKEN), "unit": BROKEN[:-4], "reason": bad["error"]}]
    for i in range(len(EFFECTS)):
        r = rows[f"S{i}"]
        assert r["status"] == "ok" and r["error"] is None
        assert r["cause"] and r["gain"] and r["n_terms"] >= 1 and r["tau_1"] > 0
        assert r["residual_creep"] is not None and r["creep_step"] > 0
        assert (r["in_spec"] is None) == ("unexplained" in r["findings"].split(","))
        if r["in_spec"] is not None:
            assert r["in_spec"] == (r["residual_creep"] <= r["spec"])
        unit = out / "units" / f"S{i}"
        for name in ("model.json", "diagnosis.json", "extended-model.json", "result.json"):
            assert (unit / name).is_file()
        diagnosis = json.loads((unit / "diagnosis.json").read_text())
        assert diagnosis["cause"] == r["cause"]
    # a clean record corrected with its own model leaves (almost) no creep; a record with an
    # effect the linear model cannot hold leaves more
    assert rows["S0"]["residual_creep"] < 1e-4
    assert rows["S2"]["residual_creep"] > rows["S0"]["residual_creep"]
    table = pq.read_table(result.paths["parquet"])
    assert table.column_names == list(COLUMN_NAMES) and table.num_rows == len(rows)
    assert result.paths["csv"].read_text().splitlines()[0].startswith('"file","unit"')
    page = result.paths["report"].read_text()
    for heading in ("Units to look at first", "How often each effect is found",
                    "Fitted parameters across the lot", "Units out of spec", "Failed units"):
        assert heading in page
    assert page.count("data:image/png;base64,") >= 2


@pytest.mark.slow
def test_cluster_of_two_survives_a_killed_worker_and_matches_the_serial_run(serial, records, cluster,
                                                                            tmp_path):
    from dask.distributed import Client

    killed = {}
    with Client(cluster) as client:
        client.wait_for_workers(2, timeout=60)
        pids = client.run(os.getpid)

        def progress(done, total, row):
            if killed:
                return
            # mid-run, the worker of a unit still being processed dies with it
            busy = {w: keys for w, keys in client.processing().items() if keys}
            if not busy:
                return
            victim = sorted(busy)[0]
            os.kill(pids[victim], signal.SIGKILL)
            killed.update(pid=pids[victim], keys=busy[victim], done=done, total=total)

        result = run([records], tmp_path, scheduler=cluster.scheduler_address, progress=progress,
                     retries=1)
    assert killed and killed["done"] < killed["total"]
    assert result.workers == 2 and result.scheduler == cluster.scheduler_address
    rows = result.table.to_pylist()
    # the units the dead worker held (task keys end with the unit's index) were run again
    lost = [rows[int(key.rsplit("-", 1)[1])] for key in killed["keys"]]
    assert lost and all(r["status"] == "ok" or r["unit"] == BROKEN[:-4] for r in lost)
    # the broken record is one failed row, every other unit has its result: the serial run's
    assert [r["unit"] for r in rows if r["status"] != "ok"] == [BROKEN[:-4]]
    assert compared(result.table) == compared(serial[0].table)
    with Client(cluster) as client:
        client.wait_for_workers(2, timeout=60)
        assert killed["pid"] not in client.run(os.getpid).values()


@pytest.mark.slow
def test_cluster_run_interrupted_then_run_again_skips_the_units_done(serial, records, cluster,
                                                                     tmp_path):
    def interrupt(done, total, row):
        if done == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run([records], tmp_path, scheduler=cluster.scheduler_address, progress=interrupt)
    results = sorted(tmp_path.glob("units/*/result.json"))
    assert 2 <= len(results) < serial[0].n
    written = {p.parent.name: p.stat().st_mtime_ns for p in results}
    again = run([records], tmp_path, scheduler=cluster.scheduler_address)
    assert len(written) <= again.skipped < again.n and again.workers == 2
    assert compared(again.table) == compared(serial[0].table)
    # the units done by the first run were not run again
    assert {u: (tmp_path / "units" / u / "result.json").stat().st_mtime_ns for u in written} == written
    third = run([records], tmp_path, scheduler=cluster.scheduler_address)
    assert third.skipped == third.n and third.workers == 0
    assert compared(third.table) == compared(serial[0].table)


@pytest.mark.slow
def test_second_run_skips_units_done_and_reruns_a_changed_record(serial, records):
    result, out = serial
    again = run([records], out, scheduler=SERIAL)
    assert again.skipped == again.n == result.n and again.workers == 0
    assert compared(again.table) == compared(result.table)
    # a unit is done only for the same record file and the same settings
    one, unit = records / "S0.csv", out / "units" / "S0"
    settings = run_settings(OIML_C3_CREEP, False, False)
    assert done_row(one, unit, settings)["cause"] == result.table.to_pylist()[0]["cause"]
    assert done_row(one, unit, run_settings(0.01, False, False)) is None
    assert done_row(one, unit, run_settings(OIML_C3_CREEP, True, False)) is None
    st = one.stat()
    try:
        os.utime(one, ns=(st.st_atime_ns, st.st_mtime_ns + 10 ** 9))
        assert done_row(one, unit, settings) is None
    finally:
        os.utime(one, ns=(st.st_atime_ns, st.st_mtime_ns))
    assert done_row(one, unit, settings) is not None


def test_correct_writes_the_corrected_record_and_its_error(records, tmp_path):
    result = run([records / "S1.csv"], tmp_path, scheduler=SERIAL, correct=True, report=False)
    row = result.table.to_pylist()[0]
    assert row["status"] == "ok"
    text = (tmp_path / "units" / "S1" / "corrected.csv").read_text()
    assert "compensated" in text.splitlines()[[not l.startswith("#") for l in text.splitlines()].index(True)]
    assert 0 < row["corrected_error_rms"] <= row["corrected_error_peak"] < 0.05
    assert "report" not in result.paths


def test_a_fit_no_corrector_can_invert_is_reported_not_judged_and_says_why(records, tmp_path,
                                                                           monkeypatch):
    from dataclasses import replace

    import creepcomp.diagnose

    real = creepcomp.diagnose.diagnose

    def uninvertible(record, *args, **kwargs):
        """The real diagnosis with its baseline model's terms replaced by two of beta0 = -1.2."""
        result = real(record, *args, **kwargs)
        return replace(result, baseline_model=dict(result.baseline_model, beta=[-0.7, -0.5],
                                                   tau=[20.0, 25.0]))

    monkeypatch.setattr(creepcomp.diagnose, "diagnose", uninvertible)
    result = run([records / "S1.csv"], tmp_path, scheduler=SERIAL, correct=True, report=False)
    row = result.table.to_pylist()[0]
    assert row["status"] == "ok" and row["error"] is None and row["cause"]
    assert row["beta0"] == pytest.approx(-1.2) and row["n_terms"] == 2
    assert row["in_spec"] is None and row["residual_creep"] is None and row["creep_step"] is None
    assert row["corrected_error_rms"] is None
    assert not (tmp_path / "units" / "S1" / "corrected.csv").exists()
    assert row["notes"].startswith("in_spec not judged: the fitted model has beta0 = -1.2 ")
    assert "no corrector can invert" in row["notes"] and "\n" not in row["notes"]
    assert result.summary["not_judged"][0]["notes"] == row["notes"]


@pytest.mark.slow
def test_cli_json_has_the_contract_keys(serial, records, capsys):
    _, out = serial
    assert main(["fleet", str(records), "-o", str(out), "--scheduler", SERIAL, "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    for key in ("n", "failed", "seconds", "workers", "table"):
        assert key in d
    assert d["n"] == len(EFFECTS) + 1 and pq.read_table(d["table"]).num_rows == d["n"]
    assert [f["file"] for f in d["failed"]] == [str(records / BROKEN)] and d["failed"][0]["reason"]


@pytest.mark.slow
def test_cli_readable_summary(serial, records, capsys):
    _, out = serial
    assert main(["fleet", str(records / "S*.csv"), "-o", str(out), "--scheduler", SERIAL]) == 0
    text = capsys.readouterr().out
    assert "creepcomp fleet" in text and "out of spec" in text and "lot report written" in text


@pytest.mark.parametrize("args, words", [
    (["/no/such/records"], "no such file or folder"),
    (["{records}", "--spec", "-1%"], "--spec"),
    (["{records}", "--workers", "0"], "--workers"),
    (["{records}/*.json"], "matches no file"),
    (["{records}", "--workers", "2", "--scheduler", "tcp://127.0.0.1:1"], "scheduler"),
])
def test_bad_input_exits_2_with_one_line(records, tmp_path, capsys, args, words):
    argv = ["fleet", *[a.format(records=records) for a in args], "-o", str(tmp_path / "o")]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and words in err and "Traceback" not in err


def test_unit_names_and_discovery(tmp_path):
    for sub in ("lot7", "lot8"):
        (tmp_path / sub).mkdir()
        (tmp_path / sub / "S1.csv").write_text("x")
    (tmp_path / "lot7" / "notes.md").write_text("x")
    found = find_records([tmp_path, str(tmp_path / "lot7" / "*.csv")])
    assert [p.name for p in found] == ["S1.csv", "S1.csv"]
    assert unit_names(found) == ["lot7__S1", "lot8__S1"]
    assert unit_names([tmp_path / "lot7" / "S1.csv"]) == ["S1"]
    # a run's output folder inside the records' folder holds no records
    assert [p.parent.name for p in find_records([tmp_path], exclude=tmp_path / "lot8")] == ["lot7"]
    # names that clean to the same one are told apart, in the order given
    assert unit_names([tmp_path / "a" / "S 1.csv", tmp_path / "a" / "S_1.csv"]) == ["S_1", "S_1~2"]


def test_robust_z():
    x = np.array([1.0, 2.0, 3.0, 4.0, 100.0, np.nan])
    z = robust_z(x)
    assert z[2] == 0 and np.isnan(z[5])
    assert z[4] == pytest.approx(0.6745 * 97 / 1.0)
    assert np.isnan(robust_z([2.0, 2.0, 2.0])).all()


def test_row_reads_the_newer_diagnosis_keys_when_present():
    model = {"beta": [0.01, 0.02], "tau": [10.0, 300.0], "gain": 2.0, "offset": 0.1}
    old = {"cause": "none", "findings": [], "baseline": {"residual_rms": 1.0}, "extended": {},
           "gain": {"heldout_rms_ratio": 1.0, "correction_error_ratio": None}}
    row = row_from(empty_row("f.csv", "f"), model, old)
    assert row["misfit_ratio_baseline"] is None and row["noise_floor"] is None
    assert row["beta0"] == pytest.approx(0.03) and row["tau_2"] == 300.0 and row["beta_3"] is None
    new = dict(old, noise_floor=0.5, explained_share=0.9, findings=[{"effect": "viscous_flow"},
                                                                   {"effect": "unexplained"}],
               baseline={"residual_rms": 1.0, "misfit_ratio": 2.0}, extended={"misfit_ratio": 1.1})
    row = row_from(empty_row("f.csv", "f"), model, new)
    assert (row["noise_floor"], row["explained_share"], row["misfit_ratio_baseline"],
            row["misfit_ratio_extended"]) == (0.5, 0.9, 2.0, 1.1)
    assert row["findings"] == "viscous_flow,unexplained"


def test_help_does_not_import_dask_or_pyarrow():
    probe = ("import contextlib, io, json, sys\nfrom creepcomp.cli import main\n"
             "with contextlib.redirect_stdout(io.StringIO()):\n    main(['--help'])\n"
             "print(json.dumps(sorted(sys.modules)))")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True,
                         env=dict(os.environ, PYTHONPATH=str(Path(__file__).parents[1] / "src")))
    loaded = set(json.loads(out.stdout.strip().splitlines()[-1]))
    assert not {"dask", "distributed", "pyarrow"} & loaded


def test_every_column_is_documented():
    text = (Path(__file__).parents[1] / "docs" / "fleet.md").read_text()
    for name in COLUMN_NAMES:
        assert f"`{name}`" in text or name in ("beta_2", "beta_3", "tau_2", "tau_3"), name
