"""Engineering notation at the edges: parse ``4.7k``, ``10u``, ``45s``, ``3%``; format back.

SI prefixes follow IEC usage (``M`` is mega, ``m`` is milli); ``meg`` is accepted as mega
for SPICE habits. RKM notation (``4k7``, ``2M2``, ``4R7``) is accepted for resistances.
"""

from __future__ import annotations

import math
import numbers
import re
from decimal import Decimal

from creepcomp.errors import InputError

__all__ = ["PREFIXES", "UNITS", "TIME_UNITS", "parse_quantity", "format_quantity", "format_percent",
           "format_parameter", "format_time", "check_number"]

# prefix -> power of ten (decimal arithmetic keeps "2.7%" and "4.7u" exact to the last digit)
PREFIXES = {
    "p": -12, "n": -9, "u": -6, "µ": -6, "μ": -6, "m": -3,
    "k": 3, "K": 3, "meg": 6, "Meg": 6, "MEG": 6, "M": 6, "G": 9, "T": 12,
}

# unit kind -> accepted unit spellings (after the prefix), lower-cased
UNITS = {
    "ohm": ("", "ohm", "ohms", "ω", "r"),  # compared lower-cased: "Ω" -> "ω"
    "farad": ("", "f"),
    "second": ("", "s", "sec"),
    "fraction": ("",),
    "hertz": ("", "hz"),
    "volt": ("", "v"),
    "number": ("",),
}

TIME_UNITS = {"ms": 1e-3, "min": 60.0, "h": 3600.0, "hour": 3600.0, "d": 86400.0, "day": 86400.0}

_NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_RKM = re.compile(r"^(\d+)([pnuµμmkKMGRr])(\d+)(ohm|ohms|Ω)?$")


def parse_quantity(text: str | float | int, kind: str = "number", name: str = "value") -> float:
    """Parse a number with optional SI prefix and unit.

    Parameters
    ----------
    text : str or float
        What the user wrote, e.g. ``"4.7k"``, ``"10uF"``, ``"45s"``, ``"2min"``, ``"3%"``.
    kind : str
        One of ``ohm``, ``farad``, ``second``, ``fraction``, ``hertz``, ``volt``, ``number``.
    name : str
        The option or field name, used in the error message.

    Returns
    -------
    float
        The value in SI units (fractions for ``%`` and ``ppm``).

    Raises
    ------
    InputError
        When the text is not a number in the expected unit, or is NaN or infinite.
    """
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        value = float(text)
        return _finite(value, name, text)
    raw = str(text).strip()
    s = raw.replace(" ", "")
    if not s:
        raise InputError(f"{name}: empty value")
    if s.lower() in ("nan", "inf", "+inf", "-inf", "infinity"):
        raise InputError(f"{name}: '{raw}' is not a finite number")
    if kind == "ohm":
        m = _RKM.match(s)
        if m:
            power = 0 if m.group(2) in "Rr" else PREFIXES[m.group(2)]
            return float(Decimal(f"{m.group(1)}.{m.group(3)}").scaleb(power))
    m = re.match(rf"^({_NUMBER})(.*)$", s)
    if not m:
        raise InputError(f"{name}: cannot read '{raw}' as a number")
    number = Decimal(m.group(1))
    rest = m.group(2)
    if kind in ("fraction", "number") and rest == "%":
        return _finite(float(number.scaleb(-2)), name, raw)
    if kind in ("fraction", "number") and rest.lower() == "ppm":
        return _finite(float(number.scaleb(-6)), name, raw)
    if kind == "second" and rest in TIME_UNITS:
        return _finite(float(number) * TIME_UNITS[rest], name, raw)
    units = UNITS.get(kind, ("",))
    for prefix in sorted(PREFIXES, key=len, reverse=True):
        if rest.startswith(prefix) and rest[len(prefix):].lower() in units:
            return _finite(float(number.scaleb(PREFIXES[prefix])), name, raw)
    if rest.lower() in units:
        return _finite(float(number), name, raw)
    expected = {"ohm": "ohm, e.g. 4.7k, 4k7, 150M", "farad": "farad, e.g. 10u, 4.7uF",
                "second": "seconds, e.g. 45, 45s, 2min", "fraction": "a fraction, e.g. 0.03 or 3%",
                "hertz": "hertz, e.g. 10, 1k", "volt": "volts, e.g. 100u, 100uV, 1V"}.get(kind, "a plain number")
    raise InputError(f"{name}: cannot read '{raw}': expected {expected}")


def _finite(value: float, name: str, raw) -> float:
    if not math.isfinite(value):
        raise InputError(f"{name}: '{raw}' is not a finite number")
    return value


_FORMAT_PREFIXES = [(1e12, "T"), (1e9, "G"), (1e6, "M"), (1e3, "k"), (1.0, ""),
                    (1e-3, "m"), (1e-6, "µ"), (1e-9, "n"), (1e-12, "p")]


def format_quantity(value: float | None, unit: str = "", digits: int = 4) -> str:
    """Format a value with an SI prefix, e.g. ``format_quantity(4.7e6, "Ω") == "4.7 MΩ"``.

    Parameters
    ----------
    value : float or None
        The value in SI units; None and infinity print as ``none`` / ``∞``.
    unit : str
        Unit symbol appended after the prefix.
    digits : int
        Significant digits.

    Returns
    -------
    str
    """
    if value is None:
        return "none"
    if math.isnan(value):
        return "n/a"
    if math.isinf(value):
        return f"∞ {unit}".strip()
    if value == 0:
        return f"0 {unit}".strip()
    mag = abs(value)
    if mag >= 1e16 or mag < 1e-16:
        return f"{value:.{digits}g} {unit}".strip()      # beyond the prefixes: plain exponent
    for scale, prefix in _FORMAT_PREFIXES:
        if mag >= scale * 0.9999999:
            break
    text = f"{value / scale:.{digits}g}"
    return f"{text} {prefix}{unit}".strip()


#: Units of :func:`format_time`, largest first: a time is told in the largest one it reaches.
_CLOCK_UNITS = ((86400.0, "d"), (3600.0, "h"), (60.0, "min"))


def format_time(seconds: float, digits: int = 4) -> str:
    """A time as people say it: in the largest of days, hours and minutes of which it makes at
    least two (``20 min``, ``90 min``, ``2.5 h``, ``3 d``), else in seconds with an SI prefix
    (``113.6 s``, ``150 ms``); the units :func:`parse_quantity` reads back."""
    if seconds is not None and math.isfinite(seconds):
        for size, unit in _CLOCK_UNITS:
            if abs(seconds) >= 2 * size:
                return f"{seconds / size:.{digits}g} {unit}"
    return format_quantity(seconds, "s", digits)


def format_percent(x: float | None, digits: int = 3) -> str:
    """A fraction as percent, e.g. ``0.0849 %``; tiny values in scientific notation."""
    if x is None:
        return "n/a"
    v = 100.0 * x
    if v != 0 and abs(v) < 1e-4:
        return f"{v:.2e} %"
    return f"{v:.{digits}g} %"


#: A part of a network by its label: ``R1``, ``C2``, a cell of a chain ``R1.3``, ``C1.2``.
_PART = re.compile(r"([RC])\d+(?:\.\d+)?")


def format_parameter(name: str, value: float | None, unit: str | None = None) -> str:
    """A parameter with its unit, by its name: parts (``R1.2``, ``C1``) and resistances
    (``source_resistance``) in Ω and F, times (``tau*``, ``*_tau``, ``delay``) in seconds
    (instants, ``where``, to 7 digits), ``beta``, ``absorption`` and ``share`` in percent,
    ``rate`` per second, ``samples`` as a count, a ``value`` with a unit to 10 digits, others
    as plain numbers (``unit``: a number with this unit instead); a kind as it
    is, and a list item by item (an interval ``[a, b]`` as ``a to b``). A dotted name
    (``C1.1.absorption``) is read by its last part."""
    if unit is not None and not isinstance(value, (str, list, tuple)):
        # a value a record holds (a rail a signal is stuck at) to the digit, not to 4 digits
        digits = 10 if name.split(".")[-1] == "value" else 4
        return "n/a" if value is None or not math.isfinite(value) else f"{value:.{digits}g} {unit}"
    part = _PART.fullmatch(name)
    if part and isinstance(value, (int, float)) and math.isfinite(value):
        return format_quantity(value, "Ω" if part.group(1) == "R" else "F")
    name = name.split(".")[-1]
    if isinstance(value, str):
        return value
    if isinstance(value, (list, tuple)):
        items = [" to ".join(format_parameter(name, v, unit) for v in x) if isinstance(x, (list, tuple))
                 else format_parameter(name, x, unit) for x in value]
        return ", ".join(items) if items else "-"
    if value is None or not math.isfinite(value):
        return "n/a"
    if name == "where":
        # an instant on the record's own clock, which may be absolute (days of seconds): to
        # 0.1 s there, not to 4 digits
        return format_quantity(value, "s", digits=7)
    if name.endswith("resistance") or name == "R25":
        return format_quantity(value, "Ω")
    if name == "tc":
        return f"{value * 1e6:.4g} ppm/K"
    if name == "B":
        return f"{value:.5g} K"
    if name.startswith("tau") or name.endswith("_tau") or name in ("delay", "slip"):
        return format_quantity(value, "s")
    if name.startswith("beta") or name in ("absorption", "share"):
        return format_percent(value)
    if name == "samples":
        return f"{value:.0f} samples"
    if name == "rate":
        return f"{value:.4g} /s"
    return f"{value:.4g}"


def check_number(value, name: str, low: float | None = None, high: float | None = None,
                 unit: str = "") -> float:
    """A model or design value as a float: a real number (not a boolean, not text), finite,
    and with its magnitude within ``low`` .. ``high`` when they are given (0 is always
    within).

    Raises
    ------
    InputError
        Naming ``name``, the value and what is allowed.

    Examples
    --------
    >>> check_number(45, "tau")
    45.0
    >>> check_number(1e300, "offset", high=1e30)
    Traceback (most recent call last):
    ...
    creepcomp.errors.InputError: offset = 1e+300: its magnitude must be at most 1e+30
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InputError(f"{name} = {value!r} is not a number")
    try:
        x = float(value)
    except (OverflowError, ValueError):
        x = math.inf
    if not math.isfinite(x):
        raise InputError(f"{name} = {str(value)[:40]} is not a finite number")
    size = abs(x)
    if x != 0 and ((low is not None and size < low) or (high is not None and size > high)):
        span = f"from {low:g}{unit} to {high:g}{unit}" if low and high else (
            f"at least {low:g}{unit}" if low else f"at most {high:g}{unit}")
        raise InputError(f"{name} = {x:g}{unit}: its magnitude must be {span}")
    return x
