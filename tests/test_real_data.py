"""Others' measured data: the insole and creep-workbook readers, the shipped trimmed copies
(by name, against the originals where ``../shared/data`` is present, with their licences),
and fits on them that come out finite and of the right sign."""

from __future__ import annotations

import gzip
import os
from pathlib import Path

import numpy as np
import pytest
from openpyxl import Workbook
from scipy.io import savemat

from creepcomp import data
from creepcomp.errors import InputError
from creepcomp.fit import fit_prony, prepare, term_table
from creepcomp.fit.noise import FEW_WINDOWS, noise_floor, none_statement
from creepcomp.io.formats import read_any
from creepcomp.io.insole import (rank_taxels, read_insole, read_insole_file, taxel_problems)
from creepcomp.io.wood import LR_ELASTIC_MODULUS_MPA, read_wood, read_wood_sheet

ROOT = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("CREEPCOMP_SHARED_DATA", ROOT.parent / "shared" / "data"))
REAL = ROOT / "src" / "creepcomp" / "data" / "real"


# ----------------------------------------------------------------------------- insole files

def insole_mat(path: Path, n_taxels_rows=300, n_pressure_rows=290) -> Path:
    """A small insole file: taxel 3 follows the pressure (falls 10 counts per bar), taxel 5
    drops out to 0, taxel 7 is clipped at 255, the rest sit still at 240."""
    rng = np.random.default_rng(0)
    t = 1000.0 + 0.02 * np.arange(n_taxels_rows)
    p = np.repeat([0.0, 1.0, 2.0, 1.0, 0.0, 0.5], 60)[:max(n_taxels_rows, n_pressure_rows)]
    c = np.full((n_taxels_rows, 282), 240.0)
    c[:, 0] = np.arange(n_taxels_rows)
    c[:, 1] = t
    c[:, 2 + 3] = np.round(240 - 10 * p[:n_taxels_rows] + rng.normal(0, 0.3, n_taxels_rows))
    c[:, 2 + 4] = np.round(240 - 5 * p[:n_taxels_rows] + rng.normal(0, 2, n_taxels_rows))
    c[100:110, 2 + 5] = 0.0
    c[200:, 2 + 7] = 255.0
    savemat(path, {"experiment": {"C": c, "P": p[:n_pressure_rows].reshape(-1, 1)}})
    return path


def test_insole_channels_are_cut_to_the_shorter_one(tmp_path):
    for n_c, n_p in ((300, 290), (280, 300)):
        f = read_insole_file(insole_mat(tmp_path / f"i{n_c}.mat", n_c, n_p))
        n = min(n_c, n_p)
        assert len(f.time) == len(f.pressure) == f.counts.shape[0] == n
        assert (f.rows_taxels, f.rows_pressure) == (n_c, n_p)
        assert f.time[0] == 1000.0 and f.time[-1] == pytest.approx(1000.0 + 0.02 * (n - 1))
        assert f"first {n} rows" in f.alignment


def test_insole_taxel_choice_units_and_sign(tmp_path):
    r = read_insole(insole_mat(tmp_path / "i.mat"), taxel=3)
    assert len(r) == 290 and r.unit("load") == "bar" and r.unit("signal") == "counts"
    assert r.metadata["insole.taxel"] == "3"
    slope = np.polyfit(r.load, r.signal, 1)[0]
    assert slope == pytest.approx(-10, abs=0.3)           # the counts of column 2 + 3, falling


def test_insole_broken_taxels_are_refused_with_the_reason(tmp_path):
    path = insole_mat(tmp_path / "i.mat")
    with pytest.raises(InputError, match=r"taxel 5 drops to 0 counts in 10 samples") as info:
        read_insole(path, taxel=5)
    assert str(info.value).endswith("follow the pressure best: 3, 4")       # only working ones
    with pytest.raises(InputError, match="taxel 7 reaches the converter's full scale"):
        read_insole(path, taxel=7)
    with pytest.raises(InputError, match=r"taxel 9 does not move \(range 0 counts"):
        read_insole(path, taxel=9)
    with pytest.raises(InputError, match="taxel 280 does not exist"):
        read_insole(path, taxel=280)
    flagged = read_insole(path, taxel=5, allow_broken=True)
    assert "drops to 0" in flagged.metadata["insole.problems"]
    assert taxel_problems(np.array([240.0, 241.0, 239.0])) == []


def test_rank_taxels_puts_the_responsive_working_ones_first(tmp_path):
    ranked = rank_taxels(read_insole_file(insole_mat(tmp_path / "i.mat")))
    assert [r["taxel"] for r in ranked[:2]] == [3, 4]
    assert ranked[0]["correlation"] < -0.99 and ranked[0]["sensitivity"] == pytest.approx(-10, abs=0.3)
    assert all(r["problems"] for r in ranked[2:])        # the rest: dropouts, clipping, still


def test_not_an_insole_file(tmp_path):
    p = tmp_path / "x.mat"
    savemat(p, {"other": np.zeros(3)})
    with pytest.raises(InputError, match="no struct 'experiment'.*other"):
        read_insole_file(p)
    (tmp_path / "junk.mat").write_text("not matlab")
    with pytest.raises(InputError, match="not a readable MATLAB file"):
        read_insole_file(tmp_path / "junk.mat")


# ----------------------------------------------------------------------------- creep workbooks

def workbook(path: Path, moisture: bool = False) -> Path:
    """A workbook laid out like the spruce creep files: two sheets, a header block, a table."""
    wb = Workbook()
    wb.remove(wb.active)
    for name, stress in (("A-1", 40.0), ("A-2", 60.0)):
        ws = wb.create_sheet(name)
        for row in (("Experiment", "X1"), ("Sample", name), ("Sample Type", "LR"),
                    ("Thickness [mm]", 0.3), ("Area [mm^2]", 3.0), ("Creep Load [N]", stress * 3.0),
                    ("Creep Stress [MPa]", stress), ("Nominal Loading Degree [-]", 0.3),
                    ("Nominal RH [%]", 65)):
            ws.append(row)
        ws.append((None, None))
        cols = ["Time [h]", "Creep Strain [-]", "Creep Compliance [MPa^-1]"]
        if moisture:
            cols.insert(1, "Moisture [%]")
        ws.append(cols)
        for h in (0.0, 0.5, 1.0, 2.0):
            strain = 1e-4 * (1 - np.exp(-h))
            row = [h, strain, strain / stress]
            if moisture:
                row.insert(1, 8.0 + h)
            ws.append(row)
    wb.save(path)
    return path


def test_workbook_header_values_units_and_the_instantaneous_strain(tmp_path):
    path = workbook(tmp_path / "w.xlsx")
    ws = read_wood_sheet(path, "A-2")
    assert ws.header["Creep Stress [MPa]"] == 60.0 and ws.header["Thickness [mm]"] == 0.3
    assert ws.header["Sample Type"] == "LR"
    r = read_wood(path, "A-2")
    e = LR_ELASTIC_MODULUS_MPA[65][0]
    np.testing.assert_allclose(r.time, [0, 1800, 3600, 7200])                 # hours -> s
    np.testing.assert_allclose(r.load, 60.0)
    np.testing.assert_allclose(r.signal, ws.columns["Creep Strain [-]"] + 60.0 / e)
    assert r.unit("load") == "MPa" and float(r.metadata["wood.Creep Stress [MPa]"]) == 60.0
    assert "mean modulus of 10 LR slices at 65 % RH" in r.metadata["wood.instantaneous_strain"]
    bare = read_wood(path, "A-2", elastic_modulus=None)
    np.testing.assert_array_equal(bare.signal, ws.columns["Creep Strain [-]"])
    given = read_wood(path, "A-2", elastic_modulus=5000.0)
    assert given.signal[0] == pytest.approx(60.0 / 5000.0)
    assert bare.temperature is None


def test_workbook_moisture_goes_into_the_temperature_column(tmp_path):
    r = read_wood(workbook(tmp_path / "m.xlsx", moisture=True), "A-1")
    np.testing.assert_allclose(r.temperature, [8.0, 8.5, 9.0, 10.0])
    assert "moisture" in r.unit("temperature")


def test_workbook_problems_are_named(tmp_path):
    path = workbook(tmp_path / "w.xlsx")
    with pytest.raises(InputError, match="2 sheets .*name one .*A-1, A-2"):
        read_wood_sheet(path)
    with pytest.raises(InputError, match="no sheet 'B'"):
        read_wood_sheet(path, "B")
    from openpyxl import load_workbook

    wb = load_workbook(path)
    wb["A-1"].cell(row=13, column=2).value = "n/a"
    wb.save(path)
    with pytest.raises(InputError, match=r"\[A-1\], row 13, column 'Creep Strain \[-\]': 'n/a'"):
        read_wood_sheet(path, "A-1")


def test_read_any_dispatches_by_suffix_and_rejects_misplaced_options(tmp_path):
    r = read_any(insole_mat(tmp_path / "i.mat"), taxel=3)
    assert r.metadata["insole.taxel"] == "3"
    with pytest.raises(InputError, match=r"name one \(--taxel N\).*best: 3, 4$"):
        read_any(tmp_path / "i.mat")
    assert read_any(workbook(tmp_path / "w.xlsx"), sheet="A-1").load[0] == 40.0
    csv = tmp_path / "r.csv"
    csv.write_text("time,load,signal\n0,0,0\n1,1,1\n")
    with pytest.raises(InputError, match="a taxel applies to insole .mat files only"):
        read_any(csv, taxel=1)
    with pytest.raises(InputError, match="a sheet applies to .xlsx"):
        read_any(csv, sheet="A")
    gz = tmp_path / "r.csv.gz"
    gz.write_bytes(gzip.compress(csv.read_bytes()))
    np.testing.assert_array_equal(read_any(gz).signal, [0, 1])


def test_cli_reads_a_workbook_sheet(run_cli, tmp_path):
    path = workbook(tmp_path / "w.xlsx")
    status, _, err = run_cli("fit", path, "--load-step-at", "0")
    assert status == 2 and "--sheet" in err and "A-1, A-2" in err
    status, _, err = run_cli("fit", path, "--sheet", "A-1", "--taxel", "2", "--load-step-at", "0")
    assert status == 2 and "a taxel applies to insole .mat files only" in err


def test_correct_reads_an_insole_taxel(run_cli, tmp_path):
    path = insole_mat(tmp_path / "i.mat")
    model = tmp_path / "static.json"
    model.write_text('{"beta": [], "tau": [], "gain": -10.0, "offset": 240.0}')
    status, _, err = run_cli("correct", path, "--model", model)
    assert status == 2 and "--taxel" in err
    out = tmp_path / "c.csv"
    status, stdout, err = run_cli("correct", path, "--taxel", "3", "--model", model, "-o", out)
    assert status == 0, err
    assert "static calibration" in stdout
    corrected = read_any(out)
    assert corrected.metadata["insole.taxel"] == "3"
    header, *rows = [line.split(",") for line in out.read_text().splitlines() if not line.startswith("#")]
    estimate = np.array([float(row[header.index("load_estimate")]) for row in rows])
    np.testing.assert_allclose(estimate, corrected.load, atol=0.1)


# ----------------------------------------------------------------------------- shipped copies

SHIPPED = {
    "insole_left_steps": ("insole", "left/experiment_Inf_15September_steps_1.mat", 128),
    "insole_right_staircase": ("insole", "right/experiment_2September_allTaxels_dynamic_pink_good.mat", 123),
}


@pytest.mark.parametrize("folder", ["insole", "wood"])
def test_licence_and_source_beside_the_data(folder):
    licence = (REAL / folder / "LICENSE").read_text()
    assert ("BSD 3-Clause" if folder == "insole" else "MIT License") in licence
    source = (REAL / folder / "SOURCE.md").read_text()
    assert ("34f0241" if folder == "insole" else "0863aaf") in source
    assert ("10.3390/s23094501" if folder == "insole" else "10.17632/vmvpvjj4g3.2") in source
    if (SHARED / folder / "LICENSE").exists():
        assert licence == (SHARED / folder / "LICENSE").read_text()      # verbatim
    size = sum(p.stat().st_size for p in REAL.rglob("*") if p.is_file())
    assert size < 500_000


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_insole_records_load_by_name_and_match_the_originals(name):
    r = getattr(data, name)()
    folder, original, taxel = SHIPPED[name]
    assert r.unit("load") == "bar" and r.metadata["insole.taxel"].startswith(str(taxel))
    assert r.time[0] == 0 and np.all(np.diff(r.time) > 0) and 300 < r.duration < 500
    if not (SHARED / folder / original).exists():
        pytest.skip("the originals (../shared/data) are not on this machine")
    f = read_insole_file(SHARED / folder / original)
    assert len(r) == len(f.time)
    np.testing.assert_allclose(r.time + float(r.metadata["time_origin"].split()[0]), f.time, atol=1e-6)
    np.testing.assert_array_equal(r.load, f.pressure)
    np.testing.assert_array_equal(r.signal, f.counts[:, taxel])


def test_shipped_wood_records_load_by_name_and_match_the_originals():
    names = data.wood_specimens()
    assert len(names) == 10 and len(data.wood_specimens(0.5)) == 5
    with pytest.raises(InputError, match="loading degree 0.4 not shipped"):
        data.wood_creep(0.4)
    original = SHARED / "wood" / "LR_samples_results.xlsx"
    for level in (0.3, 0.5):
        for name in data.wood_specimens(level):
            r = data.wood_creep(level, name)
            assert r.metadata["wood.Nominal Loading Degree [-]"] == str(level)
            assert r.metadata["wood.Nominal RH [%]"] == "90" and r.unit("load") == "MPa"
            assert float(r.metadata["wood.Creep Stress [MPa]"]) == r.load[0]
            if original.exists():
                expected = read_wood(original, name)
                np.testing.assert_array_equal(r.time, expected.time)
                np.testing.assert_array_equal(r.load, expected.load)
                np.testing.assert_array_equal(r.signal, expected.signal)


def _thinned(record, k):
    return record.with_columns(time=record.time[::k], load=record.load[::k], signal=record.signal[::k])


@pytest.mark.parametrize("name", SHIPPED)
def test_a_fit_on_each_insole_record_has_a_negative_gain(name):
    r = _thinned(getattr(data, name)(), 5)       # every 5th sample: the test is of sign, not detail
    fit = fit_prony(prepare(r), n_terms=1).fit
    gain = fit.estimate(lambda v: v["gain"])
    (term,) = term_table(fit)
    assert np.isfinite(gain).all() and np.isfinite([term["beta"], term["tau"]]).all()
    assert gain[0] < 0 and gain[0] * (1 + term["beta"]) < 0   # counts fall under pressure


def test_the_right_insole_staircase_is_fitted_whole_without_load_steps():
    """Its pressure is read by a converter and wanders by a count between samples it mostly
    holds: none of that is a load step (each would be a nuisance column per creep term: the
    fit of the whole record then never ended), and the fit chooses its terms by evidence."""
    from creepcomp.fit.data import load_steps

    prepared = prepare(data.insole_right_staircase())
    assert len(load_steps(prepared)) == 0 and len(prepared.abrupt) == 0
    result = fit_prony(prepared)
    terms = term_table(result.fit)
    assert len(terms) >= 1 and not any(name.startswith("step_time") for name in result.fit.values)
    assert all(np.isfinite([t["beta"], t["tau"]]).all() for t in terms)


@pytest.mark.parametrize("level", [0.3, 0.5])
def test_a_fit_on_each_wood_record_creeps(level):
    r = data.wood_creep(level)
    fit = fit_prony(prepare(r, load_step_at=0.0)).fit
    terms = term_table(fit)
    assert fit.estimate(lambda v: v["gain"])[0] > 0
    assert all(np.isfinite(t["beta"]) and t["beta"] > 0 and np.isfinite(t["tau"]) for t in terms)
    assert fit.residual_rms / np.ptp(r.signal) < 0.1


# ----------------------------------------------------------------------------- the noise floor of sparse records

def test_the_floor_of_a_sparse_wood_record_is_called_rough():
    """25 samples over 60 h give 3 windows: the floor says it is rough, and a diagnosis with no
    finding does not claim that the model explains the record to its noise."""
    r = data.wood_creep(0.5)
    floor = noise_floor(r.signal, r.load, r.time)
    assert floor.windows < FEW_WINDOWS and floor.rough
    assert "rough estimate" in floor.method and floor.to_dict()["noise_floor_windows"] == floor.windows
    assert "too sparse" in none_statement(floor) and "explains the record" not in none_statement(floor)


def test_a_floor_from_many_windows_is_not_rough():
    rng = np.random.default_rng(3)
    t = np.arange(2000.0)
    floor = noise_floor(1.0 - np.exp(-t / 300.0) + rng.normal(0, 0.01, t.size), np.ones_like(t), t)
    assert floor.windows >= FEW_WINDOWS and not floor.rough
    assert floor.rms == pytest.approx(0.01, rel=0.15)
    assert "explains the record to its noise" in none_statement(floor)


def test_report_cells_show_a_data_problems_kind_and_places():
    """A ``data_problem`` finding's parameters are a kind and lists (the insole's jumps): the
    HTML report writes them as the text output does, instead of failing."""
    from creepcomp.report.common import format_named

    assert format_named("data_problem.kind", "jump") == "jump"
    assert format_named("data_problem.where", [29.28, 319.4]) == "29.28 s, 319.4 s"
    assert format_named("data_problem.size", [-23.8, 22.51]) == "-23.8, 22.51"
