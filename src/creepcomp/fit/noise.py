"""The residual's noise: an autoregressive model on the sample sequence (its memory broken
at gaps), prewhitening, whiteness tests, the spectral spread of a weighted sum of noise, and
the Gaussian likelihood and information criterion of a residual."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import linalg

from creepcomp.fit.data import Data, gaps
from creepcomp.fit.normal import normal_solution
from creepcomp.lti import lag_states

__all__ = ["MAX_AR_ORDER", "SPARSE_SAMPLES", "ar_order_for", "ar_order", "is_sparse",
           "ARNoise", "rows_for", "whiten", "fit_noise", "ljung_box",
           "autocorrelation", "spectral_variance", "gaussian_bic", "FLOOR_WINDOW", "FEW_WINDOWS", "MISFIT_LIMIT",
           "NoiseFloor", "noise_floor", "quantisation_step", "misfit_ratio", "explained_share",
           "slow_drift", "none_statement", "with_reference_noise", "REFERENCE_SHARE"]

#: Largest order of the autoregressive noise model.
MAX_AR_ORDER = 5
#: Records of fewer samples are sparse: their noise is taken as white (AR order 0), since a
#: handful of residuals cannot tell a correlation from structure, and the order's
#: predecessors would take the few rows there are out of the likelihood.
SPARSE_SAMPLES = 20


def ar_order_for(n_samples: int, segment: np.ndarray | None = None) -> int:
    """Largest AR noise order fitted on a record of ``n_samples``: 0 for a sparse record
    (:data:`SPARSE_SAMPLES`). With the record's ``segment`` of each sample, the order is lowered
    until the samples with that many predecessors in their own segment, and the order, add up
    to :data:`SPARSE_SAMPLES` (as for a record of that many samples without gaps; one sampled
    ever more sparsely, as creep tests often are, has a gap at most steps), and is 0 when no
    order does: such a record is sparse too."""
    if n_samples < SPARSE_SAMPLES:
        return 0
    if segment is None:
        return MAX_AR_ORDER
    segment = np.asarray(segment)
    for order in range(MAX_AR_ORDER, 0, -1):
        if np.count_nonzero(segment[order:] == segment[:-order]) + order >= SPARSE_SAMPLES:
            return order
    return 0


def ar_order(data: Data) -> int:
    """Largest AR noise order fitted on a prepared record (:func:`ar_order_for` its samples
    and segments)."""
    return ar_order_for(data.n, data.segment)


def is_sparse(data: Data) -> bool:
    """Too few samples, or too few with predecessors in their segment, for a noise model
    with memory (:func:`ar_order`): the noise is taken as white."""
    return ar_order(data) == 0


def gaussian_bic(rss: float, n: int, n_params: int) -> tuple[float, float]:
    """Log-likelihood of ``n`` independent Gaussian errors whose variance is estimated from
    their sum of squares ``rss``, and its Bayesian information criterion
    (``-2 loglik + n_params ln n``): the one information criterion of both fits, sensor
    (:func:`creepcomp.fit.solver.with_noise`) and circuit (:mod:`creepcomp.fit.circuit`).

    Returns
    -------
    loglik, bic : float
    """
    sigma2 = max(rss / n, 1e-300)
    loglik = -0.5 * n * (math.log(2 * math.pi * sigma2) + 1.0)
    return loglik, -2.0 * loglik + n_params * math.log(n)


@dataclass(frozen=True)
class ARNoise:
    """AR(p) noise: ``e[n] = sum_i phi_i e[n-i] + w[n]``, ``w`` white with deviation ``sigma``."""

    phi: tuple[float, ...] = ()
    sigma: float = float("nan")

    @property
    def order(self) -> int:
        """p."""
        return len(self.phi)

    def correlation_samples(self) -> float:
        """Rough memory of the noise in samples (``1 / (1 - sum phi)``)."""
        s = sum(self.phi)
        return float("inf") if s >= 1 else 1.0 / (1.0 - s)

    def to_dict(self, dt: float) -> dict:
        """JSON form."""
        return {"model": f"AR({self.order})", "phi": list(self.phi),
                "innovation_sigma": self.sigma,
                "memory_s": self.correlation_samples() * dt}


def rows_for(data: Data, mask: np.ndarray | None = None, order: int | None = None) -> np.ndarray:
    """Samples that have ``order`` predecessors in the same segment and inside ``mask``
    (default: the record's largest AR order, :func:`ar_order`)."""
    n = data.n
    order = ar_order(data) if order is None else order
    ok = np.ones(n, bool) if mask is None else np.asarray(mask, bool).copy()
    good = ok.copy()
    for i in range(1, order + 1):
        prev = np.zeros(n, bool)
        prev[i:] = ok[:-i] & (data.segment[i:] == data.segment[:-i])
        good &= prev
    return np.flatnonzero(good)


def whiten(z: np.ndarray, rows: np.ndarray, noise: ARNoise) -> np.ndarray:
    """Prewhitened rows: ``z[n] - sum_i phi_i z[n-i]`` for ``n`` in ``rows``."""
    out = z[rows].copy()
    for i, phi in enumerate(noise.phi, start=1):
        out -= phi * z[rows - i]
    return out


def fit_noise(residual: np.ndarray, rows: np.ndarray, max_order: int | None = None) -> ARNoise:
    """AR(p) noise of a residual, p chosen by BIC (least squares on the given rows); ``p`` up
    to ``max_order`` (default: :func:`ar_order_for` the residual's length)."""
    max_order = ar_order_for(len(residual)) if max_order is None else max_order
    y = residual[rows]
    n = len(rows)
    best, best_bic = ARNoise((), float(np.sqrt(np.mean(y ** 2)))), n * np.log(np.mean(y ** 2) + 1e-300)
    lagged = np.column_stack([residual[rows - i] for i in range(1, max_order + 1)]) if max_order else None
    if max_order:
        gram, rhs = lagged.T @ lagged, lagged.T @ y
    for p in range(1, max_order + 1):
        # (each order's normal equations are the leading block of the highest's; the lagged
        # columns are the same series, of nearly equal norms: unscaled, they are well-posed
        # as the unit-scaled ones)
        phi = normal_solution(gram[:p, :p], rhs[:p])
        if phi is None:
            phi, *_ = linalg.lstsq(lagged[:, :p], y, lapack_driver="gelsy")
        rss = float(np.sum((y - lagged[:, :p] @ phi) ** 2))
        bic = n * np.log(rss / n + 1e-300) + p * np.log(n)
        if bic < best_bic - 1e-9:
            best, best_bic = ARNoise(tuple(float(v) for v in phi), math.sqrt(rss / n)), bic
    return best


def ljung_box(white_residual: np.ndarray, lags: int = 20) -> tuple[float, float]:
    """Ljung-Box statistic and p-value of a (prewhitened) residual: is it white?"""
    from scipy.special import chdtrc   # (chi-squared survival: scipy.stats is 0.3 s to import)

    w = white_residual - np.mean(white_residual)
    n = len(w)
    lags = min(lags, n // 4)
    if lags < 1:
        return float("nan"), float("nan")
    acf = autocorrelation(w, lags)[1:]
    q = float(n * (n + 2) * np.sum(acf ** 2 / (n - np.arange(1, lags + 1))))
    return q, float(chdtrc(lags, q))


def autocorrelation(x: np.ndarray, lags: int) -> np.ndarray:
    """Sample autocorrelation at lags 0 ... ``lags`` (FFT)."""
    x = np.asarray(x, float) - np.mean(x)
    n = len(x)
    size = 1 << (2 * n - 1).bit_length()
    f = np.fft.rfft(x, size)
    acov = np.fft.irfft(f * np.conj(f), size)[:lags + 1]
    return acov / acov[0] if acov[0] > 0 else np.zeros(lags + 1)


def spectral_variance(weights: np.ndarray, noise_sample: np.ndarray) -> float:
    """Variance of ``sum_n weights[n] e[n]`` for stationary noise ``e`` whose spectrum is
    estimated from ``noise_sample`` (periodogram smoothed over about +-15 % in frequency,
    at least +-4 frequency bins, and not below its +-1-bin local mean); samples are taken as
    equally spaced."""
    n = len(weights)
    m = 1 << (2 * n - 1).bit_length()          # zero padding: no circular wrap-around
    e = noise_sample - np.mean(noise_sample)
    power = np.abs(np.fft.rfft(e, m)) ** 2 / n
    per_bin = max(1, m // n)                   # padded bins per independent frequency
    # smoothed for a steady estimate, but never below the local level: at the lowest
    # frequencies slow noise (drift, 1/f^2) would otherwise be averaged away
    spectrum = np.maximum(_smooth_log(power, min_half=4 * per_bin),
                          _smooth_log(power, min_half=per_bin, fraction=0.0))
    gain = np.abs(np.fft.rfft(weights, m)) ** 2
    w = np.full(len(power), 2.0)
    w[0] = 1.0
    w[-1] = 1.0
    return float(np.sum(w * gain * spectrum) / m)


def _smooth_log(x: np.ndarray, min_half: int, fraction: float = 0.15) -> np.ndarray:
    k = np.arange(len(x))
    half = np.maximum(min_half, (fraction * k).astype(int))
    lo = np.clip(k - half, 0, len(x) - 1)
    hi = np.clip(k + half, 0, len(x) - 1)
    c = np.concatenate([[0.0], np.cumsum(x)])
    return (c[hi + 1] - c[lo]) / (hi - lo + 1)


# --------------------------------------------------------------------------------------------
# The noise floor, measured apart from any creep model
# --------------------------------------------------------------------------------------------

#: Samples per window of the noise-floor estimate: long enough that noise correlated over a
#: few tens of samples stays in the window's residual, short enough that a quadratic follows
#: creep within it.
FLOOR_WINDOW = 96
#: Fewer windows than this make the floor a rough estimate (said in its method).
FEW_WINDOWS = 10
#: A misfit ratio (residual RMS / noise floor) up to this is consistent with 1: the floor
#: misses part of noise correlated over more than about a third of a window, and a drift.
MISFIT_LIMIT = 1.5


@dataclass(frozen=True)
class NoiseFloor:
    """RMS of a record's measurement noise, estimated without the creep model.

    Attributes
    ----------
    rms : float
        Noise RMS in signal units.
    method : str
        How it was estimated (``noise_floor_method``).
    quantisation_step : float
        Step of the signal's value grid (0: not quantised).
    windows : int
        Windows the estimate is the median of.
    """

    rms: float
    method: str
    quantisation_step: float
    windows: int

    @property
    def windows_text(self) -> str:
        """The number of windows in words ("1 window", "3 windows")."""
        return windows_text(self.windows)

    @property
    def rough(self) -> bool:
        """Fewer than :data:`FEW_WINDOWS` windows: the floor, and every misfit ratio over it, is
        a rough estimate."""
        return self.windows < FEW_WINDOWS

    def to_dict(self) -> dict:
        """JSON form."""
        return {"noise_floor": self.rms, "noise_floor_method": self.method,
                "noise_floor_windows": self.windows, "quantisation_step": self.quantisation_step or None}


def quantisation_step(y: np.ndarray) -> float:
    """The step of the grid the values lie on (the smallest change between successive samples,
    when nearly all changes are whole multiples of it), or 0.

    A grid needs three levels at least: a signal that takes two values only (one that follows
    a load between two levels at every sample, without noise) changes by its whole range
    every time, which shows no grid."""
    d = np.abs(np.diff(np.asarray(y, float)))
    scale = float(np.max(np.abs(y))) if len(y) else 0.0
    d = d[d > 1e-9 * max(scale, 1e-300)]
    if len(d) < 10:
        return 0.0
    q = float(np.min(d))
    if float(np.ptp(y)) < 1.999 * q:
        return 0.0
    multiples = d / q
    on_grid = np.abs(multiples - np.round(multiples)) <= 1e-3
    return q if np.mean(on_grid) >= 0.99 else 0.0


def noise_floor(signal, load=None, time=None, window: int = FLOOR_WINDOW,
                follows_lag: bool = False, weights=None, samples=None) -> NoiseFloor:
    """The measurement noise's RMS from the record alone (no creep model).

    The record is cut into windows of ``window`` samples (not across gaps in the sampling);
    in each, the signal is fitted by least squares with a quadratic in time plus the load
    (so load steps and load noise the signal follows do not count as noise), and the median of
    the windows' residual variances (corrected for the parameters and for the median's bias)
    is the noise variance: windows with a creep transient or a jump are few and do not move
    the median. A signal on a value grid of step ``q`` has at least ``q**2 / 12``.

    Parameters
    ----------
    signal : array_like
    load : array_like, optional
        The input the signal follows (the load; on the circuit side the network's input).
    time : array_like, optional
        Sample times (default: sample numbers).
    window : int
    follows_lag : bool
        The signal may follow the load through lags (creep): in windows where the load
        changes, two more columns, the load times time and the load through a lag of a quarter
        of the window's span, so that creep after a turn of a sweep does not count as noise.
    weights, samples : array_like, optional
        Of a reduced record (:class:`~creepcomp.fit.data.Data`): each sample's inverse noise
        variance relative to one sample of the full record, and the samples it holds. Each
        window is then fitted by weighted least squares, so the floor is the full record's
        noise, as the weighted residual of a fit; blocks of different lengths are no gap.

    Returns
    -------
    NoiseFloor
    """
    y = np.asarray(signal, float)
    n = len(y)
    t = np.arange(n, dtype=float) if time is None else np.asarray(time, float)
    x = None if load is None else np.asarray(load, float)
    w = int(min(window, max(8, n // 4)))
    root = None if weights is None else np.sqrt(np.asarray(weights, float))
    breaks = np.flatnonzero(gaps(t, samples)) if n > 2 else np.array([], int)
    edges = np.concatenate([[0], breaks, [n]])
    variances, dofs = [], []
    for a, b in zip(edges[:-1], edges[1:]):
        for start in range(a, b - w + 1, w):
            sl = slice(start, start + w)
            tt = t[sl] - t[sl].mean()
            span = max(float(np.ptp(tt)), 1e-300)
            cols = [np.ones(w), tt / span, (tt / span) ** 2]
            if x is not None and np.ptp(x[sl]) > 0:
                cols.append(x[sl] - x[sl].mean())
                if follows_lag:
                    cols.append(cols[-1] * tt / span)
                    lagged = lag_states(t[sl], x[sl], [0.25 * span], initial="settled")[:, 0]
                    cols.append(lagged - lagged.mean())
            a_, y_ = np.column_stack(cols), y[sl]
            if root is not None:
                a_, y_ = a_ * root[sl, None], y_ * root[sl]
            coef, *_ = np.linalg.lstsq(a_, y_, rcond=None)
            r = y_ - a_ @ coef
            dof = w - a_.shape[1]
            variances.append(float(r @ r) / dof)
            dofs.append(dof)
    q = quantisation_step(y)
    if variances:
        k = float(np.median(dofs))
        # median of chi2(k)/k (Wilson-Hilferty)
        var = float(np.median(variances)) / (1.0 - 2.0 / (9.0 * k)) ** 3
    else:
        var = 0.0
    method = (f"median over {windows_text(len(variances))} of {w} samples of the residual variance "
              f"of a local quadratic in time plus the load"
              + (" (and the load times time and through a lag of a quarter window)" if follows_lag else ""))
    if len(variances) < FEW_WINDOWS:
        method += (f" (only {windows_text(len(variances))} of {w} samples: a rough estimate, and on a sparse "
                   f"record a window spans enough time for creep to bend within it)")
    if q > 0 and var < q * q / 12.0:
        var = q * q / 12.0
        method += f"; raised to the quantisation floor step^2/12 (step {q:.4g})"
    return NoiseFloor(float(np.sqrt(var)), method, q, len(variances))


#: The reference load's noise joins the floor when it adds at least this share to the
#: signal's own (below, the floor is the signal's as before, to the digit).
REFERENCE_SHARE = 0.05


def with_reference_noise(floor: NoiseFloor, signal, load, reference: float) -> NoiseFloor:
    """The floor of a model's residual when the load is itself measured (a reference load cell,
    a test machine): the signal's noise and the reference's noise through the sensor's gain.

    A model driven by a noisy reference predicts the reference's noise too: its residual
    holds ``gain * load_noise`` beside the signal's own noise, and a misfit judged against
    the signal's floor alone reads that as structure. ``reference`` is the load's noise RMS
    (:attr:`creepcomp.fit.data.Data.reference_noise`);
    the gain is the least-squares slope of signal against load. ``floor**2 + (gain *
    reference)**2`` is the floor when it adds at least :data:`REFERENCE_SHARE` to it.

    Examples
    --------
    >>> import numpy as np
    >>> from creepcomp.fit.noise import noise_floor, with_reference_noise
    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(0.0, 600.0, 0.1)
    >>> load = np.where((t // 60) % 2 == 1, 10.0, 0.0)
    >>> signal = 2.0 * load + rng.normal(0, 1e-3, t.size)
    >>> measured = load + rng.normal(0, 0.01, t.size)
    >>> floor = noise_floor(signal, measured, t)
    >>> reference = 0.01
    >>> print(f"{floor.rms:.2g} -> {with_reference_noise(floor, signal, measured, reference).rms:.2g}")
    0.001 -> 0.02
    """
    x = np.asarray(load, float)
    if not reference > 0 or np.ptp(x) == 0:
        return floor
    gain = float(np.polyfit(x, np.asarray(signal, float), 1)[0])
    total = float(np.hypot(floor.rms, gain * reference))
    if not total > (1.0 + REFERENCE_SHARE) * floor.rms:
        return floor
    return NoiseFloor(total, f"{floor.method}; with the reference load's own noise ({reference:.3g} "
                             f"load units, from its third differences, times the gain {gain:.4g})",
                      floor.quantisation_step, floor.windows)


def slow_drift(residual: np.ndarray, time: np.ndarray, spacing: float) -> np.ndarray:
    """The slow part of a residual: its least-squares cubic spline with knots ``spacing``
    seconds apart (at most one knot interval per 8 samples), evaluated at ``time``.

    Parameters
    ----------
    residual, time : numpy.ndarray
        Residual and its (increasing) sample times, s.
    spacing : float
        Knot spacing, s.

    Returns
    -------
    numpy.ndarray
        The spline at ``time``.
    """
    t = np.asarray(time, float)
    span = float(t[-1] - t[0])
    intervals = int(max(1, min(round(span / max(spacing, 1e-300)), len(t) // 8)))
    # knots at quantiles of the sample times: every interval holds samples (Schoenberg-Whitney)
    inner = np.quantile(t, np.linspace(0.0, 1.0, intervals + 1)[1:-1]) if intervals > 1 else np.zeros(0)
    knots = np.r_[[t[0]] * 4, inner, [t[-1]] * 4]
    from scipy.interpolate import make_lsq_spline   # (imported here: most fits do without it)

    return make_lsq_spline(t, np.asarray(residual, float), knots, 3)(t)


def windows_text(count: int) -> str:
    """A number of noise-floor windows in words ("1 window", "3 windows")."""
    return f"{count} window" + ("" if count == 1 else "s")


def none_statement(floor: NoiseFloor | None) -> str:
    """What a diagnosis with no finding says: that the model explains the record to its noise,
    unless the floor is too rough (few windows) to show it."""
    if floor is not None and floor.rough:
        return (f"no effect is supported by the evidence, and the baseline's misfit ratio is under "
                f"{MISFIT_LIMIT:g}; but the noise floor rests on only {floor.windows_text} (a rough "
                f"estimate, fewer than {FEW_WINDOWS}): the record is too sparse to show that the paper's "
                f"model explains it to its noise")
    return ("no effect is supported by the evidence, and the baseline's misfit is consistent with the "
            "noise floor: the paper's model explains the record to its noise")


def misfit_ratio(residual_rms: float, floor: NoiseFloor | float) -> float | None:
    """Residual RMS over the noise floor (None when the floor is zero)."""
    f = floor.rms if isinstance(floor, NoiseFloor) else float(floor)
    return float(residual_rms / f) if f > 0 else None


def explained_share(baseline_rms: float, extended_rms: float, floor: NoiseFloor | float) -> float | None:
    """Share of the baseline's misfit variance above the floor that the extended model removes,
    ``1 - (ext^2 - floor^2) / (base^2 - floor^2)`` clipped to [0, 1] (None when the baseline
    is at the floor: nothing to explain)."""
    f = floor.rms if isinstance(floor, NoiseFloor) else float(floor)
    excess = baseline_rms ** 2 - f ** 2
    if excess <= 0:
        return None
    return float(min(1.0, max(0.0, 1.0 - (extended_rms ** 2 - f ** 2) / excess)))
