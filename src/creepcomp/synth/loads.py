"""Random load programs and sample times of synthetic records."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from creepcomp.errors import InputError
from creepcomp.programs import LoadProgram

__all__ = ["PROGRAMS", "ALL_PROGRAMS", "make_program", "sample_times"]

#: Kinds of load program :func:`make_program` draws for any effect.
PROGRAMS = ("step", "staircase", "sweep", "mixture", "random")
#: Every kind :func:`make_program` makes: also cycles to rising levels (first-cycle effects),
#: and ``bipolar`` programs that cross zero (a sensor loaded either way, such as an
#: accelerometer over +-1 g).
ALL_PROGRAMS = PROGRAMS + ("cycles", "bipolar")


def make_program(kind: str, duration: float, rng: np.random.Generator, full_scale: float = 1.0,
                 start_loaded: bool = False, tau: float = 45.0, start: float = 0.0,
                 unload: bool = False, one_sided: bool = False) -> LoadProgram:
    """A random load program of a kind: ``step``, ``staircase``, ``sweep``, ``mixture``,
    ``random``, ``cycles`` (to rising levels, each with a partial reload) or ``bipolar``
    (steps to levels of alternating sign, rising in magnitude, each partly released towards
    zero), spanning ``duration`` from ``start``.

    With ``start_loaded`` the load is already at a level when the program starts (and has been
    for a random time, so creep is part-way), otherwise it starts at zero. ``unload``: a
    ``step`` program always unloads again (otherwise it does so in 60 % of the cases).
    ``one_sided``: sweeps from 0 to full scale (otherwise half of them are -FS ... +FS, under
    which flow and other odd effects average out).
    """
    if kind not in ALL_PROGRAMS:
        raise InputError(f"load program '{kind}': use one of {', '.join(ALL_PROGRAMS)}")
    fs = full_scale
    pre = rng.uniform(0.3, 3.0) * tau if start_loaded else 0.0
    first = rng.uniform(0.4, 1.0) * fs if start_loaded else 0.0
    b = _Breakpoints([start - pre], [first if start_loaded else 0.0], rng, fs, tau, duration, start + duration)
    if start_loaded:
        b.times.insert(0, start - pre)
        b.loads.insert(0, 0.0)
    t = start + rng.uniform(0.03, 0.1) * duration
    if kind == "step":
        _step(b, t, unload)
    elif kind == "staircase":
        _staircase(b, t)
    elif kind == "sweep":
        _sweep(b, t, one_sided)
    elif kind == "cycles":
        _cycles(b, t)
    elif kind == "bipolar":
        _bipolar(b, t)
    else:
        _segments(b, t, mixture=kind == "mixture")
    if b.times[-1] < b.t_end:
        b.hold(b.loads[-1], b.t_end)
    return LoadProgram(tuple(b.times), tuple(b.loads), f"{kind} program")


@dataclass
class _Breakpoints:
    """A load program being drawn: its breakpoints so far and what the draws are scaled to."""

    times: list
    loads: list
    rng: np.random.Generator
    fs: float
    tau: float
    duration: float
    t_end: float

    def hold(self, level, until):
        """Reach ``level`` at ``until`` (a ramp from the last breakpoint)."""
        self.times.append(until)
        self.loads.append(level)

    def jump(self, level, at):
        """Hold the last level until ``at``, then step to ``level``."""
        if self.times[-1] < at:
            self.times.append(at)
            self.loads.append(self.loads[-1])
        self.times.append(at)
        self.loads.append(level)


def _step(b: _Breakpoints, t: float, unload: bool) -> None:
    rng = b.rng
    level = rng.choice([-1, 1]) * rng.uniform(0.5, 1.0) * b.fs
    b.jump(level, t)
    if unload or rng.uniform() < 0.6:
        off = t + rng.uniform(0.4, 0.6) * (b.t_end - t)
        b.hold(level, off)
        b.jump(0.0, off)


def _staircase(b: _Breakpoints, t: float) -> None:
    rng, fs = b.rng, b.fs
    n = int(rng.integers(4, 9))
    up = list(np.sort(rng.uniform(0.15, 1.0, n // 2 + 1)) * fs)
    levels = up + list(rng.uniform(0, 1, n - len(up)) * fs) + [0.0]
    if rng.uniform() < 0.3:
        levels = [-v for v in levels]
    step = (b.t_end - t) / (len(levels) + 0.5)
    for k, level in enumerate(levels):
        if k:
            b.hold(b.loads[-1], t + k * step)
        b.jump(level, t + k * step)


def _sweep(b: _Breakpoints, t: float, one_sided: bool) -> None:
    rng, fs = b.rng, b.fs
    period = rng.uniform(0.5, 6.0) * b.tau
    low = -fs if rng.uniform() < 0.5 and not one_sided else 0.0
    tt = t
    b.hold(b.loads[-1], tt)
    phase_up = True
    while tt < b.t_end:
        tt = min(tt + period / 2, b.t_end)
        b.hold(fs if phase_up else low, tt)
        phase_up = not phase_up


def _segments(b: _Breakpoints, t: float, mixture: bool) -> None:
    """Random segments (steps and ramps; with ``mixture`` also sweeps and holds)."""
    rng, fs, t_end = b.rng, b.fs, b.t_end
    while t < t_end:
        seg = rng.choice(["step", "ramp", "sweep", "hold"] if mixture else ["step", "ramp"])
        length = rng.uniform(0.05, 0.25) * b.duration
        level = rng.uniform(-0.3, 1.0) * fs
        if seg == "step":
            b.jump(level, t)
            b.hold(level, min(t + length, t_end))
        elif seg == "ramp":
            b.hold(level, min(t + rng.uniform(0.2, 1.0) * length, t_end))
            b.hold(level, min(t + length, t_end))
        elif seg == "sweep":
            period = rng.uniform(0.3, 3.0) * b.tau
            tt, k = t, 0
            while tt < min(t + length, t_end):
                tt = min(tt + period / 2, t_end)
                b.hold(fs * (0.9 if k % 2 == 0 else -0.2), tt)
                k += 1
        else:
            b.hold(b.loads[-1], min(t + length, t_end))
        t = b.times[-1] if b.times[-1] > t else t + length


def _cycles(b: _Breakpoints, t: float) -> None:
    """Load cycles to ever higher levels, each with a partial reload (first-cycle effects)."""
    rng, fs = b.rng, b.fs
    n = int(rng.integers(3, 6))
    peaks = np.sort(rng.uniform(0.25, 1.0, n)) * fs * (1 if rng.uniform() < 0.7 else -1)
    peaks[-1] = np.sign(peaks[-1]) * fs * rng.uniform(0.85, 1.0)
    step = (b.t_end - t) / (4 * n + 0.5)
    k = 0
    for peak in peaks:
        for level in (peak, 0.0, peak * rng.uniform(0.4, 0.8), 0.0):
            if k:
                b.hold(b.loads[-1], t + k * step)
            b.jump(float(level), t + k * step)
            k += 1


def _bipolar(b: _Breakpoints, t: float) -> None:
    """Steps to levels of alternating sign and rising magnitude, each followed by a partial
    release towards zero and, in half the cycles, a step straight across zero to the other
    side: the load's magnitude falls towards zero and rises again from either side."""
    rng, fs = b.rng, b.fs
    n = int(rng.integers(3, 6))
    peaks = np.sort(rng.uniform(0.3, 1.0, n)) * fs
    peaks[-1] = fs * rng.uniform(0.85, 1.0)
    sign = rng.choice([-1.0, 1.0])
    levels = []
    for k, peak in enumerate(peaks):
        side = sign * (-1) ** k
        levels += [side * peak, side * peak * rng.uniform(0.1, 0.5)]
        if rng.uniform() < 0.5:
            levels.append(-side * peak * rng.uniform(0.3, 0.8))
    levels.append(0.0)
    step = (b.t_end - t) / (len(levels) + 0.5)
    for k, level in enumerate(levels):
        if k:
            b.hold(b.loads[-1], t + k * step)
        b.jump(float(level), t + k * step)


def sample_times(duration: float, rate: float, rng: np.random.Generator, jitter: float = 0.0,
                 gaps: int = 0, start: float = 0.0) -> np.ndarray:
    """Sample times at ``rate`` Hz, jittered by ``jitter`` (fraction of a step), with ``gaps``
    random missing stretches."""
    dt = 1.0 / rate
    n = int(duration * rate) + 1
    t = start + np.arange(n) * dt
    if jitter > 0:
        t = t + rng.uniform(-jitter, jitter, n) * dt
        t[0], t[-1] = start, start + (n - 1) * dt
        t = np.sort(t)
        t = t[np.concatenate([[True], np.diff(t) > 1e-6 * dt])]
    keep = np.ones(len(t), bool)
    for _ in range(gaps):
        length = rng.uniform(0.005, 0.02) * duration
        at = rng.uniform(0.2, 0.9) * duration + start
        keep &= ~((t > at) & (t < at + length))
    return t[keep]
