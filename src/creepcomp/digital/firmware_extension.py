"""The C corrector of a model with an extension the diagnosis writes (``creepcomp firmware``).

Each extension's ``firmware_output`` hook (:mod:`creepcomp.diagnose.effects`) gives it as a map
in signal units; this module writes its C step (fixed rate, subtractive; float32: the linear
step's creep sum and states, the extension's own arithmetic and state words in double; q31,
for :data:`INTEGER_KINDS`: everything in integers) and its bound
(:mod:`creepcomp.digital.firmware_bound`). The step does what the
creep correction (:func:`creepcomp.diagnose.effects.compensate_extended`) does, sample by
sample, with the load held between samples:

- ``reloading``: the load ``X`` whose response ``X (1 - softening g(1 - |X|/m))`` is ``S``,
  ``m`` the running maximum of ``|X|`` (one state word), ``X = S`` at or beyond it;
- ``peak``: the load whose response ``X (1 - k m)`` is ``S``, ``m`` the running maximum of
  ``|X|`` including this sample (one state word);
- ``play``: the load with ``X + ratio (P - X) = S``, ``P`` a play operator of ``X`` (one
  state word), the creep terms driven by ``X``;
- ``overshoot``: the load with ``S = X + ratio sum_i w_i (v - lag_i(v))``, ``v`` the total
  variation of a play of ``X`` (one lag, or several for a stretched decay; state words: the
  play, a start flag, one per lag), the creep terms driven by ``X``;
- ``recovery``: one creep term steps with ``a_recovery`` over the steps where its state
  shrinks towards the input's mean over the step, with ``a`` otherwise (two state words:
  the last ``S`` and the last mode).

The static polynomial (``polynomial``) is written by :func:`creepcomp.digital.firmware.generate_firmware`
itself.
"""

from __future__ import annotations

import math

import numpy as np

from creepcomp.digital.firmware_bound import (OVERSHOOT_EVENTS, _mantissa, ROOT_STEPS, ErrorBound,
                                              firmware_bound, float32_value, overshoot_bound,
                                              peak_bound, play_bound, recovery_bound,
                                              reloading_bound)
from creepcomp.errors import InputError
from creepcomp.model import CreepModel

__all__ = ["EXTENSION_KINDS", "INTEGER_KINDS", "extension_kind", "check_extension", "extension_parts", "recovery_ambiguity",
           "overshoot_events", "overshoot_record_bound"]

#: The extension maps the C corrector writes (besides the static ``polynomial``), with what
#: each is in words.
EXTENSION_KINDS = {"reloading": "softening below the running maximum of the load",
                   "peak": "softening by the largest load magnitude so far",
                   "play": "a play operator (rate-independent hysteresis)",
                   "recovery": "recovery with its own time constant, switched by the state",
                   "overshoot": "a decaying transient after every load change (total variation)"}


#: The kinds the q31 step carries too (in integers: a mode switch; a piecewise linear map; a
#: running maximum with a root by bisection, but for a shaped reloading curve's exponential).
INTEGER_KINDS = ("recovery", "play", "reloading", "peak")


def extension_kind(extension: dict) -> str:
    """The kind of an extension map (its one key), checked."""
    if not isinstance(extension, dict) or len(extension) != 1 or next(iter(extension)) not in EXTENSION_KINDS:
        raise InputError(f"internal error: extension map {extension!r} is none of "
                         f"{', '.join(EXTENSION_KINDS)}")
    return next(iter(extension))


def check_extension(extension: dict, method: str, precision: str, max_interval, temperature) -> None:
    """Refuse, naming the extension, what its C corrector does not do: q31 (but for
    :data:`INTEGER_KINDS`), the supplemental method, the dt step, a temperature law."""
    kind = extension_kind(extension)
    what = EXTENSION_KINDS[kind]
    if precision != "float32" and kind not in INTEGER_KINDS:
        raise InputError(f"the model's extension ({what}) has a C corrector in float32 only: its map "
                         f"and state words are computed in double, which the integer-only q31 "
                         f"step does not use (q31 carries a play, the recovery switch and Mullins "
                         f"softening's chord and largest magnitude); give "
                         f"--precision float32")
    if method != "subtractive":
        raise InputError(f"the model's extension ({what}) has a C corrector for the subtractive "
                         f"method only (the load is what it finds); give --method subtractive")
    if max_interval is not None:
        raise InputError(f"the model's extension ({what}) has a C corrector at a fixed rate only; "
                         f"give --rate instead of --max-interval")
    if temperature:
        raise InputError(f"the model's extension ({what}) has no C corrector together with a "
                         f"temperature law")


def _c_double(value: float) -> str:
    return repr(float(value))


def extension_parts(model: CreepModel, rate: float, full_scale: float, name: str,
                    extension: dict, precision: str = "float32") -> tuple[ErrorBound, dict, list[str], dict]:
    """The bound, the template's ``extension`` values, the derivation's lines and the values
    to verify with, of one extension map.

    Returns
    -------
    (ErrorBound, dict, list of str, dict)
        ``extension`` holds ``kind``, ``words`` (state words: double, or int64 for q31), ``constants`` (C
        lines), ``summary`` (header lines), ``drive`` (what the creep terms follow), and
        per kind ``steps``, ``shaped``, ``exp``, ``term``; the last dict (``check``) what
        :func:`creepcomp.digital.firmware_check.verify_firmware` needs (the recovery's
        switching margin).
    """
    kind = extension_kind(extension)
    p = extension[kind]
    values = {"kind": kind, "words": 1, "drive": "S", "steps": str(ROOT_STEPS), "shaped": False,
              "exp": False, "term": "0", "lags": "0"}
    offset, offset_st = float(model.offset), float32_value(model.offset)
    check: dict = {"kind": kind}
    word = 2 ** 30 / full_scale
    if kind in ("reloading", "peak"):
        linear = firmware_bound(model, "subtractive", precision, rate, full_scale)
    if kind == "reloading":
        sigma, shape, chord = p["softening"], p["shape"], p["chord"]
        shaped = abs(shape) >= chord
        if shaped and precision == "q31":
            raise InputError(f"the model's reloading curve is shaped (shape {shape:g}): its exponential "
                             "has a C corrector in float32 only; give --precision float32")
        bound = reloading_bound(linear, sigma, shape, chord, offset, offset_st, precision)
        if shaped and abs(shape) > 30:
            raise InputError(f"the reloading curve's shape {shape:g} is beyond the C corrector's "
                             f"exponential (|shape| <= 30)")
        if precision == "q31":
            m, shift = _mantissa(sigma, "softening")
            constants = [f"static const int64_t {name}_softening_m = {m};     /* softening_m 2^-(30 + softening_s) */",
                         f"static const unsigned {name}_softening_s = {1 + shift};"]
        else:
            constants = [f"static const double {name}_softening = {_c_double(sigma)};"]
        if shaped:
            constants += [f"static const double {name}_shape = {_c_double(shape)};",
                          f"static const double {name}_expm1_shape = {_c_double(math.expm1(-shape))};"]
        values.update(shaped=shaped, exp=shaped,
                      summary=["with the load X found from S through the reloading curve below its running maximum m:",
                               "  S = X (1 - softening g(1 - |X|/m)) for |X| < m, S = X (and m = |X|) beyond it"])
        lines = [f"Softening below the running maximum m of |X|: softening = {sigma:.9g}, "
                 + (f"g(z) = expm1(-{shape:.9g} z) / expm1(-{shape:.9g}) (expm1 without libm)" if shaped
                    else "g(z) = z (the chord)")
                 + (f"; |X| by {ROOT_STEPS} bisection steps in double." if precision == "float32" else
                    "; |X| by bisection in words, to one word.")]
    elif kind == "peak":
        k = p["softening"] / p["scale"]
        bound = peak_bound(linear, p["softening"], p["scale"], offset, offset_st, precision)
        reach = bound.peak_fs * full_scale
        if precision == "q31":
            m, shift = _mantissa(k * full_scale, "k x full scale")
            constants = [f"static const int64_t {name}_k_m = {m};     /* k FS = k_m 2^-(30 + k_s) */",
                         f"static const unsigned {name}_k_s = {1 + shift};",
                         f"static const int64_t {name}_reach = {math.ceil(reach * word)};     /* words */"]
        else:
            constants = [f"static const double {name}_k = {_c_double(k)};",
                         f"static const double {name}_reach = {_c_double(reach)};"]
        values["summary"] = ["with the load X found from S = X (1 - k m), m the largest |X| so far including this sample"]
        how = (f"{ROOT_STEPS} bisection steps in double" if precision == "float32" else
               "bisection in words, to one word,")
        lines = [f"Softening by the largest magnitude so far: k = softening / scale = {k:.9g} per signal unit; "
                 f"a new largest |X| by {how} up to {reach:.9g}."]
    elif kind == "play":
        ratio, half = p["ratio"], p["half_width"]
        bound = play_bound(model, rate, full_scale, ratio, half, precision)
        if precision == "float32":
            constants = [f"static const double {name}_ratio = {_c_double(ratio)};",
                         f"static const double {name}_half_width = {_c_double(half)};",
                         f"static const double {name}_one_minus_ratio = {_c_double(1.0 - ratio)};"]
        else:
            m, shift = _mantissa(ratio / (1.0 - ratio), "ratio / (1 - ratio)")
            constants = [f"static const int64_t {name}_half_width = {round(half * word)};     /* words */",
                         f"static const int64_t {name}_ratio_half_width = {round(ratio * half * word)};",
                         f"static const int64_t {name}_band_m = {m};     /* ratio / (1 - ratio) = band_m 2^-(30 + band_s) */",
                         f"static const unsigned {name}_band_s = {1 + shift};"]
        values.update(drive="X", summary=[
            "with the load X found from S = X + ratio (P - X), P = clip(P_prev, X - r, X + r) the play",
            "operator (from P = 0), and the creep terms driven by X: c_k[n+1] = c_k[n] + a_k (X[n] - c_k[n])"])
        lines = [f"Play operator: ratio = weight / gain = {ratio:.9g}, half width r = {half:.9g} signal units; "
                 + ("X and P in double." if precision == "float32" else
                    "X and P in words (2^30 per full scale), ratio / (1 - ratio) a 31-bit mantissa.")]
    elif kind == "overshoot":
        ratio, half = p["ratio"], p["half_width"]
        weights, taus = list(map(float, p["weights"])), list(map(float, p["taus"]))
        bound = overshoot_bound(model, rate, full_scale, ratio, half, weights, taus)
        keep = np.exp(-(1.0 / rate) / np.array(taus))
        ratio_w = ratio * float(np.sum(weights))
        constants = [f"static const double {name}_ratio = {_c_double(ratio)};",
                     f"static const double {name}_ratio_w = {_c_double(ratio_w)};",
                     f"static const double {name}_half_width = {_c_double(half)};",
                     f"static const double {name}_weight[{len(weights)}] = "
                     + "{" + ", ".join(_c_double(x) for x in weights) + "};",
                     f"static const double {name}_keep[{len(weights)}] = "
                     + "{" + ", ".join(_c_double(x) for x in keep) + "};"]
        values.update(drive="X", words=2 + len(weights), lags=str(len(weights)), summary=[
            "with the load X found from S = X + ratio sum_i w_i D_i, D_i = (1 - a_i) D_i + |Q - Q_prev| (the total",
            "variation of the play Q of X less its lag), and the creep terms driven by X"])
        lines = [f"Overshoot: ratio = amplitude / |gain| = {ratio:.9g}, dead band half width {half:.9g} signal units, "
                 f"{len(weights)} lag(s): tau = " + ", ".join(f"{t:.6g}" for t in taus) + " s, weights "
                 + ", ".join(f"{x:.6g}" for x in weights) + "; X, Q and D_i in double.",
                 f"The bound assumes the load turns at most {OVERSHOOT_EVENTS:g} times within the decay (discounted "
                 "count R of the play's runs and of its moves at the dead band's edge); creepcomp firmware "
                 "--verify gives the bound of the record's own R."]
        check.update(ratio=ratio, half_width=half, weights=weights, taus=taus, rate=float(rate),
                     full_scale=float(full_scale), model=model)
    else:
        term, tau_r = int(p["term"]), float(p["tau_recovery"])
        bound, switch = recovery_bound(model, rate, full_scale, term, tau_r, precision)
        band = p["dead_band"] * full_scale
        a_rec = switch["a_recovery"]
        if precision == "float32":
            constants = [f"static const float {name}_a_recovery = {float32_value(a_rec):.9e}f;",
                         f"static const double {name}_band = {_c_double(band)};"]
        else:
            m, shift = switch["a_recovery_q"]
            constants = [f"static const int64_t {name}_a_recovery_m = {m};",
                         f"static const unsigned {name}_a_recovery_s = {1 + shift};",
                         f"static const int64_t {name}_band = {round(p['dead_band'] * 2 ** 60)};"
                         "     /* dead band, 2^60 per full scale */"]
        values.update(words=2, term=str(term), summary=[
            f"except term {term}, which steps with a_recovery over the steps where its state shrinks towards",
            "the input's mean over the step, sign(c)((S[n] + S[n+1])/2 - c) < -band, with a_k otherwise"])
        stored = (f"{float32_value(a_rec):.9e}" if precision == "float32" else
                  f"{switch['a_recovery_q'][0]} * 2^-{31 + switch['a_recovery_q'][1]}")
        lines = [f"Recovery of term {term}: tau_recovery = {tau_r:.9g} s, a_recovery = {a_rec:.12g} "
                 f"(stored {stored}); dead band {band:.3g} signal units.",
                 f"The bound holds where each mode decision of the exact corrector is {switch['margin']:.3g} "
                 f"signal units or more from its threshold (and its state that far from 0); where one is not, "
                 f"{switch['switch_gain']:.3g} x FS per signal unit of |S[n] - c[n]| there adds to it "
                 "(creepcomp firmware --verify finds such steps)."]
        check.update(switch, term=term, tau=float(model.tau[term]), tau_recovery=tau_r,
                     dead_band=float(p["dead_band"]))
    values["constants"] = constants
    return bound, values, lines, check


def recovery_ambiguity(check: dict, time, output, offset: float) -> dict:
    """The steps of a record whose mode decision the C corrector may take otherwise than the
    exact one (its decision quantity within ``margin`` of 0, or its state within the state
    error of 0), and what they add to the bound (:func:`creepcomp.digital.firmware_bound.recovery_bound`).

    ``output``: the exact corrector's output (signal units); the term's states are stepped
    from it with the exact modes.

    Returns
    -------
    dict
        ``steps`` (how many), ``largest`` (``|h_n - c_n|`` there, signal units) and
        ``added_fs`` (what it adds to the bound).
    """
    t = np.asarray(time, float)
    h = np.asarray(output, float) - offset
    e = -np.expm1(-np.diff(t) / check["tau"])
    e_r = -np.expm1(-np.diff(t) / check["tau_recovery"])
    band = check["dead_band"] * max(float(np.max(np.abs(h))), 1e-300)
    margin, state_error = check["margin"], check["state_error"]
    c = 0.0
    largest, steps = 0.0, 0
    # until a step after the first non-zero input both states are exactly 0 (the C's input
    # x = raw - offset is exactly 0 too before it): no mode
    unloaded = np.concatenate([[True], np.cumsum(h[:-1] != 0) == 0])
    for n in range(len(h) - 1):
        q = math.copysign(1.0, c) * (0.5 * (h[n] + h[n + 1]) - c) if c != 0 else 0.0
        near = abs(q + band) <= margin or abs(c) <= state_error
        if near and not unloaded[n]:
            steps += 1
            largest = max(largest, abs(h[n] - c) + state_error)
        recovering = c != 0 and q < -band
        c = c + (e_r[n] if recovering else e[n]) * (h[n] - c)
    return {"steps": steps, "largest": largest, "added_fs": check["switch_gain"] * largest}


def overshoot_events(check: dict, output, offset: float, error: float) -> float:
    """The discounted count ``R`` of an overshoot's events on a record
    (:func:`creepcomp.digital.firmware_bound.overshoot_bound`): the turns of the exact
    corrector's play and the samples where the load found is within ``2 error`` (signal
    units: the C's error, which may move its play otherwise) of the dead band's edge opposite
    to the play's last move (where the C's play may turn a sample apart from the exact one),
    each discounted by the slowest lag's ``1 - a`` per sample since; the largest over the
    record, with the current run. Where one play moves and the other does not, or both the
    same way, the variation's error telescopes (``|q~| - |q| = s (dQ_n - dQ_n-1)`` with the
    moving one's sign ``s``)."""
    x = np.asarray(output, float) - offset
    r = check["half_width"]
    keep = math.exp(-(1.0 / check["rate"]) / max(check["taus"]))
    q, direction, count, largest = float(x[0]), 0, 0.0, 1.0
    for value in x[1:].tolist():
        # at the edge the play last moved towards, the C's can only move the same way (the
        # variation's error still telescopes); at the other it may turn one sample apart
        gap = abs(value - q) if direction == 0 else direction * (q - value)
        near = abs(gap - r) <= 2 * error
        moved = min(max(q, value - r), value + r)
        step = int(moved > q) - int(moved < q)
        count *= keep
        if near or (step != 0 and direction != 0 and step != direction):
            count += 1.0
        if step != 0:
            direction = step
        q = moved
        largest = max(largest, 1.0 + count)
    return largest


def overshoot_record_bound(check: dict, output, offset: float, bound: ErrorBound) -> dict:
    """The overshoot's bound on a record: at the record's own event count ``R``
    (:func:`overshoot_events`, the near-edge samples found with the bound's own error, to a
    fixed point), plus the float64 reference's rounding of the total variation it subtracts
    (``4 u |ratio| W v``, ``v`` the record's total variation).

    Returns
    -------
    dict
        ``events`` (R), ``bound_fs`` and ``reference_fs``.
    """
    fs = check["full_scale"]
    x = np.asarray(output, float) - offset
    current = bound
    for _ in range(6):
        events = overshoot_events(check, output, offset, current.total_fs * fs)
        current = overshoot_bound(check["model"], check["rate"], fs, check["ratio"], check["half_width"],
                                  check["weights"], check["taus"], events=max(events, OVERSHOOT_EVENTS))
        if overshoot_events(check, output, offset, current.total_fs * fs) <= max(events, OVERSHOOT_EVENTS):
            break
    else:
        raise InputError("the overshoot's bound on this record does not settle: no error bound")
    v = float(np.sum(np.abs(np.diff(x))))
    reference = 4 * 2.0 ** -53 * abs(check["ratio"]) * float(np.sum(check["weights"])) * v / fs
    return {"events": events, "bound_fs": current.total_fs + reference, "reference_fs": reference}
