"""Start-up time of the command line, beside the interpreter's own.

Runs each command ``--repeat`` times in a fresh process and prints the median, lowest and
highest wall time (s). The commands are the ones a user types first: ``creepcomp --help`` and a
one-term sizing with JSON output; ``python -c pass`` is the floor no Python tool goes below.

Usage::

    python benchmarks/startup.py [--repeat 5] [--markdown]

Run it on an idle machine: start-up is mostly reading and compiling modules, and a busy
second core doubles it. The runs reuse compiled byte-code as an installed package does
(:func:`installed_environment`), also where this interpreter does not write it.
"""

from __future__ import annotations

import argparse
import atexit
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def creepcomp_command() -> list[str]:
    """The console script next to this interpreter, or ``python -m creepcomp.cli`` without it."""
    script = Path(sys.executable).with_name("creepcomp")
    if script.exists():
        return [str(script)]
    found = shutil.which("creepcomp")
    return [found] if found else [sys.executable, "-c", "from creepcomp.cli import run; run()"]


def installed_environment() -> dict:
    """The environment for timed runs: byte-code written and reused, as for an installed
    package. When this interpreter does not write it (``PYTHONDONTWRITEBYTECODE``), the runs
    write it in a temporary folder (``PYTHONPYCACHEPREFIX``, removed at exit), so that no run
    compiles the modules from source."""
    env = dict(os.environ)
    if sys.dont_write_bytecode and "PYTHONPYCACHEPREFIX" not in env:
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        env["PYTHONPYCACHEPREFIX"] = folder = tempfile.mkdtemp(prefix="creepcomp-pycache-")
        atexit.register(shutil.rmtree, folder, ignore_errors=True)
    return env


ENV = installed_environment()


def wall_times(command: list[str], repeat: int) -> list[float]:
    """Wall time of ``repeat`` runs of ``command`` (output discarded; a failure stops)."""
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                       env=ENV)
        times.append(time.perf_counter() - start)
    return times


def main(argv: list[str] | None = None) -> int:
    """Measure and print the start-up times."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="runs per command (default 5)")
    parser.add_argument("--markdown", action="store_true", help="print a Markdown table")
    args = parser.parse_args(argv)
    cli = creepcomp_command()
    commands = {
        "python -c pass": [sys.executable, "-c", "pass"],
        "creepcomp --help": cli + ["--help"],
        "creepcomp size --beta0 3% --tau 45s --json": cli + ["size", "--beta0", "3%", "--tau", "45s",
                                                            "--json"],
    }
    rows = []
    for label, command in commands.items():
        wall_times(command, 1)                      # warm the file cache and byte-code
        t = wall_times(command, args.repeat)
        rows.append((label, statistics.median(t), min(t), max(t)))
    if args.markdown:
        print("| command | median (s) | lowest (s) | highest (s) |\n|---|---|---|---|")
        for label, med, lo, hi in rows:
            print(f"| `{label}` | {med:.3f} | {lo:.3f} | {hi:.3f} |")
    else:
        for label, med, lo, hi in rows:
            print(f"{label:45s} median {med:.3f} s  (lowest {lo:.3f} s, highest {hi:.3f} s, "
                  f"{args.repeat} runs)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
