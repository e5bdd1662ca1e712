"""Plain option values are converted without pydantic; anything else as Typer converts it."""

import subprocess
import sys

import numpy as np


def _record(tmp_path):
    t = np.arange(400) * 0.5
    load = np.where(t >= 10.0, 1.0, 0.0)
    y = load + 0.02 * (1 - np.exp(-np.clip(t - 10.0, 0, None) / 20.0)) * load
    y = y + np.random.default_rng(0).normal(0.0, 1e-4, t.size)
    path = tmp_path / "r.csv"
    np.savetxt(path, np.column_stack([t, load, y]), delimiter=",", header="time,load,signal",
               comments="")
    return path


def test_a_fit_command_line_imports_no_pydantic(tmp_path):
    path = _record(tmp_path)
    out = tmp_path / "m.json"
    code = ("import sys\nfrom creepcomp.cli import main\n"
            f"status = main(['fit', {str(path)!r}, '--terms', '1', '--max-terms', '3',"
            f" '-o', {str(out)!r}, '--json'])\n"
            "print(status, 'pydantic' in sys.modules, file=sys.stderr)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.stderr.strip().splitlines()[-1] == "0 False"
    assert out.exists()


def test_values_the_plain_conversion_does_not_take_get_typers_words(tmp_path, capsys):
    from creepcomp.cli import main

    path = _record(tmp_path)
    assert main(["fit", str(path), "--taxel", "abc"]) == 2
    assert "Invalid value for '--taxel': Input should be a valid integer" in capsys.readouterr().err
    assert main(["fit", str(path), "--max-terms", "0"]) == 2
    assert "--max-terms 0: a count is a whole number >= 1" in capsys.readouterr().err
