"""The drive of a SPICE experiment: synthetic load programs sized to a design's time scales,
their time points, and the program as both simulators see it.

A SPICE source cannot jump, so each load step becomes a short ramp; the program is then
normalised to full scale 1 and every number rounded as the netlist prints it, so that
ngspice and python-control are driven by exactly the same input.
"""

from __future__ import annotations

import math

import numpy as np

from creepcomp import programs as _programs
from creepcomp.analog.quality import default_sweep_period
from creepcomp.errors import InputError
from creepcomp.model import CreepModel
from creepcomp.network import Network
from creepcomp.programs import LoadProgram

__all__ = [
    "DEFAULT_SIGNAL", "DEFAULT_POINTS", "RISE_FRACTION", "HOLD_TIME_CONSTANTS",
    "STEP_TIME_CONSTANTS", "SWEEP_CYCLES", "PROGRAMS", "MAX_STEP_FRACTION", "RAMP_STEP_FRACTION",
    "largest_step",
    "slowest_time_constant", "fastest_time_constant", "round_up", "synthetic_program",
    "default_duration", "ramped", "program_breakpoints", "transient_times", "checked_times",
    "spice_number", "rise_time", "spice_program",
]

#: Full-scale instantaneous signal of the synthetic sensor (V): a bridge sensor's output.
DEFAULT_SIGNAL = 100e-6
#: Time points of a synthetic transient (uniform within each segment of the load program).
DEFAULT_POINTS = 2000
#: A load step becomes a ramp about this long (the power of ten below), relative to the
#: fastest time constant of sensor and network (SPICE sources cannot jump; python-control
#: simulates the same ramp).
RISE_FRACTION = 1e-6
#: ngspice's largest time step, as a fraction of the output spacing.
MAX_STEP_FRACTION = 0.5
#: A ramp lasts at least this fraction of ngspice's largest time step. ngspice's smallest
#: step is 1e-11 of its largest, and it cuts its step by decades at a ramp's corners: a ramp
#: of 5e-8 of the largest step ended in "Timestep too small" (a network with time constants
#: from 6 s to 20 min, dielectric absorption and leakage, simulated over 4 h), 5e-7 ran.
RAMP_STEP_FRACTION = 1e-6
#: Step holds and step durations, in units of the slowest time constant.
HOLD_TIME_CONSTANTS = 5.0
STEP_TIME_CONSTANTS = 20.0
#: Cycles of the synthetic sweep.
SWEEP_CYCLES = 3
PROGRAMS = ("step", "staircase", "sweep")


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


def checked_times(times) -> np.ndarray:
    """``times`` as an array, checked to increase strictly from ``t >= 0``.

    Raises
    ------
    InputError
        When they do not.
    """
    t = np.asarray(times, dtype=float)
    if t.ndim != 1 or len(t) < 2 or np.any(np.diff(t) <= 0) or t[0] < 0:
        raise InputError("times must be a strictly increasing array from t >= 0")
    return t


def spice_number(x: float) -> str:
    """A number for a netlist: 12 significant digits (stable across platforms)."""
    return f"{float(x):.12g}"


def largest_step(duration: float, points: int) -> float:
    """ngspice's largest time step for ``points`` output points over ``duration`` (s)."""
    return duration / points * MAX_STEP_FRACTION


def rise_time(model: CreepModel, network: Network, max_step: float | None = None) -> float:
    """Ramp time of a step: a power of ten near ``RISE_FRACTION`` of the fastest time constant,
    and at least :data:`RAMP_STEP_FRACTION` of ngspice's largest step ``max_step`` (s)."""
    rise = 10.0 ** math.floor(math.log10(RISE_FRACTION * fastest_time_constant(model, network)))
    if max_step is not None and rise < RAMP_STEP_FRACTION * max_step:
        rise = 10.0 ** math.ceil(math.log10(RAMP_STEP_FRACTION * max_step))
    return rise


def spice_program(program: LoadProgram, model: CreepModel, network: Network,
                  max_step: float | None = None) -> LoadProgram:
    """The program as both simulators see it: normalised to full scale 1 (the largest
    ``|load|``), steps as ramps (:func:`rise_time`; ``max_step`` is ngspice's largest step),
    and every number rounded as the netlist prints it (so python-control sees the same input).
    """
    if program.start < 0:
        raise InputError(f"the load program starts at {program.start:g} s: SPICE time starts at 0")
    full = max(abs(x) for x in program.loads)
    if full == 0:
        raise InputError("the load program is zero throughout: nothing to simulate")
    ramp = ramped(program, rise_time(model, network, max_step))
    return LoadProgram(tuple(_as_printed(t) for t in ramp.times),
                       tuple(_as_printed(u / full) for u in ramp.loads), program.name)


def _as_printed(x: float) -> float:
    return float(spice_number(x))
