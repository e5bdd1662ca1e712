"""Synthetic sensor records with known hidden effects, for examples, tests, the demo and benchmarks.

A record is simulated on a fine time grid that holds every breakpoint of the load program
(so steps and ramps are exact), independently of how the fit discretises: the hidden effects
are written in their own forms (some deliberately not the fitted ones: a saturating static
nonlinearity, a power-law nonlinear creep, an Arrhenius temperature law), then sampled at the
record's (uniform, jittered or gappy) times and given noise of several kinds. Everything
random takes a seed.

The generator names no effect: each hidden effect is a unit that gives its forward model at
the stages of the signal path, its parameter sampler and formulations, its load programs and
its truth (:class:`~creepcomp.diagnose.effects.Simulated`): the sensor effects of the
diagnosis registry (:func:`~creepcomp.diagnose.effects.sensor_effects`), then the effects no
template describes (:mod:`creepcomp.synth.untemplated`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from creepcomp.diagnose.effects import Scales, SignalPath, Simulated, sensor_effects
from creepcomp.diagnose.effects.asymmetric_recovery import EFFECT as SLOW_RECOVERY
from creepcomp.diagnose.effects.rate_independent_hysteresis import play_loop
from creepcomp.errors import InputError
from creepcomp.io.records import Record, write_record
from creepcomp.lti import lag_states, varying_lag_states
from creepcomp.programs import LoadProgram
from creepcomp.synth.common import DETECTABLE_Z, NoiseSpec, heldout_z, sample_noise, scaled_noise
from creepcomp.synth.loads import ALL_PROGRAMS, PROGRAMS, make_program, sample_times
from creepcomp.synth.untemplated import UNTEMPLATED

__all__ = ["EFFECTS", "FORMS", "DATA_PROBLEMS", "NO_TEMPLATE", "PROGRAMS", "ALL_PROGRAMS", "PROGRAMS_FOR", "Spec", "Synthetic", "make_program", "sample_times",
           "temperature_profile", "simulate_signal", "detectability", "generate", "random_hidden",
           "random_spec", "random_record", "DEMO_SPEC", "write_demo_record", "reported_truth", "play_loop",
           "VISIBLE_RATIO", "hidden_units"]


def hidden_units() -> list[Simulated]:
    """Every effect the generator can hide in a record, in the order it lists them: the
    registered sensor effects (vocabulary order), then those no template describes."""
    return [e for e in sensor_effects() if isinstance(e, Simulated)] + list(UNTEMPLATED)


def _unit(name: str | None) -> Simulated | None:
    """The generator's effect of this name, or None."""
    return next((u for u in hidden_units() if u.name == name), None)


def _active(hidden: dict) -> list[tuple[Simulated, dict]]:
    """The hidden effects the generator knows and their parameters, in the order their stages
    act (:attr:`~creepcomp.diagnose.effects.Simulated.stage_order`)."""
    units = sorted((u for u in hidden_units() if u.name in hidden), key=_stage_order)
    return [(u, hidden[u.name]) for u in units]


def _stage_order(unit: Simulated) -> float:
    return unit.stage_order if unit.stage_order is not None else getattr(unit, "vocabulary_index", math.inf)


def _physical_names() -> tuple[str, ...]:
    return tuple(u.name for u in hidden_units() if u.templated and not u.record_problem)


def _known_names() -> tuple[str, ...]:
    """Physical effects, faults of the record, then effects no template describes."""
    units = hidden_units()
    return (_physical_names() + tuple(u.name for u in units if u.templated and u.record_problem)
            + tuple(u.name for u in units if not u.templated))


#: Hidden effects the generator can put in a record.
EFFECTS = _physical_names()

#: Formulations of each hidden effect (``form`` of :func:`random_spec`); the first is closest to
#: the fitted template, the others are what a physicist would equally write down.
FORMS = {u.name: tuple(u.forms) for u in hidden_units() if u.templated}

#: Kinds of fault of the record the generator makes (the forms of the effect that is one).
DATA_PROBLEMS = next((tuple(u.forms) for u in hidden_units() if u.record_problem), ())

#: Records with effects no template describes (diagnosis must say ``unexplained``): a
#: multiplicative sensitivity drift over time, a periodic disturbance, creep whose retardation
#: time ages with the time since the last load change.
NO_TEMPLATE = tuple(u.name for u in UNTEMPLATED)

#: No-template records keep their misfit visible: the part of their signature the baseline
#: cannot absorb has at least this RMS relative to the noise (the noise is scaled down).
VISIBLE_RATIO = 3.0


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
    faults of the record are added by :func:`generate`, to the noisy record).

    Each hidden effect acts at the stages of the signal path it changes
    (:class:`~creepcomp.diagnose.effects.Simulated`), the effects in the generator's order."""
    active = _active(spec.hidden)
    delay = float(sum(u.sim_lead(p) for u, p in active))
    taus, betas = list(spec.tau), list(spec.beta)
    for u, p in active:
        more_taus, more_betas = u.sim_terms(p)
        taus += list(more_taus)
        betas += list(more_betas)
    spacing = min(1.0 / spec.rate / 4.0, min(taus) / 40.0)
    grid = _fine_grid(program, t_samples, spacing, delay)
    # the load on the grid, with steps placed exactly: duplicate each breakpoint time
    path = SignalPath(t_samples, program, spec.full_scale, spec.gain, spec.offset, spec.rate, grid,
                      program.sample(grid), program.sample_before(grid),
                      temperature_fn(grid) if temperature_fn is not None else None, taus)
    s_after, s_before = path.u_after, path.u_before
    for u, p in active:
        s_after, s_before = u.sim_instant(path, p, s_after, s_before)
    path.s_after, path.s_before = s_after, s_before
    h_after, h_before = s_after, s_before
    for u, p in active:
        h_after, h_before = u.sim_creep_input(path, p, h_after, h_before)
    path.h_after, path.h_before = h_after, h_before
    lags = _lags(path, active)
    y = s_after + lags @ np.array(betas)
    for u, p in active:
        y = u.sim_response(path, p, y)
    y = spec.offset + spec.gain * y
    for u, p in active:
        y = u.sim_output(path, p, y)
    out = next((o for o in (u.sim_sample(path, p, y) for u, p in active) if o is not None), None)
    if out is None:
        out = np.interp(t_samples, grid, y)
    for u, p in active:
        out = u.sim_sampled(path, p, out)
    return out


def _lags(path: SignalPath, active: list) -> np.ndarray:
    """The creep terms' states on the fine grid, driven by the creep input, with the hidden
    effects' factors on their retardation times and changes of their states."""
    grid, taus = path.grid, path.taus
    init = np.full(len(taus), path.h_after[0])
    lags = lag_states(grid, path.h_after, taus, hold="linear", initial=init, u_before=path.h_before)
    factor = np.ones((len(grid) - 1, 1))
    varying = False
    for u, p in active:
        changed = u.sim_tau_factor(path, p, factor)
        if changed is not None:
            factor, varying = changed, True
    if varying:
        # steps at grid points: varying_lag_states takes the value after; a step inside a
        # fine step is at most one fine step late, which the fine spacing makes negligible
        lags = varying_lag_states(grid, path.h_after, np.array(taus)[None, :] * factor, hold="linear",
                                  initial=init)
    for u, p in active:
        lags = u.sim_lags(path, p, lags)
    return lags


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
    problems = _record_problems(spec.hidden)
    plain = {k: v for k, v in spec.hidden.items() if k in problems}
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


def generate(spec: Spec) -> Synthetic:
    """Simulate a record from a :class:`Spec`.

    Returns
    -------
    Synthetic
        The record (``time``, ``load``, ``signal`` and, when asked for or needed by a hidden
        thermal effect, ``temperature``) and the truth.
    """
    rng = np.random.default_rng(spec.seed)
    active = _active(spec.hidden)
    program = make_program(spec.program, spec.duration, rng, spec.full_scale, spec.start_loaded,
                           max(abs(t) for t in spec.tau), spec.start,
                           unload=any(u.unloads for u, _ in active),
                           one_sided=any(u.one_sided for u, _ in active))
    t = sample_times(spec.duration, spec.rate, rng, spec.jitter, spec.gaps, spec.start)
    thermal = {u.name for u, _ in active if "temperature" in u.needs}
    needs_temp = spec.temperature or bool(thermal)
    temp_fn, temp_mean = temperature_profile(t[0], t[-1], rng)
    hidden = {k: dict(v) for k, v in spec.hidden.items()}
    for name in thermal:
        hidden[name].setdefault("reference_temperature", temp_mean)
    spec = replace(spec, hidden=hidden)
    clean = simulate_signal(spec, program, t, temp_fn)
    noise = sample_noise(t, spec.noise, rng)
    spec, noise = _detectable(spec, program, t, temp_fn, clean, noise)
    signal = clean + noise
    if spec.noise.lsb > 0:
        signal = np.round(signal / spec.noise.lsb) * spec.noise.lsb
    load = program.sample(t)
    for u, p in _active(spec.hidden):
        if u.record_problem:
            signal, problem = u.damage(p, t, load, signal, clean, rng)
            spec = replace(spec, hidden={**spec.hidden, u.name: problem})
    metadata = {"units.load": "N", "units.signal": "V", "synth.seed": str(spec.seed),
                "synth.program": spec.program}
    temperature = temp_fn(t) if needs_temp else None
    record = Record(t, load, signal, temperature=temperature, metadata=metadata,
                    source=f"synthetic record (seed {spec.seed})")
    return Synthetic(record, spec, program)


def _record_problems(hidden: dict) -> set[str]:
    """The hidden faults of the record itself."""
    return {u.name for u, _ in _active(hidden) if u.record_problem}


def _detectable(spec: Spec, program: LoadProgram, t, temp_fn, clean, noise) -> tuple:
    """The spec and the noise, the noise scaled down (the same realisation) until the hidden
    effects reach the spec's ``detectable_z`` (and, for effects no template describes, stay
    visible: :data:`VISIBLE_RATIO`)."""
    problems = _record_problems(spec.hidden)
    physical = {k: v for k, v in spec.hidden.items() if k not in problems}
    if not physical or spec.detectable_z <= 0:
        return spec, noise
    z = detectability(spec, program, t, temp_fn, clean, noise)
    f = min(1.0, z / spec.detectable_z)
    untemplated = [u for u, _ in _active(physical) if not u.templated]
    if untemplated:
        # and visible against the noise floor: the baseline fitted to the noise-free record
        # misses it by VISIBLE_RATIO times the noise's RMS
        rms_rest = _baseline_misfit(t, program.sample(t), clean,
                                    terms=max(u.baseline_terms for u in untemplated))
        rms_noise = float(np.std(noise))
        if rms_noise > 0:
            f = min(f, rms_rest / (VISIBLE_RATIO * rms_noise))
    if f < 1.0:
        # the same noise realisation, scaled (every component is linear in its size)
        noise = noise * f
        spec = replace(spec, noise=scaled_noise(spec.noise, f))
    return spec, noise


# --------------------------------------------------------------------------------------------
# Randomised cases
# --------------------------------------------------------------------------------------------

def _programs_for(unit: Simulated | None) -> tuple:
    """The kinds of load program that let ``unit`` show (None: a clean record)."""
    return PROGRAMS if unit is None or unit.programs is None else tuple(unit.programs)


#: Load programs that let each effect show (e.g. load-dependent effects need several levels).
PROGRAMS_FOR = {**{u.name: _programs_for(u) for u in hidden_units()}, None: PROGRAMS}


def random_hidden(effect: str | None, rng: np.random.Generator, tau: float, rate: float,
                  duration: float, beta: float, forms: bool = True, signal_scale: float = 1.0,
                  form: str | None = None, gain: float = 1.0) -> dict:
    """Random parameters of a hidden effect, at sizes a designer would care about
    (``signal_scale``: the full-scale signal, for effects in signal units; ``gain``: signal per
    load unit). ``form``: one of :data:`FORMS` (default: the effect's default draw, with the
    old effects' random mixture of forms when ``forms``)."""
    if effect is None:
        return {}
    unit = _unit(effect)
    if unit is None:
        known = _known_names() if form is not None else _physical_names()
        raise InputError(f"unknown effect '{effect}' (known: {', '.join(known)})")
    scales = Scales(tau, rate, duration, beta, signal_scale, gain)
    return {effect: unit.random_parameters(rng, scales, form, forms)}


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
    known = _known_names()
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
    unit = _unit(effect)
    choices = list(programs or _programs_for(unit))
    irregular_now = rng.uniform() < irregular
    hidden = random_hidden(effect, rng, tau, r, dur, beta, forms, abs(gain) * fs, form, gain)
    if unit is not None:
        unit.finish_draw(hidden[effect], rng, n)
    if relaxation:
        beta = -beta
        if unit is not None:
            unit.relax(hidden[effect])
    if unit is not None:
        choices = unit.program_choices(hidden[effect], tau, choices, bool(programs))
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
DEMO_SPEC = Spec(hidden={SLOW_RECOVERY.name: {"tau_recovery": 150.0}}, beta=(0.03,), tau=(45.0,),
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
        unit = _unit(name)
        out[name] = unit.truth(p, synthetic) if unit is not None else {}
    return out
