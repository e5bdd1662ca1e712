"""IEC 60063 preferred values (E3 ... E192) and snapping to them.

E3 to E24 are the standard's table (its older values such as 2.7, 3.3, 4.7 and 8.2 are not
the rounded geometric series). E192 is written out as the standard lists it, including its one
departure from rounding (9.20, where 10**(185/192) rounds to 9.19); E96 and E48 are every
second and every fourth E192 value. Source of the values: IEC 60063:2015, as tabulated in
Wikipedia, "E series of preferred numbers".
"""

from __future__ import annotations

import math

import numpy as np

from creepcomp.errors import InputError

__all__ = ["SERIES", "TOLERANCE", "series_values", "values_in_range", "neighbours", "nearest"]

_E24 = (1.0, 1.1, 1.2, 1.3, 1.5, 1.6, 1.8, 2.0, 2.2, 2.4, 2.7, 3.0,
        3.3, 3.6, 3.9, 4.3, 4.7, 5.1, 5.6, 6.2, 6.8, 7.5, 8.2, 9.1)

_E192 = (
    1.00, 1.01, 1.02, 1.04, 1.05, 1.06, 1.07, 1.09, 1.10, 1.11, 1.13, 1.14,
    1.15, 1.17, 1.18, 1.20, 1.21, 1.23, 1.24, 1.26, 1.27, 1.29, 1.30, 1.32,
    1.33, 1.35, 1.37, 1.38, 1.40, 1.42, 1.43, 1.45, 1.47, 1.49, 1.50, 1.52,
    1.54, 1.56, 1.58, 1.60, 1.62, 1.64, 1.65, 1.67, 1.69, 1.72, 1.74, 1.76,
    1.78, 1.80, 1.82, 1.84, 1.87, 1.89, 1.91, 1.93, 1.96, 1.98, 2.00, 2.03,
    2.05, 2.08, 2.10, 2.13, 2.15, 2.18, 2.21, 2.23, 2.26, 2.29, 2.32, 2.34,
    2.37, 2.40, 2.43, 2.46, 2.49, 2.52, 2.55, 2.58, 2.61, 2.64, 2.67, 2.71,
    2.74, 2.77, 2.80, 2.84, 2.87, 2.91, 2.94, 2.98, 3.01, 3.05, 3.09, 3.12,
    3.16, 3.20, 3.24, 3.28, 3.32, 3.36, 3.40, 3.44, 3.48, 3.52, 3.57, 3.61,
    3.65, 3.70, 3.74, 3.79, 3.83, 3.88, 3.92, 3.97, 4.02, 4.07, 4.12, 4.17,
    4.22, 4.27, 4.32, 4.37, 4.42, 4.48, 4.53, 4.59, 4.64, 4.70, 4.75, 4.81,
    4.87, 4.93, 4.99, 5.05, 5.11, 5.17, 5.23, 5.30, 5.36, 5.42, 5.49, 5.56,
    5.62, 5.69, 5.76, 5.83, 5.90, 5.97, 6.04, 6.12, 6.19, 6.26, 6.34, 6.42,
    6.49, 6.57, 6.65, 6.73, 6.81, 6.90, 6.98, 7.06, 7.15, 7.23, 7.32, 7.41,
    7.50, 7.59, 7.68, 7.77, 7.87, 7.96, 8.06, 8.16, 8.25, 8.35, 8.45, 8.56,
    8.66, 8.76, 8.87, 8.98, 9.09, 9.20, 9.31, 9.42, 9.53, 9.65, 9.76, 9.88,
)

SERIES: dict[str, tuple[float, ...]] = {
    "E3": _E24[::8],
    "E6": _E24[::4],
    "E12": _E24[::2],
    "E24": _E24,
    "E48": _E192[::4],
    "E96": _E192[::2],
    "E192": _E192,
}

# Tolerance that each series is made for (IEC 60063), as a fraction.
TOLERANCE = {"E3": 0.4, "E6": 0.2, "E12": 0.1, "E24": 0.05, "E48": 0.02, "E96": 0.01, "E192": 0.005}


def series_values(name: str) -> tuple[float, ...]:
    """Mantissas of a series in [1, 10).

    Parameters
    ----------
    name : str
        Series name, ``E3`` ... ``E192`` (case-insensitive).

    Returns
    -------
    tuple of float

    Raises
    ------
    InputError
        For an unknown series name.
    """
    key = str(name).strip().upper()
    if key not in SERIES:
        raise InputError(f"unknown E-series '{name}': choose one of {', '.join(SERIES)}")
    return SERIES[key]


def values_in_range(name: str, low: float, high: float) -> np.ndarray:
    """All values of a series between ``low`` and ``high`` inclusive, ascending.

    Parameters
    ----------
    name : str
        Series name.
    low, high : float
        Range limits, positive, in SI units.

    Returns
    -------
    numpy.ndarray
    """
    if not (0 < low <= high) or not math.isfinite(high):
        raise InputError(f"range {low:g} .. {high:g} is not a positive, ordered range")
    mantissas = np.array(series_values(name))
    first, last = math.floor(math.log10(low)) - 1, math.ceil(math.log10(high)) + 1
    decades = 10.0 ** np.arange(first, last + 1)
    # round to the series' own precision so that 4.7e-6 is exactly what a user types
    values = np.array(sorted({float(f"{m * d:.3g}") for d in decades for m in mantissas}))
    tol = 1e-9
    return values[(values >= low * (1 - tol)) & (values <= high * (1 + tol))]


def neighbours(value: float, name: str, count: int = 2) -> np.ndarray:
    """The ``count`` series values below ``value`` and the ``count`` above it (or equal).

    Parameters
    ----------
    value : float
        Positive value to bracket.
    name : str
        Series name.
    count : int
        How many values on each side.

    Returns
    -------
    numpy.ndarray
        Ascending values: ``2 * count`` of them, plus ``value`` itself when it is a series
        value.
    """
    if not value > 0 or not math.isfinite(value):
        raise InputError(f"cannot snap {value!r}: a part value must be positive and finite")
    grid = values_in_range(name, value / 100.0, value * 100.0)
    idx = int(np.searchsorted(grid, value * (1 - 1e-12)))
    exact = idx < len(grid) and abs(grid[idx] / value - 1) < 1e-12
    below = grid[max(0, idx - count):idx]
    above = grid[idx:idx + count + (1 if exact else 0)]
    return np.concatenate([below, above])


def nearest(value: float, name: str) -> float:
    """The series value nearest to ``value`` on a logarithmic scale.

    Parameters
    ----------
    value : float
        Positive value.
    name : str
        Series name.

    Returns
    -------
    float
    """
    cands = neighbours(value, name, 1)
    return float(cands[np.argmin(np.abs(np.log(cands / value)))])
