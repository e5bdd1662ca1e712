"""The notebooks of ``examples/`` run from top to bottom in a fresh kernel, each well under a
minute, and show their results: a result as the last expression of a cell gives HTML, a plot
into the user's Axes gives a picture. The site shows the outputs stored in them
(``tools/run_notebooks.py`` stores them): those must be there, and free of errors."""

import sys
import time
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "examples").glob("*.ipynb"))
#: Seconds a notebook may take here (on a loaded 2-core machine they took 11-18 s).
BUDGET = 60

sys.path.insert(0, str(ROOT / "tools"))
from run_notebooks import execute  # noqa: E402


def shows_html(cell) -> bool:
    return any("text/html" in out.get("data", {}) for out in cell.outputs)


def shows_picture(cell) -> bool:
    return any("image/png" in out.get("data", {}) for out in cell.outputs)


def check_outputs(notebook) -> None:
    """Every code cell ran without error; results show as HTML, plots as pictures."""
    code = [c for c in notebook.cells if c.cell_type == "code"]
    assert code
    for cell in code:
        assert not any(out.output_type == "error" for out in cell.outputs), cell.source
        last = cell.source.strip().splitlines()[-1]
        if ".plot(ax=ax" in last:
            assert shows_picture(cell), cell.source
        elif last.isidentifier():                    # a result as the cell's last expression
            assert shows_html(cell), cell.source


def test_there_are_the_four_notebooks():
    assert [p.name for p in NOTEBOOKS] == ["firmware.ipynb", "first_fit.ipynb", "real_insole.ipynb",
                                          "size_prove_tolerance.ipynb"]


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_the_stored_outputs_show_every_result(path):
    notebook = nbformat.read(path, as_version=4)
    check_outputs(notebook)
    text = path.read_text(encoding="utf-8")
    assert str(ROOT) not in text and "/tmp/" not in text      # no path of the machine that ran it


@pytest.mark.slow
@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_the_notebook_runs_and_shows_its_results(path):
    pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    start = time.perf_counter()
    notebook, _ = execute(path)
    assert time.perf_counter() - start < BUDGET
    check_outputs(notebook)
