"""Execute the notebooks of ``examples/`` and store their outputs in them (the documentation
site shows the stored outputs; the test suite executes the notebooks on its own).

Run it after changing a notebook or what it shows::

    .venv/bin/python tools/run_notebooks.py                   # every notebook
    .venv/bin/python tools/run_notebooks.py examples/firmware.ipynb

Each notebook runs in a fresh kernel (``python3``, from ipykernel) in a temporary folder, so
that the files it writes land there; the execution's metadata (times, kernel versions) is
left out, so that a re-run changes only what the notebook shows.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

import nbformat
from nbclient import NotebookClient

ROOT = Path(__file__).resolve().parents[1]
#: Seconds a cell may take before the run fails.
CELL_TIMEOUT = 120


def execute(path: Path) -> tuple[nbformat.NotebookNode, float]:
    """The notebook at ``path`` executed in a fresh kernel in a temporary folder, and the
    seconds it took."""
    notebook = nbformat.read(path, as_version=4)
    start = time.perf_counter()
    # the kernel inherits this process's environment: a file backend chosen here (the command
    # line sets MPLBACKEND=Agg when it runs in-process) would keep its figures from showing
    backend = os.environ.pop("MPLBACKEND", None)
    try:
        with tempfile.TemporaryDirectory(prefix="creepcomp-notebook-") as folder:
            NotebookClient(notebook, timeout=CELL_TIMEOUT, kernel_name="python3",
                           resources={"metadata": {"path": folder}}).execute()
    finally:
        if backend is not None:
            os.environ["MPLBACKEND"] = backend
    return notebook, time.perf_counter() - start


def strip_run_metadata(notebook: nbformat.NotebookNode) -> None:
    """Drop what changes at every run without changing what the notebook shows."""
    for cell in notebook.cells:
        cell.metadata.pop("execution", None)
    notebook.metadata.pop("widgets", None)


def main(argv: list[str]) -> int:
    paths = [Path(p) for p in argv] or sorted((ROOT / "examples").glob("*.ipynb"))
    for path in paths:
        notebook, seconds = execute(path)
        strip_run_metadata(notebook)
        nbformat.write(notebook, path)
        print(f"{path.name}: executed in {seconds:.1f} s, outputs stored")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
