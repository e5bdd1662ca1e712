"""The proven worst-case error of the generated C corrector against the exact one.

The C code (:mod:`creepcomp.digital.firmware`) stores rounded coefficients and rounds every
operation. Each rounding and each stored coefficient's error is a local error; the state errors
obey ``d[n+1] = M d[n] + a eps[n] + eta[n]`` with ``M = I - diag(a) - a beta^T`` (the corrector's
own recursion), so a local error reaches the output through the impulse response of that
recursion, whose l1 norm is bounded by the geometric sums ``sum_i |l_i r_i| / (1 - |lambda_i|)``
over the eigenvalues of ``M``. For the dt step (irregular sampling) a componentwise invariant
over all allowed intervals takes the place of the eigenvalues. ``docs/firmware.md`` has the
derivation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from creepcomp.errors import InputError
from creepcomp.model import CreepModel

__all__ = ["PRECISIONS", "FULL_SCALE_WORD", "REFERENCE_ALLOWANCE", "MIN_INTERVAL", "TICK",
           "DEFAULT_TEMPERATURE_RANGE", "ErrorBound", "firmware_bound", "check_arguments",
           "check_interval", "TargetArithmetic", "TARGET_ARITHMETIC", "check_target_arithmetic",
           "BoundedCorrector", "RecursionGains", "SampleErrors", "ExactCoefficients",
           "VaryingAErrors", "Float32DtScheme", "Q31DtScheme", "Float32TemperatureScheme",
           "Q31TemperatureScheme",
           "StoredCoefficients", "exact_coefficients", "stored_coefficients", "dt_scheme",
           "float32_value", "temperature_scheme", "q31_temperature_scheme", "temperature_bound",
           "TEMPERATURE_STEP_Q", "ROOT_STEPS", "polynomial_bound", "EXP_RELATIVE_ERROR",
           "reloading_bound", "peak_bound", "play_bound", "recovery_bound", "overshoot_bound",
           "OVERSHOOT_EVENTS", "STATES", "check_state"]

PRECISIONS = ("float32", "q31")
#: How a float32 corrector holds each creep state: ``compensated``, a float and the rounding
#: error of its last update carried in a second float; ``plain``, one float (fewer operations,
#: a bound larger by about ``u tau / T``).
STATES = ("compensated", "plain")
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
class TargetArithmetic:
    """The arithmetic of a machine the corrector runs on, as its bound takes it.

    The float32 bound counts every operation of ``float`` as IEEE binary32 rounded to nearest
    (ties to even) with gradual underflow, each rounding at most ``float_unit_roundoff`` of its
    result; the q31 corrector uses fixed-width integers only, the same on every machine.

    Attributes
    ----------
    target : str
        ``host``, ``avr``, ``cortex-m0plus`` or ``cortex-m4f``.
    float_arithmetic : str
        Where its binary32 operations come from.
    float_unit_roundoff : float
        ``u`` of its ``float``: ``2**-24`` (binary32 rounded to nearest) on every target here.
    double_bits : int
        Significand bits of its C ``double``: 53 (binary64), or 24 on the ATmega328P, whose
        avr-gcc ``double`` is binary32. A map computed in ``double`` (the diagnosis's extensions)
        has its bound for 53 bits only.
    fused_multiply_add : bool
        It has a fused multiply-add a build may contract ``a * b + c`` into: one rounding where
        the bound counts two of no larger terms, so the bound still holds.
    """

    target: str
    float_arithmetic: str
    float_unit_roundoff: float
    double_bits: int
    fused_multiply_add: bool


#: The arithmetic of each target of ``creepcomp firmware --verify --target``.
TARGET_ARITHMETIC = {
    "host": TargetArithmetic("host", "the host's FPU (x86-64 SSE)", _U32, 53, False),
    "avr": TargetArithmetic("avr", "avr-libc's soft float", _U32, 24, False),
    "cortex-m0plus": TargetArithmetic("cortex-m0plus", "libgcc's soft float", _U32, 53, False),
    "cortex-m4f": TargetArithmetic("cortex-m4f", "the FPv4-SP unit", _U32, 53, True),
}


def check_target_arithmetic(target: str, uses_double: bool) -> TargetArithmetic:
    """The arithmetic of ``target``, refused (InputError) when the corrector computes in
    ``double`` and the target's ``double`` is narrower than the binary64 its bound assumes."""
    arithmetic = TARGET_ARITHMETIC[target]
    if uses_double and arithmetic.double_bits < 53:
        raise InputError(f"target {target}: the extension's map is computed in double, which the "
                         f"bound takes as IEEE binary64, and {target}'s double has "
                         f"{arithmetic.double_bits} bits; verify it with --target host")
    return arithmetic


# ----------------------------------------------------------------------------------- checks

def check_arguments(model: CreepModel, method: str, precision: str, rate: float,
                    full_scale: float, name: str) -> None:
    """Refuse bad arguments of the generator and the bound with an InputError.

    An unknown method or precision, a rate outside 1e-300 to 1e12 Hz, a full scale that is not
    positive and finite, a name that is not a C identifier of at most 63 characters, or a model
    the corrector cannot invert.
    """
    from creepcomp.digital.correctors import check_invertible

    if method not in _METHODS:
        raise InputError(f"method '{method}': use 'subtractive' or 'supplemental'")
    if precision not in PRECISIONS:
        raise InputError(f"precision '{precision}': use 'float32' or 'q31'")
    if not 1e-300 <= rate <= 1e12:   # 1/rate, the sample step, must stay a normal double
        raise InputError(f"rate = {rate!r} Hz: the sample rate must be from 1e-300 Hz to 1e12 Hz")
    if not (full_scale > 0 and math.isfinite(full_scale)):
        raise InputError(f"full scale = {full_scale!r}: must be positive and finite (signal units)")
    if not (name and name.isascii() and name.replace("_", "a").isalnum() and not name[0].isdigit()
            and len(name) <= 63):
        raise InputError(f"name '{name[:70]}': a C identifier is needed (letters, digits, '_'; "
                         "not starting with a digit; at most 63 characters)")
    check_invertible(model)


def check_state(state: str, precision: str, fixed_linear: bool) -> None:
    """Refuse (InputError) a state form that is not one of :data:`STATES`, or ``plain`` for
    any corrector but the float32 fixed-rate step of a model's creep terms alone."""
    if state not in STATES:
        raise InputError(f"state '{state}': use {' or '.join(STATES)}")
    if state == "plain" and (precision != "float32" or not fixed_linear):
        raise InputError("plain states are for the float32 corrector at a fixed rate without a "
                         "temperature law, static maps, a static polynomial response or an "
                         "extension map: use the compensated states (the default) for this one")


def check_interval(max_interval: float) -> None:
    """Raise InputError unless the dt step can accept intervals up to ``max_interval`` (s)."""
    if not MIN_INTERVAL <= max_interval <= 1e12:
        raise InputError(f"max interval = {max_interval!r}: must be from {MIN_INTERVAL:g} s (the "
                         "shortest interval the dt step accepts) to 1e12 s")


@dataclass(frozen=True)
class ExactCoefficients:
    """The corrector's recursion at one sample interval, exact (float64).

    Attributes
    ----------
    interval : float
        The sample interval ``T`` (s).
    beta, tau : numpy.ndarray
        The creep terms' amplitudes and retardation times (s).
    a : numpy.ndarray
        ``a_k = 1 - exp(-T / tau_k)``, the weight of a state's update.
    decay : numpy.ndarray
        ``e_k = exp(-T / tau_k) = 1 - a_k``.
    saturation : float
        ``sigma = 1 + beta0``, the supplemental method's output scale.
    inv_saturation : float
        ``w = 1 / (1 + beta0)``, a settled start's state per unit input.
    offset : float
        The signal at no load (signal units).
    """

    interval: float
    beta: np.ndarray
    tau: np.ndarray
    a: np.ndarray
    decay: np.ndarray
    saturation: float
    inv_saturation: float
    offset: float


@dataclass(frozen=True)
class StoredCoefficients:
    """The coefficients as the C code stores them, with their exact values (float64).

    Attributes
    ----------
    precision : str
        ``float32`` or ``q31``.
    beta, a : numpy.ndarray
        The stored ``beta_k`` and ``a_k``: binary32 values, or ``m 2^-(31 + s)`` of their q31
        mantissas.
    offset : float
        The stored offset (binary32; q31 works above the offset: the exact one).
    saturation, inv_saturation : float
        The stored ``1 + beta0`` and ``1 / (1 + beta0)`` (q31: words of ``2^30``).
    beta_q, a_q : list of (int, int) or None
        q31: the mantissas ``m`` (``2^30 <= |m| < 2^31``) and right shifts ``s``.
    saturation_q, inv_saturation_q : int or None
        q31: ``1 + beta0`` and ``1 / (1 + beta0)`` times ``2^30``, rounded.
    """

    precision: str
    beta: np.ndarray
    a: np.ndarray
    offset: float
    saturation: float
    inv_saturation: float
    beta_q: list | None = None
    a_q: list | None = None
    saturation_q: int | None = None
    inv_saturation_q: int | None = None


def exact_coefficients(model: CreepModel, rate: float) -> ExactCoefficients:
    """The recursion's exact coefficients at ``rate`` (Hz), in float64."""
    taus = np.array(model.tau)
    x = (1.0 / rate) / taus
    return ExactCoefficients(interval=1.0 / rate, beta=np.array(model.beta), tau=taus,
                             a=-np.expm1(-x), decay=np.exp(-x), saturation=1.0 + model.beta0,
                             inv_saturation=1.0 / (1.0 + model.beta0), offset=model.offset)


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


@dataclass(frozen=True)
class RecursionGains:
    """l1 gains of the corrector's error recursion ``d[n+1] = M d[n] + g u[n]``, output
    ``beta . d``, at a fixed rate (each bounded by its modal expansion, so a little above).

    Attributes
    ----------
    sample : float
        ``L_sample = 1 + sum_m |beta^T M^m a|``: from a local error of ``S`` to the output,
        and from the input to ``S`` (so also the largest ``|S|`` per unit input).
    state : numpy.ndarray
        ``L_state[k] = sum_m |beta^T M^m e_k|``: from a local error of state ``k`` per sample.
    state_peak : numpy.ndarray
        ``G_state[k] = sup_m |beta^T M^m e_k|``: from an error of state ``k`` at the start.
    """

    sample: float
    state: np.ndarray
    state_peak: np.ndarray


def _gains(a: np.ndarray, beta: np.ndarray) -> RecursionGains:
    """The :class:`RecursionGains` of the recursion with weights ``a`` and amplitudes ``beta``,
    by the modal expansion ``sum_i |l_i r_i| / (1 - |lambda_i|)`` (``sum_i |l_i r_i|`` for the
    supremum)."""
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
    return RecursionGains(sample=l_sample * _MARGIN, state=l_state * _MARGIN,
                          state_peak=g_state * _MARGIN)


# ---------------------------------------------------------------------- stored coefficients

def float32_value(value: float) -> float:
    """``value`` rounded to IEEE binary32 (as a Python float)."""
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


def stored_coefficients(c: ExactCoefficients, precision: str) -> StoredCoefficients:
    """The coefficients as the C code stores them, and their values (float64, exact)."""
    beta, a = c.beta, c.a
    if precision == "float32":
        return StoredCoefficients(precision, beta=np.array([float32_value(b) for b in beta]),
                                  a=np.array([float32_value(x) for x in a]),
                                  offset=float32_value(c.offset),
                                  saturation=float32_value(c.saturation),
                                  inv_saturation=float32_value(c.inv_saturation))
    bm = [_mantissa(b, f"beta[{k}]") for k, b in enumerate(beta)]
    am = [_mantissa(x, f"a[{k}] = 1 - exp(-T/tau[{k}])") for k, x in enumerate(a)]
    sigma_q, w_q = round(c.saturation * FULL_SCALE_WORD), round(c.inv_saturation * FULL_SCALE_WORD)
    if not (0 < sigma_q < 2 ** 31 and 0 < w_q < 2 ** 31):
        raise InputError(f"beta0 = {c.saturation - 1:g}: q31 needs -0.5 < beta0 < 1 "
                         "(1 + beta0 and 1/(1 + beta0) are stored with 30 fraction bits)")
    return StoredCoefficients(precision, beta=np.array([m * 2.0 ** -(31 + s) for m, s in bm]),
                              a=np.array([m * 2.0 ** -(31 + s) for m, s in am]), offset=c.offset,
                              saturation=sigma_q / FULL_SCALE_WORD,
                              inv_saturation=w_q / FULL_SCALE_WORD, beta_q=bm, a_q=am,
                              saturation_q=sigma_q, inv_saturation_q=w_q)


# ------------------------------------------------------------------------------- the bound

def firmware_bound(model: CreepModel, method: str = "subtractive", precision: str = "float32",
                   rate: float = 100.0, full_scale: float = 1.0,
                   max_interval: float | None = None, state: str = "compensated") -> ErrorBound:
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
    state : {"compensated", "plain"}
        How the float32 states are held (:data:`STATES`); ``plain`` at a fixed rate only.

    Returns
    -------
    ErrorBound
        Bound on ``|C output - exact output| / full_scale`` for every sample of every input
        sequence in the range, from a relaxed or a settled start. float32 assumes IEEE binary32
        rounding to nearest with no excess precision (the C code refuses to compile otherwise).
    """
    check_state(state, precision, max_interval is None)
    if max_interval is not None:
        check_interval(max_interval)
        check_arguments(model, method, precision, 1.0 / max_interval, full_scale, "x")
        return _irregular_bound(model, method, precision, max_interval, full_scale)
    check_arguments(model, method, precision, rate, full_scale, "x")
    c = exact_coefficients(model, rate)
    corrector = BoundedCorrector(method, c, stored_coefficients(c, precision), full_scale, state)
    gains = _gains(c.a, c.beta)
    peak = gains.sample                               # max |S| / FS of the exact corrector
    sigma = corrector.output_scale
    # Everything below is in units of full scale. C bounds |computed state| and |computed S|;
    # it is checked (and raised if needed) after the error is known.
    cmax = peak * (1.0 + 1e-3)
    for _ in range(8):
        terms, b_s, eta_over_a = _local_terms(corrector, gains, cmax)
        need = peak + b_s + eta_over_a
        if cmax >= need:
            break
        # Plain states' error, u/a_k, passes the first guess's margin by little: twice the
        # excess over the exact peak, not twice the whole, which would double their bound.
        cmax = peak + 2 * (need - peak) if corrector.state == "plain" else 2 * need
    else:  # pragma: no cover - only for a corrector whose error is of the order of its signal
        raise InputError("the corrector's rounding error is of the order of its signal at this "
                         "rate and precision: no useful bound")
    if precision == "q31":
        _check_q31_range(peak, cmax, sigma, method)
    terms["float64 reference (allowance)"] = REFERENCE_ALLOWANCE
    total = sum(terms.values()) * _MARGIN
    return ErrorBound(total_fs=float(total), terms={n: float(v) for n, v in terms.items()},
                      full_scale=float(full_scale), peak_fs=float(peak),
                      gains={"sample": float(gains.sample), "state": [float(g) for g in gains.state]})


@dataclass(frozen=True)
class BoundedCorrector:
    """One generated corrector as its bound sees it.

    Attributes
    ----------
    method : str
        ``subtractive`` or ``supplemental``.
    exact : ExactCoefficients
        The recursion it implements.
    stored : StoredCoefficients
        What its C code stores (and so its precision).
    full_scale : float
        The input range the bound assumes, ``|raw - offset| <= full_scale`` (signal units).
    state : str
        float32: ``compensated`` (each state a float and its carried rounding error) or
        ``plain`` (one float); :data:`STATES`.
    """

    method: str
    exact: ExactCoefficients
    stored: StoredCoefficients
    full_scale: float
    state: str = "compensated"

    @property
    def precision(self) -> str:
        """``float32`` or ``q31``."""
        return self.stored.precision

    @property
    def terms(self) -> int:
        """The number of creep terms."""
        return len(self.exact.beta)

    @property
    def sum_beta(self) -> float:
        """``sum_k |beta_k|``: the creep states' weight in ``S``."""
        return float(np.sum(np.abs(self.exact.beta)))

    @property
    def output_scale(self) -> float:
        """What multiplies ``S`` in the output: ``1 + beta0`` (supplemental) or 1."""
        return self.exact.saturation if self.method == "supplemental" else 1.0


@dataclass(frozen=True)
class SampleErrors:
    """The local errors of one sample, as fractions of full scale (docs/firmware.md's table).

    Attributes
    ----------
    per_sample : dict
        The errors made in ``S`` each sample, by cause (input, coefficients beta, the sum).
    start : float
        The error of a settled start's states.
    output_offset : float
        The output's rounding with the offset added (float32).
    output_scale : float
        The supplemental output's scale: its stored value and rounding.
    """

    per_sample: dict
    start: float
    output_offset: float
    output_scale: float


def _sample_errors(corrector: BoundedCorrector, cmax: float) -> SampleErrors:
    """The local errors of ``S`` per sample, of a settled start and of the output, given that
    ``|computed state|`` and ``|computed S|`` stay within ``cmax`` (fraction of full scale)."""
    c, st, fs, method = corrector.exact, corrector.stored, corrector.full_scale, corrector.method
    k, sum_beta, precision = corrector.terms, corrector.sum_beta, corrector.precision
    beta = c.beta
    beta_err = float(np.sum(np.abs(st.beta - beta)))
    sum_beta_hat = float(np.sum(np.abs(st.beta)))
    if precision == "float32":
        u = _U32
        offset = abs(c.offset) / fs
        offset_err = abs(st.offset - c.offset) / fs
        raw_max = offset + 1.0
        x_err = u * raw_max + offset_err + u * (1.0 + u * raw_max + offset_err)
        gamma = k * u / (1 - k * u)
        c_hi = cmax * (1 + u)
        eps = {"input": x_err,
               "coefficients beta": beta_err * c_hi + sum_beta * u * c_hi,
               "sum beta.c": gamma * sum_beta_hat * c_hi + u * (1.0 + x_err + sum_beta_hat * c_hi * (1 + gamma))}
        start = x_err * abs(st.inv_saturation) + abs(st.inv_saturation - c.inv_saturation) + u * (1.0 + x_err) * abs(st.inv_saturation)
        out_offset = offset_err + u * (offset + offset_err + abs(st.saturation if method == "supplemental" else 1.0) * cmax * (1 + u))
        out_scale = (abs(st.saturation - c.saturation) * cmax + u * abs(st.saturation) * cmax
                     if method == "supplemental" else 0.0)
    else:
        x_err = _Q_IN
        c_q = cmax + _Q_IN
        eps = {"input": x_err,
               "coefficients beta": beta_err * c_q,
               "sum beta.c": sum_beta_hat * _Q_IN + k * _Q_STATE + _Q_IN}
        start = x_err * st.inv_saturation + abs(st.inv_saturation - c.inv_saturation)
        out_offset = 0.0
        out_scale = (abs(st.saturation - c.saturation) * cmax + _Q_IN) if method == "supplemental" else 0.0
    return SampleErrors(per_sample=eps, start=start, output_offset=out_offset, output_scale=out_scale)


def _float32_swap_error(a_stored, d: float, c_hi: float, u: float = _U32):
    """Local error of a float32 state update's error term taken by Fast2Sum with ``hi`` first.

    ``lo = m - (sum - hi)`` is the exact error of ``sum = hi + m`` when ``|hi| >= |m|``; when
    not (an increment passing a state near zero), ``sum - hi`` rounds by at most ``u |m| (1 +
    2u)`` and ``m - (sum - hi)``, at most ``u |m| (3 + 2u)`` itself, by ``u`` of that: ``hi +
    lo`` is then within ``u (1 + 6u) |m|`` of ``hi + m``, and ``|lo| <= 3.1 u |m|``. With
    ``|m| <= (â d (1+u)^3 + |lo|)(1 + u)`` and ``|lo| <= u max(c_hi, 3.1 |m|)``.

    Parameters
    ----------
    a_stored : float or numpy.ndarray
        The largest ``|a|`` the update multiplies by.
    d : float
        Bound of ``|target - hi|`` (fraction of full scale).
    c_hi : float
        Bound of ``|hi|`` (fraction of full scale).
    """
    return u * (1 + 6 * u) * (a_stored * d * (1 + u) ** 3 + u * (1 + u) * c_hi) / (1 - 4 * u)


def _float32_plain_update_error(a, a_err, d: float, cmax: float, u: float = _U32):
    """Local error of a plain float32 state update ``c = c + a (S - c)``, one float per state.

    The computed ``fl(c + fl(â fl(S - c)))`` is ``c + â (S - c)(1 + d1)(1 + d2)`` with the sum
    rounded by ``(1 + d3)``, ``|d_i| <= u``; against the exact update ``c + a (S - c)`` of the
    same ``c`` and ``S`` it is off by at most ``|â - a| d (1 + u)^2 + a d ((1 + u)^2 - 1) + u (|c|
    + â d (1 + u)^2)``. The last part, the rounding of the new state, is not proportional to
    ``a``: through the recursion's state gain (about ``beta_k / a_k``) it is the bound's
    largest part, about ``u cmax beta_k tau_k / T``.

    Parameters
    ----------
    a, a_err : numpy.ndarray
        The exact ``a_k`` and ``|stored a_k - a_k|``.
    d : float
        Bound of ``|S - c|`` (fraction of full scale).
    cmax : float
        Bound of ``|c|`` (fraction of full scale).

    Returns
    -------
    total, coefficient : numpy.ndarray
        The local error of each state's update, and its part due to the stored ``a_k``.
    """
    coefficient = a_err * d * (1 + u) ** 2
    rounding = a * d * ((1 + u) ** 2 - 1) + u * (cmax + (a + a_err) * d * (1 + u) ** 2)
    return coefficient + rounding, coefficient


def _local_terms(corrector: BoundedCorrector, gains: RecursionGains, cmax: float):
    """The local errors times their gains (fractions of full scale; see docs/firmware.md), given
    ``|computed state|, |computed S| <= cmax``. Returns the bound's parts, the bound of the
    error of ``S`` and the largest state error per unit ``a``."""
    a, st, sigma = corrector.exact.a, corrector.stored, corrector.output_scale
    l_sample, l_state, g_state = gains.sample, gains.state, gains.state_peak
    a_err = np.abs(st.a - a)
    d = 2 * cmax                                            # |S - c_k|
    local = _sample_errors(corrector, cmax)
    eps, start = local.per_sample, local.start
    if corrector.precision == "float32" and corrector.state == "plain":
        eta, eta_coef = _float32_plain_update_error(a, a_err, d, cmax)
    elif corrector.precision == "float32":
        u = _U32
        c_hi = cmax * (1 + u)
        eta = (a_err * d * (1 + u) ** 3 + a * d * ((1 + u) ** 3 - 1) + a * u * c_hi + u * u * c_hi
               + _float32_swap_error(a + a_err, d, c_hi))
        eta_coef = a_err * d * (1 + u) ** 3
    else:
        eta = a_err * d + st.a * _Q_IN + _Q_STATE
        eta_coef = a_err * d
    eps_total = sum(eps.values())
    state_terms = l_state * eta
    b_s = l_sample * eps_total + float(np.sum(state_terms)) + float(np.sum(g_state)) * start
    terms = {f"{name} (per sample, x{l_sample:.4g})": sigma * l_sample * v for name, v in eps.items()}
    coef_part = l_state * eta_coef
    terms["coefficients a_k (state updates)"] = sigma * float(np.sum(coef_part))
    terms["state updates rounding"] = sigma * float(np.sum(state_terms - coef_part))
    terms["settled start"] = sigma * float(np.sum(g_state)) * start
    terms["output"] = local.output_offset + local.output_scale
    return terms, b_s, float(np.max(eta / a))


# ------------------------------------------------------------- irregular sampling (dt step)

@dataclass(frozen=True)
class VaryingAErrors:
    """The errors of a step whose ``a_k`` change from sample to sample (the dt step, the
    temperature step, a recovery's switched term), as :func:`_invariant_bound` takes them.

    Attributes
    ----------
    rel_a : numpy.ndarray
        The worst relative error of each computed ``a_k``.
    extra : numpy.ndarray
        q31: the words' roundings in a state's update per unit ``a`` (fraction of full
        scale); float32: zeros.
    nu : numpy.ndarray
        The update's own rounding per sample: float32 relative to the state (``u^2``, the
        sum with ``lo``), q31 in fractions of full scale (the last shift, ``2^-60``).
    """

    rel_a: np.ndarray
    extra: np.ndarray
    nu: np.ndarray


@dataclass(frozen=True)
class Float32DtScheme(VaryingAErrors):
    """How the float32 dt step computes ``a_k(dt)`` (:func:`dt_scheme`).

    Attributes
    ----------
    dt_min, dt_max : float
        The interval range the bound covers (s; the float32 limits included).
    inv_tau : numpy.ndarray
        The stored ``1/tau_k`` (binary32 values, 1/s).
    halvings : numpy.ndarray
        Per term, the most halvings that bring ``x = dt/tau_k`` to ``x <= 1/8``.
    series : numpy.ndarray
        Per term, the Taylor terms of ``(1 - exp(-x))/x`` its range of ``x`` needs.
    series_c : list of float
        The stored coefficients ``(-1)^j / (j + 1)!``, as many as the most ``series``.
    limit_f, min_f : float
        The longest and shortest interval the step accepts, as binary32 (s).
    """

    dt_min: float
    dt_max: float
    inv_tau: np.ndarray
    halvings: np.ndarray
    series: np.ndarray
    series_c: list
    limit_f: float
    min_f: float


@dataclass(frozen=True)
class Q31DtScheme(VaryingAErrors):
    """How the q31 dt step computes ``a_k(dt)`` from whole ticks (:func:`dt_scheme`).

    Attributes
    ----------
    dt_min, dt_max : float
        The interval range (s): one tick to ``max_ticks`` ticks.
    max_ticks : int
        The longest interval the step accepts, in ticks of :data:`TICK`.
    m : list of (int, int)
        Per term, ``tick/tau_k`` as a mantissa and a shift.
    exps : numpy.ndarray
        Per term, ``31 + shift``: ``tick/tau_k = m 2^-exps``.
    n : int
        Taylor terms of ``t(x) = (1 - exp(-x))/x`` in Q31.
    inv_next : list of int
        ``2^31/(j + 1)``, ``j < n``.
    r1 : int
        The first right shift of the increment (after the product with ``m_k``).
    r2 : numpy.ndarray
        Per term, the second right shift (after the product with the interval).
    """

    dt_min: float
    dt_max: float
    max_ticks: int
    m: list
    exps: np.ndarray
    n: int
    inv_next: list
    r1: int
    r2: np.ndarray


@dataclass(frozen=True)
class Float32TemperatureScheme(VaryingAErrors):
    """How the float32 temperature step computes ``a_k = 1 - exp(-(T/tau_k) / a_T)``
    (:func:`temperature_scheme`).

    Attributes
    ----------
    low, high : float
        The temperature range (°C, binary32 values) the step clamps to.
    reference : float
        The law's reference temperature (°C, binary32).
    curve_c, curve_d : float
        ``C`` and ``D0`` of ``ln(1/a_T) = C d / (D0 + d)`` (binary32).
    log2e, ln2_head, ln2_tail : float
        ``1/ln 2`` and ``ln 2`` in two parts, for the range reduction of ``exp``.
    j_max : int
        The largest ``|j|`` of ``1/a_T = 2^j exp(f)``.
    exp_terms : int
        Degree of the Taylor polynomial of ``exp(f)``; ``exp_c`` its stored coefficients
        ``1/i!``, ``i <= exp_terms``.
    exp_c : list of float
    y_range : (float, float)
        ``ln(1/a_T)`` at the range's ends.
    rel_shift : float
        The worst relative error of the computed ``1/a_T``.
    dt : float
        The sample interval (s).
    dt_over_tau : numpy.ndarray
        The stored ``T/tau_k`` (binary32).
    a_max, a_min : numpy.ndarray
        ``a_k`` at the range's ends.
    tau_range : (numpy.ndarray, numpy.ndarray)
        ``tau_k`` at the range's ends.
    halvings, series, series_c
        As :class:`Float32DtScheme`.
    """

    low: float
    high: float
    reference: float
    curve_c: float
    curve_d: float
    log2e: float
    ln2_head: float
    ln2_tail: float
    j_max: int
    exp_terms: int
    exp_c: list
    y_range: tuple
    rel_shift: float
    dt: float
    dt_over_tau: np.ndarray
    a_max: np.ndarray
    a_min: np.ndarray
    tau_range: tuple
    halvings: np.ndarray
    series: np.ndarray
    series_c: list


@dataclass(frozen=True)
class Q31TemperatureScheme(VaryingAErrors):
    """How the q31 temperature step computes ``a_k`` with integers only
    (:func:`q31_temperature_scheme`).

    Attributes
    ----------
    low, high : float
        The temperature range (°C), whole steps of :data:`TEMPERATURE_STEP_Q`; ``low_q``,
        ``high_q`` in those steps.
    low_q, high_q : int
    reference_q : int
        The reference temperature in steps of :data:`TEMPERATURE_STEP_Q`.
    reference_d : int
        The reference temperature in units of ``d`` (2^-19 K).
    curve_c_q, curve_d_q : int
        ``C`` in Q28 and ``D0`` in units of ``d``.
    log2e_q, ln2_q : int
        ``2^24 / ln 2`` and ``ln 2`` in Q31.
    exp_terms : int
        Taylor terms of ``exp(f)`` in Q31; ``exp_next`` their ``2^31/(i + 1)``.
    exp_next : list of int
    y_range : (float, float)
        ``ln(1/a_T)`` at the range's ends.
    rel_shift : float
        The worst relative error of the computed ``1/a_T``.
    m : list of (int, int)
        Per term, ``T/tau_k`` as a mantissa and a shift; ``exps`` is ``31 + shift``.
    exps : numpy.ndarray
    n, inv_next
        As :class:`Q31DtScheme`.
    a_max, a_min : numpy.ndarray
        ``a_k`` at the range's ends.
    tau_range : (numpy.ndarray, numpy.ndarray)
        ``tau_k`` at the range's ends.
    dt : float
        The sample interval (s).
    """

    low: float
    high: float
    low_q: int
    high_q: int
    reference_q: int
    reference_d: int
    curve_c_q: int
    curve_d_q: int
    log2e_q: int
    ln2_q: int
    exp_terms: int
    exp_next: list
    y_range: tuple
    rel_shift: float
    m: list
    exps: np.ndarray
    n: int
    inv_next: list
    a_max: np.ndarray
    a_min: np.ndarray
    tau_range: tuple
    dt: float



def _series_terms(x_max: float, target: float) -> int:
    """Fewest Taylor terms N of ``a = x t(x)`` with truncation ``x^N/(N+1)! <= target``."""
    n = 2
    while x_max ** n / math.factorial(n + 1) > target:
        n += 1
    return n


#: Largest relative truncation of the float32 steps' Taylor series (``a_k``'s and ``exp``'s): a
#: quarter of the unit roundoff, below the roundings of their evaluation.
_TRUNCATION = 2.0 ** -26


def _horner_error(exact: list, stored: list, x_max: float, u: float = _U32) -> float:
    """Bound of the error of the float32 Horner evaluation ``t = c_i + x t`` of
    ``sum_i c_i x^i`` (``|x| <= x_max``, exact) with the stored coefficients, level by level:
    the inner error times ``x_max``, the product's rounding and the sum's, the stored
    coefficient's error. Absolute (units of the polynomial)."""
    mag, err = abs(exact[-1]), abs(stored[-1] - exact[-1])
    for c, c_f in zip(reversed(exact[:-1]), reversed(stored[:-1])):
        product = x_max * (mag + err)                      # |fl(x t)| before its rounding
        err = (abs(c_f - c) + x_max * err + u * product
               + u * (abs(c) + abs(c_f - c) + product * (1 + u)))
        mag = abs(c) + x_max * mag
    return err


def _float32_a_error(x_hi: np.ndarray, rel_x: np.ndarray, u: float):
    """The float32 computation of ``a = 1 - exp(-x)`` (``x`` up to ``x_hi``, stored with
    relative error ``rel_x``): halvings to ``x <= 1/8``, per term the Taylor terms of
    ``t = (1 - exp(-x))/x`` its ``x`` needs (truncation below :data:`_TRUNCATION`), and ``a``'s worst
    relative error.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray, list, numpy.ndarray)
        Halvings and series terms per term, the stored coefficients ``(-1)^j/(j + 1)!``, the
        relative error of each computed ``a_k``.
    """
    halvings = np.array([max(0, math.ceil(math.log2(x / 0.125))) if x > 0.125 else 0
                         for x in x_hi], dtype=int)
    x_top = np.minimum(x_hi, 0.125)
    series = np.array([_series_terms(float(x), _TRUNCATION) for x in x_top], dtype=int)
    exact = [(-1) ** j / math.factorial(j + 1) for j in range(int(series.max()))]
    stored = [float32_value(c) for c in exact]
    rel_series = np.empty(len(x_hi))
    for k, (x, n) in enumerate(zip(x_top, series)):
        # the alternating series' tail is below its first term; t(x) >= 1 - x/2; then a = x t
        trunc = float(x) ** n / math.factorial(n + 1)
        t_min = 1 - float(x) / 2
        rel_series[k] = (1 + (trunc + _horner_error(exact[:n], stored[:n], float(x), u)) / t_min) * (1 + u) - 1
    # each doubling a <- a (2 - a) adds (1+u)^2 and does not increase a relative error
    return halvings, series, stored, (1 + rel_x) * (1 + rel_series) * (1 + u) ** (2 * halvings) - 1


def dt_scheme(model: CreepModel, precision: str, max_interval: float) -> Float32DtScheme | Q31DtScheme:
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
        dt_max = max(max_interval, float32_value(max_interval))
        dt_min = min(MIN_INTERVAL, float32_value(MIN_INTERVAL))
        inv_tau = np.array([float32_value(1.0 / tau) for tau in taus])
        delta_x = np.abs(inv_tau * taus - 1.0) + u * (1 + 1e-6)        # stored 1/tau, product
        x_hi = dt_max * inv_tau * (1 + u)
        halvings, series, series_c, rel_a = _float32_a_error(x_hi, delta_x, u)
        return Float32DtScheme(dt_min=dt_min, dt_max=dt_max, inv_tau=inv_tau, halvings=halvings,
                series=series, series_c=series_c,
                rel_a=rel_a, extra=np.zeros(len(taus)), nu=np.full(len(taus), u * u),
                limit_f=float32_value(max_interval), min_f=float32_value(MIN_INTERVAL))
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
    return Q31DtScheme(dt_min=TICK, dt_max=max_ticks * TICK, max_ticks=max_ticks, m=ms,
            exps=exps, n=n, inv_next=[round(2 ** 31 / (j + 1)) for j in range(n)],
            r1=r1, r2=r2, rel_a=(1 + rel_m) * (1 + rel_t) - 1, extra=extra,
            nu=np.where(r2 >= 1, _Q_STATE, 0.0))


# ------------------------------------------------------------- over temperature (float32)

#: Default temperature range (°C) of the generated corrector of a model with a temperature law.
DEFAULT_TEMPERATURE_RANGE = (-40.0, 85.0)
#: ln 2 split for the range reduction of exp: a 12-bit head (``j * head`` is exact for
#: ``|j| < 2**12``) and the float32 of the rest.
_LN2_HEAD = math.ldexp(round(math.ldexp(math.log(2.0), 11)), -11)
#: Largest |ln a_T| the step accepts over its range (keeps 2^j far inside float32).
_MAX_LOG_SHIFT = 60.0


def _law_curve(law) -> tuple[float, float]:
    """``(C, D0)`` of ``ln(1/a_T) = C d / (D0 + d)``, ``d = T - T_ref`` (K): Arrhenius
    ``C = E_a / (R T_ref)``, ``D0 = T_ref`` (kelvin); WLF ``C = c1 ln 10``, ``D0 = c2``."""
    from creepcomp.temperature import GAS_CONSTANT, ZERO_CELSIUS

    if law.law == "arrhenius":
        t_ref = law.reference + ZERO_CELSIUS
        return law.activation_energy / (GAS_CONSTANT * t_ref), t_ref
    return law.c1 * math.log(10.0), law.c2


def temperature_scheme(model: CreepModel, rate: float, low: float, high: float) -> Float32TemperatureScheme:
    """How the temperature step computes ``a_k = 1 - exp(-(T/tau_k) / a_T)`` per sample in
    float32 without libm, and the worst relative error of the computed ``a_k``.

    ``y = ln(1/a_T) = C d / (D0 + d)`` at the step's mid temperature (one division), then
    ``1/a_T = 2^j exp(f)`` with ``j`` the nearest integer to ``y / ln 2``, ``|f| <= ln 2 / 2``
    and a Taylor polynomial of ``exp(f)`` in Horner form; ``x_k = (T/tau_k) / a_T`` and
    ``a_k`` as in the dt step (:func:`dt_scheme`). Every rounding is bounded; the errors of
    the temperature, ``y``, ``f``, the polynomial and the stored ``T/tau_k`` add up in the
    relative error of ``x_k``, which bounds that of ``a_k``.

    Parameters
    ----------
    model : CreepModel
        With a temperature law (shift only: no ``beta_per_kelvin``).
    rate : float
        Sample rate (Hz).
    low, high : float
        Temperature range (°C): the step clamps to it, the bound holds over it.
    """
    u = _U32
    lo_f, hi_f = float32_value(low), float32_value(high)
    lo_t, hi_t = min(low, lo_f), max(high, hi_f)          # the range the bound covers
    law, shifts = _check_shift_law(model, lo_t, hi_t)
    y_lo, y_hi = -math.log(shifts[0]), -math.log(shifts[1])
    y_max = max(abs(y_lo), abs(y_hi))
    curve_c, curve_d = _law_curve(law)
    c_f, d_f, ref_f = float32_value(curve_c), float32_value(curve_d), float32_value(law.reference)
    t_abs = max(abs(lo_t), abs(hi_t))
    d_max = max(hi_t - law.reference, law.reference - lo_t)
    den_min = curve_d + (lo_t - law.reference)
    # y: mid temperature (sum rounded, halved exactly), d, the denominator, the product, the quotient
    err_mid = u * t_abs
    err_d = err_mid + abs(ref_f - law.reference) + u * (d_max + abs(ref_f - law.reference) + err_mid)
    d_hat = d_max + err_d
    rho = (abs(d_f - curve_d) + err_d + u * (curve_d + d_max + abs(d_f - curve_d) + err_d)) / den_min
    if rho >= 0.5:
        raise InputError(f"temperature range {low:g}:{high:g} °C comes too close to the law's "
                         "singularity for a float32 step")
    err_num = abs(c_f - curve_c) * d_hat + curve_c * err_d + u * abs(c_f) * d_hat
    err_y = (err_num / (den_min * (1 - rho)) + y_max * rho / (1 - rho)) * (1 + u) + u * (y_max + 1e-30) * 2
    y_hat = y_max + err_y
    # range reduction: j = nearest integer to y log2(e) (ties away), f = y - j ln2_head - j ln2_tail
    log2e_f = float32_value(1.0 / math.log(2.0))
    j_max = math.floor(y_hat * log2e_f * (1 + u) ** 2 + 0.5) + 1
    ln2_tail = float32_value(math.log(2.0) - _LN2_HEAD)
    f_max = math.log(2.0) * (0.5 + 3 * u * (y_hat / math.log(2.0) + 1)) + j_max * abs(ln2_tail) * 2 * u
    err_f = (u * (f_max + j_max * abs(ln2_tail)) * 2 + u * j_max * abs(ln2_tail)
             + j_max * abs(_LN2_HEAD + ln2_tail - math.log(2.0)))
    f_max += err_f
    n_exp = 2
    while f_max ** (n_exp + 1) / math.factorial(n_exp + 1) * math.exp(2 * f_max) > _TRUNCATION:
        n_exp += 1
    trunc = f_max ** (n_exp + 1) / math.factorial(n_exp + 1) * math.exp(2 * f_max)
    exp_exact = [1.0 / math.factorial(i) for i in range(n_exp + 1)]
    exp_c = [float32_value(c) for c in exp_exact]
    rel_horner = _horner_error(exp_exact, exp_c, f_max, u) / math.exp(-f_max)
    rel_r = math.exp(err_y + err_f) * (1 + rel_horner) * (1 + trunc) - 1
    # x_k = stored (T/tau_k) * r, then a_k as in the dt step
    dt = 1.0 / rate
    taus = np.array(model.tau)
    dt_over_tau = np.array([float32_value(dt / tau) for tau in taus])
    rel_x = (1 + np.abs(dt_over_tau * taus / dt - 1.0)) * (1 + rel_r) * (1 + u) - 1
    r_min, r_max = 1.0 / float(shifts[0]), 1.0 / float(shifts[1])
    x_hi = dt_over_tau * r_max * (1 + rel_x)
    halvings, series, series_c, rel_a = _float32_a_error(x_hi, rel_x, u)
    return Float32TemperatureScheme(low=lo_f, high=hi_f, reference=ref_f, curve_c=c_f, curve_d=d_f,
            log2e=log2e_f, ln2_head=_LN2_HEAD, ln2_tail=ln2_tail, j_max=j_max,
            exp_terms=n_exp, exp_c=exp_c,
            y_range=(y_lo, y_hi), rel_shift=rel_r, dt=dt, dt_over_tau=dt_over_tau,
            a_max=-np.expm1(-dt / taus * r_max), a_min=-np.expm1(-dt / taus * r_min),
            tau_range=(taus / r_min, taus / r_max), halvings=halvings, series=series,
            series_c=series_c, rel_a=rel_a,
            extra=np.zeros(len(taus)), nu=np.full(len(taus), u * u))


#: q31 temperature step: the temperature argument's unit (°C).
TEMPERATURE_STEP_Q = 1.0 / 256.0
#: q31 temperature step: fraction bits of y = ln(1/a_T), and the extra bits of its division.
_Y_BITS = 28
_D_BITS = 10


def _check_shift_law(model: CreepModel, low: float, high: float):
    """The law of a temperature step, checked; returns ``(law, shifts at low and high)``."""
    law = model.temperature
    if law is None:
        raise InputError("the model has no temperature law: it has no temperature step")
    if any(b != 0 for b in law.beta_per_kelvin):
        raise InputError("the model's temperature law changes the amplitudes (beta_per_kelvin): "
                         "the firmware follows the shift of the retardation times only; "
                         "give a model without beta_per_kelvin")
    if not (math.isfinite(low) and math.isfinite(high) and low < high):
        raise InputError(f"temperature range {low:g}:{high:g} °C: expected LOW:HIGH with LOW < HIGH")
    shifts = law.shift(np.array([low, high]))             # refuses a range the law cannot take
    y_max = max(abs(math.log(shifts[0])), abs(math.log(shifts[1])))
    if y_max > _MAX_LOG_SHIFT:
        raise InputError(f"the temperature law shifts tau by e^{y_max:.3g} over {low:g}:{high:g} °C; "
                         f"the firmware takes at most e^{_MAX_LOG_SHIFT:g}: narrow --temperature-range")
    return law, shifts


def q31_temperature_scheme(model: CreepModel, rate: float, low: float, high: float) -> Q31TemperatureScheme:
    """How the q31 temperature step computes ``a_k`` per sample with integers only, and its errors.

    The temperature comes in units of :data:`TEMPERATURE_STEP_Q` °C (°C x 256, int32), so the
    step's mid temperature is exact (the sum of two); ``y = ln(1/a_T)`` in Q28 is one 64-bit
    division ``C_q d / (D0_q + d)`` (``d`` = the mid temperature above the reference, in
    2^-19 K); ``1/a_T = p 2^j`` with ``j`` the nearest integer to ``y / ln 2``, ``f = y - j ln 2``
    in Q31 and ``p = exp(f)`` in Q31 by its Taylor polynomial (Horner, rounding shifts). Per term,
    ``x_k = m_k p 2^(j - e_k)`` (``m_k 2^-e_k`` = ``T/tau_k``) feeds ``t(x) = (1 - exp(-x))/x``
    of the q31 dt step, and the increment ``(S - c_k) a_k`` is ``((S - c_k) t) mp_k
    2^(j - e_k + 31)`` with ``mp_k = m_k p 2^-32``: ``a_k`` keeps its relative precision however
    small it is.
    """
    law, _ = _check_shift_law(model, low, high)
    q = TEMPERATURE_STEP_Q
    low_q, high_q = math.floor(low / q + 1e-9), math.ceil(high / q - 1e-9)   # covers low:high
    lo_t, hi_t = low_q * q, high_q * q
    if not lo_t < hi_t:
        raise InputError(f"temperature range {low:g}:{high:g} °C is narrower than the q31 step's "
                         f"resolution {q:g} °C")
    shifts = law.shift(np.array([lo_t, hi_t]))
    curve_c, curve_d = _law_curve(law)
    ref_q = round(law.reference / q)
    unit = q / 2 / 2 ** _D_BITS                                    # K per unit of d
    c_q = round(curve_c * 2 ** _Y_BITS)
    d_q = round(curve_d / unit)
    ref_d = round(law.reference / unit)                            # the reference in units of d
    err_c = abs(c_q * 2.0 ** -_Y_BITS - curve_c)
    err_d0 = abs(d_q * unit - curve_d)
    err_ref = abs(ref_d * unit - law.reference)
    d_max = max(hi_t - law.reference, law.reference - lo_t) + err_ref
    den_min = curve_d + (lo_t - law.reference) - err_d0 - err_ref
    if den_min <= 0:
        raise InputError(f"temperature range {low:g}:{high:g} °C reaches the law's singularity")
    y_abs = [abs(math.log(x)) for x in shifts]
    y_max = max(y_abs) + curve_c * err_d0 / den_min + 1e-6
    d_units = 2 * d_max / (q / 2) * 2 ** _D_BITS + 2
    if abs(c_q) * d_units >= 2.0 ** 62 or (curve_d + d_max) / unit >= 2.0 ** 62:
        raise InputError(f"the temperature law's constants over {low:g}:{high:g} °C do not fit the "
                         "q31 step's 64-bit division; use float32")
    # y: the stored C and D0 (and the reference's rounding), the truncating division (1 unit)
    err_y = err_c * d_max / den_min + y_max * err_d0 / den_min + curve_c * err_ref \
        * curve_d / den_min ** 2 + 2.0 ** -_Y_BITS
    y_hat = y_max + err_y
    log2e_q = round(2 ** 24 / math.log(2.0))
    ln2_q = round(math.log(2.0) * 2 ** 31)
    j_max = math.floor(y_hat / math.log(2.0) + 0.5 + 1e-9) + 1
    f_max = math.log(2.0) * (0.5 + y_hat * 2.0 ** -23) + j_max * 2.0 ** -32 + err_y
    err_f = j_max * abs(ln2_q * 2.0 ** -31 - math.log(2.0))
    n_exp = 2
    while f_max ** (n_exp + 1) / math.factorial(n_exp + 1) * math.exp(2 * f_max) > 2.0 ** -36:
        n_exp += 1
    trunc = f_max ** (n_exp + 1) / math.factorial(n_exp + 1) * math.exp(2 * f_max)
    # Horner in Q31: each level rounds f/(i) (with the stored 2^31/(i+1)) and its product with p
    top, err = math.exp(f_max), 0.0
    for i in range(n_exp, 0, -1):
        err = 2.0 ** -32 * (1 + (1 + f_max) * (top + err)) + f_max / i * err
    rel_p = err / math.exp(-f_max)
    rel_r = math.exp(err_y + err_f) * (1 + rel_p) * (1 + trunc) - 1
    dt = 1.0 / rate
    taus = np.array(model.tau)
    r_min, r_max = 1.0 / float(shifts[0]), 1.0 / float(shifts[1])
    x_max = float(np.max(dt / taus)) * r_max * (1 + rel_r) * (1 + 2.0 ** -30)
    if x_max > 0.5:
        raise InputError(f"the q31 temperature step needs T/tau_k <= 1/2 at {high:g} °C (tau_k "
                         f"reaches {float(np.min(taus)) / r_max:.3g} s there): sample faster, narrow "
                         "--temperature-range or use float32")
    ms = [_mantissa(dt / tau, f"T/tau[{k}]") for k, tau in enumerate(taus)]
    mant = np.array([m for m, _ in ms], dtype=float)
    exps = np.array([31 + sh for _, sh in ms], dtype=int)
    rel_m = np.abs(mant * 2.0 ** -exps / (dt / taus) - 1.0)
    p_min = math.exp(-f_max) * (1 - rel_p - trunc)
    rel_mp = 0.5 / (2.0 ** 30 * p_min * 2 ** 31 * 2.0 ** -32)      # mp_k >= 2^30 p_min / 2
    n = _series_terms(0.5, 2.0 ** -34)
    t_min = -math.expm1(-x_max) / x_max
    rel_t = (3 * 2.0 ** -31 + 0.5 ** n / math.factorial(n + 1)) / t_min
    rel_a = (1 + rel_m) * (1 + rel_r) * (1 + rel_mp) * (1 + rel_t) - 1
    # per unit a: the word rounding of c_k >> 30 and of (S - c_k) t; the last shift (or a shift
    # beyond 62 bits, which gives 0) is below one state unit, 2^-60 of full scale, per sample
    extra = (2.0 ** -31 + 2.0 ** -31 / t_min) * np.ones(len(taus))
    return Q31TemperatureScheme(low=lo_t, high=hi_t, low_q=low_q, high_q=high_q, reference_q=ref_q,
            reference_d=ref_d,
            curve_c_q=c_q, curve_d_q=d_q, log2e_q=log2e_q, ln2_q=ln2_q,
            exp_terms=n_exp, exp_next=[round(2 ** 31 / (i + 1)) for i in range(n_exp)],
            y_range=(-math.log(shifts[0]), -math.log(shifts[1])), rel_shift=rel_r,
            m=ms, exps=exps, n=n, inv_next=[round(2 ** 31 / (j + 1)) for j in range(n)],
            a_max=-np.expm1(-dt / taus * r_max), a_min=-np.expm1(-dt / taus * r_min),
            tau_range=(taus / r_min, taus / r_max), rel_a=rel_a, extra=extra,
            nu=np.full(len(taus), 2.0 ** -60), dt=dt)


def temperature_bound(model: CreepModel, method: str, rate: float, full_scale: float,
                      scheme: Float32TemperatureScheme | Q31TemperatureScheme,
                      precision: str = "float32") -> ErrorBound:
    """Proven worst-case error of the temperature step against the exact corrector
    (:func:`creepcomp.digital.correctors.compensate` with the same temperatures), for every
    temperature history within the scheme's range (:func:`temperature_scheme`,
    :func:`q31_temperature_scheme`)."""
    check_arguments(CreepModel(model.beta, model.tau, model.gain, model.offset), method,
                    precision, rate, full_scale, "x")
    c = exact_coefficients(model, rate)
    st = stored_coefficients(c, precision)
    try:
        return _invariant_bound(c, st, scheme, scheme.a_max, scheme.a_min, method,
                                precision, full_scale, "coefficients a_k(T) (a_T and exp without libm)")
    except InputError as exc:
        slowest = float(np.max(scheme.tau_range[0]))
        raise InputError(f"{exc} over {scheme.low:g} to {scheme.high:g} °C (the slowest "
                         f"retardation time reaches {slowest:.3g} s, {slowest * rate:.3g} samples): "
                         "narrow --temperature-range") from None


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
    c = exact_coefficients(model, 1.0 / max_interval)
    st = stored_coefficients(c, precision)
    sch = dt_scheme(model, precision, max_interval)
    taus = c.tau
    a_max = -np.expm1(-sch.dt_max / taus)
    a_min = -np.expm1(-sch.dt_min / taus)
    return _invariant_bound(c, st, sch, a_max, a_min, method, precision, full_scale,
                            "coefficients a_k(dt) (series, stored 1/tau)")


def _invariant_bound(c: ExactCoefficients, st: StoredCoefficients, sch: VaryingAErrors, a_max: np.ndarray, a_min: np.ndarray,
                     method: str, precision: str, full_scale: float, coef_label: str,
                     state_error: list | None = None) -> ErrorBound:
    """The bound of a step whose ``a_k`` changes from sample to sample within
    ``[a_min_k, a_max_k]`` (dt step, temperature step), from :func:`_invariant_gains`.

    ``sch`` gives the relative error ``rel_a`` of the computed ``a_k``, and the rounding
    ``nu`` (and ``extra``, q31) of the state update. ``state_error``: a list to which the
    bound of the states' errors (fraction of full scale) is appended.
    """
    beta = c.beta
    zmat, _ = _invariant_gains(beta, a_max)
    b = np.abs(beta)
    sum_beta = float(b.sum())
    gain_state = b @ zmat                          # output error per unit of w_k (per unit a)
    gain_sample = 1.0 + float(gain_state.sum())   # from a local error of S
    z_peak = zmat @ np.ones(len(b))               # |c_k| of the exact corrector, |x| <= 1
    z_peak = z_peak + max(0.0, abs(c.inv_saturation) - float(np.min(z_peak)))     # settled start
    peak = 1.0 + float(b @ z_peak)                # |S| of the exact corrector
    sigma = c.saturation if method == "supplemental" else 1.0
    k = len(beta)
    u = _U32
    cmax = max(peak, float(np.max(z_peak))) * (1.0 + 1e-3)
    for _ in range(8):
        d = 2 * cmax
        local = _sample_errors(BoundedCorrector(method, c, st, full_scale), cmax)
        eps, start = local.per_sample, local.start
        eps_total = sum(eps.values())
        if precision == "float32":
            coef = sch.rel_a * d * (1 + u) ** 3
            rounding = (d * ((1 + u) ** 3 - 1) + u * cmax * (1 + u) + sch.nu * cmax * (1 + u) / a_min
                        + _float32_swap_error(1 + sch.rel_a, d, 0.0)
                        + _float32_swap_error(0.0, d, cmax * (1 + u)) / a_min)
        else:
            coef = sch.rel_a * d
            rounding = sch.extra + sch.nu / a_min
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
    terms[coef_label] = sigma * float(gain_state @ coef)
    terms["state updates rounding"] = sigma * float(gain_state @ rounding)
    terms["settled start"] = sigma * sum_beta * start
    terms["output"] = local.output_offset + local.output_scale
    terms["float64 reference (allowance)"] = REFERENCE_ALLOWANCE
    total = sum(terms.values()) * _MARGIN
    if state_error is not None:
        state_error.append(float(np.max(z_err)))
    return ErrorBound(total_fs=float(total), terms={n: float(v) for n, v in terms.items()},
                      full_scale=float(full_scale), peak_fs=float(peak),
                      gains={"sample": float(gain_sample), "state": [float(g) for g in gain_state]})


def _check_q31_range(peak: float, cmax: float, sigma: float, method: str) -> None:
    """Every word and product of the q31 code fits its integer type."""
    out = sigma * cmax if method == "supplemental" else cmax
    if cmax * FULL_SCALE_WORD + 2 >= 2 ** 31 or out * FULL_SCALE_WORD + 2 >= 2 ** 31:
        raise InputError(f"the corrected signal can reach {max(cmax, out):.4g} x full scale, beyond "
                         "the q31 words' one bit of headroom (2 x full scale); use float32")


#: Bisection steps of the C corrector's polynomial root (in double): the bracket's width falls
#: to ``2**-ROOT_STEPS`` of the root's range.
ROOT_STEPS = 64
#: Unit roundoff of IEEE double.
_U64 = 2.0 ** -53


def _least_slope(c2: float, c3: float, reach: float) -> float:
    """Least slope of ``X + c2 X^2 + c3 X^3`` over ``|X| <= reach``: at the ends or at the
    vertex of the quadratic ``1 + 2 c2 X + 3 c3 X^2``."""
    points = [-reach, reach]
    if c3 != 0 and abs(c2 / (3 * c3)) <= reach:
        points.append(-c2 / (3 * c3))
    return min(1 + 2 * c2 * x + 3 * c3 * x * x for x in points)


def polynomial_bound(linear: ErrorBound, c2: float, c3: float, offset: float) -> tuple[ErrorBound, float]:
    """The bound of a corrector whose output is the root ``X`` of ``X + c2 X^2 + c3 X^3 = S``
    (``S``: the linear corrector's output above the offset, within ``linear``'s bound), found
    by :data:`ROOT_STEPS` bisection steps in double over ``|X| <= reach``.

    With ``m`` the polynomial's least slope over the reach, ``|dX| <= |dS| / m``: the linear
    corrector's error divided by ``m``; the bracket's last width; the rounding of the
    polynomial's evaluation in double (at most 6 roundings of terms no larger than
    ``|X| + |c2| X^2 + |c3| |X|^3 + |S|``: a sign taken wrong only that close to the root,
    divided by ``m``); the rounding of ``offset + X`` to float32.

    Returns
    -------
    (ErrorBound, float)
        The bound (fractions of full scale) and the reach (signal units).
    """
    fs = linear.full_scale
    s_max = (linear.peak_fs + linear.total_fs) * fs
    reach = s_max
    for _ in range(60):
        m = _least_slope(c2, c3, reach)
        if m <= 0:
            raise InputError("the static polynomial does not rise over the corrector's range: "
                             "no C corrector for it")
        wanted = 1.01 * s_max / m
        if wanted <= reach:
            break
        reach = wanted
    else:  # pragma: no cover - a slope that keeps falling as the range grows
        raise InputError("the static polynomial's root leaves every range: no C corrector for it")
    m = _least_slope(c2, c3, reach)
    poly = reach + abs(c2) * reach ** 2 + abs(c3) * reach ** 3 + s_max
    terms = {f"linear corrector / least slope {m:.4g}": linear.total_fs / m,
             f"root bracket after {ROOT_STEPS} bisections": 2 * reach * 2.0 ** -ROOT_STEPS / fs,
             "polynomial in double": 6 * _U64 * poly / m / fs,
             "output rounding (float32)": 2.0 ** -24 * (abs(offset) + reach) / fs * (1 + 2 * _U64)}
    total = sum(terms.values()) * _MARGIN
    return ErrorBound(total_fs=float(total), terms={n: float(v) for n, v in terms.items()},
                      full_scale=fs, peak_fs=float(reach / fs),
                      gains=dict(linear.gains, least_slope=float(m))), float(reach)


# ------------------------------------------------------------ extensions of the diagnosis

#: Relative error of ``expm1(y)``, ``|y| <= 32``, as the C corrector computes it in double
#: without libm (range reduction by ``ln 2`` in two parts, 18 Taylor terms of ``exp(f)`` for
#: ``|f| <= ln2 / 2``, 20 of ``expm1(y)`` for ``|y| < 1/2``): at most about 12 roundings of
#: the result's size; 32 is taken.
EXP_RELATIVE_ERROR = 32 * _U64


def _output_rounding(offset: float, offset_stored: float, x_max: float) -> float:
    """``(float)((double) offset + X)``: the float32 offset's error and the final rounding
    (signal units)."""
    return abs(offset_stored - offset) + _U32 * (abs(offset) + x_max) * (1 + 2 * _U64)


def _reloading_shape(softening: float, shape: float, chord: float) -> tuple[float, float]:
    """Least slope in ``|x|`` of ``t (1 - softening g(1 - t/m))`` over ``0 <= t <= m`` (and 1
    on the virgin curve), and the largest ``|d/dm|`` of it, ``|softening| (1 - z)^2 |g'(z)|``.

    Evaluated on 20001 points of ``z`` in [0, 1]; the least slope is lowered by the grid's
    half step times a bound of its derivative (``|softening| (2 max|g'| + max|g''|)``), so it
    is a lower bound."""
    z = np.linspace(0.0, 1.0, 20001)
    if abs(shape) < chord:
        g, dg, ddg = z, np.ones_like(z), np.zeros_like(z)
    else:
        den = math.expm1(-shape)
        g, dg, ddg = (np.expm1(-shape * z) / den, -shape * np.exp(-shape * z) / den,
                      shape * shape * np.exp(-shape * z) / den)
    slope = 1.0 - softening * (g - (1.0 - z) * dg)
    change = abs(softening) * (2 * float(np.max(np.abs(dg))) + float(np.max(np.abs(ddg))))
    least = min(1.0, float(np.min(slope)) - 0.5 * (z[1] - z[0]) * change)
    return least, abs(softening) * float(np.max((1.0 - z) ** 2 * np.abs(dg)))


def _map_bound(linear: ErrorBound, offset: float, offset_stored: float, least: float, lm: float,
               x_max: float, evaluation: float, maximum_gain: float, label: str,
               precision: str = "float32") -> ErrorBound:
    """The bound of an output map ``X = f^-1(S; m)`` with a running maximum ``m`` of ``|X|``
    (the linear corrector unchanged, its states driven by ``S``).

    ``f`` rises in ``|X|`` with slope at least ``least`` and ``|df/dm| <= lm``. Below ``m``
    the response's size is below the virgin response's at ``m``, so ``m`` is the virgin
    inverse of the running maximum of ``|S|``: its error is at most ``maximum_gain`` times the
    largest error ``E_S`` of ``S`` (the linear bound) plus its own evaluation's. The bisection's
    comparison is right wherever ``|f - S|`` exceeds ``e_f``, the evaluation error of ``f`` in
    double, so ``|dX| <= (E_S + e_f + lm E_m) / least + br`` (``br``: the bracket's last
    width: ``2^-64`` of the range in double, a word in q31). q31 outputs the word found: no
    output rounding."""
    fs = linear.full_scale
    bracket = x_max * 2.0 ** -ROOT_STEPS if precision == "float32" else 2 * _Q_IN * fs
    gain = (1.0 + lm * maximum_gain) / least              # of E_S, directly and through m
    own = (evaluation + lm * (maximum_gain * evaluation + bracket)) / least + bracket
    terms = {f"linear corrector (x{gain:.4g}: least slope {least:.4g}, running maximum {lm:.4g})":
             linear.total_fs * gain,
             f"{label} ({'in double' if precision == 'float32' else 'in words'}), bisection bracket": own / fs}
    if precision == "float32":
        terms["output rounding (float32)"] = _output_rounding(offset, offset_stored, x_max) / fs
    else:
        _check_q31_range(x_max / fs, x_max / fs, 1.0, "subtractive")
    total = sum(terms.values()) * _MARGIN
    return ErrorBound(total_fs=float(total), terms={n: float(v) for n, v in terms.items()},
                      full_scale=fs, peak_fs=float(x_max / fs),
                      gains=dict(linear.gains, least_slope=float(least), maximum_gain=float(lm)))


def reloading_bound(linear: ErrorBound, softening: float, shape: float, chord: float,
                    offset: float, offset_stored: float, precision: str = "float32") -> ErrorBound:
    """The bound of the reloading curve's inverse (softening below the running maximum ``m``
    of ``|X|``): ``S = X (1 - softening g(1 - |X|/m))`` below ``m``, ``S = X`` on the virgin
    curve, so ``m`` is the running maximum of ``|S|`` and ``|X| <= m`` (see :func:`_map_bound`,
    ``maximum_gain`` 1, ``m`` set exactly). ``f`` is evaluated with at most 8 roundings of its
    size, and ``g`` of a shaped curve with two ``expm1`` of relative error
    :data:`EXP_RELATIVE_ERROR` each. q31 (the chord): ``t (m - t) / m`` truncated to a word,
    its product with the stored softening rounded to half a word, the stored softening's
    error on ``t (m - t) / m <= m / 4``."""
    least, lm = _reloading_shape(softening, shape, chord)
    if least <= 0:
        raise InputError("the reloading curve does not rise: no C corrector for it")
    x_max = (linear.peak_fs + linear.total_fs) * linear.full_scale
    if precision == "float32":
        g_error = 0.0 if abs(shape) < chord else 2.2 * EXP_RELATIVE_ERROR
        evaluation = x_max * (8 * _U64 * (1 + abs(softening)) + abs(softening) * g_error)
    else:
        m, sh = _mantissa(softening, "softening")
        word = 2 * _Q_IN * linear.full_scale
        evaluation = (abs(softening) + 0.5) * word + abs(m * 2.0 ** -(31 + sh) - softening) * x_max / 4
    return _map_bound(linear, offset, offset_stored, least, lm, x_max, evaluation, 1.0, "reloading curve",
                      precision)


def peak_bound(linear: ErrorBound, softening: float, scale: float, offset: float,
               offset_stored: float, precision: str = "float32") -> ErrorBound:
    """The bound of the inverse of ``S = X (1 - k m)``, ``k = softening / scale``, ``m`` the
    running maximum of ``|X|`` including this sample (see :func:`_map_bound`): ``m`` is the
    virgin inverse of the running maximum of ``|S|``, the root ``t`` of ``t (1 - k t) = |S|``,
    so ``|X| <= m <= X_max``, the root at the largest ``|S|``; below ``m`` the slope is
    ``1 - k m``, on the virgin curve ``1 - 2 k |X|`` (its inverse's gain ``1 / least``);
    ``|df/dm| <= |k| X_max``."""
    k = softening / scale
    s_max = (linear.peak_fs + linear.total_fs) * linear.full_scale * 1.01
    if k > 0 and 4 * k * s_max >= 1:
        raise InputError("the softened response does not rise over the corrector's range: no C "
                         "corrector for it")
    x_max = 2 * s_max / (1 + math.sqrt(1 - 4 * k * s_max)) if k > 0 else s_max
    least = 1.0 - 2.0 * max(k, 0.0) * x_max
    if precision == "float32":
        evaluation = 6 * _U64 * x_max * (1 + abs(k) * x_max)
    else:
        # k FS stored as a mantissa; k t^2 from t^2 rounded to 2^30 and the product to half a
        # word; below m the quotient S 2^30 / (2^30 - k m) truncated (a word), its divisor rounded
        fs = linear.full_scale
        m, sh = _mantissa(k * fs, "k x full scale")
        word = 2 * _Q_IN * fs
        k_err = abs(m * 2.0 ** -(31 + sh) - k * fs) / fs
        evaluation = 2 * word + k_err * x_max ** 2 + (word + k_err * x_max * x_max) / least
    return _map_bound(linear, offset, offset_stored, least, abs(k) * x_max, x_max, evaluation,
                      1.0 / least, "softened response", precision)


def play_bound(model: CreepModel, rate: float, full_scale: float, ratio: float,
               half_width: float, precision: str = "float32") -> ErrorBound:
    """The bound of the corrector whose creep states are driven by the load ``X`` found from
    ``S = X + ratio (P - X)``, ``P = clip(P_prev, X - r, X + r)`` a play operator.

    ``X(S, P_prev)`` is continuous and piecewise linear: on the branches that follow the
    load ``X = S +- ratio r`` (slopes 1 and 0), in the dead band ``X = (S - ratio P_prev) /
    (1 - ratio)``; so ``|dX| <= max(1, (1 + |ratio|) / |1 - ratio|) max(|dS|, |dP_prev|)``.
    ``P`` is copied in the dead band and recomputed from ``S`` on the branches (slopes
    ``(0, 1)`` and ``(1, 0)`` in ``(S, P_prev)``), so ``|dP| <= max(|dP_prev|, |dS|)``: its
    error never exceeds the largest error of ``S`` (plus its own rounding). The states then
    obey the max-norm invariant of :func:`_loop_bound`. ``|X| <= |S| + |ratio| r``."""
    if not abs(1.0 - ratio) > 0 or ratio >= 1.0:
        raise InputError("the play operator's weight is not below the gain: no C corrector for it")
    lip = max(1.0, (1.0 + abs(ratio)) / abs(1.0 - ratio))
    sum_beta = float(np.sum(np.abs(model.beta)))
    x_exact = (full_scale + abs(ratio) * half_width) / max(1.0 - sum_beta, 1e-300)
    reach = x_exact + half_width
    if precision == "float32":
        ext = 2 * _U64 * reach * abs(ratio) / abs(1.0 - ratio) + 8 * _U64 * reach * lip
    else:
        if reach / full_scale >= 1.9:     # |S - P| below 2^32 words: its product fits 64 bits
            raise InputError("the play operator reaches beyond the q31 words' headroom (2 x full "
                             "scale); use float32")
        # words of 2^-30 FS: ratio r and r rounded (half a word each), the dead band's product
        # rounded (half a word) with the stored ratio / (1 - ratio)'s error on |S - P|; P's
        # own rounding through L_P
        k2 = ratio / (1.0 - ratio)
        m, sh = _mantissa(k2, "ratio / (1 - ratio)")
        k2_err = abs(m * 2.0 ** -(31 + sh) - k2)
        word = _Q_IN * full_scale
        ext = (3 * word + k2_err * 2 * reach) + abs(ratio) / abs(1.0 - ratio) * word
    return _loop_bound(model, rate, full_scale, lip, x_exact, ext, "play operator", precision)


#: The discounted count of the load's turns the overshoot's printed bound assumes
#: (:func:`overshoot_bound`): the current run and two turns within its decay time.
OVERSHOOT_EVENTS = 3.0


def overshoot_bound(model: CreepModel, rate: float, full_scale: float, ratio: float,
                    half_width: float, weights, taus, events: float = OVERSHOOT_EVENTS) -> ErrorBound:
    """The bound of the corrector whose creep states are driven by the load ``X`` found from
    ``S = X + ratio sum_i w_i D_i``, ``D_i = (1 - a_i) D_i + |Q - Q_prev|`` (the total
    variation ``v`` of the play ``Q`` of ``X``, less its lag: ``v - lag_i(v)``).

    With ``E`` the known part ``ratio sum_i w_i (1 - a_i) D_i`` and ``W = sum_i w_i``, ``X(S - E,
    Q_prev)`` is continuous and piecewise linear: ``|dX| <= L1 (|dS| + |dE|) + L2 |dQ|``,
    ``L1 = 1 / (1 - |ratio W|)``, ``L2 = |ratio W| L1``; the play is 1-Lipschitz, ``|dQ| <= E_X``.
    The total variation's error telescopes along each run of moves in one direction (summation
    by parts: ``sum_j (1 - a)^(n-j) s (dQ_j - dQ_j-1)`` is at most ``2 (1 - a)^(n - end) max|dQ|``),
    so ``|dD_i| <= 2 R E_X`` with ``R`` the count of runs (the load's turns) and of samples where
    the C's play may move otherwise than the exact one (within the error of its dead band's
    edge), each discounted by ``(1 - a)`` per sample since: ``|dE| <= |ratio| K E_X``, ``K = 2 R
    sum_i w_i (1 - a_i)``, and ``E_X <= L1 E_S / (1 - g)``, ``g = L1 |ratio| K + L2 < 1``: the
    inverse's error gain of :func:`_loop_bound`. ``events``: ``R`` (a record's own from
    :func:`creepcomp.digital.firmware_extension.overshoot_events`). The magnitudes follow the
    same way: ``D_i <= 2 R (X_max + r)``. The double arithmetic adds a few roundings per
    sample, and each decay's rounding accumulated, ``3 u (D_max + 2 (X_max + r)) / a_i``.
    """
    w, tau = np.asarray(weights, float), np.asarray(taus, float)
    a = -np.expm1(-(1.0 / rate) / tau)
    total = abs(ratio) * float(np.sum(w))
    if total >= 1.0:
        raise InputError("the overshoot's amplitude is not below the gain: no C corrector for it")
    l1 = 1.0 / (1.0 - total)
    gain = l1 * abs(ratio) * 2 * events * float(np.sum(w * (1 - a))) + total * l1
    if gain >= 1.0:
        raise InputError(f"the overshoot's error gain through the total variation of the load is "
                         f"{gain:.3g} (the load turns {events:.3g} times, discounted, within its decay): "
                         "no error bound")
    sum_beta = float(np.sum(np.abs(model.beta)))
    spread = 2 * abs(ratio) * float(np.sum(w)) * events
    room = 1.0 - sum_beta - spread
    if room <= 0:
        raise InputError("the overshoot and the creep terms together can reach any size: no error bound")
    x_exact = (full_scale + spread * half_width) / room
    reach = x_exact + half_width
    d_max = 2 * events * reach                     # |D_i|: each run moves the play by 2 reach at most
    lip = l1 / (1.0 - gain)
    # X in double: a few roundings of its terms; D_i: 3 roundings of |D_i| + |change| a step,
    # decaying with 1 - a_i
    ext = lip * _U64 * (8 * (reach + total * d_max)
                        + abs(ratio) * float(np.sum(w * 3 * (d_max + 2 * reach) / a)))
    return _loop_bound(model, rate, full_scale, lip, x_exact, ext, "overshoot")


def _loop_bound(model: CreepModel, rate: float, full_scale: float, lip: float, x_exact: float,
                ext: float, label: str, precision: str = "float32") -> ErrorBound:
    """The bound of a float32 fixed-rate subtractive corrector whose states are driven by
    ``X``, a map of ``S`` (and of its own states) with error gain ``lip`` and evaluation
    error ``ext`` (signal units), ``|X| <= x_exact`` exactly.

    With ``D`` a bound of every state's error, ``|dS| <= sum|beta| D + eps`` (``eps``: the
    local errors of ``S``, :func:`_sample_errors`) and ``|dX| <= lip |dS| + ext``; a state's
    update ``c += a (X~ - c)`` then gives ``|d'| <= (1 - a) D + a (|dX| + u |X| + eta / a)``,
    which is at most ``D`` when ``D (1 - lip sum|beta|) >= lip eps + ext + u X + max eta/a``:
    the invariant holds from the relaxed start (no error) for every input in the range,
    when ``lip sum|beta| < 1``."""
    fs = full_scale
    c = exact_coefficients(model, rate)
    st = stored_coefficients(c, precision)
    beta, a = c.beta, c.a
    sum_beta = float(np.sum(np.abs(beta)))
    loop = lip * sum_beta
    if loop >= 1.0:
        raise InputError(f"{label}: the creep terms' coupling (sum of |beta| {sum_beta:.3g}) times the "
                         f"inverse's error gain {lip:.3g} is not below 1: no error bound")
    u = _U32
    gain = 1.0 / (1.0 - loop)
    cmax = x_exact / fs * (1.0 + 1e-3)
    for _ in range(8):
        eps = _sample_errors(BoundedCorrector("subtractive", c, st, fs), cmax).per_sample
        eps_total = sum(eps.values())
        d = 2 * cmax
        c_hi = cmax * (1 + u)
        if precision == "float32":
            eta = (np.abs(st.a - a) * d * (1 + u) ** 3 + a * d * ((1 + u) ** 3 - 1) + a * u * c_hi
                   + u * u * c_hi + _float32_swap_error(np.maximum(st.a, a), d, c_hi))
            rounding = float(np.max(eta / a)) + u * cmax       # and the target (float)X
        else:                                                  # the target X is a word already
            eta = np.abs(st.a - a) * d + st.a * _Q_IN + _Q_STATE
            rounding = float(np.max(eta / a))
        state = gain * (lip * eps_total + ext / fs + rounding)
        if cmax >= x_exact / fs + state:
            break
        cmax = 2 * (x_exact / fs + state)
    else:  # pragma: no cover
        raise InputError("the corrector's rounding error is of the order of its signal: no useful bound")
    terms = {f"{name} (per sample, x{lip * gain:.4g})": lip * gain * v for name, v in eps.items()}
    terms[f"{label} in double (x{gain:.4g})"] = gain * ext / fs
    terms[f"state updates, coefficients a_k (x{loop * gain:.4g})"] = loop * gain * rounding
    if precision == "float32":
        terms["output rounding (float32)"] = _output_rounding(c.offset, st.offset, x_exact + state * fs) / fs
    else:
        _check_q31_range(x_exact / fs, cmax, 1.0, "subtractive")
    terms["float64 reference (allowance)"] = REFERENCE_ALLOWANCE
    total = sum(terms.values()) * _MARGIN
    return ErrorBound(total_fs=float(total), terms={n: float(v) for n, v in terms.items()},
                      full_scale=float(fs), peak_fs=float(x_exact / fs),
                      gains={"sample": float(lip * gain), "state_error": float(state),
                             "loop": float(loop)})


def recovery_bound(model: CreepModel, rate: float, full_scale: float, term: int,
                   tau_recovery: float, precision: str = "float32") -> tuple[ErrorBound, dict]:
    """The bound of the corrector whose term ``term`` steps with ``a`` or ``a_r`` (the
    recovery's ``1 - exp(-T/tau_recovery)``) by the mode its state's step is in.

    Given the modes, it is the step of a time-varying ``a_k`` in ``[min(a, a_r), max(a,
    a_r)]``, bounded by the componentwise invariant of the temperature and dt steps
    (:func:`_invariant_bound`). The mode is exact where the reference's decision quantity
    ``q = sign(c)((h_n + h_n+1)/2 - c) + band`` is farther from 0 than the error of the C's
    (``margin``: the output's and the state's bounds, the dead band, roundings) and the
    state farther from 0 than its error; at a step where it is not, taking the other mode
    adds ``|a_r - a| |h_n - c_n|`` to the state, a local error of ``|a_r - a| / a_min`` per
    unit ``a``: ``switch_gain`` times the largest ``|h_n - c_n|`` of such steps adds to the
    bound (:func:`creepcomp.digital.firmware_check.verify_firmware` finds them).

    Returns
    -------
    (ErrorBound, dict)
        The bound given the modes, and ``{"margin", "state_error", "switch_gain", "a_recovery"}``
        (signal units; ``switch_gain`` per signal unit, as a fraction of full scale).
    """
    c = exact_coefficients(model, rate)
    st = stored_coefficients(c, precision)
    a_rec = -math.expm1(-c.interval / tau_recovery)
    a_rec_q = _mantissa(a_rec, "a_recovery = 1 - exp(-T/tau_recovery)")
    a_rec_st = float32_value(a_rec) if precision == "float32" else a_rec_q[0] * 2.0 ** -(31 + a_rec_q[1])
    a_lo, a_hi = c.a.copy(), c.a.copy()
    a_lo[term], a_hi[term] = min(c.a[term], a_rec), max(c.a[term], a_rec)
    rel = np.abs(st.a / c.a - 1)
    rel[term] = max(rel[term], abs(a_rec_st / a_rec - 1))
    k = len(c.a)
    # q31: per unit a, the input's rounding to 30 bits; the update's last shift (2^-60 FS)
    sch = (VaryingAErrors(rel_a=rel, extra=np.zeros(k), nu=np.zeros(k)) if precision == "float32" else
           VaryingAErrors(rel_a=rel, extra=np.full(k, _Q_IN), nu=np.full(k, _Q_STATE)))
    errors: list = []
    bound = _invariant_bound(c, st, sch, a_hi, a_lo, "subtractive", precision,
                             full_scale, "coefficients a_k, a_recovery (state updates)", errors)
    fs = full_scale
    state_error = errors[0] * fs
    x_max = (bound.peak_fs + bound.total_fs) * fs
    margin = (bound.total_fs * fs + state_error + 2e-9 * x_max + 8 * _U64 * x_max) * (1 + 1e-6)
    switch_gain = bound.gains["state"][term] * abs(a_rec - c.a[term]) / a_lo[term] / fs
    return bound, {"margin": margin, "state_error": state_error, "switch_gain": switch_gain,
                   "a_recovery": a_rec, "a_recovery_q": a_rec_q}
