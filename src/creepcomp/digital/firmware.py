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
  to ``hi`` and its rounding error, by Dekker's Fast2Sum with ``hi`` first (exact unless the
  increment passes a state near zero), kept in ``lo`` (error feedback). With ``state="plain"``
  each state is one float instead (the fixed-rate step only): fewer operations per sample, and
  a bound larger by about ``u tau_k / T``, the rounding of each update carried by the
  recursion's memory.
- ``q31``: samples are 32-bit words, ``2**30`` per full scale; the states are 64-bit integers with
  ``2**60`` per full scale; coefficients are 31-bit mantissas with a shift (relative error
  ``2**-31`` however small ``a_k`` is); every product fits a 64-bit integer.

For a model with a temperature law the step takes the sensor's temperature (°C) with each
sample and computes ``a_k = 1 - exp(-(T / tau_k) / a_T)`` per sample without libm, ``tau_k``
following the temperature at the middle of the step
(:func:`~creepcomp.digital.firmware_bound.temperature_scheme`); the bound then holds over a
declared temperature range, to which the step clamps. float32 takes the temperature as a
float in °C; q31, integer-only, as an ``int32_t`` in units of 1/256 °C
(:func:`~creepcomp.digital.firmware_bound.q31_temperature_scheme`).

The C text is in the Jinja2 templates of ``creepcomp/digital/templates`` (one leaf template per
file kind and variant, sharing a base, includes and macros); this module computes the values
they are filled with. The worst-case error bound written into the header comes from
:mod:`creepcomp.digital.firmware_bound`; ``docs/firmware.md`` has the derivation.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from pathlib import Path

import jinja2
from jinja2 import meta

from creepcomp.digital.firmware_bound import (DEFAULT_TEMPERATURE_RANGE, FULL_SCALE_WORD,
                                              MIN_INTERVAL, PRECISIONS, REFERENCE_ALLOWANCE,
                                              STATES, check_state,
                                              ExactCoefficients, StoredCoefficients,
                                              ROOT_STEPS, TEMPERATURE_STEP_Q, TICK, ErrorBound,
                                              check_arguments, check_interval, dt_scheme,
                                              exact_coefficients, firmware_bound, float32_value,
                                              polynomial_bound,
                                              q31_temperature_scheme, stored_coefficients,
                                              temperature_bound, temperature_scheme)
from creepcomp.digital.firmware_extension import check_extension, extension_parts
from creepcomp.display import Shown
from creepcomp.digital.firmware_transfer import (LIBM_ULPS, TransferBound, check_filter_arguments,
                                                 check_maps_arguments, load_filter_samples,
                                                 map_code, range_full_scale, transfer_bound)
from creepcomp.errors import InputError
from creepcomp.model import CreepModel

__all__ = ["PRECISIONS", "STATES", "FULL_SCALE_WORD", "REFERENCE_ALLOWANCE", "MIN_INTERVAL", "TICK",
           "DEFAULT_TEMPERATURE_RANGE", "TEMPERATURE_STEP_Q", "ErrorBound", "Firmware", "firmware_bound", "generate_firmware", "naive_float32",
           "check_no_extensions", "render_target_program"]


@dataclass(frozen=True)
class Firmware(Shown):
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
    temperature_range : tuple of float or None
        ``(low, high)`` (°C) of the temperature step (a model with a temperature law): the
        step clamps to it and the bound holds over it; None without a law.
    extension : dict or None
        For the step of an extension map (:mod:`creepcomp.digital.firmware_extension`): its
        kind and what its verification needs; None otherwise.
    uses_double : bool
        The step computes in ``double`` (a static polynomial's root, a float32 extension map):
        its bound takes ``double`` as IEEE binary64.
    maps : dict or None
        For a model with static maps or a static calibration
        (:mod:`creepcomp.digital.firmware_transfer`): ``bound_signal`` (the compensated
        signal's bound, signal units), ``bound_load`` (load units), ``bound_corrected``, and the
        ranges they hold over; None otherwise.
    state : str
        float32: ``compensated`` (each state a float and its carried rounding error) or
        ``plain`` (one float); :data:`~creepcomp.digital.firmware_bound.STATES`.
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
    temperature_range: tuple[float, float] | None = None
    extension: dict | None = None
    uses_double: bool = False
    maps: dict | None = None
    state: str = "compensated"

    def __repr__(self) -> str:
        from creepcomp.units import format_quantity

        rate = "dt step" if self.irregular else format_quantity(self.rate, "Hz")
        bound = "no proven bound" if self.bound is None else f"bound {self.bound.total_fs:.3g} of FS"
        states = ", plain states" if self.state == "plain" else ""
        return f"<Firmware {self.name}: {self.method}, {self.precision}{states}, {rate}, {bound}>"

    def to_dict(self) -> dict:
        """JSON form without the C text: name, files, method, precision, rate (Hz) or longest
        interval (s), full scale (signal units), the states' form, the proven bound and the
        temperature range."""
        return {"name": self.name, "files": list(self.filenames), "method": self.method,
                "precision": self.precision, "rate": None if self.irregular else self.rate,
                "max_interval": self.max_interval, "full_scale": self.full_scale,
                "state": self.state,
                "bound": None if self.bound is None else self.bound.to_dict(),
                "temperature_range": None if self.temperature_range is None else list(self.temperature_range)}

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


def generate_firmware(model: CreepModel, method: str = "subtractive", precision: str = "float32",
                      rate: float = 100.0, full_scale: float = 1.0, name: str = "creep",
                      max_interval: float | None = None,
                      temperature_range: tuple[float, float] | None = None,
                      output_polynomial: tuple[float, float] | None = None,
                      extension: dict | None = None, state: str = "compensated") -> Firmware:
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
    full_scale : float or (float, float)
        Largest ``|raw - offset|`` (signal units): the bound assumes it, q31 scales by it. For
        a model with static maps, ``|raw - h^-1(offset)|``, or ``(low, high)``: the raw range
        (:func:`creepcomp.digital.firmware_transfer.raw_range`).
    name : str
        Prefix of the C identifiers and of the file names.
    max_interval : float, optional
        Generate the dt step for irregular sampling instead of the fixed-rate step:
        ``PREFIX_step_dt(state, raw, dt, &out)`` accepts ``MIN_INTERVAL <= dt <= max_interval``
        (float32: dt in seconds; q31: dt in microsecond ticks). ``rate`` is then not used.
    temperature_range : tuple of float, optional
        ``(low, high)`` in °C for a model with a temperature law (default
        :data:`DEFAULT_TEMPERATURE_RANGE`): the step ``PREFIX_step(state, raw, temperature_c)``
        clamps the temperature to it and the bound holds over it. Refused without a law.
    output_polynomial : (c2, c3), optional
        An instantaneous response ``X + c2 X^2 + c3 X^3`` that is not linear in the load
        (``X``: the load in signal units above the offset; a diagnosis's extension, given by
        :func:`creepcomp.diagnose.effects.firmware_output`): the output is the root of it
        equal to the linear corrector's output, found in double; its bound
        (:func:`~creepcomp.digital.firmware_bound.polynomial_bound`) covers the root. float32
        at a fixed rate, subtractive only.
    extension : dict, optional
        Another extension map of the diagnosis (:func:`creepcomp.diagnose.effects.firmware_output`:
        ``reloading``, ``peak``, ``play`` or ``recovery``), written by
        :mod:`creepcomp.digital.firmware_extension`: float32, at a fixed rate, subtractive only.
    state : {"compensated", "plain"}
        How the float32 step holds each creep state: a float and the rounding error of its
        last update, carried to the next (``compensated``, the default), or one float
        (``plain``: fewer operations per sample, a bound larger by about ``u tau_k / T``; the
        float32 fixed-rate step of the creep terms alone, refused otherwise).

    Returns
    -------
    Firmware

    Notes
    -----
    A model with static maps (a ``transfer``) or a static calibration (no creep terms) gets
    the float32 fixed-rate step of :mod:`creepcomp.digital.firmware_transfer`:
    ``PREFIX_step`` returns the compensated signal, ``PREFIX_step_load`` the load. So does a
    model with a load filter that averages more than one load at ``rate``: its
    ``PREFIX_step_load`` returns the mean of the last ``N`` loads.
    """
    if model.load_filter is not None and (max_interval is not None
                                          or load_filter_samples(model, rate) > 1):
        check_filter_arguments(model, precision, state, max_interval, temperature_range,
                               output_polynomial, extension)
        return _maps_firmware(model, method, precision, rate, full_scale, name)
    check_no_extensions(model)
    check_state(state, precision, max_interval is None and temperature_range is None
                and model.temperature is None and model.transfer is None and not model.is_static
                and output_polynomial is None and extension is None)
    if model.transfer is not None or model.is_static:
        check_maps_arguments(model, precision, max_interval, temperature_range, output_polynomial,
                             extension)
        return _maps_firmware(model, method, precision, rate, full_scale, name)
    if isinstance(full_scale, (tuple, list)):
        raise InputError("a raw range LOW:HIGH as the full scale is for a model with static maps: "
                         "give this model's largest |signal - offset| as one number")
    if extension is not None:
        check_extension(extension, method, precision, max_interval,
                        model.temperature is not None or temperature_range is not None)
        return _extension_firmware(model, rate, full_scale, name, extension, precision)
    if output_polynomial is not None and (precision != "float32" or method != "subtractive"
                                          or max_interval is not None or model.temperature is not None
                                          or temperature_range is not None):
        raise InputError("a static polynomial response has a C corrector in float32, subtractive, "
                         "at a fixed rate, without a temperature law only")
    if model.temperature is not None or temperature_range is not None:
        return _temperature_firmware(model, method, precision, rate, full_scale, name,
                                     max_interval, temperature_range)
    if max_interval is not None:
        check_interval(max_interval)
        rate = 1.0 / max_interval
    check_arguments(model, method, precision, rate, full_scale, name)
    bound = firmware_bound(model, method, precision, rate, full_scale, max_interval, state)
    polynomial = None
    if output_polynomial is not None:
        bound, reach = polynomial_bound(bound, *output_polynomial, offset=model.offset)
        polynomial = {"c2": repr(float(output_polynomial[0])), "c3": repr(float(output_polynomial[1])),
                      "reach": repr(reach), "steps": ROOT_STEPS}
    c = exact_coefficients(model, rate)
    st = stored_coefficients(c, precision)
    irregular = max_interval is not None
    scheme = dt_scheme(model, precision, max_interval) if irregular else None
    derivation = (_dt_derivation(model, method, precision, full_scale, c, st, scheme) if irregular
                  else _derivation(model, method, precision, rate, full_scale, c, st))
    if polynomial is not None:
        derivation = derivation + [
            f"Static response: the output is offset + X, X the root of X + c2 X^2 + c3 X^3 = S "
            f"(c2 = {polynomial['c2']}, c3 = {polynomial['c3']} per signal unit), bracketed in "
            f"|X| <= {float(polynomial['reach']):.6g} where it rises, by {ROOT_STEPS} bisection steps in double."]
    values = _header_values(model, method, precision, rate, full_scale, name, c, scheme, max_interval)
    plain = {"plain": True} if state == "plain" else {}
    if plain:
        values["command"] += " --state plain"
        values["model_id"] = f"0x{_fnv1a(repr((values['model_id'], state))):08x}u"
        derivation = derivation + [
            "Plain states: each c_k is one float, updated as c_k + a_k (S - c_k) rounded to float; "
            "the rounding of the new state, u |c_k|, is not proportional to a_k, so the recursion "
            "carries it over about tau_k/T samples (the bound's 'state updates rounding')."]
    header = _render(f"{precision}_dt.h.j2" if irregular else "fixed_rate.h.j2", **values,
                     derivation=derivation, bound=_bound_lines(bound, full_scale),
                     bound_fs=f"{bound.total_fs:.3e}", **plain)
    extra = {"polynomial": polynomial} if precision == "float32" and not irregular else {}
    source = _render(f"{precision}_dt.c.j2" if irregular else f"{precision}.c.j2",
                     name=name, NAME=name.upper(), version=_version(), method=method,
                     irregular=irregular, temperature=False,
                     **_coefficient_values(precision, st, scheme), **extra, **plain)
    harness = _render("harness.c.j2", name=name, NAME=name.upper(), precision=precision,
                      irregular=irregular, temperature=False)
    return Firmware(model=model, method=method, precision=precision,
                    rate=None if irregular else float(rate),
                    full_scale=float(full_scale), name=name, header=header, source=source,
                    harness=harness, bound=bound, coefficients=_coefficient_table(c, st, precision),
                    max_interval=float(scheme.dt_max) if irregular else None,
                    uses_double=polynomial is not None, state=state)


def _extension_firmware(model: CreepModel, rate: float, full_scale: float, name: str,
                        extension: dict, precision: str) -> Firmware:
    """The fixed-rate subtractive step of a model with an extension map (float32; q31 for
    those of :data:`~creepcomp.digital.firmware_extension.INTEGER_KINDS`)."""
    method = "subtractive"
    check_arguments(model, method, precision, rate, full_scale, name)
    bound, values, lines, check = extension_parts(model, rate, full_scale, name, extension, precision)
    c = exact_coefficients(model, rate)
    st = stored_coefficients(c, precision)
    header_values = _header_values(model, method, precision, rate, full_scale, name, c, None, None)
    identity = (header_values["model_id"], repr(extension))
    header_values["model_id"] = f"0x{_fnv1a(repr(identity)):08x}u"
    header = _render("fixed_rate.h.j2", **header_values, extension=values,
                     derivation=_derivation(model, method, precision, rate, full_scale, c, st) + lines,
                     bound=[line.replace("from a relaxed or settled start", "from the relaxed start")
                            .replace("Largest |S|", "Largest |X|") for line in _bound_lines(bound, full_scale)],
                     bound_fs=f"{bound.total_fs:.3e}")
    source = _render(f"{precision}_extension.c.j2", name=name, NAME=name.upper(), version=_version(),
                     method=method, irregular=False, temperature=False, extension=values,
                     **_coefficient_values(precision, st, None))
    harness = _render("harness.c.j2", name=name, NAME=name.upper(), precision=precision,
                      irregular=False, temperature=False)
    return Firmware(model=model, method=method, precision=precision, rate=float(rate),
                    full_scale=float(full_scale), name=name, header=header, source=source,
                    harness=harness, bound=bound, coefficients=_coefficient_table(c, st, precision),
                    extension=check, uses_double=precision == "float32")


def _maps_firmware(model: CreepModel, method: str, precision: str, rate: float, full_scale,
                   name: str) -> Firmware:
    """The float32 fixed-rate corrector of a model with static maps, of a static calibration or
    of a model with a load filter (:mod:`creepcomp.digital.firmware_transfer` has the step and
    its bound).

    Returns
    -------
    Firmware
        Its ``bound`` is the compensated signal's (fraction of ``full_scale``); ``maps`` holds
        the load's bound and the ranges (from the
        :class:`~creepcomp.digital.firmware_transfer.TransferBound`).
    """
    linear_model = CreepModel(model.beta, model.tau, model.gain, model.offset)
    raw = full_scale
    full_scale = range_full_scale(model, raw)
    if model.is_static:     # the arguments checked with a stand-in: no creep terms to check
        check_arguments(CreepModel((0.1,), (1.0,), model.gain, model.offset), method, precision,
                        rate, full_scale, name)
    else:
        check_arguments(linear_model, method, precision, rate, full_scale, name)
    bound = transfer_bound(model, method, rate, raw)
    path = model.transfer
    h = None if path is None else path.signal_map
    f = None if path is None else path.load_map
    sigma = 1.0 + model.beta0 if method == "supplemental" else 1.0
    maps = {"static": model.is_static, "describe": "linear" if path is None else path.describe(),
            "h": None if h is None else _map_values(h, "forward"),
            "h_inverse": None if h is None else _map_values(h, "inverse"),
            "f_inverse": None if f is None else _map_values(f, "inverse"),
            "load_scale": _c_float(1.0 / (model.gain * sigma)),
            "raw_min": repr(float(bound.raw[0])), "raw_max": repr(float(bound.raw[1])),
            "bound_signal": f"{bound.compensated:.3e}", "bound_load": f"{bound.load:.3e}",
            "libm_ulps": f"{LIBM_ULPS:g}"}
    load_filter = {}
    if bound.filter_samples > 1:
        load_filter = {"load_filter": {"samples": str(bound.filter_samples),
                                       "window": _qty(bound.filter_samples / rate, "s")}}
    maps["libm"] = any(m is not None and m["libm"] for m in (maps["h"], maps["f_inverse"]))
    maps["spline"] = any(m is not None and m["form"] == "spline"
                         for m in (maps["h"], maps["h_inverse"], maps["f_inverse"]))
    lines = _maps_lines(model, rate, full_scale, bound)
    bound_fs = bound.compensated / full_scale
    if model.is_static:
        identity = ((), (), model.offset, model.gain, rate, full_scale, precision, method)
        values = {"name": name, "NAME": name.upper(), "version": _version(), "method": method,
                  "precision": precision, "irregular": False, "temperature": False,
                  "command": (f"creepcomp firmware MODEL --method {method} --precision {precision} "
                              f"--rate {rate:.9g} --full-scale {full_scale:.9g} --name {name}"),
                  "terms": "0", "full_scale": repr(float(full_scale)), "rate": repr(float(rate)),
                  "offset": repr(float(model.offset))}
        derivation, coefficients, table, gains, peak = lines, {}, {"precision": precision}, {}, 1.0
        source_template, source_values = "static_float32.c.j2", {"offset": _c_float(model.offset),
                                                                 "irregular": False}
    else:
        c = exact_coefficients(linear_model, rate)
        st = stored_coefficients(c, precision)
        values = _header_values(linear_model, method, precision, rate, full_scale, name, c, None, None)
        identity = (values["model_id"], model.gain)
        derivation = _derivation(linear_model, method, precision, rate, bound.linear_full_scale, c, st)
        derivation = [_in_h(line) for line in derivation] + lines
        coefficients = _coefficient_values(precision, st, None)
        table = _coefficient_table(c, st, precision)
        gains, peak = dict(bound.linear.gains), bound.linear.peak_fs
        source_template, source_values = "float32_maps.c.j2", {"irregular": False, "temperature": False,
                                                                "method": method, **coefficients}
    if isinstance(raw, (tuple, list)):
        values["command"] = values["command"].replace(f"--full-scale {full_scale:.9g}",
                                                      f"--full-scale {bound.raw[0]:.9g}:{bound.raw[1]:.9g}")
    if load_filter:
        identity = (identity, bound.filter_samples)
    values["model_id"] = f"0x{_fnv1a(repr((identity, bound.raw, path and path.to_dict()))):08x}u"
    error_bound = ErrorBound(total_fs=float(bound_fs), terms={"compensated signal, all parts": float(bound_fs)},
                             full_scale=float(full_scale), peak_fs=float(peak), gains=gains)
    bound_lines = _maps_bound_lines(bound, full_scale)
    if bound.linear is not None:
        bound_lines += ["The corrector on the linearised signal (units of h(raw), FS_h = "
                        f"{bound.linear.full_scale:.9g}):"]
        bound_lines += ["  " + _in_h(line) for line in _bound_lines(bound.linear, bound.linear.full_scale)[:-1]]
    header = _render("fixed_rate.h.j2", **values, maps=maps, derivation=derivation,
                     bound=bound_lines, bound_fs=f"{bound_fs:.3e}", **load_filter)
    source = _render(source_template, name=name, NAME=name.upper(), version=_version(), maps=maps,
                     **source_values, **load_filter)
    harness = _render("harness.c.j2", name=name, NAME=name.upper(), precision=precision,
                      irregular=False, temperature=False, maps=maps)
    return Firmware(model=model, method=method, precision=precision, rate=float(rate),
                    full_scale=float(full_scale), name=name, header=header, source=source,
                    harness=harness, bound=error_bound, coefficients=table,
                    uses_double=False, maps=_maps_summary(bound, rate))


def _in_h(line: str) -> str:
    """A line of the creep corrector's derivation or bound, in the units it has with a signal
    map: those of the linearised signal ``h(raw)``."""
    return line.replace("signal units", "units of h(raw)").replace("|raw - offset|", "|h(raw) - offset|")


def _map_values(m, direction: str) -> dict:
    """A map's :func:`~creepcomp.digital.firmware_transfer.map_code` with its constants as C
    float literals."""
    code = map_code(m, direction)
    for key in ("origin", "exponent", "inv_limit"):
        if key in code:
            code[key] = _c_float(code[key])
    if code["form"] == "spline":
        code.update(knots=str(code["knots"]), **{k: [_c_float(v) for v in code[k]] for k in ("x", "y", "s")})
    return code


def _maps_summary(bound: TransferBound, rate: float) -> dict:
    """The firmware's ``maps``: bounds and ranges, JSON-ready; with a load filter,
    ``load_filter``: its ``samples`` and ``window`` (s) at the firmware's rate."""
    summary = {"bound_signal": bound.compensated, "bound_load": bound.load,
               "bound_corrected": bound.corrected, "raw_range": list(bound.raw),
               "corrected_range": list(bound.corrected_range), "load_range": list(bound.load_range),
               "linear_full_scale": bound.linear_full_scale, "terms": dict(bound.terms)}
    if bound.filter_samples > 1:
        summary["load_filter"] = {"samples": bound.filter_samples,
                                  "window": bound.filter_samples / rate}
    return summary


def _maps_lines(model: CreepModel, rate: float, full_scale: float, bound: TransferBound) -> list[str]:
    """The maps' part of the derivation, as comment lines."""
    path = model.transfer
    lines = [f"Static maps: {'none' if path is None else path.describe()}; gain = {model.gain:.9g} "
             "(linearised signal per unit of the creep's input).",
             f"Raw range: {bound.raw[0]:.9g} to {bound.raw[1]:.9g} signal units (full scale "
             f"{full_scale:.9g} about the unloaded raw signal); h(raw) - offset within "
             f"+-{bound.linear_full_scale:.9g}.",
             "Maps in float32: reciprocal and saturating by one division, spline by a knot table "
             "(binary search, y_k + s_k (x - x_k), end slopes continued), power and log by powf/logf/expf "
             f"(assumed within {LIBM_ULPS:g} ulp)."]
    if model.is_static and bound.filter_samples > 1:
        lines.append("A static calibration: no creep terms, the state holds the load filter's "
                     "window only.")
    elif model.is_static:
        lines.append(f"A static calibration: no creep terms, the state holds nothing (the rate, "
                     f"{_qty(rate, 'Hz')}, changes nothing).")
    if bound.filter_samples > 1:
        n = bound.filter_samples
        lines.append(f"Load filter: {model.load_filter.describe()}; at {_qty(rate, 'Hz')}, the mean "
                     f"of the last N = {n} loads ({_qty(n / rate, 's')}), fewer while the window "
                     "fills. The loads are held in the state, summed afresh each sample in float32 "
                     "and divided by their count; init, settle and restore empty the window, as "
                     "the Python filter starts from an empty history. The compensated signal is "
                     "not filtered.")
    return lines


def _maps_bound_lines(bound: TransferBound, full_scale: float) -> list[str]:
    lo, hi = bound.corrected_range
    llo, lhi = bound.load_range
    lines = [f"Worst-case |compensated - float64 compensate| <= {bound.compensated:.3e} signal units "
             f"({bound.compensated / full_scale:.3e} x FS);",
             f"worst-case |load - float64 estimate_load| <= {bound.load:.3e} load units"
             + (f" (both the mean of the last {bound.filter_samples} loads)" if bound.filter_samples > 1
                else "") + ";",
             f"corrected value c (units of h) within {bound.corrected:.3e} of the exact one,",
             f"for every raw sample from {bound.raw[0]:.9g} to {bound.raw[1]:.9g}, from a relaxed or "
             "settled start. The compensated signal's and the load's bounds hold while the exact c",
             f"stays within {lo:.9g} to {hi:.9g} (the corrector's reach from the raw range; loads "
             f"{llo:.6g} to {lhi:.6g}).",
             "Parts (by cause, in the units of the stage they enter):"]
    lines += [f"  {name}: {value:.3e}" for name, value in bound.terms.items()]
    lines.append("Derivation: docs/firmware.md (static maps: each map's float32 evaluation, and each "
                 "error carried through the next map by its slope over the range).")
    return lines


def render_target_program(firmware: Firmware, template: str) -> str:
    """The program that runs a corrector's step on a simulated chip
    (:mod:`creepcomp.digital.firmware_target`), from its template."""
    maps = {} if firmware.maps is None else {"maps": firmware.maps}
    return _render(template, name=firmware.name, precision=firmware.precision,
                   irregular=firmware.irregular, temperature=firmware.temperature_range is not None,
                   **maps)


def check_no_extensions(model: CreepModel) -> None:
    """Refuse, naming it, an extension of the model (``extensions``): the C corrector runs
    the Prony terms, gain and offset and the temperature law, and would drop it."""
    for name in model.extensions or {}:
        raise InputError(f"the model's extension '{name}' has no C corrector: generate the firmware "
                         f"of the baseline model (baseline-model.json, which creepcomp diagnose -o "
                         f"writes), or correct records in Python with creepcomp correct, which "
                         f"applies it")


def naive_float32(model: CreepModel, method: str = "subtractive", rate: float = 100.0,
                  full_scale: float = 1.0, name: str = "creep") -> Firmware:
    """The straightforward single-precision recursion, for comparison only (it has no bound).

    ``c_k = e_k c_k + (1 - e_k) S`` with ``e_k`` and ``1 - e_k`` rounded to float32: with long
    time constants at high rates both the stored ``1 - e_k`` and the state's increments lose
    most of their digits.
    """
    check_arguments(model, method, "float32", rate, full_scale, name)
    c = exact_coefficients(model, rate)
    st = stored_coefficients(c, "float32")
    header = _render("naive.h.j2", **_header_values(model, method, "float32", rate, full_scale,
                                                    name, c, None, None),
                     derivation=_derivation(model, method, "float32", rate, full_scale, c, st),
                     bound=["NAIVE reference recursion (c = e c + (1 - e) S in float32): no error "
                            "bound; for comparison only, do not deploy."], bound_fs="-1.0")
    source = _render("naive.c.j2", name=name, NAME=name.upper(), method=method,
                     e=[_c_float(x) for x in c.decay], **_coefficient_values("float32", st, None))
    harness = _render("harness.c.j2", name=name, NAME=name.upper(), precision="float32",
                      irregular=False, temperature=False)
    return Firmware(model=model, method=method, precision="float32", rate=float(rate),
                    full_scale=float(full_scale), name=name, header=header, source=source,
                    harness=harness, bound=None, coefficients=_coefficient_table(c, st, "float32"))


def _temperature_firmware(model, method, precision, rate, full_scale, name, max_interval,
                          temperature_range) -> Firmware:
    """The fixed-rate float32 step of a model with a temperature law (see the module docstring)."""
    law = model.temperature
    if law is None:
        raise InputError("a temperature range was given but the model has no temperature law "
                         "(no 'temperature' block): its corrector takes no temperature")
    if max_interval is not None:
        raise InputError("--max-interval with a temperature law: the dt step does not take a "
                         "temperature; use the fixed rate (--rate)")
    low, high = DEFAULT_TEMPERATURE_RANGE if temperature_range is None else temperature_range
    check_arguments(CreepModel(model.beta, model.tau, model.gain, model.offset), method,
                    precision, rate, full_scale, name)
    if precision == "float32":
        scheme = temperature_scheme(model, rate, float(low), float(high))
    else:
        scheme = q31_temperature_scheme(model, rate, float(low), float(high))
    bound = temperature_bound(model, method, rate, full_scale, scheme, precision)
    c = exact_coefficients(model, rate)
    st = stored_coefficients(c, precision)
    values = _header_values(model, method, precision, rate, full_scale, name, c, None, None)
    values["command"] += f" --temperature-range {low:g}:{high:g}"
    identity = (values["model_id"], law.to_dict(), scheme.low, scheme.high)
    values.update(irregular=True, temperature=True, model_id=f"0x{_fnv1a(repr(identity)):08x}u")
    if precision == "float32":
        values.update(temperature_low=_c_float(scheme.low), temperature_high=_c_float(scheme.high),
                      temperature_reference=_c_float(scheme.reference))
    else:
        values.update(temperature_low=str(scheme.low_q), temperature_high=str(scheme.high_q),
                      temperature_reference=str(scheme.reference_q))
    header = _render(f"{precision}_temperature.h.j2", **values,
                     derivation=_temperature_derivation(model, method, precision, rate, full_scale,
                                                        c, st, scheme),
                     bound=_bound_lines(bound, full_scale)
                     + [f"The bound holds for temperatures in {scheme.low:g} to {scheme.high:g} °C; "
                        "outside, the step clamps the temperature to that range."],
                     bound_fs=f"{bound.total_fs:.3e}")
    source = _render(f"{precision}_temperature.c.j2", name=name, NAME=name.upper(),
                     version=_version(), method=method, irregular=True, temperature=True,
                     **_temperature_values(precision, st, scheme))
    harness = _render("harness.c.j2", name=name, NAME=name.upper(), precision=precision,
                      irregular=False, temperature=True)
    table = _coefficient_table(c, st, precision)
    table.update(temperature_range=[scheme.low, scheme.high],
                 a_range=[[float(x) for x in scheme.a_min], [float(x) for x in scheme.a_max]],
                 shift_relative_error=scheme.rel_shift)
    return Firmware(model=model, method=method, precision=precision, rate=float(rate),
                    full_scale=float(full_scale), name=name, header=header, source=source,
                    harness=harness, bound=bound, coefficients=table,
                    temperature_range=(scheme.low, scheme.high))


def _coefficient_table(c: ExactCoefficients, st: StoredCoefficients, precision: str) -> dict:
    return {"T": c.interval, "beta": [float(x) for x in c.beta], "tau": [float(x) for x in c.tau],
            "a": [float(x) for x in c.a], "a_stored": [float(x) for x in st.a],
            "beta_stored": [float(x) for x in st.beta], "precision": precision}


# ------------------------------------------------------------------ the values of the templates

def _c_float(value: float) -> str:
    return f"{float32_value(value):.9e}f"


def _fnv1a(text: str) -> int:
    h = 2166136261
    for byte in text.encode():
        h = ((h ^ byte) * 16777619) % 2 ** 32
    return h


def _qty(value: float, unit: str) -> str:
    from creepcomp.units import format_quantity

    return format_quantity(value, unit, digits=6)


def _header_values(model, method, precision, rate, full_scale, name, c, scheme,
                   max_interval) -> dict:
    """The header's values but its comments (derivation, bound): the description and macros."""
    timing = f"--rate {rate:.9g}" if scheme is None else f"--max-interval {max_interval:.9g}"
    identity = (c.beta.tolist(), c.tau.tolist(), c.offset, rate, full_scale, precision,
                method) + (() if max_interval is None else (max_interval,))
    values = {"name": name, "NAME": name.upper(), "version": _version(), "method": method,
              "precision": precision, "irregular": scheme is not None, "temperature": False,
              "command": (f"creepcomp firmware MODEL --method {method} --precision {precision} "
                          f"{timing} --full-scale {full_scale:.9g} --name {name}"),
              "terms": str(model.n_terms), "full_scale": repr(float(full_scale)),
              "offset": repr(float(model.offset)), "model_id": f"0x{_fnv1a(repr(identity)):08x}u"}
    if scheme is None:
        values["rate"] = repr(float(rate))
    elif precision == "float32":
        values.update(min_interval=_c_float(scheme.min_f),
                      max_interval=_c_float(scheme.limit_f))
    else:
        values.update(tick=repr(TICK), max_ticks=str(scheme.max_ticks),
                      max_interval=repr(scheme.dt_max))
    return values


def _coefficient_values(precision: str, st: StoredCoefficients, scheme=None) -> dict:
    """The stored coefficients as C literals: of the fixed-rate step, or of the dt step."""
    if precision == "float32":
        values = {"beta": [_c_float(x) for x in st.beta], "offset": _c_float(st.offset),
                  "inv_saturation": _c_float(st.inv_saturation), "saturation": _c_float(st.saturation)}
        if scheme is None:
            values["a"] = [_c_float(x) for x in st.a]
        else:
            values.update(inv_tau=[_c_float(x) for x in scheme.inv_tau],
                          **_series_values(scheme))
        return values
    values = {"beta_mantissas": [str(m) for m, _ in st.beta_q],
              "beta_shifts": [str(1 + s) for _, s in st.beta_q],
              "saturation": str(st.saturation_q), "inv_saturation": str(st.inv_saturation_q)}
    if scheme is None:
        values.update(a_mantissas=[str(m) for m, _ in st.a_q],
                      a_shifts=[str(1 + s) for _, s in st.a_q])
    else:
        values.update(tick_mantissas=[str(m) for m, _ in scheme.m],
                      tick_exponents=[str(int(e)) for e in scheme.exps],
                      second_shifts=[str(int(r)) for r in scheme.r2],
                      first_shift=str(scheme.r1), inv_next=[str(v) for v in scheme.inv_next],
                      series_terms=str(scheme.n))
    return values


def _derivation(model, method, precision, rate, full_scale, c, st) -> list[str]:
    """The coefficients' derivation, as comment lines."""
    unit = "signal units"
    lines = [f"Model: {model.n_terms} creep term(s), beta0 = {model.beta0:.6g}, offset = "
             f"{model.offset:.9g} {unit}; method {method}; precision {precision}.",
             f"Sample interval T = 1 / {_qty(rate, 'Hz')} = {_qty(c.interval, 's')}; load held between samples.",
             f"Full scale FS = {full_scale:.9g} {unit}: the inputs satisfy |raw - offset| <= FS."]
    for k in range(model.n_terms):
        tau, a = c.tau[k], c.a[k]
        lines.append(f"term {k}: beta = {c.beta[k]:.9g}, tau = {_qty(tau, 's')}, tau/T = {tau / c.interval:.6g}")
        lines.append(f"  a = 1 - exp(-T/tau) = -expm1(-{c.interval / tau:.9g}) = {a:.12g}")
        if precision == "float32":
            lines.append(f"  stored a = {st.a[k]:.9e} (relative error {abs(st.a[k] / a - 1):.2e}), "
                         f"beta = {st.beta[k]:.9e} (relative error {abs(st.beta[k] / c.beta[k] - 1):.2e})")
        else:
            (am, ash), (bm, bsh) = st.a_q[k], st.beta_q[k]
            lines.append(f"  stored a = {am} * 2^-{31 + ash} (relative error {abs(st.a[k] / a - 1):.2e}), "
                         f"beta = {bm} * 2^-{31 + bsh} (relative error {abs(st.beta[k] / c.beta[k] - 1):.2e})")
    lines.append(f"1 + beta0 = {c.saturation:.12g} (supplemental scale); 1/(1 + beta0) = {c.inv_saturation:.12g} "
                 "(settled start: c_k = x / (1 + beta0))")
    return lines


def _series_values(scheme) -> dict:
    """The float32 series of ``(1 - exp(-x))/x`` as C literals: its coefficients and the terms
    each creep term takes."""
    return {"series_c": [_c_float(x) for x in scheme.series_c], "series_terms": str(len(scheme.series_c)),
            "series": [str(int(n)) for n in scheme.series]}


def _series_text(scheme) -> str:
    """The series' terms per creep term (float32) or of all (q31), for the derivation."""
    return "/".join(str(int(n)) for n in scheme.series) if hasattr(scheme, "series") else str(scheme.n)


def _dt_derivation(model, method, precision, full_scale, c, st, scheme) -> list[str]:
    """The dt step's coefficients and the error of its ``a_k(dt)``, as comment lines."""
    unit = "signal units"
    lo, hi = scheme.dt_min, scheme.dt_max
    lines = [f"Model: {model.n_terms} creep term(s), beta0 = {model.beta0:.6g}, offset = "
             f"{model.offset:.9g} {unit}; method {method}; precision {precision}.",
             f"Irregular sampling: dt = time since the previous sample, {_qty(lo, 's')} <= dt <= "
             f"{_qty(hi, 's')}; load held between samples.",
             f"Full scale FS = {full_scale:.9g} {unit}: the inputs satisfy |raw - offset| <= FS.",
             "a_k(dt) = 1 - exp(-dt/tau_k) is computed per sample without libm "
             + ("(halving to x <= 1/8, " if precision == "float32" else "(x <= 1/2, ")
             + f"{_series_text(scheme)} Taylor terms of (1 - exp(-x))/x"
             + (", doubling a <- a(2 - a));" if precision == "float32" else ");"),
             "its worst relative error over the dt range is in the bound:"]
    for k in range(model.n_terms):
        tau = c.tau[k]
        lines.append(f"term {k}: beta = {c.beta[k]:.9g}, tau = {_qty(tau, 's')}, "
                     f"a(dt max) = {-math.expm1(-hi / tau):.9g}, relative error of computed a <= "
                     f"{scheme.rel_a[k]:.2e}")
        if precision == "float32":
            lines.append(f"  stored 1/tau = {scheme.inv_tau[k]:.9e} 1/s, halvings <= {int(scheme.halvings[k])}; "
                         f"beta = {st.beta[k]:.9e}")
        else:
            m, sh = scheme.m[k]
            lines.append(f"  tick/tau = {m} * 2^-{31 + sh} (tick {TICK:g} s); beta = "
                         f"{st.beta_q[k][0]} * 2^-{31 + st.beta_q[k][1]}")
    lines.append(f"1 + beta0 = {c.saturation:.12g} (supplemental scale); 1/(1 + beta0) = {c.inv_saturation:.12g} "
                 "(settled start: c_k = x / (1 + beta0))")
    return lines


def _temperature_values(precision: str, st: StoredCoefficients, scheme) -> dict:
    """The temperature step's stored coefficients as C literals."""
    coefficients = _coefficient_values(precision, st, None)
    if precision == "float32":
        del coefficients["a"]
        return {**coefficients, "dt_over_tau": [_c_float(x) for x in scheme.dt_over_tau],
                **_series_values(scheme), "exp_c": [_c_float(x) for x in scheme.exp_c],
                "exp_terms": str(scheme.exp_terms), "curve_c": _c_float(scheme.curve_c),
                "curve_d": _c_float(scheme.curve_d), "log2e": _c_float(scheme.log2e),
                "ln2_head": _c_float(scheme.ln2_head), "ln2_tail": _c_float(scheme.ln2_tail)}
    del coefficients["a_mantissas"], coefficients["a_shifts"]
    return {**coefficients, "dt_mantissas": [str(m) for m, _ in scheme.m],
            "dt_exponents": [str(int(e)) for e in scheme.exps],
            "inv_next": [str(v) for v in scheme.inv_next], "series_terms": str(scheme.n),
            "exp_next": [str(v) for v in scheme.exp_next], "exp_terms": str(scheme.exp_terms),
            "curve_c": str(scheme.curve_c_q), "curve_d": str(scheme.curve_d_q),
            "reference": str(scheme.reference_d),
            "log2e": str(scheme.log2e_q), "ln2": str(scheme.ln2_q)}


def _temperature_derivation(model, method, precision, rate, full_scale, c, st, scheme) -> list[str]:
    """The temperature step's law, its computation without libm and its errors, as comment lines."""
    law = model.temperature
    unit = "signal units"
    shape = (f"a_T = exp(E_a/R (1/T - 1/T_ref)), E_a = {law.activation_energy:.6g} J/mol"
             if law.law == "arrhenius" else f"log10 a_T = -c1 d / (c2 + d), c1 = {law.c1:.6g}, c2 = {law.c2:.6g} K")
    y_lo, y_hi = scheme.y_range
    lines = [f"Model: {model.n_terms} creep term(s), beta0 = {model.beta0:.6g}, offset = "
             f"{model.offset:.9g} {unit}; method {method}; precision {precision}.",
             f"Sample interval T = 1 / {_qty(rate, 'Hz')} = {_qty(c.interval, 's')}; load held between samples.",
             f"Full scale FS = {full_scale:.9g} {unit}: the inputs satisfy |raw - offset| <= FS.",
             f"Temperature law ({law.law}, reference T_ref = {law.reference:g} °C): tau_k(T) = tau_k a_T, {shape}.",
             f"Temperature range {scheme.low:g} to {scheme.high:g} °C (clamped): "
             f"ln(1/a_T) from {y_lo:.6g} to {y_hi:.6g}.",
             "Per sample, tau_k over the step follows the temperature at its middle, "
             "Tm = (T_prev + T)/2; without libm:"]
    if precision == "float32":
        lines += [f"  y = ln(1/a_T) = C d / (D0 + d), d = Tm - T_ref, C = {scheme.curve_c:.9g}, D0 = {scheme.curve_d:.9g};",
                  f"  1/a_T = 2^j exp(f), j = round(y / ln 2), |f| <= ln2/2, exp(f) by its Taylor polynomial of degree {scheme.exp_terms};",
                  f"  a_k = 1 - exp(-x_k), x_k = (T/tau_k) / a_T, as the dt step ({_series_text(scheme)} terms of (1 - exp(-x))/x)."]
    else:
        lines += ["  temperatures in 1/256 °C (int32_t), so Tm is exact;",
                  f"  y = ln(1/a_T) = C d / (D0 + d) in Q28, d = Tm - T_ref in 2^-19 K, C = {scheme.curve_c_q} * 2^-28, "
                  f"D0 = {scheme.curve_d_q} * 2^-19 K (one 64-bit division);",
                  f"  1/a_T = p 2^j, j = round(y / ln 2), p = exp(f) in Q31 by {scheme.exp_terms} Taylor terms;",
                  f"  a_k = x t(x), x = (T/tau_k) p 2^j, t = (1 - exp(-x))/x in Q31 ({scheme.n} terms), as the q31 dt step."]
    lines.append(f"Relative error of the computed 1/a_T <= {scheme.rel_shift:.2e} (temperature, y, f, polynomial).")
    lo_tau, hi_tau = scheme.tau_range
    for k in range(model.n_terms):
        lines.append(f"term {k}: beta = {c.beta[k]:.9g}, tau = {_qty(c.tau[k], 's')} at T_ref, "
                     f"{_qty(hi_tau[k], 's')} to {_qty(lo_tau[k], 's')} over the range; a from "
                     f"{scheme.a_min[k]:.6g} to {scheme.a_max[k]:.6g}, relative error of computed a <= "
                     f"{scheme.rel_a[k]:.2e}")
        if precision == "float32":
            lines.append(f"  stored T/tau = {scheme.dt_over_tau[k]:.9e}, beta = {st.beta[k]:.9e}")
        else:
            m, sh = scheme.m[k]
            lines.append(f"  T/tau = {m} * 2^-{31 + sh}; beta = {st.beta_q[k][0]} * 2^-{31 + st.beta_q[k][1]}")
    lines.append(f"1 + beta0 = {c.saturation:.12g} (supplemental scale); 1/(1 + beta0) = {c.inv_saturation:.12g} "
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


@functools.cache
def _version() -> str:
    """The installed creepcomp's version (read once: both the header and the source print it)."""
    from importlib import metadata

    try:
        return metadata.version("creepcomp")
    except metadata.PackageNotFoundError:
        return "(version unknown)"


# ------------------------------------------------------------------------------ the templates

def _initializer(values) -> str:
    """A C array initializer: ``{v0, v1, ...}``."""
    return "{" + ", ".join(values) + "}"


def _comment(lines) -> str:
    """Lines of a block comment: `` * line`` each."""
    return "\n".join((" * " + line).rstrip() for line in lines)


@functools.cache
def _environment() -> jinja2.Environment:
    env = jinja2.Environment(loader=jinja2.PackageLoader("creepcomp.digital", "templates"),
                             undefined=jinja2.StrictUndefined, keep_trailing_newline=True,
                             trim_blocks=True, lstrip_blocks=True, autoescape=False)
    env.filters.update(initializer=_initializer, comment=_comment)
    return env


@functools.cache
def _parsed(template: str) -> jinja2.nodes.Template:
    env = _environment()
    return env.parse(env.loader.get_source(env, template)[0])


@functools.cache
def _template_tree(template: str) -> frozenset[str]:
    """The template and every template it extends, includes or imports, recursively."""
    found = {template}
    for other in meta.find_referenced_templates(_parsed(template)):
        if other is None:
            raise RuntimeError(f"internal error: template {template} names a template by a "
                               "computed name, which cannot be checked")
        found |= _template_tree(other)
    return frozenset(found)


@functools.cache
def _template_variables(template: str) -> frozenset[str]:
    """The values a template needs: the undeclared variables of its tree (found once: the walk
    of the tree's syntax costs more than the rendering)."""
    return frozenset().union(*(meta.find_undeclared_variables(_parsed(t))
                               for t in _template_tree(template)))


#: Values a template may go without (tested with ``is defined``): the extension map's, which
#: only the step of a model with an extension has, the static maps' (``maps``), which only
#: a model with a transfer or a static calibration has, ``plain``, which only the float32
#: step with plain states has, and ``load_filter``, which only a model with a load filter has.
_OPTIONAL = frozenset({"extension", "maps", "plain", "load_filter"})


def _render(template: str, **values) -> str:
    """Render a template with exactly the values it uses (each a final text, or a list of them;
    those of :data:`_OPTIONAL` may be left out)."""
    needed = _template_variables(template)
    missing, unused = sorted(needed - values.keys() - _OPTIONAL), sorted(values.keys() - needed)
    if missing or unused:
        raise RuntimeError(f"internal error: template {template}"
                           + (f" has no value for {', '.join(missing)}" if missing else "")
                           + (" and" if missing and unused else "")
                           + (f" does not use {', '.join(unused)}" if unused else ""))
    return _environment().get_template(template).render(values)
