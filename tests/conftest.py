import os

import matplotlib
import pytest
from hypothesis import settings

matplotlib.use("Agg")

settings.register_profile("default", deadline=None, max_examples=60)
settings.register_profile("ci", deadline=None, max_examples=60, derandomize=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


@pytest.fixture
def run_cli(capsys):
    """Run the command line in-process; returns (status, stdout, stderr). The consoles are
    wide, so that a long temporary path is never folded across lines of the output."""
    from creepcomp.cli import main
    from creepcomp.cli.common import console, err_console

    console.width = err_console.width = 400

    def run(*args):
        status = main([str(a) for a in args])
        out, err = capsys.readouterr()
        return status, out, err

    return run


@pytest.fixture(autouse=True)
def _outside_the_checkout(tmp_path_factory, monkeypatch):
    """Every test runs in a working folder of its own: a command that writes into its working
    folder (a file named by default) writes there, never into the checkout (a stray
    ``design-step.png`` was once committed from a test run in the repository)."""
    monkeypatch.chdir(tmp_path_factory.mktemp("cwd"))
