"""Synthetic records of the soft sensors people build: force-sensing resistors, piezoresistive
polymer pads (Velostat type), carbon-black and liquid-metal stretch sensors, capacitive foam
taxels, and near-linear load cells for comparison.

Unlike :mod:`creepcomp.synth.sensor` (a signal linear in load plus small perturbations), these
records follow the physics of soft materials: a material strain that creeps by tens of percent
(either sign) under the load, a strongly nonlinear transfer from strain to reading, memory of the
load's history, and the faults of a real bench. Every record is built in this order:

1. a load program of presses, a step and hold, a staircase or random holds (ramps of a fraction
   of a second, never ideal steps), starting at a clock that is rarely zero;
2. the material's strain ``e``: the normalised load ``x = F / FS`` through a static input map
   (a power ``x ** a``), then linear creep in the strain domain (first-order lags, exact for a
   piecewise-linear input: :func:`creepcomp.lti.lag_states`; unloading with other retardation
   times than loading where drawn), then first-cycle (Mullins) softening: the strain grows with
   the largest strain seen so far and keeps a permanent set;
3. the transfer to the physical reading: an FSR's power law ``R0 (e / e0) ** -p`` plus a series
   resistance, in parallel with a leakage resistance (the reading falls over decades); a pad's
   saturating resistance (loaded 0.5-8 % of unloaded); a stretch sensor's resistance rising with
   strain (carbon black: gauge factor; liquid metal: ``(1 + e) ** 2``); a foam taxel's counts
   falling with the compression; a load cell's bridge, linear up to a small cubic term;
4. memory in the output domain: creep or overshoot at each change of the reading
   (``y = q + a (q - c(q))``, ``c`` a lag of ``q``: ``a > 0`` overshoots and relaxes, ``a < 0``
   approaches gradually), a release overshoot (the reading spikes after each release and
   decays over 2-5 s), a slow climb of the unloaded level over minutes of presses, and offset
   jumps (foam taxels);
5. the bench: white and coloured noise, a converter with a fixed input range (quantisation to
   its step, clipping at its rails, some records drawn to clip), and a reference load measured
   with noise of its own (0.1-0.5 % of the load range).

:func:`soft_record` draws every parameter from a seed (:func:`draw_soft`, widely varied) and
returns the record with the truth beside it: the drawn parameters, the true load, the strain
and the noise-free reading.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from creepcomp.errors import InputError
from creepcomp.io.records import Record
from creepcomp.lti import lag_states, varying_lag_states
from creepcomp.programs import LoadProgram
from creepcomp.synth.common import NoiseSpec, sample_noise

__all__ = ["SOFT_KINDS", "SOFT_PROGRAMS", "SOFT_CREEP_RANGE", "OUTPUT_CREEP_RANGE", "LOAD_CELL_CREEP_RANGE",
           "LOG_DOMAIN_FORMS", "MAX_SOFT_SAMPLES",
           "SoftSynthetic", "soft_program", "draw_soft", "simulate_soft", "soft_record",
           "soft_records"]

#: Kinds of sensor :func:`soft_record` makes.
SOFT_KINDS = ("fsr", "velostat", "carbon_stretch", "liquid_metal", "foam_taxel", "load_cell")
#: Load programs :func:`soft_program` makes: repeated short presses, one step held and released,
#: a staircase up and down, random holds at random levels.
SOFT_PROGRAMS = ("presses", "step", "staircase", "random_holds")
#: Range of the total strain-domain creep of the soft kinds (fraction of the instant strain,
#: either sign), and of the output-domain creep or overshoot (fraction of each change).
SOFT_CREEP_RANGE = (0.05, 0.45)
OUTPUT_CREEP_RANGE = (0.05, 0.40)
#: Range of a load cell's creep (fraction of the instant signal, either sign).
LOAD_CELL_CREEP_RANGE = (0.005, 0.02)
#: Transfers whose reading spans decades: their output-domain creep acts on the reading's
#: logarithm (a fraction of each change of ``log q``).
LOG_DOMAIN_FORMS = ("power_law", "saturating")
#: Samples at most in a drawn record (the rate is lowered to fit): keeps a benchmark quick.
MAX_SOFT_SAMPLES = 6000

_UNITS = {"fsr": ("N", "ohm"), "velostat": ("N", "ohm"), "carbon_stretch": ("N", "ohm"),
          "liquid_metal": ("N", "ohm"), "foam_taxel": ("bar", "counts"), "load_cell": ("N", "mV/V")}


@dataclass(frozen=True)
class SoftSynthetic:
    """A synthetic soft-sensor record and the truth behind it.

    Attributes
    ----------
    record : Record
        ``time``, ``load`` (the reference, with its own noise) and ``signal`` (the converter's
        reading).
    parameters : dict
        Every drawn parameter (see :func:`draw_soft`), plus what the simulation found:
        ``clipped_fraction`` (share of samples at a rail), ``creep_total`` (signed sum of the
        strain-domain creep amplitudes).
    program : LoadProgram
        The true load program.
    true_load : numpy.ndarray
        The true load at the sample times.
    strain : numpy.ndarray
        The material's normalised strain at the sample times (before the transfer).
    clean : numpy.ndarray
        The noise-free reading at the sample times, before the converter.
    """

    record: Record
    parameters: dict
    program: LoadProgram
    true_load: np.ndarray = field(repr=False)
    strain: np.ndarray = field(repr=False)
    clean: np.ndarray = field(repr=False)

    @property
    def kind(self) -> str:
        """The sensor's kind (one of :data:`SOFT_KINDS`)."""
        return self.parameters["kind"]


# --------------------------------------------------------------------------------------------
# Load programs
# --------------------------------------------------------------------------------------------

class _Program:
    """Breakpoints of a program being drawn; every change is a ramp of ``rise`` seconds."""

    def __init__(self, start: float, rise: float):
        self.times, self.loads, self.rise = [start], [0.0], rise

    def hold_until(self, t: float) -> None:
        if t > self.times[-1]:
            self.times.append(t)
            self.loads.append(self.loads[-1])

    def go_to(self, level: float, at: float) -> None:
        self.hold_until(at)
        self.times.append(self.times[-1] + self.rise)
        self.loads.append(float(level))


def soft_program(kind: str, duration: float, rng: np.random.Generator, full_scale: float,
                 start: float = 0.0) -> LoadProgram:
    """A random load program from rest, spanning ``duration`` seconds from ``start``.

    Parameters
    ----------
    kind : str
        One of :data:`SOFT_PROGRAMS`: ``presses`` (presses of 0.8-3 s at 25-100 % of full scale,
        1-6 s apart, in groups with rests between), ``step`` (one step to 50-100 %, held for
        30-50 % of the record, released), ``staircase`` (4-8 levels up, then down to rest) or
        ``random_holds`` (holds of 2-60 s at random levels, a third of them at rest).
    duration : float
        Seconds.
    rng : numpy.random.Generator
    full_scale : float
        Largest load (load units).
    start : float
        Time of the first breakpoint (s).

    Returns
    -------
    LoadProgram

    Examples
    --------
    >>> import numpy as np
    >>> from creepcomp.synth.soft import soft_program
    >>> p = soft_program("presses", 60.0, np.random.default_rng(1), 20.0, start=1000.0)
    >>> p.start, p.end
    (1000.0, 1060.0)
    >>> 0.0 <= min(p.loads) and max(p.loads) <= 20.0
    True
    """
    if kind not in SOFT_PROGRAMS:
        raise InputError(f"load program '{kind}': use one of {', '.join(SOFT_PROGRAMS)}")
    end = start + duration
    b = _Program(start, float(rng.uniform(0.05, 0.25)))
    t = start + rng.uniform(0.03, 0.08) * duration
    if kind == "presses":
        while t < end - 4.0:
            for _ in range(int(rng.integers(3, 12))):
                on = rng.uniform(0.8, 3.0)
                if t + on + 2 * b.rise >= end - 1.0:
                    break
                b.go_to(rng.uniform(0.25, 1.0) * full_scale, t)
                b.go_to(0.0, b.times[-1] + on)
                t = b.times[-1] + rng.uniform(1.0, 6.0)
            t += rng.uniform(5.0, 30.0)
    elif kind == "step":
        b.go_to(rng.uniform(0.5, 1.0) * full_scale, t)
        b.go_to(0.0, t + rng.uniform(0.3, 0.5) * duration)
    elif kind == "staircase":
        n = int(rng.integers(4, 9))
        up = np.sort(rng.uniform(0.15, 1.0, n // 2 + 1))
        levels = list(up) + list(np.sort(rng.uniform(0.0, up[-1], n - len(up)))[::-1]) + [0.0]
        hold = (end - t) / (len(levels) + 0.5)
        for k, level in enumerate(levels):
            b.go_to(level * full_scale, t + k * hold)
    else:
        while t < end - 2.0:
            level = 0.0 if rng.uniform() < 1 / 3 else rng.uniform(0.1, 1.0) * full_scale
            b.go_to(level, t)
            t = b.times[-1] + rng.uniform(2.0, 60.0)
        b.go_to(0.0, min(t, end - 2 * b.rise))
    b.hold_until(end)
    return LoadProgram(tuple(b.times), tuple(b.loads), f"{kind} program")


# --------------------------------------------------------------------------------------------
# Parameters
# --------------------------------------------------------------------------------------------

def _log_uniform(rng, lo, hi) -> float:
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


def _creep_terms(rng, total_range, tau_ranges, sign) -> tuple[tuple, tuple]:
    """Creep amplitudes (summing to a draw from ``total_range`` times ``sign``) and their
    retardation times, one term per range of ``tau_ranges``."""
    total = sign * rng.uniform(*total_range)
    shares = rng.dirichlet(np.ones(len(tau_ranges)))
    taus = tuple(_log_uniform(rng, *r) for r in tau_ranges)
    return tuple(float(total * s) for s in shares), taus


def draw_soft(kind: str, rng: np.random.Generator, max_samples: int = MAX_SOFT_SAMPLES) -> dict:
    """Draw a sensor of a kind, its bench and its load program's settings.

    The ranges follow what such sensors do (an FSR's power-law exponent 0.7-1.5 over a leakage
    of 50 kOhm-2 MOhm; a pad's loaded reading at 0.5-8 % of the unloaded one; a foam taxel at
    200-240 counts at rest falling by 15-60 counts, noise 1/20 of the range; a load cell's
    creep of 0.5-2 %); every kind but the load cell creeps by :data:`SOFT_CREEP_RANGE` in the
    strain domain (positive in 80 % of the records), and half of them (every carbon-black
    sensor) also in the output domain.

    Parameters
    ----------
    kind : str
        One of :data:`SOFT_KINDS`.
    rng : numpy.random.Generator
    max_samples : int
        The sample rate is lowered so that the record holds at most this many samples.

    Returns
    -------
    dict
        The parameters :func:`simulate_soft` takes.

    Examples
    --------
    >>> import numpy as np
    >>> from creepcomp.synth.soft import draw_soft
    >>> p = draw_soft("velostat", np.random.default_rng(3))
    >>> p["kind"], p["transfer"]["form"]
    ('velostat', 'saturating')
    """
    if kind not in SOFT_KINDS:
        raise InputError(f"sensor kind '{kind}': use one of {', '.join(SOFT_KINDS)}")
    program = str(rng.choice(SOFT_PROGRAMS, p=[0.35, 0.15, 0.2, 0.3]))
    duration = {"presses": (90, 300), "step": (200, 900), "staircase": (300, 1200),
                "random_holds": (200, 900)}[program]
    duration = float(rng.uniform(*duration))
    rate = _log_uniform(rng, 5.0, 100.0)
    rate = min(rate, (max_samples - 1) / duration)
    clock = rng.uniform()
    start = 0.0 if clock < 0.2 else (float(rng.uniform(100.0, 2e5)) if clock < 0.75
                                      else float(rng.uniform(1.70e9, 1.80e9)))
    soft = kind != "load_cell"
    sign = 1.0 if rng.uniform() < 0.8 else -1.0
    if soft:
        beta, tau = _creep_terms(rng, SOFT_CREEP_RANGE, [(0.5, 10.0), (20.0, 300.0)][:int(rng.integers(1, 3))],
                                 sign)
    else:
        beta, tau = _creep_terms(rng, LOAD_CELL_CREEP_RANGE, [(5.0, 200.0)], sign)
    output_creep = None
    if kind == "carbon_stretch" or (soft and rng.uniform() < 0.5):
        a = rng.uniform(*OUTPUT_CREEP_RANGE) * (0.25 if kind == "fsr" else 1.0)
        output_creep = {"amplitude": float(a if kind == "carbon_stretch" or rng.uniform() < 0.5 else -a),
                        "tau": _log_uniform(rng, 0.5, 60.0)}
    p = {"kind": kind, "program": program, "duration": duration, "rate": float(rate), "start": start,
         "full_scale": 1.0, "input_power": 1.0, "beta": beta, "tau": tau,
         "unloading_tau_factor": 1.0, "softening": 0.0, "permanent_set": 0.0,
         "output_creep": output_creep, "release_spike": None, "climb": None, "offset_jumps": (),
         "noise": 0.0, "coloured_noise": 0.0, "reference_noise": float(rng.uniform(0.001, 0.005)),
         "readout": "linear", "bits": 16, "clip": None}
    if soft:
        p["input_power"] = float(rng.uniform(0.5, 1.0))
        if rng.uniform() < 0.6:
            p["unloading_tau_factor"] = _log_uniform(rng, 0.3, 3.0)
        if rng.uniform() < 0.5:
            p["softening"] = float(rng.uniform(0.02, 0.2))
            # an FSR's power law makes a small set a large change of its unloaded reading
            p["permanent_set"] = float(rng.uniform(0.001, 0.01) if kind == "fsr" else rng.uniform(0.01, 0.08))
    if kind == "fsr":
        p["full_scale"] = _log_uniform(rng, 5.0, 50.0)
        p["transfer"] = {"form": "power_law", "r0": _log_uniform(rng, 300.0, 5000.0),
                         "exponent": float(rng.uniform(0.7, 1.5)), "strain_floor": 1e-3,
                         "series": _log_uniform(rng, 10.0, 200.0), "parallel": _log_uniform(rng, 5e4, 2e6)}
    elif kind == "velostat":
        p["full_scale"] = _log_uniform(rng, 0.5, 40.0)
        p["transfer"] = {"form": "saturating", "unloaded": _log_uniform(rng, 500.0, 20000.0),
                         "loaded_ratio": _log_uniform(rng, 0.005, 0.08),
                         "half_strain": float(rng.uniform(0.05, 0.3)), "steepness": float(rng.uniform(1.0, 2.5))}
        p["release_spike"] = {"amplitude": float(rng.uniform(0.2, 1.0)), "tau": float(rng.uniform(0.7, 1.7))}
        if rng.uniform() < 0.7:
            # 10-50 % over a minute or two of presses (the lag of the load: a few tenths)
            p["climb"] = {"amplitude": float(rng.uniform(0.5, 2.5)), "tau": float(rng.uniform(30.0, 120.0))}
    elif kind == "carbon_stretch":
        p["full_scale"] = _log_uniform(rng, 2.0, 20.0)
        p["transfer"] = {"form": "gauge", "r0": _log_uniform(rng, 1e3, 1e5),
                         "gauge": float(rng.uniform(2.0, 20.0)), "quadratic": float(rng.uniform(0.0, 10.0))}
        # the unloaded resistance up to ~10 % higher after the first cycle
        p["softening"], p["permanent_set"] = float(rng.uniform(0.02, 0.15)), float(rng.uniform(0.01, 0.05))
    elif kind == "liquid_metal":
        p["full_scale"] = _log_uniform(rng, 1.0, 10.0)
        p["transfer"] = {"form": "geometric", "r0": _log_uniform(rng, 0.5, 5.0),
                         "stretch": float(rng.uniform(0.3, 2.0))}
    elif kind == "foam_taxel":
        p["full_scale"] = float(rng.uniform(1.0, 4.0))
        span = float(rng.uniform(15.0, 60.0))
        p["transfer"] = {"form": "foam", "rest": float(rng.uniform(200.0, 240.0)), "span": span,
                         "densification": float(rng.uniform(0.3, 2.0))}
        p["offset_jumps"] = tuple((float(rng.uniform(0.15, 0.95)), float(rng.choice([-1, 1]) * rng.uniform(0.05, 0.3) * span))
                                  for _ in range(int(rng.integers(0, 3))))
        p["bits"] = 8
    else:
        p["full_scale"] = _log_uniform(rng, 10.0, 1000.0)
        p["transfer"] = {"form": "bridge", "sensitivity": float(rng.uniform(1.0, 3.0)),
                         "zero": float(rng.uniform(-0.1, 0.1)), "cubic": float(rng.uniform(-0.003, 0.003))}
        p["bits"] = 24
    # noise relative to the reading's range; a foam taxel's is ~1/20 of it
    p["noise"] = (float(rng.uniform(0.03, 0.07)) if kind == "foam_taxel"
                  else _log_uniform(rng, 1e-4, 5e-3))
    if rng.uniform() < 0.4:
        p["coloured_noise"] = p["noise"] * float(rng.uniform(0.3, 1.0))
    p["correlation_time"] = float(rng.uniform(2.0, 20.0)) / p["rate"]       # 2-20 samples
    if kind in ("fsr", "velostat"):
        p["readout"] = str(rng.choice(["ohmmeter", "divider"]))
        p["digits"], p["bits"] = int(rng.integers(3, 6)), int(rng.integers(10, 17))
    if kind != "foam_taxel" and rng.uniform() < 0.3:
        p["clip"] = {"side": str(rng.choice(["high", "low"])), "inside": float(rng.uniform(0.01, 0.08))}
    return p


# --------------------------------------------------------------------------------------------
# Simulation
# --------------------------------------------------------------------------------------------

def _transfer(form: dict, e: np.ndarray) -> np.ndarray:
    """The reading's physical quantity for a normalised strain ``e`` (>= 0 at rest)."""
    f = form["form"]
    e = np.maximum(e, 0.0)
    if f == "power_law":
        r = form["series"] + form["r0"] * (e + form["strain_floor"]) ** -form["exponent"]
        return r * form["parallel"] / (r + form["parallel"])
    if f == "saturating":
        # falls from ``unloaded`` towards ``loaded_ratio`` of it, halfway at ``half_strain``
        r0, low = form["unloaded"], form["unloaded"] * form["loaded_ratio"]
        return low + (r0 - low) / (1.0 + (e / form["half_strain"]) ** form["steepness"])
    if f == "gauge":
        return form["r0"] * (1.0 + form["gauge"] * 0.1 * e + form["quadratic"] * 0.01 * e ** 2)
    if f == "geometric":
        return form["r0"] * (1.0 + form["stretch"] * e) ** 2
    if f == "foam":
        return form["rest"] - form["span"] * (1.0 + form["densification"]) * e / (1.0 + form["densification"] * e)
    if f == "bridge":
        return form["zero"] + form["sensitivity"] * (e + form["cubic"] * (4 * e ** 3 - 3 * e))
    raise InputError(f"transfer form '{f}' is unknown")


def _grid(program: LoadProgram, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The sample times with every breakpoint inside the record (the piecewise-linear load is
    then exact between grid points), and the indices of the samples in it."""
    bt = np.array(program.times)
    grid = np.union1d(t, bt[(bt > t[0]) & (bt < t[-1])])
    return grid, np.searchsorted(grid, t)


def _strain(p: dict, grid: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The material's strain on the grid: input map, creep (other retardation times where the
    creep state falls, if drawn), first-cycle softening with a permanent set."""
    h = x ** p["input_power"]
    taus = np.array(p["tau"], float)
    init = np.full(len(taus), h[0])
    lags = lag_states(grid, h, taus, initial=init)
    if p["unloading_tau_factor"] != 1.0:
        falling = h[1:, None] < lags[:-1]
        varying = taus[None, :] * np.where(falling, p["unloading_tau_factor"], 1.0)
        lags = varying_lag_states(grid, h, varying, initial=init)
    e = h + lags @ np.array(p["beta"], float)
    peak = np.maximum.accumulate(e)
    return e * (1.0 + p["softening"] * peak) + p["permanent_set"] * peak


def _output_memory(p: dict, grid: np.ndarray, x: np.ndarray, q: np.ndarray) -> np.ndarray:
    """The output domain's creep or overshoot, the release overshoot, the slow climb of the
    unloaded level and offset jumps, applied to the reading ``q`` on the grid."""
    y = q
    oc = p["output_creep"]
    if oc:
        # a resistance over decades creeps in proportion (on its logarithm): it stays positive
        log = p["transfer"]["form"] in LOG_DOMAIN_FORMS
        v = np.log(q) if log else q
        c = lag_states(grid, v, [oc["tau"]], initial=np.full(1, v[0]))[:, 0]
        v = v + oc["amplitude"] * (v - c)
        y = np.exp(v) if log else v
    ro = p["release_spike"]
    if ro:
        c = lag_states(grid, x, [ro["tau"]], initial=np.full(1, x[0]))[:, 0]
        y = y * (1.0 + ro["amplitude"] * np.maximum(c - x, 0.0))
    cl = p["climb"]
    if cl:
        c = lag_states(grid, x, [cl["tau"]], initial=np.full(1, x[0]))[:, 0]
        y = y * (1.0 + cl["amplitude"] * c)
    if p["offset_jumps"]:
        rel = (grid - grid[0]) / max(grid[-1] - grid[0], 1e-12)
        for at, size in p["offset_jumps"]:
            y = y + np.where(rel >= at, size, 0.0)
    return y


def _noise(p: dict, t: np.ndarray, scale: float, rng: np.random.Generator) -> np.ndarray:
    """White plus coloured noise of ``p``'s sizes times ``scale`` at the times ``t``."""
    spec = NoiseSpec(white=p["noise"] * scale, coloured=p["coloured_noise"] * scale,
                     correlation_time=p["correlation_time"])
    return sample_noise(t, spec, rng)


def _read(p: dict, t: np.ndarray, clean: np.ndarray,
          rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, dict]:
    """The bench's reading of ``clean``: the signal, which samples sit at a rail, and the
    converter's settings.

    ``ohmmeter``: an autoranging meter, its noise a fraction of the reading, rounded to
    ``digits`` significant digits, reading its range's top above it. ``divider``: the
    resistance in a voltage divider (``Rm / (Rm + R)`` of the reference, ``Rm`` the geometric
    mean of the reading's extremes) read by a converter in counts. ``linear``: a converter of a
    fixed input range around the reading (0-255 counts for a foam taxel); the signal is its
    counts in the reading's units. A drawn ``clip`` puts a rail inside the reading's range."""
    clip = p["clip"]
    if p["readout"] == "ohmmeter":
        top = float(np.max(clean)) * (1 - clip["inside"] if clip and clip["side"] == "high" else 10.0)
        noisy = clean * (1.0 + _noise(p, t, 1.0, rng))
        step = 10.0 ** (np.floor(np.log10(np.abs(noisy))) - (p["digits"] - 1))
        signal = np.minimum(np.round(noisy / step) * step, top)
        return signal, signal >= top, {"range_top": top, "digits": p["digits"]}
    y = clean
    if p["readout"] == "divider":
        rm = float(np.sqrt(np.min(clean) * np.max(clean)))
        y = rm / (rm + clean)
    if p["kind"] == "foam_taxel":
        lo, hi = 0.0, 255.0
    else:
        lo, hi = float(np.min(y)), float(np.max(y))
        span = max(hi - lo, 1e-12 * max(abs(hi), 1.0))
        if p["readout"] == "divider":
            lo, hi = 0.0, 1.0
        else:
            lo, hi = lo - 0.05 * span, hi + 0.05 * span
        if clip and clip["side"] == "high":
            hi = float(np.max(y)) - clip["inside"] * span
        elif clip:
            lo = float(np.min(y)) + clip["inside"] * span
    full = 2 ** p["bits"] - 1
    lsb = (hi - lo) / full
    counts = np.clip(np.round((y + _noise(p, t, max(float(np.ptp(y)), lsb), rng) - lo) / lsb), 0, full)
    signal = counts if p["readout"] == "divider" else lo + counts * lsb
    return signal, (counts == 0) | (counts == full), {"converter_low": lo, "converter_high": hi, "lsb": lsb}


def simulate_soft(p: dict, seed: int = 0) -> SoftSynthetic:
    """Simulate a record of the sensor and bench ``p`` (:func:`draw_soft`'s form).

    Parameters
    ----------
    p : dict
        Parameters, e.g. from :func:`draw_soft`, changed where a test needs it.
    seed : int
        Seed of the program's draw and the noise.

    Returns
    -------
    SoftSynthetic

    Examples
    --------
    An FSR: its resistance (before the readout) spans more than a decade over the record:

    >>> import numpy as np
    >>> from creepcomp.synth.soft import draw_soft, simulate_soft
    >>> p = draw_soft("fsr", np.random.default_rng(4))
    >>> s = simulate_soft(p, seed=4)
    >>> bool(s.clean.max() / s.clean.min() > 10)
    True
    """
    rng = np.random.default_rng([seed, 1])
    fs = p["full_scale"]
    program = soft_program(p["program"], p["duration"], rng, fs, p["start"])
    n = int(p["duration"] * p["rate"]) + 1
    t = p["start"] + np.arange(n) / p["rate"]
    grid, at = _grid(program, t)
    x_grid = program.sample(grid) / fs
    e_grid = _strain(p, grid, x_grid)
    y_grid = _output_memory(p, grid, x_grid, _transfer(p["transfer"], e_grid))
    clean = y_grid[at]
    signal, at_rail, converter = _read(p, t, clean, rng)
    true_load = program.sample(t)
    ref_noise = rng.normal(0.0, p["reference_noise"] * max(float(np.ptp(true_load)), 1e-12), n)
    load_units = _UNITS[p["kind"]][0]
    signal_units = "counts" if p["readout"] == "divider" else _UNITS[p["kind"]][1]
    parameters = dict(p, **converter, seed=seed,
                      clipped_fraction=float(np.mean(at_rail)), creep_total=float(sum(p["beta"])))
    metadata = {"units.load": load_units, "units.signal": signal_units,
                "synth.kind": p["kind"], "synth.program": p["program"], "synth.seed": str(seed)}
    record = Record(t, true_load + ref_noise, signal, metadata=metadata,
                    source=f"synthetic {p['kind']} record (seed {seed})")
    return SoftSynthetic(record, parameters, program, true_load, e_grid[at], clean)


def soft_record(kind: str, seed: int, max_samples: int = MAX_SOFT_SAMPLES, **changes) -> SoftSynthetic:
    """A record of a randomly drawn sensor of a kind (:func:`draw_soft` then
    :func:`simulate_soft`), the same for the same seed.

    Parameters
    ----------
    kind : str
        One of :data:`SOFT_KINDS`.
    seed : int
    max_samples : int
        Most samples in the record.
    **changes
        Parameters to set instead of drawing them (e.g. ``program="step"``, ``clip=None``).

    Returns
    -------
    SoftSynthetic

    Examples
    --------
    >>> from creepcomp.synth.soft import soft_record
    >>> s = soft_record("foam_taxel", 7)
    >>> s.record.unit("signal"), s.kind
    ('counts', 'foam_taxel')
    """
    p = draw_soft(kind, np.random.default_rng([seed, 0]), max_samples)
    unknown = set(changes) - set(p)
    if unknown:
        raise InputError(f"soft_record: no parameter named {', '.join(sorted(unknown))}")
    p.update(changes)
    return simulate_soft(p, seed)


def soft_records(count: int, first_seed: int = 0, max_samples: int = MAX_SOFT_SAMPLES) -> list[SoftSynthetic]:
    """``count`` records over every kind in turn (kind ``k % len(SOFT_KINDS)`` for seed
    ``first_seed + k``).

    Examples
    --------
    >>> from creepcomp.synth.soft import SOFT_KINDS, soft_records
    >>> [s.kind for s in soft_records(2, max_samples=500)] == list(SOFT_KINDS[:2])
    True
    """
    return [soft_record(SOFT_KINDS[k % len(SOFT_KINDS)], first_seed + k, max_samples)
            for k in range(count)]
