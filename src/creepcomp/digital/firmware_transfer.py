"""The C corrector of a model with static maps (a ``transfer``), of a static calibration, or
of a model with a load filter.

A soft sensor's model reads ``signal = h^-1(offset + gain * G(s)[f(load)])``
(:mod:`creepcomp.transfer`). Its float32 step, per raw sample::

    z = h(raw)                      the signal map: where the creep is linear
    c = corrector(z)                the exact corrector of creepcomp.digital.firmware (none for
                                    a static calibration: c = z)
    compensated = h^-1(c)           what creepcomp.digital.correctors.compensate returns
    load = f^-1((c - offset) / (gain * scale))     what estimate_load returns without a load filter
    load_out = mean of the last N loads            with one (creepcomp.load_filter): estimate_load's

The C (reciprocal, saturating and spline with ``+ - * /`` only; power and log with
``powf``/``logf``/``expf``) is rendered by :mod:`creepcomp.digital.firmware` from
:func:`map_code`; this module bounds its float32 evaluation. The bound
propagates, in order: the raw sample's rounding through ``h``; the error of ``h``'s evaluation
into the corrector as an input error (through the corrector's own l1 gains); the corrector's
bound; the output error through ``h^-1`` and through ``f^-1`` over the range the full scale
implies, plus their own evaluation; with a load filter, the float32 rounding of the mean
(:func:`filter_rounding`). ``docs/firmware.md`` has the derivation.

With a signal map, ``full_scale`` is a range of the raw signal around the unloaded raw signal
``h^-1(offset)``: ``|raw - h^-1(offset)| <= full_scale``, inside the map's domain.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from creepcomp.digital.firmware_bound import (REFERENCE_ALLOWANCE, ErrorBound, _gains,
                                              exact_coefficients, firmware_bound, float32_value)
from creepcomp.errors import InputError
from creepcomp.model import CreepModel
from creepcomp.transfer import StaticMap

__all__ = ["LIBM_ULPS", "TransferBound", "transfer_bound", "map_code", "raw_range", "range_full_scale",
           "evaluation_error", "spread", "check_maps_arguments", "load_filter_samples",
           "filter_rounding", "check_filter_arguments"]

#: Error of ``powf``, ``logf`` and ``expf`` the bound assumes, in units in the last place of
#: the result: an assumption about the target's libm, which ``--verify`` checks against the
#: float64 reference on the libm the code is linked with.
LIBM_ULPS = 2.0
_U = 2.0 ** -24                    # unit roundoff of IEEE binary32
_ULP = 2 * _U                      # ulp(v) <= 2u |v| for a normal v
_TINY = 2.0 ** -126                # an absolute allowance for results near the subnormals
_MARGIN = 1.0 + 1e-6               # second-order terms and float64 evaluation of the bound


# ---------------------------------------------------------------------------- C of one map

def _spline_table(xs, ys) -> dict:
    """Knots (increasing ``xs``) and slopes of a piecewise-linear map, stored and exact."""
    xs, ys = np.asarray(xs, float), np.asarray(ys, float)
    slopes = np.diff(ys) / np.diff(xs)
    return {"x": xs, "y": ys, "s": slopes, "x_f": np.array([float32_value(v) for v in xs]),
            "y_f": np.array([float32_value(v) for v in ys]),
            "s_f": np.array([float32_value(v) for v in slopes])}


def map_code(m: StaticMap, direction: str) -> dict:
    """What the C template needs to evaluate ``m`` (``forward``) or ``m^-1`` (``inverse``).

    Returns
    -------
    dict
        ``form``, ``direction``, ``libm`` (whether it calls libm) and its constants (floats, to
        be stored as float32): ``origin``, ``exponent`` (the inverse's: ``1/e``), ``inv_limit``,
        or a spline's knot table ``x``, ``y``, ``s`` (slopes; the inverse's with the roles of
        ``x`` and ``y`` swapped, sorted increasing) and ``knots``.
    """
    p = m.parameters
    out = {"form": m.form, "direction": direction, "libm": m.form in ("power", "log")}
    if m.form in ("power", "reciprocal", "log"):
        out["origin"] = p["origin"]
    if m.form == "power":
        out["exponent"] = p["exponent"] if direction == "forward" else 1.0 / p["exponent"]
    if m.form == "saturating":
        out["inv_limit"] = 1.0 / p["limit"]
    if m.form == "spline":
        xs, ys = np.array(p["x"]), np.array(p["y"])
        if direction == "inverse":
            xs, ys = (ys, xs) if ys[-1] > ys[0] else (ys[::-1], xs[::-1])
        table = _spline_table(xs, ys)
        out.update(knots=len(xs), x=list(xs), y=list(ys), s=list(table["s"]))
    return out


# ------------------------------------------------------------------- float32 evaluation error

def _exact(m: StaticMap, direction: str):
    return m.forward if direction == "forward" else m.inverse


def _check_finite(values, what: str) -> None:
    if not np.all(np.isfinite(values)):
        raise InputError(f"{what} leaves the map's domain over the range the full scale implies: "
                         "give a smaller --full-scale")


def _difference_error(origin: float, d_max: float) -> float:
    """``fl(x - origin_f)`` against ``x - origin``: the stored origin and the rounding."""
    e_o = abs(float32_value(origin) - origin)
    return e_o + _U * (d_max + e_o)


def _power_exponent_error(exponent: float, d_lo: float, d_hi: float) -> float:
    """Largest ``|d^e (d^(e_f - e) - 1)|`` over ``d_lo <= d <= d_hi`` (``d >= 0``): the exponent
    stored as a float; ``d^e |ln d|`` peaks at the ends or at ``d = exp(-1/e)``."""
    delta = abs(float32_value(exponent) - exponent)
    points = [v for v in (d_lo, d_hi, math.exp(-1.0 / exponent)) if d_lo <= v <= d_hi and v > 0]
    return max((v ** exponent * math.expm1(abs(math.log(v)) * delta) for v in points), default=0.0)


def evaluation_error(m: StaticMap, direction: str, lo: float, hi: float) -> float:
    """Bound on ``|C float32 value - exact value|`` of ``m`` (or ``m^-1``) for every float input
    in ``[lo, hi]`` (the input itself exact; see :func:`spread` for its error).

    Parameters
    ----------
    m : StaticMap
    direction : {"forward", "inverse"}
    lo, hi : float
        The input range.

    Returns
    -------
    float
        In the output's units.

    Examples
    --------
    A conductance ``1/R`` of resistances from 1 to 10 kOhm, in float32:

    >>> from creepcomp.transfer import StaticMap
    >>> e = evaluation_error(StaticMap("reciprocal", {"origin": 0.0}), "forward", 1000.0, 10000.0)
    >>> print(f"{e:.3g} S, {e / (1e-3 * 2.0 ** -24):.2f} half-ulps of the largest conductance")
    1.19e-10 S, 2.00 half-ulps of the largest conductance
    """
    p = m.parameters
    f = _exact(m, direction)
    ends = np.array([lo, hi], float)
    values = f(ends)
    _check_finite(values, f"the {m.form} map")
    y_max = float(np.max(np.abs(values)))
    if m.form == "spline":
        return _spline_error(m, direction, lo, hi)
    if m.form == "saturating":
        inv = 1.0 / p["limit"]
        e_inv = abs(float32_value(inv) - inv)
        sign = -1.0 if direction == "forward" else 1.0
        denominators = 1.0 + sign * ends * inv
        d_min, d_max = float(np.min(denominators)), float(np.max(denominators))
        x_max = float(np.max(np.abs(ends)))
        e_d = x_max * e_inv + _U * x_max * abs(float32_value(inv)) * (1 + _U) + _U * (d_max + x_max * e_inv)
        if d_min <= e_d:
            raise InputError("the saturating map is evaluated too near its limit over the range the "
                             "full scale implies: give a smaller --full-scale")
        return x_max * e_d / (d_min * (d_min - e_d)) + _U * x_max / (d_min - e_d) + _TINY
    origin = p["origin"]
    o_f = float32_value(origin)
    e_o = abs(o_f - origin)
    if direction == "forward":
        d = np.abs(ends - origin)
        crosses = lo < origin < hi
        d_lo, d_hi = (0.0 if crosses else float(np.min(d))), float(np.max(d))
        e_d = _difference_error(origin, d_hi)
        if m.form in ("reciprocal", "log"):
            # fl(x - o_f) errs by e_o + u |d|: relative to d, largest nearest the origin
            e_d = _difference_error(origin, d_lo)
        if m.form == "reciprocal":
            if d_lo <= e_d:
                raise InputError("the reciprocal map is evaluated too near its origin over the range "
                                 "the full scale implies: give a smaller --full-scale")
            return e_d / (d_lo * (d_lo - e_d)) + _U / (d_lo - e_d) + _TINY
        if m.form == "log":
            if d_lo <= e_d:
                raise InputError("the log map is evaluated too near its origin over the range the "
                                 "full scale implies: give a smaller --full-scale")
            logs = max(abs(math.log(d_lo - e_d)), abs(math.log(d_hi + _difference_error(origin, d_hi))))
            return e_d / (d_lo - e_d) + LIBM_ULPS * _ULP * logs + _TINY
        exponent = p["exponent"]                          # power
        if exponent < 0 and d_lo <= e_d:
            raise InputError("the power map is evaluated too near its origin over the range the "
                             "full scale implies: give a smaller --full-scale")
        moved = spread(StaticMap("power", {"exponent": exponent, "origin": 0.0}),
                       "forward", (-d_hi if crosses else d_lo), d_hi, e_d)
        lo_d, hi_d = max(d_lo - e_d, 0.0), d_hi + e_d
        return (moved + _power_exponent_error(exponent, lo_d, hi_d) * (1 + _U)
                + LIBM_ULPS * _ULP * (y_max + moved) + _TINY)
    x_span = float(np.max(np.abs(values - origin)))           # |m^-1(y) - origin|
    if m.form == "reciprocal":
        return e_o + _U * x_span + _U * (abs(o_f) + x_span * (1 + _U)) + _TINY
    if m.form == "log":
        grown = x_span * (1 + LIBM_ULPS * _ULP)
        return e_o + LIBM_ULPS * _ULP * x_span + _U * (abs(o_f) + grown) + _TINY
    inv_exponent = 1.0 / p["exponent"]                        # power, inverse
    y_abs = np.abs(ends)
    crosses = lo < 0 < hi
    y_lo, y_hi = (0.0 if crosses else float(np.min(y_abs))), float(np.max(y_abs))
    part = _power_exponent_error(inv_exponent, y_lo, y_hi) * (1 + _U) + LIBM_ULPS * _ULP * x_span
    return e_o + part + _U * (abs(o_f) + x_span + part) + _TINY


def _spline_error(m: StaticMap, direction: str, lo: float, hi: float) -> float:
    """Per segment the C computes ``y_k + s_k (x - x_k)`` with stored knots and slope: their
    errors, three roundings, and a stored knot on the wrong side of the input (the neighbour's
    line, off by the slopes' difference times the knot's error)."""
    p = m.parameters
    xs, ys = np.array(p["x"]), np.array(p["y"])
    if direction == "inverse":
        xs, ys = (ys, xs) if ys[-1] > ys[0] else (ys[::-1], xs[::-1])
    t = _spline_table(xs, ys)
    n = len(xs)
    worst = 0.0
    for k in range(n - 1):
        left = -math.inf if k == 0 else min(t["x"][k], t["x_f"][k])
        right = math.inf if k == n - 2 else max(t["x"][k + 1], t["x_f"][k + 1])
        a, b = max(lo, left), min(hi, right)
        if a > b:
            continue
        width = max(abs(a - t["x_f"][k]), abs(b - t["x_f"][k]))
        s, s_f = t["s"][k], t["s_f"][k]
        e_x = abs(t["x_f"][k] - t["x"][k])
        e_t = _U * width
        product = abs(s_f) * width * (1 + _U) ** 2
        # an input between a knot and its stored value takes this segment's line where the
        # neighbour's holds: off by the slopes' difference times the knot's error
        kink = max((abs(t["s"][other] - s) * abs(t["x_f"][knot] - t["x"][knot])
                    for knot, other in ((k, k - 1), (k + 1, k + 1)) if 0 < knot < n - 1),
                   default=0.0)
        err = (abs(t["y_f"][k] - t["y"][k]) + abs(s_f - s) * width + abs(s) * (e_x + e_t)
               + _U * product + _U * (abs(t["y_f"][k]) + product) + kink)
        worst = max(worst, err)
    return worst + _TINY


def spread(m: StaticMap, direction: str, lo: float, hi: float, error: float) -> float:
    """``sup |g(y + e) - g(y)|`` over ``lo <= y <= hi``, ``|e| <= error``, ``g`` the map (or its
    inverse): how far an input error moves its output.

    Every form is monotone and convex or concave on its domain (a power through its origin:
    on either side, with its inflection at ``centre``), so a window of fixed width moves ``g``
    most at an end of the range or centred on the inflection; a spline by its steepest
    segment over the range.
    """
    if error == 0:
        return 0.0
    g = _exact(m, direction)
    centre = None
    if m.form == "power":
        centre = m.parameters["origin"] if direction == "forward" else 0.0
    if m.form == "spline":
        p = m.parameters
        xs, ys = np.array(p["x"]), np.array(p["y"])
        if direction == "inverse":
            xs, ys = (ys, xs) if ys[-1] > ys[0] else (ys[::-1], xs[::-1])
        slopes = np.abs(np.diff(ys) / np.diff(xs))
        seg_lo = np.concatenate([[-math.inf], xs[1:-1]])
        seg_hi = np.concatenate([xs[1:-1], [math.inf]])
        touched = (seg_hi >= lo - error) & (seg_lo <= hi + error)
        return float(np.max(slopes[touched])) * error * _MARGIN
    points = np.array([lo - error, lo, hi, hi + error], float)
    values = g(points)
    _check_finite(values, f"the {m.form} map (input within {error:.3g} of the range)")
    moves = [abs(values[1] - values[0]), abs(values[3] - values[2])]
    if centre is not None and lo - error <= centre <= hi + error:
        ends = g(np.array([centre - error / 2, centre + error / 2]))
        moves.append(abs(ends[1] - ends[0]))
    return max(moves) * _MARGIN


# ---------------------------------------------------------------------------- the whole bound

def raw_range(model: CreepModel, full_scale) -> tuple[float, float, float]:
    """``(raw0, raw_min, raw_max)``: the unloaded raw signal and the raw range the bound holds
    over, checked inside the signal map's domain.

    ``full_scale`` is a number (``|raw - raw0| <= full_scale``, ``raw0 = h^-1(offset)`` with a
    signal map, else the offset) or ``(low, high)``, the raw range itself: a sensor whose signal
    moves one way from its unloaded level (a resistance that falls with load) needs it.

    Examples
    --------
    A pad unloaded at 10 kOhm (conductance 1e-4 S), read between 2 and 18 kOhm:

    >>> from creepcomp.model import CreepModel
    >>> from creepcomp.transfer import StaticMap, Transfer
    >>> pad = CreepModel((0.2,), (5.0,), gain=1e-4, offset=1e-4,
    ...                  transfer=Transfer(signal_map=StaticMap("reciprocal", {"origin": 0.0})))
    >>> [round(v) for v in raw_range(pad, 8000.0)]
    [10000, 2000, 18000]
    """
    h = None if model.transfer is None else model.transfer.signal_map
    raw0 = model.offset if h is None else float(h.inverse(model.offset))
    if not math.isfinite(raw0):
        raise InputError(f"the signal map ({h.describe()}) has no raw signal for the offset "
                         f"{model.offset:.9g}: the model cannot be compiled")
    if isinstance(full_scale, (tuple, list)):
        low, high = (float(v) for v in full_scale)
        if not (math.isfinite(low) and math.isfinite(high) and low < high):
            raise InputError(f"raw range {low!r} to {high!r}: LOW must be below HIGH, both finite")
        where = f"--full-scale {low:.9g}:{high:.9g}"
    else:
        low, high = raw0 - full_scale, raw0 + full_scale
        where = f"--full-scale {full_scale:.9g}: the raw range {low:.9g} to {high:.9g} around the unloaded signal {raw0:.9g}"
    if h is not None:
        d_lo, d_hi = h.domain()
        if not (low > d_lo and high < d_hi):
            raise InputError(f"{where} leaves the signal map's domain ({h.describe()}: raw from "
                             f"{d_lo:.9g} to {d_hi:.9g}, ends excluded); give a raw range LOW:HIGH "
                             "inside it")
    return raw0, low, high


def range_full_scale(model: CreepModel, full_scale) -> float:
    """The full scale as one number: ``full_scale`` itself, or for a raw range ``(low, high)``
    the larger distance of its ends from the unloaded raw signal (signal units)."""
    raw0, low, high = raw_range(model, full_scale)
    return float(max(abs(low - raw0), abs(high - raw0)))


@dataclass(frozen=True)
class TransferBound:
    """The bound of a corrector with static maps, stage by stage.

    Attributes
    ----------
    linear : ErrorBound or None
        The creep corrector's own bound on the linearised signal (None for a static calibration).
    linear_full_scale : float
        ``max |h(raw) - offset|`` over the raw range (units of ``h``).
    raw : tuple of float
        ``(raw_min, raw_max)``: the input range (signal units).
    corrected : float
        Bound on the corrected linear value ``c`` (units of ``h``).
    compensated : float
        Bound on the compensated signal (signal units).
    load : float
        Bound on the load (load units).
    corrected_range, load_range : tuple of float
        The range of ``c`` (the corrector's reach from the raw range, see
        :func:`_reachable`) and of the load it stands for: the compensated signal's and the
        load's bounds hold for the samples whose exact ``c`` lies in it (always, for a static
        calibration).
    terms : dict
        The parts, by cause, in the units of the stage they enter.
    filter_samples : int
        ``N``, the loads the load filter averages at this rate (1: no filter); ``load`` is the
        filtered load's bound, against ``estimate_load`` with the filter.
    """

    linear: ErrorBound | None
    linear_full_scale: float
    raw: tuple[float, float]
    corrected: float
    compensated: float
    load: float
    corrected_range: tuple[float, float]
    load_range: tuple[float, float]
    terms: dict
    filter_samples: int = 1


def load_filter_samples(model: CreepModel, rate: float) -> int:
    """``N``, the loads the model's load filter averages at a sample rate (Hz): 1 without one."""
    return 1 if model.load_filter is None else model.load_filter.samples_at(1.0 / rate)


def filter_rounding(samples: int, largest: float) -> float:
    """Bound on the float32 rounding of the mean of ``n <= samples`` floats each within
    ``largest`` of 0, summed one after another and divided by ``n``.

    The sum's ``n - 1`` roundings err by at most ``gamma_(n-1) sum |y_j| <= gamma_(n-1) n L``
    (``gamma_m = m u / (1 - m u)``); divided by ``n`` that is ``gamma_(n-1) L``, and the
    division adds ``u`` times the computed mean, at most ``(1 + gamma_(n-1)) L``. It grows
    with ``n``: the full window is the worst.

    Examples
    --------
    >>> u = 2.0 ** -24
    >>> bool(abs(filter_rounding(16, 1.0) - 16 * u) < 1e-12)
    True
    """
    m = (samples - 1) * _U
    gamma = m / (1.0 - m)
    return largest * (gamma * (1.0 + _U) + _U) + _TINY


def _reachable(model: CreepModel, method: str, l1: float, z_lo: float, z_hi: float, e_c: float,
               image: tuple[float, float]) -> tuple[float, float]:
    """The range of the exact corrected value ``c`` for inputs ``h(raw)`` in ``[z_lo, z_hi]``.

    The corrector is linear: ``S`` is the input's convolution with an impulse response of l1
    norm ``l1`` and sum ``1 / (1 + beta0)``, so its positive part sums to ``P = (l1 + dc) / 2``
    and its negative part to ``N = (l1 - dc) / 2``, and ``S`` reaches from
    ``P x_lo - N x_hi`` to ``P x_hi - N x_lo``, ``x = h(raw) - offset``, with 0 (a relaxed
    start's past) in the range of ``x``. Where ``h^-1`` or ``f^-1`` is not defined at an end (a
    reciprocal's at or below zero), the end falls back to the reach without the relaxed past,
    then to the image of the raw range: the bounds then hold while ``c`` stays within it.
    """
    path = model.transfer
    sigma = 1.0 + model.beta0 if method == "supplemental" else 1.0
    dc = 1.0 / (1.0 + model.beta0)
    positive, negative = (l1 + dc) / 2, max((l1 - dc) / 2, 0.0)
    scale = 1.0 / (model.gain * sigma)

    def reach(x_lo, x_hi):
        return (model.offset + sigma * (positive * x_lo - negative * x_hi),
                model.offset + sigma * (positive * x_hi - negative * x_lo))

    def defined(c: float) -> bool:
        if path is None:            # no maps: every value has a load
            return True
        c = np.array([c])
        return bool(np.all(np.isfinite(path.delinearise(c)))
                    and np.all(np.isfinite(path.load_out((c - model.offset) * scale))))

    x_lo, x_hi = z_lo - model.offset, z_hi - model.offset
    candidates = [reach(min(x_lo, 0.0), max(x_hi, 0.0)), reach(x_lo, x_hi), image]
    ends = []
    for k, step in ((0, -e_c), (1, e_c)):
        ends.append(next(c[k] for c in candidates if defined(c[k] + step) or c is image))
    return ends[0], ends[1]


def _through(m: StaticMap, direction: str, lo: float, hi: float, error: float, terms: dict,
             moved_label: str, own_label: str) -> float:
    """The error after one map: its input's error carried through it (:func:`spread`) and its
    own float32 evaluation over the widened range, each recorded in ``terms``."""
    terms[moved_label] = spread(m, direction, lo, hi, error)
    terms[own_label] = evaluation_error(m, direction, lo - error, hi + error)
    return terms[moved_label] + terms[own_label]


def transfer_bound(model: CreepModel, method: str, rate: float, full_scale: float) -> TransferBound:
    """The float32 corrector's worst-case error with its maps, in every unit it outputs.

    Parameters
    ----------
    model : CreepModel
        With a ``transfer``, with no creep terms (a static calibration) or with a
        ``load_filter`` (:func:`load_filter_samples` loads at ``rate``: the load's bound is the
        filtered load's).
    method : {"subtractive", "supplemental"}
    rate : float
        Sample rate (Hz).
    full_scale : float or (float, float)
        ``|raw - raw0| <= full_scale`` or the raw range ``(low, high)`` (:func:`raw_range`).

    Returns
    -------
    TransferBound

    Examples
    --------
    >>> from creepcomp.model import CreepModel
    >>> from creepcomp.transfer import StaticMap, Transfer
    >>> pad = CreepModel((0.2,), (5.0,), gain=1e-4, offset=1e-4,
    ...                  transfer=Transfer(signal_map=StaticMap("reciprocal", {"origin": 0.0})))
    >>> b = transfer_bound(pad, "subtractive", 100.0, 8000.0)
    >>> bool(b.load < 1e-3)
    True
    """
    path = model.transfer
    h = None if path is None else path.signal_map
    f = None if path is None else path.load_map
    _, raw_lo, raw_hi = raw_range(model, full_scale)
    samples = load_filter_samples(model, rate)
    terms: dict = {}
    e_raw = _U * max(abs(raw_lo), abs(raw_hi))                # the sample rounded to float
    terms["raw sample to float"] = e_raw
    if h is None:
        z_lo, z_hi, e_z = raw_lo - e_raw, raw_hi + e_raw, e_raw
    else:
        e_z = _through(h, "forward", raw_lo, raw_hi, e_raw, terms, "signal map h: input rounding through h",
                       "signal map h: float32 evaluation")
        z_lo, z_hi = sorted(float(v) for v in h.forward(np.array([raw_lo, raw_hi])))
    fs_lin = max(abs(z_lo - model.offset), abs(z_hi - model.offset))
    sigma = 1.0 + model.beta0 if method == "supplemental" else 1.0
    linear = None
    if model.is_static:
        e_c = e_z
    else:
        linear_model = CreepModel(model.beta, model.tau, model.gain, model.offset)
        linear = firmware_bound(linear_model, method, "float32", rate, fs_lin + e_z)
        c = exact_coefficients(linear_model, rate)
        gains = _gains(c.a, c.beta)
        through = sigma * (gains.sample + float(np.sum(gains.state_peak)) * abs(c.inv_saturation)) * e_z
        terms["corrector: its own rounding"] = linear.total_fs * (fs_lin + e_z)
        terms[f"corrector: input error through its gains (x{gains.sample:.4g})"] = through
        e_c = linear.total_fs * (fs_lin + e_z) + through
    c_lo, c_hi = z_lo, z_hi
    if not model.is_static:
        c_lo, c_hi = _reachable(model, method, gains.sample, z_lo, z_hi, e_c, (c_lo, c_hi))
    if h is None:
        compensated = e_c
    else:
        compensated = _through(h, "inverse", c_lo, c_hi, e_c, terms,
                               "compensated: h^-1 of the corrected value's error",
                               "compensated: h^-1 float32 evaluation")
    scale = 1.0 / (model.gain * sigma)
    k_f, off_f = float32_value(scale), float32_value(model.offset)
    q_span = max(abs(c_lo - model.offset), abs(c_hi - model.offset)) + e_c
    diff = e_c + abs(off_f - model.offset) + _U * (q_span + abs(off_f - model.offset))
    e_q = abs(k_f) * diff + abs(k_f - scale) * q_span + _U * abs(k_f) * (q_span + diff) * (1 + _U)
    q_lo, q_hi = sorted(((c_lo - model.offset) * scale, (c_hi - model.offset) * scale))
    terms["load: (c - offset) / (gain scale)"] = e_q
    if f is None:
        load, load_range = e_q, (q_lo, q_hi)
    else:
        load = _through(f, "inverse", q_lo, q_hi, e_q, terms, "load: f^-1 of that error",
                        "load: f^-1 float32 evaluation")
        load_range = tuple(sorted(float(v) for v in f.inverse(np.array([q_lo, q_hi]))))
    allowance = REFERENCE_ALLOWANCE * max(abs(raw_lo), abs(raw_hi))
    load = load * _MARGIN + REFERENCE_ALLOWANCE * max(map(abs, load_range))
    if samples > 1:
        # the mean of loads each within `load` of the exact ones is within `load` of their
        # mean; its float32 sum and division add their rounding, the loads within the range
        # widened by their own error
        mean = filter_rounding(samples, max(map(abs, load_range)) + load)
        terms[f"load filter: float32 mean of {samples} loads"] = mean
        load += mean * _MARGIN
    return TransferBound(linear=linear, linear_full_scale=float(fs_lin), raw=(raw_lo, raw_hi),
                         corrected=float(e_c * _MARGIN),
                         compensated=float(compensated * _MARGIN + allowance),
                         load=float(load), corrected_range=(c_lo, c_hi),
                         load_range=load_range, terms={k: float(v) for k, v in terms.items()},
                         filter_samples=samples)


# ---------------------------------------------------------------------------- the generator

def check_maps_arguments(model: CreepModel, precision: str, max_interval, temperature_range,
                         output_polynomial, extension) -> None:
    """Refuse, naming what to use, what the corrector with maps does not have: q31, the dt step,
    a temperature law, a diagnosis's extension map."""
    what = (f"a model with static maps ({model.transfer.describe()})" if model.transfer is not None
            else "a static calibration (no creep terms)")
    if precision != "float32":
        raise InputError(f"{what} has a C corrector in float32 only (its maps are not fixed-point): "
                         "give --precision float32")
    if max_interval is not None:
        raise InputError(f"{what} has a fixed-rate C corrector only: give --rate instead of "
                         "--max-interval" + (" (a static calibration has no dynamics: any rate "
                                             "serves every sampling)" if model.is_static else ""))
    if model.temperature is not None or temperature_range is not None:
        raise InputError(f"{what} with a temperature law has no C corrector: correct its records "
                         "with creepcomp correct")
    if output_polynomial is not None or extension is not None:
        raise InputError(f"{what} with an extension map of the diagnosis has no C corrector: "
                         "generate the firmware of its baseline model (baseline-model.json, which "
                         "creepcomp diagnose -o writes), or correct records in Python with "
                         "creepcomp correct")


def check_filter_arguments(model: CreepModel, precision: str, state: str, max_interval,
                           temperature_range, output_polynomial, extension) -> None:
    """Refuse, naming what to use, what the corrector with a load filter does not have: it is
    the float32 fixed-rate step with compensated states, without a temperature law or an
    extension map."""
    what = f"a model with a load filter (a moving average over {model.load_filter.window:.3g} s)"
    instead = ""
    if model.transfer is None and not model.is_static:
        instead = ("; without the filter (remove 'load_filter' from the model file) its corrector "
                   "of the compensated signal has it")
    if precision != "float32":
        raise InputError(f"{what} has a C corrector in float32 only: give --precision float32"
                         + instead)
    if max_interval is not None:
        raise InputError(f"{what} has a fixed-rate C corrector only (its window is a number of "
                         "samples): give --rate instead of --max-interval" + instead)
    if state != "compensated":
        raise InputError(f"{what} has a C corrector with compensated states only (not "
                         f"'{state}'): leave out --state" + instead)
    if model.temperature is None and temperature_range is not None:
        raise InputError("a temperature range was given but the model has no temperature law "
                         "(no 'temperature' block): its corrector takes no temperature")
    if model.temperature is not None:
        raise InputError(f"{what} and a temperature law has no C corrector: correct its records "
                         "with creepcomp correct" + instead)
    if output_polynomial is not None or extension is not None or model.extensions:
        raise InputError(f"{what} and an extension map of the diagnosis has no C corrector: "
                         "correct its records with creepcomp correct")
