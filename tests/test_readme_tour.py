"""The README's tour runs as written against a non-editable install, in a folder of its own.

The tour is the part of README.md between ``<!-- tour -->`` and ``<!-- /tour -->``; each line
``$ creepcomp ...`` of its ``console`` blocks is run in turn in one temporary folder (later
commands read what earlier ones wrote), and the lines shown under it must be printed: each
run of lines between ``...`` lines in one piece, the runs in order (trailing spaces aside).

The install: a wheel built from a copy of the project (``pip wheel --no-deps``), installed
with ``pip install --no-deps`` into a new virtual environment in a temporary folder. Its
dependencies are this interpreter's own, reached through a ``.pth`` line naming this
environment's site-packages (where the editable install's ``.pth`` is not processed, so the
project's source tree is not on the path): a wheel and an environment in about 11 s, where
installing the dependencies too takes about 60 s and 800 MB.
"""

import os
import re
import shlex
import shutil
import site
import subprocess
import sys
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
START, END = "<!-- tour -->", "<!-- /tour -->"
#: The terminal width the tour's outputs were printed at.
COLUMNS = "120"


def tour_text(readme: str) -> str:
    """The README's tour: the text between its markers."""
    assert readme.count(START) == 1 and readme.count(END) == 1, "one tour, between its markers"
    return readme.split(START, 1)[1].split(END, 1)[0]


def tour_steps(text: str) -> list[tuple[str, list[str]]]:
    """Each ``$`` command of the tour's console blocks and the lines shown under it."""
    steps: list[tuple[str, list[str]]] = []
    for block in re.findall(r"^```console\n(.*?)^```", text, re.S | re.M):
        for line in block.splitlines():
            if line.startswith("$ "):
                steps.append((line[2:].strip(), []))
            else:
                assert steps, f"output before any command: {line!r}"
                steps[-1][1].append(line.rstrip())
    return steps


def shown_runs(shown: list[str]) -> list[list[str]]:
    """The runs of consecutive lines between ``...`` lines."""
    runs, run = [], []
    for line in shown:
        if line == "...":
            runs.append(run)
            run = []
        else:
            run.append(line)
    runs.append(run)
    return [r for r in runs if r]


def missing_run(shown: list[str], printed: list[str]) -> list[str] | None:
    """The first run of shown lines not printed in one piece after the runs before it."""
    at = 0
    for run in shown_runs(shown):
        for i in range(at, len(printed) - len(run) + 1):
            if printed[i:i + len(run)] == run:
                at = i + len(run)
                break
        else:
            return run
    return None


def test_the_tour_is_there_and_uses_no_source_paths():
    text = tour_text((ROOT / "README.md").read_text(encoding="utf-8"))
    steps = tour_steps(text)
    assert len(steps) >= 8
    assert all(command.startswith("creepcomp ") for command, _ in steps)
    assert "src/creepcomp" not in text
    first = [command.split()[1:3] for command, _ in steps][:2]
    assert first == [["data", "list"], ["data", "export"]]


def test_the_comparison_finds_what_is_not_printed():
    printed = ["a", "b", "c", "d"]
    assert missing_run(["a", "...", "c", "d"], printed) is None
    assert missing_run(["a", "c"], printed) == ["a", "c"]          # not in one piece
    assert missing_run(["c", "...", "a"], printed) == ["a"]        # not in order


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> Path:
    """The bin folder of a new environment holding the project's wheel, installed."""
    tmp = tmp_path_factory.mktemp("tour-install")
    project = tmp / "project"
    project.mkdir()
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy2(ROOT / name, project / name)
    shutil.copytree(ROOT / "src", project / "src",
                    ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check", "-q"]
    subprocess.run(pip + ["wheel", "--no-deps", "-w", str(tmp / "wheel"), str(project)],
                   check=True, capture_output=True, timeout=300)
    [wheel] = (tmp / "wheel").glob("creepcomp-*.whl")
    env_dir = tmp / "env"
    venv.EnvBuilder(with_pip=False).create(env_dir)
    python = env_dir / "bin" / "python"
    purelib = subprocess.run([python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                             check=True, capture_output=True, text=True).stdout.strip()
    ours = [p for p in site.getsitepackages() if Path(p).is_dir()]
    Path(purelib, "_creepcomp_dependencies.pth").write_text("\n".join(ours) + "\n")
    subprocess.run([python, "-m", "pip", "--disable-pip-version-check", "-q", "install",
                    "--no-deps", "--no-index", str(wheel)], check=True, capture_output=True,
                   timeout=300)
    return env_dir / "bin"


def tour_environment(bin_dir: Path) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "VIRTUAL_ENV"))}
    env.update(PATH=f"{bin_dir}{os.pathsep}{env.get('PATH', '')}", COLUMNS=COLUMNS)
    return env


@pytest.mark.slow
def test_the_tour_runs_as_shown_against_a_non_editable_install(installed, tmp_path):
    env = tour_environment(installed)
    where = subprocess.run(["python", "-c", "import creepcomp; print(creepcomp.__file__)"],
                           cwd=tmp_path, env=env, check=True, capture_output=True, text=True)
    package = Path(where.stdout.strip())
    assert package.is_relative_to(installed.parent) and "site-packages" in package.parts
    assert not package.is_relative_to(ROOT)
    steps = tour_steps(tour_text((ROOT / "README.md").read_text(encoding="utf-8")))
    for command, shown in steps:
        done = subprocess.run(shlex.split(command), cwd=tmp_path, env=env, capture_output=True,
                              text=True, timeout=600)
        assert done.returncode == 0, f"$ {command}\n{done.stderr}"
        printed = [line.rstrip() for line in (done.stdout + done.stderr).splitlines()]
        run = missing_run(shown, printed)
        assert run is None, (f"$ {command}: not printed as the README shows:\n" + "\n".join(run)
                             + "\n--- printed:\n" + "\n".join(printed))
