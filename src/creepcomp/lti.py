"""Sums of first-order lags, ``D + sum_k a_k / (1 + s tau_k)``, and their exact time responses.

Both halves of the problem have this form: the creep model ``G(s)`` (``D = 1``, ``a = beta``)
and every passive RC correction network ``H(s)`` (its poles are real, negative and simple).
Everything that simulates either one in time goes through :func:`lag_states`, which
discretises each lag exactly, for inputs held between samples (``hold="zero"``) or ramping
linearly between samples (``hold="linear"``), on uniform or irregular time points.
"""

from __future__ import annotations

import contextvars
import math
import threading
from contextlib import contextmanager
from functools import cached_property
from typing import TYPE_CHECKING

from dataclasses import dataclass

import numpy as np

from creepcomp.errors import InputError

if TYPE_CHECKING:
    import control

__all__ = ["LagExpansion", "UNIFORM_RTOL", "lag_coefficients", "is_uniform", "lag_states",
           "cascade_matrices", "cascade_step", "cascade_step_arrays", "triangle_lag_gap",
           "cascade_lags", "varying_lag_states", "lag_tau_derivatives", "first_order_filter",
           "decay", "DECAY_FLOOR", "decay_columns", "varying_lag_derivatives", "compiled_loops", "compiled_active",
           "Sampling"]

#: Relative spread of time steps below which sampling counts as uniform (then a recursion
#: with constant coefficients runs, :func:`first_order_filter`; the coefficient error this
#: tolerance allows is below 1e-9 * dt / tau).
UNIFORM_RTOL = 1e-9

#: Decay (in units of the fastest time constant) spanned by one block of the irregular scan;
#: exp(500) stays far from float64 overflow.
_BLOCK_DECAY = 500.0


_COMPILED = contextvars.ContextVar("compiled_loops", default=False)


@contextmanager
def compiled_loops():
    """Within it, the lag recursions of this module run compiled (:mod:`creepcomp.recursions`,
    numba) instead of in numpy: for work that evaluates lags thousands of times (a diagnosis),
    where numba's start (about 0.5 s, once per process) pays. The results agree with
    numpy's to rounding (the same recursion, not summed in blocks)."""
    from creepcomp import recursions  # noqa: F401  (numba's start, here rather than in a loop)

    token = _COMPILED.set(True)
    try:
        yield
    finally:
        _COMPILED.reset(token)


def compiled_active() -> bool:
    """True inside :func:`compiled_loops`."""
    return _COMPILED.get()


@dataclass(frozen=True)
class LagExpansion:
    """A transfer function ``direct + sum_k gains[k] / (1 + s * taus[k])``.

    Parameters
    ----------
    direct : float
        High-frequency gain ``D``.
    gains : tuple of float
        Residue of each lag, ``a_k``.
    taus : tuple of float
        Time constant of each lag in seconds, positive.
    """

    direct: float
    gains: tuple[float, ...]
    taus: tuple[float, ...]

    def __post_init__(self):
        object.__setattr__(self, "gains", tuple(float(g) for g in self.gains))
        object.__setattr__(self, "taus", tuple(float(t) for t in self.taus))
        if len(self.gains) != len(self.taus):
            raise InputError("a lag expansion needs one gain per time constant")
        if any(not t > 0 or not np.isfinite(t) for t in self.taus):
            raise InputError("time constants of a lag expansion must be positive and finite")

    @property
    def dc_gain(self) -> float:
        """Gain at zero frequency, ``D + sum a_k``."""
        return self.direct + sum(self.gains)

    @property
    def hf_gain(self) -> float:
        """Gain at infinite frequency, ``D``."""
        return self.direct

    def matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Diagonal state-space matrices ``A, B, C, D`` (state ``k`` is lag ``k``'s output)."""
        taus = np.array(self.taus)
        return (np.diag(-1.0 / taus), (1.0 / taus)[:, None], np.array(self.gains)[None, :],
                np.array([[self.direct]]))

    def state_space(self) -> "control.StateSpace":
        """Diagonal state-space realisation as a python-control object (see :meth:`matrices`)."""
        import control

        if len(self.taus) == 0:
            return control.ss([], [], [], [[self.direct]])
        return control.ss(*self.matrices())

    def transfer_function(self) -> "control.TransferFunction":
        """The transfer function as a python-control object."""
        import control

        tf = control.tf([self.direct], [1.0])
        for a, tau in zip(self.gains, self.taus):
            tf = tf + control.tf([a], [tau, 1.0])
        return tf

    def frequency_response(self, omega) -> np.ndarray:
        """Complex gain at angular frequencies ``omega`` (rad/s)."""
        s = 1j * np.asarray(omega, dtype=float)[..., None]
        return self.direct + np.sum(np.array(self.gains) / (1 + s * np.array(self.taus)), axis=-1)

    def step(self, t) -> np.ndarray:
        """Unit-step response at times ``t >= 0`` (closed form)."""
        t = np.asarray(t, dtype=float)[..., None]
        return self.direct + np.sum(np.array(self.gains) * -np.expm1(-t / np.array(self.taus)), axis=-1)

    def simulate(self, time, u, hold: str = "linear", initial="relaxed") -> np.ndarray:
        """Response to the input ``u`` sampled at ``time`` (uniform or irregular).

        Parameters
        ----------
        time : array_like
            Strictly increasing sample times in seconds.
        u : array_like
            Input at those times.
        hold : {"linear", "zero"}
            Input ramps linearly between samples, or is held from one sample to the next.
        initial : {"relaxed", "settled"} or array_like
            Lag states at ``time[0]``: zero (input was 0 before ``time[0]``), equal to
            ``u[0]`` (input held at ``u[0]`` forever before), or given explicitly.

        Returns
        -------
        numpy.ndarray
            Output at ``time``.
        """
        u = np.asarray(u, dtype=float)
        states = lag_states(time, u, self.taus, hold=hold, initial=initial)
        return self.direct * u + states @ np.array(self.gains)


def _initial_states(initial, u0: float, n_terms: int) -> np.ndarray:
    if isinstance(initial, str):
        if initial == "relaxed":
            return np.zeros(n_terms)
        if initial == "settled":
            return np.full(n_terms, u0)
        raise InputError(f"initial state '{initial}': use 'relaxed', 'settled' or an array")
    c0 = np.asarray(initial, dtype=float).reshape(-1)
    if c0.shape != (n_terms,):
        raise InputError(f"initial state has {c0.size} values for {n_terms} lags")
    return c0


def lag_coefficients(dt, taus, hold: str = "linear"):
    """Exact one-step coefficients of ``tau c' = u - c`` over steps ``dt``.

    ``c[n+1] = e * c[n] + b0 * u[n] + b1 * u[n+1]``.

    Parameters
    ----------
    dt : array_like
        Time steps (broadcast against ``taus``).
    taus : array_like
        Time constants.
    hold : {"linear", "zero"}
        Input ramping between samples, or held at ``u[n]``.

    Returns
    -------
    e, b0, b1 : numpy.ndarray
    """
    linear = _linear_hold(hold)
    with np.errstate(over="ignore"):     # (a vanishing time constant: x = inf, the lag follows its input)
        x = np.asarray(dt, dtype=float) / np.asarray(taus, dtype=float)
    e = np.exp(-x)
    if not linear:
        return e, -np.expm1(-x), np.zeros_like(e)
    from scipy import special

    g = special.exprel(-x)          # (1 - e) / x, accurate for small x
    return e, g - e, 1.0 - g


def is_uniform(time) -> bool:
    """True when the time steps are equal to within :data:`UNIFORM_RTOL`."""
    dt = np.diff(np.asarray(time, dtype=float))
    return len(dt) == 0 or float(np.ptp(dt)) <= UNIFORM_RTOL * float(np.mean(dt))


def lag_states(time, u, taus, hold: str = "linear", initial="relaxed", u_before=None) -> np.ndarray:
    """States ``c_k`` of first-order lags ``tau_k c_k' = u - c_k`` at the sample times.

    Exact for the chosen hold; O(N) per lag; never overflows, whatever ``t / tau``.

    Parameters
    ----------
    time : array_like or Sampling
        Strictly increasing times (s); a :class:`Sampling` keeps what is computed from
        them for the next call.
    u : array_like
        Input samples (for a step at a sample time: the value after the step).
    taus : array_like
        Time constants (s).
    hold : {"linear", "zero"}
        Interpolation of the input between samples.
    initial : {"relaxed", "settled"} or array_like
        States at ``time[0]`` (see :meth:`LagExpansion.simulate`).
    u_before : array_like, optional
        Input just before each sample time, where it differs from ``u`` (a step exactly at
        a sample, with linear hold). Default: ``u``.

    Returns
    -------
    numpy.ndarray
        Shape ``(len(time), len(taus))``.
    """
    sampling = Sampling.of(time)
    t = sampling.time
    u = np.asarray(u, dtype=float)
    taus = np.atleast_1d(np.asarray(taus, dtype=float))
    if t.ndim != 1 or u.shape != t.shape:
        raise InputError(f"time and input must be 1-D of equal length (got {t.shape} and {u.shape})")
    ub = u if u_before is None else np.asarray(u_before, dtype=float)
    n, k = len(t), len(taus)
    out = np.empty((n, k), order="F")       # (filled lag by lag)
    if n == 0:
        return out
    c0 = _initial_states(initial, u[0], k)
    out[0] = c0
    if n == 1 or k == 0:
        return out
    sampling.steps                          # (checks the times)
    if _COMPILED.get():
        from creepcomp import recursions

        recursions.lag_recursion(*_compiled_plan(sampling, taus, hold), u, ub, c0, out)
        return out
    changes = _input_changes(u, hold) if u_before is None else None
    if changes is not None:
        _held_runs(sampling, u, taus, changes, c0, out)
        return out
    plan = _lag_plan(sampling, taus, hold)
    if plan.uniform:
        for j, (e, b0, b1) in enumerate(plan.coefficients):
            out[1:, j] = first_order_filter(e, b0 * u[:-1] + b1 * ub[1:], c0[j])
        return out
    e, b0, b1 = plan.coefficients
    drive = b0 * u[:-1, None] + b1 * ub[1:, None]
    _scan(t, taus, e, drive, c0, out, plan.blocks)
    return out


@dataclass(frozen=True)
class _LagPlan:
    """What :func:`lag_states` computes from the sample times and time constants alone:
    uniform steps and each lag's coefficients, or the coefficients of every step and the
    blocks of :func:`_scan` with their growth factors (None: found as the scan goes)."""

    uniform: bool
    coefficients: tuple
    blocks: tuple | None = None


#: Plans a :class:`Sampling` keeps (the last few sets of time constants of :func:`lag_states`):
#: a fit evaluates the lags of many inputs for the same time constants (an effect's own
#: parameters move the input only). Only up to :data:`_PLAN_KEPT_VALUES` samples times lags (a
#: diagnosis's record; a plan holds four such arrays).
_PLANS_KEPT = 4
_PLAN_KEPT_VALUES = 120_000


class Sampling:
    """Strictly increasing sample times and what the lag recursions of this module compute
    from them alone: their steps, the kinds of step, the coefficients of the last few sets of
    time constants (:data:`_PLANS_KEPT`) and the runs of the last few inputs
    (:data:`_RUNS_KEPT`), each computed once and kept on it.

    Whoever owns a record's times holds one (a prepared record:
    :attr:`creepcomp.fit.data.Data.sampling`) and passes it wherever a function here takes
    ``time``: a fit evaluates the lags of one record's times thousands of times. An array
    passed instead serves that call only (:meth:`of`).

    Parameters
    ----------
    time : array_like
        Strictly increasing times (s); copied, read-only.
    """

    def __init__(self, time):
        t = np.array(time, dtype=float)
        t.flags.writeable = False
        self._start(t)

    def _start(self, t: np.ndarray) -> None:
        self.time = t
        self._plans: dict = {}
        self._runs: list = []
        self._lock = threading.Lock()       # (a fleet's worker runs units on several threads)

    @classmethod
    def of(cls, time) -> "Sampling":
        """``time`` itself when it is a :class:`Sampling`, else one for a single call (not
        copied, kept by nobody)."""
        if isinstance(time, Sampling):
            return time
        one = cls.__new__(cls)
        one._start(np.asarray(time, dtype=float))
        return one

    def __len__(self) -> int:
        return len(self.time)

    def __reduce__(self):
        # the times only: what it keeps is made again where it is unpickled
        return (Sampling, (self.time,))

    @cached_property
    def steps(self) -> np.ndarray:
        """``np.diff(time)``, read-only (:class:`InputError` unless strictly increasing)."""
        dt = np.diff(self.time)
        if not np.all(dt > 0):
            raise InputError("time must be strictly increasing")
        dt.flags.writeable = False
        return dt

    @cached_property
    def uniform(self) -> bool:
        """:func:`is_uniform` of the times."""
        return is_uniform(self.time)

    @cached_property
    def kinds(self) -> tuple[np.ndarray, np.ndarray]:
        """The lengths of the distinct kinds of step and the kind of each step (read-only):
        one kind (the mean step) when sampling is uniform, the distinct lengths when there are
        few (a reduced record's blocks take a few lengths), else every step its own. The
        coefficients of a new time constant are then computed once per kind."""
        dt = self.steps
        if self.uniform:
            lengths, kind = np.array([float(np.mean(dt))]), np.zeros(len(dt), np.intp)
        else:
            lengths, kind = np.unique(dt, return_inverse=True)
            if len(lengths) > _KINDS_SHARE * len(dt):
                lengths, kind = dt.copy(), np.arange(len(dt))
        kinds = (lengths, kind.astype(np.intp))
        for a in kinds:
            a.flags.writeable = False
        return kinds

    def plan(self, key: tuple, make, keep: bool):
        """What ``make()`` gives for ``key`` (time constants, hold and way of solving), kept
        among the last :data:`_PLANS_KEPT` when ``keep``."""
        with self._lock:
            hit = self._plans.get(key)
        if hit is not None:
            return hit
        value = make()
        if keep:
            with self._lock:
                while len(self._plans) >= _PLANS_KEPT:
                    self._plans.pop(next(iter(self._plans)))
                self._plans[key] = value
        return value

    def runs(self, u: np.ndarray, changes: np.ndarray) -> "_Runs":
        """The :class:`_Runs` of the input ``u`` (``changes``: its changing intervals), kept
        for the last :data:`_RUNS_KEPT` inputs of records up to :data:`_RUNS_KEPT_SAMPLES`
        samples: a fit evaluates the lags of one input for many time constants. An input's
        runs are known by what they are made of, its changing intervals and its levels (a
        comparison of a few values per run, not per sample)."""
        with self._lock:
            kept = list(self._runs)
        for runs in kept:
            if np.array_equal(runs.last[:-1], changes) and np.array_equal(runs.levels, u[runs.first]):
                return runs
        runs = _Runs(self.time, u, changes)
        if len(self.time) <= _RUNS_KEPT_SAMPLES:
            with self._lock:
                if len(self._runs) >= _RUNS_KEPT:
                    self._runs.pop(0)
                self._runs.append(runs)
        return runs


def _lag_plan(sampling: Sampling, taus: np.ndarray, hold: str) -> _LagPlan:
    """The :class:`_LagPlan` of these sample times and time constants (kept on ``sampling``)."""
    keep = len(sampling) * len(taus) <= _PLAN_KEPT_VALUES

    def make() -> _LagPlan:
        t, dt = sampling.time, sampling.steps
        if sampling.uniform:
            step = float(np.mean(dt))
            return _LagPlan(True, tuple(tuple(float(c) for c in lag_coefficients(step, tau, hold))
                                        for tau in taus))
        coefficients = lag_coefficients(dt[:, None], taus[None, :], hold)
        for c in coefficients:
            c.flags.writeable = False           # (shared by every call with this plan)
        # (a plan not kept grows its blocks one at a time, as the scan reaches them)
        return _LagPlan(False, coefficients, tuple(_scan_blocks(t, taus)) if keep else None)

    return sampling.plan((taus.tobytes(), hold), make, keep)


def _compiled_plan(sampling: Sampling, taus: np.ndarray, hold: str) -> tuple:
    """The coefficients ``(e, b0, b1)`` of :func:`creepcomp.recursions.lag_recursion` for these
    sample times and time constants, one row per kind of step (:attr:`Sampling.kinds`), and the
    kinds (kept as :func:`_lag_plan` keeps its plans)."""
    keep = len(sampling) * len(taus) <= _PLAN_KEPT_VALUES

    def make() -> tuple:
        from creepcomp import recursions

        lengths, kind = sampling.kinds
        plan = tuple(np.empty((len(lengths), len(taus))) for _ in range(3))
        recursions.step_coefficients(lengths, taus, _linear_hold(hold), *plan)
        if keep:
            for c in plan:
                c.flags.writeable = False
        return plan + (kind,)

    return sampling.plan((taus.tobytes(), hold, "compiled"), make, keep)


#: Steps of a few lengths (a reduced record's blocks) are solved by kind when there are at
#: most this share as many kinds as steps.
_KINDS_SHARE = 0.25


#: Most load changes, as a share of the samples, for which lags are solved run by run
#: (:func:`_held_runs`): the closed form costs one exponential per sample and lag, the
#: recursion between runs a Python step per change.
_RUNS_SHARE = 1.0 / 200.0


def _input_changes(u: np.ndarray, hold: str) -> np.ndarray | None:
    """Sample intervals over which a linearly held input changes, when they are few enough
    (:data:`_RUNS_SHARE`) for :func:`_held_runs`; else None."""
    if hold != "linear" or len(u) < 2:
        return None
    changes = np.flatnonzero(u[1:] != u[:-1])
    return changes if len(changes) <= _RUNS_SHARE * len(u) else None


def _held_runs(sampling: Sampling, u, taus, changes, c0, out) -> None:
    """Lag states for an input that is constant but over a few sample intervals (``changes``,
    linear hold): within a run of constant input ``U`` the exact solution
    ``U + (c - U) exp(-(t - t_start) / tau)``, the changing intervals by the recursion of
    :func:`lag_states`. Fills ``out`` (N, K)."""
    t = sampling.time
    runs = sampling.runs(u, changes)
    e, b0, b1 = lag_coefficients((t[changes + 1] - t[changes])[:, None], taus[None, :], "linear")
    levels = runs.levels.tolist()
    before, after = u[changes].tolist(), u[changes + 1].tolist()
    for k, tau in enumerate(taus):           # (column by column: contiguous and fast)
        head = runs.heads(tau)
        ends = head[runs.last].tolist()
        ek, b0k, b1k = e[:, k].tolist(), b0[:, k].tolist(), b1[:, k].tolist()
        starts = [float(c0[k])]
        for j in range(len(changes)):        # (a run's end, then across the change)
            end = ends[j] * (starts[j] - levels[j]) + levels[j]
            starts.append(ek[j] * end + b0k[j] * before[j] + b1k[j] * after[j])
        column = out[:, k]
        np.multiply(head, runs.spread(np.array(starts) - runs.levels), out=column)
        column += runs.level


def _held_runs_derivatives(sampling: Sampling, u, taus, states, changes, slope0, out) -> None:
    """``d c_k / d tau_k`` of :func:`_held_runs`: within a run ``exp(-s / tau) (d_start +
    (c_start - U) s / tau^2)`` (``s`` the time since the run's start), the changing
    intervals by the differentiated recursion (:func:`lag_tau_derivatives`)."""
    t = sampling.time
    runs = sampling.runs(u, changes)
    x = (t[changes + 1] - t[changes])[:, None] / taus[None, :]
    e, de, db0, db1 = _coefficient_slopes(x, taus[None, :], "linear")
    before, after = u[changes].tolist(), u[changes + 1].tolist()
    ends_since = runs.since[runs.last].tolist()
    for k, tau in enumerate(taus):
        head = runs.heads(tau)
        slopes = (states[runs.first, k] - runs.levels) / tau ** 2
        ends, slope = head[runs.last].tolist(), slopes.tolist()
        at_change = states[changes, k].tolist()
        ek, dek, db0k, db1k = (c[:, k].tolist() for c in (e, de, db0, db1))
        starts = [float(slope0[k])]
        for j in range(len(changes)):
            end = ends[j] * (ends_since[j] * slope[j] + starts[j])
            starts.append(ek[j] * end + dek[j] * at_change[j] + db0k[j] * before[j] + db1k[j] * after[j])
        column = out[:, k]                   # (in place: no temporaries of the record's length)
        np.multiply(runs.since, runs.spread(slopes), out=column)
        column += runs.spread(np.array(starts))
        column *= head


class _Runs:
    """The runs of constant input between the changing intervals of :func:`_held_runs`: their
    first and last samples and levels, and each sample's time since its run's start and its
    run's level."""

    def __init__(self, t: np.ndarray, u: np.ndarray, changes: np.ndarray):
        self.first = np.concatenate([[0], changes + 1])
        self.last = np.append(changes, len(t) - 1)
        self.lengths = self.last - self.first + 1
        self.levels = u[self.first]
        self.since = t - self.spread(t[self.first])
        self.level = self.spread(self.levels)

    def spread(self, per_run: np.ndarray) -> np.ndarray:
        """One value per run, repeated over its samples."""
        return np.repeat(per_run, self.lengths)

    def heads(self, tau: float) -> np.ndarray:
        """``exp(-since / tau)`` (:func:`decay` of every run at once)."""
        if not tau > 0:
            return (self.since <= 0).astype(float)
        live = self.since < DECAY_FLOOR * tau
        head = np.multiply(self.since, -1.0 / tau)
        np.exp(head, out=head, where=live)
        head[~live] = 0.0
        return head


#: Runs a :class:`Sampling` keeps (of its last few inputs: :meth:`Sampling.runs`), only of
#: records up to :data:`_RUNS_KEPT_SAMPLES` samples (a fit's reduced record).
_RUNS_KEPT = 4
_RUNS_KEPT_SAMPLES = 200_000


#: Decay (e-foldings) beyond which :func:`decay` is zero: far below rounding of anything
#: it multiplies, and clear of subnormal numbers (whose arithmetic is slow).
DECAY_FLOOR = 460.0


def decay(since: np.ndarray, tau: float) -> np.ndarray:
    """``exp(-since / tau)`` for non-decreasing ``since >= 0``, exactly zero beyond
    :data:`DECAY_FLOOR` e-foldings (one exponential per sample that has not decayed)."""
    since = np.asarray(since, dtype=float)
    out = np.zeros(since.shape)
    live, head = _decay_head(since, tau)
    out[:live] = head
    return out


def decay_columns(time, first, mids, taus, scales) -> np.ndarray:
    """Columns ``scales[j, k] * exp(-(t - mids[j]) / taus[k])`` from sample ``first[j]`` on
    (zero before it, and beyond :data:`DECAY_FLOOR` e-foldings: :func:`decay`), one per ``j``
    and ``k`` in that order (``j`` major), column-major.

    Inside :func:`compiled_loops` each column is the recursion of the lags' decays
    (:func:`creepcomp.recursions.decay_columns`, with the coefficients of these time constants,
    kept on ``time`` when it is a :class:`Sampling`), else one :func:`decay` per column."""
    sampling = Sampling.of(time)
    t = sampling.time
    first = np.asarray(first, dtype=np.intp)
    mids = np.asarray(mids, dtype=float)
    taus = np.atleast_1d(np.asarray(taus, dtype=float))
    scales = np.asarray(scales, dtype=float).reshape(len(first), len(taus))
    out = np.zeros((len(t), len(first) * len(taus)), order="F")
    if _COMPILED.get() and len(t) > 1:
        from creepcomp import recursions

        sampling.steps                      # (checks the times)
        e, _, _, kind = _compiled_plan(sampling, taus, "linear")
        ends = np.searchsorted(t, mids[:, None] + DECAY_FLOOR * taus[None, :], side="left")
        recursions.decay_columns(t, first, ends.astype(np.intp), mids, taus, scales, e, kind, out)
        return out
    for j, (i, mid) in enumerate(zip(first.tolist(), mids.tolist())):
        for k, tau in enumerate(taus.tolist()):
            if scales[j, k] != 0.0:
                out[i:, j * len(taus) + k] = scales[j, k] * decay(t[i:] - mid, tau)
    return out


def _decay_head(since: np.ndarray, tau: float) -> tuple[int, np.ndarray]:
    """The samples of :func:`decay` that have not decayed (a leading run of ``since``) and
    their exponentials."""
    if not tau > 0:
        live = int(np.searchsorted(since, 0.0, side="right"))
        return live, np.ones(live)
    live = int(np.searchsorted(since, DECAY_FLOOR * tau, side="left"))
    head = np.multiply(since[:live], -1.0 / tau)
    return live, np.exp(head, out=head)


#: Decay (in e-foldings) over a block of :func:`first_order_filter`: the block's growth
#: factors stay below e^30, and a state carried over three blocks is below e^-45 of it.
_FILTER_BLOCK_DECAY = 30.0


def first_order_filter(e: float, drive: np.ndarray, c0: float) -> np.ndarray:
    """``c[1:]`` of the recursion ``c[n+1] = e c[n] + drive[n]``, ``c[0] = c0``, with
    ``0 <= e <= 1``: in blocks of :data:`_FILTER_BLOCK_DECAY` e-foldings, each a scaled
    cumulative sum, and the states carried between blocks (over at most three blocks: the
    rest has decayed below rounding). Vectorised numpy, as exact as the recursion."""
    drive = np.asarray(drive, dtype=float)
    n = len(drive)
    rate = -math.log(e) if e > 0 else math.inf          # decay per sample
    if n == 0:
        return drive.copy()
    if rate > _FILTER_BLOCK_DECAY:                       # e below rounding of e^-30
        out = drive.copy()
        out[0] += e * c0
        out[1:] += e * drive[:-1]
        return out
    size = n if rate * n <= _FILTER_BLOCK_DECAY else max(1, int(_FILTER_BLOCK_DECAY / rate))
    blocks = -(-n // size)
    x = np.zeros(blocks * size)
    x[:n] = drive
    x = x.reshape(blocks, size)
    grow = np.exp(rate * np.arange(1, size + 1))         # e^-(j+1)
    within = np.cumsum(x * grow, axis=1) / grow          # each block started from zero
    decay = 1.0 / grow                                   # e^(j+1)
    if blocks > 1:
        ends, across = within[:, -1], decay[-1]
        carried = ends.copy()                            # state at each block's end
        carried[1:] += across * ends[:-1]
        carried[2:] += across ** 2 * ends[:-2]
        carried += c0 * np.exp(-rate * size * np.arange(1, blocks + 1))
        start = np.concatenate([[c0], carried[:-1]])
    else:
        start = np.array([c0])
    within += decay[None, :] * start[:, None]
    return within.ravel()[:n]


def _scan_blocks(t, taus):
    """The blocks of bounded decay of :func:`_scan`, one at a time: ``(i0, i1, growth)``,
    ``growth`` the inverse of the product of ``e`` from ``i0`` to each later sample of the
    block (at most ``exp(500)``; None for a block of one sample)."""
    block = np.floor((t - t[0]) / (_BLOCK_DECAY * taus.min())).astype(np.int64)
    starts = np.flatnonzero(np.diff(block, prepend=block[0] - 1))
    ends = np.append(starts[1:], len(t))
    for i0, i1 in zip(starts, ends):
        yield int(i0), int(i1), (np.exp((t[i0 + 1:i1] - t[i0])[:, None] / taus[None, :]) if i1 - i0 > 1
                                 else None)


def _scan(t, taus, e, drive, c0, out, blocks=None):
    """Solve ``c[n+1] = e[n] c[n] + drive[n]`` in blocks of bounded decay (vectorised);
    ``blocks``: those of :func:`_scan_blocks` for ``t`` and ``taus``, when known."""
    c = c0
    for i0, i1, growth in (_scan_blocks(t, taus) if blocks is None else blocks):
        if i0 > 0:
            c = e[i0 - 1] * out[i0 - 1] + drive[i0 - 1]
        out[i0] = c
        if growth is not None:
            acc = np.cumsum(drive[i0:i1 - 1] * growth, axis=0)
            out[i0 + 1:i1] = (c + acc) / growth


def cascade_matrices(first: LagExpansion, second: LagExpansion):
    """State-space matrices ``A, B, C, D`` of ``second(s) * first(s)`` (first's states first)."""
    a1, b1, c1, d1 = first.matrices()
    a2, b2, c2, d2 = second.matrices()
    n1, n2 = len(a1), len(a2)
    a = np.block([[a1, np.zeros((n1, n2))], [b2 @ c1, a2]])
    b = np.vstack([b1, b2 @ d1])
    c = np.hstack([d2 @ c1, c2])
    return a, b, c, d2 @ d1


def cascade_step(first: LagExpansion, second: LagExpansion, t) -> np.ndarray:
    """Closed-form unit-step response of ``second(s) * first(s)`` at times ``t >= 0``.

    Coincident time constants (the paper's rule puts the network's pole on the creep's)
    are handled without loss of precision.
    """
    return cascade_step_arrays(first.direct, np.array(first.gains), np.array(first.taus),
                               second.direct, np.array(second.gains), np.array(second.taus),
                               np.asarray(t, dtype=float))


def cascade_step_arrays(d1, a1, tau1, d2, a2, tau2, t):
    """Batched closed form behind :func:`cascade_step`.

    Parameters
    ----------
    d1, d2 : array_like, shape (B,) or scalar
        Direct gains of the first and second system.
    a1, tau1 : array_like, shape (B, K1) or (K1,)
        Gains and time constants of the first system.
    a2, tau2 : array_like, shape (B, K2) or (K2,)
        Gains and time constants of the second system.
    t : array_like, shape (T,) or (B, T)
        Times, >= 0 (one grid for all, or one per system).

    Returns
    -------
    numpy.ndarray
        Shape (B, T), or (T,) when all inputs are unbatched.
    """
    batched = (np.ndim(d1) > 0 or np.ndim(d2) > 0 or np.ndim(a1) > 1 or np.ndim(a2) > 1
               or np.ndim(t) > 1)
    d1 = np.atleast_1d(np.asarray(d1, float))[:, None]                  # (B,1)
    d2 = np.atleast_1d(np.asarray(d2, float))[:, None]
    a1, tau1 = np.atleast_2d(a1), np.atleast_2d(tau1)                   # (B,K1)
    a2, tau2 = np.atleast_2d(a2), np.atleast_2d(tau2)                   # (B,K2)
    t = np.atleast_2d(np.asarray(t, float))                             # (1,T) or (B,T)
    dc1 = d1 + a1.sum(axis=1, keepdims=True)                            # (B,1)
    decay1 = np.exp(-t[:, None, :] / tau1[:, :, None])                  # (B,K1,T)
    decay2 = np.exp(-t[:, None, :] / tau2[:, :, None])                  # (B,K2,T)
    step2 = d2 + np.sum(a2[:, :, None] * (1.0 - decay2), axis=1)
    # second system's lags driven by exp(-t/tau1_k): phi_ik = (t/p_i) e^{-t/slow} E(t/fast - t/slow)
    r1 = 1.0 / tau1[:, :, None, None]                                   # (B,K1,1,1)
    r2 = 1.0 / tau2[:, None, :, None]                                   # (B,1,K2,1)
    e1, e2 = decay1[:, :, None, :], decay2[:, None, :, :]
    tt = t[:, None, None, :]
    x = np.abs(r1 - r2) * tt
    e_slow = np.where(r1 <= r2, e1, e2)
    e_fast = np.where(r1 <= r2, e2, e1)
    phi = tt * r2 * _one_minus_exp_over(x, e_slow, e_fast)             # (B,K1,K2,T)
    resp = d2[:, :, None] * decay1 + np.sum(a2[:, None, :, None] * phi, axis=2)
    y = dc1 * step2 - np.sum(a1[:, :, None] * resp, axis=1)
    return y if batched else y[0]


def _one_minus_exp_over(x, e_slow, e_fast):
    """``e_slow * (1 - exp(-x)) / x`` with ``exp(-x) = e_fast / e_slow``, stable for small x.

    Reuses the exponentials already computed: no new transcendental per point.
    """
    small = x < 1e-2
    with np.errstate(divide="ignore", invalid="ignore"):
        direct = (e_slow - e_fast) / np.where(small, 1.0, x)
    series = e_slow * (1 - x / 2 * (1 - x / 3 * (1 - x / 4 * (1 - x / 5 * (1 - x / 6)))))
    return np.where(small, series, direct)


def triangle_lag_gap(q, half_period, x, decays=None):
    """Down-minus-up gap of one lag ``1 / (1 + s q)`` in a ±1 triangular sweep, periodic
    steady state, at fraction ``x`` of the rising half period (load ``-1 + 2 x``).

    Closed form: with slope ``s = 2 / h`` the lag error on each branch relaxes to ``-+ s q``;
    periodicity fixes its value at the turning points to ``+- s q tanh(h / 2q)``.
    ``decays`` may pass ``(exp(-t/q), exp(-(h-t)/q))`` when the caller has them.
    """
    h = half_period
    slope = 2.0 / h
    if decays is None:
        t = x * h
        decays = (np.exp(-t / q), np.exp(-(h - t) / q))
    return slope * q * (2.0 - (1.0 + np.tanh(h / (2.0 * q))) * (decays[0] + decays[1]))


def cascade_lags(d1, a1, tau1, d2, a2, tau2, separation: float = 1e-9):
    """Sum-of-lags form of the cascade ``second(s) * first(s)``, batched.

    ``1/((1+sp)(1+st)) = (p/(1+sp) - t/(1+st)) / (p - t)``; time constants that coincide
    to within ``separation`` (relative) are moved apart by that much, which costs about
    ``1e-16 / separation`` of relative precision: fast, and enough for tolerance analysis.
    Use :func:`cascade_step_arrays` where full precision near coincidence matters.

    Returns
    -------
    direct : (B,), gains : (B, K1 + K2), taus : (B, K1 + K2)
    """
    d1 = np.atleast_1d(np.asarray(d1, float))
    d2 = np.atleast_1d(np.asarray(d2, float))
    a1, t1 = np.atleast_2d(a1), np.atleast_2d(np.asarray(tau1, float))
    a2, t2 = np.atleast_2d(a2), np.atleast_2d(np.asarray(tau2, float))
    close = np.any(np.abs(t2[:, None, :] - t1[:, :, None]) < separation * t1[:, :, None], axis=1)
    t2 = np.where(close, t2 * (1.0 + 2.0 * separation), t2)
    p = t2[:, None, :]                                                  # (B,1,K2)
    t = t1[:, :, None]                                                  # (B,K1,1)
    w = a1[:, :, None] * a2[:, None, :] / (p - t)                       # (B,K1,K2)
    gains1 = d2[:, None] * a1 - np.sum(w * t, axis=2)
    gains2 = d1[:, None] * a2 + np.sum(w * p, axis=1)
    return d1 * d2, np.concatenate([gains1, gains2], axis=1), np.concatenate([t1, t2], axis=1)


def varying_lag_states(time, u, taus, hold: str = "linear", initial="relaxed") -> np.ndarray:
    """States of first-order lags whose time constant changes from one sample step to the next.

    ``tau_k(t) c_k' = u - c_k`` with ``tau_k`` constant over each step ``[t[n], t[n+1]]``
    (e.g. a retardation time that follows temperature, or that differs between creep and
    recovery). Each step is discretised exactly as in :func:`lag_states`; the recursion is
    solved in vectorised blocks of bounded decay, so it never overflows.

    Parameters
    ----------
    time : array_like, shape (N,), or Sampling
        Strictly increasing times (s).
    u : array_like, shape (N,)
        Input samples.
    taus : array_like, shape (N-1, K)
        Time constant of each lag over each step (s), positive.
    hold : {"linear", "zero"}
        Interpolation of the input between samples.
    initial : {"relaxed", "settled"} or array_like
        States at ``time[0]``.

    Returns
    -------
    numpy.ndarray
        Shape ``(N, K)``.
    """
    sampling = Sampling.of(time)
    u = np.asarray(u, dtype=float)
    taus = np.asarray(taus, dtype=float)
    n = len(sampling)
    if taus.ndim != 2 or taus.shape[0] != max(n - 1, 0):
        raise InputError(f"varying time constants need shape (N-1, K); got {taus.shape} for N = {n}")
    k = taus.shape[1]
    out = np.empty((n, k))
    if n == 0:
        return out
    c0 = _initial_states(initial, u[0] if n else 0.0, k)
    out[0] = c0
    if n == 1 or k == 0:
        return out
    dt = sampling.steps
    if not np.all(taus > 0):
        raise InputError("time constants must be positive")
    if _COMPILED.get():
        from creepcomp import recursions

        recursions.varying_lag_recursion(dt, taus, _linear_hold(hold), u, c0, out)
        return out
    e, b0, b1 = lag_coefficients(dt[:, None], taus, hold)
    drive = b0 * u[:-1, None] + b1 * u[1:, None]
    _varying_solve(dt, taus, e, drive, c0, out)
    return out


def _varying_solve(dt, taus, e, drive, c0, out) -> None:
    """Solve ``c[n+1] = e[n] c[n] + drive[n]`` (``e[n] = exp(-dt[n] / taus[n])``) into ``out``
    from ``c[0] = c0``, in vectorised blocks of bounded decay (:func:`varying_lag_states`)."""
    n, k = out.shape
    # a step of more decay than a block holds ends its block (its own e is exact there), so
    # capping it keeps the cumulative decay finite when a time constant is tiny
    with np.errstate(over="ignore"):
        rates = np.minimum(dt[:, None] / taus, _BLOCK_DECAY)
    decay = np.zeros((n, k))
    np.cumsum(rates, axis=0, out=decay[1:])
    # blocks of bounded decay for every lag at once: the decay of the fastest lag at each step
    fastest = rates[:, 0].copy()
    for j in range(1, k):            # column by column: far faster than max(axis=1) on few columns
        np.maximum(fastest, rates[:, j], out=fastest)
    bound = np.concatenate([[0.0], np.cumsum(fastest)])
    block = np.floor(bound / _BLOCK_DECAY).astype(np.int64)
    starts = np.flatnonzero(np.diff(block, prepend=block[0] - 1))
    ends = np.append(starts[1:], n)
    c = c0
    for i0, i1 in zip(starts, ends):
        if i0 > 0:
            c = e[i0 - 1] * out[i0 - 1] + drive[i0 - 1]
        out[i0] = c
        if i1 - i0 > 1:
            growth = np.exp(decay[i0 + 1:i1] - decay[i0])     # <= exp(500) within a block
            acc = np.cumsum(drive[i0:i1 - 1] * growth, axis=0)
            out[i0 + 1:i1] = (c + acc) / growth


def varying_lag_derivatives(time, u, taus, states, tau_slopes, hold: str = "linear",
                            initial_slope=None) -> np.ndarray:
    """Derivatives of the states of :func:`varying_lag_states` by one parameter that moves
    the time constants of the steps, exact for the discretisation (forward mode): with
    ``T`` the time constants and ``T'`` their derivatives, differentiating
    ``c[n+1] = e c[n] + b0 u[n] + b1 u[n+1]`` gives the same recursion
    ``d[n+1] = e d[n] + (e_T c[n] + b0_T u[n] + b1_T u[n+1]) T'[n]``.

    Parameters
    ----------
    time : array_like, shape (N,), or Sampling
    u : array_like, shape (N,)
    taus, tau_slopes : array_like, shape (N-1, K)
        The time constants of each lag over each step, and their derivatives.
    states : numpy.ndarray, shape (N, K)
        The lags' states (:func:`varying_lag_states` with the same arguments).
    hold : {"linear", "zero"}
    initial_slope : array_like, shape (K,), optional
        Derivatives of the states at ``time[0]`` (default zero).

    Returns
    -------
    numpy.ndarray
        Shape ``(N, K)``.
    """
    sampling = Sampling.of(time)
    u = np.asarray(u, dtype=float)
    taus = np.asarray(taus, dtype=float)
    n, k = states.shape
    out = np.empty((n, k))
    out[0] = 0.0 if initial_slope is None else np.asarray(initial_slope, float)
    if n < 2 or k == 0:
        return out
    dt = sampling.steps
    if _COMPILED.get():
        from creepcomp import recursions

        recursions.varying_derivative_recursion(dt, taus, _linear_hold(hold),
                                                np.broadcast_to(tau_slopes, taus.shape), states, u,
                                                out[0].copy(), out)
        return out
    e, de, db0, db1 = _coefficient_slopes(dt[:, None] / taus, taus, hold)
    drive = (de * states[:-1] + db0 * u[:-1, None] + db1 * u[1:, None]) * tau_slopes
    _varying_solve(dt, taus, e, drive, out[0].copy(), out)
    return out


def _coefficient_slopes(x: np.ndarray, taus: np.ndarray, hold: str):
    """The decay ``e = exp(-x)`` of a step ``x = dt / tau`` and the derivatives by tau of the
    recursion's coefficients ``e``, ``b0``, ``b1`` (:func:`lag_coefficients`)."""
    linear = _linear_hold(hold)
    e = np.exp(-x)
    dx = -x / taus                            # dx / d tau
    de = -e * dx
    if not linear:
        return e, de, -de, np.zeros_like(de)
    dg = _exprel_slope(x) * dx
    return e, de, dg - de, -dg


def _linear_hold(hold: str) -> bool:
    """True for linear hold, False for zero hold (else :class:`InputError`): the check of
    every function here that takes a ``hold``."""
    if hold not in ("linear", "zero"):
        raise InputError(f"hold '{hold}': use 'linear' or 'zero'")
    return hold == "linear"


def _exprel_slope(x: np.ndarray) -> np.ndarray:
    """d/dx of ``(1 - exp(-x)) / x``: ``(exp(-x) - g) / x``, by its series for small x."""
    x = np.asarray(x, dtype=float)
    small = x < 1e-2
    xs = np.where(small, x, 0.0)
    series = -0.5 + xs / 3.0 - xs ** 2 / 8.0 + xs ** 3 / 30.0 - xs ** 4 / 144.0
    from scipy import special

    xl = np.where(small, 1.0, x)
    exact = (np.exp(-xl) - special.exprel(-xl)) / xl
    return np.where(small, series, exact)


def lag_tau_derivatives(time, u, taus, states, hold: str = "linear", initial_slope=None) -> np.ndarray:
    """Derivatives ``d c_k / d tau_k`` of the states of :func:`lag_states`, exact for the
    discretisation: differentiating ``c[n+1] = e c[n] + b0 u[n] + b1 u[n+1]`` gives the same
    recursion ``d[n+1] = e d[n] + e' c[n] + b0' u[n] + b1' u[n+1]`` (primes: d/d tau).

    Parameters
    ----------
    time : array_like, shape (N,), or Sampling
    u : array_like, shape (N,)
    taus : array_like, shape (K,)
    states : numpy.ndarray, shape (N, K)
        The lags' states (:func:`lag_states` with the same arguments).
    hold : {"linear", "zero"}
    initial_slope : array_like, shape (K,), optional
        ``d c_k[0] / d tau_k`` (default zero: an initial state that does not depend on tau).

    Returns
    -------
    numpy.ndarray
        Shape ``(N, K)``.
    """
    sampling = Sampling.of(time)
    t = sampling.time
    u = np.asarray(u, dtype=float)
    taus = np.atleast_1d(np.asarray(taus, dtype=float))
    n, k = len(t), len(taus)
    out = np.empty((n, k), order="F")
    out[0] = 0.0 if initial_slope is None else np.asarray(initial_slope, float)
    if n < 2 or k == 0:
        return out
    if _COMPILED.get():
        from creepcomp import recursions

        sampling.steps                      # (checks the times)
        lengths, kind = sampling.kinds
        slopes = tuple(np.empty((len(lengths), k)) for _ in range(4))
        recursions.step_coefficient_slopes(lengths, taus, _linear_hold(hold), *slopes)
        recursions.derivative_recursion(*slopes, kind, np.ones((1, k)), states, u, out[0].copy(), out)
        return out
    changes = _input_changes(u, hold)
    if changes is not None:
        _held_runs_derivatives(sampling, u, taus, states, changes, out[0].copy(), out)
        return out
    dt = sampling.steps
    uniform = sampling.uniform
    step = np.full((1, 1), float(np.mean(dt))) if uniform else dt[:, None]
    e, de, db0, db1 = _coefficient_slopes(step / taus[None, :], taus[None, :], hold)
    drive = de * states[:-1] + db0 * u[:-1, None] + db1 * u[1:, None]
    if uniform:
        for j in range(k):
            out[1:, j] = first_order_filter(float(e[0, j]), drive[:, j], out[0, j])
        return out
    _scan(t, taus, np.broadcast_to(e, drive.shape), drive, out[0].copy(), out)
    return out
