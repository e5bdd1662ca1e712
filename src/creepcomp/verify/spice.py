"""ngspice netlists of a design driven by synthetic or measured creep, and their runs.

The netlist holds the whole experiment, not just the network:

* synthetic creep: the load program is a PWL source (normalised to full scale 1); a VCVS
  turns it into the sensor's instantaneous signal ``S_ins`` (``signal`` volts at full
  scale); each Prony term is an RC lag of ``S_ins`` (``R C = tau_k``); a B source sums
  ``S_ins + sum beta_k lag_k``, the creeping sensor output, which drives the network
  through the sensor's source resistance. The netlist stays small whatever the duration,
  and ngspice simulates the creep itself.
* a measured record: its ``signal`` column drives the network through an XSPICE
  ``filesource`` that reads a two-column text file next to the netlist (linear
  interpolation between samples), so a long record never becomes inline PWL text.

Runs go through PySpice's shared ngspice: one library instance per process (PySpice keeps
it as a singleton), loaded on first use and reset between runs. The python-control
reference simulates the same ``H(s) G(s)`` cascade on the same time points; the two are
compared as a fraction of full scale (the step, for a step program).
"""

from __future__ import annotations

import contextlib
import ctypes.util
import logging
import math
import statistics
import os
import tempfile
import threading
import time as _time
from dataclasses import dataclass, field, replace
from pathlib import Path

import control
import numpy as np
from scipy.interpolate import CubicSpline

from creepcomp import programs as _programs
from creepcomp.errors import CreepcompError, InputError
from creepcomp.lti import is_uniform
from creepcomp.model import CreepModel
from creepcomp.network import Network
from creepcomp.programs import LoadProgram
from creepcomp.analog.quality import corrected_system, default_sweep_period
from creepcomp.units import format_quantity

#: Full-scale instantaneous signal of the synthetic sensor (V): a bridge sensor's output.
DEFAULT_SIGNAL = 100e-6
#: Time points of a synthetic transient (uniform within each segment of the load program).
DEFAULT_POINTS = 2000
#: ngspice's largest time step, as a fraction of the output spacing.
MAX_STEP_FRACTION = 0.5
#: ngspice's largest time step while a record drives the netlist, as a fraction of the
#: median sample interval (ngspice does not step on the samples: the finer, the closer).
RECORD_MAX_STEP_FRACTION = 0.5
#: A load step becomes a ramp about this long (the power of ten below), relative to the
#: fastest time constant of sensor and network (SPICE sources cannot jump; python-control
#: simulates the same ramp).
RISE_FRACTION = 1e-6
#: ngspice's relative tolerance (default 1e-3) and its truncation-error factor (default 7).
RELTOL = 1e-7
TRTOL = 1.0
#: ngspice's voltage tolerance relative to full scale (default VNTOL is an absolute 1 uV,
#: as large as 1 % of a 100 uV sensor signal).
VOLTAGE_TOLERANCE = 1e-9
#: Step holds and step durations, in units of the slowest time constant.
HOLD_TIME_CONSTANTS = 5.0
STEP_TIME_CONSTANTS = 20.0
#: Cycles of the synthetic sweep.
SWEEP_CYCLES = 3
PROGRAMS = ("step", "staircase", "sweep")
INSTALL_HINT = "sudo apt-get install ngspice libngspice0-dev (or: make setup)"

class NgspiceUnavailable(CreepcompError):
    """ngspice's shared library cannot be loaded; the message names the install command."""


class NgspiceError(CreepcompError):
    """ngspice refused a netlist or failed during the analysis."""


# ------------------------------------------------------------------------------------------
# Load programs and time points
# ------------------------------------------------------------------------------------------

def slowest_time_constant(model: CreepModel, network: Network | None = None) -> float:
    """Largest retardation time of the model or time constant of the network (s)."""
    taus = list(model.tau) + (list(network.lag_expansion().taus) if network else [])
    return float(max(taus))


def fastest_time_constant(model: CreepModel, network: Network | None = None) -> float:
    """Smallest retardation time of the model or time constant of the network (s)."""
    taus = list(model.tau) + (list(network.lag_expansion().taus) if network else [])
    return float(min(taus))


def round_up(x: float, digits: int = 2) -> float:
    """``x`` rounded up to ``digits`` significant digits (durations that read well and do
    not move with the last bits of an eigenvalue)."""
    scale = 10.0 ** (math.floor(math.log10(x)) - digits + 1)
    return float(round(math.ceil(x / scale - 1e-9) * scale, 12))


def synthetic_program(model: CreepModel, name: str = "step",
                      network: Network | None = None) -> LoadProgram:
    """A named test program sized to the sensor's time scales.

    Parameters
    ----------
    model : CreepModel
    name : {"step", "staircase", "sweep"}
        A load step; the paper's staircase of loading and unloading steps (its fig. 2),
        each held ``5 tau_max``; three cycles of the triangular sweep between -FS and +FS
        (its fig. 6) at the period of largest hysteresis, ``2 pi tau``.
    network : Network, optional
        Its time constants count towards the slowest one.

    Returns
    -------
    LoadProgram
    """
    slow = slowest_time_constant(model, network)
    if name == "step":
        return _programs.step(1.0, at=0.0, name="load step")
    if name == "staircase":
        return _programs.staircase((1.0, 2.0, 3.0, 2.0, 1.0, 0.0),
                                   hold=round_up(HOLD_TIME_CONSTANTS * slow),
                                   name="staircase of loading and unloading steps")
    if name == "sweep":
        period = default_sweep_period(model)
        return _programs.triangle_sweep(period, SWEEP_CYCLES, 1.0,
                                        name=f"triangular sweep ±FS, period {period:.4g} s")
    raise InputError(f"program '{name}': choose one of {', '.join(PROGRAMS)}")


def default_duration(program: LoadProgram, model: CreepModel,
                     network: Network | None = None) -> float:
    """How long to simulate: the program's end, or ``20 tau_max`` after it when the
    program ends in a step (so the creep after the step settles)."""
    ends_in_step = len(program.times) >= 2 and program.times[-1] == program.times[-2]
    settle = round_up(STEP_TIME_CONSTANTS * slowest_time_constant(model, network)) if ends_in_step else 0.0
    return float(program.end + settle)


def ramped(program: LoadProgram, rise: float) -> LoadProgram:
    """The program with each step turned into a ramp of duration ``rise`` (for SPICE).

    Raises
    ------
    InputError
        When ``rise`` does not fit between the program's breakpoints.
    """
    t = list(program.times)
    gaps = [b - a for a, b in zip(t, t[1:]) if b > a]
    if gaps and rise >= 0.5 * min(gaps):
        raise InputError(f"a ramp of {rise:g} s does not fit between breakpoints {min(gaps):g} s apart")
    out = list(t)
    for i in range(1, len(t)):
        if t[i] == t[i - 1]:
            out[i] = t[i] + rise
    return LoadProgram(tuple(out), program.loads, program.name)


def program_breakpoints(program: LoadProgram, duration: float) -> np.ndarray:
    """Times in ``[0, duration]`` where the program's slope changes, with both ends."""
    bt = np.array(program.times)
    inner = bt[(bt > 0) & (bt < duration)]
    return np.unique(np.concatenate([[0.0], inner, [duration]]))


def transient_times(program: LoadProgram, duration: float, points: int = DEFAULT_POINTS) -> np.ndarray:
    """Output times: uniform within each segment between breakpoints, at most
    ``duration / points`` apart, breakpoints included.

    This is the grid on which python-control's ``forced_response`` (uniform steps, input
    linear between samples) is exact for a piecewise-linear program.
    """
    if not duration > 0 or not math.isfinite(duration):
        raise InputError(f"duration = {duration!r}: must be positive")
    if points < 10:
        raise InputError(f"points = {points}: use at least 10")
    spacing = duration / points
    edges = program_breakpoints(program, duration)
    parts = [np.array([0.0])]
    for a, b in zip(edges[:-1], edges[1:]):
        n = max(1, int(math.ceil((b - a) / spacing - 1e-9)))
        parts.append(np.linspace(a, b, n + 1)[1:])
    return np.concatenate(parts)


# ------------------------------------------------------------------------------------------
# Netlists
# ------------------------------------------------------------------------------------------

def ascii_text(text: str) -> str:
    """Netlist-safe text: the few non-ASCII symbols the project prints, spelled out."""
    for a, b in (("µ", "u"), ("μ", "u"), ("Ω", "ohm"), ("±", "+/-"), ("−", "-")):
        text = text.replace(a, b)
    return text.encode("ascii", "replace").decode()


def spice_number(x: float) -> str:
    """A number for a netlist: 12 significant digits (stable across platforms)."""
    return f"{float(x):.12g}"


@dataclass(frozen=True)
class Deck:
    """An ngspice input deck: circuit, options, transient analysis, and what a standalone
    run (``ngspice -b FILE.cir``) prints.

    Attributes
    ----------
    title : str
        First line.
    circuit : str
        Element, model and comment lines (built with PySpice).
    options : tuple of (str, str)
        ``.options`` values.
    tran : (float, float, float)
        ``TSTEP``, ``TSTOP``, ``TMAX`` (s).
    control : tuple of str
        Lines of the ``.control`` block of a standalone run (after ``run``).
    data_file : str or None
        The file a ``filesource`` reads, as named in the netlist.
    nodes : dict
        Role (``load``, ``instantaneous``, ``sensor``, ``output``) -> node name.
    """

    title: str
    circuit: str
    options: tuple[tuple[str, str], ...]
    tran: tuple[float, float, float]
    control: tuple[str, ...] = ()
    data_file: str | None = None
    nodes: dict = field(default_factory=dict)

    def text(self, standalone: bool = True) -> str:
        """The netlist; ``standalone`` adds the ``.control`` block for ``ngspice -b``."""
        lines = [ascii_text(self.title), self.circuit.rstrip("\n")]
        lines.append(".options " + " ".join(f"{k}={v}" for k, v in self.options))
        tstep, tstop, tmax = self.tran
        lines.append(f".tran {spice_number(tstep)} {spice_number(tstop)} 0 {spice_number(tmax)}")
        if standalone:
            lines += [".control", "run", *self.control, "quit", ".endc"]
        lines.append(".end")
        return "\n".join(lines) + "\n"

    def with_data_file(self, path: str) -> "Deck":
        """The same deck reading its ``filesource`` data from ``path``."""
        if self.data_file is None:
            return self
        old = f'file="{self.data_file}"'
        return replace(self, circuit=self.circuit.replace(old, f'file="{path}"'), data_file=path)


class _Lines:
    """Netlist text built from PySpice elements, in order, with comments between them."""

    def __init__(self, title: str):
        from PySpice.Spice.Netlist import Circuit

        self.circuit = Circuit(title)
        self.lines: list[str] = []

    def comment(self, text: str) -> None:
        self.lines.append(f"* {ascii_text(text)}")

    def add(self, kind: str, name: str, *args, **kwargs) -> None:
        element = getattr(self.circuit, kind)(name, *args, **kwargs)
        self.lines.append(str(element))

    def model(self, name: str, kind: str, **parameters) -> None:
        self.lines.append(str(self.circuit.model(name, kind, **parameters)))

    def text(self) -> str:
        return "\n".join(self.lines) + "\n"


def _network_lines(out: _Lines, network: Network, input_node: str) -> None:
    """The correction network between ``input_node`` and ``out`` (ground ``0``)."""
    n = spice_number
    many = len(network.cells) > 1
    out.comment("correction network: series cells R1 || C1 from the sensor to the output")
    node = input_node
    for k, cell in enumerate(network.cells, 1):
        suffix = f"_{k}" if many else ""
        nxt = "out" if k == len(network.cells) else f"n{k}"
        out.add("R", f"1{suffix}", node, nxt, n(cell.R))
        if cell.C > 0:
            out.add("C", f"1{suffix}", node, nxt, n(cell.C))
        if cell.leakage is not None:
            out.comment(f"leakage of C1{suffix}")
            out.add("R", f"leak{suffix or '_1'}", node, nxt, n(cell.leakage))
        if cell.has_absorption:
            out.comment(f"dielectric absorption of C1{suffix}: a series R-C across it")
            mid = f"da{k}"
            out.add("R", f"da{suffix or '_1'}", node, mid, n(cell.absorption_R))
            out.add("C", f"da{suffix or '_1'}", mid, nxt, n(cell.absorption_C))
        node = nxt
    if network.R2 is not None:
        out.comment("R2 from the output to ground")
        out.add("R", "2", "out", "0", n(network.R2))
    for j, branch in enumerate(network.shunt, 1):
        suffix = f"_{j}" if len(network.shunt) > 1 else ""
        if j == 1:
            out.comment("lag network: series R-C branches from the output to ground")
        out.add("R", f"3{suffix}", "out", f"s{j}", n(branch.R))
        out.add("C", f"3{suffix}", f"s{j}", "0", n(branch.C))
    if network.load_resistance is not None:
        out.comment("input resistance of the next stage")
        out.add("R", "L", "out", "0", n(network.load_resistance))


def _source_resistance_lines(out: _Lines, network: Network, emf_node: str) -> str:
    """The sensor's source resistance; returns the node that drives the network."""
    if network.source_resistance > 0:
        out.comment("the sensor's source resistance")
        out.add("R", "s", emf_node, "sensor", spice_number(network.source_resistance))
        return "sensor"
    return emf_node


def _options(full_scale: float, network: Network) -> tuple[tuple[str, str], ...]:
    """Tolerances scaled to the signal level and the network: VNTOL a fraction
    :data:`VOLTAGE_TOLERANCE` of full scale, ABSTOL the current it drives through the
    smallest resistor, CHGTOL the charge it puts on the largest capacitor."""
    vntol = VOLTAGE_TOLERANCE * full_scale
    resistors = [v for _, kind, v in network.parts() if kind == "R"]
    resistors += [network.source_resistance or math.inf]
    capacitors = [v for _, kind, v in network.parts() if kind == "C"] or [1e-12]
    return (("reltol", spice_number(RELTOL)), ("trtol", spice_number(TRTOL)),
            ("vntol", spice_number(vntol)), ("abstol", spice_number(vntol / min(resistors))),
            ("chgtol", spice_number(vntol * max(capacitors))))


def program_deck(network: Network, model: CreepModel, program: LoadProgram, duration: float,
                 points: int = DEFAULT_POINTS, signal: float = DEFAULT_SIGNAL,
                 title: str = "creepcomp: correction network driven by a creeping sensor") -> Deck:
    """The netlist of a design driven by synthetic creep.

    Parameters
    ----------
    network : Network
    model : CreepModel
        The sensor's creep (its ``gain`` and ``offset`` are not used: the drive is set by
        ``signal``).
    program : LoadProgram
        Load history; it is normalised to full scale 1 (the largest ``|load|``) and its
        steps become ramps of :data:`RISE_FRACTION` of the fastest time constant.
    duration : float
        Simulated time (s).
    points : int
        Output spacing is ``duration / points``; ngspice's largest step is
        :data:`MAX_STEP_FRACTION` of it.
    signal : float
        Instantaneous sensor signal at full scale (V).
    title : str
        The netlist's title line.

    Returns
    -------
    Deck
    """
    if not signal > 0 or not math.isfinite(signal):
        raise InputError(f"signal = {signal!r}: must be a positive voltage")
    spice_prog = spice_program(program, model, network)
    n = spice_number
    out = _Lines(title)
    out.comment(f"load program: {program.name}, normalised to full scale 1"
                + ("; steps as ramps of " + format_quantity(_rise(model, network), "s")
                   if len(set(program.times)) < len(program.times) else ""))
    pwl = list(zip(spice_prog.times, spice_prog.loads))
    out.add("PieceWiseLinearVoltageSource", "load", "load", "0", values=pwl)
    out.comment(f"instantaneous (creep-free) sensor signal: {format_quantity(signal, 'V')} at full scale")
    out.add("VCVS", "ins", "ins", "0", "load", "0", n(signal))
    terms = []
    for k, (beta, tau) in enumerate(zip(model.beta, model.tau), 1):
        out.comment(f"creep term {k}: beta = {beta:.6g}, tau = {tau:.6g} s: a lag of the "
                    "instantaneous signal (R = 1 ohm, C = tau)")
        out.add("R", f"creep{k}", "ins", f"creep{k}", "1")
        out.add("C", f"creep{k}", f"creep{k}", "0", n(tau))
        terms.append(f"{'-' if beta < 0 else '+'} {n(abs(beta))}*V(creep{k})")
    out.comment("creeping sensor output: S_ins + sum beta_k lag_k")
    out.add("B", "sensor", "emf", "0", v="V(ins) " + " ".join(terms))
    node = _source_resistance_lines(out, network, "emf")
    _network_lines(out, network, node)
    spacing = duration / points
    hf = network.lag_expansion().direct
    control_lines = (
        f"* residual creep: (v(out) - H(inf) S_ins) / (H(inf) full scale); H(inf) = {hf:.12g} "
        "(capacitors shorted)",
        f"let hinf = {hf:.12g}",
        f"let full_scale = {n(signal)}",
        "let residual = (v(out) - hinf * v(ins)) / (hinf * full_scale)",
        "let residual_abs = abs(residual)",
        "meas tran residual_creep_peak max residual_abs",
        f"meas tran residual_creep_final find residual at={n(duration)}",
        "let uncorrected = (v(emf) - v(ins)) / full_scale",
        f"meas tran uncorrected_creep_final find uncorrected at={n(duration)}",
    )
    return Deck(title, out.text(), _options(signal, network),
                (spacing, duration, spacing * MAX_STEP_FRACTION), control_lines, None,
                {"load": "load", "instantaneous": "ins", "sensor": "emf", "output": "out"})


def _record_arrays(time, signal, name: str):
    t = np.asarray(time, float)
    v = np.asarray(signal, float)
    if t.ndim != 1 or t.shape != v.shape or len(t) < 2 or np.any(np.diff(t) <= 0):
        raise InputError(f"{name}: time and signal must be equal-length, time strictly increasing")
    if not np.all(np.isfinite(v)):
        raise InputError(f"{name}: the signal has values that are not finite")
    if np.ptp(v) == 0:
        raise InputError(f"{name}: the signal is constant: nothing to simulate")
    return t - t[0], v


def record_deck(network: Network, time, signal, data_file: str = "record-signal.txt",
                title: str = "creepcomp: correction network driven by a measured record",
                name: str = "record") -> Deck:
    """The netlist of a design driven by a measured signal read from ``data_file``.

    The file (see :func:`record_data`) holds two columns, time from 0 (s) and signal (V),
    read by an XSPICE ``filesource`` (linear between samples). ngspice steps at most
    :data:`RECORD_MAX_STEP_FRACTION` of the median sample interval.
    """
    rel, v = _record_arrays(time, signal, name)
    duration = float(rel[-1])
    interval = float(np.median(np.diff(rel)))
    n = spice_number
    out = _Lines(title)
    out.comment(f"measured sensor signal, read from {data_file} (time and volts, "
                "linear between samples)")
    out.add("A", "record", "%vd([emf 0])", model="record_signal")
    out.model("record_signal", "filesource", file=f'"{data_file}"', amploffset="[0]",
              amplscale="[1]", timeoffset=0, timescale=1, timerelative="false", amplstep="false")
    node = _source_resistance_lines(out, network, "emf")
    _network_lines(out, network, node)
    control_lines = (
        "meas tran output_min min v(out)",
        "meas tran output_max max v(out)",
        f"meas tran output_final find v(out) at={n(duration)}",
    )
    return Deck(title, out.text(), _options(float(np.ptp(v)), network),
                (interval, duration, interval * RECORD_MAX_STEP_FRACTION),
                control_lines, data_file, {"sensor": "emf", "output": "out"})


def record_data(time, signal) -> str:
    """Text of a ``filesource`` file: time from 0 (s) and signal, full precision, and one
    more line an interval after the last sample holding its value: the netlist's stop time
    (12 digits) can lie a rounding past the last sample, where a filesource with no next
    line gives 0 V over the whole last interval."""
    t = np.asarray(time, float) - float(time[0])
    v = np.asarray(signal, float)
    rows = np.column_stack([np.append(t, 2.0 * t[-1] - t[-2]), np.append(v, v[-1])])
    import io

    buf = io.StringIO()
    np.savetxt(buf, rows, fmt="%.17g")
    return buf.getvalue()


def _rise(model: CreepModel, network: Network) -> float:
    """Ramp time of a step: a power of ten near ``RISE_FRACTION`` of the fastest time constant."""
    return 10.0 ** math.floor(math.log10(RISE_FRACTION * fastest_time_constant(model, network)))


def spice_program(program: LoadProgram, model: CreepModel, network: Network) -> LoadProgram:
    """The program as both simulators see it: normalised to full scale 1 (the largest
    ``|load|``), steps as ramps of :data:`RISE_FRACTION` of the fastest time constant, and
    every number rounded as the netlist prints it (so python-control sees the same input).
    """
    if program.start < 0:
        raise InputError(f"the load program starts at {program.start:g} s: SPICE time starts at 0")
    full = max(abs(x) for x in program.loads)
    if full == 0:
        raise InputError("the load program is zero throughout: nothing to simulate")
    ramp = ramped(program, _rise(model, network))
    return LoadProgram(tuple(_rounded(t) for t in ramp.times),
                       tuple(_rounded(u / full) for u in ramp.loads), program.name)


def _rounded(x: float) -> float:
    return float(spice_number(x))


def write_deck(path: str | Path, deck: Deck, data: str | None = None) -> Path:
    """Write a standalone netlist (and the data file its ``filesource`` reads, beside it)."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text(deck.text(standalone=True), encoding="utf-8")
    if deck.data_file is not None:
        if data is None:
            raise InputError("a record netlist needs its data")
        (p.parent / deck.data_file).write_text(data, encoding="utf-8")
    return p


# ------------------------------------------------------------------------------------------
# The shared ngspice
# ------------------------------------------------------------------------------------------

#: ngspice messages on stderr that are notes, not errors.
HARMLESS = ("note:", "warning", "using sparse", "reducing trtol", "no compatibility mode")


class _QuietPySpice(logging.Filter):
    """Drop PySpice's version warning, and its echo of ngspice's output during our runs
    (we read that output ourselves and raise on real errors)."""

    def __init__(self):
        super().__init__()
        self.running = False

    def filter(self, record: logging.LogRecord) -> bool:
        if "Unsupported Ngspice version" in record.getMessage():
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
        with self._lock, _running():
            start = _time.perf_counter()
            notes: list[str] = []
            try:
                shared.destroy()
                try:
                    shared.load_circuit(text)
                except NgSpiceCircuitError:
                    pass                     # ngspice's own lines say why, just below
                notes += _check(shared.stdout, shared.stderr, "loading the netlist")
                try:
                    shared.run()
                except NgSpiceCommandError:
                    pass
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
    from PySpice.Spice.NgSpice.Shared import NgSpiceShared

    _quiet_pyspice()
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


# ------------------------------------------------------------------------------------------
# Transients: ngspice and python-control on the same time points
# ------------------------------------------------------------------------------------------

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
    t = _check_times(times)
    duration = float(t[-1])
    deck = program_deck(network, model, program, duration, points or max(len(t) - 1, 10), signal)
    return waveforms_from_run((engine or ngspice()).run(deck), deck, t,
                              program_breakpoints(spice_program(program, model, network), duration))


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


def _check_times(times) -> np.ndarray:
    t = np.asarray(times, dtype=float)
    if t.ndim != 1 or len(t) < 2 or np.any(np.diff(t) <= 0) or t[0] < 0:
        raise InputError("times must be a strictly increasing array from t >= 0")
    return t


def _settled(sys: control.StateSpace, u0: float) -> np.ndarray:
    A, B = np.asarray(sys.A), np.asarray(sys.B)[:, 0]
    return np.linalg.solve(A, -B * u0) if u0 else np.zeros(A.shape[0])


def _piecewise_response(sys: control.StateSpace, t, u, edges) -> np.ndarray:
    """python-control ``forced_response`` segment by segment (uniform steps within each)."""
    y = np.empty(len(t))
    x = _settled(sys, u[0])
    y[0] = (np.asarray(sys.C) @ x + np.asarray(sys.D)[:, 0] * u[0])[0]
    for a, b in zip(edges[:-1], edges[1:]):
        idx = np.flatnonzero((t >= a) & (t <= b))
        if len(idx) < 2:
            continue
        seg = t[idx]
        if not is_uniform(seg):
            raise InputError(f"times between {a:g} and {b:g} s are not uniform: python-control "
                             "needs uniform steps (use transient_times)")
        r = control.forced_response(sys, seg - seg[0], u[idx], X0=x, return_states=True)
        y[idx] = np.atleast_1d(r.outputs)
        x = np.atleast_2d(r.states)[:, -1]
    return y


def reference_transient(network: Network, model: CreepModel, program: LoadProgram, times,
                        signal: float = DEFAULT_SIGNAL) -> Waveforms:
    """python-control's transient of the same experiment, on the same time points.

    ``G(s)`` (the sensor) and ``H(s) G(s)`` (the corrected output) are simulated with
    ``control.forced_response`` on each segment of ``times`` between the program's
    breakpoints (uniform steps; the input is linear in between, so the result is exact).
    """
    t = _check_times(times)
    prog = spice_program(program, model, network)
    edges = program_breakpoints(prog, float(t[-1]))
    missing = [e for e in edges if not np.any(np.isclose(t, e, rtol=0, atol=1e-9 * t[-1]))]
    if missing:
        raise InputError(f"times must include the program's breakpoints (missing {missing[0]:g} s); "
                         "use transient_times")
    u = prog.sample(t)
    sensor = _piecewise_response(model.state_space(), t, u, edges)
    output = _piecewise_response(corrected_system(model, network), t, u, edges)
    return Waveforms(t, signal * sensor, signal * output, signal * u)


@dataclass(frozen=True)
class Comparison:
    """One design simulated by python-control and by ngspice on the same time points.

    Attributes
    ----------
    drive : str
        What drives the network (program name, or the record).
    full_scale : float
        Full-scale sensor signal (V): the step of a step program; the range of a record.
    hf_gain : float
        ``H(inf)``: the network's gain with its capacitors shorted.
    reference : Waveforms
        python-control (or, for an irregular record, the exact lag discretisation of H).
    spice : Waveforms or None
        ngspice on the same time points; None when ngspice is unavailable.
    reference_method : str
        How the reference was computed.
    ngspice_seconds : float or None
        Wall time of the ngspice run (load, transient, read back).
    ngspice_version : int or None
    ngspice_points : int or None
        ngspice's own time points.
    unavailable : str or None
        Why ngspice did not run.
    deck : Deck
        The netlist that ran (or would have run).
    """

    drive: str
    full_scale: float
    hf_gain: float
    reference: Waveforms
    spice: Waveforms | None
    reference_method: str
    ngspice_seconds: float | None
    ngspice_version: int | None
    ngspice_points: int | None
    unavailable: str | None
    deck: Deck

    def residual(self, which: str = "spice") -> np.ndarray | None:
        """Residual creep ``(y - H(inf) S_ins) / (H(inf) FS)`` (None without ``S_ins``)."""
        w = self.spice if which == "spice" else self.reference
        if w is None or self.reference.instantaneous is None:
            return None
        return (w.output - self.hf_gain * self.reference.instantaneous) / (self.hf_gain * self.full_scale)

    def uncorrected_residual(self) -> np.ndarray | None:
        """The sensor's own creep ``(S_raw - S_ins) / FS`` (python-control)."""
        if self.reference.instantaneous is None:
            return None
        return (self.reference.sensor - self.reference.instantaneous) / self.full_scale

    @property
    def agreement_output(self) -> float | None:
        """Largest ``|ngspice - python-control|`` of the output, fraction of ``H(inf) FS``."""
        if self.spice is None:
            return None
        return float(np.max(np.abs(self.spice.output - self.reference.output))
                     / (self.hf_gain * self.full_scale))

    @property
    def agreement_sensor(self) -> float | None:
        """Largest ``|ngspice - python-control|`` of the creeping sensor signal, fraction of FS."""
        if self.spice is None or self.reference.instantaneous is None:
            return None
        return float(np.max(np.abs(self.spice.sensor - self.reference.sensor)) / self.full_scale)

    @property
    def agreement_max_abs(self) -> float | None:
        """The larger of :attr:`agreement_output` and :attr:`agreement_sensor`."""
        values = [v for v in (self.agreement_output, self.agreement_sensor) if v is not None]
        return max(values) if values else None

    def _residual_figures(self, which: str):
        e = self.residual(which)
        if e is None:
            return None, None, None
        k = int(np.argmax(np.abs(e)))
        return float(abs(e[k])), float(self.reference.time[k]), float(e[-1])

    @property
    def residual_creep_peak(self) -> float | None:
        """Largest ``|residual creep|``, from ngspice (python-control when it did not run)."""
        return self._residual_figures("spice" if self.spice is not None else "reference")[0]

    @property
    def residual_creep_final(self) -> float | None:
        """Residual creep at the end, from ngspice (python-control when it did not run)."""
        return self._residual_figures("spice" if self.spice is not None else "reference")[2]

    def to_dict(self) -> dict:
        """JSON form (``simulate --json``): fractions of full scale, seconds, volts."""
        ref = self._residual_figures("reference")
        out = {
            "agreement_max_abs": self.agreement_max_abs,
            "residual_creep_peak": self.residual_creep_peak,
            "residual_creep_final": self.residual_creep_final,
            "drive": self.drive,
            "full_scale_signal": self.full_scale,
            "hf_gain": self.hf_gain,
            "duration": float(self.reference.time[-1]),
            "points": len(self.reference.time),
            "python_control": {"method": self.reference_method, "residual_creep_peak": ref[0],
                               "residual_creep_peak_time": ref[1], "residual_creep_final": ref[2]},
            "ngspice": {"available": self.unavailable is None, "reason": self.unavailable},
            "agreement": {"output_max_abs": self.agreement_output,
                          "sensor_max_abs": self.agreement_sensor},
            "netlist_bytes": len(self.deck.text().encode()),
        }
        if self.spice is not None:
            spice = self._residual_figures("spice")
            out["ngspice"].update({"version": self.ngspice_version, "seconds": self.ngspice_seconds,
                                   "time_points": self.ngspice_points,
                                   "residual_creep_peak": spice[0],
                                   "residual_creep_peak_time": spice[1],
                                   "residual_creep_final": spice[2]})
        return out


def simulate(network: Network, model: CreepModel, program: LoadProgram | str = "step",
             duration: float | None = None, points: int = DEFAULT_POINTS,
             signal: float = DEFAULT_SIGNAL, engine: Ngspice | None = None) -> Comparison:
    """Simulate a design driven by synthetic creep with python-control and with ngspice.

    Parameters
    ----------
    network : Network
    model : CreepModel
    program : LoadProgram or {"step", "staircase", "sweep"}
        The load history (see :func:`synthetic_program`).
    duration : float, optional
        Simulated time (s); default :func:`default_duration`.
    points : int
        Time points (uniform within each segment of the program).
    signal : float
        Instantaneous signal at full scale (V).
    engine : Ngspice, optional
        Default: :func:`ngspice`. When it cannot be loaded, the comparison carries the
        python-control result alone and says why.

    Returns
    -------
    Comparison
    """
    if isinstance(program, str):
        program = synthetic_program(model, program, network)
    if duration is None:
        duration = default_duration(program, model, network)
    as_simulated = spice_program(program, model, network)
    times = transient_times(as_simulated, duration, points)
    reference = reference_transient(network, model, program, times, signal)
    deck = program_deck(network, model, program, duration, points, signal)
    hf = network.lag_expansion().direct
    spice, seconds, version, n_points, unavailable = None, None, None, None, None
    try:
        engine = engine or ngspice()
    except NgspiceUnavailable as exc:
        unavailable = str(exc)
    else:
        run = engine.run(deck)
        spice = waveforms_from_run(run, deck, times, program_breakpoints(as_simulated, duration))
        seconds, version, n_points = run.seconds, engine.version, len(run.time)
    return Comparison(program.name, signal, hf, reference, spice,
                      "python-control forced_response, uniform steps between the program's "
                      "breakpoints (exact for its piecewise-linear input)",
                      seconds, version, n_points, unavailable, deck)


def simulate_record(network: Network, time, signal, engine: Ngspice | None = None,
                    name: str = "measured record") -> Comparison:
    """Drive the network with a measured signal, in ngspice (file source) and in Python.

    ngspice reads the signal from a temporary file; the reference is the network's
    ``H(s)`` (from its state-space model) discretised exactly for a signal linear between
    samples, evaluated at ngspice's own time points, so nothing is interpolated.

    Parameters
    ----------
    network : Network
    time, signal : array_like
        The record's time (s, strictly increasing) and signal (treated as volts).
    engine : Ngspice, optional
    name : str
        Description for reports.

    Returns
    -------
    Comparison
    """
    rel, s = _record_arrays(time, signal, name)
    full = float(np.ptp(s))
    lag = network.lag_expansion()
    hf = lag.direct
    deck = record_deck(network, rel, s, name=name)
    method = ("exact discretisation of H(s) from its state-space model, signal linear "
              "between samples, at ngspice's time points")
    try:
        engine = engine or ngspice()
    except NgspiceUnavailable as exc:
        out = lag.simulate(rel, s, hold="linear", initial="settled")
        return Comparison(name, full, hf, Waveforms(rel, s, out), None, method, None, None, None,
                          str(exc), deck)
    with tempfile.TemporaryDirectory(prefix="creepcomp-") as tmp:
        data = Path(tmp) / deck.data_file
        data.write_text(record_data(rel, s), encoding="utf-8")
        run = engine.run(deck.with_data_file(str(data)))
    # the netlist gives the stop time to 12 digits: its last point may lie a rounding past
    # the last sample, and is the one that holds the last sample's value
    keep = (run.time >= 0) & (run.time <= rel[-1] * (1.0 + 1e-11))
    tk = run.time[keep]
    grid = np.union1d(rel, tk)
    ref = lag.simulate(grid, np.interp(grid, rel, s), hold="linear", initial="settled")
    reference = Waveforms(tk, np.interp(tk, rel, s), ref[np.searchsorted(grid, tk)])
    spice = Waveforms(tk, run.vectors["emf"][keep], run.vectors["out"][keep])
    return Comparison(name, full, hf, reference, spice, method, run.seconds, engine.version,
                      len(run.time), None, deck)


def at_sample_times(points, values, times) -> np.ndarray:
    """An ngspice waveform read at a record's sample times.

    ngspice's own time points do not fall on the samples, where the (linear between
    samples) drive has its kinks: interpolating across a kink would mix both sides. Each
    sample's value is extrapolated from the last two ngspice points at or before it, which
    lie between it and the previous sample when ngspice steps at most half a sample
    interval (:data:`RECORD_MAX_STEP_FRACTION`): the waveform is smooth there.

    Parameters
    ----------
    points, values : array_like
        ngspice's time points (s, increasing) and the waveform there.
    times : array_like
        Sample times on the same clock.

    Returns
    -------
    numpy.ndarray
    """
    tp, yp, ts = (np.asarray(a, float) for a in (points, values, times))
    tol = 1e-9 * max(float(np.max(np.abs(ts))), 1e-300)
    j = np.clip(np.searchsorted(tp, ts + tol, side="right") - 1, 1, len(tp) - 1)
    t1, y1, t0, y0 = tp[j], yp[j], tp[j - 1], yp[j - 1]
    slope = (y1 - y0) / (t1 - t0)
    return np.where(np.abs(t1 - ts) <= tol, y1, y1 + slope * (ts - t1))


# ------------------------------------------------------------------------------------------
# Reference netlists, plots, demo
# ------------------------------------------------------------------------------------------

#: Largest capacitor of the bundled reference designs (F).
REFERENCE_CAPACITANCE = 10e-6


def reference_designs() -> dict:
    """The bundled designs whose netlists live in ``netlists/``, by file stem.

    The default sensor by the paper's rule and exactly, a 3-term Foster chain, and a lag
    network for an overshooting (negative-creep) sensor; all with ideal part values at
    C = 10 uF, so their residual creep is the rule's own.

    Returns
    -------
    dict
        Stem -> (:class:`creepcomp.io.jsonfiles.Design`, description).
    """
    from creepcomp.data import default_sensor
    from creepcomp.io.jsonfiles import Design
    from creepcomp.analog.sizing import ideal_network

    default = default_sensor()
    foster = CreepModel((0.01, 0.01, 0.015), (5.0, 50.0, 500.0))
    negative = CreepModel((-0.02, -0.01), (20.0, 120.0))
    c = REFERENCE_CAPACITANCE
    return {
        "default-paper": (Design(default, ideal_network(default, "paper", c), {"rule": "paper"}),
                          "default sensor (beta0 = 3 %, tau = 45 s), paper's rule, ideal parts"),
        "default-exact": (Design(default, ideal_network(default, "exact", c), {"rule": "exact"}),
                          "default sensor (beta0 = 3 %, tau = 45 s), exact rule, ideal parts"),
        "foster3-exact": (Design(foster, ideal_network(foster, "exact", c), {"rule": "exact"}),
                          "3-term Prony sensor (tau = 5, 50, 500 s), exact Foster chain"),
        "negative-lag": (Design(negative, ideal_network(negative, "exact", c), {"rule": "exact"}),
                         "overshooting sensor (beta = -2 %, -1 %), exact lag network"),
    }


def reference_deck(design, description: str) -> Deck:
    """The netlist of a bundled design: a load step, default drive and time points."""
    program = synthetic_program(design.model, "step", design.network)
    duration = default_duration(program, design.model, design.network)
    return program_deck(design.network, design.model, program, duration,
                        title=f"creepcomp: {description}; load step")


def write_reference_netlists(folder: str | Path = "netlists") -> list[Path]:
    """Write each bundled design (``STEM.json``) and its netlist (``STEM.cir``) into ``folder``.

    The text is deterministic (no dates, no absolute paths): a test regenerates it and
    compares with the committed files.
    """
    from creepcomp.io.jsonfiles import write_design

    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for stem, (design, description) in reference_designs().items():
        written.append(write_design(out / f"{stem}.json", design))
        deck = reference_deck(design, description)
        header = (f"* {ascii_text(description)}\n* written by creepcomp (make netlists); "
                  f"run it with: ngspice -b {stem}.cir\n")
        path = out / f"{stem}.cir"
        text = deck.text()
        first, rest = text.split("\n", 1)
        path.write_text(f"{first}\n{header}{rest}", encoding="utf-8")
        written.append(path)
    return written
