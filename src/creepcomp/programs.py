"""Load programs: the load histories the paper tests with, as exact piecewise-linear inputs.

A :class:`LoadProgram` is a list of breakpoints ``(time, load)`` joined by straight lines;
two breakpoints at the same time make a step. The paper's tests are a load step, a staircase
of loading and unloading steps (its fig. 2) and a triangular sweep between -FS and +FS (its
fig. 6). Responses of sums of lags (creep models, networks) to a program are exact at any
sample times, whether or not they fall on the breakpoints.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from creepcomp.errors import InputError
from creepcomp.lti import LagExpansion, lag_states

__all__ = ["LoadProgram", "step", "staircase", "triangle_sweep"]


@dataclass(frozen=True)
class LoadProgram:
    """Piecewise-linear load history.

    Before the first breakpoint the load is ``loads[0]``, held long enough for creep to
    settle; after the last it stays at ``loads[-1]``.

    Parameters
    ----------
    times : tuple of float
        Breakpoint times (s), non-decreasing; a repeated time is a step.
    loads : tuple of float
        Load at each breakpoint.
    name : str
        Short description for plots and reports.
    """

    times: tuple[float, ...]
    loads: tuple[float, ...]
    name: str = "load program"

    def __post_init__(self):
        t = np.asarray(self.times, dtype=float)
        u = np.asarray(self.loads, dtype=float)
        if t.ndim != 1 or t.shape != u.shape or len(t) < 1:
            raise InputError("a load program needs matching, non-empty lists of times and loads")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(u))):
            raise InputError("load program times and loads must be finite")
        if np.any(np.diff(t) < 0):
            raise InputError("load program times must not decrease")
        if np.any((np.diff(t[:-1]) == 0) & (np.diff(t[1:]) == 0)):
            raise InputError("a load program may repeat a time only once (one step per instant)")
        object.__setattr__(self, "times", tuple(float(x) for x in t))
        object.__setattr__(self, "loads", tuple(float(x) for x in u))

    @property
    def start(self) -> float:
        """Time of the first breakpoint (s)."""
        return self.times[0]

    @property
    def end(self) -> float:
        """Time of the last breakpoint (s)."""
        return self.times[-1]

    def sample(self, times) -> np.ndarray:
        """Load at the given times (after a step when a time falls on one)."""
        t = np.asarray(times, dtype=float)
        bt, bu = np.array(self.times), np.array(self.loads)
        # right-continuous: at a step time take the later breakpoint's value
        idx = np.searchsorted(bt, t, side="right") - 1
        idx = np.clip(idx, 0, len(bt) - 1)
        nxt = np.clip(idx + 1, 0, len(bt) - 1)
        span = bt[nxt] - bt[idx]
        frac = np.where(span > 0, (t - bt[idx]) / np.where(span > 0, span, 1.0), 0.0)
        out = bu[idx] + frac * (bu[nxt] - bu[idx])
        return np.where(t < bt[0], bu[0], out)

    def response(self, system: LagExpansion, times) -> np.ndarray:
        """Exact output of a sum of lags driven by this program, at ``times``.

        The system starts settled at ``loads[0]``; breakpoints between sample times are
        taken into account exactly.

        Parameters
        ----------
        system : LagExpansion
            E.g. ``model.lag_expansion()`` (creep signal per unit load) or a network's.
        times : array_like
            Strictly increasing sample times (s).

        Returns
        -------
        numpy.ndarray
        """
        t = np.asarray(times, dtype=float)
        if t.ndim != 1 or len(t) == 0 or np.any(np.diff(t) <= 0):
            raise InputError("sample times must be a non-empty, strictly increasing array")
        bt = np.array(self.times)
        grid = np.union1d(t, bt[bt <= t[-1]])
        after, before = self.sample(grid), self.sample_before(grid)
        states = lag_states(grid, after, system.taus, hold="linear",
                            initial=np.full(len(system.taus), self.loads[0]), u_before=before)
        y = system.direct * after + states @ np.array(system.gains)
        return y[np.searchsorted(grid, t)]

    def sample_before(self, times) -> np.ndarray:
        """Load just before the given times (before a step when a time falls on one)."""
        t = np.asarray(times, dtype=float)
        bt, bu = np.array(self.times), np.array(self.loads)
        out = self.sample(t)
        first = np.searchsorted(bt, t, side="left")
        on_break = (first < len(bt)) & (bt[np.minimum(first, len(bt) - 1)] == t)
        out[on_break] = bu[first[on_break]]
        return out


def step(level: float = 1.0, at: float = 0.0, name: str | None = None) -> LoadProgram:
    """A single load step from 0 to ``level`` at time ``at``."""
    return LoadProgram((at, at), (0.0, level), name or f"step to {level:g}")


def staircase(levels=(1.0, 2.0, 3.0, 2.0, 1.0, 0.0), hold: float = 300.0, start: float = 0.0,
              name: str | None = None) -> LoadProgram:
    """Loading and unloading steps, each held for ``hold`` seconds (the paper's fig. 2).

    Parameters
    ----------
    levels : sequence of float
        Load after each step, starting from 0.
    hold : float
        Time each level is held (s).
    start : float
        Time of the first step (s).
    """
    if not hold > 0:
        raise InputError(f"hold = {hold!r}: must be positive")
    # steps: (t_k, previous level) then (t_k, new level)
    times, loads = [start, start], [0.0, levels[0]]
    for k in range(1, len(levels)):
        t = start + k * hold
        times += [t, t]
        loads += [levels[k - 1], levels[k]]
    times.append(start + len(levels) * hold)
    loads.append(levels[-1])
    return LoadProgram(tuple(times), tuple(loads), name or "staircase of loading and unloading steps")


def triangle_sweep(period: float, cycles: int = 3, full_scale: float = 1.0, start: float = 0.0,
                   name: str | None = None) -> LoadProgram:
    """Triangular sweep between -FS and +FS (the paper's fig. 6), starting at 0 going up."""
    if not period > 0 or cycles < 1:
        raise InputError("a sweep needs a positive period and at least one cycle")
    q = period / 4.0
    times, loads = [start], [0.0]
    for c in range(cycles):
        t0 = start + c * period
        times += [t0 + q, t0 + 3 * q, t0 + 4 * q]
        loads += [full_scale, -full_scale, 0.0]
    return LoadProgram(tuple(times), tuple(loads), name or f"triangular sweep ±{full_scale:g}, period {period:g} s")
