"""The noise floor of a built network's record and a drift of its output's measuring chain
(circuit side of ``docs/diagnosis.md``).

The nominal network's misfit is judged against the noise of the comparison itself
(:func:`circuit_noise_floor`); a slow misfit left after the search is counted in that floor as a
drift of the measuring chain (:func:`output_drift`) only when its slow changes do not follow
what the signal drives (:func:`signal_follows`): a fault of the network is driven by the
signal, a drift of the measuring chain is not.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.special import fdtrc

from creepcomp.fit.circuit import CircuitData, CircuitFit
from creepcomp.fit.noise import (FEW_WINDOWS, FLOOR_WINDOW, MISFIT_LIMIT, NoiseFloor, misfit_ratio, noise_floor,
                                 slow_drift)
from creepcomp.lti import lag_states
from creepcomp.units import format_quantity

__all__ = ["SLOW_SHARE", "DRIFT_INDEPENDENCE_P", "DRIFT_DRIVEN_SHARE", "OutputDrift", "circuit_noise_floor",
           "floor_window", "slow_share", "signal_follows", "output_drift"]

#: A misfit left unexplained is called slow (a drift of the measuring chain would look like it)
#: when at least this share of its excess variance over the floor is slower than the floor's
#: windows (:func:`slow_share`).
SLOW_SHARE = 0.8
#: A slow misfit that no circuit effect explains is not a drift of the output's measuring
#: chain when its changes follow the signal's with a p-value under this and what follows
#: the signal makes at least :data:`DRIFT_DRIVEN_SHARE` of its excess variance over the floor
#: (:func:`signal_follows`, :func:`output_drift`).
#: Loose on purpose: a drift wrongly refused is ``unexplained``, a fault wrongly taken for
#: drift is ``none`` (a random walk is refused on 2-10 % of records, a resistor fault outside
#: the candidates at 3.3 times the floor gave p = 0.06).
DRIFT_INDEPENDENCE_P = 0.1
#: See :data:`DRIFT_INDEPENDENCE_P` (on the benchmark's records: faults outside the candidates
#: 0.5 and more, clean drifting outputs 0.04-0.41 where the test was significant).
DRIFT_DRIVEN_SHARE = 0.5


@dataclass(frozen=True)
class OutputDrift:
    """A slow drift of the output's measuring chain, counted in the noise floor
    (:func:`output_drift`).

    Attributes
    ----------
    rms, span : float
        RMS and peak-to-peak of the drift, output units.
    knot_spacing : float
        Spacing of its spline's knots, s.
    white_floor : float
        The floor without the drift (:func:`circuit_noise_floor`).
    misfit_ratio_white, misfit_ratio_without_drift : float
        The nominal network's misfit over the white floor, with the drift and once it is
        taken out.
    unit : str
        The output's unit (of ``rms`` and ``span``).
    curve : numpy.ndarray
        The drift at the record's sample times (mean included).
    """

    rms: float
    span: float
    knot_spacing: float
    white_floor: float
    misfit_ratio_white: float
    misfit_ratio_without_drift: float
    unit: str = ""
    curve: np.ndarray | None = field(default=None, compare=False, repr=False)

    def format(self, value: float) -> str:
        """A value in the output's unit (output units when the record names none)."""
        return format_quantity(value, self.unit) if self.unit else f"{value:.3g} output units"

    def to_dict(self) -> dict:
        """JSON form."""
        return {"rms": self.rms, "span": self.span, "knot_spacing": self.knot_spacing,
                "white_noise_floor": self.white_floor, "misfit_ratio_over_white_floor": self.misfit_ratio_white,
                "misfit_ratio_without_drift": self.misfit_ratio_without_drift}


def circuit_noise_floor(data: CircuitData) -> NoiseFloor:
    """The noise floor that the nominal network's misfit is judged against
    (:func:`creepcomp.fit.noise.noise_floor`, no model fitted): of the measured ``corrected``
    minus the nominal network's simulation on the measured ``signal``. The comparison's noise
    is the output's measurement noise and, where the built network saw the sensor's
    continuous signal, the signal's measurement noise as the simulation passes it; both are
    in that difference, and neither in ``corrected`` alone. Slow misfit (a wrong part) is
    what each window's quadratic takes up.

    The windows span half the network's fastest time constant (at least
    :data:`~creepcomp.fit.noise.FLOOR_WINDOW` samples, and at most what leaves
    2 x :data:`~creepcomp.fit.noise.FEW_WINDOWS` windows): within that a quadratic follows any
    response of the network, nominal or faulty, to a few parts in a thousand, and noise of
    the measuring chain correlated over seconds (coloured noise of a fast-sampled record)
    stays in the floor instead of being taken for misfit. A drift over the whole record is
    still not in it."""
    nominal = data.design.network.lag_expansion().simulate(data.time, data.signal, initial="settled")
    floor = noise_floor(data.corrected - nominal, None, data.time, floor_window(data))
    return replace(floor, method="the measured corrected minus the nominal network's simulation on the "
                                 "measured signal: " + floor.method)


def floor_window(data: CircuitData) -> int:
    """Samples per window of the circuit side's noise floor (see :func:`circuit_noise_floor`)."""
    taus = data.design.network.lag_expansion().taus
    span = 0.5 * min(taus) / data.dt_median if taus else 0.0
    return int(min(max(round(span), FLOOR_WINDOW), max(data.n // (2 * FEW_WINDOWS), FLOOR_WINDOW)))


def slow_share(residual: np.ndarray, floor: NoiseFloor, window: int = FLOOR_WINDOW) -> float | None:
    """Share of a residual's variance above the noise floor that is slower than the floor's
    windows: the variance of its moving average over a window (less the floor's part that
    passes the average, ``floor**2 / window``) over its excess variance ``rms**2 - floor**2``,
    clipped to [0, 1] (None when there is no excess; ``window``: the floor's, in samples). The
    floor takes up everything that slow within its windows (a drift of the measuring chain too), so a misfit above the floor
    that is mostly this slow is drift or a slow fault, not faster structure."""
    excess = float(np.mean(residual ** 2)) - floor.rms ** 2
    w = int(min(window, max(8, len(residual) // 4)))
    if excess <= 0 or len(residual) < 2 * w:
        return None
    average = np.convolve(residual, np.ones(w) / w, mode="valid")
    slow = float(np.mean(average ** 2)) - floor.rms ** 2 / w
    return float(min(1.0, max(0.0, slow / excess)))


def signal_follows(data: CircuitData, residual: np.ndarray, window: int,
                   floor: NoiseFloor) -> tuple[float, float | None]:
    """How far a residual's slow changes follow the signal: (p-value, driven share).

    The residual's means over blocks of ``window`` samples are regressed on the block means
    of what the signal drives -- the signal, the nominal network's output, and first-order
    lags of the signal at a third, one and three times each of the network's time
    constants -- all differenced from block to block (the increments of a random-walk
    drift are independent of the signal's; its levels would correlate spuriously with any
    slow input). The p-value is that regression's F test; the driven share is the variance
    of the fitted combination of the regressors (in levels, sample by sample) over the
    residual's excess variance above ``floor`` (None without excess). A long record makes
    even a tiny correlation significant, hence the share. (0, 1) when there are too few
    blocks to tell."""
    network = data.design.network.lag_expansion()
    taus = sorted({round(math.log(f * t), 1) for t in network.taus for f in (1 / 3, 1.0, 3.0)})
    columns = [data.signal, network.simulate(data.time, data.signal, initial="settled")]
    if taus:
        states = lag_states(data.time, data.signal, np.exp(taus), initial="settled")
        columns.extend(states.T)
    levels = np.column_stack(columns)
    blocks = len(residual) // max(int(window), 1)
    if blocks - 1 < levels.shape[1] + 10:
        return 0.0, 1.0
    means = np.asarray(residual, float)[:blocks * window].reshape(blocks, window).mean(axis=1)
    x = np.diff(levels[:blocks * window].reshape(blocks, window, -1).mean(axis=1), axis=0)
    scale = np.maximum(np.sqrt(np.mean(x ** 2, axis=0)), 1e-300)
    y = np.diff(means)
    coef, *_ = np.linalg.lstsq(x / scale, y, rcond=None)
    rank = np.linalg.matrix_rank(x / scale)
    fitted = (x / scale) @ coef
    rss = float(np.sum((y - fitted) ** 2))
    dof = len(y) - rank
    if rank == 0 or dof <= 0 or rss <= 0:
        return 0.0, 1.0
    # (the F distribution's survival function, as scipy.stats has it: 0.3 s less to import)
    p = float(fdtrc(rank, dof, (float(np.sum(fitted ** 2)) / rank) / (rss / dof)))
    driven = (levels / scale) @ coef
    excess = float(np.mean(np.asarray(residual, float) ** 2)) - floor.rms ** 2
    share = float(np.var(driven) / excess) if excess > 0 else None
    return p, share


def output_drift(data: CircuitData, fit: CircuitFit, floor: NoiseFloor, unit: str = "") -> OutputDrift | None:
    """A drift of the output's measuring chain that explains the misfit of ``fit`` above the
    floor, or None.

    The slow part of the residual (:func:`~creepcomp.fit.noise.slow_drift`, knots one slowest
    time constant of the network apart, but at least 8 and at most 100 intervals over the
    record, so that a drift over the whole record can be followed) is the drift when,
    taken out, it leaves a misfit ratio of at most :data:`~creepcomp.fit.noise.MISFIT_LIMIT`.
    Called only when no circuit effect and no generic lag is supported, and a drift only
    when the residual's slow changes do not follow the signal's (:func:`signal_follows`: not
    both a p-value under :data:`DRIFT_INDEPENDENCE_P` and a driven share of at least
    :data:`DRIFT_DRIVEN_SHARE`): a fault outside the templates is driven by the signal, a
    drift of the measuring chain is not."""
    ratio = misfit_ratio(fit.rms, floor)
    if ratio is None or ratio <= MISFIT_LIMIT or data.n < 64:
        return None
    span = float(data.time[-1] - data.time[0])
    taus = data.design.network.lag_expansion().taus
    spacing = max(min(max(taus) if taus else span, span / 8), span / 100)
    slow = slow_drift(fit.residual, data.time, spacing)
    left = misfit_ratio(float(np.sqrt(np.mean((fit.residual - slow) ** 2))), floor)
    if left > MISFIT_LIMIT:
        return None
    p, share = signal_follows(data, fit.residual, floor_window(data), floor)
    if p < DRIFT_INDEPENDENCE_P and (share is None or share >= DRIFT_DRIVEN_SHARE):
        return None
    drift = slow - np.mean(slow)
    return OutputDrift(float(np.sqrt(np.mean(drift ** 2))), float(np.ptp(drift)), spacing, floor.rms, ratio, left,
                       unit, slow)
