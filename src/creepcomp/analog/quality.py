"""Predicted quality of a correction: residual creep after a load step, sweep hysteresis.

Residual creep is the corrected output relative to its ideal, creep-free value,
``y(t) / (H(inf) G(inf) S_ins) - 1``: for a step, the output's drift after the
instantaneous jump, as a fraction of that jump. With the paper's rule it moves from 0 to
``beta0^2 / (1 + 2 beta0)`` (``docs/physics.md``, section 3); with the exact rule it stays at 0.

The step response is the closed form :func:`residual_curves` (which also screens many
candidate designs at once) on uniform segments that resolve every time constant, its peak
refined between grid points; the sweep is the exact discretisation of the cascade
``H(s) G(s)`` for a load ramping linearly between samples (first-order hold), the method
python-control's ``forced_response`` uses. python-control itself is the independent check:
the tests hold both figures against it, and ``creepcomp simulate`` against ngspice. (Only
:func:`corrected_system` imports it, when called: its import costs more than a whole
``creepcomp size``.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from creepcomp.lti import cascade_matrices, cascade_step_arrays
from creepcomp.model import CreepModel
from creepcomp.network import Network
from creepcomp.errors import InputError
from creepcomp.units import check_number, format_quantity

if TYPE_CHECKING:
    import control

__all__ = ["Quality", "SEGMENT_POINTS", "SEGMENT_SPAN", "SWEEP_QUARTER_POINTS",
           "default_sweep_period", "corrected_system", "step_residual", "sweep_hysteresis",
           "sweep_branches", "step_peak", "predict", "screening_times", "residual_curves",
           "screening_deviation", "step_deviation", "SWEEP_SPAN", "check_sweep_period"]

#: Points per uniform segment of the step-response grid.
SEGMENT_POINTS = 801
#: A segment ends at this many times its time constant.
SEGMENT_SPAN = 25.0
#: Points per quarter period of the hysteresis sweep.
SWEEP_QUARTER_POINTS = 250


@dataclass(frozen=True)
class Quality:
    """Predicted figures of merit of a corrected (or uncorrected) sensor.

    Attributes
    ----------
    residual_creep_peak : float
        Largest ``|y / y_ideal - 1|`` after a load step (fraction of the step).
    residual_creep_final : float
        ``y / y_ideal - 1`` once all creep has settled (signed fraction).
    residual_creep_peak_time : float
        When the peak occurs (s after the step; ``inf`` when it is the final value).
    hysteresis : float
        Largest gap between the up and down branches of a triangular sweep between
        -FS and +FS, as a fraction of the full-scale output, in periodic steady state.
    sweep_period : float
        Period of that sweep (s).
    """

    residual_creep_peak: float
    residual_creep_final: float
    residual_creep_peak_time: float
    hysteresis: float
    sweep_period: float

    def to_dict(self) -> dict:
        """JSON form (fractions and seconds)."""
        peak_time = self.residual_creep_peak_time
        return {"residual_creep_peak": self.residual_creep_peak,
                "residual_creep_final": self.residual_creep_final,
                "residual_creep_peak_time": None if math.isinf(peak_time) else peak_time,
                "hysteresis": self.hysteresis,
                "sweep_period": self.sweep_period}


def default_sweep_period(model: CreepModel) -> float:
    """``2 pi tau`` of the largest creep term: the sweep rate that maximises a single
    term's hysteresis (``omega tau = 1``)."""
    k = int(np.argmax(np.abs(model.beta)))
    return 2.0 * math.pi * model.tau[k]


#: Sweep periods the hysteresis is computed for, as multiples of the creep's shortest and
#: longest time constants: far outside, the sweep is a step or a standstill and shows no
#: hysteresis (and the periodic solution's matrix is singular to float64).
SWEEP_SPAN = (1e-6, 1e6)


def check_sweep_period(model: CreepModel, period) -> float:
    """``period`` (s) as a float, within :data:`SWEEP_SPAN` of the model's time constants.

    Raises
    ------
    InputError
        Naming the period and the range that suits ``model``.
    """
    low, high = SWEEP_SPAN[0] * min(model.tau), SWEEP_SPAN[1] * max(model.tau)
    value = check_number(period, "sweep period")
    if not low <= value <= high:
        raise InputError(f"sweep period {format_quantity(value, 's')}: use "
                         f"{format_quantity(low, 's')} to {format_quantity(high, 's')} (a "
                         "millionth to a million times the creep's time constants)")
    return value


def corrected_system(model: CreepModel, network: Network | None) -> "control.StateSpace":
    """The cascade ``H(s) G(s)`` (or ``G(s)`` alone when ``network`` is None) in python-control."""
    import control

    G = model.state_space()
    return G if network is None else control.series(G, network.state_space())


def _cascade(model: CreepModel, network: Network | None):
    """State-space matrices of ``H(s) G(s)`` (``G(s)`` alone when ``network`` is None)."""
    g = model.lag_expansion()
    if network is None:
        return g.matrices()
    return cascade_matrices(g, network.lag_expansion())


def _ideal_gain(model: CreepModel, network: Network | None) -> float:
    hf = model.lag_expansion().hf_gain
    return hf if network is None else hf * network.lag_expansion().hf_gain


def _dc_gain(model: CreepModel, network: Network | None) -> float:
    dc = model.lag_expansion().dc_gain
    return dc if network is None else dc * network.lag_expansion().dc_gain


def _segment_ends(taus) -> list[float]:
    """End times of uniform grid segments, one per decade-separated time constant."""
    taus = np.sort(np.asarray(taus, dtype=float))
    ends: list[float] = []
    for tau in taus:
        end = SEGMENT_SPAN * tau
        if ends and end < 3.0 * ends[-1]:
            ends[-1] = max(ends[-1], end)
        else:
            ends.append(end)
    return ends


def step_residual(model: CreepModel, network: Network | None = None):
    """Residual creep after a unit load step (closed form :func:`residual_curves`).

    Returns
    -------
    time : numpy.ndarray
        Times after the step (s), on uniform segments that resolve every time constant.
    residual : numpy.ndarray
        ``y / y_ideal - 1`` at those times.
    """
    lags = _lag_arrays(network)
    ends = _segment_ends(np.concatenate([model.tau, lags[2][0]]))
    starts = [0.0] + ends[:-1]
    time = np.concatenate([np.linspace(0.0, end - t0, SEGMENT_POINTS) + t0
                           for t0, end in zip(starts, ends)])
    time = time[np.concatenate([[True], np.diff(time) > 0])]
    return time, residual_curves(model, *lags, time)[0]


def _golden_max(f, lo: float, hi: float, xatol: float) -> tuple[float, float]:
    """Largest value of a unimodal ``f`` on ``[lo, hi]`` by golden-section search."""
    ratio = (math.sqrt(5.0) - 1.0) / 2.0
    a, b = lo, hi
    c, d = b - ratio * (b - a), a + ratio * (b - a)
    fc, fd = f(c), f(d)
    while b - a > xatol:
        if fc >= fd:
            b, d, fd = d, c, fc
            c = b - ratio * (b - a)
            fc = f(c)
        else:
            a, c, fc = c, d, fd
            d = a + ratio * (b - a)
            fd = f(d)
    return (fc, c) if fc >= fd else (fd, d)


def _refine_peak(model: CreepModel, network: Network | None, time, residual) -> tuple[float, float]:
    """Largest |residual| near the grid's largest, between its neighbours, from the exact
    closed form (:func:`residual_curves`)."""
    k = int(np.argmax(np.abs(residual)))
    lo, hi = max(k - 1, 0), min(k + 1, len(time) - 1)
    if hi == lo:
        return float(abs(residual[k])), float(time[k])
    lags = _lag_arrays(network)

    def size(t):
        return abs(residual_curves(model, *lags, np.array([t]))[0, 0])

    best = max(_golden_max(size, float(time[lo]), float(time[hi]), 1e-9 * max(time[hi], 1.0)),
               (abs(residual[k]), time[k]))
    return float(best[0]), float(best[1])


def sweep_hysteresis(model: CreepModel, network: Network | None = None,
                     period: float | None = None):
    """Hysteresis of a triangular load sweep between -FS and +FS (periodic steady state).

    Parameters
    ----------
    model : CreepModel
    network : Network or None
        None for the uncorrected sensor.
    period : float, optional
        Sweep period (s); default :func:`default_sweep_period`.

    Returns
    -------
    hysteresis : float
        Largest ``|y_down - y_up|`` at equal load, as a fraction of the ideal full-scale output.
    load, y_up, y_down : numpy.ndarray
        The two branches against load (normalised to FS and to the ideal output), for plots.
    """
    from scipy import linalg

    period = default_sweep_period(model) if period is None else check_sweep_period(model, period)
    a, b, c, d = _cascade(model, network)
    n = len(a)
    m = SWEEP_QUARTER_POINTS
    q = np.arange(4 * m + 1)
    load = np.where(q <= m, q / m, np.where(q <= 3 * m, 2.0 - q / m, q / m - 4.0))
    # first-order hold: x[k+1] = Ad x[k] + B0 u[k] + B1 u[k+1], exact for a ramping load
    dt = period / (4 * m)
    aug = np.zeros((n + 2, n + 2))
    aug[:n, :n], aug[:n, n:n + 1], aug[n, n + 1] = a * dt, b * dt, 1.0
    e = linalg.expm(aug)
    ad, b1 = e[:n, :n], e[:n, n + 1]
    b0 = e[:n, n] - b1

    def states(x0):
        x = np.empty((len(load), n))
        x[0] = x0
        for k in range(len(load) - 1):
            x[k + 1] = ad @ x[k] + b0 * load[k] + b1 * load[k + 1]
        return x

    gamma = states(np.zeros(n))[-1]
    x0 = np.linalg.solve(np.eye(n) - linalg.expm(a * period), gamma)
    y = (states(x0) @ c[0] + d[0, 0] * load) / _ideal_gain(model, network)
    load, y_up, y_down = sweep_branches(y, m)
    return float(np.abs(y_down - y_up).max()), load, y_up, y_down


def sweep_branches(y, quarter_points: int):
    """Up and down branches of one period of the triangular sweep, at equal loads.

    Parameters
    ----------
    y : array_like
        Output over one period ``0 -> +FS -> -FS -> 0``, sampled at ``4 * quarter_points + 1``
        equally spaced times (both ends included).
    quarter_points : int
        Samples per quarter period.

    Returns
    -------
    load, y_up, y_down : numpy.ndarray
        Load (fraction of FS, -1 to 1) and the rising and falling branches there.
    """
    y = np.asarray(y)
    m = int(quarter_points)
    if y.shape != (4 * m + 1,):
        raise ValueError(f"one sweep period needs {4 * m + 1} samples, got {y.shape}")
    levels = np.arange(-m, m + 1)
    up = np.where(levels >= 0, levels, 4 * m + levels)        # rising: -FS -> 0 -> +FS
    down = 2 * m - levels                                      # falling: +FS -> -FS
    return levels / m, y[up], y[down]


def step_peak(model: CreepModel, network: Network | None = None) -> tuple[float, float, float]:
    """Peak and final residual creep after a load step (segment grid, exact refinement).

    Returns
    -------
    peak : float
        Largest ``|y / y_ideal - 1|``.
    peak_time : float
        When it occurs (s); ``inf`` when the peak is the settled value.
    final : float
        Settled ``y / y_ideal - 1`` (signed).
    """
    ideal = _ideal_gain(model, network)
    time, residual = step_residual(model, network)
    peak, peak_time = _refine_peak(model, network, time, residual)
    final = _dc_gain(model, network) / ideal - 1.0
    if abs(final) >= peak:
        peak, peak_time = abs(final), math.inf
    return peak, peak_time, final


def predict(model: CreepModel, network: Network | None = None,
            sweep_period: float | None = None) -> Quality:
    """Predicted residual creep and hysteresis of a design, from exact transfer functions.

    Parameters
    ----------
    model : CreepModel
        The sensor's creep.
    network : Network or None
        The correction network; None gives the uncorrected sensor.
    sweep_period : float, optional
        Period of the hysteresis sweep (s).

    Returns
    -------
    Quality
    """
    peak, peak_time, final = step_peak(model, network)
    period = (default_sweep_period(model) if sweep_period is None
              else check_sweep_period(model, sweep_period))
    hyst = sweep_hysteresis(model, network, period)[0]
    return Quality(peak, final, peak_time, hyst, period)


def screening_times(model: CreepModel, points: int = 400) -> np.ndarray:
    """Log-spaced times resolving every time scale near the model's."""
    taus = np.array(model.tau)
    return np.geomspace(taus.min() * 1e-3, taus.max() * 60.0, points)


def residual_curves(model: CreepModel, direct, gains, taus, t) -> np.ndarray:
    """Closed-form residual creep ``y / y_ideal - 1`` of many networks at once.

    Parameters
    ----------
    model : CreepModel
    direct, gains, taus : numpy.ndarray, shapes (B,), (B, n), (B, n)
        Sum-of-lags forms of the networks (see :func:`creepcomp.network.modal_form`).
    t : numpy.ndarray
        Times after the step (s).

    Returns
    -------
    numpy.ndarray, shape (B, len(t))
    """
    g = model.lag_expansion()
    y = cascade_step_arrays(np.full(len(direct), g.direct), np.broadcast_to(g.gains, (len(direct), model.n_terms)),
                            np.broadcast_to(g.taus, (len(direct), model.n_terms)), direct, gains, taus, t)
    return y / (g.hf_gain * np.asarray(direct)[:, None]) - 1.0


def _lag_arrays(network: Network | None):
    """Batch-of-one sum-of-lags arrays of a network (``H = 1`` when None)."""
    if network is None:
        return np.ones(1), np.zeros((1, 0)), np.ones((1, 0))
    lag = network.lag_expansion()
    return np.array([lag.direct]), np.array([lag.gains]), np.array([lag.taus])


#: Most values the closed-form screening computes at once (8 bytes each).
SCREENING_VALUES = 4_000_000


def screening_deviation(model: CreepModel, direct, gains, taus,
                        reference: Network | None = None) -> np.ndarray:
    """Peak ``|e(t) - e_ref(t)|`` of many networks after a load step (closed form).

    ``e`` is the residual creep; ``e_ref`` is that of ``reference`` (zero when None, so the
    result is the peak residual creep). Evaluated on a log grid plus the settled value.
    """
    t = screening_times(model)
    # the curves hold (batch, sensor terms, network lags, times) values at once: in pieces of
    # at most SCREENING_VALUES of them
    direct, gains, taus = np.asarray(direct), np.asarray(gains), np.asarray(taus)
    size = max(1, model.n_terms * gains.shape[1] * len(t))
    step = max(1, SCREENING_VALUES // size)
    if len(direct) > step:
        return np.concatenate([screening_deviation(model, direct[i:i + step], gains[i:i + step],
                                                   taus[i:i + step], reference)
                               for i in range(0, len(direct), step)])
    curves = residual_curves(model, direct, gains, taus, t)
    g = model.lag_expansion()
    final = g.dc_gain * (direct + gains.sum(axis=1)) / (g.hf_gain * direct) - 1.0
    if reference is not None:
        ref = _lag_arrays(reference)
        curves = curves - residual_curves(model, *ref, t)
        final = final - (g.dc_gain * (ref[0] + ref[1].sum(axis=1)) / (g.hf_gain * ref[0]) - 1.0)
    return np.maximum(np.abs(curves).max(axis=1), np.abs(final))


def step_deviation(model: CreepModel, network: Network, reference: Network | None = None) -> float:
    """Peak ``|e(t) - e_ref(t)|`` after a load step, on :func:`step_residual`'s grid.

    With ``reference`` None this is the peak residual creep on that grid.
    """
    t, e = step_residual(model, network)
    final = _dc_gain(model, network) / _ideal_gain(model, network) - 1.0
    if reference is not None:
        e = e - residual_curves(model, *_lag_arrays(reference), t)[0]
        final -= _dc_gain(model, reference) / _ideal_gain(model, reference) - 1.0
    return float(max(np.abs(e).max(), abs(final)))
