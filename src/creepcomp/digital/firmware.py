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
                rate: float = 100.0, full_scale: float = 1.0) -> ErrorBound:
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

    Returns
    -------
    ErrorBound
        Bound on ``|C output - exact output| / full_scale`` for every sample of every input
        sequence in the range, from a relaxed or a settled start. float32 assumes IEEE binary32
        rounding to nearest with no excess precision (the C code refuses to compile otherwise).
    """
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


def _local_terms(precision, st, c, k, cmax, fs, l_sample, l_state, g_state, sum_beta, sigma,
                 method):
    """Local errors times their gains (fractions of full scale); see docs/firmware.md."""
    beta, a = c["beta"], c["a"]
    beta_err = float(np.sum(np.abs(st["beta"] - beta)))
    a_err = np.abs(st["a"] - a)
    d = 2 * cmax                                            # |S - c_k|
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
        eta = a_err * d * (1 + u) ** 3 + a * d * ((1 + u) ** 3 - 1) + a * u * c_hi + u * u * c_hi
        eta_coef = a_err * d * (1 + u) ** 3
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
        eta = a_err * d + st["a"] * _Q_IN + _Q_STATE
        eta_coef = a_err * d
        start = x_err * st["w"] + abs(st["w"] - c["w"])
        out_offset = 0.0
        out_scale = (abs(st["sigma"] - c["sigma"]) * cmax + _Q_IN) if method == "supplemental" else 0.0
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
             rate: float = 100.0, full_scale: float = 1.0, name: str = "creep") -> Firmware:
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

    Returns
    -------
    Firmware
    """
    _check(model, method, precision, rate, full_scale, name)
    bound = firmware_bound(model, method, precision, rate, full_scale)
    c = _coefficients(model, rate)
    st = _stored(c, precision)
    text = _FLOAT32 if precision == "float32" else _Q31
    sub = _substitutions(model, method, precision, rate, full_scale, name, c, st, bound)
    header, source, harness = (_fill(t, sub) for t in (text.header, text.source, text.harness))
    return Firmware(model=model, method=method, precision=precision, rate=float(rate),
                    full_scale=float(full_scale), name=name, header=header, source=source,
                    harness=harness, bound=bound, coefficients=_coefficient_table(c, st, precision))


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
    sub = _substitutions(model, method, "float32", rate, full_scale, name, c, st, None)
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


def _bound_lines(bound: ErrorBound, full_scale: float) -> list[str]:
    lines = [f"Worst-case |output - exact float64 corrector| <= {bound.total_fs:.3e} x FS "
             f"= {bound.total_fs * full_scale:.3e} signal units,",
             f"for every input with |raw - offset| <= FS, from a relaxed or settled start. "
             f"Largest |S|: {bound.peak_fs:.6g} x FS.", "Parts (fraction of FS, times their gains):"]
    lines += [f"  {name}: {value:.3e}" for name, value in bound.terms.items()]
    lines.append("Derivation: docs/firmware.md (local roundings through the l1 norm of the "
                 "recursion's impulse response).")
    return lines


def _version() -> str:
    from importlib import metadata

    try:
        return metadata.version("creepcomp")
    except metadata.PackageNotFoundError:
        return "(version unknown)"


def _comment(lines) -> str:
    return "\n".join((" * " + line).rstrip() for line in lines)


def _substitutions(model, method, precision, rate, full_scale, name, c, st, bound) -> dict:
    k = model.n_terms
    derivation = _derivation(model, method, precision, rate, full_scale, c, st)
    bound_text = (_bound_lines(bound, full_scale) if bound is not None else
                  ["NAIVE reference recursion (c = e c + (1 - e) S in float32): no error bound; "
                   "for comparison only, do not deploy."])
    command = (f"creepcomp firmware MODEL --method {method} --precision {precision} "
               f"--rate {rate:.9g} --full-scale {full_scale:.9g} --name {name}")
    sub = {"@P@": name, "@PU@": name.upper(), "@K@": str(k), "@VERSION@": _version(),
           "@COMMAND@": command, "@DERIVATION@": _comment(derivation), "@BOUND@": _comment(bound_text),
           "@RATE@": repr(float(rate)), "@FS@": repr(float(full_scale)), "@OFFSET@": repr(float(model.offset)),
           "@BOUND_FS@": f"{bound.total_fs:.3e}" if bound is not None else "-1.0",
           "@METHOD@": method, "@START@": "relaxed" if method == "subtractive" else "settled"}
    sub["@MODEL_ID@"] = f"0x{_fnv1a(repr((c['beta'].tolist(), c['tau'].tolist(), c['offset'], rate, full_scale, precision, method))):08x}u"
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
#define @PU@_RATE_HZ @RATE@
#define @PU@_FULL_SCALE @FS@
#define @PU@_OFFSET @OFFSET@
#define @PU@_BOUND_FS @BOUND_FS@
#define @PU@_MODEL_ID @MODEL_ID@
#define @PU@_SAVED_WORDS (2 + 2 * @PU@_TERMS)

#ifdef __cplusplus
extern "C" {   /* C linkage when included from C++ (an Arduino sketch) */
#endif
"""

_HEADER_API = """
/* State save/restore (power cycles): model id, state words, checksum. */
typedef struct { uint32_t w[@PU@_SAVED_WORDS]; } @P@_saved;

void @P@_init(@P@_state *s);
void @P@_settle(@P@_state *s, @T@ raw);
@T@ @P@_step(@P@_state *s, @T@ raw);
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
        @P@_unpack(s, k, in->w[1 + 2 * k], in->w[2 + 2 * k]);
    return 0;
}

void @P@_save(const @P@_state *s, @P@_saved *out)
{
    int k;
    out->w[0] = @PU@_MODEL_ID;
    for (k = 0; k < @PU@_TERMS; ++k)
        @P@_pack(s, k, &out->w[1 + 2 * k], &out->w[2 + 2 * k]);
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
static const float @P@_a[@PU@_TERMS] = {@A@};
static const float @P@_offset = @OFF_F@;
static const float @P@_inv_saturation = @W_F@;
static const float @P@_saturation = @SIGMA_F@;

void @P@_init(@P@_state *s)
{
    int k;
    for (k = 0; k < @PU@_TERMS; ++k) {
        s->hi[k] = 0.0f;
        s->lo[k] = 0.0f;
    }
}

void @P@_settle(@P@_state *s, float raw)
{
    const float c = (raw - @P@_offset) * @P@_inv_saturation;
    int k;
    for (k = 0; k < @PU@_TERMS; ++k) {
        s->hi[k] = c;
        s->lo[k] = 0.0f;
    }
}

float @P@_step(@P@_state *s, float raw)
{
    const float x = raw - @P@_offset;
    float p = 0.0f, S;
    int k;
    for (k = 0; k < @PU@_TERMS; ++k)
        p += @P@_beta[k] * s->hi[k];
    S = x - p;
    for (k = 0; k < @PU@_TERMS; ++k) {
        /* c_k += a_k (S - c_k); the increment is added to hi exactly (TwoSum), its rounding
         * error carried in lo to the next update. */
        const float hi = s->hi[k];
        const float m = @P@_a[k] * (S - hi) + s->lo[k];
        const float sum = hi + m;
        const float m_part = sum - hi;
        const float hi_part = sum - m_part;
        s->hi[k] = sum;
        s->lo[k] = (hi - hi_part) + (m - m_part);
    }
    (void)@P@_saturation;
    return @RETURN@;
}

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
static const int32_t @P@_a_m[@PU@_TERMS] = {@A_M@};
static const unsigned char @P@_a_s[@PU@_TERMS] = {@A_S@};
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
        s->c[k] = 0;
}

void @P@_settle(@P@_state *s, int32_t x)
{
    int k;
    for (k = 0; k < @PU@_TERMS; ++k)
        s->c[k] = (int64_t)x * @P@_inv_saturation_q30;
}

int32_t @P@_step(@P@_state *s, int32_t x)
{
    int64_t p = 0, S;
    int k;
    for (k = 0; k < @PU@_TERMS; ++k)
        p += @P@_shift(@P@_shift(s->c[k], 30) * @P@_beta_m[k], @P@_beta_s[k]);
    S = (int64_t)x - @P@_shift(p, 30);
    for (k = 0; k < @PU@_TERMS; ++k)
        s->c[k] += @P@_shift((S - @P@_shift(s->c[k], 30)) * @P@_a_m[k], @P@_a_s[k]);
    (void)@P@_saturation_q30;
    return @RETURN@;
}

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
/* Host harness (not for the target): reads N doubles (signal units), runs @P@_step over them
 * REPEATS times from the start given, writes the outputs (doubles, signal units) of the first
 * run and prints the best time per sample in nanoseconds (clock_gettime, CLOCK_MONOTONIC). */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "@P@.h"

int main(int argc, char **argv)
{
    FILE *f;
    long n, i;
    int r, repeats, settled;
    double *buf, best = -1.0;
    @T@ *in, *out, *spare;
    @P@_state s;
    if (argc != 5) {
        fprintf(stderr, "usage: %s IN OUT relaxed|settled REPEATS\\n", argv[0]);
        return 2;
    }
    settled = strcmp(argv[3], "settled") == 0;
    repeats = atoi(argv[4]);
    f = fopen(argv[1], "rb");
    if (!f) return 3;
    fseek(f, 0, SEEK_END);
    n = ftell(f) / (long)sizeof(double);
    fseek(f, 0, SEEK_SET);
    buf = malloc((size_t)n * sizeof *buf);
    in = malloc((size_t)n * sizeof *in);
    out = malloc((size_t)n * sizeof *out);
    spare = malloc((size_t)n * sizeof *spare);
    if (!buf || !in || !out || !spare || fread(buf, sizeof *buf, (size_t)n, f) != (size_t)n) return 3;
    fclose(f);
    for (i = 0; i < n; ++i)
        in[i] = @TO_WORD@;
    for (r = 0; r < repeats; ++r) {
        struct timespec t0, t1;
        double ns;
        @T@ *dst = r == 0 ? out : spare;
        if (settled) @P@_settle(&s, in[0]); else @P@_init(&s);
        clock_gettime(CLOCK_MONOTONIC, &t0);
        for (i = 0; i < n; ++i)
            dst[i] = @P@_step(&s, in[i]);
        clock_gettime(CLOCK_MONOTONIC, &t1);
        ns = ((double)(t1.tv_sec - t0.tv_sec) * 1e9 + (double)(t1.tv_nsec - t0.tv_nsec)) / (double)n;
        if (best < 0 || ns < best) best = ns;
    }
    for (i = 0; i < n; ++i)
        buf[i] = @FROM_WORD@;
    f = fopen(argv[2], "wb");
    if (!f || fwrite(buf, sizeof *buf, (size_t)n, f) != (size_t)n) return 3;
    fclose(f);
    printf("%.6f\\n", best);
    return 0;
}
"""

_FLOAT_STATE = """
/* State in signal units above the offset: c_k = hi[k] + lo[k]. Owned by the caller. */
typedef struct { float hi[@PU@_TERMS]; float lo[@PU@_TERMS]; } @P@_state;
"""

_Q31_STATE = """
/* Input and output words: round((signal - offset) / FULL_SCALE * 2^30), so |word| <= 2^30 at
 * full scale (one bit of headroom). State: c_k * 2^60 / FULL_SCALE. Owned by the caller. */
typedef struct { int64_t c[@PU@_TERMS]; } @P@_state;
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

_FLOAT_IO = {"@T@": "float", "@TO_WORD@": "(float)buf[i]", "@FROM_WORD@": "(double)out[i]"}
_Q31_IO = {"@T@": "int32_t",
           "@TO_WORD@": "(int32_t)llround((buf[i] - @PU@_OFFSET) / @PU@_FULL_SCALE * 1073741824.0)",
           "@FROM_WORD@": "@PU@_OFFSET + (double)out[i] * (@PU@_FULL_SCALE / 1073741824.0)"}

_FLOAT32 = _Texts(header=_fill(_HEADER_TOP + _FLOAT_STATE + _HEADER_API, _FLOAT_IO),
                  source=_FLOAT32_SOURCE, harness=_fill(_HARNESS, _FLOAT_IO))
_Q31 = _Texts(header=_fill(_HEADER_TOP + _Q31_STATE + _HEADER_API, _Q31_IO),
              source=_Q31_SOURCE, harness=_fill(_HARNESS, _Q31_IO))
_NAIVE = _Texts(header=_NAIVE_HEADER, source=_NAIVE_SOURCE, harness=_fill(_HARNESS, _FLOAT_IO))
