"""Model structures: the nonlinear parameters, the effects applied, and the linear basis of
a model for given values of its nonlinear parameters.

The model of a record is

    signal = offset + gain * (s + sum_k beta_k c_k) + ...

with ``s`` the load as the sensor sees it and ``c_k`` the load through a first-order lag of
time constant ``tau_k`` (:func:`creepcomp.lti.lag_states`, exact for any sampling), started
from an initial state that is fitted (a record may start loaded or creeping: ``c0[k]``,
bounded by the loads a sensor sees) or known. For fixed time constants and initial states
the signal is *linear* in offset, gain and ``gain * beta_k`` (the columns of :class:`Basis`),
so only the time constants, the initial states and an effect's own nonlinear parameters
(see :mod:`creepcomp.diagnose.effects`) are searched.
"""

from __future__ import annotations

import functools
import math
import threading
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from creepcomp.fit.data import Data, load_steps
from creepcomp.lti import (compiled_active, decay, decay_columns, lag_states, lag_tau_derivatives,
                           varying_lag_derivatives, varying_lag_states)

__all__ = ["Param", "Applied", "Structure", "taus_of", "Basis", "basis", "with_step_times",
           "basis_derivatives", "DIFF_STEP"]

#: Iterations of the mode switching of lags whose time constant depends on their state.
_MODE_ITERATIONS = 50


@dataclass(frozen=True)
class Param:
    """A nonlinear parameter: name, bounds in natural units, and how it is searched.

    ``log`` parameters (time constants) are searched on their logarithm; the others on
    ``value / scale``.
    """

    name: str
    lower: float
    upper: float
    log: bool = False
    scale: float = 1.0
    default: float = 0.0

    def to_search(self, value: float) -> float:
        """Natural value to search coordinate."""
        return math.log(value) if self.log else value / self.scale

    def from_search(self, x: float) -> float:
        """Search coordinate to natural value."""
        return math.exp(x) if self.log else x * self.scale

    def bounds(self) -> tuple[float, float]:
        """Bounds in search coordinates."""
        return self.to_search(self.lower), self.to_search(self.upper)

    def clip(self, value: float) -> float:
        """The value moved inside the bounds (strictly)."""
        lo, hi = self.bounds()
        x = min(max(self.to_search(value), lo + 1e-9 * (hi - lo)), hi - 1e-9 * (hi - lo))
        return self.from_search(x)


@dataclass(frozen=True)
class Applied:
    """An effect applied to a model, with its fixed settings (e.g. which term it acts on)."""

    effect: Any
    settings: tuple = ()

    @property
    def name(self) -> str:
        """The effect's identifier."""
        return self.effect.name

    def setting(self, key: str, default=None):
        """One fixed setting."""
        return dict(self.settings).get(key, default)

    def own(self, values: dict) -> dict:
        """This effect's parameter values, without the ``effect.`` prefix."""
        prefix = self.name + "."
        return {k[len(prefix):]: v for k, v in values.items() if k.startswith(prefix)}


@dataclass(frozen=True)
class Structure:
    """Which model: the number of Prony terms and the effects applied, in order."""

    n_terms: int = 1
    effects: tuple[Applied, ...] = ()

    def with_effect(self, applied: Applied) -> "Structure":
        """This structure plus one effect."""
        return replace(self, effects=self.effects + (applied,))

    def has(self, name: str) -> bool:
        """True when the effect ``name`` is applied."""
        return any(a.name == name for a in self.effects)

    def params(self, data: Data) -> list[Param]:
        """The nonlinear parameters: time constants, then each effect's own."""
        lo, hi = data.tau_limits()
        out = [Param(f"tau[{k}]", lo, hi * 10.0, log=True) for k in range(self.n_terms)]
        if data.initial == "free":
            # each term's creep state at the first sample, relative to the first load: within
            # the loads a sensor sees (a free decay amplitude alone could follow any slow trend)
            scale = data.load_scale
            out += [Param(f"c0[{k}]", -2.0 * scale, 2.0 * scale, scale=scale)
                    for k in range(self.n_terms)]
        for a in self.effects:
            out += [replace(p, name=f"{a.name}.{p.name}") for p in a.effect.nonlinear_params(data, a)]
        return out

    def describe(self) -> str:
        """Short text, e.g. ``2 terms + viscous_flow``."""
        text = f"{self.n_terms} term{'s' if self.n_terms > 1 else ''}"
        return " + ".join([text] + [a.name for a in self.effects])


def taus_of(values: dict, n_terms: int) -> np.ndarray:
    """The time constants in a value dictionary."""
    return np.array([values[f"tau[{k}]"] for k in range(n_terms)])


_NO_SAMPLES = np.zeros(0, int)


@dataclass(frozen=True)
class Basis:
    """Columns of the linear part of a model for fixed nonlinear parameters."""

    columns: np.ndarray
    names: tuple[str, ...]
    load_seen: np.ndarray        # the load after load-side effects (delay)
    instant: np.ndarray          # s: instantaneous signal in load units
    creep_input: np.ndarray      # h: what drives the lags
    lags: np.ndarray             # (N, K)
    step_bounds: tuple = ()      # (column, term k, half width in s) of each step-time column
    step_mids: tuple = ()        # the middle (s) of each step-time column's sample interval
    # samples each fitted by a parameter of its own (Effect.straddling; Problem.straddled)
    straddling: np.ndarray = field(default_factory=lambda: _NO_SAMPLES)


#: Samples per segment when lags whose time constant depends on their own state are solved.
_SEGMENT = 4096


def _state_dependent_lags(data: Data, h, taus, init, factor, effects, values, cache: dict | None = None):
    """Lags whose time constants depend on their own state (modes such as creep and recovery),
    solved segment by segment: within a segment the modes are found by fixed-point iteration
    (modes from states, states from modes; the causal solution is its only fixed point), and
    the segment's last state starts the next one. Short segments hold few mode switches, so
    the iteration converges in a few rounds whatever the whole record holds.

    With a ``cache`` (one per fitting problem), the iteration starts from the modes the last
    call converged to: an optimiser's next point, or a finite-difference step, nearly always
    has the same modes, and then one solve confirms them instead of several rounds. The
    fixed point, and so the result, is the same from any start."""
    t = data.time
    n, k = len(t), len(taus)
    out = np.empty((n, k))
    modes = np.ones((n - 1, k))
    c = np.full(k, h[0]) if isinstance(init, str) and init == "settled" else (
        np.zeros(k) if isinstance(init, str) else np.asarray(init, float))
    out[0] = c
    start = 0
    while start < n - 1:
        end = min(start + _SEGMENT, n - 1)
        seg_t, seg_h = t[start:end + 1], h[start:end + 1]
        base = factor[start:end]
        current = None if cache is None else cache.get(("modes", start))
        if current is not None and current.shape != base.shape:
            current = None
        seg = varying_lag_states(seg_t, seg_h, taus[None, :] * base if current is None else
                                 taus[None, :] * base * current, hold=data.hold, initial=c)
        for _ in range(_MODE_ITERATIONS):
            new = np.ones_like(base)
            for a in effects:
                new = new * a.effect.tau_factor(data, seg_h, seg, taus, a.own(values), a)
            if current is not None and np.array_equal(new, current):
                break
            current = new
            seg = varying_lag_states(seg_t, seg_h, taus[None, :] * base * current, hold=data.hold,
                                     initial=c)
        out[start:end + 1] = seg
        modes[start:end] = current
        if cache is not None:
            cache[("modes", start)] = current
        c = seg[-1]
        start = end
    return out, factor * modes


def _lags(data: Data, h, taus, init, dynamic, values, cache) -> np.ndarray:
    """States of the creep lags driven by ``h`` (time constants changed by ``dynamic`` effects)."""
    t = data.time
    static = [a for a in dynamic if not a.effect.state_dependent]
    if not dynamic or static:
        lags = lag_states(data.sampling, h, taus, hold=data.hold, initial=init)
        if not dynamic:
            return lags
    factor = np.ones((len(t) - 1, len(taus)))
    for a in static:
        factor = factor * a.effect.tau_factor(data, h, lags, taus, a.own(values), a)
    states = [a for a in dynamic if a.effect.state_dependent]
    if states:
        return _state_dependent_lags(data, h, taus, init, factor, states, values, cache)[0]
    return varying_lag_states(data.sampling, h, taus[None, :] * factor, hold=data.hold, initial=init)


def _same_array(kept: np.ndarray, given: np.ndarray) -> bool:
    """``given`` is the array ``kept`` or holds the same values (the identity checked first:
    a fit passes the same creep input again and again)."""
    return kept is given or np.array_equal(kept, given)


def _same_lag_inputs(last, h, key) -> bool:
    (h0, (taus0, init0, own0)), (taus, init, own) = last, key
    if isinstance(init0, str) or isinstance(init, str):
        same_init = isinstance(init0, str) and isinstance(init, str) and init0 == init
    else:
        same_init = np.array_equal(init0, init)
    try:
        same_own = bool(own0 == own)
    except ValueError:          # an array-valued parameter: no reuse
        same_own = False
    return same_init and same_own and np.array_equal(taus0, taus) and _same_array(h0, h)


#: Lag states shared by every fit of the process (the candidate effects of a diagnosis all
#: start from the same time constants): the last few, by their inputs.
_SHARED: dict = {}
_SHARED_SIZE = 8
_SHARED_LOCK = threading.Lock()          # a fleet's worker runs units on several threads


def _fingerprint(x: np.ndarray) -> tuple:
    """A few numbers that tell arrays apart cheaply (a match is confirmed in full)."""
    x = np.asarray(x)
    return (len(x), float(x[0]), float(x[len(x) // 2]), float(x[-1]), float(x.sum())) if len(x) else (0,)


def _lag_key(data: Data, h, taus, init) -> tuple:
    init_key = init if isinstance(init, str) else np.asarray(init, float).tobytes()
    return (_fingerprint(data.time), _fingerprint(h), np.asarray(taus, float).tobytes(),
            init_key, data.hold, compiled_active())     # (numpy's and the compiled lags differ by rounding)


def _shared_lags(data: Data, h, key: tuple):
    """Lag states of plain lags computed before for the same inputs (None: not held), by
    their :func:`_lag_key`."""
    with _SHARED_LOCK:
        hit = _SHARED.get(key)
    if hit is not None and _same_array(hit[0], data.time) and _same_array(hit[1], h):
        return hit[2]
    return None


def _share_lags(data: Data, h, key: tuple, lags) -> None:
    lags.flags.writeable = False          # shared: nobody may change them
    with _SHARED_LOCK:
        while len(_SHARED) >= _SHARED_SIZE:
            _SHARED.pop(next(iter(_SHARED)))
        _SHARED[key] = (data.time, np.asarray(h), lags)


def _stack(parts) -> np.ndarray:
    """Columns (1-D arrays, or 2-D blocks of them) side by side, column-major: every column
    is contiguous, to fill and to use one at a time."""
    parts = [p[:, None] if p.ndim == 1 else p for p in parts]
    out = np.empty((len(parts[0]), sum(p.shape[1] for p in parts)), order="F")
    at = 0
    for p in parts:
        out[:, at:at + p.shape[1]] = p
        at += p.shape[1]
    return out


#: Results of an effect's stage (:func:`_staged`) a fitting problem keeps.
_STAGED_KEPT = 8


def _staged(cache: dict | None, stage: str, applied, own: dict, given: np.ndarray, make):
    """What ``make()`` gives: the effect's ``stage`` (a method of :data:`_STAGES`) of the array
    ``given`` at its own parameter values ``own``, kept in a fitting problem's ``cache`` for
    the last few of them: a time constant's start grid, or the difference of another
    parameter, evaluates the same delayed load again and again. The result is read-only."""
    if cache is None or not _overrides(type(applied.effect), stage):
        return make()                       # (no cache, or the stage's default: nothing done)
    try:
        key = (stage, applied, tuple(sorted(own.items())))
        hash(key)
    except TypeError:                       # an array-valued parameter: not kept
        return make()
    kept = cache.setdefault("staged", {})
    hit = kept.get(key)
    if hit is not None and hit[0] is given:
        return hit[1]
    out = make()
    if isinstance(out, np.ndarray) and out is not given:
        out.flags.writeable = False
    while len(kept) >= _STAGED_KEPT:
        kept.pop(next(iter(kept)))
    kept[key] = (given, out)
    return out


def _ones(t: np.ndarray, cache: dict | None) -> np.ndarray:
    """The offset's column for the sample times ``t`` (read-only; kept in a fitting problem's
    ``cache``)."""
    ones = None if cache is None else cache.get("ones")
    if ones is None or len(ones) != len(t):
        ones = np.ones_like(t)
        ones.flags.writeable = False
        if cache is not None:
            cache["ones"] = ones
    return ones


def basis(data: Data, structure: Structure, values: dict, cache: dict | None = None,
          step_times: bool = False) -> Basis:
    """Evaluate the model's linear basis for given nonlinear parameter values (``step_times``:
    with the record's unknown step times, as :func:`with_step_times` adds them)."""
    t = data.time
    effects = structure.effects
    own = [a.own(values) for a in effects]
    x = data.load
    for a, p in zip(effects, own):
        x = _staged(cache, "load_transform", a, p, x, lambda: a.effect.load_transform(data, x, p, a))
    s = x
    for a, p in zip(effects, own):
        s = _staged(cache, "instant", a, p, s, lambda: a.effect.instant(data, s, p, a))
    h = s
    for a, p in zip(effects, own):
        h = a.effect.creep_input(data, h, p, a)
    taus = taus_of(values, structure.n_terms)
    init = data.lag_initial(h, taus, values)
    dynamic = [a for a in effects if a.effect.changes_lags]
    # the lags depend on h, taus, the initial state and the lag-changing effects' parameters
    # only: a step in any other parameter (an effect's own columns, a finite-difference step)
    # reuses the last ones
    key = (taus, init, [p for a, p in zip(effects, own) if a.effect.changes_lags])
    last = None if cache is None else cache.get("lags")
    if last is not None and _same_lag_inputs(last[0], h, key):
        lags = last[1]
    else:
        shared = None if dynamic else _lag_key(data, h, taus, init)
        lags = None if dynamic else _shared_lags(data, h, shared)
        if lags is None:
            lags = _lags(data, h, taus, init, dynamic, values, cache)
            if not dynamic:
                _share_lags(data, h, shared, lags)
        if cache is not None:
            cache["lags"] = ((h, key), lags)
    cols, names = [], []
    if not data.fixed_offset:
        cols.append(_ones(t, cache))
        names.append("offset")
    cols.append(s)
    names.append("gain")
    for k in range(len(taus)):
        cols.append(lags[:, k])
        names.append(f"a[{k}]")
    for a, p in zip(effects, own):
        for name, col in a.effect.columns(data, s, h, lags, p, a).items():
            cols.append(col)
            names.append(f"{a.name}.{name}")
    straddling = [_staged(cache, "straddling", a, p, data.time, lambda: a.effect.straddling(data, p, a))
                  for a, p in zip(effects, own)]
    straddling = np.unique(np.concatenate(straddling)) if any(len(i) for i in straddling) else _NO_SAMPLES
    block = _step_time_block(data, h, taus, cache) if step_times else None
    if block is None:
        return Basis(_stack(cols), tuple(names), x, s, h, lags, straddling=straddling)
    # (stacked once with the step-time columns: the basis is the fit's largest array)
    step_cols, step_names, bounds, mids = block
    first = len(cols)
    return Basis(_stack(cols + [step_cols]), tuple(names) + step_names, x, s, h, lags,
                 step_bounds=tuple((first + i, k, half) for i, k, half in bounds), step_mids=mids,
                 straddling=straddling)


#: A change of the creep input across a load step's interval within this share of its largest
#: value is rounding: the input does not step there.
_ROUNDING = 1e-12


def with_step_times(data: Data, b: Basis, taus: np.ndarray, cache: dict | None = None) -> Basis:
    """The basis with the record's unknown step times: a load step between two samples
    happened anywhere between them, but the lags are driven by the load taken linear between
    samples, which for a lag much slower than the sampling is a step at the interval's middle.
    A step ``delta`` later than that changes the signal after it by ``-a_k dh delta / tau_k
    exp(-(t - t_mid) / tau_k)`` in term ``k`` (to first order). All steps later by the same
    time is what gain and creep amplitude absorb already (the sum of these columns is a
    combination of the load and the lag states), so the first step is the reference: one
    column per later step and term, whose coefficient the solver bounds by ``|a_k|`` times
    the half intervals of that step and the first (:attr:`Basis.step_bounds`). Only with the
    load linear between samples. With a ``cache`` (one per fitting problem), the steps and
    the last columns (for the same time constants and creep input) are kept."""
    block = _step_time_block(data, b.creep_input, taus, cache)
    if block is None:
        return b
    cols, names, bounds, mids = block
    first = b.columns.shape[1]
    return replace(b, columns=_stack([b.columns, cols]), names=b.names + names,
                   step_bounds=tuple((first + i, k, half) for i, k, half in bounds), step_mids=mids)


def _step_time_block(data: Data, h: np.ndarray, taus: np.ndarray, cache: dict | None) -> tuple | None:
    """The step-time columns of :func:`with_step_times` for the creep input ``h``: ``(columns,
    names, bounds, middles)``, each bound ``(i, k, half width)`` with ``i`` the column's place
    in the block; None when there are none (no lags, or fewer than two load steps)."""
    if len(taus) == 0:
        return None
    t = data.time
    if cache is None:
        cache = {}
    steps = cache.get("load_steps")
    if steps is None:
        steps = load_steps(data) if data.hold == "linear" else np.zeros(0, int)
        cache["load_steps"] = steps
    if len(steps) < 2:
        return None
    key = (np.asarray(taus, float).tobytes(), compiled_active())    # (the decays of either way)
    last = cache.get("step_times")
    if last is not None and last[0] == key and _same_array(last[1], h):
        return last[2]
    later = steps[1:]
    middles = 0.5 * (t[later] + t[later + 1])
    dh = h[later + 1] - h[later]
    dh[np.abs(dh) <= _ROUNDING * float(np.abs(h).max())] = 0.0   # no step of the creep input here (a delayed load): an empty column
    # the decays of these time constants (kept: an effect's own parameters move the creep
    # input's steps, not the time constants), each column scaled by its step
    kept = cache.setdefault("step_decay_columns", {})
    scales = (-dh[:, None] / np.asarray(taus, float)[None, :]).reshape(-1)
    size = len(t) * len(later) * len(taus)
    small = size <= _STEP_DECAYS_KEPT_VALUES
    unit = kept.get(key)
    if unit is not None:
        cols = unit * scales
    else:
        unit = decay_columns(data.sampling, later + 1, middles, taus, np.ones((len(later), len(taus))))
        if small:
            while kept and (len(kept) >= _STEP_DECAYS_KEPT
                            or sum(u.size for u in kept.values()) + size > _STEP_DECAYS_KEPT_VALUES):
                kept.pop(next(iter(kept)))
            kept[key] = unit
            cols = unit * scales
        else:
            cols = unit                     # (not kept: scaled in place)
            cols *= scales
    labels = cache.get(("step_time_labels", len(taus)))
    if labels is None:
        labels = _step_time_labels(t, steps, middles, len(taus))
        cache[("step_time_labels", len(taus))] = labels
    block = (cols,) + labels
    if small:
        cache["step_times"] = (key, h, block)
    else:
        cache.pop("step_times", None)
    return block


def _step_time_labels(t: np.ndarray, steps: np.ndarray, middles: np.ndarray, n_terms: int) -> tuple:
    """Names, bounds and middles of the step-time columns of :func:`_step_time_block` (they
    depend on the sample times and the load steps alone)."""
    names, bounds, mids = [], [], []
    reference = 0.5 * float(t[steps[0] + 1] - t[steps[0]])
    for j, i in enumerate(steps[1:], start=1):
        for k in range(n_terms):
            names.append(f"step_time[{j}][{k}]")
            bounds.append((len(bounds), k, 0.5 * float(t[i + 1] - t[i]) + reference))
            mids.append(float(middles[j - 1]))
    return tuple(names), tuple(bounds), tuple(mids)


#: Sets of time constants whose step-time decays a fitting problem keeps (:func:`_step_time_block`).
_STEP_DECAYS_KEPT = 4
#: Most values (samples times columns) of the step-time decays a fitting problem keeps in all:
#: a record of many load steps has hundreds of step-time columns per term, its largest arrays
#: (a reduced record of 50,000 samples and 200 steps: 80 MB per term), and decays kept for
#: several sets of time constants, and the last block besides, multiplied a fit's memory. Larger
#: ones are made again when asked for.
_STEP_DECAYS_KEPT_VALUES = 5_000_000


def basis_derivatives(data: Data, structure: Structure, values: dict, b: Basis, params,
                      with_effects: bool = False,
                      cache: dict | None = None) -> list[list[tuple[int, np.ndarray]]] | None:
    """Derivatives of the basis by the nonlinear parameters.

    Analytic for a time constant or an initial state of lags that no effect changes: a time
    constant moves its lag column (derivatives by the lags' own recursion,
    :func:`~creepcomp.lti.lag_tau_derivatives`) and its step-time columns
    (:func:`with_step_times`); an initial state moves its lag column; an effect's columns
    that read the lags (:attr:`Effect.columns_from_lags`) move with them (a difference of
    those columns along the lags' derivative). Lags whose time constants depend on their
    own state: by a forward-mode recursion (:func:`_state_dependent_derivatives`). Any other
    parameter (an effect's own, or a time constant of lags another effect changes) moves the
    columns by a forward difference of the basis alone (:func:`_column_differences`).

    Parameters
    ----------
    data, structure, values, b
        The record, the model, the values at which ``b`` is the basis.
    params : sequence of Param
        The parameters to differentiate by.
    with_effects : bool
        Also for a structure that applies effects (default: None for it).
    cache : dict, optional
        The fitting problem's cache (:func:`basis`), for the differences.

    Returns
    -------
    list of list of (int, numpy.ndarray) or None
        Per parameter of ``params``, the columns it moves: (column index, that column's
        derivative by the parameter's search coordinate); None when the structure applies
        effects and ``with_effects`` is False.
    """
    if structure.effects and not with_effects:
        return None
    t, h = data.time, b.creep_input
    taus = taus_of(values, structure.n_terms)
    dynamic = [a for a in structure.effects if a.effect.changes_lags]
    if dynamic and all(a.effect.state_dependent for a in dynamic):
        return _state_dependent_derivatives(data, structure, values, b, params, dynamic, cache)
    plain_lags = not dynamic
    slope = _initial_slope(data, h, taus)
    needs_tau = plain_lags and any(p.name.startswith("tau[") for p in params)
    dtau = lag_tau_derivatives(data.sampling, h, taus, b.lags, data.hold, slope) if needs_tau else None
    steps: dict[int, list[tuple[int, float]]] = {}
    for (col, k, _), mid in zip(b.step_bounds, b.step_mids):
        steps.setdefault(k, []).append((col, mid))
    out = []
    for p in params:
        if not (plain_lags and p.name.startswith(("tau[", "c0["))):
            if not structure.effects:
                return None
            out.append(_column_differences(data, structure, values, b, p, cache))
            continue
        k = int(p.name[p.name.index("[") + 1:-1])
        column = b.names.index(f"a[{k}]")
        if p.name.startswith("tau["):
            lag = dtau[:, k] * taus[k]          # search coordinate: log tau
            moves = [(column, lag)]
            moves += [_StepTimeMove(col, b.columns[:, col], t, mid, taus[k]) for col, mid in steps.get(k, ())]
        else:
            lag = decay(t - t[0], taus[k]) * p.scale
            moves = [(column, lag)]
        if structure.effects:
            lags = np.zeros_like(b.lags)
            lags[:, k] = lag
            moves += _lag_reading_moves(data, structure, values, b, lags)
        out.append(moves)
    return out


class _StepTimeMove:
    """A step-time column and its derivative by log tau, the derivative made when the pair
    is unpacked (``col, d = move``): a record of many load steps has hundreds of them per term,
    made all at once a copy of the basis's step-time columns. The column is ``-dh/tau exp(-(t
    - mid)/tau)`` (zero before its step): by log tau it is the column times ``(t - mid)/tau - 1``."""

    __slots__ = ("col", "column", "t", "mid", "tau")

    def __init__(self, col: int, column: np.ndarray, t: np.ndarray, mid: float, tau: float):
        self.col, self.column, self.t, self.mid, self.tau = col, column, t, mid, tau

    def __iter__(self):
        yield self.col
        yield self.column * ((self.t - self.mid) / self.tau - 1.0)


def _initial_slope(data: Data, h: np.ndarray, taus: np.ndarray) -> np.ndarray | None:
    """``d c_k[0] / d tau_k`` of the lags' initial state (None: it does not depend on tau)."""
    if data.initial != "step":
        return None
    since = data.t0 - data.load_step_at
    return -h[0] * np.exp(-since / taus) * since / taus ** 2


def _step_taus(data: Data, h, lags, taus, effects, values) -> np.ndarray:
    """The time constants of the lags over each sample step, shape (N-1, K), that the
    ``state_dependent`` ``effects`` give for these lag states (the modes of
    :func:`_state_dependent_lags`, found again on the same segments)."""
    n = len(h)
    out = np.empty((n - 1, len(taus)))
    start = 0
    while start < n - 1:
        end = min(start + _SEGMENT, n - 1)
        factor = np.ones((end - start, len(taus)))
        for a in effects:
            factor = factor * a.effect.tau_factor(data, h[start:end + 1], lags[start:end + 1], taus,
                                                  a.own(values), a)
        out[start:end] = factor
        start = end
    return out * taus[None, :]


#: The stages of the signal path through which an effect's parameters enter the basis.
_STAGES = ("load_transform", "instant", "creep_input", "tau_factor", "columns", "straddling")


def _enters_only(effect, stage: str) -> bool:
    """The effect's parameters enter the basis through ``stage`` alone (it keeps the
    default, "no change", of every other stage of :data:`_STAGES`)."""
    return _class_enters_only(type(effect), stage)


@functools.lru_cache(maxsize=None)
def _overrides(kind: type, stage: str) -> bool:
    """The effect class replaces the default of ``stage`` (where the base-most class has it)."""
    first = [c for c in kind.__mro__ if stage in vars(c)][-1]
    return getattr(kind, stage) is not vars(first)[stage]


@functools.lru_cache(maxsize=None)
def _class_enters_only(kind: type, stage: str) -> bool:
    for other in _STAGES:
        if other == stage:
            continue
        if _overrides(kind, other):
            return False
    return True


def _lags_only(effect) -> bool:
    """The effect changes nothing but the lags' time constants (its parameters enter the
    basis through :meth:`tau_factor` alone)."""
    return _enters_only(effect, "tau_factor")


def _state_dependent_derivatives(data: Data, structure: Structure, values: dict, b: Basis, params,
                                 dynamic, cache: dict | None) -> list[list[tuple[int, np.ndarray]]]:
    """:func:`basis_derivatives` of a structure whose lags' time constants depend on their
    state (and on no other lag-changing effect): with the modes held (they switch at
    isolated points), the time constants of the steps move with a time constant or an
    effect's own parameter (a difference of :meth:`tau_factor` alone, the lags held) and the
    lags by the forward-mode recursion :func:`~creepcomp.lti.varying_lag_derivatives`; an
    initial state moves the lags through the same recursion. Parameters that enter the basis
    elsewhere are differenced (:func:`_column_differences`)."""
    t, h = data.time, b.creep_input
    n_terms = structure.n_terms
    taus = taus_of(values, n_terms)
    step_taus = _step_taus(data, h, b.lags, taus, dynamic, values)
    slope = _initial_slope(data, h, taus)
    lag_columns = [b.names.index(f"a[{k}]") for k in range(n_terms)]
    steps: dict[int, list[tuple[int, float]]] = {}
    for (col, k, _), mid in zip(b.step_bounds, b.step_mids):
        steps.setdefault(k, []).append((col, mid))
    own = {f"{a.name}.{p.name}" for a in dynamic if _lags_only(a.effect)
           for p in a.effect.nonlinear_params(data, a)}
    out = []
    for p in params:
        is_tau, is_c0 = p.name.startswith("tau["), p.name.startswith("c0[")
        if not (is_tau or is_c0 or p.name in own):
            out.append(_column_differences(data, structure, values, b, p, cache))
            continue
        initial = np.zeros(n_terms)
        tau_slopes = np.zeros_like(step_taus)
        if is_c0:
            k = int(p.name[3:-1])
            initial[k] = p.scale
        else:
            x = p.to_search(values[p.name])
            step = DIFF_STEP * max(1.0, abs(x))
            moved = dict(values, **{p.name: p.from_search(x + step)})
            tau_slopes = (_step_taus(data, h, b.lags, taus_of(moved, n_terms), dynamic, moved)
                          - step_taus) / step
            if is_tau and slope is not None:
                k = int(p.name[4:-1])
                initial[k] = slope[k] * taus[k]
        lags = varying_lag_derivatives(data.sampling, h, step_taus, b.lags, tau_slopes, data.hold, initial)
        moves = [(col, lags[:, k]) for k, col in enumerate(lag_columns)
                 if (lags[:, k] != 0.0).any()]
        if is_tau:
            k = int(p.name[4:-1])
            for col, mid in steps.get(k, ()):
                moves.append((col, b.columns[:, col] * ((t - mid) / taus[k] - 1.0)))
        moves += _lag_reading_moves(data, structure, values, b, lags)
        out.append(moves)
    return out


#: Relative step of the differences of the basis (:func:`_column_differences`), and the
#: resolution of a parameter in a refinement (:meth:`~creepcomp.fit.solver.Problem.refine`).
DIFF_STEP = 1e-6


def _column_differences(data: Data, structure: Structure, values: dict, b: Basis, p: Param,
                        cache: dict | None) -> list[tuple[int, np.ndarray]]:
    """The columns of ``b`` that a parameter moves, and their derivatives by its search
    coordinate, by a forward difference of the basis (step :data:`DIFF_STEP` relative, away
    from the nearer bound as the optimiser steps): the basis alone is evaluated again (its
    lags reused when the parameter does not change them), not the projection."""
    x = p.to_search(values[p.name])
    step = DIFF_STEP * (1.0 if x >= 0 else -1.0) * max(1.0, abs(x))
    lo, hi = p.bounds()
    if not lo <= x + step <= hi:
        step = -step
    moved = dict(values)
    moved[p.name] = p.from_search(x + step)
    owners = [a for a in structure.effects if p.name.startswith(a.name + ".")]
    if len(owners) == 1 and _enters_only(owners[0].effect, "columns"):
        # only the owner's columns move: the rest of the basis is the same (bit for bit)
        a = owners[0]
        out = []
        for name, col in a.effect.columns(data, b.instant, b.creep_input, b.lags, a.own(moved), a).items():
            at = b.names.index(f"{a.name}.{name}")
            d = col - b.columns[:, at]
            d /= step
            if (d != 0.0).any():
                out.append((at, d))
        return out
    bp = basis(data, structure, moved, cache)
    own = bp.columns.shape[1]                  # the columns before the step times'
    diff = bp.columns - b.columns[:, :own]
    diff /= step
    out = [(col, diff[:, col]) for col in np.flatnonzero((diff != 0.0).any(axis=0))]
    taus = taus_of(moved, structure.n_terms)
    if b.step_bounds and not (np.array_equal(taus, taus_of(values, structure.n_terms))
                              and _same_array(bp.creep_input, b.creep_input)):
        # the step-time columns follow the time constants and the creep input only
        steps = _step_time_block(data, bp.creep_input, taus, cache)[0] - b.columns[:, own:]
        steps /= step
        out += [(own + j, steps[:, j]) for j in np.flatnonzero((steps != 0.0).any(axis=0))]
    return out


def _lag_reading_moves(data: Data, structure: Structure, values: dict, b: Basis,
                       slopes: np.ndarray) -> list[tuple[int, np.ndarray]]:
    """The effect columns that read the lag states (:attr:`Effect.columns_from_lags`) and
    their derivatives when the lags move by ``slopes`` (N, K) per unit of a parameter: a
    forward difference of those columns alone."""
    readers = [a for a in structure.effects if getattr(a.effect, "columns_from_lags", True)]
    if not readers:
        return []
    size = float(np.abs(slopes).max())
    if size == 0.0:
        return []
    step = DIFF_STEP * max(1.0, float(np.abs(b.lags).max())) / size
    lags = b.lags + step * slopes
    out = []
    for a in readers:
        own = a.own(values)
        for name, col in a.effect.columns(data, b.instant, b.creep_input, lags, own, a).items():
            at = b.names.index(f"{a.name}.{name}")
            d = (col - b.columns[:, at]) / step
            if (d != 0.0).any():
                out.append((at, d))
    return out
