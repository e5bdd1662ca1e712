"""Synthetic sensor records with known hidden effects, for examples, tests, the demo and benchmarks.

A record is simulated on a fine time grid that holds every breakpoint of the load program
(so steps and ramps are exact), independently of how the fit discretises: the hidden effects
are written here in their own forms (some deliberately not the fitted ones: a saturating
static nonlinearity, a power-law nonlinear creep, an Arrhenius temperature law), then sampled
at the record's (uniform, jittered or gappy) times and given noise of several kinds. Everything
random takes a seed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from creepcomp.errors import InputError
from creepcomp.io.records import Record, write_record
from creepcomp.lti import lag_states, varying_lag_states
from creepcomp.programs import LoadProgram
from creepcomp.synth.common import DETECTABLE_Z, NoiseSpec, heldout_z, sample_noise, scaled_noise

__all__ = ["EFFECTS", "FORMS", "DATA_PROBLEMS", "NO_TEMPLATE", "PROGRAMS", "ALL_PROGRAMS", "PROGRAMS_FOR", "Spec", "Synthetic", "make_program", "sample_times",
           "temperature_profile", "simulate_signal", "detectability", "generate", "random_hidden",
           "random_spec", "random_record", "DEMO_SPEC", "write_demo_record", "reported_truth", "play_loop",
           "VISIBLE_RATIO"]

#: Hidden effects the generator can put in a record.
EFFECTS = ("extra_retardation", "viscous_flow", "nonlinear_creep", "asymmetric_recovery",
           "thermal_drift", "thermal_retardation", "static_nonlinearity", "time_offset",
           "transition_overshoot", "rate_independent_hysteresis", "mullins_softening")

#: Formulations of each hidden effect (``form`` of :func:`random_spec`); the first is closest to
#: the fitted template, the others are what a physicist would equally write down.
FORMS = {
    "extra_retardation": ("exponential", "spectrum"),      # one term; a log-normal band of terms
    "viscous_flow": ("linear", "norton"),                  # Newtonian dashpot; power-law (Norton) flow
    "nonlinear_creep": ("linear", "power", "time"),        # amplitude ~ load; ~ |load|^m; load-dependent time
    "asymmetric_recovery": ("state", "direction"),         # switched by the state's magnitude; by the load's direction
    "thermal_drift": ("linear", "lagged"),                 # offset ~ T; ~ T through the sensor's thermal lag
    "thermal_retardation": ("arrhenius", "wlf"),           # shift factor Arrhenius; Williams-Landel-Ferry
    "static_nonlinearity": ("poly", "tanh"),               # polynomial; saturating
    "time_offset": ("delay", "average"),                   # a delay; a boxcar-averaging ADC (group delay)
    "transition_overshoot": ("exponential", "stretched"),  # exp(-t/tau); exp(-(t/tau)^b)
    "rate_independent_hysteresis": ("play", "distributed"),  # one play on the output; several on the load, before creep
    "mullins_softening": ("chord", "damage"),              # linear reloading curve; tanh-shaped damage
    "data_problem": ("jump", "clipping", "out_of_step", "quantisation"),
}

#: Kinds of ``data_problem`` the generator makes (its forms).
DATA_PROBLEMS = FORMS["data_problem"]

#: Records with effects no template describes (diagnosis must say ``unexplained``): a
#: multiplicative sensitivity drift over time, a periodic disturbance, creep whose retardation
#: time ages with the time since the last load change.
NO_TEMPLATE = ("sensitivity_drift", "periodic_disturbance", "aging_retardation")

#: No-template records keep their misfit visible: the part of their signature the baseline
#: cannot absorb has at least this RMS relative to the noise (the noise is scaled down).
VISIBLE_RATIO = 3.0

#: Kinds of load program :func:`make_program` draws for any effect.
PROGRAMS = ("step", "staircase", "sweep", "mixture", "random")
#: Every kind :func:`make_program` makes: also cycles to rising levels (first-cycle effects).
ALL_PROGRAMS = PROGRAMS + ("cycles",)


@dataclass(frozen=True)
class Spec:
    """Everything that defines a synthetic record (see :func:`generate`)."""

    hidden: dict = field(default_factory=dict)
    beta: tuple = (0.03,)
    tau: tuple = (45.0,)
    gain: float = 1.0
    offset: float = 0.0
    rate: float = 10.0
    duration: float = 1800.0
    program: str = "staircase"
    full_scale: float = 1.0
    jitter: float = 0.0
    gaps: int = 0
    start_loaded: bool = False
    start: float = 0.0
    noise: NoiseSpec = NoiseSpec()
    temperature: bool = False
    seed: int = 0
    detectable_z: float = 0.0      # see DETECTABLE_Z


@dataclass(frozen=True)
class Synthetic:
    """A synthetic record and what is hidden in it."""

    record: Record
    spec: Spec
    program: LoadProgram

    @property
    def hidden(self) -> dict:
        """Hidden effects and their parameters."""
        return self.spec.hidden


# --------------------------------------------------------------------------------------------
# Load programs
# --------------------------------------------------------------------------------------------

def make_program(kind: str, duration: float, rng: np.random.Generator, full_scale: float = 1.0,
                 start_loaded: bool = False, tau: float = 45.0, start: float = 0.0,
                 unload: bool = False, one_sided: bool = False) -> LoadProgram:
    """A random load program of a kind: ``step``, ``staircase``, ``sweep``, ``mixture``,
    ``random`` or ``cycles`` (to rising levels, each with a partial reload), spanning
    ``duration`` from ``start``.

    With ``start_loaded`` the load is already at a level when the program starts (and has been
    for a random time, so creep is part-way), otherwise it starts at zero. ``unload``: a
    ``step`` program always unloads again (otherwise it does so in 60 % of the cases).
    ``one_sided``: sweeps from 0 to full scale (otherwise half of them are -FS ... +FS, under
    which flow and other odd effects average out).
    """
    fs = full_scale
    t_end = start + duration
    pre = rng.uniform(0.3, 3.0) * tau if start_loaded else 0.0
    first = rng.uniform(0.4, 1.0) * fs if start_loaded else 0.0
    times, loads = [start - pre], [first if start_loaded else 0.0]
    if start_loaded:
        times.insert(0, start - pre)
        loads.insert(0, 0.0)
    t = start + rng.uniform(0.03, 0.1) * duration

    def hold(level, until):
        times.append(until)
        loads.append(level)

    def jump(level, at):
        if times[-1] < at:
            times.append(at)
            loads.append(loads[-1])
        times.append(at)
        loads.append(level)

    if kind == "step":
        level = rng.choice([-1, 1]) * rng.uniform(0.5, 1.0) * fs
        jump(level, t)
        if unload or rng.uniform() < 0.6:
            off = t + rng.uniform(0.4, 0.6) * (t_end - t)
            hold(level, off)
            jump(0.0, off)
    elif kind == "staircase":
        n = int(rng.integers(4, 9))
        up = list(np.sort(rng.uniform(0.15, 1.0, n // 2 + 1)) * fs)
        levels = up + list(rng.uniform(0, 1, n - len(up)) * fs) + [0.0]
        if rng.uniform() < 0.3:
            levels = [-v for v in levels]
        step = (t_end - t) / (len(levels) + 0.5)
        for k, level in enumerate(levels):
            if k:
                hold(loads[-1], t + k * step)
            jump(level, t + k * step)
    elif kind == "sweep":
        period = rng.uniform(0.5, 6.0) * tau
        low = -fs if rng.uniform() < 0.5 and not one_sided else 0.0
        tt = t
        hold(loads[-1], tt)
        phase_up = True
        while tt < t_end:
            tt = min(tt + period / 2, t_end)
            hold(fs if phase_up else low, tt)
            phase_up = not phase_up
    elif kind in ("mixture", "random"):
        while t < t_end:
            seg = rng.choice(["step", "ramp", "sweep", "hold"] if kind == "mixture" else ["step", "ramp"])
            length = rng.uniform(0.05, 0.25) * duration
            level = rng.uniform(-0.3, 1.0) * fs
            if seg == "step":
                jump(level, t)
                hold(level, min(t + length, t_end))
            elif seg == "ramp":
                hold(level, min(t + rng.uniform(0.2, 1.0) * length, t_end))
                hold(level, min(t + length, t_end))
            elif seg == "sweep":
                period = rng.uniform(0.3, 3.0) * tau
                tt, k = t, 0
                while tt < min(t + length, t_end):
                    tt = min(tt + period / 2, t_end)
                    hold(fs * (0.9 if k % 2 == 0 else -0.2), tt)
                    k += 1
            else:
                hold(loads[-1], min(t + length, t_end))
            t = times[-1] if times[-1] > t else t + length
    elif kind == "cycles":
        # load cycles to ever higher levels, each with a partial reload (first-cycle effects)
        n = int(rng.integers(3, 6))
        peaks = np.sort(rng.uniform(0.25, 1.0, n)) * fs * (1 if rng.uniform() < 0.7 else -1)
        peaks[-1] = np.sign(peaks[-1]) * fs * rng.uniform(0.85, 1.0)
        step = (t_end - t) / (4 * n + 0.5)
        k = 0
        for peak in peaks:
            for level in (peak, 0.0, peak * rng.uniform(0.4, 0.8), 0.0):
                if k:
                    hold(loads[-1], t + k * step)
                jump(float(level), t + k * step)
                k += 1
    else:
        raise InputError(f"load program '{kind}': use one of {', '.join(ALL_PROGRAMS)}")
    if times[-1] < t_end:
        hold(loads[-1], t_end)
    return LoadProgram(tuple(times), tuple(loads), f"{kind} program")


def sample_times(duration: float, rate: float, rng: np.random.Generator, jitter: float = 0.0,
                 gaps: int = 0, start: float = 0.0) -> np.ndarray:
    """Sample times at ``rate`` Hz, jittered by ``jitter`` (fraction of a step), with ``gaps``
    random missing stretches."""
    dt = 1.0 / rate
    n = int(duration * rate) + 1
    t = start + np.arange(n) * dt
    if jitter > 0:
        t = t + rng.uniform(-jitter, jitter, n) * dt
        t[0], t[-1] = start, start + (n - 1) * dt
        t = np.sort(t)
        t = t[np.concatenate([[True], np.diff(t) > 1e-6 * dt])]
    keep = np.ones(len(t), bool)
    for _ in range(gaps):
        length = rng.uniform(0.005, 0.02) * duration
        at = rng.uniform(0.2, 0.9) * duration + start
        keep &= ~((t > at) & (t < at + length))
    return t[keep]


# --------------------------------------------------------------------------------------------
# Simulation on a fine grid
# --------------------------------------------------------------------------------------------

def temperature_profile(t_first: float, t_last: float, rng: np.random.Generator):
    """A temperature history (deg C) over a record: a slow sine plus a ramp, not proportional
    to any load program. Returns the function of time and its mean."""
    mean, amplitude = rng.uniform(15, 35), rng.uniform(2, 6)
    cycles, phase, ramp = rng.uniform(0.6, 2.2), rng.uniform(0, 2 * np.pi), rng.uniform(-4, 4)

    def temperature(x):
        rel = (np.asarray(x, float) - t_first) / max(t_last - t_first, 1e-9)
        return mean + amplitude * np.sin(2 * np.pi * cycles * rel + phase) + ramp * (rel - 0.5)

    return temperature, float(mean)


def _fine_grid(program: LoadProgram, t_samples: np.ndarray, spacing: float, delay: float):
    """Sample times, delayed sample times and breakpoints exactly, filled in with a uniform grid
    (uniform points next to an exact one are dropped, never the exact one)."""
    t_lo = min(program.start, t_samples[0] - max(delay, 0.0))
    t_hi = t_samples[-1]
    bt = np.array(program.times)
    exact = np.unique(np.concatenate([bt[(bt >= t_lo) & (bt <= t_hi)], t_samples,
                                      (t_samples - delay)[t_samples - delay >= t_lo]]))
    uniform = np.arange(t_lo, t_hi, spacing)
    idx = np.clip(np.searchsorted(exact, uniform), 1, len(exact) - 1)
    near = np.minimum(np.abs(uniform - exact[idx]), np.abs(uniform - exact[idx - 1]))
    return np.unique(np.concatenate([exact, uniform[near > 1e-3 * spacing]]))


def simulate_signal(spec: Spec, program: LoadProgram, t_samples: np.ndarray,
                    temperature_fn=None) -> np.ndarray:
    """Noise-free signal at ``t_samples`` with the hidden effects (fine-grid simulation;
    data problems are added by :func:`generate`, to the noisy record)."""
    hidden = spec.hidden
    delay = float(hidden.get("time_offset", {}).get("delay", 0.0))
    average = hidden.get("time_offset", {}).get("form") == "average"
    if average:
        delay = 0.0
    taus = list(spec.tau)
    betas = list(spec.beta)
    if "extra_retardation" in hidden:
        p = hidden["extra_retardation"]
        if p.get("form", "exponential") == "spectrum":
            # a band of retardation times, log-normal weights over +-spread decades
            grid_tau = float(p["tau"]) * 10.0 ** np.linspace(-p["spread"], p["spread"], 7)
            w = np.exp(-0.5 * (np.linspace(-2.0, 2.0, 7)) ** 2)
            taus += list(grid_tau)
            betas += list(float(p["beta"]) * w / w.sum())
        else:
            taus.append(float(p["tau"]))
            betas.append(float(p["beta"]))
    spacing = min(1.0 / spec.rate / 4.0, min(taus) / 40.0)
    grid = _fine_grid(program, t_samples, spacing, delay)
    # the load on the grid, with steps placed exactly: duplicate each breakpoint time
    u_after, u_before = program.sample(grid), program.sample_before(grid)
    fs = spec.full_scale
    s_after, s_before = u_after, u_before
    if "static_nonlinearity" in hidden:
        p = hidden["static_nonlinearity"]
        f = _static_function(p, fs)
        s_after, s_before = f(u_after), f(u_before)
    if "mullins_softening" in hidden:
        s_after, s_before = _mullins(hidden["mullins_softening"], u_after, u_before)
    if hidden.get("rate_independent_hysteresis", {}).get("form") == "distributed":
        # friction in the mechanics: several plays on the load, before creep
        p = hidden["rate_independent_hysteresis"]
        extra = p["weight"] / spec.gain * _plays(p, u_after, u_before)
        s_after, s_before = s_after + extra[1], s_before + extra[0]
    h_after, h_before = s_after, s_before
    if "nonlinear_creep" in hidden and hidden["nonlinear_creep"].get("form", "linear") != "time":
        g = _creep_function(hidden["nonlinear_creep"], fs)
        h_after, h_before = g(s_after), g(s_before)
    temp = temperature_fn(grid) if temperature_fn is not None else None
    init = np.full(len(taus), h_after[0])
    lags = lag_states(grid, h_after, taus, hold="linear", initial=init, u_before=h_before)
    factor = np.ones((len(grid) - 1, 1))
    varying = False
    if "thermal_retardation" in hidden:
        p = hidden["thermal_retardation"]
        tm = 0.5 * (temp[:-1] + temp[1:])
        if p.get("form", "arrhenius") == "wlf":
            dT = tm - p["reference_temperature"]
            factor = factor * (10.0 ** (-p["c1"] * dT / (p["c2"] + dT)))[:, None]
        else:
            tk = tm + 273.15
            tref = p["reference_temperature"] + 273.15
            factor = factor * np.exp(p["activation"] * (1.0 / tk - 1.0 / tref))[:, None]
        varying = True
    if hidden.get("nonlinear_creep", {}).get("form") == "time":
        # creep that runs faster under a higher load (stress-accelerated retardation)
        hm = 0.5 * (np.abs(h_after[:-1]) + np.abs(h_before[1:]))
        factor = factor / (1.0 + hidden["nonlinear_creep"]["acceleration"] * hm / fs)[:, None]
        varying = True
    if "aging_retardation" in hidden:
        factor = factor * _aging_factor(grid, u_after, hidden["aging_retardation"]["age"])[:, None]
        varying = True
    if varying:
        # steps at grid points: varying_lag_states takes the value after; a step inside a
        # fine step is at most one fine step late, which the fine spacing makes negligible
        lags = varying_lag_states(grid, h_after, np.array(taus)[None, :] * factor, hold="linear",
                                  initial=init)
    if "asymmetric_recovery" in hidden:
        p = hidden["asymmetric_recovery"]
        if p.get("form", "state") == "direction":
            lags[:, 0] = _direction_lag(grid, h_before, h_after, taus[0], p["tau_recovery"], h_after[0])
        else:
            lags[:, 0] = _asymmetric_lag(grid, h_before, h_after, taus[0], p["tau_recovery"], h_after[0])
    y = s_after + lags @ np.array(betas)
    if "viscous_flow" in hidden:
        p = hidden["viscous_flow"]
        drive_a, drive_b = s_after, s_before
        if p.get("form", "linear") == "norton":
            n = p["exponent"]
            drive_a = s_after * np.abs(s_after / fs) ** (n - 1.0)
            drive_b = s_before * np.abs(s_before / fs) ** (n - 1.0)
        steps = 0.5 * (drive_a[:-1] + drive_b[1:]) * np.diff(grid)
        y = y + p["rate"] * np.concatenate([[0.0], np.cumsum(steps)])
    y = spec.offset + spec.gain * y
    if "thermal_drift" in hidden:
        p = hidden["thermal_drift"]
        dT = temp - p["reference_temperature"]
        if p.get("form", "linear") == "lagged":
            dT = lag_states(grid, dT, [p["lag"]], hold="linear", initial="settled")[:, 0]
        y = y + p["coefficient"] * dT
    p = hidden.get("rate_independent_hysteresis")
    if p is not None and p.get("form", "play") == "play":
        y = y + p["weight"] * _plays(p, u_after, u_before)[1]
    if "sensitivity_drift" in hidden:
        rel = (grid - t_samples[0]) / max(t_samples[-1] - t_samples[0], 1e-12)
        y = spec.offset + (y - spec.offset) * (1.0 + hidden["sensitivity_drift"]["change"] * rel)
    if "periodic_disturbance" in hidden:
        p = hidden["periodic_disturbance"]
        y = y + p["amplitude"] * np.sin(2 * np.pi * grid / p["period"] + p["phase"])
    out = np.interp(t_samples - delay, grid, y)
    if "transition_overshoot" in hidden:
        out = out + _overshoot(hidden["transition_overshoot"], program, t_samples)
    if average:
        k = int(hidden["time_offset"]["samples"])
        out = np.mean([np.interp(t_samples - j / spec.rate, grid, y) for j in range(k)], axis=0)
        if "transition_overshoot" in hidden:
            out = out + _overshoot(hidden["transition_overshoot"], program, t_samples)
    return out


def play_loop(x, width: float, initial: float = 0.0) -> np.ndarray:
    """A play (backlash) operator of dead-band ``width``, stepped sample by sample."""
    r = 0.5 * width
    y, out = initial, []
    for v in np.asarray(x, float).tolist():
        y = min(max(y, v - r), v + r)
        out.append(y)
    return np.array(out)


def _plays(p: dict, u_after, u_before) -> np.ndarray:
    """Mean of ``play(u) - u`` over the hidden operators' widths, before and after each grid
    time (shape (2, N)); the grid holds every breakpoint, so the plays are exact there."""
    widths = [p["width"]] if p.get("form", "play") == "play" else \
        list(p["width"] * np.linspace(1.0 - p["spread"], 1.0 + p["spread"], 5))
    # interleave before/after values so that steps at grid points are followed exactly
    x = np.column_stack([u_before, u_after]).ravel()
    acc = np.zeros_like(x)
    for w in widths:
        acc += play_loop(x, w) - x
    acc /= len(widths)
    return acc.reshape(-1, 2).T


def _mullins(p: dict, u_after, u_before):
    """Instantaneous response with first-cycle softening below the largest |load| so far."""
    x = np.column_stack([u_before, u_after]).ravel()
    m = np.maximum.accumulate(np.abs(x))
    with np.errstate(invalid="ignore", divide="ignore"):
        r = np.where(m > 0, np.abs(x) / m, 1.0)
    sigma = p["softening"]
    if p.get("form", "chord") == "damage":
        b = p["shape"]
        factor = 1.0 - sigma * np.tanh((1.0 - r) / b) / np.tanh(1.0 / b)
    else:
        factor = 1.0 - sigma * (1.0 - r)
    s = (x * factor).reshape(-1, 2).T
    return s[1], s[0]


def _aging_factor(grid, u, age: float) -> np.ndarray:
    """Factor on the retardation time over each fine step: ``1 + (time since the last load
    change) / age`` (the material stiffens as it rests under a load)."""
    changed = np.concatenate([[True], np.abs(np.diff(u)) > 0])
    last = np.maximum.accumulate(np.where(changed, np.arange(len(grid)), 0))
    since = grid - grid[last]
    return 1.0 + 0.5 * (since[:-1] + since[1:]) / age


def _overshoot(p: dict, program: LoadProgram, t: np.ndarray) -> np.ndarray:
    """Sum over the program's load changes of ``amplitude |dL| g(t - t_change)``; ramps are
    cut into 32 changes each. ``g``: exp(-x/tau) or, stretched, exp(-(x/tau)^b)."""
    bt, bu = np.array(program.times), np.array(program.loads)
    times, sizes = [], []
    for k in range(len(bt) - 1):
        du = bu[k + 1] - bu[k]
        if du == 0:
            continue
        if bt[k + 1] == bt[k]:
            times.append(bt[k])
            sizes.append(abs(du))
        else:
            pieces = 32
            times += list(bt[k] + (np.arange(pieces) + 0.5) / pieces * (bt[k + 1] - bt[k]))
            sizes += [abs(du) / pieces] * pieces
    out = np.zeros(len(t))
    tau, b = p["tau"], p.get("exponent", 1.0) if p.get("form") == "stretched" else 1.0
    for tj, sj in zip(times, sizes):
        after = t >= tj
        x = (t[after] - tj) / tau
        out[after] += p["amplitude"] * sj * np.exp(-x ** b)
    return out


def _static_function(p: dict, fs: float):
    if p.get("form", "poly") == "poly":
        a2, a3 = p["a2"], p["a3"]
        return lambda u: u + fs * (a2 * (u / fs) ** 2 + a3 * (u / fs) ** 3)
    k = p["saturation"]               # tanh: compressive, 1 - tanh(k) / k at full scale
    return lambda u: fs * np.tanh(k * u / fs) / k


def _creep_function(p: dict, fs: float):
    if p.get("form", "linear") == "linear":
        c = p["growth"]
        return lambda s: s * (1.0 + c * np.abs(s) / fs)
    m = p["exponent"]                                 # power law: creep ~ |s|^m
    return lambda s: fs * np.sign(s) * np.abs(s / fs) ** m


def _asymmetric_lag(grid, h_before, h_after, tau: float, tau_recovery: float, c0: float) -> np.ndarray:
    """A lag that relaxes with ``tau`` while its state grows in magnitude and with
    ``tau_recovery`` while it shrinks, stepped exactly on the fine grid with the input held at
    each step's midpoint (a plain sequential loop, independent of the fitted discretisation)."""
    t = grid.tolist()
    hb, ha = h_before.tolist(), h_after.tolist()
    out = [c0]
    c = c0
    for n in range(len(t) - 1):
        target = 0.5 * (ha[n] + hb[n + 1])
        shrinking = (c > 0 and target < c) or (c < 0 and target > c)
        step = (t[n + 1] - t[n]) / (tau_recovery if shrinking else tau)
        c = target + (c - target) * math.exp(-step)
        out.append(c)
    return np.array(out)

def _direction_lag(grid, h_before, h_after, tau: float, tau_recovery: float, c0: float) -> np.ndarray:
    """A lag that runs with ``tau_recovery`` from a fall of the load's magnitude until the
    next rise, with ``tau`` otherwise (the mode switched by the load's direction)."""
    t = grid.tolist()
    hb, ha = h_before.tolist(), h_after.tolist()
    out = [c0]
    c, recovering = c0, False
    for n in range(len(t) - 1):
        # the load's last move, up to this step
        for a, b in ((hb[n], ha[n]), (ha[n], hb[n + 1])):
            if abs(b) < abs(a):
                recovering = True
            elif abs(b) > abs(a):
                recovering = False
        target = 0.5 * (ha[n] + hb[n + 1])
        step = (t[n + 1] - t[n]) / (tau_recovery if recovering else tau)
        c = target + (c - target) * math.exp(-step)
        out.append(c)
    return np.array(out)


def detectability(spec: Spec, program: LoadProgram, t: np.ndarray, temperature_fn,
                  clean: np.ndarray, noise: np.ndarray) -> float:
    """How far the hidden effects stand out of the noise: the held-out ``z`` (see
    :func:`creepcomp.fit.evidence.compare`) that the part of their signature the baseline cannot
    absorb would give with every parameter known. The signature (the noise-free record with
    the effects minus the one without) is projected off the baseline's directions at the true
    values (offset, load, the lag, its derivative in tau, a free initial creep state); ``z``
    is its energy over twice the spread of its product with the noise (noise spectrum from
    ``noise``). The baseline fitted to the noise-free record may absorb more than that first
    order (a load-dependent retardation time moves the fitted tau far from the true one):
    the ``z`` of its residual counts when smaller."""
    plain = {k: v for k, v in spec.hidden.items() if k == "data_problem"}
    signature = clean - simulate_signal(replace(spec, hidden=plain), program, t, temperature_fn)
    u = program.sample(t)
    tau = spec.tau[0]
    lag, lag_up = lag_states(t, u, [tau, 1.01 * tau], initial=np.full(2, u[0])).T
    directions = np.column_stack([np.ones_like(t), u, lag, (lag_up - lag) / 0.01,
                                  np.exp(-(t - t[0]) / tau)])
    coef, *_ = np.linalg.lstsq(directions, signature, rcond=None)
    rest = signature - directions @ coef
    return min(heldout_z(rest, noise), heldout_z(_baseline_residual(t, u, clean), noise))


def _baseline_misfit(t, load, clean, terms: int = 1) -> float:
    """RMS residual of the baseline (:func:`_baseline_residual`)."""
    return float(np.sqrt(np.mean(_baseline_residual(t, load, clean, terms) ** 2)))


def _baseline_residual(t, load, clean, terms: int = 1) -> np.ndarray:
    """Residual of the baseline (one creep term, free initial state; or ``terms`` = 2 creep
    terms) fitted to a noise-free record."""
    from creepcomp.fit.data import prepare
    from creepcomp.fit.solver import fit_structure
    from creepcomp.fit.starts import extra_term_starts, one_term_starts
    from creepcomp.fit.structure import Structure

    data = prepare(Record(t, load, clean, source="noise-free record"))
    fit = fit_structure(data, Structure(1), one_term_starts(data), with_cov=False)
    if terms == 2:
        two = Structure(2)
        fit = fit_structure(data, two, extra_term_starts(data, fit, two), with_cov=False)
    return fit.residual


def _quiet_indices(load: np.ndarray, margin: int) -> np.ndarray:
    """Samples with no load change within ``margin`` samples either side."""
    changed = np.concatenate([[False], np.diff(load) != 0])
    near = np.convolve(changed.astype(float), np.ones(2 * margin + 1), mode="same") > 0
    return np.flatnonzero(~near[margin:len(load) - margin]) + margin


def _data_problem(p: dict, t, load, signal, clean, rng):
    """The record with a data problem of kind ``p["form"]``, and the problem's truth (kind,
    where)."""
    kind = p.get("form", "jump")
    y = signal.copy()
    span = float(np.ptp(clean)) or 1.0
    if kind == "jump":
        quiet = _quiet_indices(load, 12)
        quiet = quiet[(quiet > 0.1 * len(t)) & (quiet < 0.9 * len(t))]
        at = np.sort(rng.choice(quiet, size=min(int(p.get("count", 1)), len(quiet)), replace=False))
        sizes = []
        for i in at:
            size = float(rng.choice([-1, 1]) * p["size"] * span)
            y[i:] += size
            sizes.append(size)
        return y, {"form": kind, "kind": kind, "where": [float(t[i]) for i in at], "size": sizes}
    if kind == "clipping":
        level = float(np.max(clean) - p["fraction"] * span)
        y = np.minimum(y, level)
        at = np.flatnonzero(y >= level)
        return y, {"form": kind, "kind": kind, "level": level,
                   "where": [float(t[at[0]]), float(t[at[-1]])] if len(at) else []}
    if kind == "out_of_step":
        # the signal channel repeats ``slip`` samples at one instant: later than the load after it
        quiet = _quiet_indices(load, 12)
        quiet = quiet[(quiet > 0.35 * len(t)) & (quiet < 0.65 * len(t))]
        i = int(rng.choice(quiet))
        k = int(p["slip"])
        y = np.concatenate([y[:i], np.repeat(y[i], k), y[i:len(y) - k]])
        return y, {"form": kind, "kind": kind, "where": [float(t[i])], "slip": k * float(np.median(np.diff(t)))}
    if kind == "quantisation":
        q = float(p["step"])
        return np.round(signal / q) * q, {"form": kind, "kind": kind, "where": [float(t[0]), float(t[-1])],
                                          "step": q}
    raise InputError(f"data problem '{kind}': use one of {', '.join(DATA_PROBLEMS)}")


def generate(spec: Spec) -> Synthetic:
    """Simulate a record from a :class:`Spec`.

    Returns
    -------
    Synthetic
        The record (``time``, ``load``, ``signal`` and, when asked for or needed by a hidden
        thermal effect, ``temperature``) and the truth.
    """
    rng = np.random.default_rng(spec.seed)
    program = make_program(spec.program, spec.duration, rng, spec.full_scale, spec.start_loaded,
                           max(abs(t) for t in spec.tau), spec.start,
                           unload=bool({"asymmetric_recovery", "transition_overshoot", "data_problem"}
                                       & set(spec.hidden)),
                           one_sided="viscous_flow" in spec.hidden)
    t = sample_times(spec.duration, spec.rate, rng, spec.jitter, spec.gaps, spec.start)
    needs_temp = spec.temperature or any(k.startswith("thermal") for k in spec.hidden)
    temp_fn, temp_mean = temperature_profile(t[0], t[-1], rng)
    hidden = {k: dict(v) for k, v in spec.hidden.items()}
    for name in ("thermal_drift", "thermal_retardation"):
        if name in hidden:
            hidden[name].setdefault("reference_temperature", temp_mean)
    spec = replace(spec, hidden=hidden)
    clean = simulate_signal(spec, program, t, temp_fn)
    noise = sample_noise(t, spec.noise, rng)
    physical = {k: v for k, v in spec.hidden.items() if k != "data_problem"}
    if physical and spec.detectable_z > 0:
        z = detectability(spec, program, t, temp_fn, clean, noise)
        f = min(1.0, z / spec.detectable_z)
        if set(physical) & set(NO_TEMPLATE):
            # and visible against the noise floor: the baseline fitted to the noise-free record
            # misses it by VISIBLE_RATIO times the noise's RMS
            # (aging creep against two creep terms: one further term must not absorb it either)
            rms_rest = _baseline_misfit(t, program.sample(t), clean,
                                        terms=2 if "aging_retardation" in physical else 1)
            rms_noise = float(np.std(noise))
            if rms_noise > 0:
                f = min(f, rms_rest / (VISIBLE_RATIO * rms_noise))
        if f < 1.0:
            # the same noise realisation, scaled (every component is linear in its size)
            noise = noise * f
            spec = replace(spec, noise=scaled_noise(spec.noise, f))
    signal = clean + noise
    if spec.noise.lsb > 0:
        signal = np.round(signal / spec.noise.lsb) * spec.noise.lsb
    load = program.sample(t)
    if "data_problem" in spec.hidden:
        signal, problem = _data_problem(spec.hidden["data_problem"], t, load, signal, clean, rng)
        spec = replace(spec, hidden={**spec.hidden, "data_problem": problem})
    metadata = {"units.load": "N", "units.signal": "V", "synth.seed": str(spec.seed),
                "synth.program": spec.program}
    temperature = temp_fn(t) if needs_temp else None
    record = Record(t, load, signal, temperature=temperature, metadata=metadata,
                    source=f"synthetic record (seed {spec.seed})")
    return Synthetic(record, spec, program)


# --------------------------------------------------------------------------------------------
# Randomised cases
# --------------------------------------------------------------------------------------------

#: Load programs that let each effect show (e.g. load-dependent effects need several levels).
PROGRAMS_FOR = {
    "extra_retardation": PROGRAMS,
    "viscous_flow": PROGRAMS,
    "nonlinear_creep": ("staircase", "mixture", "random", "sweep"),
    "asymmetric_recovery": ("staircase", "step", "mixture", "random"),
    "thermal_drift": PROGRAMS,
    "thermal_retardation": ("staircase", "mixture", "random", "sweep"),
    "static_nonlinearity": ("staircase", "sweep", "mixture", "random"),
    "time_offset": ("staircase", "step", "mixture", "random", "sweep"),
    "transition_overshoot": ("staircase", "step", "random", "cycles"),
    "rate_independent_hysteresis": ("sweep", "staircase", "mixture", "cycles"),
    "mullins_softening": ("cycles",),
    "data_problem": ("staircase", "step", "cycles"),
    "sensitivity_drift": ("staircase", "step", "mixture", "random", "sweep", "cycles"),
    "periodic_disturbance": ALL_PROGRAMS,
    "aging_retardation": ("staircase", "step", "cycles"),
    None: PROGRAMS,
}


def random_hidden(effect: str | None, rng: np.random.Generator, tau: float, rate: float,
                  duration: float, beta: float, forms: bool = True, signal_scale: float = 1.0,
                  form: str | None = None, gain: float = 1.0) -> dict:
    """Random parameters of a hidden effect, at sizes a designer would care about
    (``signal_scale``: the full-scale signal, for effects in signal units; ``gain``: signal per
    load unit). ``form``: one of :data:`FORMS` (default: the fitted template's, with the old
    effects' random mixture of forms when ``forms``)."""
    if effect is None:
        return {}
    if form is not None or effect in ("transition_overshoot", "rate_independent_hysteresis",
                                      "mullins_softening", "data_problem") or effect in NO_TEMPLATE:
        return {effect: _formulated(effect, form, rng, tau, rate, duration, beta, signal_scale, gain)}
    if effect == "extra_retardation":
        slow = tau * rng.uniform(4.0, 12.0)
        fast = tau / rng.uniform(4.0, 12.0)
        t2 = slow if (rng.uniform() < 0.5 and slow <= duration / 3.0) or fast < 10.0 / rate else fast
        t2 = min(t2, duration / 3.0)
        return {"extra_retardation": {"tau": float(t2), "beta": float(beta * rng.uniform(0.4, 1.0))}}
    if effect == "viscous_flow":
        # flow that adds 0.5 ... 3 times the creep over the record
        return {"viscous_flow": {"rate": float(beta * rng.uniform(0.5, 3.0) / duration)}}
    if effect == "nonlinear_creep":
        if forms and rng.uniform() < 0.3:
            return {"nonlinear_creep": {"form": "power", "exponent": float(rng.uniform(1.5, 2.5))}}
        return {"nonlinear_creep": {"growth": float(rng.choice([-1, 1]) * rng.uniform(0.5, 1.0)
                                                    if rng.uniform() < 0.2 else rng.uniform(0.6, 2.0))}}
    if effect == "asymmetric_recovery":
        f = rng.uniform(2.5, 5.0)
        return {"asymmetric_recovery": {"tau_recovery": float(tau * (f if rng.uniform() < 0.5 else 1 / f))}}
    if effect == "thermal_drift":
        # 0.02 ... 0.1 % of full scale per K
        return {"thermal_drift": {"coefficient": float(rng.choice([-1, 1]) * rng.uniform(2e-4, 1e-3)
                                                       * signal_scale)}}
    if effect == "thermal_retardation":
        # activation energy 60 ... 150 kJ/mol: tau changes 7 ... 17 % per K near 300 K
        return {"thermal_retardation": {"activation": float(rng.uniform(60e3, 150e3) / 8.314)}}
    if effect == "static_nonlinearity":
        if forms and rng.uniform() < 0.3:
            return {"static_nonlinearity": {"form": "tanh", "saturation": float(rng.uniform(0.15, 0.35))}}
        return {"static_nonlinearity": {"a2": float(rng.choice([-1, 1]) * rng.uniform(0.005, 0.02)),
                                        "a3": float(rng.choice([-1, 1]) * rng.uniform(0.0, 0.02))}}
    if effect == "time_offset":
        dt = 1.0 / rate
        return {"time_offset": {"delay": float(dt * rng.uniform(2.0, 10.0))}}
    raise InputError(f"unknown effect '{effect}' (known: {', '.join(EFFECTS)})")


def _formulated(effect: str, form: str | None, rng, tau, rate, duration, beta, signal_scale, gain) -> dict:
    """Random parameters of ``effect`` in the formulation ``form`` (first of :data:`FORMS` by default)."""
    if effect in NO_TEMPLATE:
        if effect == "sensitivity_drift":          # the gain changes by 2 ... 6 % over the record
            return {"change": float(rng.choice([-1, 1]) * rng.uniform(0.02, 0.06))}
        if effect == "periodic_disturbance":       # a slow pick-up, 0.2 ... 1 % of full scale
            return {"amplitude": float(rng.uniform(0.002, 0.01) * signal_scale),
                    "period": float(rng.uniform(0.04, 0.15) * duration), "phase": float(rng.uniform(0, 2 * np.pi))}
        return {"age": float(tau * rng.uniform(0.5, 2.0))}       # aging_retardation
    forms_of = FORMS.get(effect)
    if forms_of is None:
        raise InputError(f"unknown effect '{effect}' (known: {', '.join(EFFECTS + ('data_problem',) + NO_TEMPLATE)})")
    form = form or forms_of[0]
    if form not in forms_of:
        raise InputError(f"{effect}: unknown form '{form}' (known: {', '.join(forms_of)})")
    out = {"form": form}
    if effect == "extra_retardation":
        out.update(random_hidden(effect, rng, tau, rate, duration, beta, False)[effect])
        if form == "spectrum":
            out["spread"] = float(rng.uniform(0.15, 0.35))
    elif effect == "viscous_flow":
        out["rate"] = float(beta * rng.uniform(0.5, 3.0) / duration)
        if form == "norton":
            out["exponent"] = float(rng.uniform(1.5, 3.0))
    elif effect == "nonlinear_creep":
        if form == "linear":
            out["growth"] = float(rng.uniform(0.6, 2.0))
        elif form == "power":
            out["exponent"] = float(rng.uniform(1.5, 2.5))
        else:
            out["acceleration"] = float(rng.uniform(1.0, 3.0))
    elif effect == "asymmetric_recovery":
        f = rng.uniform(2.5, 5.0)
        out["tau_recovery"] = float(tau * (f if rng.uniform() < 0.5 else 1 / f))
    elif effect == "thermal_drift":
        out["coefficient"] = float(rng.choice([-1, 1]) * rng.uniform(2e-4, 1e-3) * signal_scale)
        if form == "lagged":
            out["lag"] = float(rng.uniform(0.01, 0.05) * duration)
    elif effect == "thermal_retardation":
        if form == "wlf":
            out.update(c1=float(rng.uniform(8.0, 17.0)), c2=float(rng.uniform(50.0, 120.0)))
        else:
            out["activation"] = float(rng.uniform(60e3, 150e3) / 8.314)
    elif effect == "static_nonlinearity":
        if form == "tanh":
            out["saturation"] = float(rng.uniform(0.15, 0.35))
        else:
            out.update(a2=float(rng.choice([-1, 1]) * rng.uniform(0.005, 0.02)),
                       a3=float(rng.choice([-1, 1]) * rng.uniform(0.0, 0.02)))
    elif effect == "time_offset":
        if form == "average":
            k = int(rng.integers(3, 9))
            out.update(samples=k, delay=float((k - 1) / 2.0 / rate))
        else:
            out["delay"] = float(rng.uniform(2.0, 10.0) / rate)
    elif effect == "transition_overshoot":
        # 2 ... 8 % of the change, decaying 3 ... 30 times faster than the creep
        out.update(amplitude=float(rng.choice([-1, 1], p=[0.3, 0.7]) * rng.uniform(0.02, 0.08) * abs(gain)),
                   tau=float(max(tau / rng.uniform(3.0, 30.0), 8.0 / rate)))
        if form == "stretched":
            out["exponent"] = float(rng.uniform(0.6, 0.85))
    elif effect == "rate_independent_hysteresis":
        out.update(width=float(rng.uniform(0.05, 0.25) * signal_scale / abs(gain)),
                   weight=float(rng.choice([-1, 1], p=[0.2, 0.8]) * rng.uniform(0.03, 0.1) * gain))
        if form == "distributed":
            out["spread"] = float(rng.uniform(0.3, 0.7))
    elif effect == "mullins_softening":
        out["softening"] = float(rng.uniform(0.1, 0.3))
        if form == "damage":
            out["shape"] = float(rng.uniform(0.2, 0.6))
    elif effect == "data_problem":
        if form == "jump":
            out.update(size=float(rng.uniform(0.005, 0.03)), count=int(rng.integers(1, 4)))
        elif form == "clipping":
            out["fraction"] = float(rng.uniform(0.03, 0.1))
        elif form == "out_of_step":
            out["slip"] = int(rng.integers(2, 7))
    return out


def random_spec(effect: str | None, seed: int, rate: tuple = (2.0, 50.0),
                duration: tuple = (900.0, 3600.0), noise: tuple = (2e-4, 2e-3),
                irregular: float = 0.3, coloured: float = 0.3, drift: float = 0.2,
                start_loaded: float = 0.2, forms: bool = True, programs=None,
                max_samples: int | None = None, colour_scale: float = 1.0,
                detectable_z: float = DETECTABLE_Z, form: str | None = None,
                relaxation: bool = False) -> Spec:
    """A randomised :class:`Spec` hiding ``effect`` (None: a clean record).

    Parameters
    ----------
    effect : str or None
    seed : int
    rate : (low, high)
        Sample rate range (Hz), drawn log-uniformly.
    duration : (low, high)
        Record length range (s).
    noise : (low, high)
        White-noise range, relative to the full-scale signal, log-uniform.
    irregular, coloured, drift, start_loaded : float
        Probabilities of jittered/gappy sampling, coloured noise (0.3-1 times the white noise,
        correlation time 2-20 samples), random-walk drift (0.2-1 times the white noise after
        an hour), and a record that starts loaded.
    forms : bool
        Also use effect forms other than the fitted ones.
    programs : sequence of str, optional
        Programs to draw from (default: those that let the effect show).
    max_samples : int, optional
        Shorten the record to at most this many samples (the retardation time scales with
        it): small records for fast tests.
    colour_scale : float
        Multiplies the coloured noise and the drift (the wide benchmark uses 2).
    detectable_z : float
        The hidden effect's least :func:`detectability` (the noise is scaled down to reach it).
    form : str, optional
        Formulation of the hidden effect (:data:`FORMS`; for ``data_problem`` its kind).
    relaxation : bool
        The sensor relaxes (read under imposed displacement): beta < 0, and so has a hidden
        further term.
    """
    known = EFFECTS + ("data_problem",) + NO_TEMPLATE
    if effect is not None and effect not in known:
        raise InputError(f"unknown effect '{effect}' (known: {', '.join(known)})")
    rng = np.random.default_rng(seed)
    r = float(np.exp(rng.uniform(np.log(rate[0]), np.log(rate[1]))))
    dur = float(rng.uniform(*duration))
    if max_samples is not None:
        dur = min(dur, max_samples / r)
    tau = float(np.exp(rng.uniform(np.log(min(20.0, dur / 40)), np.log(min(120.0, dur / 8)))))
    beta = float(rng.uniform(0.01, 0.06))
    gain = float(rng.uniform(0.2, 5.0) * rng.choice([-1, 1], p=[0.2, 0.8]))
    fs = float(rng.choice([1.0, 2.0, 9.81, 50.0]))
    white = float(np.exp(rng.uniform(np.log(noise[0]), np.log(noise[1])))) * abs(gain) * fs
    n = NoiseSpec(white=white,
                  coloured=white * rng.uniform(0.3, 1.0) * colour_scale if rng.uniform() < coloured else 0.0,
                  correlation_time=float(rng.uniform(2.0, 20.0) / r),
                  drift=white * rng.uniform(0.2, 1.0) * colour_scale if rng.uniform() < drift else 0.0,
                  lsb=white * rng.uniform(0.1, 1.0) if rng.uniform() < 0.3 else 0.0)
    choices = list(programs or PROGRAMS_FOR[effect])
    if effect == "data_problem" and form == "out_of_step" and not programs:
        # a slip shows as a change of delay between load steps: programs with many of them
        choices = ["staircase", "cycles"]
    irregular_now = rng.uniform() < irregular
    hidden = random_hidden(effect, rng, tau, r, dur, beta, forms, abs(gain) * fs, form, gain)
    if effect == "data_problem" and hidden[effect]["form"] == "quantisation":
        hidden[effect]["step"] = float(n.white * rng.uniform(5.0, 12.0))
    if relaxation:
        beta = -beta
        if effect == "extra_retardation":
            hidden[effect]["beta"] = -abs(hidden[effect]["beta"])
    if effect == "extra_retardation" and hidden[effect]["tau"] < tau and len(choices) > 1:
        # a fast further term shows after load steps, hardly in a slow sweep
        choices = [c for c in choices if c != "sweep"]
    return Spec(hidden=hidden, beta=(beta,), tau=(tau,), gain=gain,
                offset=float(rng.normal(0, 0.1) * abs(gain) * fs), rate=r, duration=dur,
                program=str(rng.choice(list(choices))), full_scale=fs,
                jitter=float(rng.uniform(0.1, 0.4)) if irregular_now else 0.0,
                gaps=int(rng.integers(1, 3)) if irregular_now and rng.uniform() < 0.5 else 0,
                start_loaded=bool(rng.uniform() < start_loaded),
                start=float(rng.choice([0.0, rng.uniform(0, 1e5)])),
                noise=n, temperature=bool(rng.uniform() < 0.5), seed=seed,
                detectable_z=detectable_z)


def random_record(effect: str | None, seed: int, **ranges) -> Synthetic:
    """:func:`generate` of :func:`random_spec`."""
    return generate(random_spec(effect, seed, **ranges))


#: The bundled demo record (``data/hidden_effect.csv``): a force sensor (V per N) on a
#: staircase of loading and unloading steps whose recovery is slower than its creep.
DEMO_SPEC = Spec(hidden={"asymmetric_recovery": {"tau_recovery": 150.0}}, beta=(0.03,), tau=(45.0,),
                 gain=0.05, offset=0.002, rate=2.0, duration=1500.0, program="staircase",
                 full_scale=10.0, noise=NoiseSpec(white=2e-4), seed=2008)


def write_demo_record(folder) -> Path:
    """Write the record bundled as ``data/hidden_effect.csv`` (:data:`DEMO_SPEC`) into ``folder``."""
    record = generate(DEMO_SPEC).record
    meta = dict(record.metadata)
    meta["description"] = ("synthetic force sensor with a hidden effect "
                           "(creepcomp.synth.sensor.DEMO_SPEC)")
    return write_record(Path(folder) / "hidden_effect.csv", replace(record, metadata=meta), digits=9)


def reported_truth(synthetic: Synthetic) -> dict:
    """The hidden parameters under the names diagnosis reports (where they share a meaning)."""
    out = {}
    for name, p in synthetic.hidden.items():
        if name == "extra_retardation":
            out[name] = {"tau": p["tau"], "beta": p["beta"]}
        elif name == "viscous_flow":
            rate = p["rate"]
            if p.get("form") == "norton":
                # the diagnosis gives the rate at the record's largest load, not at the
                # generator's full scale
                largest = float(np.max(np.abs(synthetic.record.load)))
                rate *= (largest / synthetic.spec.full_scale) ** (p["exponent"] - 1.0)
            out[name] = {"rate": rate}
        elif name == "asymmetric_recovery":
            out[name] = {"tau_recovery": p["tau_recovery"]}
        elif name == "thermal_drift":
            out[name] = {"coefficient": p["coefficient"]}
        elif name == "time_offset":
            out[name] = {"delay": p["delay"]}
        elif name == "transition_overshoot":
            out[name] = {"amplitude": p["amplitude"], "tau": p["tau"]}
        elif name == "rate_independent_hysteresis":
            out[name] = {"width": p["width"], "weight": p["weight"], "loop_height": p["width"] * p["weight"]}
        elif name == "mullins_softening":
            out[name] = {"softening": p["softening"]}
        elif name == "data_problem":
            out[name] = {"kind": p["kind"], "where": p["where"]}
        else:
            out[name] = {}
    return out

