"""Every result shows itself: a one-line repr without arrays, an HTML table with units and
escaped text, a text report, a JSON-able dict, a pandas table where tabular, and a plot drawn
into the caller's Axes that is neither closed nor saved."""

import functools
import json
import re

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from creepcomp.io.records import Record  # noqa: E402
from creepcomp.model import CreepModel  # noqa: E402

HOSTILE = "<script>alert(1)</script>"
MODEL = CreepModel((0.03,), (20.0,), 0.01)


def hostile_record(n=300) -> Record:
    """A staircase load and a one-term creeping signal, with a hostile source and metadata."""
    t = 0.5 * np.arange(n)
    load = np.where((t // 30) % 2 == 1, 100.0, 0.0)
    signal = MODEL.response(t, load) + np.random.default_rng(0).normal(0, 1e-4, n)
    return Record(t, load, signal, metadata={"units.signal": "V", "units.load": "N", "name": HOSTILE},
                  source=HOSTILE)


def _prony():
    from creepcomp.fit.data import prepare
    from creepcomp.fit.prony import fit_prony

    return fit_prony(prepare(hostile_record()), max_terms=2)


def _diagnosis():
    from creepcomp.diagnose.sensor import diagnose

    return diagnose(hostile_record(), candidates=[], correction=False)


def _circuit_diagnosis():
    from creepcomp import synth
    from creepcomp.diagnose.circuit import diagnose_circuit

    built = synth.generate_circuit(synth.random_circuit_spec(None, 1, rate=(2.0, 8.0),
                                                             duration=(1200.0, 2400.0)))
    return diagnose_circuit(built.record, built.design, spice_check=False)


def _correction():
    from creepcomp.digital.correction import correct_record

    return correct_record(hostile_record(), MODEL)


@functools.cache
def _sizing():
    from creepcomp.analog.sizing import size

    return size(MODEL)


def _design():
    from creepcomp.io.jsonfiles import Design

    return Design(MODEL, _sizing().chosen)


def _comparison():
    from creepcomp.verify.compare import compare_program

    return compare_program(_sizing().chosen, MODEL, "step", engine=None)


@functools.cache
def _tolerance():
    from creepcomp.verify.tolerance_analysis import analyse
    from creepcomp.verify.tolerances import ToleranceSpec

    return analyse(_design(), ToleranceSpec(), 2000, seed=1, sensitivity_samples=0, workers=1)


def _creep_test():
    from creepcomp.verify.creep_test import CreepTestProgram, model_test, parse_class

    return model_test(MODEL, [20.0], parse_class("C3"),
                      CreepTestProgram(loading_time=10.0, hold=300.0, recovery=200.0))


def _firmware():
    from creepcomp.digital.firmware import generate_firmware

    return generate_firmware(MODEL, "subtractive", "float32", 10.0, 1.0)


def _verification():
    from creepcomp.digital.firmware_check import Verification

    return Verification(samples=600, max_error_fs=2e-8, worst_sample=17, ns_per_sample=12.5,
                        object_bytes=900, bound_fs=1e-7)


def _network_design():
    from creepcomp.analog.network_design import design_network

    return design_network(MODEL)


#: How to make a small result of every type a user gets from the API.
MAKERS = {
    "Record": hostile_record, "CreepModel": lambda: MODEL, "PronyResult": _prony,
    "Diagnosis": _diagnosis, "CircuitDiagnosis": _circuit_diagnosis, "Correction": _correction,
    "SizingReport": _sizing, "NetworkDesign": _network_design, "Design": _design, "Comparison": _comparison,
    "MonteCarloResult": lambda: _tolerance().result, "ToleranceReport": _tolerance,
    "CreepTestResult": _creep_test, "Firmware": _firmware, "Verification": _verification,
}


class Results(dict):
    """Each result made when first asked for."""

    def __missing__(self, name):
        self[name] = MAKERS[name]()
        return self[name]


@pytest.fixture(scope="module")
def results():
    return Results()


TYPES = tuple(MAKERS)


@pytest.mark.parametrize("name", TYPES)
def test_the_repr_is_one_short_line_without_arrays(results, name):
    text = repr(results[name])
    assert text.startswith(f"<{name} ") and text.endswith(">")
    assert "\n" not in text and len(text) < 200
    assert "array(" not in text and "[" not in text.replace("[0]", "")


@pytest.mark.parametrize("name", TYPES)
def test_the_html_table_has_units_and_escapes_text(results, name):
    page = results[name]._repr_html_()
    assert "<table>" in page
    assert re.search(r"\d [µmkMGn]?(s|%|Ω|F|V|Hz|min|h)<", page) or \
        any(unit in page for unit in ("(of full scale)", ">of full scale<", " (v)<", "(signal units)"))
    assert "<script>" not in page


def test_a_hostile_name_in_a_record_is_escaped(results):
    page = results["Record"]._repr_html_()
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in page and "<script" not in page
    assert "<td style=\"text-align:right\">149.5 s</td>" in page


@pytest.mark.parametrize("name", TYPES)
def test_the_text_report_holds_the_tables(results, name):
    r = results[name]
    text = r.report()
    for table in r.tables().tables:
        assert table.title in text
        assert all(c.name in text for c in table.columns)


@pytest.mark.parametrize("name", TYPES)
def test_to_dict_is_json(results, name):
    json.dumps(results[name].to_dict(), allow_nan=True)


@pytest.mark.parametrize("name", TYPES)
def test_plot_draws_into_the_given_axes_and_leaves_it_open(results, name):
    fig, ax = plt.subplots()
    figures = set(plt.get_fignums())
    try:
        got = results[name].plot(ax=ax)
        assert got is ax
        assert ax.lines or ax.patches or ax.collections or ax.texts
        assert plt.fignum_exists(fig.number)
        assert set(plt.get_fignums()) == figures        # no figure made, none closed
    finally:
        plt.close(fig)


def test_plot_without_axes_makes_a_figure_and_closes_nothing(results):
    ax = results["CreepModel"].plot()
    try:
        assert plt.fignum_exists(ax.figure.number)
        assert ax.get_xlabel() == "time after a load step (s)"
    finally:
        plt.close(ax.figure)


def test_the_model_table_is_the_models_terms(results):
    text = CreepModel((0.02, 0.01), (30.0, 1200.0), 2.0).report()
    assert "2 % at 30 s, 1 % at 20 min" in text and "gain 2" in text


@pytest.mark.parametrize("name", ["Record", "PronyResult", "Diagnosis", "Correction", "SizingReport",
                                  "Design", "Comparison", "MonteCarloResult", "ToleranceReport",
                                  "CreepTestResult"])
def test_to_pandas(results, name):
    pytest.importorskip("pandas")
    frame = results[name].to_pandas()
    assert len(frame.columns) >= 2
    if name == "Record":
        assert list(frame.columns) == ["time", "load", "signal"] and len(frame) == 300


def test_to_pandas_without_pandas_says_so(results, monkeypatch):
    import builtins

    from creepcomp.errors import InputError

    real = builtins.__import__

    def no_pandas(name, *args, **kwargs):
        if name == "pandas":
            raise ImportError(name)
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_pandas)
    with pytest.raises(InputError, match="pip install pandas"):
        results["Record"].to_pandas()


def test_a_diagnosis_equals_itself_only(results):
    d = results["Diagnosis"]
    assert d == d
    assert (d == results["Correction"]) is False


def test_equal_models_stay_equal_and_hash_alike():
    a, b = CreepModel((0.03,), (45.0,)), CreepModel((0.03,), (45.0,), extensions={"x": 1})
    assert a == b and hash(a) == hash(b)
    assert a != CreepModel((0.03,), (46.0,))


def test_a_correction_is_the_compensated_signal_and_its_errors(results):
    from creepcomp.digital.correctors import compensate, creep_error

    record, c = results["Record"], results["Correction"]
    assert np.array_equal(c.compensated, compensate(record.time, record.signal, MODEL))
    assert c.after == creep_error(record.time, c.compensated, record.load, MODEL)
    assert c.reduction == pytest.approx(c.before.peak / c.after.peak)
    assert c.reduction > 3


def test_a_long_model_keeps_a_short_repr():
    model = CreepModel(tuple([0.001] * 20), tuple(np.logspace(0, 5, 20)))
    text = repr(model)
    assert len(text) < 200 and "17 more" in text and "beta0 2 %" in text


def test_a_subclass_of_a_result_shows_itself_as_its_base(results):
    from creepcomp.model import CreepModel as Base

    class Mine(Base):
        pass

    mine = Mine((0.03,), (20.0,), 0.01)
    assert mine.tables().tables[0].rows == MODEL.tables().tables[0].rows


def _cells(summary):
    return [c for t in summary.tables for row in t.rows for c in row if c]


def test_the_terminal_prints_the_tables_a_notebook_shows(run_cli, tmp_path):
    """One place per table: every cell of a result's tables is in its command's output."""
    from creepcomp.io.jsonfiles import write_model
    from creepcomp.verify.creep_test import CreepTestProgram, model_test, parse_class

    status, out, _ = run_cli("size", "--beta0", "3%", "--tau", "20s")
    assert status == 0
    assert [c for c in _cells(_network_design().tables()) if c not in out] == []
    model = write_model(tmp_path / "m.json", MODEL)
    status, out, _ = run_cli("creep-test", model, "--class", "C3", "--temperatures", "20")
    assert status == 0
    shown = model_test(MODEL, [20.0], parse_class("C3"), CreepTestProgram()).tables()
    assert [c for c in _cells(shown) if c not in out] == []


def test_the_terminal_prints_text_from_a_file_as_written():
    from rich.console import Console

    from creepcomp.report.tables import Table

    table = Table.of("[red]title", ["[b]column"], [["[bold]x[/bold]"], ["FAIL"]], marks={"FAIL": "red"})
    console = Console(record=True, width=80, color_system=None)
    console.print(table.to_rich())
    text = console.export_text()
    assert "[red]title" in text and "[b]column" in text and "[bold]x[/bold]" in text and "FAIL" in text


def test_a_corrector_says_what_it_is():
    from creepcomp.digital.correctors import Corrector

    corrector = Corrector(MODEL, dt=0.5)
    assert repr(corrector) == "<Corrector subtractive, 1 term, dt 0.5 s, zero hold: not started>"
    corrector.process([0.0, 1.0])
    assert repr(corrector).endswith("running>")


def test_a_refused_design_shows_why_and_the_way_out():
    from creepcomp.analog.network_design import design_network

    design = design_network(CreepModel.voigt(0.03, 45.0), load_resistance=1e6)
    assert design.refused and "\n" not in repr(design) and "way out" in repr(design)
    text = design.report()
    assert "impractical: load resistance 1 MΩ is too low" in text
    assert f"way out: {design.way_out.description}" in text
    assert design.to_dict()["practical"] is False
    json.dumps(design.to_dict())
    fig, ax = plt.subplots()
    try:
        assert design.plot(ax=ax) is ax and ax.lines
    finally:
        plt.close(fig)
