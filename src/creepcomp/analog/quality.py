"""Predicted quality of a correction: residual creep after a load step, sweep hysteresis.

Residual creep is the corrected output relative to its ideal, creep-free value,
``y(t) / (H(inf) G(inf) S_ins) - 1``: for a step, the output's drift after the
instantaneous jump, as a fraction of that jump. With the paper's rule it moves from 0 to
``beta0^2 / (1 + 2 beta0)`` (``docs/physics.md``, section 3); with the exact rule it stays at 0.

The reported figures come from python-control (exact discretisation of the cascade
``H(s) G(s)`` on uniform segments); between grid points the peak is refined with the closed
form :func:`residual_curves`, which also screens many candidate designs at once. The tests
hold the two together.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import control
import numpy as np
from scipy import linalg, optimize

from creepcomp.lti import LagExpansion, cascade_step_arrays
from creepcomp.model import CreepModel
from creepcomp.network import Network

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


def corrected_system(model: CreepModel, network: Network | None) -> control.StateSpace:
    """The cascade ``H(s) G(s)`` (or ``G(s)`` alone when ``network`` is None)."""
    G = model.state_space()
    return G if network is None else control.series(G, network.state_space())


def _ideal_gain(model: CreepModel, network: Network | None) -> float:
    hf = model.lag_expansion().hf_gain
    return hf if network is None else hf * network.lag_expansion().hf_gain


def _dc_gain(model: CreepModel, network: Network | None) -> float:
    dc = model.lag_expansion().dc_gain
    return dc if network is None else dc * network.lag_expansion().dc_gain


def _segment_ends(sys: control.StateSpace) -> list[float]:
    """End times of uniform grid segments, one per decade-separated time constant."""
    taus = np.sort(-1.0 / np.real(np.linalg.eigvals(sys.A)))
    ends: list[float] = []
    for tau in taus:
        end = SEGMENT_SPAN * tau
        if ends and end < 3.0 * ends[-1]:
            ends[-1] = max(ends[-1], end)
        else:
            ends.append(end)
    return ends


def step_residual(model: CreepModel, network: Network | None = None):
    """Residual creep after a unit load step, computed with python-control.

    Returns
    -------
    time : numpy.ndarray
        Times after the step (s), on uniform segments that resolve every time constant.
    residual : numpy.ndarray
        ``y / y_ideal - 1`` at those times.
    states : numpy.ndarray
        The cascade's states there (for exact evaluation in between).
    """
    sys = corrected_system(model, network)
    ideal = _ideal_gain(model, network)
    x0 = np.zeros(sys.nstates)
    t0 = 0.0
    times, outs, states = [], [], []
    for end in _segment_ends(sys):
        grid = np.linspace(0.0, end - t0, SEGMENT_POINTS)
        r = control.forced_response(sys, grid, np.ones_like(grid), X0=x0, return_x=True)
        times.append(grid + t0)
        outs.append(np.atleast_1d(r.outputs))
        states.append(np.atleast_2d(r.states).T)
        x0 = states[-1][-1]
        t0 = end
    time = np.concatenate(times)
    keep = np.concatenate([[True], np.diff(time) > 0])
    return time[keep], np.concatenate(outs)[keep] / ideal - 1.0, np.concatenate(states)[keep]


def _refine_peak(model: CreepModel, network: Network | None, time, residual) -> tuple[float, float]:
    """Largest |residual| near the grid's largest, between its neighbours, from the exact
    closed form (:func:`residual_curves`)."""
    k = int(np.argmax(np.abs(residual)))
    lo, hi = max(k - 1, 0), min(k + 1, len(time) - 1)
    if hi == lo:
        return float(abs(residual[k])), float(time[k])
    lags = _lag_arrays(network) if network is not None else (np.ones(1), np.zeros((1, 0)), np.ones((1, 0)))

    def neg_abs(t):
        return -abs(residual_curves(model, *lags, np.array([t]))[0, 0])

    res = optimize.minimize_scalar(neg_abs, bounds=(time[lo], time[hi]), method="bounded",
                                   options={"xatol": 1e-9 * max(time[hi], 1.0)})
    best = max((-res.fun, res.x), (abs(residual[k]), time[k]))
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
    period = default_sweep_period(model) if period is None else float(period)
    sys = corrected_system(model, network)
    ideal = _ideal_gain(model, network)
    m = SWEEP_QUARTER_POINTS
    t = np.linspace(0.0, period, 4 * m + 1)
    q = np.arange(4 * m + 1)
    load = np.where(q <= m, q / m, np.where(q <= 3 * m, 2.0 - q / m, q / m - 4.0))
    one_period = control.forced_response(sys, t, load, X0=np.zeros(sys.nstates), return_x=True)
    gamma = np.atleast_2d(one_period.states)[:, -1]
    phi = linalg.expm(np.asarray(sys.A) * period)
    x0 = np.linalg.solve(np.eye(sys.nstates) - phi, gamma)
    y = np.atleast_1d(control.forced_response(sys, t, load, X0=x0).outputs) / ideal
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
    """Peak and final residual creep after a load step (python-control grid, exact refinement).

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
    time, residual, _ = step_residual(model, network)
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
    period = default_sweep_period(model) if sweep_period is None else float(sweep_period)
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


def _lag_arrays(network: Network):
    lag = network.lag_expansion()
    return np.array([lag.direct]), np.array([lag.gains]), np.array([lag.taus])


def screening_deviation(model: CreepModel, direct, gains, taus,
                        reference: Network | None = None) -> np.ndarray:
    """Peak ``|e(t) - e_ref(t)|`` of many networks after a load step (closed form).

    ``e`` is the residual creep; ``e_ref`` is that of ``reference`` (zero when None, so the
    result is the peak residual creep). Evaluated on a log grid plus the settled value.
    """
    t = screening_times(model)
    curves = residual_curves(model, direct, gains, taus, t)
    g = model.lag_expansion()
    final = g.dc_gain * (direct + gains.sum(axis=1)) / (g.hf_gain * direct) - 1.0
    if reference is not None:
        ref = _lag_arrays(reference)
        curves = curves - residual_curves(model, *ref, t)
        final = final - (g.dc_gain * (ref[0] + ref[1].sum(axis=1)) / (g.hf_gain * ref[0]) - 1.0)
    return np.maximum(np.abs(curves).max(axis=1), np.abs(final))


def step_deviation(model: CreepModel, network: Network, reference: Network | None = None) -> float:
    """Peak ``|e(t) - e_ref(t)|`` after a load step, ``e`` from python-control.

    With ``reference`` None this is the peak residual creep on python-control's grid.
    """
    t, e, _ = step_residual(model, network)
    final = _dc_gain(model, network) / _ideal_gain(model, network) - 1.0
    if reference is not None:
        e = e - residual_curves(model, *_lag_arrays(reference), t)[0]
        final -= _dc_gain(model, reference) / _ideal_gain(model, reference) - 1.0
    return float(max(np.abs(e).max(), abs(final)))
