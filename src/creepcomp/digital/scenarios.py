"""The paper's digital-correction scenarios on synthetic records, and how each method fares.

- Loading and unloading steps (the paper's figs. 3-5): a staircase held long enough for creep
  to show, the load changing at sample instants (so it is held between samples, the case in
  which eq. 7 is exact).
- The triangular sweep between -FS and +FS (fig. 6): the load ramps between samples; its
  hysteresis is read from the last period, as :func:`creepcomp.analog.quality.sweep_hysteresis`
  defines it.
- A long run (months of samples, ``t / tau`` up to 10^6): where the paper's printed form
  overflows and the recursive correctors stay exact.

Raw signals come from :meth:`LoadProgram.response` (exact for any sampling).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from creepcomp.digital import paper_methods
from creepcomp.digital.correctors import CreepError, compensate, creep_error, saturation_factor
from creepcomp.model import CreepModel
from creepcomp.programs import LoadProgram, staircase, triangle_sweep
from creepcomp.analog.quality import default_sweep_period, sweep_branches
from creepcomp.io.records import Record

__all__ = ["paper_model", "SyntheticRecord", "step_record", "sweep_record", "sweep_hysteresis",
           "Outcome", "outcomes", "LongRun", "long_run"]


def paper_model() -> CreepModel:
    """Three creep terms, ``beta0`` = 3 %: a sensor like the paper's accelerometer.

    The paper corrected its sensor with three exponentials (figs. 4-5) and reports about 3 %
    of creep with retardation times of 20-100 s; it does not list the fitted terms, so these
    (0.6 % at 6 s, 1.5 % at 45 s, 0.9 % at 150 s) are illustrative.
    """
    return CreepModel((0.006, 0.015, 0.009), (6.0, 45.0, 150.0))


@dataclass(frozen=True)
class SyntheticRecord:
    """A synthetic record and how it was made.

    Attributes
    ----------
    name : str
    time, load, signal : numpy.ndarray
        Samples; ``signal`` is the exact raw response of ``model`` to ``program``.
    model : CreepModel
    program : LoadProgram
    hold : {"zero", "linear"}
        How the load moves between samples (the correction that is exact for it).
    quarter_points : int or None
        Samples per quarter period, for sweeps.
    """

    name: str
    time: np.ndarray
    load: np.ndarray
    signal: np.ndarray
    model: CreepModel
    program: LoadProgram
    hold: str
    quarter_points: int | None = None

    def to_record(self) -> Record:
        """As a :class:`~creepcomp.io.records.Record` (to write with ``write_record``)."""
        return Record(self.time, self.load, self.signal, metadata={"description": self.name},
                      source=self.name)


def _synthesise(name, model, program, time, hold, quarter_points=None) -> SyntheticRecord:
    signal = model.offset + model.gain * program.response(model.lag_expansion(), time)
    return SyntheticRecord(name, time, program.sample(time), signal, model, program, hold,
                           quarter_points)


def step_record(model: CreepModel | None = None, levels=(1.0, 2.0, 3.0, 2.0, 1.0, 0.0),
                hold_time: float = 300.0, rate: float = 5.0, lead: float = 60.0) -> SyntheticRecord:
    """Loading and unloading steps (figs. 3-5), sampled at ``rate`` Hz, steps on samples.

    Parameters
    ----------
    model : CreepModel, optional
        Default :func:`paper_model`.
    levels : sequence of float
        Load after each step (from 0).
    hold_time : float
        Seconds each level is held.
    rate : float
        Sampling rate (Hz).
    lead : float
        Unloaded time before the first step (s).
    """
    model = paper_model() if model is None else model
    program = staircase(levels, hold_time, start=lead)
    n = int(round((lead + len(levels) * hold_time) * rate)) + 1
    time = np.arange(n) / rate
    return _synthesise("loading and unloading steps", model, program, time, "zero")


def sweep_record(model: CreepModel | None = None, period: float | None = None, cycles: int = 10,
                 quarter_points: int = 500, full_scale: float = 1.0) -> SyntheticRecord:
    """Triangular sweep between -FS and +FS (fig. 6), breakpoints on samples.

    The period defaults to :func:`creepcomp.analog.quality.default_sweep_period`; after ``cycles``
    periods the last one is in periodic steady state (to ``exp(-(cycles - 1) period / tau)``).
    """
    model = paper_model() if model is None else model
    period = default_sweep_period(model) if period is None else float(period)
    program = triangle_sweep(period, cycles, full_scale)
    n = 4 * quarter_points * cycles + 1
    time = np.arange(n) / (4 * quarter_points) * period
    return _synthesise(f"triangular sweep ±{full_scale:g}, period {period:.4g} s", model, program,
                       time, "linear", quarter_points)


def sweep_hysteresis(record: SyntheticRecord, values, method: str = "subtractive") -> float:
    """Largest gap between the up and down branches of the last sweep period, as a fraction
    of the method's full-scale output (see :func:`creepcomp.analog.quality.sweep_branches`)."""
    m = record.quarter_points
    model = record.model
    full = abs(model.gain) * saturation_factor(model, method) * float(np.max(np.abs(record.load)))
    period = (np.asarray(values)[-(4 * m + 1):] - model.offset) / full
    _, up, down = sweep_branches(period, m)
    return float(np.max(np.abs(down - up)))


@dataclass(frozen=True)
class Outcome:
    """One way of correcting (or not) a synthetic record.

    Attributes
    ----------
    label : str
    method : str
        The reference it is judged against (``subtractive``: instantaneous signal,
        ``supplemental``: saturated signal).
    values : numpy.ndarray
        The output, signal units.
    error : CreepError
    hysteresis : float or None
        Sweep hysteresis (fraction of full-scale output), for sweeps.
    """

    label: str
    method: str
    values: np.ndarray
    error: CreepError
    hysteresis: float | None = None


def outcomes(record: SyntheticRecord, literal: bool = True) -> list[Outcome]:
    """The raw signal and every correction of a record, judged against the load.

    Production correctors (:func:`creepcomp.digital.correctors.compensate`) with the hold that matches the
    record (exact), and for ramping loads also with the paper's held-load assumption
    (``--hold zero``); with ``literal``, the paper's printed eqs. 9 and 13 (O(N^2)).
    """
    model, t, x = record.model, record.time, record.signal
    runs = [("raw signal", "subtractive", x)]
    holds = [record.hold] + (["zero"] if record.hold != "zero" else [])
    for hold in holds:
        for method in ("subtractive", "supplemental"):
            runs.append((f"{method}, --hold {hold}", method,
                         compensate(t, x, model, method, hold=hold)))
    if literal:
        raw = x - model.offset
        runs.append(("paper eq. 9", "subtractive",
                     model.offset + paper_methods.subtractive(t, raw, model.beta, model.tau)))
        runs.append(("paper eq. 13 (as printed)", "supplemental",
                     model.offset + paper_methods.supplemental(t, raw, model.beta, model.tau)))
    result = []
    for label, method, values in runs:
        err = creep_error(t, values, record.load, model, method)
        hyst = sweep_hysteresis(record, values, method) if record.quarter_points else None
        result.append(Outcome(label, method, values, err, hyst))
    return result


@dataclass(frozen=True)
class LongRun:
    """Production correctors against the paper's printed form over a very long record.

    Attributes
    ----------
    samples : int
        Samples in the long record.
    elapsed_over_tau : float
        Its length over the shortest retardation time.
    error_subtractive, error_supplemental : float
        Peak creep error of the production correctors (fraction of full scale).
    literal_samples : int
        Samples of the shorter record given to the paper's form (it is O(N^2)).
    literal_first_nonfinite : float or None
        ``t / tau_min`` at the first inf/nan of the paper's eq. 9 (None if it stayed finite).
    literal_warning : str or None
        What numpy said.
    """

    samples: int
    elapsed_over_tau: float
    error_subtractive: float
    error_supplemental: float
    literal_samples: int
    literal_first_nonfinite: float | None
    literal_warning: str | None


def long_run(model: CreepModel | None = None, samples: int = 10 ** 6, span: float = 1e6,
             literal_span: float = 1000.0, literal_samples: int = 2000, seed: int = 0) -> LongRun:
    """Correct a record of ``samples`` samples reaching ``t / tau_min = span``.

    The load is a random staircase (a new level every 50 samples, held between samples);
    the paper's eq. 9 is run on a shorter record reaching ``literal_span``.
    """
    model = paper_model() if model is None else model
    tau_min = min(model.tau)
    rng = np.random.default_rng(seed)
    time = np.arange(samples) * (span * tau_min / (samples - 1))
    load = np.repeat(rng.uniform(-1.0, 1.0, -(-samples // 50)), 50)[:samples]
    signal = model.response(time, load, hold="zero")
    errors = [creep_error(time, compensate(time, signal, model, method, initial="relaxed"), load,
                          model, method).peak_fraction for method in ("subtractive", "supplemental")]
    short = np.arange(literal_samples) * (literal_span * tau_min / (literal_samples - 1))
    short_load = load[:literal_samples]
    raw = model.response(short, short_load, hold="zero") - model.offset
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        literal = paper_methods.subtractive(short, raw, model.beta, model.tau)
    bad = np.flatnonzero(~np.isfinite(literal))
    first = float(short[bad[0]] / tau_min) if bad.size else None
    message = str(caught[0].message) if caught else None
    return LongRun(samples, float(time[-1] / tau_min), errors[0], errors[1], literal_samples,
                   first, message)
