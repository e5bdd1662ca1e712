"""Sample-by-sample recursions that numpy cannot vectorise, compiled by numba: the states of
first-order lags and their derivatives, and the play operator.

:mod:`creepcomp.lti` sums the same lag recursions in numpy (blocks of scaled cumulative sums)
and calls these instead inside :func:`creepcomp.lti.compiled_loops`, where a process runs
enough of them to pay for numba's start (about 0.5 s once: a diagnosis evaluates its lags
thousands of times, a single fit a few hundred). The recursions' coefficients are computed
here too, as :func:`creepcomp.lti.lag_coefficients` gives them (to rounding): for fixed time
constants once per kind of step; for time constants that change from step to step, each
step's from the last when its ``dt / tau`` is the same (a mode holds for many steps). Importing
this module imports numba; each function is compiled on first use and its machine code is
cached beside the module.
"""

from __future__ import annotations

import math

import numba

__all__ = ["lag_recursion", "derivative_recursion", "varying_lag_recursion",
           "varying_derivative_recursion", "step_coefficients", "step_coefficient_slopes",
           "decay_columns", "play"]

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")   # (IEEE division, as numpy)


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
def _exprel(x):
    """``(1 - exp(-x)) / x`` for ``x >= 0`` (1 below 1e-16), as ``scipy.special.exprel(-x)``."""
    if x < 1e-16:
        return 1.0
    return -math.expm1(-x) / x


@_jit
def _exprel_slope(x):
    """d/dx of ``(1 - exp(-x)) / x`` (:func:`creepcomp.lti._exprel_slope`)."""
    if x < 1e-2:
        return -0.5 + x / 3.0 - x ** 2 / 8.0 + x ** 3 / 30.0 - x ** 4 / 144.0
    return (math.exp(-x) - _exprel(x)) / x


@_jit
def _coefficients(dt, tau, linear):
    """``(e, b0, b1)`` of a step ``dt`` of a lag of time constant ``tau``
    (:func:`creepcomp.lti.lag_coefficients`)."""
    x = dt / tau
    e = math.exp(-x)
    if linear:
        g = _exprel(x)
        return e, g - e, 1.0 - g
    return e, -math.expm1(-x), 0.0


@_jit
def _slopes(dt, tau, linear):
    """``(e, e_T, b0_T, b1_T)``: the decay of a step ``dt`` and the derivatives of the
    coefficients by the time constant ``tau`` (:func:`creepcomp.lti._coefficient_slopes`)."""
    x = dt / tau
    e = math.exp(-x)
    dx = -x / tau
    de = -e * dx
    if linear:
        dg = _exprel_slope(x) * dx
        return e, de, dg - de, -dg
    return e, de, -de, 0.0


@_jit
def step_coefficients(lengths, taus, linear, e, b0, b1):
    """The coefficients of :func:`lag_recursion` for steps of the given ``lengths`` (rows) and
    time constants ``taus`` (columns), into ``e``, ``b0``, ``b1``."""
    for r in range(lengths.shape[0]):
        for j in range(taus.shape[0]):
            e[r, j], b0[r, j], b1[r, j] = _coefficients(lengths[r], taus[j], linear)


@_jit
def step_coefficient_slopes(lengths, taus, linear, e, de, db0, db1):
    """The coefficients of :func:`derivative_recursion` (derivatives by each time constant)
    for steps of the given ``lengths`` (rows) and ``taus`` (columns)."""
    for r in range(lengths.shape[0]):
        for j in range(taus.shape[0]):
            e[r, j], de[r, j], db0[r, j], db1[r, j] = _slopes(lengths[r], taus[j], linear)


@_jit
def varying_lag_recursion(dt, taus, linear, u, c0, out):
    """``out[n+1, j] = e c + b0 u[n] + b1 u[n+1]`` from ``out[0, j] = c0[j]`` with the exact
    coefficients (:func:`creepcomp.lti.lag_coefficients`; ``linear``: linear hold, else zero
    hold) of step ``dt[n]`` and time constant ``taus[n, j]``."""
    n, k = out.shape
    for j in range(k):
        c = c0[j]
        out[0, j] = c
        last = -1.0
        e = b0 = b1 = 0.0
        for i in range(n - 1):
            x = dt[i] / taus[i, j]
            if x != last:
                last = x
                e, b0, b1 = _coefficients(dt[i], taus[i, j], linear)
            c = e * c + (b0 * u[i] + b1 * u[i + 1])
            out[i + 1, j] = c


@_jit
def varying_derivative_recursion(dt, taus, linear, scale, states, u, d0, out):
    """The derivative of the states of :func:`varying_lag_recursion` by a parameter that
    moves the time constant of step ``n`` of lag ``j`` by ``scale[n, j]``: ``out[n+1, j] = e d
    + (e_T states[n, j] + b0_T u[n] + b1_T u[n+1]) scale[n, j]`` from ``out[0, j] = d0[j]``
    (``_T``: derivative by the time constant)."""
    n, k = out.shape
    for j in range(k):
        d = d0[j]
        out[0, j] = d
        last_dt = last_tau = -1.0
        e = de = db0 = db1 = 0.0
        for i in range(n - 1):
            tau = taus[i, j]
            if tau != last_tau or dt[i] != last_dt:
                last_dt, last_tau = dt[i], tau
                e, de, db0, db1 = _slopes(dt[i], tau, linear)
            d = e * d + (de * states[i, j] + db0 * u[i] + db1 * u[i + 1]) * scale[i, j]
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
