"""Hostile and careless input: text from a file never runs as script in a report or as
mathtext in a plot, records and models whose scales or sizes the arithmetic cannot hold are
refused before the work, and every fault ends in one line, never a traceback."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.io import savemat

from creepcomp import data
from creepcomp.errors import InputError
from creepcomp.io.records import Record, read_record, write_record

INJECTED = "<p id=x>...</p><script>document.title='pwned'</script>"
MATHTEXT = r"$\foo{$"


def data_path(name):
    return Path(data.__file__).parent / name


def one_term_record(n=300, signal_unit="V", seed=0) -> Record:
    """A staircase load and a one-term creeping signal with a little noise."""
    from creepcomp.model import CreepModel

    t = 0.5 * np.arange(n)
    load = np.where((t // 30) % 2 == 1, 100.0, 0.0)
    clean = CreepModel((0.03,), (20.0,), 0.01).response(t, load)
    signal = clean + np.random.default_rng(seed).normal(0, 1e-4, n)
    return Record(t, load, signal, metadata={"units.signal": signal_unit, "units.load": "N"},
                  source="r.csv")


@pytest.fixture(scope="module")
def small_diagnosis():
    from creepcomp.diagnose.sensor import diagnose

    return diagnose(one_term_record(), candidates=[], correction=False)


# ----------------------------------------------------------------------------- reports

def test_diagnosis_report_escapes_the_units(small_diagnosis, monkeypatch):
    from creepcomp.report import diagnosis as report

    monkeypatch.setattr(report, "diagnosis_figures", lambda d, units: [])
    page = report.render_html(small_diagnosis, {"signal": INJECTED, "load": INJECTED})
    assert "<script" not in page and "<p id=x>" not in page
    assert "&lt;script&gt;document.title=&#39;pwned&#39;&lt;/script&gt;" in page


def test_a_parameter_without_an_uncertainty_is_shown_without_one(small_diagnosis, monkeypatch):
    """A kind (``data_problem``'s) has no standard deviation: the report shows the value alone,
    as the command line does; a number keeps its ``±``."""
    from dataclasses import replace

    from creepcomp.diagnose.sensor import Finding
    from creepcomp.fit.evidence import Evidence
    from creepcomp.report import diagnosis as report

    monkeypatch.setattr(report, "diagnosis_figures", lambda d, units: [])
    finding = Finding("data_problem", {"kind": "jump", "size": [-23.8]}, {"kind": None, "size": [0.36]},
                      Evidence(-50.0, 2.0, 9.0), 1.0)
    page = report.render_html(replace(small_diagnosis, findings=(finding,)), {"signal": "counts"})
    assert "kind = jump;" in page and "kind = jump ±" not in page
    assert "size = -23.8 counts ± 0.36 counts" in page
    two = Finding("data_problem", {"kind": "jump", "where": [10.0, 20.0], "size": [-23.8, 22.5]},
                  {"kind": None, "where": None, "size": [0.36, 0.23]}, Evidence(-50.0, 2.0, 9.0), 1.0)
    assert two.parameters_text({"signal": "counts"}) == (
        "kind = jump; where = 10 s, 20 s; size = -23.8 counts ± 0.36 counts, 22.5 counts ± 0.23 counts")


def test_a_findings_parameters_carry_their_units_and_state_a_missing_deviation():
    """Parameters in signal or load units are written in the record's units (``signal units``
    where it names none); a deviation stated but not finite is ``± n/a``, one not stated is
    left out, on the command line and in the report alike (one text)."""
    from creepcomp.diagnose.sensor import Finding
    from creepcomp.fit.evidence import Evidence

    ev = Evidence(-50.0, 2.0, 9.0)
    loop = Finding("rate_independent_hysteresis", {"width": 2.5, "weight": 0.01, "loop_height": 0.025},
                   {"width": 0.1, "weight": float("nan")}, ev, 1.0)
    assert loop.parameters_text({"signal": "mV", "load": "N"}) == (
        "width = 2.5 N ± 0.1 N; weight = 0.01 mV/N ± n/a; loop_height = 0.025 mV")
    assert loop.parameters_text({}) == ("width = 2.5 load units ± 0.1 load units; weight = 0.01 signal "
                                        "units/load units ± n/a; loop_height = 0.025 signal units")
    # a time offset's window is in seconds, as its delay
    window = Finding("time_offset", {"delay": 0.43, "width": 0.2}, {"delay": 0.01, "width": 0.05}, ev, 1.0)
    assert window.parameters_text({"load": "N"}) == "delay = 430 ms ± 10 ms; width = 0.2 s ± 0.05 s"
    rest = Finding("unexplained", {"misfit_ratio": 41.6, "excess_rms": 0.0144}, {}, ev, 1.0)
    assert rest.parameters_text({"signal": "counts"}) == "misfit_ratio = 41.6; excess_rms = 0.0144 counts"
    assert Finding("data_problem", {}, {}, ev, 1.0).parameters_text() == "-"


def test_page_and_table_escape_every_cell():
    from creepcomp.report.common import html_page, html_table

    page = html_page(INJECTED, [(INJECTED, html_table([INJECTED], [[INJECTED]]))])
    assert "<script" not in page and page.count("&lt;script&gt;") == 5  # title, h1, h2, th, td


def test_units_are_no_mathtext_in_plots(small_diagnosis, tmp_path):
    from creepcomp.report.common import save_axes
    from creepcomp.report.diagnosis import plot_fit

    rec = one_term_record(signal_unit=MATHTEXT)
    path = save_axes(plot_fit(small_diagnosis.data, small_diagnosis.baseline, record=rec), tmp_path / "f.png")
    assert path.stat().st_size > 1000


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("chromium") is None, reason="no chromium")
def test_injected_record_runs_no_script_in_chromium(run_cli, tmp_path):
    rec = one_term_record(600, signal_unit=INJECTED)
    path = write_record(tmp_path / "inj.csv", rec)
    status, _, err = run_cli("diagnose", path, "-o", tmp_path / "d")
    assert status == 0, err
    dom = subprocess.run(["chromium", "--headless", "--no-sandbox", "--disable-gpu", "--dump-dom",
                          (tmp_path / "d" / "report.html").as_uri()],
                         capture_output=True, text=True, timeout=120).stdout
    assert "<title>creepcomp diagnose</title>" in dom and "pwned</title>" not in dom
    assert "<script" not in dom and "document.title='pwned'" in dom.replace("&#39;", "'")


# ----------------------------------------------------------------------------- records

@pytest.mark.parametrize("change, needle", [
    (lambda r: Record(r.time * 1e300 + 1e300, r.load, r.signal, source="r"), "the time column must be in seconds"),
    (lambda r: Record(r.time, r.load, np.full_like(r.signal, 1.5), source="r"), "signal does not vary"),
    (lambda r: Record(r.time, r.load, r.signal * 1e300, source="r"), "signal reaches"),
    (lambda r: Record(r.time, r.load * 1e300, r.signal, source="r"), "load reaches"),
    (lambda r: Record(r.time, r.load, r.signal * 1e-300, source="r"), "signal varies by only"),
])
def test_scales_the_fit_cannot_hold_are_refused(change, needle):
    from creepcomp.fit.data import prepare

    with pytest.raises(InputError, match=needle):
        prepare(change(one_term_record()))


def test_two_columns_of_one_name_are_refused(tmp_path):
    p = tmp_path / "dup.csv"
    p.write_text("time,load,signal,SIGNAL\n" + "".join(f"{i},{i % 2},{i},{2 * i}\n" for i in range(30)))
    with pytest.raises(InputError, match="'signal' and 'SIGNAL'"):
        read_record(p)


def test_a_field_over_the_csv_limit_is_one_line(run_cli, tmp_path):
    p = tmp_path / "big.csv"
    p.write_text("time,load,signal\n0,0,1\n1,1," + "9" * 200_000 + "\n")
    status, _, err = run_cli("fit", p)
    assert status == 2 and "big.csv, line 3: field larger than field limit" in err


def test_insole_pressure_with_two_columns_is_refused(tmp_path):
    from creepcomp.io.insole import read_insole

    c = np.full((50, 282), 240.0)
    c[:, 1] = 0.02 * np.arange(50)
    pressure = np.column_stack([np.zeros(50), np.full(50, 100.0)])
    savemat(tmp_path / "i.mat", {"experiment": {"C": c, "P": pressure}})
    with pytest.raises(InputError, match="experiment.P has shape 50 x 2"):
        read_insole(tmp_path / "i.mat", taxel=5)


# ----------------------------------------------------------------------------- sizes

def test_models_and_networks_are_bounded():
    from creepcomp.model import MAX_TERMS, CreepModel
    from creepcomp.network import MAX_CELLS, Cell, Network

    with pytest.raises(InputError, match=f"at most {MAX_TERMS}"):
        CreepModel((0.001,) * 5000, tuple(1.0 + np.arange(5000)))
    with pytest.raises(InputError, match=f"at most {MAX_CELLS}"):
        Network((Cell(1e3, 1e-6),) * 2000, 1e3)


def test_a_5000_term_model_file_is_refused_at_once(run_cli, tmp_path):
    p = tmp_path / "m.json"
    p.write_text(json.dumps({"beta": [1e-5] * 5000, "tau": [1.0 + k for k in range(5000)]}))
    status, _, err = run_cli("size", "--model", p)
    assert status == 2 and "5000 creep terms: at most 20" in err


@pytest.mark.parametrize("args, needle", [
    (["--sensitivity-n", "1e9"], "--sensitivity-n 1e9: at most"),
    (["--temperature", "1e6"], "above 200 °C"),
    (["--temperature", "-300"], "absolute zero"),
])
def test_mc_options_out_of_range(run_cli, args, needle):
    status, _, err = run_cli("mc", data_path("built_network.design.json"), "--n", "100", *args)
    assert status == 2 and needle in err


# ----------------------------------------------------------------------------- one line each

@pytest.fixture(scope="module")
def model_file(tmp_path_factory):
    p = tmp_path_factory.mktemp("m") / "model.json"
    p.write_text(json.dumps({"beta": [0.03], "tau": [45.0]}))
    return p


@pytest.mark.parametrize("args, needle", [
    (["--rate", "1e300", "--full-scale", "1"], "from 1e-300 Hz to 1e12 Hz"),
    (["--rate", "100", "--full-scale", "1", "--name", "a" * 5000], "at most 63 characters"),
    (["--max-interval", "1e300", "--full-scale", "1"], "to 1e12 s"),
])
def test_firmware_arguments_out_of_range(run_cli, model_file, tmp_path, args, needle):
    status, _, err = run_cli("firmware", model_file, "-o", tmp_path / "fw", *args)
    assert status == 2 and needle in err and not (tmp_path / "fw").exists()


def test_deeply_nested_json_is_one_line(run_cli, tmp_path):
    p = tmp_path / "deep.json"
    p.write_text("[" * 100_000 + "]" * 100_000)
    status, _, err = run_cli("size", "--model", p)
    assert status == 2 and "nested too deeply" in err


def test_a_plot_suffix_no_format_has_is_refused_first(run_cli, tmp_path):
    status, _, err = run_cli("size", "--term", "3%@45s", "-o", tmp_path / "d.json", "--plot", tmp_path / "x.xyz")
    assert status == 2 and "--plot" in err and "x.xyz" in err and not (tmp_path / "d.json").exists()


def _cli(*args, env=None, stdout=subprocess.PIPE):
    return subprocess.run([sys.executable, "-c", "from creepcomp.cli import run; run()", *args],
                          stdout=stdout, stderr=subprocess.PIPE, text=True, timeout=60,
                          env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path), **(env or {})})


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full")
def test_stdout_on_a_full_device_is_one_line():
    with open("/dev/full", "w") as full:
        done = _cli("size", "--term", "3%@45s", stdout=full)
    assert done.returncode == 1 and "Traceback" not in done.stderr
    assert done.stderr.strip() == "creepcomp: error: writing the output: no space left on the device"


def test_an_ascii_terminal_gets_replacements():
    done = _cli("size", "--term", "3%@45s", env={"PYTHONIOENCODING": "ascii"})
    assert done.returncode == 0 and "Traceback" not in done.stderr
    assert "?" in done.stdout and "3 % at 45 s" in done.stdout


def test_lot_report_escapes_unit_names_and_errors():
    from creepcomp.fleet.lot import lot_summary
    from creepcomp.fleet.unit import empty_row
    from creepcomp.report.fleet import lot_report_html

    ok = empty_row(f"{INJECTED}.csv", INJECTED)
    ok.update(status="ok", findings="none", in_spec=False, residual_creep=0.01, spec=0.001)
    failed = empty_row("b.csv", "b")
    failed.update(status="failed", error=INJECTED)
    page = lot_report_html(lot_summary([ok, failed]), {"spec": 0.001, "table": INJECTED,
                                                      "workers": 1, "scheduler": INJECTED})
    assert "<script" not in page and "Units out of spec" in page and "Failed units" in page
    assert page.count("&lt;script&gt;") >= 6
