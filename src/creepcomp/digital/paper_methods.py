"""The paper's correction formulas as printed (section III): for comparison and tests only.

These follow eqs. 7/9 (subtractive) and 12/13 (supplemental, lagging one step) literally, in
the form ``exp(-t_i / tau) * sum_j dS_j * exp(t_j / tau)``, with the sum over all past
samples recomputed at every sample. That costs O(N) per sample (O(N^2) per record) and
overflows float64 once ``t / tau`` passes about 709: ``exp(t_j / tau)`` becomes ``inf``
(numpy warns ``overflow encountered in exp``) and the output turns to ``nan``.
Production code is :mod:`creepcomp.digital.correctors`.

Notation: ``raw`` is the signal above its offset (the paper's ``S_raw``); the paper's
``beta' c_k`` are the model's ``beta_k``; times count from the first sample, as the paper's
``t_i`` do.
"""

from __future__ import annotations

import numpy as np

from creepcomp.errors import InputError

__all__ = ["subtractive", "supplemental"]


def _arrays(time, raw, beta, tau):
    t = np.asarray(time, dtype=float)
    x = np.asarray(raw, dtype=float)
    beta = np.atleast_1d(np.asarray(beta, dtype=float))
    tau = np.atleast_1d(np.asarray(tau, dtype=float))
    if t.ndim != 1 or x.shape != t.shape or len(t) == 0:
        raise InputError("time and raw signal must be 1-D of equal, non-zero length")
    if beta.shape != tau.shape:
        raise InputError("one beta per tau")
    elapsed = t - t[0]
    # the paper's factors; exp(t_j / tau) overflows to inf beyond t / tau ~ 709
    growth = np.exp(elapsed[:, None] / tau[None, :])
    decay = np.exp(-elapsed[:, None] / tau[None, :])
    return x, beta, growth, decay


def subtractive(time, raw, beta, tau) -> np.ndarray:
    """Eq. 7 (one term) and eq. 9 (several): the instantaneous signal, from an unloaded start.

    ``S_cor(t_i) = S_raw(t_i) - sum_k beta_k [S_cor(t_(i-1))
    - exp(-t_i / tau_k) sum_(j=0..i-1) (S_cor(t_j) - S_cor(t_(j-1))) exp(t_j / tau_k)]``,
    with ``S_cor(t_(-1)) = 0``.

    Parameters
    ----------
    time : array_like
        Sample times (s).
    raw : array_like
        Raw signal above its offset.
    beta, tau : array_like
        Creep terms.

    Returns
    -------
    numpy.ndarray
    """
    x, beta, growth, decay = _arrays(time, raw, beta, tau)
    corrected = np.empty_like(x)
    steps = np.empty_like(x)             # S_cor(t_j) - S_cor(t_(j-1))
    previous = 0.0
    for i in range(len(x)):
        history = steps[:i] @ growth[:i]                  # sum over j < i, one per term
        corrected[i] = x[i] - beta @ (previous - decay[i] * history)
        steps[i] = corrected[i] - previous
        previous = corrected[i]
    return corrected


def supplemental(time, raw, beta, tau, gains=None, lag: bool = True,
                 initial: str = "settled") -> np.ndarray:
    """Eq. 12 (one term) and eq. 13 (several): the saturated signal, lagging one step.

    ``S_cor(t_i) = S_raw(t_i) + sum_k b_k exp(-t_(i-1) / tau_k)
    sum_(j=0..i-1) (S_cor(t_j) - S_cor(t_(j-1))) exp(t_j / tau_k)``.

    Parameters
    ----------
    time, raw, beta, tau
        As :func:`subtractive`.
    gains : array_like, optional
        ``b_k``; default ``beta_k`` (the paper's ``beta' c_k``). Exactness needs
        ``beta_k / (1 + beta0)``.
    lag : bool
        True: eq. 12/13 as printed (the current sample left out of the sum). False: the
        implicit eq. 11, whose sum includes the current sample, solved for it exactly
        (it is linear in it).
    initial : {"settled", "relaxed"}
        Start saturated at the first sample's level (``S_cor(t_(-1)) = S_cor(t_0)``, the
        paper's "any saturation state") or unloaded (``S_cor(t_(-1)) = 0``).

    Returns
    -------
    numpy.ndarray
    """
    x, beta, growth, decay = _arrays(time, raw, beta, tau)
    b = beta if gains is None else np.atleast_1d(np.asarray(gains, dtype=float))
    if b.shape != beta.shape:
        raise InputError("one gain per creep term")
    if initial not in ("settled", "relaxed"):
        raise InputError(f"initial '{initial}': use 'settled' or 'relaxed'")
    corrected = np.empty_like(x)
    steps = np.empty_like(x)
    previous = None if initial == "settled" else 0.0
    for i in range(len(x)):
        if lag:
            history = steps[:i] @ growth[:i]
            corrected[i] = x[i] + (b @ (decay[i - 1] * history) if i > 0 else 0.0)
        else:
            if previous is None:
                corrected[i] = x[i]                          # saturated: nothing still to come
            else:
                history = decay[i] * (steps[:i] @ growth[:i])
                corrected[i] = (x[i] + b @ (history - previous)) / (1.0 - b.sum())
        if previous is None:
            previous = corrected[i]
        steps[i] = corrected[i] - previous
        previous = corrected[i]
    return corrected
