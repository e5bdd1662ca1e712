"""The load-cell creep test of OIML R 60: its limits per accuracy class, and the test run on a
sensor, a digital corrector or an analog network at several temperatures.

The rules (OIML R 60-1:2017, *Metrological regulation for load cells*; R 60-2, the tests; R 60-3,
the test report):

- accuracy classes A, B, C, D, each with a range of the maximum number of load cell
  verification intervals ``n_max`` (R 60-1, 5.1.2: A at least 50 000; B 5 000 to 100 000;
  C 500 to 10 000; D 100 to 1 000); the designation ``C3`` is class C with ``n_max`` = 3 000;
- the maximum permissible error at a load ``m`` (in verification intervals ``v``), R 60-1,
  5.3.2, Table 4: ``p_LC`` times 0.5 v, 1.0 v or 1.5 v, the steps at 50 000 v and 200 000 v
  (class A), 5 000 v and 20 000 v (B), 500 v and 2 000 v (C), 50 v and 200 v (D);
- creep (R 60-1, 5.5.1): at 90-100 % of the maximum load the reading may change from the
  initial reading by at most 0.7 |MPE| over 30 min, and by at most 0.15 |MPE| from 20 to
  30 min, with the MPE taken with the apportioning factor ``p_LC = 0.7`` whatever the maker
  declares;
- the minimum dead load output return DR (R 60-1, 5.5.2; R 60-3, 2.1.5.4-5): the minimum-load
  reading after the creep test, taken after the unloading time of R 60-2 Table 1, may differ
  from the one before by at most 0.5 v.

With the load at full scale ``E_max = n_max v``, every limit is a fraction of the full-scale
output: for C3, ``0.7 x 0.7 x 1.5 v / (3000 v) = 2.45e-4`` (0.0245 % of FS).

The test program (:class:`CreepTestProgram`): the load ramps linearly from 0 to full scale over the
loading time (R 60-2, 2.8.3.2 and Table 1: about 5 s for a 10 kg step, 20 s for 1 500 kg;
default here 10 s), and the initial reading is taken when it ends; it is held for 30 min
(readings at 20 and 30 min after the initial one), then ramps back to 0 over the same time,
when the DR reading is taken; the unloaded return is followed for 30 min more (``dr_30min``,
for the curve and for information: R 60 judges the reading at the end of the unloading).
The sensor starts relaxed (unloaded for long).

The responses are exact: every target is a sum of first-order lags (the sensor's creep, its
cascade with the network, :func:`creepcomp.lti.cascade_lags`), and a lag's response to the
trapezoid load is written in closed form (:func:`trapezoid_lag_response`); the digital
corrector runs on the sensor's exact output sampled at a stated rate.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Mapping, Sequence

import numpy as np

from creepcomp.display import Shown, data_frame
from creepcomp.errors import InputError
from creepcomp.lti import cascade_lags
from creepcomp.model import CreepModel
from creepcomp.network import Cell, Network

__all__ = ["ACCURACY_CLASSES", "CREEP_APPORTIONING", "CREEP_FRACTION", "CREEP_20_30_FRACTION",
           "DR_INTERVALS", "C3_CREEP_LIMIT", "AccuracyClass", "CreepLimits", "creep_limits",
           "parse_class", "CreepTestProgram", "Readings", "trapezoid_lag_response", "lag_readings",
           "CreepTestResult", "model_test", "digital_test", "design_at", "design_test",
           "variant_readings", "creep_test_yield", "DIGITAL_RATE"]

#: Apportioning factor of the load cell's share of the instrument's error used for creep
#: (R 60-1, 5.5.1: 0.7 whatever the maker declares).
CREEP_APPORTIONING = 0.7
#: Creep over 30 min: at most this many times |MPE| (R 60-1, 5.5.1).
CREEP_FRACTION = 0.7
#: Creep from 20 to 30 min: at most this many times |MPE| (R 60-1, 5.5.1).
CREEP_20_30_FRACTION = 0.15
#: Minimum dead load output return: at most this many verification intervals (R 60-1, 5.5.2).
DR_INTERVALS = 0.5
#: Sampling rate of the digital corrector in the test (Hz).
DIGITAL_RATE = 10.0


@dataclass(frozen=True)
class AccuracyClass:
    """An accuracy class of R 60: the loads (in v) where the MPE steps from 0.5 v to 1.0 v and
    from 1.0 v to 1.5 v (R 60-1, Table 4), the range of ``n_max`` and the default used here."""

    name: str
    steps: tuple[float, float]
    n_max_range: tuple[int, int | None]
    default_n_max: int

    def mpe(self, load: float, apportioning: float = CREEP_APPORTIONING) -> float:
        """|MPE| at ``load`` verification intervals, in v: ``p_LC`` x 0.5, 1.0 or 1.5."""
        base = 0.5 if load <= self.steps[0] else 1.0 if load <= self.steps[1] else 1.5
        return apportioning * base


ACCURACY_CLASSES: dict[str, AccuracyClass] = {
    "A": AccuracyClass("A", (50_000, 200_000), (50_000, None), 50_000),
    "B": AccuracyClass("B", (5_000, 20_000), (5_000, 100_000), 10_000),
    "C": AccuracyClass("C", (500, 2_000), (500, 10_000), 3_000),
    "D": AccuracyClass("D", (50, 200), (100, 1_000), 1_000),
}


@dataclass(frozen=True)
class CreepLimits:
    """The creep-test limits of a class, as fractions of the full-scale output."""

    accuracy_class: str
    n_max: int
    mpe_v: float
    creep_30min: float
    creep_20_30min: float
    dr: float
    derivation: dict

    @property
    def interval(self) -> float:
        """One verification interval ``v`` as a fraction of full scale, ``1 / n_max``."""
        return 1.0 / self.n_max

    @property
    def label(self) -> str:
        """The class designation, e.g. ``C3`` (``n_max`` in thousands when it is a whole
        number of them)."""
        k = self.n_max / 1000
        return f"{self.accuracy_class}{k:g}" if k == int(k) else f"{self.accuracy_class} (n_max {self.n_max})"

    def to_dict(self) -> dict:
        """JSON form: the limits (fractions of FS) with their derivation."""
        return {"creep_30min": self.creep_30min, "creep_20_30min": self.creep_20_30min,
                "dr": self.dr, "mpe_v": self.mpe_v, "apportioning": CREEP_APPORTIONING,
                "interval_fs": self.interval, "derivation": dict(self.derivation)}


def _decimal(x: float) -> float:
    """A product of decimal factors to 12 significant digits (0.7 x 1.05 / 3000 is 2.45e-4,
    not the float product's 2.4499999999999994e-4)."""
    return float(f"{x:.12g}")


def creep_limits(accuracy_class: str, n_max: int | None = None) -> CreepLimits:
    """The limits of the R 60 creep test for a class, as fractions of the full-scale output.

    Parameters
    ----------
    accuracy_class : str
        ``A``, ``B``, ``C`` or ``D``.
    n_max : int, optional
        Number of verification intervals (default: the class's default, 3 000 for C).

    Returns
    -------
    CreepLimits

    Examples
    --------
    >>> from creepcomp.verify.creep_test import creep_limits
    >>> round(creep_limits("C", 3000).creep_30min, 9)
    0.000245
    """
    key = str(accuracy_class).strip().upper()
    if key not in ACCURACY_CLASSES:
        raise InputError(f"accuracy class '{accuracy_class}': use A, B, C or D (e.g. C3: class C, 3000 intervals)")
    cls = ACCURACY_CLASSES[key]
    n = cls.default_n_max if n_max is None else int(n_max)
    low, high = cls.n_max_range
    if n < low or (high is not None and n > high):
        span = f"at least {low}" if high is None else f"{low} to {high}"
        raise InputError(f"n_max = {n}: class {key} has {span} verification intervals (OIML R 60-1, 5.1.2)")
    mpe = _decimal(cls.mpe(n))
    base = _decimal(mpe / CREEP_APPORTIONING)
    creep = _decimal(CREEP_FRACTION * mpe / n)
    late = _decimal(CREEP_20_30_FRACTION * mpe / n)
    dr = _decimal(DR_INTERVALS / n)
    derivation = {
        "mpe": f"|MPE| at E_max = {n} v (class {key}, R 60-1 Table 4): p_LC x {base:g} v = "
               f"{CREEP_APPORTIONING:g} x {base:g} v = {mpe:.4g} v",
        "creep_30min": f"0.7 x p_LC x {base:g} v / (n_max v) = 0.7 x {CREEP_APPORTIONING:g} x {base:g} / "
                       f"{n} = {creep:.4g} of FS ({100 * creep:.4g} %)",
        "creep_20_30min": f"0.15 x p_LC x {base:g} v / (n_max v) = 0.15 x {CREEP_APPORTIONING:g} x {base:g} / "
                          f"{n} = {late:.4g} of FS ({100 * late:.4g} %)",
        "dr": f"0.5 v / (n_max v) = 0.5 / {n} = {dr:.4g} of FS ({100 * dr:.4g} %)",
    }
    return CreepLimits(key, n, mpe, creep, late, dr, derivation)


def parse_class(text: str, n_max: int | None = None, option: str | None = None) -> CreepLimits:
    """Limits from a designation such as ``C3`` (class C, 3 000 intervals) or ``C`` (the class's
    default); ``n_max`` overrides the number the designation gives. ``option`` (e.g.
    ``--creep-test``) is the command-line option that gave ``text``: an error names it."""
    where = f"accuracy class '{text}'" if option is None else f"{option} {text}"
    m = re.fullmatch(r"\s*([A-Da-d])\s*(\d+(?:\.\d+)?)?\s*", str(text))
    if not m:
        raise InputError(f"{where}: expected an accuracy class and thousands of intervals, e.g. C3 "
                         "(class C, 3000 intervals), or a class alone (A, B, C, D)")
    given = None if m.group(2) is None else int(round(float(m.group(2)) * 1000))
    try:
        return creep_limits(m.group(1), n_max if n_max is not None else given)
    except InputError as exc:
        if option is None:
            raise
        raise InputError(f"{where}: {exc}") from None


#: The OIML R 60 class C3 creep limit (fraction of full scale), used as ``fleet --spec``'s default.
C3_CREEP_LIMIT = creep_limits("C", 3000).creep_30min


@dataclass(frozen=True)
class CreepTestProgram:
    """The load program of the test: ramp up over ``loading_time``, hold ``hold`` after the
    initial reading, ramp down, follow the return for ``recovery`` (all seconds)."""

    loading_time: float = 10.0
    hold: float = 1800.0
    recovery: float = 1800.0
    late_reading: float = 1200.0

    def __post_init__(self):
        if not (self.loading_time > 0 and math.isfinite(self.loading_time)):
            raise InputError(f"loading time {self.loading_time!r} s: must be positive")

    @property
    def unload_start(self) -> float:
        """When the load starts to fall (s from the start of loading)."""
        return self.loading_time + self.hold

    @property
    def dr_time(self) -> float:
        """When the DR reading is taken: at the end of the unloading (s)."""
        return self.unload_start + self.loading_time

    def load(self, t) -> np.ndarray:
        """The load (fraction of full scale) at times ``t`` (s)."""
        t = np.asarray(t, dtype=float)
        L = self.loading_time
        return np.clip(t / L, 0, 1) - np.clip((t - self.unload_start) / L, 0, 1)

    def hold_times(self, points: int = 120) -> np.ndarray:
        """Times after the initial reading (s) at which the hold is read: log-spaced near the
        start (fast network poles), uniform beyond, 20 and 30 min included."""
        grid = np.concatenate([[0.0], np.geomspace(1e-3, self.hold, points // 2),
                               np.linspace(0.0, self.hold, points // 2 + 1), [self.late_reading]])
        return np.unique(grid)

    def recovery_times(self, points: int = 121) -> np.ndarray:
        """Times after the DR reading (s) at which the return is followed."""
        return np.unique(np.concatenate([[0.0], np.geomspace(1e-2, self.recovery, points // 2),
                                         np.linspace(0.0, self.recovery, points // 2 + 1)]))

    def to_dict(self) -> dict:
        """JSON form (seconds)."""
        return {"loading_time": self.loading_time, "hold": self.hold, "recovery": self.recovery,
                "late_reading": self.late_reading, "dr_read_after_unloading": 0.0, "start": "relaxed"}


def trapezoid_lag_response(q, program: CreepTestProgram, t) -> np.ndarray:
    """Output of first-order lags ``1 / (1 + s q)`` (relaxed) driven by the test's load, exact.

    A ramp from 0 to 1 over ``L`` then held gives ``t/L - (q/L)(1 - e^{-t/q})`` while it ramps and
    ``1 - (q/L) e^{-(t-L)/q} (1 - e^{-L/q})`` after; the unloading subtracts the same, delayed.

    Parameters
    ----------
    q : array_like, shape (B, M)
        Time constants (s).
    program : CreepTestProgram
    t : array_like, shape (T,) or (B, T)
        Times from the start of loading (s): one grid for all, or one per unit.

    Returns
    -------
    numpy.ndarray, shape (B, M, T)
    """
    q = np.asarray(q, dtype=float)[..., None]
    t = np.asarray(t, dtype=float)
    L = program.loading_time

    def rising(s):
        return s / L + (q / L) * np.expm1(-np.clip(s, 0, None) / q)

    def held(s):
        return 1.0 + (q / L) * np.exp(-np.clip(s - L, 0, None) / q) * np.expm1(-L / q)

    def ramp_held(s):
        if s.ndim == 1:
            # one grid for all: each formula only on its own times (most are after the ramp)
            out = np.zeros(q.shape[:-1] + s.shape)
            up, after = (s > 0) & (s <= L), s > L
            if up.any():
                out[..., up] = rising(s[up])
            if after.any():
                out[..., after] = held(s[after])
            return out
        s = s[:, None, :]
        return np.where(s <= 0, 0.0, np.where(s <= L, rising(s), held(s)))

    return ramp_held(t) - ramp_held(t - program.unload_start)


@dataclass(frozen=True)
class Readings:
    """The test's figures for a batch of units (fractions of the full-scale output)."""

    creep_30min: np.ndarray
    creep_20_30min: np.ndarray
    dr: np.ndarray
    dr_30min: np.ndarray

    def passes(self, limits: CreepLimits) -> np.ndarray:
        """Whether each unit passes all three limits."""
        return ((self.creep_30min <= limits.creep_30min) & (self.creep_20_30min <= limits.creep_20_30min)
                & (self.dr <= limits.dr))


def _lag_output(rel, q, program: CreepTestProgram, t) -> np.ndarray:
    """Normalised output ``u + sum rel_m lag_m[u]`` (B, T) of targets in sum-of-lags form, at
    times ``t`` (T,) or (B, T)."""
    load = program.load(t)
    return np.atleast_2d(load) + np.einsum("bm,bmt->bt", rel, trapezoid_lag_response(q, program, t))


#: Points of each zoom of the largest change between grid neighbours (two zooms: the grid's
#: spacing there shrinks 64-fold, the largest change's error about 4000-fold).
ZOOM_POINTS = 17


def _largest_change(rel, q, program: CreepTestProgram, times, change) -> np.ndarray:
    """Largest |change from the initial reading| over the hold: the grid's largest, refined by
    zooming twice into the interval around it."""
    k = np.argmax(np.abs(change), axis=1)
    rows = np.arange(len(change))
    best = np.abs(change[rows, k])
    lo, hi = times[np.maximum(k - 1, 0)], times[np.minimum(k + 1, len(times) - 1)]
    start = _lag_output(rel, q, program, np.full((len(rel), 1), times[0]))[:, 0]
    for _ in range(2):
        fine = lo[:, None] + (hi - lo)[:, None] * np.linspace(0.0, 1.0, ZOOM_POINTS)[None, :]
        v = np.abs(_lag_output(rel, q, program, fine) - start[:, None])
        j = np.argmax(v, axis=1)
        best = np.maximum(best, v[rows, j])
        step = (hi - lo) / (ZOOM_POINTS - 1)
        lo, hi = fine[rows, j] - step, fine[rows, j] + step
        lo = np.maximum(lo, times[0])
        hi = np.minimum(hi, times[-1])
    return best


def lag_readings(rel, q, program: CreepTestProgram, chunk: int = 4096) -> Readings:
    """The R 60 readings of targets whose output is ``1 + sum_m rel_m / (1 + s q_m)`` times the
    ideal (the sensor: ``rel = beta``, ``q = tau``; sensor and network: the cascade's lags over
    its high-frequency gain), vectorised over units.

    Parameters
    ----------
    rel, q : array_like, shape (B, M)
        Relative gains and time constants (s) of the lags.
    program : CreepTestProgram
    chunk : int
        Units evaluated at once (bounds memory: ``chunk x M x`` about 300 times).

    Returns
    -------
    Readings
    """
    rel = np.atleast_2d(np.asarray(rel, dtype=float))
    q = np.atleast_2d(np.asarray(q, dtype=float))
    hold = program.loading_time + program.hold_times()
    late = np.searchsorted(hold, program.loading_time + program.late_reading)
    times = np.concatenate([hold, [program.dr_time, program.dr_time + program.recovery]])
    out = [np.empty(len(rel)) for _ in range(4)]
    for lo in range(0, len(rel), chunk):
        r, qq = rel[lo:lo + chunk], q[lo:lo + chunk]
        y = _lag_output(r, qq, program, times)
        change = y[:, :len(hold)] - y[:, :1]
        out[0][lo:lo + chunk] = _largest_change(r, qq, program, hold, change)
        out[1][lo:lo + chunk] = np.abs(change[:, len(hold) - 1] - change[:, late])
        out[2][lo:lo + chunk] = np.abs(y[:, -2])
        out[3][lo:lo + chunk] = np.abs(y[:, -1])
    return Readings(*out)


@dataclass(eq=False)
class CreepTestResult(Shown):
    """The creep test of one target at several temperatures.

    ``rows`` hold, per temperature, the readings (fractions of FS), ``pass`` and the margins
    (limit minus reading, fractions of FS); ``curves`` the change from the initial reading
    over the hold and the return after unloading, for the plot.
    """

    target: str
    limits: CreepLimits
    program: CreepTestProgram
    rows: list
    curves: dict
    notes: list = field(default_factory=list)
    variants: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        """Whether every temperature passes."""
        return all(r["pass"] for r in self.rows)

    def __repr__(self) -> str:
        temps = ", ".join(f"{r['temperature']:g}" for r in self.rows)
        return (f"<CreepTestResult {self.target}, OIML R 60 class {self.limits.label}: "
                f"{'pass' if self.passed else 'FAIL'} at {temps} °C>")

    def to_pandas(self):
        """One row per temperature: readings and margins (fractions of FS) and the verdict."""
        keys = ("temperature", "creep_30min", "creep_20_30min", "dr", "dr_30min", "pass")
        return data_frame({k: [r[k] for r in self.rows] for k in keys})

    def to_dict(self) -> dict:
        """``creep-test --json``: ``class``, ``n_max``, ``limits``, ``temperatures``, ``pass``."""
        out = {"target": self.target, "class": self.limits.label, "accuracy_class": self.limits.accuracy_class,
               "n_max": self.limits.n_max, "limits": self.limits.to_dict(), "program": self.program.to_dict(),
               "temperatures": self.rows, "pass": self.passed}
        out.update(self.settings)
        for key, rows in self.variants.items():
            out[key] = {"temperatures": rows, "pass": all(r["pass"] for r in rows)}
        if self.notes:
            out["notes"] = list(self.notes)
        return out


def _row(temperature: float, creep: float, late: float, dr: float, dr_30: float, limits: CreepLimits) -> dict:
    margin = {"creep_30min": limits.creep_30min - creep, "creep_20_30min": limits.creep_20_30min - late,
              "dr": limits.dr - dr}
    return {"temperature": float(temperature), "creep_30min": float(creep), "creep_20_30min": float(late),
            "dr": float(dr), "dr_30min": float(dr_30), "pass": bool(min(margin.values()) >= 0),
            "margin": {k: float(v) for k, v in margin.items()}}


def _curve(y_hold, y_return, program: CreepTestProgram) -> dict:
    return {"hold_time": program.hold_times(), "change": y_hold - y_hold[0],
            "return_time": program.recovery_times(), "return": y_return}


def _lag_test(target: str, lags: dict, limits: CreepLimits, program: CreepTestProgram) -> CreepTestResult:
    """The test of targets given as ``{temperature: (rel, q)}`` in sum-of-lags form."""
    rows, curves = [], {}
    hold = program.loading_time + program.hold_times()
    back = program.dr_time + program.recovery_times()
    for temp, (rel, q) in lags.items():
        rel, q = np.atleast_2d(rel), np.atleast_2d(q)
        r = lag_readings(rel, q, program)
        rows.append(_row(temp, r.creep_30min[0], r.creep_20_30min[0], r.dr[0], r.dr_30min[0], limits))
        curves[temp] = _curve(_lag_output(rel, q, program, hold)[0], _lag_output(rel, q, program, back)[0],
                              program)
    return CreepTestResult(target, limits, program, rows, curves)


def _law_note(model: CreepModel) -> list:
    if model.temperature is None:
        return ["the model has no temperature block: the sensor is the same at every temperature"]
    return []


def model_test(model: CreepModel, temperatures: Sequence[float], limits: CreepLimits,
               program: CreepTestProgram | None = None) -> CreepTestResult:
    """The creep test of the uncorrected sensor: its output, the model at each temperature."""
    program = program or CreepTestProgram()
    lags = {float(T): (np.array([m.beta]), np.array([m.tau]))
            for T, m in ((T, model.at_temperature(T)) for T in temperatures)}
    result = _lag_test("sensor", lags, limits, program)
    result.notes += _law_note(model)
    return result


#: Most samples of one run of the digital creep test: the corrector's arrays of that length
#: (a few tens of bytes a sample) stay within a few hundred MB.
MAX_DIGITAL_SAMPLES = 2_000_000


def check_digital_rate(rate: float, program: CreepTestProgram) -> None:
    """Refuse a sampling rate whose test would not fit in memory, or whose samples miss the
    program's readings (a sample interval longer than the loading ramp).

    Raises
    ------
    InputError
        Naming the rate and the range that works for ``program``.
    """
    end = program.dr_time + program.recovery
    low, high = 1.0 / program.loading_time, MAX_DIGITAL_SAMPLES / end
    if not (math.isfinite(rate) and low <= rate <= high):
        raise InputError(f"rate {rate:g} Hz: the digital creep test samples its {end:g} s at "
                         f"{low:g} Hz (a sample per loading ramp) to {high:.4g} Hz "
                         f"({MAX_DIGITAL_SAMPLES:,} samples)")


def _digital_readings(sensor: CreepModel, corrector_model: CreepModel, program: CreepTestProgram,
                      rate: float) -> tuple[dict, np.ndarray, np.ndarray]:
    """Readings of the digital corrector (``corrector_model``) on ``sensor``'s output sampled at
    ``rate`` (sample times on the program's breakpoints)."""
    from creepcomp.digital.correctors import compensate

    dt = 1.0 / rate
    end = program.dr_time + program.recovery
    n = int(round(end / dt))
    t = np.arange(n + 1) * dt
    signal = sensor.response(t, program.load(t), hold="linear")
    out = compensate(t, signal, corrector_model, method="subtractive", hold="zero")
    y = (out - corrector_model.offset) / corrector_model.gain
    i0 = int(round(program.loading_time / dt))
    i_late = int(round((program.loading_time + program.late_reading) / dt))
    i_end = int(round((program.loading_time + program.hold) / dt))
    i_dr = int(round(program.dr_time / dt))
    change = y[i0:i_end + 1] - y[i0]
    figures = {"creep_30min": float(np.abs(change).max()),
               "creep_20_30min": float(abs(y[i_end] - y[i_late])),
               "dr": float(abs(y[i_dr] - y[0])), "dr_30min": float(abs(y[-1] - y[0]))}
    return figures, (t[i0:i_end + 1] - t[i0], change), (t[i_dr:] - t[i_dr], y[i_dr:] - y[0])


def digital_test(model: CreepModel, temperatures: Sequence[float], limits: CreepLimits,
                 program: CreepTestProgram | None = None, rate: float = DIGITAL_RATE) -> CreepTestResult:
    """The creep test of the digital corrector (:func:`creepcomp.digital.correctors.compensate`,
    subtractive, zero hold) on the sensor's output sampled at ``rate`` Hz.

    The corrector that knows the temperature uses the model at each temperature (its residual
    comes from sampling only); the variant ``corrector_at_reference`` keeps the model at its
    reference temperature (what a corrector without a temperature input does).
    """
    program = program or CreepTestProgram()
    check_digital_rate(rate, program)
    reference = model.temperature.reference if model.temperature is not None else None
    fixed = model.at_temperature(reference) if reference is not None else model
    rows, fixed_rows, curves = [], [], {}
    for T in temperatures:
        sensor = model.at_temperature(T)
        f, hold, back = _digital_readings(sensor, sensor, program, rate)
        rows.append(_row(T, f["creep_30min"], f["creep_20_30min"], f["dr"], f["dr_30min"], limits))
        curves[float(T)] = {"hold_time": hold[0], "change": hold[1], "return_time": back[0], "return": back[1]}
        if reference is None:
            continue
        g, _, _ = _digital_readings(sensor, fixed, program, rate)
        fixed_rows.append(_row(T, g["creep_30min"], g["creep_20_30min"], g["dr"], g["dr_30min"], limits))
    # without a temperature law the corrector at the reference temperature is the same one
    variants = {"corrector_at_reference": fixed_rows} if reference is not None else {}
    result = CreepTestResult("digital", limits, program, rows, curves, variants=variants,
                             settings={"rate": rate, "method": "subtractive", "hold": "zero",
                                       "reference_temperature": reference})
    result.notes += _law_note(model)
    return result


def design_at(design, temperature: float):
    """The sensor and the network of a design at ``temperature`` (°C): the creep model at T,
    every part at its value at T (:func:`creepcomp.analog.parts.network_at`), and each cell
    capacitor's insulation leakage at T (the plan's dielectric,
    ``insulation_time(T) / C(T)`` across it).

    Returns
    -------
    model : CreepModel
    network : Network
    """
    from creepcomp.analog.parts import DIELECTRICS, network_at, plan_of

    plan = plan_of(design)
    if design.network.topology == "active":
        from creepcomp.analog.active import stage_over

        return design.model.at_temperature(temperature), stage_over(design.network, plan, temperature)
    net = network_at(design.network, plan, temperature)
    insulation = DIELECTRICS[plan.capacitor].insulation_time(temperature)
    cells = tuple(Cell(c.R, c.C, insulation / c.C if c.C > 0 else None, c.absorption_R, c.absorption_C)
                  if c.leakage is None else c for c in net.cells)
    net = Network(cells, net.R2, net.shunt, net.source_resistance, net.load_resistance)
    return design.model.at_temperature(temperature), net


def _cascade_form(model: CreepModel, network: Network) -> tuple[np.ndarray, np.ndarray]:
    """``H G / (H G)(inf) = 1 + sum rel / (1 + s q)`` of one sensor and network."""
    h = network.lag_expansion()
    D, R, q = cascade_lags(1.0, np.array([model.beta]), np.array([model.tau]),
                           h.direct, np.array([h.gains]), np.array([h.taus]))
    return R / D[:, None], q


def design_test(design, temperatures: Sequence[float], limits: CreepLimits,
                program: CreepTestProgram | None = None) -> CreepTestResult:
    """The creep test of an analog design: the sensor at each temperature followed by its
    network at that temperature (:func:`design_at`)."""
    from creepcomp.analog.parts import plan_of

    program = program or CreepTestProgram()
    lags = {float(T): _cascade_form(*design_at(design, T)) for T in temperatures}
    result = _lag_test("design", lags, limits, program)
    plan = plan_of(design)
    result.settings = {"tracking": plan.tracking, "capacitor": plan.capacitor,
                       "topology": design.network.topology}
    result.notes += _law_note(design.model)
    return result


def variant_readings(design, values: Mapping[str, np.ndarray], temperature: float,
                     dielectric: str | None, n: int, program: CreepTestProgram | None = None) -> Readings:
    """R 60 readings of Monte Carlo variants of a design at one temperature, vectorised.

    ``values`` are the drawn factors (:func:`creepcomp.verify.tolerances.draw`): part values
    at the catalogue temperature and the sensor's ``beta[k]``/``tau[k]`` at its reference. Each
    is moved to ``temperature`` by the nominal's change (parts: their temperature coefficients
    or thermistor law, :func:`creepcomp.analog.parts.network_at`; sensor: its temperature law),
    so a part keeps its drawn deviation; leakage and absorption follow ``dielectric`` as in
    :func:`creepcomp.verify.variants.residual_lags`.
    """
    from creepcomp.analog.parts import network_at, plan_of
    from creepcomp.io.jsonfiles import Design
    from creepcomp.verify.variants import residual_lags

    program = program or CreepTestProgram()
    model_t = design.model.at_temperature(temperature)
    net_t = network_at(design.network, plan_of(design), temperature)
    moved = dict(values)
    for (label, _, nominal), (_, _, at_t) in zip(design.network.parts(), net_t.parts()):
        if label in values:
            moved[label] = np.asarray(values[label]) * (at_t / nominal)
    for k in range(design.model.n_terms):
        for key, old, new in ((f"beta[{k}]", design.model.beta[k], model_t.beta[k]),
                              (f"tau[{k}]", design.model.tau[k], model_t.tau[k])):
            if key in values:
                moved[key] = np.asarray(values[key]) * (new / old)
    rel, q = residual_lags(Design(model_t, net_t, design.extra), moved, dielectric, temperature, n)
    return lag_readings(rel, q, program)


def creep_test_yield(design, values: Mapping[str, np.ndarray], temperatures: Sequence[float],
                     limits: CreepLimits, dielectric: str | None = None,
                     program: CreepTestProgram | None = None) -> dict:
    """Yield of Monte Carlo variants against the R 60 creep test.

    Returns
    -------
    dict
        ``class``, ``n_max``, ``limits``, ``n``, per temperature the yield and the readings'
        99th percentiles (fractions of FS), and ``yield``: the fraction of units passing at
        every temperature, with its standard error.
    """
    n = len(next(iter(values.values()))) if values else 1
    every = np.ones(n, dtype=bool)
    rows = []
    for T in temperatures:
        r = variant_readings(design, values, float(T), dielectric, n, program)
        ok = r.passes(limits)
        every &= ok
        rows.append({"temperature": float(T), "yield": float(ok.mean()),
                     "p99": {k: float(np.percentile(getattr(r, k), 99))
                             for k in ("creep_30min", "creep_20_30min", "dr")}})
    y = float(every.mean())
    return {"class": limits.label, "n_max": limits.n_max, "limits": limits.to_dict(), "n": n,
            "temperatures": rows, "yield": y,
            "yield_standard_error": math.sqrt(max(y * (1 - y), 1.0 / n) / n)}
