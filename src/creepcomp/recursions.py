"""Sample-by-sample recursions that numpy cannot vectorise, compiled by numba: the states of
first-order lags and their derivatives, and the play operator.

:mod:`creepcomp.lti` sums the same lag recursions in numpy (blocks of scaled cumulative sums)
and calls these instead inside :func:`creepcomp.lti.compiled_loops`, where a process runs
enough of them to pay for numba's start (about 0.5 s once: a diagnosis evaluates its lags
thousands of times, a single fit a few hundred). The coefficients come from numpy
(:func:`creepcomp.lti.lag_coefficients`, vectorised); only the recursion runs here. Importing
this module imports numba; each function is compiled on first use and its machine code is
cached beside the module.
"""

from __future__ import annotations

import math

import numba

__all__ = ["lag_recursion", "derivative_recursion", "decay_columns", "play"]

_jit = numba.njit(cache=True, nogil=True)


@_jit
def lag_recursion(e, b0, b1, kind, u, ub, c0, out):
    """``out[n+1, j] = e c + b0 u[n] + b1 ub[n+1]`` from ``out[0, j] = c0[j]``, with ``c =
    out[n, j]`` and the coefficients of lag ``j`` in row ``kind[n]`` (the kind of step ``n``:
    steps of the same length share their coefficients)."""
    n, k = out.shape
    for j in range(k):
        c = c0[j]
        out[0, j] = c
        for i in range(n - 1):
            r = kind[i]
            c = e[r, j] * c + (b0[r, j] * u[i] + b1[r, j] * ub[i + 1])
            out[i + 1, j] = c


@_jit
def derivative_recursion(e, de, db0, db1, kind, scale, states, u, d0, out):
    """``out[n+1, j] = e d + (de states[n, j] + db0 u[n] + db1 u[n+1]) scale[n, j]`` from
    ``out[0, j] = d0[j]``, with ``d = out[n, j]`` and the coefficients in row ``kind[n]``: the
    derivative of the states of :func:`lag_recursion` (input ``u`` on both sides of every
    step) by a parameter that moves the time constant of step ``n`` of lag ``j`` by
    ``scale[n, j]`` (an array of one row: the same for every step)."""
    n, k = out.shape
    same = scale.shape[0] == 1
    for j in range(k):
        d = d0[j]
        out[0, j] = d
        for i in range(n - 1):
            r = kind[i]
            s = scale[0 if same else i, j]
            d = e[r, j] * d + (de[r, j] * states[i, j] + db0[r, j] * u[i] + db1[r, j] * u[i + 1]) * s
            out[i + 1, j] = d


@_jit
def decay_columns(t, first, ends, mids, taus, scales, e, kind, out):
    """``out[n, j K + k] = scales[j, k] exp(-(t[n] - mids[j]) / taus[k])`` for ``first[j] <= n <
    ends[j, k]``, each sample's value from the last by its step's decay ``e[kind[n - 1], k]``;
    ``out`` zero elsewhere (as it is given)."""
    k_count = taus.shape[0]
    for j in range(first.shape[0]):
        for k in range(k_count):
            scale = scales[j, k]
            if scale == 0.0:
                continue
            c = j * k_count + k
            i = first[j]
            v = scale * math.exp(-(t[i] - mids[j]) / taus[k])
            for n in range(i, ends[j, k]):
                if n > i:
                    v *= e[kind[n - 1], k]
                out[n, c] = v


@_jit
def play(x, width, initial, out):
    """``out[n] = clip(out[n-1], x[n] - width/2, x[n] + width/2)`` from ``out[-1] = initial``."""
    r = 0.5 * width
    y = initial
    for i in range(x.shape[0]):
        lo = x[i] - r
        hi = x[i] + r
        if y < lo:
            y = lo
        elif y > hi:
            y = hi
        out[i] = y
