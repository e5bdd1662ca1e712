"""Hostile input, the rest of the third pass: a load that toggles every sample, missing numbers
in tables, a signal at an ADC rail, units of the fleet's tau, two runs into one folder,
candidates that do not apply, the record's extra columns through ``correct -o``, and no
file written unasked."""

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

DATA = Path(__file__).resolve().parents[1] / "src" / "creepcomp" / "data"
RECORD = DATA / "hidden_effect.csv"
MODEL = DATA / "default_sensor.json"


def _rows():
    text = RECORD.read_text().splitlines()
    return np.array([line.split(",") for line in text if line[:1].isdigit()], dtype=float)


def _write(path: Path, columns: dict, comments=("# units.load: N", "# units.signal: V")) -> Path:
    names = list(columns)
    lines = list(comments) + [",".join(names)]
    lines += [",".join(repr(float(x)) for x in row) for row in zip(*columns.values())]
    path.write_text("\n".join(lines) + "\n")
    return path


# -- 2. no 'nan' in the findings tables ------------------------------------------------------

def test_findings_and_candidates_tables_print_a_dash_for_a_missing_number():
    from creepcomp.fit.evidence import Evidence
    from creepcomp.report.results import MISSING, diagnosis_tables

    nan = float("nan")
    finding = SimpleNamespace(effect="data_problem", parameters_text=lambda units: "kind = clipping",
                              evidence=Evidence(nan, nan, nan))
    trial = SimpleNamespace(step=1, effect="thermal_drift", delta_bic=None, evidence=None,
                            outcome="does not apply (the record has no 'temperature' column)")
    fit = SimpleNamespace(heldout=SimpleNamespace(rms=nan))
    d = SimpleNamespace(findings=[finding], trials=[trial], baseline=fit, extended=fit,
                        gain={"heldout_rms_ratio": None, "correction_error_ratio": math.nan,
                              "correction_error_baseline": nan, "correction_error_extended": nan})
    cells = [str(c) for t in diagnosis_tables(d, {"signal": "V"}) for row in t.rows for c in row]
    assert not any("nan" in c.lower() for c in cells), cells
    assert MISSING in cells


# -- 6. "does not apply", not "fit failed" ---------------------------------------------------

def test_candidates_that_do_not_fit_the_record_do_not_apply_rather_than_fail(run_cli):
    status, out, err = run_cli("diagnose", RECORD, "--effects", "data_problem,thermal_drift")
    assert status == 0, err
    assert "fit failed" not in out
    assert "does not apply (no signal jump that no load change explains)" in out
    assert "does not apply (the record has no 'temperature' column)" in out


# -- 4. the fleet report's numbers with their units ------------------------------------------

def test_fleet_report_gives_tau_and_every_parameter_with_its_unit():
    import re

    from creepcomp.fleet.lot import lot_summary
    from creepcomp.fleet.unit import empty_row
    from creepcomp.report.fleet import lot_report_html

    rows = []
    for k in range(6):
        r = empty_row(f"u{k}.csv", f"u{k}")
        r.update(status="ok", findings="none", in_spec=True, residual_creep=1e-4, spec=1e-3,
                 creep_step=0.01, gain=2.0 + 0.01 * k, offset=0.1, beta0=0.03, beta_1=0.03,
                 tau_1=45.0 * (1 + 0.01 * k) if k < 5 else 4500.0, signal_unit="mV", load_unit="N")
        rows.append(r)
    page = lot_report_html(lot_summary(rows), {"spec": 1e-3, "table": "t.parquet", "workers": 1,
                                               "scheduler": "serial"})
    section = page[page.index("Fitted parameters across the lot"):page.index("Units out of spec")]
    row = re.search(r"<td>tau of the largest term</td>(.*?)</tr>", section).group(1)
    cells = re.findall(r"<td>(.*?)</td>", row)
    assert all(c.endswith((" s", " min", " h", " d")) for c in cells[:3]), cells
    gain = re.findall(r"<td>(.*?)</td>", re.search(r"<td>gain</td>(.*?)</tr>", section).group(1))
    assert all(c.endswith("mV/N") for c in gain[:3]), gain
    outlier = re.search(r"<td>u5</td><td>tau of the largest term</td><td>(.*?)</td>", section).group(1)
    assert outlier == "75 min", outlier


# -- 8. nothing written into the checkout ----------------------------------------------------

def test_tests_run_outside_the_checkout():
    root = Path(__file__).resolve().parents[1]
    assert root not in (Path.cwd().resolve(), *Path.cwd().resolve().parents)


def test_simulate_writes_no_plot_into_its_working_folder(run_cli, tmp_path, monkeypatch):
    import shutil

    design = shutil.copy(DATA / "built_network.design.json", tmp_path / "design.json")
    monkeypatch.chdir(tmp_path)
    status, out, err = run_cli("simulate", "design.json", "--points", "200")
    assert status == 0, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["design.json"], list(tmp_path.iterdir())
    assert Path(design).exists()


# -- the option named as given ---------------------------------------------------------------

@pytest.mark.parametrize("args, needle", [
    (["mc", DATA / "built_network.design.json", "--n", "100", "--creep-test", "X3"], "--creep-test X3: "),
    (["mc", DATA / "built_network.design.json", "--n", "100", "--creep-test", "C99"], "--creep-test C99: "),
    (["creep-test", MODEL, "--class", "Q"], "--class Q: "),
])
def test_an_accuracy_class_error_names_the_option_given(run_cli, args, needle):
    status, out, err = run_cli(*args)
    assert status == 2 and needle in err and len(err.strip().splitlines()) == 1, err


# -- 7. correct -o keeps the record's extra columns ------------------------------------------

def _with_extras(path: Path) -> Path:
    a = _rows()
    lines = ["# units.load: N", "# units.signal: V", "time,strain,load,signal,note,compensated"]
    for k, (t, load, signal) in enumerate(a):
        note = '"a, ""b"""' if k % 7 == 0 else f"x{k}"
        lines.append(f"{float(t)!r},{0.001 * k:.3f},{float(load)!r},{float(signal)!r},{note},{k}")
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("whole", [False, True], ids=["in pieces", "whole"])
def test_correct_output_keeps_the_extra_columns_and_is_read_back(run_cli, tmp_path, whole):
    import csv

    from creepcomp.io.records import read_record

    record = _with_extras(tmp_path / "r.csv")
    out = tmp_path / "out.csv"
    status, text, err = run_cli("correct", record, "--model", MODEL, "-o", out,
                                *(["--plot", tmp_path / "p.png"] if whole else []))
    assert status == 0, err
    assert "extra column 'compensated' is written as 'input.compensated'" in text
    rows = list(csv.reader(line for line in out.read_text().splitlines() if not line.startswith("#")))
    assert rows[0] == ["time", "load", "signal", "strain", "note", "input.compensated", "compensated",
                       "load_estimate"]
    original = list(csv.reader(line for line in record.read_text().splitlines() if not line.startswith("#")))
    assert [r[3:6] for r in rows[1:]] == [[r[1], r[4], r[5]] for r in original[1:]]
    back = read_record(out)
    assert len(back) == len(_rows())
    status, _, err = run_cli("fit", out, "-o", tmp_path / "again.json")
    assert status == 0, err


# -- 1. a load that toggles at every sample --------------------------------------------------

def _toggling(path: Path) -> Path:
    n = 600
    load = (np.arange(n) % 2) * 10.0
    return _write(path, {"time": 0.5 * np.arange(n), "load": load, "signal": 100.0 + 20.0 * load},
                  comments=("# units.load: N", "# units.signal: counts"))


def test_a_two_valued_signal_is_on_no_grid():
    from creepcomp.fit.noise import quantisation_step

    assert quantisation_step(np.tile([100.0, 300.0], 300)) == 0.0
    assert quantisation_step(np.round(np.linspace(0, 50, 600))) == 1.0


def test_a_load_that_toggles_at_every_sample_is_named_not_called_quantisation(run_cli, tmp_path):
    import json

    record = _toggling(tmp_path / "toggle.csv")
    status, out, err = run_cli("diagnose", record, "-o", tmp_path / "d")
    assert status == 0, err
    assert "quantisation" not in out
    assert "kind = load_toggling" in out
    findings = json.loads((tmp_path / "d" / "diagnosis.json").read_text())["findings"]
    kinds = [f["parameters"].get("kind") for f in findings if f["effect"] == "data_problem"]
    assert kinds == ["load_toggling"], findings
    assert "nan" not in out.lower().replace("nonlinear", "")


# -- 3. a signal stuck at an ADC rail --------------------------------------------------------

def _clipped(path: Path) -> tuple[Path, int]:
    a = _rows()
    counts = np.minimum(np.round(a[:, 2] / np.max(a[:, 2]) * 34000), 32767)
    _write(path, {"time": a[:, 0], "load": a[:, 1], "signal": counts},
           comments=("# units.load: N", "# units.signal: counts"))
    return path, int(np.sum(counts == 32767))


def test_rails_are_found_whole_or_in_pieces():
    from creepcomp.io.rails import RailCounter, stuck_at_rail

    y = np.r_[np.arange(10.0), [32767] * 5, np.arange(5.0), [32767] * 3, [1, 1], [-32768] * 4]
    whole = stuck_at_rail(y)
    assert [(r.side, r.value, r.samples, r.runs) for r in whole] == [
        ("largest", 32767.0, 8, 2), ("smallest", -32768.0, 4, 1)]
    for parts in (3, 7, len(y)):
        counter = RailCounter()
        for piece in np.array_split(y, parts):
            counter.add(piece)
        assert counter.result() == whole
    # plateaus everywhere: the top one is no rail; a flat top far longer than any other run is
    assert stuck_at_rail(np.repeat([240.0, 230, 220, 230, 240, 235], 100)) == []
    noisy = np.random.default_rng(0).normal(0, 1, 1000)
    noisy[100:150] = 4.0
    assert [r.samples for r in stuck_at_rail(noisy)] == [50]


def test_a_signal_at_an_adc_rail_is_named_by_diagnose_and_warned_of_by_fit_and_correct(run_cli, tmp_path):
    import json

    record, stuck = _clipped(tmp_path / "clip.csv")
    status, out, err = run_cli("diagnose", record, "-o", tmp_path / "d")
    assert status == 0, err
    found = [f["parameters"] for f in json.loads((tmp_path / "d" / "diagnosis.json").read_text())["findings"]
             if f["effect"] == "data_problem" and f["parameters"]["kind"] == "clipping"]
    assert found and found[0]["value"] == [32767.0] and found[0]["samples"] == [stuck], found
    for args in (["fit", record], ["correct", record, "--model", MODEL, "-o", tmp_path / "c.csv"],
                 ["correct", record, "--model", MODEL, "--plot", tmp_path / "c.png"]):
        status, out, err = run_cli(*args)
        lines = [line for line in err.splitlines() if "rail" in line]
        assert len(lines) == 1 and f"{stuck} samples" in lines[0] and "32767 counts" in lines[0], err
    # kept as they are
    from creepcomp.io.records import read_record

    assert np.array_equal(read_record(tmp_path / "c.csv").signal, read_record(record).signal)
