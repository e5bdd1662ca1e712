"""Output locks: a second run writing the same output while the first holds it is refused in
one line; a lock left by a process that died is taken over."""

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from creepcomp.errors import InputError
from creepcomp.io.outputs import check_outputs, lock_path, release_outputs

SRC = str(Path(__file__).resolve().parents[1] / "src")
DESIGN = Path(SRC) / "creepcomp" / "data" / "built_network.design.json"

HOLDER = ("import sys\n"
          "from creepcomp.io.outputs import check_outputs\n"
          "check_outputs({'--report': sys.argv[1]}, dirs={'-o': sys.argv[2]})\n"
          "print('held', flush=True)\n"
          "sys.stdin.read()\n")


def _holder(report: Path, folder: Path) -> subprocess.Popen:
    """A process that holds the locks of ``report`` and ``folder`` until its stdin closes."""
    proc = subprocess.Popen([sys.executable, "-c", HOLDER, str(report), str(folder)],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                            env={**os.environ, "PYTHONPATH": SRC})
    assert proc.stdout.readline().strip() == "held"
    return proc


def test_a_second_mc_report_to_the_same_file_is_refused_in_one_line(tmp_path):
    report = tmp_path / "report.html"
    first = _holder(report, tmp_path / "out")
    try:
        second = subprocess.run([sys.executable, "-c", "from creepcomp.cli import run; run()", "mc",
                                 str(DESIGN), "--n", "100", "--report", str(report)],
                                capture_output=True, text=True, timeout=120,
                                env={**os.environ, "PYTHONPATH": SRC, "OPENBLAS_NUM_THREADS": "1"})
        assert second.returncode == 2
        lines = second.stderr.strip().splitlines()
        assert len(lines) == 1 and "Traceback" not in second.stderr
        assert f"is being written by another creepcomp run (pid {first.pid})" in lines[0]
        assert not report.exists()
    finally:
        first.communicate("")
    assert first.returncode == 0
    assert not lock_path(report).exists()          # removed when the holder ended


def test_a_held_folder_is_refused_and_a_lock_left_by_a_dead_process_taken_over(tmp_path):
    report, folder = tmp_path / "report.html", tmp_path / "out"
    first = _holder(report, folder)
    try:
        with pytest.raises(InputError, match=f"-o {folder}: is being written by another creepcomp "
                                             rf"run \(pid {first.pid}\)"):
            check_outputs(dirs={"-o": folder})
    finally:
        first.send_signal(signal.SIGKILL)
        first.wait()
    assert lock_path(report).read_text().strip() == str(first.pid)   # left behind
    try:
        check_outputs({"--report": report}, dirs={"-o": folder})
        check_outputs({"--report": report})       # held by this process already: kept
        assert lock_path(report).read_text().strip() == str(os.getpid())
        assert lock_path(folder).read_text().strip() == str(os.getpid())
    finally:
        release_outputs()
    assert not lock_path(report).exists() and not lock_path(folder).exists()


@pytest.mark.parametrize("command", [["demo", "-o"], ["data", "export", "hidden_effect"]])
def test_a_second_demo_or_export_into_a_held_folder_is_refused_in_one_line(tmp_path, command):
    folder = tmp_path / "same"
    first = _holder(tmp_path / "other.html", folder)
    try:
        second = subprocess.run([sys.executable, "-c", "from creepcomp.cli import run; run()", *command,
                                 str(folder)], capture_output=True, text=True, timeout=300,
                                env={**os.environ, "PYTHONPATH": SRC, "OPENBLAS_NUM_THREADS": "1",
                                     "MPLBACKEND": "Agg"})
        assert second.returncode == 2, second.stderr
        lines = second.stderr.strip().splitlines()
        assert len(lines) == 1 and "Traceback" not in second.stderr
        assert f"is being written by another creepcomp run (pid {first.pid})" in lines[0]
        assert not folder.exists()
    finally:
        first.communicate("")
