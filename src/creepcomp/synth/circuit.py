"""Synthetic records of a built correction network with a hidden circuit fault, for tests, the
demo and benchmarks.

The sensor creeps (a Prony series); the design is the exact network for it, snapped to E24/E6
parts; the network as built carries a hidden circuit fault. Both channels (``signal`` and
``corrected``) are simulated exactly for the load program, then sampled, with independent
measurement noise. Everything random takes a seed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from creepcomp.analog.sizing import size
from creepcomp.diagnose.circuit import circuit_effect, circuit_effects, exact_equivalents
from creepcomp.diagnose.effects.capacitor_value import EFFECT as CAPACITOR_VALUE
from creepcomp.errors import InputError
from creepcomp.fit.circuit import prepare, residual_of
from creepcomp.fit.noise import spectral_variance
from creepcomp.io.jsonfiles import Design, write_design
from creepcomp.io.records import Record, write_record
from creepcomp.lti import LagExpansion, cascade_lags
from creepcomp.model import CreepModel
from creepcomp.synth.common import (DETECTABLE_Z, DISTINCT_Z, PRECISE_TO, NoiseSpec, heldout_z, sample_noise,
                                    scaled_noise)
from creepcomp.synth.sensor import PROGRAMS, make_program, sample_times

__all__ = ["CircuitSpec", "CircuitSynthetic", "generate_circuit", "circuit_detectability",
           "alternative_faults", "fault_parts", "scaled_part", "residual_at", "circuit_precision", "random_fault",
           "random_circuit_spec", "DEMO_CIRCUIT_SPEC", "demo_circuit_record", "write_demo_circuit"]


@dataclass(frozen=True)
class CircuitSpec:
    """Everything that defines a synthetic record of a built network."""

    hidden: dict = field(default_factory=dict)
    beta: tuple = (0.03,)
    tau: tuple = (45.0,)
    gain: float = 1.0
    offset: float = 0.0
    corrected_offset: float = 0.0
    rate: float = 10.0
    duration: float = 1800.0
    program: str = "staircase"
    jitter: float = 0.0
    noise: NoiseSpec = NoiseSpec(white=1e-4)
    corrected_noise: NoiseSpec = NoiseSpec(white=1e-4)
    drive: str = "continuous"
    seed: int = 0
    detectable_z: float = 0.0
    distinct_z: float = 0.0
    precise_to: float = 0.0
    """``drive``: ``continuous``, the network sees the sensor's continuous signal (measurement
    noise on both channels is the ADC's); ``samples``, it is driven by the sampled, noisy
    signal taken linear between samples, as a simulator would drive a netlist with a record.
    ``detectable_z``, ``distinct_z``, ``precise_to``: see :func:`generate_circuit` (0: noise
    as given)."""


@dataclass(frozen=True)
class CircuitSynthetic:
    """A synthetic record, the nominal design and the network as really built."""

    record: Record
    design: Design
    built: object
    spec: CircuitSpec
    noise_factor: dict = field(default_factory=dict)
    """``noise_factor``: what each rule of :func:`generate_circuit` asked the noise to be
    multiplied by (1: left as drawn)."""


def generate_circuit(spec: CircuitSpec) -> CircuitSynthetic:
    """Simulate a record with ``signal`` and ``corrected`` from a :class:`CircuitSpec`.

    With ``spec.detectable_z`` the noise of both channels is scaled down where the fault
    would not stand out of it (see :func:`circuit_detectability`); with ``spec.distinct_z``
    where the part of its signature that no other circuit fault mimics (to first order, see
    :func:`alternative_faults`) would not stand out that far; with ``spec.precise_to``
    also where the record would not determine the fault's parts (``C``, ``R``) to that
    relative 1-sigma uncertainty (see :func:`circuit_precision`)."""
    rng = np.random.default_rng(spec.seed)
    model = CreepModel(spec.beta, spec.tau)
    design = Design(model, size(model).chosen, {"rule": "exact"})
    built = design.network
    for effect, params in spec.hidden.items():
        params = dict(params)
        built = circuit_effect(effect).apply_fault(built, params, params.pop("cell", None))
    program = make_program(spec.program, spec.duration, rng, 1.0, False, max(spec.tau), 0.0, unload=True)
    t = sample_times(spec.duration, spec.rate, rng, spec.jitter, 0, 0.0)
    g = model.lag_expansion()
    clean = spec.offset + spec.gain * program.response(g, t)
    signal_noise = sample_noise(t, spec.noise, rng)
    output_noise = sample_noise(t, spec.corrected_noise, rng)

    def output(network, signal):
        if spec.drive != "continuous":
            return network.lag_expansion().simulate(t, signal, initial="settled")
        h = network.lag_expansion()
        D, R, q = cascade_lags(1.0, [g.gains], [g.taus], h.direct, [h.gains], [h.taus])
        return h.dc_gain * spec.offset + spec.gain * program.response(LagExpansion(float(D[0]), tuple(R[0]),
                                                                                   tuple(q[0])), t)

    def record(signal_noise, output_noise):
        signal = clean + signal_noise
        corrected = spec.corrected_offset + output(built, signal) + output_noise
        return Record(t, program.sample(t), signal, corrected=corrected,
                      metadata={"units.load": "N", "units.signal": "V", "synth.seed": str(spec.seed),
                                "synth.program": spec.program},
                      source=f"synthetic built network (seed {spec.seed})")

    factors = {}
    if spec.hidden and (spec.detectable_z > 0 or spec.distinct_z > 0 or spec.precise_to > 0):
        nominal = design.network.lag_expansion()
        # what the model's residual holds: the output's noise, and for a network that saw the
        # clean signal, the signal's noise through the simulated network
        residual_noise = output_noise - (nominal.simulate(t, signal_noise)
                                         if spec.drive == "continuous" else 0.0)
        nominal_out = output(design.network, clean)
        signature = output(built, clean) - nominal_out
        if (spec.distinct_z > 0 or spec.precise_to > 0) and len(spec.hidden) != 1:
            raise ValueError("distinct_z and precise_to judge one hidden fault: the spec has "
                             f"{len(spec.hidden)}")
        (effect, params), *_ = spec.hidden.items()
        where = circuit_effect(effect).fault_part(design.network, params.get("cell"), params.get("part"))
        if spec.detectable_z > 0:
            z = circuit_detectability(t, signature, nominal.taus, residual_noise)
            factors["detectability"] = min(1.0, z / spec.detectable_z)
        if spec.distinct_z > 0:
            z = min(circuit_detectability(t, signature, nominal.taus, residual_noise,
                                          [output(net, clean) - nominal_out])
                    for net in alternative_faults(design.network, effect, spec.duration, part=where))
            factors["distinctness"] = min(1.0, z / spec.distinct_z)
        if spec.precise_to > 0:
            factors["precision"] = _precision_factor(spec, design, effect, params,
                                                     lambda f: record(signal_noise * f, output_noise * f),
                                                     residual_noise)
        f = min(factors.values())
        if f < 1.0:
            signal_noise, output_noise = signal_noise * f, output_noise * f
            spec = replace(spec, noise=scaled_noise(spec.noise, f),
                           corrected_noise=scaled_noise(spec.corrected_noise, f))
    return CircuitSynthetic(record(signal_noise, output_noise), design, built, spec, factors)


def _precision_factor(spec: CircuitSpec, design: Design, effect: str, params: dict, record_with, noise) -> float:
    """Factor on the noise for which the record determines the fault's parts to
    ``spec.precise_to`` (see :func:`circuit_precision`; ``record_with(f)``: the record with
    its noise times ``f``). The priors of the diagnosis's decays are relative to the noise, so
    the factor is found in a few steps."""
    fault = dict(params)
    cell = fault.pop("cell", None)
    f = 1.0
    for _ in range(4):
        data = prepare(record_with(f), design)
        sd = circuit_precision(lambda part, h: residual_at(data, effect, scaled_part(effect, fault, part, h), cell),
                               fault_parts(effect), noise * f)
        worst = max(sd.values())
        if worst <= 1.05 * spec.precise_to:
            break
        f *= spec.precise_to / worst
    return f


def circuit_detectability(t: np.ndarray, signature: np.ndarray, taus, noise: np.ndarray,
                          also: list | None = None) -> float:
    """How far a circuit fault stands out of the noise: the held-out ``z`` (see
    :func:`creepcomp.fit.evidence.compare`) that its signature (output as built minus output as
    designed, noise-free) would give with the fault's parameters known, once what the model
    absorbs anyway is removed (offset, decays at the network's poles, and to be safe a linear
    trend) and the directions ``also`` (e.g. another fault's signature)."""
    x = t - t[0]
    directions = np.column_stack([np.ones_like(t), x] + [np.exp(-x / p) for p in taus] + list(also or []))
    coef, *_ = np.linalg.lstsq(directions, signature, rcond=None)
    return heldout_z(signature - directions @ coef, noise)


def alternative_faults(network, effect, duration: float, size: float = 1e-3,
                       part: str | None = None) -> list:
    """Small faults of every other circuit kind (each capacitor or resistor where it applies):
    each one's signature is what that effect would explain of a fault's signature to first
    order. An absorption stands for the family of its time constants by three of them (0.7,
    2.2 and 7 times the cell's R C, at most half the ``duration``, s), as in
    :func:`random_fault` (each effect's
    :meth:`~creepcomp.diagnose.effects._network.NetworkEffect.small_faults`; ``effect``:
    identifier or object). Faults exactly equivalent to ``effect`` on ``part`` (see
    :func:`creepcomp.diagnose.circuit.exact_equivalents`) are left out: no record tells them
    apart, the diagnosis lists them as alternatives."""
    me = circuit_effect(effect)
    same = set(exact_equivalents(network, me, part))
    out = []
    for other in circuit_effects():
        if other is me and not other.alternatives_on_other_parts:
            continue
        out.extend(net for where, net in other.small_faults(network, size, duration)
                   if (other.name, where) not in same and not (other is me and where == part))
    return out


def fault_parts(effect) -> tuple:
    """The parts a circuit fault's parameters describe, as the diagnosis reports them
    (:attr:`~creepcomp.diagnose.effects._network.NetworkEffect.fault_parts`; ``effect``:
    identifier or object): ``C`` of a capacitor off its value, ``R`` of a resistance, ``C``
    and ``R`` of an absorption branch."""
    return tuple(circuit_effect(effect).fault_parts)


def scaled_part(effect, params: dict, part: str, h: float) -> dict:
    """A fault's parameters with one of its parts (see :func:`fault_parts`) multiplied by
    ``exp(h)`` (:meth:`~creepcomp.diagnose.effects._network.NetworkEffect.scaled_part`)."""
    return circuit_effect(effect).scaled_part(params, part, h)


def residual_at(data, effect, values: dict, cell: int | None = None) -> np.ndarray:
    """Residual of the nominal network with one circuit fault at ``values`` (natural units;
    ``cell``: its capacitor, by default the largest), the linear terms solved as in every
    fit (:func:`creepcomp.fit.circuit.residual_of`)."""
    return residual_of(data, circuit_effect(effect).apply_fault(data.design.network, values, cell))


def circuit_precision(residual, parts: tuple, noise: np.ndarray) -> dict:
    """Relative 1-sigma uncertainty of each part of a circuit fault that a record leaves: the
    spread of the least-squares estimate of its logarithm from the model's sensitivities at
    the true values (``residual(part, h)``: the record's residual under the diagnosis's model
    with that part multiplied by ``exp(h)``, its linear terms solved), the noise's spectrum
    from ``noise``."""
    h = 1e-4
    jac = np.column_stack([(residual(p, h) - residual(p, -h)) / (2.0 * h) for p in parts])
    weights = np.linalg.pinv(jac)
    return {p: math.sqrt(max(spectral_variance(w, noise), 0.0)) for p, w in zip(parts, weights)}


def random_fault(effect, rng: np.random.Generator, design: Design, duration: float) -> dict:
    """A random fault of a kind (identifier or effect object; None: no fault), large enough
    to matter at the record's noise (see :func:`random_circuit_spec`), with its physical
    parameters (:meth:`~creepcomp.diagnose.effects._network.NetworkEffect.random_fault`): a
    capacitor's fault names its ``cell`` (a random one of the network's capacitors), a
    resistor's its ``part``. An absorption's time constant is at most half the record's
    ``duration`` (s), so the record shows it."""
    if effect is None:
        return {}
    return circuit_effect(effect).random_fault(rng, design.network, duration)


def random_circuit_spec(effect: str | None, seed: int, rate: tuple = (2.0, 50.0),
                        duration: tuple = (600.0, 3600.0), distinct_z: float = DISTINCT_Z,
                        precise_to: float = PRECISE_TO) -> CircuitSpec:
    """A randomised record: sensor creep (one term, or two and a two-cell network in 30 % of
    the records; for a fault that also sits in lag networks, a wrong resistor, an overshooting
    sensor and its lag network in 30 % of them), sampling ``rate`` (Hz, log-uniform), ``duration`` (s), any load program,
    white noise 1e-5 to 3e-4 of the step on the signal and within a factor e of it on
    ``corrected`` (plus, each in a third of the records, coloured noise of 0.5-2 times that
    level with a correlation time of 0.5-20 s, and a random-walk drift of 1-10 times it per
    hour), measuring offsets, either way of driving the network, and the fault. The record
    keeps its fault detectable (z 10), ``distinct_z`` from the others and its parts determined
    to ``precise_to`` (see :func:`generate_circuit`)."""
    rng = np.random.default_rng(seed)
    tau = (float(math.exp(rng.uniform(math.log(15.0), math.log(150.0)))),)
    beta = (float(rng.uniform(0.01, 0.05)),)
    if rng.uniform() < 0.3:  # a two-term sensor and its two-cell Foster network
        tau += (tau[0] * float(rng.uniform(5.0, 20.0)),)
        beta += (float(rng.uniform(0.005, 0.03)),)
    # a fault that can sit in a lag network (a wrong resistor) is drawn in lag networks too
    # (an overshooting sensor, beta < 0): the other faults sit on a series capacitor, which a
    # lag network does not have (drawn only for such faults, so that the other faults' records
    # stay as they were)
    if effect is not None and circuit_effect(effect).in_lag_networks and rng.uniform() < 0.3:
        beta = tuple(-b for b in beta)
    try:
        design = Design(CreepModel(beta, tau), size(CreepModel(beta, tau)).chosen)
    except InputError:  # the slow term needs parts beyond the E-series ranges: one term
        beta, tau = beta[:1], tau[:1]
        design = Design(CreepModel(beta, tau), size(CreepModel(beta, tau)).chosen)
    record_duration = float(rng.uniform(*duration))
    hidden = {effect: random_fault(effect, rng, design, record_duration)} if effect else {}
    gain = float(math.exp(rng.uniform(math.log(1e-4), math.log(1.0))))
    level = float(math.exp(rng.uniform(math.log(1e-5), math.log(3e-4))))
    out_level = level * math.exp(rng.uniform(-1.0, 1.0))
    # the output's measuring chain: coloured noise in a third of the records, drift in a third
    coloured = out_level * rng.uniform(0.5, 2.0) if rng.uniform() < 1 / 3 else 0.0
    drift = out_level * rng.uniform(1.0, 10.0) if rng.uniform() < 1 / 3 else 0.0
    out_noise = NoiseSpec(white=out_level * gain, coloured=coloured * gain,
                          correlation_time=float(rng.uniform(0.5, 20.0)), drift=drift * gain)
    return CircuitSpec(hidden=hidden, beta=beta, tau=tau, gain=gain,
                       offset=float(rng.normal(0, 0.05)) * gain,
                       corrected_offset=float(rng.normal(0, 0.01)) * gain,
                       rate=float(math.exp(rng.uniform(*np.log(rate)))),
                       duration=record_duration,
                       program=str(rng.choice(PROGRAMS)), jitter=float(rng.choice([0.0, 0.2])),
                       noise=NoiseSpec(white=level * gain), corrected_noise=out_noise,
                       drive=str(rng.choice(["continuous", "samples"])), seed=seed,
                       detectable_z=DETECTABLE_Z, distinct_z=distinct_z, precise_to=precise_to)


#: The demo's built network: the default sensor (3 %, 45 s) read at 5 Hz for 30 minutes
#: through a staircase, its network built with a capacitor 12 % below its nominal value.
DEMO_CIRCUIT_SPEC = CircuitSpec(hidden={CAPACITOR_VALUE.name: {"C": 0.88 * 15e-6}}, beta=(0.03,), tau=(45.0,),
                                gain=1e-4, offset=2e-6, corrected_offset=-1e-6, rate=5.0, duration=1800.0,
                                program="staircase", noise=NoiseSpec(white=2e-9),
                                corrected_noise=NoiseSpec(white=2e-9), seed=2009)


def demo_circuit_record() -> CircuitSynthetic:
    """The record bundled as ``data/built_network.csv`` with its nominal design
    ``data/built_network.design.json`` (see :data:`DEMO_CIRCUIT_SPEC`)."""
    syn = generate_circuit(DEMO_CIRCUIT_SPEC)
    meta = dict(syn.record.metadata)
    meta.update({"design": "built_network.design.json",
                 "description": "synthetic sensor and its built correction network with a hidden fault "
                                "(creepcomp.synth.circuit.DEMO_CIRCUIT_SPEC)"})
    record = replace(syn.record, metadata=meta, source="built_network.csv")
    return CircuitSynthetic(record, syn.design, syn.built, syn.spec)


def write_demo_circuit(folder) -> tuple:
    """Write the demo's built-network record and its nominal design into ``folder``."""
    syn = demo_circuit_record()
    folder = Path(folder)
    return (write_record(folder / "built_network.csv", syn.record, digits=10),
            write_design(folder / "built_network.design.json", syn.design))
