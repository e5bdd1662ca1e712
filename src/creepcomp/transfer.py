"""Static monotone maps on either side of the linear creep: the signal path of soft sensors.

A force-sensing resistor's resistance follows a power law of force over decades, a Velostat
pad saturates, a capacitive foam taxel's counts fall with pressure. The paper's model (signal
linear in load) cannot hold them; a monotone static map on either side of the linear creep
can::

    signal = h^-1( offset + gain * G(s)[ f(load) ] )

- ``load_map`` ``f`` (Hammerstein): the load as the material feels it (e.g. a power of the
  force), the input of the creep;
- ``signal_map`` ``h`` (the inverse of a Wiener map): what linearises the signal (e.g. the
  reciprocal of a resistance, a conductance), where the creep is linear.

Both are monotone (increasing or decreasing), so the load comes back uniquely::

    load = f^-1( G^-1[ h(signal) - offset ] / gain )

Each map is one :class:`StaticMap`: a form (``power``, ``reciprocal``, ``log``,
``saturating``, ``spline``) and its parameters, with ``forward``, ``inverse``, a model-file
form and checks. No map means the identity.

Examples
--------
A resistance that falls as the reciprocal of the load, linearised by its conductance:

>>> import numpy as np
>>> from creepcomp.transfer import StaticMap
>>> h = StaticMap("reciprocal", {"origin": 0.0})
>>> resistance = np.array([1000.0, 500.0, 250.0])
>>> h.forward(resistance)
array([0.001, 0.002, 0.004])
>>> h.inverse(h.forward(resistance))
array([1000.,  500.,  250.])
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from creepcomp.errors import InputError
from creepcomp.units import check_number

__all__ = ["StaticMap", "Transfer", "FORMS", "MAX_KNOTS"]

#: The forms of a static map, with the parameters each takes (all required).
FORMS = {
    "power": ("exponent", "origin"),
    "reciprocal": ("origin",),
    "log": ("origin",),
    "saturating": ("limit",),
    "spline": ("x", "y"),
}
#: Largest magnitude of a map's parameter: float32, the firmware's type, holds it with room for
#: the map's arithmetic (as a model's gain and offset: :data:`creepcomp.model.VALUE_RANGE`).
VALUE_LIMIT = 1e30
#: Most knots of a ``spline`` map: a monotone calibration curve needs tens, and the firmware
#: carries every knot as a table.
MAX_KNOTS = 64


def _numbers(value, name: str) -> tuple[float, ...]:
    if not isinstance(value, (list, tuple, np.ndarray)):
        raise InputError(f"{name} must be a list of numbers")
    return tuple(check_number(v, f"{name}[{k}]", high=VALUE_LIMIT) for k, v in enumerate(value))


@dataclass(frozen=True)
class StaticMap:
    """One monotone static map ``y = m(x)``.

    Parameters
    ----------
    form : str
        ``power``: ``y = sign(x - origin) |x - origin|^exponent`` (``exponent > 0``: odd and
        increasing through ``origin``; ``exponent < 0``: decreasing, for ``x > origin``);
        ``reciprocal``: ``y = 1 / (x - origin)`` (``x > origin``); ``log``:
        ``y = ln(x - origin)`` (``x > origin``); ``saturating``: ``y = x / (1 - x / limit)``
        (``x < limit`` for ``limit > 0``; undoes a response ``x = y / (1 + y / limit)`` that
        saturates at ``limit``); ``spline``: piecewise linear through the knots ``(x, y)``,
        strictly monotone, continued past the ends with the end segments' slopes.
    parameters : mapping
        The form's parameters (:data:`FORMS`).
    """

    form: str
    parameters: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self):
        if self.form not in FORMS:
            raise InputError(f"static map form {self.form!r}: use one of {', '.join(FORMS)}")
        if not isinstance(self.parameters, Mapping):
            raise InputError(f"static map {self.form}: parameters must be an object")
        names = FORMS[self.form]
        unknown = sorted(set(self.parameters) - set(names))
        missing = [n for n in names if n not in self.parameters]
        if unknown or missing:
            raise InputError(f"static map {self.form}: needs {', '.join(names)}"
                             + (f"; missing {', '.join(missing)}" if missing else "")
                             + (f"; unknown {', '.join(unknown)}" if unknown else ""))
        p = {}
        for n in names:
            v = self.parameters[n]
            p[n] = (_numbers(v, f"{self.form}.{n}") if self.form == "spline"
                    else check_number(v, f"{self.form}.{n}", high=VALUE_LIMIT))
        if self.form == "power" and p["exponent"] == 0:
            raise InputError("power map: exponent 0 is constant, not monotone")
        if self.form == "saturating" and p["limit"] == 0:
            raise InputError("saturating map: limit 0 leaves no range")
        if self.form == "spline":
            x, y = np.array(p["x"]), np.array(p["y"])
            if len(x) != len(y) or not 2 <= len(x) <= MAX_KNOTS:
                raise InputError(f"spline map: x and y need the same number of knots, 2 to {MAX_KNOTS} "
                                 f"(got {len(x)} and {len(y)})")
            if np.any(np.diff(x) <= 0):
                raise InputError("spline map: knots x must be strictly increasing")
            dy = np.diff(y)
            if not (np.all(dy > 0) or np.all(dy < 0)):
                raise InputError("spline map: knot values y must be strictly monotone")
        object.__setattr__(self, "parameters", p)

    # -- evaluation -----------------------------------------------------------------------
    @property
    def increasing(self) -> bool:
        """Whether ``y`` grows with ``x``."""
        p = self.parameters
        if self.form == "power":
            return p["exponent"] > 0
        if self.form == "reciprocal":
            return False
        if self.form == "spline":
            return p["y"][-1] > p["y"][0]
        return True

    def domain(self) -> tuple[float, float]:
        """The open interval of ``x`` the map is defined on."""
        p = self.parameters
        if self.form in ("reciprocal", "log") or (self.form == "power" and p["exponent"] < 0):
            return (p["origin"], math.inf)
        if self.form == "saturating":
            return (-math.inf, p["limit"]) if p["limit"] > 0 else (p["limit"], math.inf)
        return (-math.inf, math.inf)

    def within(self, x) -> np.ndarray:
        """``x`` with the values outside :meth:`domain` moved just inside its edge (by a
        billionth of the values' span): a reciprocal or logarithmic map is defined on one side
        of its origin only, and a sample on the other (noise at a converter's rail) would make a
        corrector's states NaN for the rest of the record."""
        x = np.asarray(x, dtype=float)
        lo, hi = self.domain()
        if not (math.isfinite(lo) or math.isfinite(hi)):
            return x
        span = float(np.ptp(x[np.isfinite(x)])) if x.size else 0.0
        edge = 1e-9 * max(span, abs(lo) if math.isfinite(lo) else 0.0, abs(hi) if math.isfinite(hi) else 0.0, 1e-300)
        return np.clip(x, lo + edge if math.isfinite(lo) else -np.inf, hi - edge if math.isfinite(hi) else np.inf)

    def outside(self, x) -> int:
        """How many of ``x`` lie outside :meth:`domain` (those :meth:`within` moves)."""
        lo, hi = self.domain()
        x = np.asarray(x, dtype=float)
        return int(np.count_nonzero(~((x > lo) & (x < hi))))

    def forward(self, x) -> np.ndarray:
        """``y = m(x)``; ``x`` outside :meth:`domain` gives NaN."""
        x = np.asarray(x, dtype=float)
        p = self.parameters
        lo, hi = self.domain()
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            if self.form == "power":
                d = x - p["origin"]
                y = np.sign(d) * np.abs(d) ** p["exponent"]
            elif self.form == "reciprocal":
                y = 1.0 / (x - p["origin"])
            elif self.form == "log":
                y = np.log(x - p["origin"])
            elif self.form == "saturating":
                y = x / (1.0 - x / p["limit"])
            else:
                y = _piecewise(x, np.array(p["x"]), np.array(p["y"]))
            return np.where((x > lo) & (x < hi), y, np.nan) if (lo, hi) != (-math.inf, math.inf) else y

    def derivative(self, x) -> np.ndarray:
        """``dy/dx`` at ``x`` (the slope of the map; NaN outside :meth:`domain`)."""
        x = np.asarray(x, dtype=float)
        p = self.parameters
        lo, hi = self.domain()
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            if self.form == "power":
                d = np.abs(x - p["origin"])
                slope = p["exponent"] * d ** (p["exponent"] - 1.0)
            elif self.form == "reciprocal":
                slope = -1.0 / (x - p["origin"]) ** 2
            elif self.form == "log":
                slope = 1.0 / (x - p["origin"])
            elif self.form == "saturating":
                slope = 1.0 / (1.0 - x / p["limit"]) ** 2
            else:
                xs, ys = np.array(p["x"]), np.array(p["y"])
                seg = np.clip(np.searchsorted(xs, x, side="right") - 1, 0, xs.size - 2)
                slope = (ys[seg + 1] - ys[seg]) / (xs[seg + 1] - xs[seg])
            return np.where((x > lo) & (x < hi), slope, np.nan)

    def inverse(self, y) -> np.ndarray:
        """``x = m^-1(y)``; ``y`` outside the map's range gives NaN."""
        y = np.asarray(y, dtype=float)
        p = self.parameters
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            if self.form == "power":
                e = p["exponent"]
                if e > 0:
                    return p["origin"] + np.sign(y) * np.abs(y) ** (1.0 / e)
                return np.where(y > 0, p["origin"] + np.abs(y) ** (1.0 / e), np.nan)
            if self.form == "reciprocal":
                return np.where(y > 0, p["origin"] + 1.0 / y, np.nan)
            if self.form == "log":
                return p["origin"] + np.exp(y)
            if self.form == "saturating":
                x = y / (1.0 + y / p["limit"])
                lo, hi = self.domain()
                return np.where((x > lo) & (x < hi) & (1.0 + y / p["limit"] > 0), x, np.nan)
            xs, ys = np.array(p["x"]), np.array(p["y"])
            if ys[0] > ys[-1]:
                xs, ys = xs[::-1], ys[::-1]
            return _piecewise(y, ys, xs)

    def describe(self) -> str:
        """One line: the form and its parameters."""
        p = self.parameters
        if self.form == "power":
            return f"power {p['exponent']:.4g} about {p['origin']:.4g}"
        if self.form in ("reciprocal", "log"):
            return f"{self.form} about {p['origin']:.4g}"
        if self.form == "saturating":
            return f"saturating at {p['limit']:.4g}"
        return f"monotone spline, {len(p['x'])} knots"

    def to_dict(self) -> dict:
        """Model-file form: ``{"form": ..., <parameters>}``."""
        out = {"form": self.form}
        out.update({k: (list(v) if isinstance(v, tuple) else v) for k, v in self.parameters.items()})
        return out

    @classmethod
    def from_dict(cls, data, where: str = "static map") -> "StaticMap":
        """Read a model file's map object (``form`` and the form's parameters)."""
        if not isinstance(data, Mapping) or "form" not in data:
            raise InputError(f"{where}: expected an object with 'form' ({', '.join(FORMS)}) and its parameters")
        try:
            return cls(str(data["form"]), {k: v for k, v in data.items() if k != "form"})
        except InputError as exc:
            raise InputError(f"{where}: {exc}") from None


def _piecewise(x: np.ndarray, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """Linear interpolation through increasing ``xs``, continued with the end slopes."""
    y = np.interp(x, xs, ys)
    lo_slope = (ys[1] - ys[0]) / (xs[1] - xs[0])
    hi_slope = (ys[-1] - ys[-2]) / (xs[-1] - xs[-2])
    y = np.where(x < xs[0], ys[0] + (x - xs[0]) * lo_slope, y)
    return np.where(x > xs[-1], ys[-1] + (x - xs[-1]) * hi_slope, y)


@dataclass(frozen=True)
class Transfer:
    """The static maps of a sensor's signal path (either may be absent: the identity).

    Parameters
    ----------
    load_map : StaticMap, optional
        ``f``: load -> the creep's input (Hammerstein side).
    signal_map : StaticMap, optional
        ``h``: signal -> the linear creep's output domain (the inverse of the Wiener map).
    """

    load_map: StaticMap | None = None
    signal_map: StaticMap | None = None

    @property
    def is_identity(self) -> bool:
        """No map on either side."""
        return self.load_map is None and self.signal_map is None

    def load_in(self, load) -> np.ndarray:
        """``f(load)``: the creep's input."""
        return np.asarray(load, float) if self.load_map is None else self.load_map.forward(load)

    def load_out(self, x) -> np.ndarray:
        """``f^-1(x)``: the load from the creep's input."""
        return np.asarray(x, float) if self.load_map is None else self.load_map.inverse(x)

    def linearise(self, signal) -> np.ndarray:
        """``h(signal)``: the signal where the creep is linear."""
        return np.asarray(signal, float) if self.signal_map is None else self.signal_map.forward(signal)

    def linearise_within(self, signal) -> np.ndarray:
        """``h(signal)`` with the samples outside the signal map's domain taken at its edge
        (:meth:`StaticMap.within`): what a correction runs on."""
        if self.signal_map is None:
            return np.asarray(signal, float)
        return self.signal_map.forward(self.signal_map.within(signal))

    def delinearise(self, z) -> np.ndarray:
        """``h^-1(z)``: the signal from its linear domain."""
        return np.asarray(z, float) if self.signal_map is None else self.signal_map.inverse(z)

    def describe(self) -> str:
        """One line naming both maps."""
        parts = []
        if self.load_map is not None:
            parts.append(f"load map {self.load_map.describe()}")
        if self.signal_map is not None:
            parts.append(f"signal map {self.signal_map.describe()}")
        return "; ".join(parts) or "linear"

    def to_dict(self) -> dict:
        """Model-file ``transfer`` block."""
        out = {}
        if self.load_map is not None:
            out["load_map"] = self.load_map.to_dict()
        if self.signal_map is not None:
            out["signal_map"] = self.signal_map.to_dict()
        return out

    @classmethod
    def from_dict(cls, data, where: str = "transfer") -> "Transfer":
        """Read a model file's ``transfer`` block."""
        if not isinstance(data, Mapping):
            raise InputError(f"{where}: expected an object with 'load_map' and/or 'signal_map'")
        unknown = sorted(set(data) - {"load_map", "signal_map"})
        if unknown:
            raise InputError(f"{where}: unknown keys {', '.join(map(str, unknown))} (use load_map, signal_map)")
        maps = {k: (None if data.get(k) is None else StaticMap.from_dict(data[k], f"{where}: {k}"))
                for k in ("load_map", "signal_map")}
        return cls(**maps)
