"""The shared ngspice: the library loaded through PySpice, its runs, and their waveforms.

One library instance per process (PySpice keeps it as a singleton), loaded on first use and
reset between runs. ngspice's harmless stderr messages are kept as notes, its error lines
raise :class:`NgspiceError`; PySpice's warning about ngspice's version (PySpice 1.5 logs
"Unsupported Ngspice version 39") and its echo of ngspice's output during our runs are
filtered from its log.
"""

from __future__ import annotations

import contextlib
import ctypes.util
import logging
import os
import signal
import statistics
import threading
import time as _time
from dataclasses import dataclass

import numpy as np

from creepcomp.errors import CreepcompError
from creepcomp.model import CreepModel
from creepcomp.network import Network
from creepcomp.programs import LoadProgram
from creepcomp.verify.drive import (DEFAULT_SIGNAL, checked_times, default_duration, largest_step,
                                    program_breakpoints, spice_program, synthetic_program)
from creepcomp.verify.netlist import Deck, program_deck

__all__ = [
    "INSTALL_HINT", "HARMLESS", "NgspiceUnavailable", "NgspiceError", "SpiceRun", "Ngspice",
    "ngspice", "Waveforms", "run_transient", "waveforms_from_run", "time_transient",
    "run_batch",
]

INSTALL_HINT = "sudo apt-get install ngspice libngspice0-dev (or: make setup)"


class NgspiceUnavailable(CreepcompError):
    """ngspice's shared library cannot be loaded; the message names the install command."""


class NgspiceError(CreepcompError):
    """ngspice refused a netlist or failed during the analysis."""


#: ngspice messages on stderr that are notes, not errors.
HARMLESS = ("note:", "warning", "using sparse", "reducing trtol", "no compatibility mode")


class _QuietPySpice(logging.Filter):
    """Drop PySpice's version warning, and its echo of ngspice's output during our runs
    (we read that output ourselves and raise on real errors)."""

    def __init__(self):
        super().__init__()
        self.running = False

    def filter(self, record: logging.LogRecord) -> bool:
        message = record.getMessage()
        if "Unsupported Ngspice version" in message or "aren't any circuits loaded" in message:
            return False
        return not self.running


_QUIET = _QuietPySpice()


def _quiet_pyspice() -> None:
    logger = logging.getLogger("PySpice.Spice.NgSpice.Shared.NgSpiceShared")
    if _QUIET not in logger.filters:
        logger.addFilter(_QUIET)


@dataclass(frozen=True)
class SpiceRun:
    """Vectors of one ngspice transient.

    Attributes
    ----------
    time : numpy.ndarray
        ngspice's own time points (s).
    vectors : dict
        Node name -> voltages (V) at those times.
    seconds : float
        Wall time of loading, running and reading back (s).
    notes : tuple of str
        ngspice's harmless messages.
    """

    time: np.ndarray
    vectors: dict
    seconds: float
    notes: tuple[str, ...] = ()


class Ngspice:
    """The process-wide shared ngspice (through PySpice), loaded once and reused.

    Use :func:`ngspice` to get it.
    """

    def __init__(self, shared):
        self._shared = shared
        self._lock = threading.Lock()

    @property
    def version(self) -> int | None:
        """ngspice's version number."""
        return self._shared.ngspice_version

    def run(self, deck: Deck | str) -> SpiceRun:
        """Load a netlist, run its transient analysis, return its node voltages.

        Raises
        ------
        NgspiceError
            With ngspice's own error lines.
        """
        from PySpice.Spice.NgSpice.Shared import NgSpiceCircuitError, NgSpiceCommandError

        text = deck.text(standalone=False) if isinstance(deck, Deck) else deck
        shared = self._shared
        with self._lock, _running(), _deferred_interrupt() as interrupt:
            start = _time.perf_counter()
            notes: list[str] = []
            try:
                shared.destroy()
                try:
                    shared.load_circuit(text)
                except NgSpiceCircuitError:
                    pass                     # ngspice's own lines say why, just below
                notes += _check(shared.stdout, shared.stderr, "loading the netlist")
                shared._is_running = None    # set by ngspice's thread callback: False, then True
                try:
                    shared.exec_command("bg_run")
                except NgSpiceCommandError:
                    pass
                _wait(shared, interrupt)
                notes += _check(shared.stdout, shared.stderr, "the transient analysis")
                plot = shared.last_plot
                if not plot.startswith("tran"):
                    raise NgspiceError("ngspice produced no transient result")
                vectors = {name: np.array(np.asarray(vec.to_waveform()), dtype=float)
                           for name, vec in shared.plot(None, plot).items()}
            finally:
                with contextlib.suppress(Exception):
                    shared.destroy()
                    shared.remove_circuit()
            seconds = _time.perf_counter() - start
        time = vectors.pop("time")
        return SpiceRun(time, vectors, seconds, tuple(notes))


@contextlib.contextmanager
def _deferred_interrupt():
    """Ctrl-C during an ngspice run is noted, not raised where it lands: ngspice calls back
    into Python (its output), and an exception there is lost ("Exception ignored from cffi
    callback"). The run's wait loop halts ngspice on it; KeyboardInterrupt is raised once
    ngspice is stopped and cleaned up."""
    state = {"interrupted": False}
    if threading.current_thread() is not threading.main_thread():
        yield state
        return

    def note(signum, frame):
        state["interrupted"] = True

    previous = signal.signal(signal.SIGINT, note)
    try:
        yield state
    finally:
        signal.signal(signal.SIGINT, previous)
    if state["interrupted"]:
        raise KeyboardInterrupt


def _wait(shared, interrupt: dict) -> None:
    """Wait for ngspice's background run; halt it when interrupted (then raise
    KeyboardInterrupt).

    ngspice's thread reports its start and its end through PySpice's callback, which stores
    ngspice's flag "exited" (False, then True) as ``_is_running``; ``ngSpice_running()``
    alone would be False until the thread has started.
    """
    running = shared._ngspice_shared.ngSpice_running
    start = _time.monotonic()
    pause = 2e-4

    def busy():
        if shared._is_running is True:
            return False
        if shared._is_running is None and _time.monotonic() - start > 2.0:
            return bool(running())          # the thread never reported: bg_run did not start
        return True

    while busy():
        if interrupt["interrupted"]:
            with contextlib.suppress(Exception):
                shared.halt()
            deadline = _time.monotonic() + 2.0
            while running() and _time.monotonic() < deadline:
                _time.sleep(0.01)
            raise KeyboardInterrupt
        _time.sleep(pause)
        pause = min(2 * pause, 0.02)


@contextlib.contextmanager
def _running():
    _QUIET.running = True
    try:
        yield
    finally:
        _QUIET.running = False


def _check(stdout: str, stderr: str, what: str) -> list[str]:
    """Raise on ngspice's error lines; return its harmless notes."""
    notes, errors = [], []
    for line in stderr.splitlines():
        text = line.strip()
        if not text:
            continue
        (notes if text.lower().startswith(HARMLESS) else errors).append(text)
    for line in stdout.splitlines():
        text = line.strip()
        if text.lower().startswith("error") or "timestep too small" in text.lower():
            errors.append(text)
    if errors:
        raise NgspiceError(f"ngspice failed in {what}: " + " | ".join(dict.fromkeys(errors)))
    return notes


_ENGINE: Ngspice | None = None
_ENGINE_LOCK = threading.Lock()


def _load_shared():
    """Load PySpice's shared ngspice, finding the library by its soname when the
    unversioned ``libngspice.so`` (Debian's -dev package) is absent."""
    from PySpice.Spice.NgSpice import Shared
    from PySpice.Spice.NgSpice.Shared import NgSpiceShared

    _quiet_pyspice()
    # PySpice's callback for ngspice's background thread returns None where C wants an int
    # (cffi then prints "Exception ignored from cffi callback" at every run); this one
    # stores the same flag and returns 0. It must be in place before the library is loaded.
    def thread_running(exited, ngspice_id, user_data):
        Shared.ffi.from_handle(user_data)._is_running = bool(exited)
        return 0

    NgSpiceShared._background_thread_running = staticmethod(thread_running)
    if not os.environ.get("NGSPICE_LIBRARY_PATH"):
        found = ctypes.util.find_library("ngspice")
        if found is None:
            raise NgspiceUnavailable(f"ngspice is not installed (no libngspice shared library); "
                                     f"install it with: {INSTALL_HINT}")
        NgSpiceShared.LIBRARY_PATH = found
    try:
        return NgSpiceShared.new_instance()
    except OSError as exc:
        raise NgspiceUnavailable(f"ngspice's shared library cannot be loaded ({exc}); "
                                 f"install it with: {INSTALL_HINT}") from None


def ngspice() -> Ngspice:
    """The shared ngspice engine, loaded on first use.

    Raises
    ------
    NgspiceUnavailable
        When the library is missing; the message names the install command.
    """
    global _ENGINE
    with _ENGINE_LOCK:
        if _ENGINE is None:
            _ENGINE = Ngspice(_load_shared())
        return _ENGINE


@dataclass(frozen=True)
class Waveforms:
    """Node voltages of one transient (V).

    Attributes
    ----------
    time : numpy.ndarray
        Times (s).
    sensor : numpy.ndarray
        Sensor output, the network's creeping input (its open-circuit voltage).
    output : numpy.ndarray
        The network's output.
    instantaneous : numpy.ndarray or None
        Creep-free sensor signal ``S_ins``, when known (synthetic creep).
    """

    time: np.ndarray
    sensor: np.ndarray
    output: np.ndarray
    instantaneous: np.ndarray | None = None


def _interpolate(t_src, y_src, t_dst, edges) -> np.ndarray:
    """Cubic-spline interpolation within each smooth segment between ``edges``."""
    out = np.empty(len(t_dst))
    scale = max(float(t_src[-1]), 1.0)
    for a, b in zip(edges[:-1], edges[1:]):
        src = (t_src >= a - 1e-12 * scale) & (t_src <= b + 1e-12 * scale)
        dst = (t_dst >= a) & (t_dst <= b)
        if not dst.any():
            continue
        ts, ys = t_src[src], y_src[src]
        if len(ts) >= 4:
            from scipy.interpolate import CubicSpline

            out[dst] = CubicSpline(ts, ys)(t_dst[dst])
        else:
            out[dst] = np.interp(t_dst[dst], ts, ys)
    return out


def run_transient(network: Network, model: CreepModel, program: LoadProgram, times,
                  signal: float = DEFAULT_SIGNAL, engine: Ngspice | None = None,
                  points: int | None = None) -> Waveforms:
    """ngspice's transient of a design driven by synthetic creep, at the given times.

    ngspice steps at most :data:`MAX_STEP_FRACTION` of the output spacing and lands on the
    program's breakpoints; its result is interpolated onto ``times`` with cubic splines
    within each segment between breakpoints (where the solution is smooth).

    Parameters
    ----------
    network, model, program
        The design and its drive.
    times : array_like
        Increasing times in ``[0, duration]`` (s), e.g. from :func:`transient_times`.
    signal : float
        Instantaneous signal at full scale (V).
    engine : Ngspice, optional
        Default: :func:`ngspice`.
    points : int, optional
        Sets ngspice's step limit (``duration / points``); default ``len(times)``.

    Returns
    -------
    Waveforms
        In volts, at ``times``.
    """
    t = checked_times(times)
    duration = float(t[-1])
    points = points or max(len(t) - 1, 10)
    deck = program_deck(network, model, program, duration, points, signal)
    as_simulated = spice_program(program, model, network, largest_step(duration, points))
    return waveforms_from_run((engine or ngspice()).run(deck), deck, t,
                              program_breakpoints(as_simulated, duration))


def waveforms_from_run(run: SpiceRun, deck: Deck, times, edges) -> Waveforms:
    """A run's node voltages interpolated onto ``times`` (smooth between ``edges``)."""
    t = np.asarray(times, float)
    v = {role: run.vectors[node] for role, node in deck.nodes.items()}
    return Waveforms(t, _interpolate(run.time, v["sensor"], t, edges),
                     _interpolate(run.time, v["output"], t, edges),
                     _interpolate(run.time, v["instantaneous"], t, edges)
                     if "instantaneous" in v else None)


def time_transient(network: Network, model: CreepModel, repeats: int = 21,
                   engine: Ngspice | None = None) -> tuple[float, int]:
    """Median time of one ngspice transient of a design (a load step over its default
    duration; load the netlist, run, read back), and ngspice's number of time points.

    The yardstick the Monte Carlo engine is measured against.
    """
    engine = engine or ngspice()
    program = synthetic_program(model, "step", network)
    deck = program_deck(network, model, program, default_duration(program, model, network))
    engine.run(deck)                                      # warm-up
    runs = [engine.run(deck) for _ in range(repeats)]
    return statistics.median(r.seconds for r in runs), len(runs[0].time)


def run_batch(networks, model: CreepModel, program: LoadProgram, times,
              signal: float = DEFAULT_SIGNAL, engine: Ngspice | None = None) -> list[Waveforms]:
    """ngspice transients of many networks (e.g. Monte Carlo samples) through one engine.

    Returns
    -------
    list of Waveforms
        One per network, at ``times``.
    """
    engine = engine or ngspice()
    return [run_transient(net, model, program, times, signal, engine) for net in networks]
