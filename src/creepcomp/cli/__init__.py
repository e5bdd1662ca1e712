"""The ``creepcomp`` command: a thin Typer layer over the Python API (``docs/cli.md``).

Each subcommand lives in its own module and registers itself on :data:`app`.
Errors in the user's input become one line on stderr and exit status 2. Ctrl-C (SIGINT)
and SIGTERM stop a command the same way, with the same clean-up (nothing partial is left,
worker processes are stopped): one line, exit status 130 (SIGINT) or 143 (SIGTERM).
"""

from __future__ import annotations

import gc
import importlib
import os
import signal
import sys
import threading

# BLAS on one thread, set before numpy loads OpenBLAS (a value the user set is kept): the
# commands' matrices are tall and narrow or small, and OpenBLAS's idle threads spin on the
# cores after each call, beside a diagnosis's worker processes (0.3-0.4 s of CPU a command;
# a diagnosis from the command line 10 % longer)
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import typer  # noqa: E402
from typer._click.exceptions import NoArgsIsHelpError  # noqa: E402
from typer.exceptions import Abort, Exit, TyperException  # noqa: E402

from creepcomp.errors import CreepcompError  # noqa: E402
from creepcomp.cli.common import app, environment_fault, fail, tolerant_streams  # noqa: E402

#: The module of each command; a module registers its command on :data:`app` when imported.
COMMAND_MODULES = {"size": "size", "netlist": "netlist", "simulate": "simulate", "mc": "mc",
                   "creep-test": "creep_test", "correct": "correct", "firmware": "firmware",
                   "fit": "fit", "diagnose": "diagnose", "fleet": "fleet", "demo": "demo",
                   "data": "data"}


def register_commands(argv: list[str] | None = None) -> None:
    """Import the command modules: only the named command's when ``argv`` names one (a
    command's start-up pays for its own imports), else all of them (the help lists them)."""
    args = sys.argv[1:] if argv is None else list(argv)
    first = next((a for a in args if not a.startswith("-")), None)
    for name in [first] if first in COMMAND_MODULES else COMMAND_MODULES:
        importlib.import_module(f"creepcomp.cli.{COMMAND_MODULES[name]}")
    _group_commands()


#: The help's command groups, in the order of the work; commands in the order listed (one
#: not listed comes last, in the default group).
COMMAND_GROUPS = {
    "Design": ("size", "netlist"),
    "Prove": ("simulate", "mc", "creep-test"),
    "Measured data": ("fit", "diagnose"),
    "Correct": ("correct", "firmware"),
    "Fleet": ("fleet",),
    "Demo": ("demo",),
    "Bundled data": ("data",),
}


def _group_commands() -> None:
    """Put every registered command in its help group, in the order of the work."""
    order = [name for names in COMMAND_GROUPS.values() for name in names]
    panel = {name: group for group, names in COMMAND_GROUPS.items() for name in names}
    for info in app.registered_commands:
        info.rich_help_panel = panel.get(info.name, info.rich_help_panel)
    app.registered_commands.sort(
        key=lambda info: order.index(info.name) if info.name in order else len(order))


def _version(value: bool) -> None:
    if value:
        from importlib.metadata import PackageNotFoundError, version

        try:
            number = version("creepcomp")
        except PackageNotFoundError:        # run from a source tree that is not installed
            number = "(not installed: no package metadata)"
        typer.echo(f"creepcomp {number}")
        raise Exit(0)


@app.callback()
def _options(
    show_version: bool = typer.Option(False, "--version", callback=_version, is_eager=True,
                                      help="Print the version and exit."),
) -> None:
    pass




#: Exit status after SIGTERM (128 + its number), beside 130 after Ctrl-C.
TERMINATED = 128 + signal.SIGTERM


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where Ctrl-C raises :class:`KeyboardInterrupt`, so that every clean-up
    written for Ctrl-C also runs for it."""


_terminated = threading.Event()
#: A Ctrl-C or SIGTERM came: the command is stopping.
_stopping = threading.Event()

#: Seconds after which a SIGTERM is delivered again while the command still runs.
REDELIVER_AFTER = 0.5
_redelivery: threading.Timer | None = None


def _raise_terminated(signum, frame) -> None:
    # an exception raised where Python ignores them (an at-fork hook of os.fork, a __del__) is
    # lost and the command would run on: deliver the signal again until it is taken
    global _redelivery
    _terminated.set()
    _stopping.set()
    _cancel_redelivery()
    _redelivery = threading.Timer(REDELIVER_AFTER, os.kill, (os.getpid(), signal.SIGTERM))
    _redelivery.daemon = True
    _redelivery.start()
    raise Terminated()


def _raise_interrupted(signum, frame) -> None:
    _stopping.set()
    raise KeyboardInterrupt


def _quiet_when_stopping(hook):
    """``sys.unraisablehook`` that reports nothing once the command is stopping: an object of a
    library cut short in its constructor by the interrupt (llvmlite's, while numba compiles)
    fails in its ``__del__``, a consequence of the stop and not a fault of its own."""
    def report(unraisable) -> None:
        if not _stopping.is_set():
            hook(unraisable)
    return report


def _cancel_redelivery() -> None:
    global _redelivery
    if _redelivery is not None:
        _redelivery.cancel()
        _redelivery = None


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script; returns the exit status."""
    # Plots go to files: the command line chooses matplotlib's file backend (before any import
    # of pyplot); the library itself never chooses one.
    os.environ.setdefault("MPLBACKEND", "Agg")
    tolerant_streams()
    if threading.current_thread() is not threading.main_thread():
        return _main(argv)
    _terminated.clear()
    _stopping.clear()
    previous = signal.signal(signal.SIGTERM, _raise_terminated)
    previous_int = signal.getsignal(signal.SIGINT)
    if previous_int is signal.default_int_handler:  # (not when Ctrl-C is ignored)
        signal.signal(signal.SIGINT, _raise_interrupted)
    previous_hook = sys.unraisablehook
    sys.unraisablehook = _quiet_when_stopping(previous_hook)
    try:
        return _main(argv)
    except Terminated:  # a SIGTERM after the command's own handling, while printing the line
        return TERMINATED
    finally:
        _cancel_redelivery()
        signal.signal(signal.SIGTERM, previous)
        if previous_int is signal.default_int_handler:
            signal.signal(signal.SIGINT, previous_int)
        sys.unraisablehook = previous_hook


def _stopped() -> int:
    """The line and status of a command stopped by Ctrl-C or SIGTERM."""
    _cancel_redelivery()
    if _terminated.is_set():
        return fail("terminated", TERMINATED)
    return fail("interrupted", 130)


def _main(argv: list[str] | None) -> int:
    from creepcomp.io.outputs import inputs_of_this_run, release_outputs

    try:
        with inputs_of_this_run():
            return _command(argv)
    finally:
        release_outputs()     # the outputs' locks, taken when they were checked


def _command(argv: list[str] | None) -> int:
    register_commands(argv)
    command = typer.main.get_command(app)
    try:
        # a command may end with typer.Exit(status) (firmware --verify: 3 when the bound fails)
        result = command.main(args=argv, prog_name="creepcomp", standalone_mode=False)
        sys.stdout.flush()
    except NoArgsIsHelpError:
        return 0        # bare ``creepcomp``: the help, already printed, is the answer
    except TyperException as exc:
        return fail(exc.format_message(), getattr(exc, "exit_code", 2) or 2)
    except CreepcompError as exc:
        return fail(str(exc))
    except Exit as exc:
        return exc.exit_code
    except (Abort, KeyboardInterrupt):
        return _stopped()
    except OSError as exc:
        return environment_fault(exc)
    # Typer turns Ctrl-C into its exit status 130 and, outside standalone mode, returns it
    # (a command itself returns None)
    if result == 130:
        return _stopped()
    return result if isinstance(result, int) else 0


def run() -> None:
    """Console-script wrapper: exits with :func:`main`'s status."""
    status = main()
    # The process ends here: the interpreter's last garbage collections would walk every object
    # of the imported libraries (0.1 s after scipy's) to free what the system frees at exit
    # anyway. Frozen objects are still released by their reference counts as the modules go;
    # only reference cycles are left to the system (the command's files are closed by then).
    gc.freeze()
    sys.exit(status)
