"""Shared pieces of the command line: the Typer app, the consoles, value parsing, output."""

from __future__ import annotations

import contextlib
import inspect
import os
import sys

import typer
from rich.console import Console

from creepcomp.errors import CreepcompError, InputError
from creepcomp.io.jsonfiles import to_json
from creepcomp.units import format_quantity, parse_quantity

app = typer.Typer(add_completion=False, no_args_is_help=True, pretty_exceptions_enable=False,
                  help="Remove creep from elastomer-based sensors: size RC correction networks, "
                       "correct signals digitally, fit and diagnose creep models.")
console = Console(highlight=False)
err_console = Console(stderr=True, highlight=False)


def fail(message: str, status: int = 2) -> int:
    """Print one error line on stderr and return the exit status."""
    err_console.print(f"creepcomp: error: {message}", markup=False, highlight=False, soft_wrap=True)
    return status


def tolerant_streams() -> None:
    """Let stdout and stderr that cannot encode a character (``PYTHONIOENCODING=ascii``, a C
    locale) write a replacement for it (µ, Ω, °C become ``?``) instead of failing."""
    for stream in (sys.stdout, sys.stderr):
        encoding = (getattr(stream, "encoding", None) or "").lower().replace("-", "").replace("_", "")
        if encoding != "utf8" and getattr(stream, "errors", "strict") == "strict" \
                and hasattr(stream, "reconfigure"):
            stream.reconfigure(errors="replace")


def environment_fault(exc: OSError) -> int:
    """One line for an operating-system fault met while writing (a full disk, stdout closed or
    on a full device, a folder not writable); exit status 1: the input was fine, the
    machine was not. Later writes to stdout go nowhere, so the exit itself cannot fail."""
    import errno

    if exc.errno == errno.EPIPE:
        message = "the output was closed early (broken pipe)"
    elif exc.errno == errno.ENOSPC:
        message = f"{exc.filename or 'writing the output'}: no space left on the device"
    else:
        message = f"{exc.filename or 'writing the output'}: {exc.strerror or exc}"
    with contextlib.suppress(OSError, ValueError):
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    return fail(message, 1)


def read_checked_design(path, active: bool = False):
    """A design file read and checked whole: its creep, its network
    (:func:`~creepcomp.io.jsonfiles.read_design`) and its ``parts`` block
    (:func:`~creepcomp.analog.parts.plan_of`), the same for every command that reads one."""
    from creepcomp.analog.parts import plan_of
    from creepcomp.io.jsonfiles import read_design

    design = read_design(path, active=active)
    plan_of(design, f"design file {path}")
    return design


def quantity(text: str | None, kind: str, option: str, allow_none: bool = False,
             positive: bool = False, non_negative: bool = False) -> float | None:
    """Parse an option value with units; ``none``/``inf`` give None where allowed."""
    if text is None:
        return None
    if allow_none and str(text).strip().lower() in ("none", "inf", "infinite", "open"):
        return None
    value = parse_quantity(text, kind, option)
    if positive and not value > 0:
        raise InputError(f"{option} = '{text}': must be positive")
    if non_negative and value < 0:
        raise InputError(f"{option} = '{text}': must not be negative")
    return value


def count(text: str | int, option: str, minimum: int = 1, maximum: int | None = None) -> int:
    """Parse a count in engineering notation (``1e7``, ``20k``): a whole number from
    ``minimum`` to ``maximum``."""
    value = parse_quantity(text, "number", option)
    if value != round(value) or value < minimum:
        raise InputError(f"{option} {text}: a count is a whole number >= {minimum}")
    if maximum is not None and value > maximum:
        raise InputError(f"{option} {text}: at most {maximum}")
    return int(round(value))


class OptionValueError(CreepcompError):
    """A bad option value found while the options are parsed (not a ValueError: click would
    reduce its message to "Invalid value")."""


def count_option(option: str, minimum: int = 1, maximum: int | None = None):
    """A Typer ``parser=`` for a count option (:func:`count`)."""

    def parse(text):
        try:
            return count(text, option, minimum, maximum)
        except InputError as exc:
            raise OptionValueError(str(exc)) from None

    return parse


def value_range(text: str, kind: str, option: str) -> tuple[float, float]:
    """Parse ``LOW:HIGH`` (e.g. ``1u:100u``) into an ordered, positive pair."""
    parts = str(text).split(":")
    if len(parts) != 2:
        raise InputError(f"{option} = '{text}': expected LOW:HIGH, e.g. 1u:100u")
    low = quantity(parts[0], kind, option, positive=True)
    high = quantity(parts[1], kind, option, positive=True)
    if low > high:
        raise InputError(f"{option} = '{text}': LOW is above HIGH")
    return low, high


#: Largest |beta0| (relative creep at infinite time) taken without a warning: elastomer
#: sensors show a few % up to tens of %.
PLAUSIBLE_BETA0 = 0.5


#: Hottest temperature an option may give (°C): beyond every part table's range (and an
#: elastomer's life).
HOTTEST = 200.0


def temperatures_option(text: str | None, option: str = "--temperatures") -> list[float] | None:
    """``-10,20,40`` (°C, a ``°C`` or ``C`` suffix allowed) as numbers, each above absolute
    zero and at most :data:`HOTTEST`; None when not given."""
    if text is None:
        return None
    out = []
    for item in str(text).split(","):
        if not item.strip():
            raise InputError(f"{option} '{text}': expected temperatures in °C separated by commas, "
                             "e.g. -10,20,40")
        out.append(quantity(item.strip().removesuffix("°C").removesuffix("C"), "number", option))
    if any(t <= -273.15 for t in out):
        raise InputError(f"{option} '{text}': a temperature is at or below absolute zero")
    if max(out) > HOTTEST:
        raise InputError(f"{option}: {max(out):g} °C is above {HOTTEST:g} °C, beyond any part's data")
    return out


def temperature_range_option(text: str, option: str = "--temperature-range") -> tuple[float, float]:
    """``LOW:HIGH`` in °C, LOW not above HIGH."""
    parts = text.replace("..", ":").split(":")
    if len(parts) != 2:
        raise InputError(f"{option} '{text}': expected LOW:HIGH in °C, e.g. -10:40")
    (low,), (high,) = (temperatures_option(p, option) for p in parts)
    if high < low:
        raise InputError(f"{option} '{text}': LOW must not exceed HIGH")
    return low, high


def warn_creep(model, where: str) -> None:
    """One warning line on stderr when the creep is beyond :data:`PLAUSIBLE_BETA0`."""
    from creepcomp.units import format_percent

    if abs(model.beta0) > PLAUSIBLE_BETA0:
        err_console.print(f"creepcomp: warning: {where}: beta0 = {format_percent(model.beta0)} "
                          f"(relative creep at infinite time, {model.beta0:g} as a fraction) is "
                          f"beyond the {format_percent(PLAUSIBLE_BETA0)} elastomer sensors show; "
                          "a percentage needs its % sign (3% or 0.03)",
                          markup=False, highlight=False, soft_wrap=True)


@contextlib.contextmanager
def progress_bar(description: str, total: int | None = None, disable: bool = False):
    """A Rich progress bar on stderr (a spinner without ``total``), shown on a terminal only.

    Yields
    ------
    callable
        ``update(done, total=None)`` moves the bar.
    """
    if disable or not err_console.is_terminal:
        yield lambda done, total=None, description=None: None
        return
    from rich.progress import (BarColumn, Progress, SpinnerColumn, TaskProgressColumn, TextColumn,
                               TimeElapsedColumn)

    with Progress(SpinnerColumn(), TextColumn("{task.description}"), BarColumn(),
                  TaskProgressColumn(), TimeElapsedColumn(), console=err_console,
                  transient=True) as bar:
        task = bar.add_task(description, total=total)

        def update(done, total=None, description=None):
            bar.update(task, completed=done, **({"total": total} if total is not None else {}),
                       **({"description": description} if description else {}))

        yield update


def print_json(obj) -> None:
    """Print one JSON object on stdout."""
    sys.stdout.write(to_json(obj) + "\n")


def print_summary(summary) -> None:
    """Print a result's :class:`~creepcomp.report.tables.Summary`: the heading in bold with
    its first line, the other lines, the tables, the lines after them and the warnings."""
    first = f": {summary.lines[0]}" if summary.lines else ""
    console.print(f"[bold]{summary.heading}[/bold]{first}")
    for line in summary.lines[1:]:
        console.print(line)
    for table in summary.tables:
        console.print(table.to_rich())
    for line in summary.footer:
        console.print(line)
    for warning in summary.warnings:
        console.print(f"[yellow]warning:[/yellow] {warning}", soft_wrap=False)


def api_default(function, parameter: str):
    """The default of ``function``'s ``parameter``: an option's default read from the API
    (written once, there)."""
    return inspect.signature(function).parameters[parameter].default


def si_text(value: float) -> str:
    """A value as an option takes it, with an SI prefix and no space (``100u``, ``1G``)."""
    return format_quantity(value, "").replace(" ", "").replace("µ", "u")
