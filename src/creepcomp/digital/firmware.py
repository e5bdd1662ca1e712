"""The digital corrector as portable C99, with a proven bound on its error (``creepcomp firmware``).

The generated code runs the exact recursion of :mod:`creepcomp.digital.correctors` for a fixed
sample interval ``T`` and the load held between samples (``hold="zero"``)::

    S[n] = x[n] - sum_k beta_k c_k[n],       c_k[n+1] = c_k[n] + a_k (S[n] - c_k[n]),
    a_k = 1 - exp(-T / tau_k),               x = raw - offset,

and returns ``offset + S`` (subtractive) or ``offset + (1 + beta0) S`` (supplemental). The states
are updated by the difference, with ``a_k`` stored directly (not ``1 - a_k``): with long ``tau_k``
at a high rate ``a_k`` is tiny, and the increment ``a_k (S - c_k)`` is far below the rounding step
of a single-precision state. So the state is held wider than the arithmetic:

- ``float32``: each state is an unevaluated sum ``hi + lo`` of two floats; the increment is added
  with an error-free sum (Knuth's TwoSum), its rounding error kept in ``lo`` (error feedback).
- ``q31``: samples are 32-bit words, ``2**30`` per full scale; the states are 64-bit integers with
  ``2**60`` per full scale; coefficients are 31-bit mantissas with a shift (relative error
  ``2**-31`` however small ``a_k`` is); every product fits a 64-bit integer.

The worst-case error bound (:func:`firmware_bound`) follows the arithmetic: each operation's rounding
and each stored coefficient's error is a local error; the state errors obey
``d[n+1] = M d[n] + a eps[n] + eta[n]`` with ``M = I - diag(a) - a beta^T`` (the corrector's own
recursion), so a local error reaches the output through the impulse response of that recursion,
whose l1 norm is bounded by the geometric sums ``sum_i |l_i r_i| / (1 - |lambda_i|)`` over the
eigenvalues of ``M``. ``docs/firmware.md`` has the derivation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from creepcomp.errors import InputError
from creepcomp.model import CreepModel

__all__ = ["PRECISIONS", "FULL_SCALE_WORD", "REFERENCE_ALLOWANCE", "ErrorBound", "Firmware",
           "firmware_bound", "generate_firmware", "naive_float32"]

PRECISIONS = ("float32", "q31")
#: q31: the input word of a full-scale signal (the words keep one bit of headroom).
FULL_SCALE_WORD = 2 ** 30
#: Allowance (fraction of full scale) for the float64 reference corrector's own rounding; it is
#: near 1e-14 for the models here, so the bound is against exact arithmetic plus this.
REFERENCE_ALLOWANCE = 1e-12

_U32 = 2.0 ** -24                  # unit roundoff of IEEE binary32
_Q_IN = 2.0 ** -31                 # half a q31 word (fraction of full scale)
_Q_STATE = 2.0 ** -61              # half a step of the 64-bit states
_MARGIN = 1.0 + 1e-6               # second-order terms (products of roundings), float64 evaluation
_METHODS = ("subtractive", "supplemental")
#: Shortest interval the dt step accepts (s); also the q31 step's tick: dt is in microseconds.
MIN_INTERVAL = 1e-6
TICK = 1e-6


@dataclass(frozen=True)
class ErrorBound:
    """Worst-case difference between the generated corrector and the exact float64 one.

    Attributes
    ----------
    total_fs : float
        The bound, as a fraction of full scale.
    terms : dict
        Its parts (fractions of full scale, already multiplied by their gains), by cause.
    full_scale : float
        The input range it assumes: ``|raw - offset| <= full_scale`` (signal units).
    peak_fs : float
        Largest ``|S|`` the exact corrector can output for inputs in that range (fraction of
        full scale): the l1 norm of its impulse response.
    gains : dict
        ``sample``: gain from a local error of ``S`` to the output error; ``state``: one per
        creep term, gain from a local error of its state (both l1 norms).
    """

    total_fs: float
    terms: dict
    full_scale: float
    peak_fs: float
    gains: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """JSON form."""
        return {"bound_fs": self.total_fs, "terms": dict(self.terms), "full_scale": self.full_scale,
                "peak_fs": self.peak_fs, "gains": dict(self.gains)}


@dataclass(frozen=True)
class Firmware:
    """Generated C corrector of one model, method, precision and sample rate.

    Attributes
    ----------
    name : str
        C prefix of every identifier; the files are ``name.h`` and ``name.c``.
    header, source : str
        The C99 text.
    bound : ErrorBound or None
        The proven bound (None for the naive reference recursion, which has none).
    harness : str
        A host program (not for the target) that reads samples and times the corrector.
    rate : float or None
        Fixed sample rate (Hz); None for the dt step.
    max_interval : float or None
        Longest interval the dt step accepts (s); None for the fixed rate.
    """

    model: CreepModel
    method: str
    precision: str
    rate: float
    full_scale: float
    name: str
    header: str
    source: str
    harness: str
    bound: ErrorBound | None
    coefficients: dict
    max_interval: float | None = None

    @property
    def irregular(self) -> bool:
        """True for the dt step (``PREFIX_step_dt``, irregular sampling), False for the fixed rate."""
        return self.max_interval is not None

    @property
    def filenames(self) -> tuple[str, str]:
        """``(name.h, name.c)``."""
        return f"{self.name}.h", f"{self.name}.c"

    def write(self, folder) -> list[Path]:
        """Write the header and the source into ``folder`` (created if needed), atomically.

        Returns
        -------
        list of Path
            The files written.
        """
        from creepcomp.io.atomic import write_text_atomic

        folder = Path(folder)
        if folder.exists() and not folder.is_dir():
            raise InputError(f"output folder {folder} exists and is not a folder")
        folder.mkdir(parents=True, exist_ok=True)
        h, c = self.filenames
        return [write_text_atomic(folder / h, self.header), write_text_atomic(folder / c, self.source)]


# ----------------------------------------------------------------------------------- checks

def _check(model: CreepModel, method: str, precision: str, rate: float, full_scale: float,
           name: str) -> None:
    from creepcomp.digital.correctors import check_invertible

    if method not in _METHODS:
        raise InputError(f"method '{method}': use 'subtractive' or 'supplemental'")
    if precision not in PRECISIONS:
        raise InputError(f"precision '{precision}': use 'float32' or 'q31'")
    if not (rate > 0 and math.isfinite(rate)):
        raise InputError(f"rate = {rate!r}: the sample rate must be positive and finite (Hz)")
    if not (full_scale > 0 and math.isfinite(full_scale)):
        raise InputError(f"full scale = {full_scale!r}: must be positive and finite (signal units)")
    if not (name and name.isascii() and name.replace("_", "a").isalnum() and not name[0].isdigit()):
        raise InputError(f"name '{name}': a C identifier is needed (letters, digits, '_'; "
                         "not starting with a digit)")
    check_invertible(model)


def _check_interval(max_interval: float) -> None:
    if not (math.isfinite(max_interval) and max_interval >= MIN_INTERVAL):
        raise InputError(f"max interval = {max_interval!r}: must be finite and at least "
                         f"{MIN_INTERVAL:g} s (the shortest interval the dt step accepts)")


def _coefficients(model: CreepModel, rate: float) -> dict:
    taus = np.array(model.tau)
    x = (1.0 / rate) / taus
    return {"T": 1.0 / rate, "beta": np.array(model.beta), "tau": taus, "a": -np.expm1(-x),
            "e": np.exp(-x), "sigma": 1.0 + model.beta0, "w": 1.0 / (1.0 + model.beta0),
            "offset": model.offset}


# ------------------------------------------------------------------------------ the gains

def _modes(a: np.ndarray, beta: np.ndarray):
    """Eigen-decomposition of ``N = diag(a) + a beta^T``; ``M = I - N`` is the error recursion.

    Returns ``mu`` (eigenvalues of N), ``V`` and ``V^-1``. N is decomposed, not M, so that
    ``1 - lambda = mu`` keeps its relative accuracy when ``a`` is tiny.
    """
    n = np.diag(a) + np.outer(a, beta)
    mu, v = np.linalg.eig(n)
    return mu, v, np.linalg.inv(v)


def _decay(mu: np.ndarray) -> np.ndarray:
    """``1 - |1 - mu|`` without cancellation: ``(2 Re mu - |mu|^2) / (1 + |1 - mu|)``."""
    return (2 * mu.real - np.abs(mu) ** 2) / (1 + np.abs(1 - mu))


def _gains(a: np.ndarray, beta: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """l1 gains of the corrector's recursion ``d[n+1] = M d[n] + g u[n]``, output ``beta . d``.

    Returns ``L_sample`` (``1 + sum_m |beta^T M^m a|``: from a local error of ``S``, and from
    the input to ``S``), ``L_state[k]`` (``sum_m |beta^T M^m e_k|``) and ``G_state[k]``
    (``sup_m |beta^T M^m e_k|``, for an error of the start state). Each is bounded by its modal
    expansion, ``sum_i |l_i r_i| / (1 - |lambda_i|)`` (``sum_i |l_i r_i|`` for the supremum).
    """
    mu, v, vinv = _modes(a, beta)
    decay = _decay(mu)
    if np.any(decay <= 0):
        raise InputError("the sampled corrector is unstable at this rate (an eigenvalue of its "
                         "recursion is on or outside the unit circle); sample faster")
    left = beta @ v                                  # l_i
    weights = np.abs(left[:, None] * vinv)           # |l_i r_ik| for g = e_k, shape (K modes, K)
    l_state = (weights / decay[:, None]).sum(axis=0)
    g_state = weights.sum(axis=0)
    l_sample = 1.0 + float(np.sum(np.abs(left * (vinv @ a)) / decay))
    return l_sample * _MARGIN, l_state * _MARGIN, g_state * _MARGIN


# ---------------------------------------------------------------------- stored coefficients

def _float32(value: float) -> float:
    return float(np.float32(value))


def _mantissa(value: float, what: str) -> tuple[int, int]:
    """``value = m * 2**-(31 + s)`` with ``2**30 <= |m| < 2**31`` and ``s >= 0``."""
    f, exp = math.frexp(abs(value))
    m, s = round(f * 2 ** 31), -exp
    if m == 2 ** 31:
        m, s = 2 ** 30, s - 1
    if s < 0 or s > 60:
        raise InputError(f"{what} = {value:g} cannot be stored as a q31 mantissa with a right shift "
                         "(|value| must be below 1 and above 2^-61)")
    return (m if value > 0 else -m), s


def _stored(c: dict, precision: str) -> dict:
    """The coefficients as the C code stores them, and their values (float64, exact)."""
    beta, a = c["beta"], c["a"]
    if precision == "float32":
        return {"beta": np.array([_float32(b) for b in beta]), "a": np.array([_float32(x) for x in a]),
                "offset": _float32(c["offset"]), "sigma": _float32(c["sigma"]), "w": _float32(c["w"])}
    bm = [_mantissa(b, f"beta[{k}]") for k, b in enumerate(beta)]
    am = [_mantissa(x, f"a[{k}] = 1 - exp(-T/tau[{k}])") for k, x in enumerate(a)]
    sigma_q, w_q = round(c["sigma"] * FULL_SCALE_WORD), round(c["w"] * FULL_SCALE_WORD)
    if not (0 < sigma_q < 2 ** 31 and 0 < w_q < 2 ** 31):
        raise InputError(f"beta0 = {c['sigma'] - 1:g}: q31 needs -0.5 < beta0 < 1 "
                         "(1 + beta0 and 1/(1 + beta0) are stored with 30 fraction bits)")
    return {"beta": np.array([m * 2.0 ** -(31 + s) for m, s in bm]),
            "a": np.array([m * 2.0 ** -(31 + s) for m, s in am]),
            "beta_q": bm, "a_q": am, "sigma_q": sigma_q, "w_q": w_q,
            "offset": c["offset"], "sigma": sigma_q / FULL_SCALE_WORD, "w": w_q / FULL_SCALE_WORD}


# ------------------------------------------------------------------------------- the bound

def firmware_bound(model: CreepModel, method: str = "subtractive", precision: str = "float32",
                rate: float = 100.0, full_scale: float = 1.0,
                max_interval: float | None = None) -> ErrorBound:
    """Proven worst-case difference between the generated C corrector and the exact one.

    Parameters
    ----------
    model : CreepModel
        Creep terms and offset.
    method : {"subtractive", "supplemental"}
    precision : {"float32", "q31"}
    rate : float
        Sample rate (Hz).
    full_scale : float
        Input range the bound assumes: ``|raw - offset| <= full_scale`` (signal units).
    max_interval : float, optional
        The dt step (irregular sampling): the bound holds for every sequence of intervals
        ``MIN_INTERVAL <= dt <= max_interval`` (s); ``rate`` is then not used.

    Returns
    -------
    ErrorBound
        Bound on ``|C output - exact output| / full_scale`` for every sample of every input
        sequence in the range, from a relaxed or a settled start. float32 assumes IEEE binary32
        rounding to nearest with no excess precision (the C code refuses to compile otherwise).
    """
    if max_interval is not None:
        _check_interval(max_interval)
        _check(model, method, precision, 1.0 / max_interval, full_scale, "x")
        return _irregular_bound(model, method, precision, max_interval, full_scale)
    _check(model, method, precision, rate, full_scale, "x")
    c = _coefficients(model, rate)
    st = _stored(c, precision)
    beta, a = c["beta"], c["a"]
    l_sample, l_state, g_state = _gains(a, beta)
    peak = l_sample                                   # max |S| / FS of the exact corrector
    sigma = c["sigma"] if method == "supplemental" else 1.0
    sum_beta = float(np.sum(np.abs(beta)))
    k = len(beta)
    # Everything below is in units of full scale. C bounds |computed state| and |computed S|;
    # it is checked (and raised if needed) after the error is known.
    cmax = peak * (1.0 + 1e-3)
    for _ in range(8):
        terms, b_s, eta_over_a = _local_terms(precision, st, c, k, cmax, full_scale, l_sample,
                                              l_state, g_state, sum_beta, sigma, method)
        if cmax >= peak + b_s + eta_over_a:
            break
        cmax = 2 * (peak + b_s + eta_over_a)
    else:  # pragma: no cover - only for a corrector whose error is of the order of its signal
        raise InputError("the corrector's rounding error is of the order of its signal at this "
                         "rate and precision: no useful bound")
    if precision == "q31":
        _check_q31_range(peak, cmax, sigma, method)
    terms["float64 reference (allowance)"] = REFERENCE_ALLOWANCE
    total = sum(terms.values()) * _MARGIN
    return ErrorBound(total_fs=float(total), terms={n: float(v) for n, v in terms.items()},
                      full_scale=float(full_scale), peak_fs=float(peak),
                      gains={"sample": float(l_sample), "state": [float(g) for g in l_state]})


def _sample_errors(precision, st, c, k, cmax, fs, sum_beta, method):
    """Local errors of ``S`` per sample, of a settled start and of the output (fractions of FS).

    Returns ``(eps, start, out_offset, out_scale)``; see the table in docs/firmware.md.
    """
    beta = c["beta"]
    beta_err = float(np.sum(np.abs(st["beta"] - beta)))
    sum_beta_hat = float(np.sum(np.abs(st["beta"])))
    if precision == "float32":
        u = _U32
        offset = abs(c["offset"]) / fs
        offset_err = abs(st["offset"] - c["offset"]) / fs
        raw_max = offset + 1.0
        x_err = u * raw_max + offset_err + u * (1.0 + u * raw_max + offset_err)
        gamma = k * u / (1 - k * u)
        c_hi = cmax * (1 + u)
        eps = {"input": x_err,
               "coefficients beta": beta_err * c_hi + sum_beta * u * c_hi,
               "sum beta.c": gamma * sum_beta_hat * c_hi + u * (1.0 + x_err + sum_beta_hat * c_hi * (1 + gamma))}
        start = x_err * abs(st["w"]) + abs(st["w"] - c["w"]) + u * (1.0 + x_err) * abs(st["w"])
        out_offset = offset_err + u * (offset + offset_err + abs(st["sigma"] if method == "supplemental" else 1.0) * cmax * (1 + u))
        out_scale = (abs(st["sigma"] - c["sigma"]) * cmax + u * abs(st["sigma"]) * cmax
                     if method == "supplemental" else 0.0)
    else:
        x_err = _Q_IN
        c_q = cmax + _Q_IN
        eps = {"input": x_err,
               "coefficients beta": beta_err * c_q,
               "sum beta.c": sum_beta_hat * _Q_IN + k * _Q_STATE + _Q_IN}
        start = x_err * st["w"] + abs(st["w"] - c["w"])
        out_offset = 0.0
        out_scale = (abs(st["sigma"] - c["sigma"]) * cmax + _Q_IN) if method == "supplemental" else 0.0
    return eps, start, out_offset, out_scale


def _local_terms(precision, st, c, k, cmax, fs, l_sample, l_state, g_state, sum_beta, sigma,
                 method):
    """Local errors times their gains (fractions of full scale); see docs/firmware.md."""
    a = c["a"]
    a_err = np.abs(st["a"] - a)
    d = 2 * cmax                                            # |S - c_k|
    eps, start, out_offset, out_scale = _sample_errors(precision, st, c, k, cmax, fs, sum_beta, method)
    if precision == "float32":
        u = _U32
        c_hi = cmax * (1 + u)
        eta = a_err * d * (1 + u) ** 3 + a * d * ((1 + u) ** 3 - 1) + a * u * c_hi + u * u * c_hi
        eta_coef = a_err * d * (1 + u) ** 3
    else:
        eta = a_err * d + st["a"] * _Q_IN + _Q_STATE
        eta_coef = a_err * d
    eps_total = sum(eps.values())
    state_terms = l_state * eta
    b_s = l_sample * eps_total + float(np.sum(state_terms)) + float(np.sum(g_state)) * start
    terms = {f"{name} (per sample, x{l_sample:.4g})": sigma * l_sample * v for name, v in eps.items()}
    coef_part = l_state * eta_coef
    terms["coefficients a_k (state updates)"] = sigma * float(np.sum(coef_part))
    terms["state updates rounding"] = sigma * float(np.sum(state_terms - coef_part))
    terms["settled start"] = sigma * float(np.sum(g_state)) * start
    terms["output"] = out_offset + out_scale
    return terms, b_s, float(np.max(eta / a))


# ------------------------------------------------------------- irregular sampling (dt step)

def _series_terms(x_max: float, target: float) -> int:
    """Fewest Taylor terms N of ``a = x t(x)`` with truncation ``x^N/(N+1)! <= target``."""
    n = 2
    while x_max ** n / math.factorial(n + 1) > target:
        n += 1
    return n


def _dt_scheme(model: CreepModel, precision: str, max_interval: float) -> dict:
    """How the dt step computes ``a_k(dt) = 1 - exp(-dt/tau_k)``, and its worst relative error.

    float32: ``x = dt * (1/tau_k)``, halved ``m`` times until ``x <= 1/8``, ``a = x t(x)`` with
    the Taylor series of ``t = (1 - exp(-x))/x`` in Horner form, then ``a <- a (2 - a)`` ``m``
    times (``1 - a(2y) = (1 - a(y))^2``). q31: ``x = dt_ticks * m_k 2^-E_k`` exactly (``m_k`` the
    31-bit mantissa of ``tick/tau_k``), ``t(x)`` in Q31 (``x <= 1/2``, no range reduction), and
    the increment ``(S - c_k) a`` as ``((S - c_k) t) m_k dt 2^-E_k`` with two shifts.
    """
    taus = np.array(model.tau)
    if precision == "float32":
        u = _U32
        dt_max = max(max_interval, _float32(max_interval))
        dt_min = min(MIN_INTERVAL, _float32(MIN_INTERVAL))
        inv_tau = np.array([_float32(1.0 / tau) for tau in taus])
        delta_x = np.abs(inv_tau * taus - 1.0) + u * (1 + 1e-6)        # stored 1/tau, product
        x_hi = dt_max * inv_tau * (1 + u)
        halvings = np.array([max(0, math.ceil(math.log2(x / 0.125))) if x > 0.125 else 0
                             for x in x_hi], dtype=int)
        n = _series_terms(0.125, 2.0 ** -30)
        # Horner with x <= 1/8: relative error <= 18u/14 (each level damps the inner one by
        # x/(j+1) <= 1/16), then the product x t: 2.5u in all; each doubling adds (1+u)^2.
        rel_series = 0.125 ** n / math.factorial(n + 1) / (1 - 0.0625) + 2.5 * u
        rel_a = (1 + delta_x) * (1 + rel_series) * (1 + u) ** (2 * halvings) - 1
        return {"dt_min": dt_min, "dt_max": dt_max, "inv_tau": inv_tau, "halvings": halvings,
                "n": n, "inv_next": [_float32(1.0 / (j + 1)) for j in range(n)],
                "rel_a": rel_a, "extra": np.zeros(len(taus)), "nu": np.full(len(taus), u * u),
                "limit_f": _float32(max_interval), "min_f": _float32(MIN_INTERVAL)}
    max_ticks = math.floor(max_interval / TICK + 1e-6)
    if not 1 <= max_ticks < 2 ** 31:
        raise InputError(f"max interval {max_interval:g} s: q31 counts the interval in uint32 ticks "
                         f"of {TICK:g} s; give 1 tick to 2^31 - 1 ticks")
    ms = [_mantissa(TICK / tau, f"tick/tau[{k}]") for k, tau in enumerate(taus)]
    mant = np.array([m for m, _ in ms], dtype=float)
    exps = np.array([31 + sh for _, sh in ms], dtype=int)
    x_max = float(np.max(max_ticks * mant * 2.0 ** -exps))
    if x_max > 0.5 or np.any(exps < 32):
        raise InputError(f"max interval {max_interval:g} s is more than half the shortest time "
                         f"constant ({min(taus):g} s): the q31 dt step needs dt <= tau/2; use "
                         "float32 or a shorter --max-interval")
    rel_m = np.abs(mant * 2.0 ** -exps / (TICK / taus) - 1.0)
    n = _series_terms(0.5, 2.0 ** -34)
    t_min = -math.expm1(-x_max) / x_max
    # t in Q31: each Horner level rounds twice (0.75 + 0.5 units) and damps the inner error by
    # x/(j+1) <= 1/4, so |t error| <= 1.7 units; x's rounding adds 0.25: 3 units of 2^-31.
    rel_t = (3 * 2.0 ** -31 + 0.5 ** n / math.factorial(n + 1)) / t_min
    r1 = math.ceil(math.log2(max_ticks + 1)) + 1
    r2 = exps - 30 - r1
    if np.any(r2 < 0):  # pragma: no cover - excluded by x_max <= 1/2
        raise InputError("the q31 dt step cannot scale this model's coefficients")
    extra = (2.0 ** -31 + 2.0 ** -31 / t_min + 2.0 ** (r1 - 61) / t_min) * np.ones(len(taus))
    return {"dt_min": TICK, "dt_max": max_ticks * TICK, "max_ticks": max_ticks, "m": ms,
            "exps": exps, "n": n, "inv_next": [round(2 ** 31 / (j + 1)) for j in range(n)],
            "r1": r1, "r2": r2, "rel_a": (1 + rel_m) * (1 + rel_t) - 1, "extra": extra,
            "nu": np.where(r2 >= 1, _Q_STATE, 0.0)}


def _invariant_gains(beta: np.ndarray, a_max: np.ndarray):
    """Componentwise invariant of ``|d[n+1]| <= |M(dt)| |d[n]| + a(dt) w`` for all allowed dt.

    With ``M(dt) = I - diag(a) - a beta^T`` row ``k`` of ``|M|`` applied to ``z`` is
    ``|1 - a_k(1 + beta_k)| z_k + a_k sum_{j != k} |beta_j| z_j``: convex in ``a_k`` and equal
    to ``z_k`` at ``a_k = 0``, so ``|M| z + a w <= z`` holds for every ``0 < a_k <= a_max_k``
    when it holds at ``a_max``. That is ``z = G z + h w``, solved as ``z = Z w``; returns
    ``Z`` (``Z >= 0``) and the largest row sum of ``|M(a_max)|`` (at most 1, checked).
    """
    b = np.abs(beta)
    one_plus = 1.0 + beta
    big = a_max * one_plus > 1.0
    if np.any(one_plus <= 0) or np.any(a_max * one_plus >= 2.0):
        raise InputError("the corrector's recursion is unstable at the longest interval; give "
                         "a shorter --max-interval")
    h = np.where(big, a_max / np.where(big, 2.0 - a_max * one_plus, 1.0), 1.0 / one_plus)
    g = h[:, None] * b[None, :]
    np.fill_diagonal(g, 0.0)
    rows = np.abs(1 - a_max * one_plus) + a_max * (b.sum() - b)
    if np.max(np.abs(np.linalg.eigvals(g))) >= 1.0 or np.max(rows) > 1.0:
        raise InputError("no error bound for irregular sampling: the creep terms' coupling "
                         "(sum of |beta|) is too strong for the invariant used; use the fixed rate")
    z = np.linalg.solve(np.eye(len(b)) - g, np.diag(h)) * _MARGIN
    if np.any(z < 0):  # pragma: no cover - G >= 0 with spectral radius < 1 gives Z >= 0
        raise InputError("no error bound for irregular sampling for this model")
    return z, float(np.max(rows))


def _irregular_bound(model: CreepModel, method: str, precision: str, max_interval: float,
                     full_scale: float) -> ErrorBound:
    c = _coefficients(model, 1.0 / max_interval)
    st = _stored(c, precision)
    sch = _dt_scheme(model, precision, max_interval)
    beta, taus = c["beta"], c["tau"]
    a_max = -np.expm1(-sch["dt_max"] / taus)
    a_min = -np.expm1(-sch["dt_min"] / taus)
    zmat, _ = _invariant_gains(beta, a_max)
    b = np.abs(beta)
    sum_beta = float(b.sum())
    gain_state = b @ zmat                          # output error per unit of w_k (per unit a)
    gain_sample = 1.0 + float(gain_state.sum())   # from a local error of S
    z_peak = zmat @ np.ones(len(b))               # |c_k| of the exact corrector, |x| <= 1
    z_peak = z_peak + max(0.0, abs(c["w"]) - float(np.min(z_peak)))     # settled start
    peak = 1.0 + float(b @ z_peak)                # |S| of the exact corrector
    sigma = c["sigma"] if method == "supplemental" else 1.0
    k = len(beta)
    u = _U32
    cmax = max(peak, float(np.max(z_peak))) * (1.0 + 1e-3)
    for _ in range(8):
        d = 2 * cmax
        eps, start, out_offset, out_scale = _sample_errors(precision, st, c, k, cmax, full_scale,
                                                           sum_beta, method)
        eps_total = sum(eps.values())
        if precision == "float32":
            coef = sch["rel_a"] * d * (1 + u) ** 3
            rounding = d * ((1 + u) ** 3 - 1) + u * cmax * (1 + u) + sch["nu"] * cmax * (1 + u) / a_min
        else:
            coef = sch["rel_a"] * d
            rounding = sch["extra"] + sch["nu"] / a_min
        w = eps_total + coef + rounding            # per unit a: |state error| grows by a w
        z_err = zmat @ w + start
        s_max = eps_total + float(b @ z_err)
        if cmax >= max(peak + s_max, float(np.max(z_peak + z_err))):
            break
        cmax = 2 * max(peak + s_max, float(np.max(z_peak + z_err)))
    else:  # pragma: no cover
        raise InputError("the corrector's rounding error is of the order of its signal: no useful bound")
    if precision == "q31":
        _check_q31_range(peak, cmax, sigma, method)
    terms = {f"{name} (per sample, x{gain_sample:.4g})": sigma * gain_sample * v for name, v in eps.items()}
    terms["coefficients a_k(dt) (series, stored 1/tau)"] = sigma * float(gain_state @ coef)
    terms["state updates rounding"] = sigma * float(gain_state @ rounding)
    terms["settled start"] = sigma * sum_beta * start
    terms["output"] = out_offset + out_scale
    terms["float64 reference (allowance)"] = REFERENCE_ALLOWANCE
    total = sum(terms.values()) * _MARGIN
    return ErrorBound(total_fs=float(total), terms={n: float(v) for n, v in terms.items()},
                      full_scale=float(full_scale), peak_fs=float(peak),
                      gains={"sample": float(gain_sample), "state": [float(g) for g in gain_state]})


def _check_q31_range(peak: float, cmax: float, sigma: float, method: str) -> None:
    """Every word and product of the q31 code fits its integer type."""
    out = sigma * cmax if method == "supplemental" else cmax
    if cmax * FULL_SCALE_WORD + 2 >= 2 ** 31 or out * FULL_SCALE_WORD + 2 >= 2 ** 31:
        raise InputError(f"the corrected signal can reach {max(cmax, out):.4g} x full scale, beyond "
                         "the q31 words' one bit of headroom (2 x full scale); use float32")


# -------------------------------------------------------------------------------- the C text

def _c_float(value: float) -> str:
    return f"{_float32(value):.9e}f"


def _fnv1a(text: str) -> int:
    h = 2166136261
    for byte in text.encode():
        h = ((h ^ byte) * 16777619) % 2 ** 32
    return h


def _qty(value: float, unit: str) -> str:
    from creepcomp.units import format_quantity

    return format_quantity(value, unit, digits=6)


def generate_firmware(model: CreepModel, method: str = "subtractive", precision: str = "float32",
             rate: float = 100.0, full_scale: float = 1.0, name: str = "creep",
             max_interval: float | None = None) -> Firmware:
    """Generate the C99 corrector of a model, with its derivation and error bound in comments.

    Parameters
    ----------
    model : CreepModel
        Creep terms (``beta``, ``tau``) and ``offset`` (signal units); ``gain`` is not needed.
    method : {"subtractive", "supplemental"}
        Output ``offset + S`` or ``offset + (1 + beta0) S``.
    precision : {"float32", "q31"}
        Single-precision floats (signal units in and out) or 32-bit words (``2**30`` per full
        scale, above the offset) with 64-bit states.
    rate : float
        Fixed sample rate (Hz).
    full_scale : float
        Largest ``|raw - offset|`` (signal units): the bound assumes it, q31 scales by it.
    name : str
        Prefix of the C identifiers and of the file names.
    max_interval : float, optional
        Generate the dt step for irregular sampling instead of the fixed-rate step:
        ``PREFIX_step_dt(state, raw, dt, &out)`` accepts ``MIN_INTERVAL <= dt <= max_interval``
        (float32: dt in seconds; q31: dt in microsecond ticks). ``rate`` is then not used.

    Returns
    -------
    Firmware
    """
    if max_interval is not None:
        _check_interval(max_interval)
        rate = 1.0 / max_interval
    _check(model, method, precision, rate, full_scale, name)
    bound = firmware_bound(model, method, precision, rate, full_scale, max_interval)
    c = _coefficients(model, rate)
    st = _stored(c, precision)
    scheme = None if max_interval is None else _dt_scheme(model, precision, max_interval)
    text = _FLOAT32 if precision == "float32" else _Q31
    if scheme is not None:
        io = _FLOAT_IO if precision == "float32" else _Q31_IO
        text = _Texts(header=text.header, source=text.source,
                      harness=_fill(_HARNESS, {**io, "@HARNESS_DT@": "1"}))
    sub = _substitutions(model, method, precision, rate, full_scale, name, c, st, bound, scheme,
                         max_interval)
    header, source, harness = (_fill(t, sub) for t in (text.header, text.source, text.harness))
    return Firmware(model=model, method=method, precision=precision,
                    rate=None if scheme is not None else float(rate),
                    full_scale=float(full_scale), name=name, header=header, source=source,
                    harness=harness, bound=bound, coefficients=_coefficient_table(c, st, precision),
                    max_interval=None if scheme is None else float(scheme["dt_max"]))


def naive_float32(model: CreepModel, method: str = "subtractive", rate: float = 100.0,
                  full_scale: float = 1.0, name: str = "creep") -> Firmware:
    """The straightforward single-precision recursion, for comparison only (it has no bound).

    ``c_k = e_k c_k + (1 - e_k) S`` with ``e_k`` and ``1 - e_k`` rounded to float32: with long
    time constants at high rates both the stored ``1 - e_k`` and the state's increments lose
    most of their digits.
    """
    _check(model, method, "float32", rate, full_scale, name)
    c = _coefficients(model, rate)
    st = _stored(c, "float32")
    sub = _substitutions(model, method, "float32", rate, full_scale, name, c, st, None, None, None)
    sub["@E@"] = ", ".join(_c_float(x) for x in c["e"])
    header, source, harness = (_fill(t, sub) for t in (_NAIVE.header, _NAIVE.source, _NAIVE.harness))
    return Firmware(model=model, method=method, precision="float32", rate=float(rate),
                    full_scale=float(full_scale), name=name, header=header, source=source,
                    harness=harness, bound=None, coefficients=_coefficient_table(c, st, "float32"))


def _coefficient_table(c: dict, st: dict, precision: str) -> dict:
    return {"T": c["T"], "beta": [float(x) for x in c["beta"]], "tau": [float(x) for x in c["tau"]],
            "a": [float(x) for x in c["a"]], "a_stored": [float(x) for x in st["a"]],
            "beta_stored": [float(x) for x in st["beta"]], "precision": precision}


def _fill(template: str, sub: dict) -> str:
    for key, value in sub.items():
        template = template.replace(key, value)
    return template


def _derivation(model, method, precision, rate, full_scale, c, st) -> str:
    """The coefficients' derivation, as comment lines."""
    unit = "signal units"
    lines = [f"Model: {model.n_terms} creep term(s), beta0 = {model.beta0:.6g}, offset = "
             f"{model.offset:.9g} {unit}; method {method}; precision {precision}.",
             f"Sample interval T = 1 / {_qty(rate, 'Hz')} = {_qty(c['T'], 's')}; load held between samples.",
             f"Full scale FS = {full_scale:.9g} {unit}: the inputs satisfy |raw - offset| <= FS."]
    for k in range(model.n_terms):
        tau, a = c["tau"][k], c["a"][k]
        lines.append(f"term {k}: beta = {c['beta'][k]:.9g}, tau = {_qty(tau, 's')}, tau/T = {tau / c['T']:.6g}")
        lines.append(f"  a = 1 - exp(-T/tau) = -expm1(-{c['T'] / tau:.9g}) = {a:.12g}")
        if precision == "float32":
            lines.append(f"  stored a = {st['a'][k]:.9e} (relative error {abs(st['a'][k] / a - 1):.2e}), "
                         f"beta = {st['beta'][k]:.9e} (relative error {abs(st['beta'][k] / c['beta'][k] - 1):.2e})")
        else:
            (am, ash), (bm, bsh) = st["a_q"][k], st["beta_q"][k]
            lines.append(f"  stored a = {am} * 2^-{31 + ash} (relative error {abs(st['a'][k] / a - 1):.2e}), "
                         f"beta = {bm} * 2^-{31 + bsh} (relative error {abs(st['beta'][k] / c['beta'][k] - 1):.2e})")
    lines.append(f"1 + beta0 = {c['sigma']:.12g} (supplemental scale); 1/(1 + beta0) = {c['w']:.12g} "
                 "(settled start: c_k = x / (1 + beta0))")
    return lines


def _dt_derivation(model, method, precision, full_scale, c, st, scheme) -> list[str]:
    """The dt step's coefficients and the error of its ``a_k(dt)``, as comment lines."""
    unit = "signal units"
    lo, hi = scheme["dt_min"], scheme["dt_max"]
    lines = [f"Model: {model.n_terms} creep term(s), beta0 = {model.beta0:.6g}, offset = "
             f"{model.offset:.9g} {unit}; method {method}; precision {precision}.",
             f"Irregular sampling: dt = time since the previous sample, {_qty(lo, 's')} <= dt <= "
             f"{_qty(hi, 's')}; load held between samples.",
             f"Full scale FS = {full_scale:.9g} {unit}: the inputs satisfy |raw - offset| <= FS.",
             "a_k(dt) = 1 - exp(-dt/tau_k) is computed per sample without libm "
             + ("(halving to x <= 1/8, " if precision == "float32" else "(x <= 1/2, ")
             + f"{scheme['n']} Taylor terms of (1 - exp(-x))/x"
             + (", doubling a <- a(2 - a));" if precision == "float32" else ");"),
             "its worst relative error over the dt range is in the bound:"]
    for k in range(model.n_terms):
        tau = c["tau"][k]
        lines.append(f"term {k}: beta = {c['beta'][k]:.9g}, tau = {_qty(tau, 's')}, "
                     f"a(dt max) = {-math.expm1(-hi / tau):.9g}, relative error of computed a <= "
                     f"{scheme['rel_a'][k]:.2e}")
        if precision == "float32":
            lines.append(f"  stored 1/tau = {scheme['inv_tau'][k]:.9e} 1/s, halvings <= {int(scheme['halvings'][k])}; "
                         f"beta = {st['beta'][k]:.9e}")
        else:
            m, sh = scheme["m"][k]
            lines.append(f"  tick/tau = {m} * 2^-{31 + sh} (tick {TICK:g} s); beta = "
                         f"{st['beta_q'][k][0]} * 2^-{31 + st['beta_q'][k][1]}")
    lines.append(f"1 + beta0 = {c['sigma']:.12g} (supplemental scale); 1/(1 + beta0) = {c['w']:.12g} "
                 "(settled start: c_k = x / (1 + beta0))")
    return lines


def _bound_lines(bound: ErrorBound, full_scale: float) -> list[str]:
    lines = [f"Worst-case |output - exact float64 corrector| <= {bound.total_fs:.3e} x FS "
             f"= {bound.total_fs * full_scale:.3e} signal units,",
             f"for every input with |raw - offset| <= FS, from a relaxed or settled start. "
             f"Largest |S|: {bound.peak_fs:.6g} x FS.", "Parts (fraction of FS, times their gains):"]
    lines += [f"  {name}: {value:.3e}" for name, value in bound.terms.items()]
    lines.append("Derivation: docs/firmware.md (local roundings through the gains of the "
                 "corrector's own recursion).")
    return lines


def _version() -> str:
    from importlib import metadata

    try:
        return metadata.version("creepcomp")
    except metadata.PackageNotFoundError:
        return "(version unknown)"


def _comment(lines) -> str:
    return "\n".join((" * " + line).rstrip() for line in lines)


def _substitutions(model, method, precision, rate, full_scale, name, c, st, bound, scheme,
                   max_interval) -> dict:
    k = model.n_terms
    if scheme is None:
        derivation = _derivation(model, method, precision, rate, full_scale, c, st)
        structure = {"@STATE_EXTRA@": "", "@INIT_EXTRA@": "", "@SETTLE_EXTRA@": "",
                     "@SAVED_BASE@": "2", "@RESTORE_EXTRA@": "", "@SAVE_EXTRA@": "",
                     "@STEP_DECL@": ("float @P@_step(@P@_state *s, float raw);" if precision == "float32"
                                     else "int32_t @P@_step(@P@_state *s, int32_t raw);"),
                     "@TIMING@": "#define @PU@_RATE_HZ @RATE@", **_FIXED[precision]}
    else:
        derivation = _dt_derivation(model, method, precision, full_scale, c, st, scheme)
        structure = {**_DT_COMMON, **_DT[precision], "@N@": str(scheme["n"])}
        if precision == "float32":
            structure["@TIMING@"] = (f"#define @PU@_MIN_INTERVAL_S {_c_float(scheme['min_f'])}\n"
                                     f"#define @PU@_MAX_INTERVAL_S {_c_float(scheme['limit_f'])}")
            structure["@INV_TAU@"] = ", ".join(_c_float(x) for x in scheme["inv_tau"])
            structure["@INV_NEXT@"] = ", ".join(_c_float(x) for x in scheme["inv_next"])
        else:
            structure["@TIMING@"] = (f"#define @PU@_TICK_S {TICK!r}\n#define @PU@_MAX_TICKS {scheme['max_ticks']}u\n"
                                     f"#define @PU@_MAX_INTERVAL_S {scheme['dt_max']!r}")
            structure["@TICK_M@"] = ", ".join(str(m) for m, _ in scheme["m"])
            structure["@TICK_E@"] = ", ".join(str(int(e)) for e in scheme["exps"])
            structure["@R2@"] = ", ".join(str(int(r)) for r in scheme["r2"])
            structure["@R1@"] = str(scheme["r1"])
            structure["@INV_NEXT@"] = ", ".join(str(v) for v in scheme["inv_next"])
    bound_text = (_bound_lines(bound, full_scale) if bound is not None else
                  ["NAIVE reference recursion (c = e c + (1 - e) S in float32): no error bound; "
                   "for comparison only, do not deploy."])
    timing = f"--rate {rate:.9g}" if scheme is None else f"--max-interval {max_interval:.9g}"
    command = (f"creepcomp firmware MODEL --method {method} --precision {precision} "
               f"{timing} --full-scale {full_scale:.9g} --name {name}")
    sub = {**structure, "@P@": name, "@PU@": name.upper(), "@K@": str(k), "@VERSION@": _version(),
           "@COMMAND@": command, "@DERIVATION@": _comment(derivation), "@BOUND@": _comment(bound_text),
           "@RATE@": repr(float(rate)), "@FS@": repr(float(full_scale)), "@OFFSET@": repr(float(model.offset)),
           "@BOUND_FS@": f"{bound.total_fs:.3e}" if bound is not None else "-1.0",
           "@METHOD@": method, "@START@": "relaxed" if method == "subtractive" else "settled"}
    sub["@MODEL_ID@"] = f"0x{_fnv1a(repr((c['beta'].tolist(), c['tau'].tolist(), c['offset'], rate, full_scale, precision, method) + (() if max_interval is None else (max_interval,)))):08x}u"
    if precision == "float32":
        sub.update({"@BETA@": ", ".join(_c_float(x) for x in st["beta"]),
                    "@A@": ", ".join(_c_float(x) for x in st["a"]),
                    "@OFF_F@": _c_float(st["offset"]), "@W_F@": _c_float(st["w"]),
                    "@RETURN@": (f"{name}_offset + S" if method == "subtractive" else
                                 f"{name}_offset + {name}_saturation * S"),
                    "@SIGMA_F@": _c_float(st["sigma"])})
    else:
        sub.update({"@BETA_M@": ", ".join(f"{m}" for m, _ in st["beta_q"]),
                    "@BETA_S@": ", ".join(f"{1 + s}" for _, s in st["beta_q"]),
                    "@A_M@": ", ".join(f"{m}" for m, _ in st["a_q"]),
                    "@A_S@": ", ".join(f"{1 + s}" for _, s in st["a_q"]),
                    "@SIGMA_Q@": str(st["sigma_q"]), "@W_Q@": str(st["w_q"]),
                    "@RETURN@": ("(int32_t)S" if method == "subtractive" else
                                 f"(int32_t){name}_shift(S * {name}_saturation_q30, 30)")})
    return sub


@dataclass(frozen=True)
class _Texts:
    header: str
    source: str
    harness: str


_HEADER_TOP = """\
/* @P@.h: creep corrector generated by creepcomp @VERSION@. Do not edit; regenerate with
 *   @COMMAND@
 *
 * Removes the creep of an elastomer-based sensor sample by sample (method: @METHOD@):
 *   S[n] = x[n] - sum_k beta_k c_k[n],   c_k[n+1] = c_k[n] + a_k (S[n] - c_k[n]),   x = raw - offset
 * and returns the instantaneous signal offset + S (subtractive) or the saturated one
 * offset + (1 + beta0) S (supplemental). Exact for a load held between samples.
 * The usual start for this method is @START@: @P@_init() (unloaded before the first sample)
 * or @P@_settle(first sample) (creep saturated at that level).
 *
@DERIVATION@
 *
@BOUND@
 *
 * C99, no dynamic memory, no libm, no global state: the caller owns a @P@_state.
 */
#ifndef @PU@_H
#define @PU@_H

#include <stdint.h>

#define @PU@_TERMS @K@
@TIMING@
#define @PU@_FULL_SCALE @FS@
#define @PU@_OFFSET @OFFSET@
#define @PU@_BOUND_FS @BOUND_FS@
#define @PU@_MODEL_ID @MODEL_ID@
#define @PU@_SAVED_WORDS (@SAVED_BASE@ + 2 * @PU@_TERMS)

#ifdef __cplusplus
extern "C" {   /* C linkage when included from C++ (an Arduino sketch) */
#endif
"""

_HEADER_API = """
/* State save/restore (power cycles): model id, state words, checksum. */
typedef struct { uint32_t w[@PU@_SAVED_WORDS]; } @P@_saved;

void @P@_init(@P@_state *s);
void @P@_settle(@P@_state *s, @T@ raw);
@STEP_DECL@
void @P@_save(const @P@_state *s, @P@_saved *out);
/* Returns 0, or -1 for a block of another model, -2 for a corrupted block (state unchanged). */
int @P@_restore(@P@_state *s, const @P@_saved *in);

#ifdef __cplusplus
}
#endif
#endif
"""

_SAVE_COMMON = """
static uint32_t @P@_checksum(const uint32_t *w, int n)
{
    uint32_t h = 2166136261u;
    int i, b;
    for (i = 0; i < n; ++i)
        for (b = 0; b < 32; b += 8)
            h = (h ^ ((w[i] >> b) & 0xffu)) * 16777619u;
    return h;
}

int @P@_restore(@P@_state *s, const @P@_saved *in)
{
    int k;
    if (in->w[0] != @PU@_MODEL_ID)
        return -1;
    if (in->w[@PU@_SAVED_WORDS - 1] != @P@_checksum(in->w, @PU@_SAVED_WORDS - 1))
        return -2;
    for (k = 0; k < @PU@_TERMS; ++k)
        @P@_unpack(s, k, in->w[1 + 2 * k], in->w[2 + 2 * k]);@RESTORE_EXTRA@
    return 0;
}

void @P@_save(const @P@_state *s, @P@_saved *out)
{
    int k;
    out->w[0] = @PU@_MODEL_ID;
    for (k = 0; k < @PU@_TERMS; ++k)
        @P@_pack(s, k, &out->w[1 + 2 * k], &out->w[2 + 2 * k]);@SAVE_EXTRA@
    out->w[@PU@_SAVED_WORDS - 1] = @P@_checksum(out->w, @PU@_SAVED_WORDS - 1);
}
"""

_FLOAT32_SOURCE = """\
/* @P@.c: generated by creepcomp @VERSION@ (see @P@.h). float32 arithmetic, states held as
 * hi + lo pairs updated with an error-free sum. */
#include <float.h>
#include <string.h>
#include "@P@.h"

#if !defined(FLT_EVAL_METHOD) || FLT_EVAL_METHOD != 0 || defined(__FAST_MATH__)
#error "@P@.c needs IEEE float arithmetic evaluated in float, without -ffast-math: its bound assumes it"
#endif

static const float @P@_beta[@PU@_TERMS] = {@BETA@};
@COEF_A@
static const float @P@_offset = @OFF_F@;
static const float @P@_inv_saturation = @W_F@;
static const float @P@_saturation = @SIGMA_F@;

void @P@_init(@P@_state *s)
{
    int k;
    for (k = 0; k < @PU@_TERMS; ++k) {
        s->hi[k] = 0.0f;
        s->lo[k] = 0.0f;
    }@INIT_EXTRA@
}

void @P@_settle(@P@_state *s, float raw)
{
    const float c = (raw - @P@_offset) * @P@_inv_saturation;
    int k;
    for (k = 0; k < @PU@_TERMS; ++k) {
        s->hi[k] = c;
        s->lo[k] = 0.0f;
    }@SETTLE_EXTRA@
}

@STEP_FN@
static void @P@_pack(const @P@_state *s, int k, uint32_t *w0, uint32_t *w1)
{
    memcpy(w0, &s->hi[k], sizeof *w0);
    memcpy(w1, &s->lo[k], sizeof *w1);
}

static void @P@_unpack(@P@_state *s, int k, uint32_t w0, uint32_t w1)
{
    memcpy(&s->hi[k], &w0, sizeof w0);
    memcpy(&s->lo[k], &w1, sizeof w1);
}
""" + _SAVE_COMMON

_Q31_SOURCE = """\
/* @P@.c: generated by creepcomp @VERSION@ (see @P@.h). Integer arithmetic only: 32-bit words
 * (2^30 per full scale), 64-bit states (2^60 per full scale), 31-bit coefficient mantissas. */
#include "@P@.h"

/* beta_k = beta_m[k] * 2^-(30 + beta_s[k]), a_k = a_m[k] * 2^-(30 + a_s[k]) */
static const int32_t @P@_beta_m[@PU@_TERMS] = {@BETA_M@};
static const unsigned char @P@_beta_s[@PU@_TERMS] = {@BETA_S@};
@COEF_A@
static const int64_t @P@_saturation_q30 = @SIGMA_Q@;     /* (1 + beta0) * 2^30 */
static const int64_t @P@_inv_saturation_q30 = @W_Q@;     /* 2^30 / (1 + beta0) */

/* v / 2^n rounded to nearest (ties away from zero), n >= 1; no implementation-defined shift */
static int64_t @P@_shift(int64_t v, unsigned n)
{
    const int64_t half = (int64_t)1 << (n - 1);
    return v >= 0 ? (v + half) >> n : -((half - v) >> n);
}

void @P@_init(@P@_state *s)
{
    int k;
    for (k = 0; k < @PU@_TERMS; ++k)
        s->c[k] = 0;@INIT_EXTRA@
}

void @P@_settle(@P@_state *s, int32_t x)
{
    int k;
    for (k = 0; k < @PU@_TERMS; ++k)
        s->c[k] = (int64_t)x * @P@_inv_saturation_q30;@SETTLE_EXTRA@
}

@STEP_FN@
static void @P@_pack(const @P@_state *s, int k, uint32_t *w0, uint32_t *w1)
{
    const uint64_t u = (uint64_t)s->c[k];
    *w0 = (uint32_t)(u & 0xffffffffu);
    *w1 = (uint32_t)(u >> 32);
}

static void @P@_unpack(@P@_state *s, int k, uint32_t w0, uint32_t w1)
{
    const uint64_t u = ((uint64_t)w1 << 32) | w0;
    s->c[k] = (u >> 63) ? -(int64_t)(~u) - 1 : (int64_t)u;
}
""" + _SAVE_COMMON

_NAIVE_SOURCE = """\
/* @P@.c: NAIVE float32 recursion, for comparison only (see @P@.h). */
#include "@P@.h"

static const float @P@_beta[@PU@_TERMS] = {@BETA@};
static const float @P@_e[@PU@_TERMS] = {@E@};
static const float @P@_one_minus_e[@PU@_TERMS] = {@A@};
static const float @P@_offset = @OFF_F@;
static const float @P@_inv_saturation = @W_F@;
static const float @P@_saturation = @SIGMA_F@;

void @P@_init(@P@_state *s)
{
    int k;
    for (k = 0; k < @PU@_TERMS; ++k)
        s->c[k] = 0.0f;
}

void @P@_settle(@P@_state *s, float raw)
{
    int k;
    for (k = 0; k < @PU@_TERMS; ++k)
        s->c[k] = (raw - @P@_offset) * @P@_inv_saturation;
}

float @P@_step(@P@_state *s, float raw)
{
    float S = raw - @P@_offset;
    int k;
    for (k = 0; k < @PU@_TERMS; ++k)
        S -= @P@_beta[k] * s->c[k];
    for (k = 0; k < @PU@_TERMS; ++k)
        s->c[k] = @P@_e[k] * s->c[k] + @P@_one_minus_e[k] * S;
    (void)@P@_saturation;
    return @RETURN@;
}
"""

_HARNESS = """\
/* Host harness (not for the target): reads N doubles (signal units), and with HARNESS_DT N
 * intervals (doubles: seconds for float32, ticks for q31; the first is any valid value), runs
 * @P@_step (@P@_step_dt with HARNESS_DT) over them REPEATS times from the start given, writes the
 * outputs (doubles, signal units) of the first run and prints the best time per sample in
 * nanoseconds (clock_gettime, CLOCK_MONOTONIC). */
#define _POSIX_C_SOURCE 199309L
#define HARNESS_DT @HARNESS_DT@
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "@P@.h"

static double *read_doubles(const char *path, long *n)
{
    FILE *f = fopen(path, "rb");
    double *buf;
    long m;
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    m = ftell(f) / (long)sizeof(double);
    fseek(f, 0, SEEK_SET);
    buf = malloc((size_t)(m > 0 ? m : 1) * sizeof *buf);
    if (buf && fread(buf, sizeof *buf, (size_t)m, f) != (size_t)m) {
        free(buf);
        buf = NULL;
    }
    fclose(f);
    *n = m;
    return buf;
}

int main(int argc, char **argv)
{
    FILE *f;
    long n, i;
    int r, repeats, settled;
    double *buf, best = -1.0;
    @T@ *in, *out, *spare;
#if HARNESS_DT
    long n_gaps;
    double *gap;
    @DT_T@ *dts;
#endif
    @P@_state s;
    if (argc != 5 + HARNESS_DT) {
        fprintf(stderr, "usage: %s IN%s OUT relaxed|settled REPEATS\\n", argv[0], HARNESS_DT ? " DT" : "");
        return 2;
    }
    settled = strcmp(argv[3 + HARNESS_DT], "settled") == 0;
    repeats = atoi(argv[4 + HARNESS_DT]);
    buf = read_doubles(argv[1], &n);
    if (!buf) return 3;
    in = malloc((size_t)n * sizeof *in);
    out = malloc((size_t)n * sizeof *out);
    spare = malloc((size_t)n * sizeof *spare);
    if (!in || !out || !spare) return 3;
    for (i = 0; i < n; ++i)
        in[i] = @TO_WORD@;
#if HARNESS_DT
    gap = read_doubles(argv[2], &n_gaps);
    dts = malloc((size_t)n * sizeof *dts);
    if (!gap || !dts || n_gaps != n) return 3;
    for (i = 0; i < n; ++i)
        dts[i] = (@DT_T@)gap[i];
#endif
    for (r = 0; r < repeats; ++r) {
        struct timespec t0, t1;
        double ns;
        int bad = 0;
        @T@ *dst = r == 0 ? out : spare;
        if (settled) @P@_settle(&s, in[0]); else @P@_init(&s);
        clock_gettime(CLOCK_MONOTONIC, &t0);
        for (i = 0; i < n; ++i)
#if HARNESS_DT
            bad |= @P@_step_dt(&s, in[i], dts[i], &dst[i]);
#else
            dst[i] = @P@_step(&s, in[i]);
#endif
        clock_gettime(CLOCK_MONOTONIC, &t1);
        if (bad) {
            fprintf(stderr, "an interval was refused by @P@_step_dt\\n");
            return 4;
        }
        ns = ((double)(t1.tv_sec - t0.tv_sec) * 1e9 + (double)(t1.tv_nsec - t0.tv_nsec)) / (double)n;
        if (best < 0 || ns < best) best = ns;
    }
    for (i = 0; i < n; ++i)
        buf[i] = @FROM_WORD@;
    f = fopen(argv[2 + HARNESS_DT], "wb");
    if (!f || fwrite(buf, sizeof *buf, (size_t)n, f) != (size_t)n) return 3;
    fclose(f);
    printf("%.6f\\n", best);
    return 0;
}
"""


# Pieces of the fixed-rate step and of the dt step (irregular sampling), put into the templates.
_FIXED = {
    "float32": {"@STEP_FN@": 'float @P@_step(@P@_state *s, float raw)\n{\n    const float x = raw - @P@_offset;\n    float p = 0.0f, S;\n    int k;\n    for (k = 0; k < @PU@_TERMS; ++k)\n        p += @P@_beta[k] * s->hi[k];\n    S = x - p;\n    for (k = 0; k < @PU@_TERMS; ++k) {\n        /* c_k += a_k (S - c_k); the increment is added to hi exactly (TwoSum), its rounding\n         * error carried in lo to the next update. */\n        const float hi = s->hi[k];\n        const float m = @P@_a[k] * (S - hi) + s->lo[k];\n        const float sum = hi + m;\n        const float m_part = sum - hi;\n        const float hi_part = sum - m_part;\n        s->hi[k] = sum;\n        s->lo[k] = (hi - hi_part) + (m - m_part);\n    }\n    (void)@P@_saturation;\n    return @RETURN@;\n}\n', "@COEF_A@": 'static const float @P@_a[@PU@_TERMS] = {@A@};\n'},
    "q31": {"@STEP_FN@": 'int32_t @P@_step(@P@_state *s, int32_t x)\n{\n    int64_t p = 0, S;\n    int k;\n    for (k = 0; k < @PU@_TERMS; ++k)\n        p += @P@_shift(@P@_shift(s->c[k], 30) * @P@_beta_m[k], @P@_beta_s[k]);\n    S = (int64_t)x - @P@_shift(p, 30);\n    for (k = 0; k < @PU@_TERMS; ++k)\n        s->c[k] += @P@_shift((S - @P@_shift(s->c[k], 30)) * @P@_a_m[k], @P@_a_s[k]);\n    (void)@P@_saturation_q30;\n    return @RETURN@;\n}\n', "@COEF_A@": 'static const int32_t @P@_a_m[@PU@_TERMS] = {@A_M@};\nstatic const unsigned char @P@_a_s[@PU@_TERMS] = {@A_S@};\n'},
}

_DT_FLOAT_STEP = """/* a = 1 - exp(-x) for x > 0 without libm: x halved until x <= 1/8, the Taylor series of
 * (1 - exp(-x))/x in Horner form, then a <- a (2 - a) once per halving, since
 * 1 - a(2y) = (1 - a(y))^2. Relative error in the header's bound. */
static float @P@_a_of(float x)
{
    int m = 0, j;
    float t = 1.0f, a;
    while (x > 0.125f) {
        x *= 0.5f;
        ++m;
    }
    for (j = @N@ - 1; j >= 1; --j)
        t = 1.0f - x * @P@_inv_next[j] * t;
    a = x * t;
    while (m-- > 0)
        a = a * (2.0f - a);
    return a;
}

int @P@_step_dt(@P@_state *s, float raw, float dt, float *out)
{
    const float x = raw - @P@_offset;
    float p = 0.0f, S;
    int k;
    if (!(dt >= @PU@_MIN_INTERVAL_S && dt <= @PU@_MAX_INTERVAL_S))
        return -1;
    for (k = 0; k < @PU@_TERMS; ++k) {
        /* c_k += a_k(dt) (S_prev - c_k): the load held since the previous sample; the
         * increment is added to hi exactly (TwoSum), its rounding error carried in lo. */
        const float a = @P@_a_of(dt * @P@_inv_tau[k]);
        const float hi = s->hi[k];
        const float m = a * (s->last - hi) + s->lo[k];
        const float sum = hi + m;
        const float m_part = sum - hi;
        const float hi_part = sum - m_part;
        s->hi[k] = sum;
        s->lo[k] = (hi - hi_part) + (m - m_part);
    }
    for (k = 0; k < @PU@_TERMS; ++k)
        p += @P@_beta[k] * s->hi[k];
    S = x - p;
    s->last = S;
    (void)@P@_saturation;
    *out = @RETURN@;
    return 0;
}

static void @P@_pack_last(const @P@_state *s, uint32_t *w0, uint32_t *w1)
{
    memcpy(w0, &s->last, sizeof *w0);
    *w1 = 0u;
}

static void @P@_unpack_last(@P@_state *s, uint32_t w0, uint32_t w1)
{
    (void)w1;
    memcpy(&s->last, &w0, sizeof w0);
}
"""

_DT_FLOAT_COEF = """static const float @P@_inv_tau[@PU@_TERMS] = {@INV_TAU@};   /* 1/tau_k (1/s) */
static const float @P@_inv_next[@N@] = {@INV_NEXT@};   /* 1/(j+1) */"""

_DT_Q31_STEP = """/* t = (1 - exp(-x))/x in Q31 (2^31 = 1) for 0 <= x <= 1/2 given in Q31: Taylor series in
 * Horner form. */
static int64_t @P@_t_of(int64_t x)
{
    const int64_t one = (int64_t)1 << 31;
    int64_t t = one;
    int j;
    for (j = @N@ - 1; j >= 1; --j)
        t = one - @P@_shift(@P@_shift(x * @P@_inv_next[j], 31) * t, 31);
    return t;
}

int @P@_step_dt(@P@_state *s, int32_t x, uint32_t dt, int32_t *out)
{
    int64_t p = 0, S;
    int k;
    if (dt < 1u || dt > @PU@_MAX_TICKS)
        return -1;
    for (k = 0; k < @PU@_TERMS; ++k) {
        /* c_k += a_k(dt) (S_prev - c_k), a_k = x t(x), x = dt tick/tau_k = dt m_k 2^-e_k:
         * ((S_prev - c_k) t) m_k dt, shifted by e_k - 30 in two steps. */
        const int64_t xm = (int64_t)dt * @P@_tick_m[k];
        const int64_t t = @P@_t_of(@P@_shift(xm, (unsigned)@P@_tick_e[k] - 31u));
        const int64_t d = @P@_shift((s->last - @P@_shift(s->c[k], 30)) * t, 31);
        int64_t inc = @P@_shift(d * @P@_tick_m[k], @R1@) * (int64_t)dt;
        if (@P@_r2[k] > 0)
            inc = @P@_shift(inc, @P@_r2[k]);
        s->c[k] += inc;
    }
    for (k = 0; k < @PU@_TERMS; ++k)
        p += @P@_shift(@P@_shift(s->c[k], 30) * @P@_beta_m[k], @P@_beta_s[k]);
    S = (int64_t)x - @P@_shift(p, 30);
    s->last = S;
    (void)@P@_saturation_q30;
    *out = @RETURN@;
    return 0;
}

static void @P@_pack_last(const @P@_state *s, uint32_t *w0, uint32_t *w1)
{
    const uint64_t u = (uint64_t)s->last;
    *w0 = (uint32_t)(u & 0xffffffffu);
    *w1 = (uint32_t)(u >> 32);
}

static void @P@_unpack_last(@P@_state *s, uint32_t w0, uint32_t w1)
{
    const uint64_t u = ((uint64_t)w1 << 32) | w0;
    s->last = (u >> 63) ? -(int64_t)(~u) - 1 : (int64_t)u;
}
"""

_DT_Q31_COEF = """static const int32_t @P@_tick_m[@PU@_TERMS] = {@TICK_M@};   /* tick/tau_k = m 2^-e */
static const unsigned char @P@_tick_e[@PU@_TERMS] = {@TICK_E@};
static const unsigned char @P@_r2[@PU@_TERMS] = {@R2@};
static const int64_t @P@_inv_next[@N@] = {@INV_NEXT@};   /* 2^31/(j+1) */"""

_DT_COMMON = {
    "@INIT_EXTRA@": "\n    s->last = 0;",
    "@SAVED_BASE@": "4",
    "@RESTORE_EXTRA@": "\n    @P@_unpack_last(s, in->w[1 + 2 * @PU@_TERMS], in->w[2 + 2 * @PU@_TERMS]);",
    "@SAVE_EXTRA@": "\n    @P@_pack_last(s, &out->w[1 + 2 * @PU@_TERMS], &out->w[2 + 2 * @PU@_TERMS]);",
}
_DT = {
    "float32": {"@STEP_FN@": _DT_FLOAT_STEP, "@COEF_A@": _DT_FLOAT_COEF,
                "@STATE_EXTRA@": " float last;", "@SETTLE_EXTRA@": "\n    s->last = c;",
                "@STEP_DECL@": ("/* Irregular sampling: dt = seconds since the previous sample (any value in range on\n"
                                " * the first call). Returns 0 and writes *out, or -1 (nothing changed) when dt is\n"
                                " * outside [@PU@_MIN_INTERVAL_S, @PU@_MAX_INTERVAL_S] or not a number. */\n"
                                "int @P@_step_dt(@P@_state *s, float raw, float dt, float *out);")},
    "q31": {"@STEP_FN@": _DT_Q31_STEP, "@COEF_A@": _DT_Q31_COEF,
            "@STATE_EXTRA@": " int64_t last;",
            "@SETTLE_EXTRA@": "\n    s->last = @P@_shift(s->c[0], 30);",
            "@STEP_DECL@": ("/* Irregular sampling: dt = ticks of @PU@_TICK_S s (microseconds) since the previous\n"
                            " * sample (any value in range on the first call). Returns 0 and writes *out, or -1\n"
                            " * (nothing changed) when dt is outside [1, @PU@_MAX_TICKS]. */\n"
                            "int @P@_step_dt(@P@_state *s, int32_t x, uint32_t dt, int32_t *out);")},
}


_FLOAT_STATE = """
/* State in signal units above the offset: c_k = hi[k] + lo[k]. Owned by the caller. */
typedef struct { float hi[@PU@_TERMS]; float lo[@PU@_TERMS];@STATE_EXTRA@ } @P@_state;
"""

_Q31_STATE = """
/* Input and output words: round((signal - offset) / FULL_SCALE * 2^30), so |word| <= 2^30 at
 * full scale (one bit of headroom). State: c_k * 2^60 / FULL_SCALE. Owned by the caller. */
typedef struct { int64_t c[@PU@_TERMS];@STATE_EXTRA@ } @P@_state;
"""

_NAIVE_HEADER = _HEADER_TOP + """
typedef struct { float c[@PU@_TERMS]; } @P@_state;

void @P@_init(@P@_state *s);
void @P@_settle(@P@_state *s, float raw);
float @P@_step(@P@_state *s, float raw);

#ifdef __cplusplus
}
#endif
#endif
"""

_FLOAT_IO = {"@HARNESS_DT@": "0", "@T@": "float", "@DT_T@": "float", "@TO_WORD@": "(float)buf[i]", "@FROM_WORD@": "(double)out[i]"}
_Q31_IO = {"@HARNESS_DT@": "0", "@T@": "int32_t", "@DT_T@": "uint32_t",
           "@TO_WORD@": "(int32_t)llround((buf[i] - @PU@_OFFSET) / @PU@_FULL_SCALE * 1073741824.0)",
           "@FROM_WORD@": "@PU@_OFFSET + (double)out[i] * (@PU@_FULL_SCALE / 1073741824.0)"}

_FLOAT32 = _Texts(header=_fill(_HEADER_TOP + _FLOAT_STATE + _HEADER_API, _FLOAT_IO),
                  source=_FLOAT32_SOURCE, harness=_fill(_HARNESS, _FLOAT_IO))
_Q31 = _Texts(header=_fill(_HEADER_TOP + _Q31_STATE + _HEADER_API, _Q31_IO),
              source=_Q31_SOURCE, harness=_fill(_HARNESS, _Q31_IO))
_NAIVE = _Texts(header=_NAIVE_HEADER, source=_NAIVE_SOURCE, harness=_fill(_HARNESS, _FLOAT_IO))
