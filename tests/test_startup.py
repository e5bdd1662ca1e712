"""The command line starts without the heavy libraries: they are imported where they are used.

Start-up time itself is measured by ``benchmarks/startup.py`` (figures in docs/benchmarks.md);
this test checks its cause, which does not depend on how busy the machine is.
"""

import json
import subprocess
import sys

#: (pydantic: typer from 0.29 imports it to parse any command line, about 0.06 s; pyproject.toml keeps
#: typer below that)
HEAVY = ("control", "scipy.signal", "scipy.optimize", "scipy.interpolate", "matplotlib", "PySpice", "numba",
         "pydantic")


def modules_after(code: str) -> set[str]:
    """Modules loaded by a fresh interpreter after running ``code``."""
    probe = code + "\nimport sys, json\nprint(json.dumps(sorted(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    return set(json.loads(out.stdout.strip().splitlines()[-1]))


def modules_after_command(args: list[str]) -> set[str]:
    """Modules loaded by a fresh interpreter after the command line ``args`` (which must
    succeed; its output is dropped)."""
    return modules_after("from creepcomp.cli import main\n"
                         "import contextlib, io\n"
                         "with contextlib.redirect_stdout(io.StringIO()):\n"
                         f"    assert main({args!r}) == 0")


def _write_record(path, t, load, signal):
    import numpy as np

    np.savetxt(path, np.column_stack([t, load, signal]), delimiter=",", header="time,load,signal",
               comments="")
    return path


def heavy(modules: set[str]) -> list[str]:
    return sorted(h for h in HEAVY if h in modules)


def test_help_imports_no_heavy_library():
    loaded = modules_after("import sys\nfrom creepcomp.cli import main\n"
                           "import contextlib, io\n"
                           "with contextlib.redirect_stdout(io.StringIO()):\n"
                           "    main(['--help'])")
    assert "typer" in loaded
    assert heavy(loaded) == []


def test_sizing_imports_neither_python_control_nor_matplotlib():
    loaded = modules_after("from creepcomp.cli import main\n"
                           "import contextlib, io\n"
                           "with contextlib.redirect_stdout(io.StringIO()):\n"
                           "    assert main(['size', '--beta0', '3%', '--tau', '45s', '--json']) == 0")
    assert "creepcomp.analog.sizing" in loaded
    assert heavy(loaded) == []


def test_import_creepcomp_imports_nothing_heavy():
    loaded = modules_after("import creepcomp")
    assert heavy(loaded) == [] and "numpy" not in loaded


def test_fit_imports_only_what_a_fit_uses(tmp_path):
    """A fit needs scipy.optimize and nothing heavier: not scipy.signal (which loads
    scipy.stats), interpolation, numba (0.5 s to start: a single fit runs its lags in
    numpy), the diagnosis or any other command's module."""
    import numpy as np

    t = np.arange(0.0, 300.0, 0.5)
    load = np.where(t >= 10.0, 1.0, 0.0)
    signal = load * (1.0 + 0.03 * -np.expm1(-np.clip(t - 10.0, 0.0, None) / 20.0))
    path = _write_record(tmp_path / "step.csv", t, load, signal + 1e-4 * np.sin(7.0 * t))
    loaded = modules_after_command(["fit", str(path), "--json"])
    assert "creepcomp.fit.prony" in loaded and "scipy.optimize" in loaded
    assert [m for m in ("control", "scipy.signal", "scipy.stats", "scipy.interpolate", "matplotlib",
                        "PySpice", "dask", "numba", "pydantic", "creepcomp.diagnose", "creepcomp.cli.mc")
            if m in loaded] == []
    # off a terminal no progress bar is drawn, and a JSON answer prints no table
    assert "rich.progress" not in loaded and "rich.table" not in loaded


def test_the_console_script_skips_the_last_garbage_collections(monkeypatch):
    """``run`` freezes the objects before the interpreter ends (its last collections would
    walk every object of scipy: 0.1 s), and exits with the command's status."""
    import gc

    import pytest

    import creepcomp.cli as cli

    frozen = []
    monkeypatch.setattr(cli, "main", lambda: 3)
    monkeypatch.setattr(gc, "freeze", lambda: frozen.append(True))
    with pytest.raises(SystemExit) as stop:
        cli.run()
    assert stop.value.code == 3 and frozen == [True]


def test_the_record_reducer_imports_no_scipy():
    """A long record is read and reduced in a thread while the fit's scipy is imported in the
    other: the reducer itself must not need scipy."""
    loaded = modules_after("import creepcomp.fit.reduce")
    assert "numpy" in loaded and not any(m == "scipy" or m.startswith("scipy.") for m in loaded)


def test_a_diagnosis_needs_no_scipy_stats(tmp_path):
    """The diagnosis's few distribution functions (chi-squared and F survival, Student's t
    quantile) come from scipy.special: scipy.stats costs 0.3 s to import, a fifth of a
    30-minute record's whole diagnosis from the command line."""
    import numpy as np

    t = np.arange(0.0, 600.0, 0.5)
    load = np.where((t >= 10.0) & (t < 300.0), 1.0, 0.0)
    path = _write_record(tmp_path / "steps.csv", t, load, load + 1e-3 * np.sin(3.0 * t))
    loaded = modules_after_command(["diagnose", str(path), "--json", "--jobs", "1",
                                    "--effects", "viscous_flow"])
    assert "creepcomp.diagnose.sensor" in loaded and "creepcomp.diagnose.output_drift" in loaded
    assert "scipy.stats" not in loaded


def _blas_threads(env: dict) -> list[int]:
    """OpenBLAS's thread counts in a fresh interpreter that starts the command line."""
    import os

    probe = ("from creepcomp.cli import main\nimport json, numpy, scipy.linalg, threadpoolctl\n"
             "print(json.dumps([i['num_threads'] for i in threadpoolctl.threadpool_info()"
             " if i['internal_api'] == 'openblas']))")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True,
                         env={**{k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"},
                              **env})
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_the_command_line_runs_blas_on_one_thread_unless_told_otherwise():
    """OpenBLAS's idle threads spin beside a diagnosis's worker processes: the command line
    sets one thread before numpy loads it, and keeps a count the user set."""
    assert set(_blas_threads({})) == {1}
    assert set(_blas_threads({"OPENBLAS_NUM_THREADS": "2"})) == {2}
