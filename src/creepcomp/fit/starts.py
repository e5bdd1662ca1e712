"""Starting values of the nonlinear search: a log grid of the time constants a record can
resolve, the creep spectrum on it by non-negative least squares, and its clustering."""

from __future__ import annotations

import math

import numpy as np
from scipy import optimize

from creepcomp.fit.data import Data
from creepcomp.fit.solver import Fit
from creepcomp.fit.structure import Structure, basis

__all__ = ["tau_grid", "nnls_spectrum", "cluster_taus", "one_term_starts", "extra_term_starts"]


def tau_grid(data: Data, per_decade: float = 4.0, low: float | None = None,
             high: float | None = None) -> np.ndarray:
    """Log-spaced retardation times the record can resolve."""
    lo, hi = data.tau_limits()
    lo, hi = low or lo, high or hi
    n = max(2, int(round(per_decade * math.log10(hi / lo))) + 1)
    return np.geomspace(lo, hi, n)


def _decimate(data: Data, target: int = 4000) -> np.ndarray:
    step = max(1, data.n // target)
    return np.arange(0, data.n, step)


def nnls_spectrum(data: Data, taus: np.ndarray) -> tuple[np.ndarray, float]:
    """Creep spectrum on a grid: amplitudes ``gain * beta`` of lags at ``taus`` by non-negative
    least squares, tried with all amplitudes positive and with all negative.

    Returns
    -------
    amplitudes : numpy.ndarray
        One per grid time (mostly zero).
    rss : float
    """
    idx = _decimate(data)
    b = basis(data, Structure(len(taus)), {f"tau[{k}]": t for k, t in enumerate(taus)})
    cols = b.columns[idx]
    y = data.signal[idx]
    names = b.names
    lag_cols = [i for i, n in enumerate(names) if n.startswith("a[")]
    free_cols = [i for i, n in enumerate(names) if not n.startswith("a[")]
    scale = np.sqrt(np.sum(cols ** 2, axis=0))
    scale[scale == 0] = 1.0
    cols = cols / scale
    best = (np.zeros(len(taus)), np.inf)
    for sign in (1.0, -1.0):
        mat = np.column_stack([cols[:, free_cols], -cols[:, free_cols], sign * cols[:, lag_cols]])
        try:
            sol, rnorm = optimize.nnls(mat, y, maxiter=50 * mat.shape[1])
        except RuntimeError:
            continue
        amps = sign * sol[2 * len(free_cols):] / scale[lag_cols]
        if rnorm ** 2 < best[1]:
            best = (amps, rnorm ** 2)
    return best


def cluster_taus(taus: np.ndarray, weights: np.ndarray, k: int) -> list[float]:
    """``k`` representative time constants of a spectrum (weighted 1-D k-means on log tau)."""
    w = np.abs(weights)
    logt = np.log(taus)
    if np.count_nonzero(w) == 0:
        return list(np.exp(np.linspace(logt[0], logt[-1], k + 2)[1:-1]))
    nz = np.flatnonzero(w)
    if len(nz) <= k:
        centres = list(logt[nz])
        spare = [x for x in np.linspace(logt[0], logt[-1], k + 2)[1:-1]]
        while len(centres) < k:
            far = max(spare, key=lambda s: min(abs(s - c) for c in centres))
            centres.append(far)
            spare.remove(far)
        return sorted(float(np.exp(c)) for c in centres)
    x, wx = logt[nz], w[nz]
    centres = np.quantile(x, (np.arange(k) + 0.5) / k)
    for _ in range(50):
        assign = np.argmin(np.abs(x[:, None] - centres[None, :]), axis=1)
        new = np.array([np.sum(wx[assign == j] * x[assign == j]) / np.sum(wx[assign == j])
                        if np.any(assign == j) else centres[j] for j in range(k)])
        if np.allclose(new, centres):
            break
        centres = new
    return sorted(float(np.exp(c)) for c in centres)


def one_term_starts(data: Data) -> list[dict]:
    """Start values for the one-term (Voigt) model: a log grid of time constants."""
    return [{"tau[0]": t} for t in tau_grid(data, per_decade=3)]


def extra_term_starts(data: Data, fit: Fit, structure: Structure, per_decade: float = 3) -> list[dict]:
    """Start values for a model with one more term than ``fit``: its values plus a grid time."""
    k = fit.structure.n_terms
    base = {name: v for name, v in fit.values.items() if name in {p.name for p in fit.params}}
    out = []
    for tau in tau_grid(data, per_decade):
        if np.min(np.abs(np.log(fit.taus / tau))) < 0.1:
            continue
        s = dict(base)
        s[f"tau[{k}]"] = float(tau)
        out.append(s)
    return out
