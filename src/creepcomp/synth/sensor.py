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

__all__ = ["EFFECTS", "PROGRAMS", "PROGRAMS_FOR", "Spec", "Synthetic", "make_program", "sample_times",
           "temperature_profile", "simulate_signal", "detectability", "generate", "random_hidden",
           "random_spec", "random_record", "DEMO_SPEC", "write_demo_record", "reported_truth"]

#: Hidden effects the generator can put in a record.
EFFECTS = ("extra_retardation", "viscous_flow", "nonlinear_creep", "asymmetric_recovery",
           "thermal_drift", "thermal_retardation", "static_nonlinearity", "time_offset")

#: Kinds of load program :func:`make_program` draws.
PROGRAMS = ("step", "staircase", "sweep", "mixture", "random")


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
    """A random load program of a kind: ``step``, ``staircase``, ``sweep``, ``mixture`` or
    ``random``, spanning ``duration`` from ``start``.

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
    else:
        raise InputError(f"load program '{kind}': use one of {', '.join(PROGRAMS)}")
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
    """Noise-free signal at ``t_samples`` with the hidden effects (fine-grid simulation)."""
    hidden = spec.hidden
    delay = float(hidden.get("time_offset", {}).get("delay", 0.0))
    taus = list(spec.tau)
    betas = list(spec.beta)
    if "extra_retardation" in hidden:
        taus.append(float(hidden["extra_retardation"]["tau"]))
        betas.append(float(hidden["extra_retardation"]["beta"]))
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
    h_after, h_before = s_after, s_before
    if "nonlinear_creep" in hidden:
        g = _creep_function(hidden["nonlinear_creep"], fs)
        h_after, h_before = g(s_after), g(s_before)
    temp = temperature_fn(grid) if temperature_fn is not None else None
    init = np.full(len(taus), h_after[0])
    lags = lag_states(grid, h_after, taus, hold="linear", initial=init, u_before=h_before)
    if "thermal_retardation" in hidden:
        p = hidden["thermal_retardation"]
        tk = 0.5 * (temp[:-1] + temp[1:]) + 273.15
        tref = p["reference_temperature"] + 273.15
        factor = np.exp(p["activation"] * (1.0 / tk - 1.0 / tref))[:, None]
        # steps at grid points: varying_lag_states takes the value after; a step inside a
        # fine step is at most one fine step late, which the fine spacing makes negligible
        lags = varying_lag_states(grid, h_after, np.array(taus)[None, :] * factor, hold="linear",
                                  initial=init)
    if "asymmetric_recovery" in hidden:
        lags[:, 0] = _asymmetric_lag(grid, h_before, h_after, taus[0],
                                     hidden["asymmetric_recovery"]["tau_recovery"], h_after[0])
    y = s_after + lags @ np.array(betas)
    if "viscous_flow" in hidden:
        steps = 0.5 * (s_after[:-1] + s_before[1:]) * np.diff(grid)
        y = y + hidden["viscous_flow"]["rate"] * np.concatenate([[0.0], np.cumsum(steps)])
    y = spec.offset + spec.gain * y
    if "thermal_drift" in hidden:
        p = hidden["thermal_drift"]
        y = y + p["coefficient"] * (temp - p["reference_temperature"])
    return np.interp(t_samples - delay, grid, y)


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

def detectability(spec: Spec, program: LoadProgram, t: np.ndarray, temperature_fn,
                  clean: np.ndarray, noise: np.ndarray) -> float:
    """How far the hidden effects stand out of the noise: the held-out ``z`` (see
    :func:`creepcomp.fit.evidence.compare`) that the part of their signature the baseline cannot
    absorb would give with every parameter known. The signature (the noise-free record with
    the effects minus the one without) is projected off the baseline's directions at the true
    values (offset, load, the lag, its derivative in tau, a free initial creep state); ``z``
    is its energy over twice the spread of its product with the noise (noise spectrum from
    ``noise``)."""
    signature = clean - simulate_signal(replace(spec, hidden={}), program, t, temperature_fn)
    u = program.sample(t)
    tau = spec.tau[0]
    lag, lag_up = lag_states(t, u, [tau, 1.01 * tau], initial=np.full(2, u[0])).T
    directions = np.column_stack([np.ones_like(t), u, lag, (lag_up - lag) / 0.01,
                                  np.exp(-(t - t[0]) / tau)])
    coef, *_ = np.linalg.lstsq(directions, signature, rcond=None)
    return heldout_z(signature - directions @ coef, noise)


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
                           max(spec.tau), spec.start, unload="asymmetric_recovery" in spec.hidden,
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
    if spec.hidden and spec.detectable_z > 0:
        z = detectability(spec, program, t, temp_fn, clean, noise)
        if z < spec.detectable_z:
            # the same noise realisation, scaled (every component is linear in its size)
            f = z / spec.detectable_z
            noise = noise * f
            spec = replace(spec, noise=scaled_noise(spec.noise, f))
    signal = clean + noise
    if spec.noise.lsb > 0:
        signal = np.round(signal / spec.noise.lsb) * spec.noise.lsb
    load = program.sample(t)
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
    None: PROGRAMS,
}


def random_hidden(effect: str | None, rng: np.random.Generator, tau: float, rate: float,
                  duration: float, beta: float, forms: bool = True, signal_scale: float = 1.0) -> dict:
    """Random parameters of a hidden effect, at sizes a designer would care about
    (``signal_scale``: the full-scale signal, for effects in signal units)."""
    if effect is None:
        return {}
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


def random_spec(effect: str | None, seed: int, rate: tuple = (2.0, 50.0),
                duration: tuple = (900.0, 3600.0), noise: tuple = (2e-4, 2e-3),
                irregular: float = 0.3, coloured: float = 0.3, drift: float = 0.2,
                start_loaded: float = 0.2, forms: bool = True, programs=None,
                max_samples: int | None = None, colour_scale: float = 1.0,
                detectable_z: float = DETECTABLE_Z) -> Spec:
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
    """
    if effect is not None and effect not in EFFECTS:
        raise InputError(f"unknown effect '{effect}' (known: {', '.join(EFFECTS)})")
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
    irregular_now = rng.uniform() < irregular
    hidden = random_hidden(effect, rng, tau, r, dur, beta, forms, abs(gain) * fs)
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
            out[name] = {"rate": p["rate"]}
        elif name == "asymmetric_recovery":
            out[name] = {"tau_recovery": p["tau_recovery"]}
        elif name == "thermal_drift":
            out[name] = {"coefficient": p["coefficient"]}
        elif name == "time_offset":
            out[name] = {"delay": p["delay"]}
        else:
            out[name] = {}
    return out

