"""Diagnosis of a built correction network (``docs/diagnosis.md``, circuit side).

When a record holds both the sensor's raw ``signal`` and the measured output of the analog
network (``corrected``), the nominal network of the design is simulated on the measured
signal and compared with ``corrected`` (the model of the measured output, its fit and
held-out prediction are in :mod:`creepcomp.fit.circuit`). The circuit-side effects of
:mod:`creepcomp.diagnose.effects` are extensions of the network with physical parameters;
each is fitted on top of the current model and kept while the evidence supports it, by the
same rules as the sensor side (:func:`creepcomp.fit.evidence.compare_with_halves`: BIC lower
by :data:`~creepcomp.fit.evidence.BIC_STRONG` and held-out blocks predicted better by
:data:`~creepcomp.fit.evidence.HELDOUT_Z` standard deviations); of several supported, the
lowest BIC unless another predicts the record's halves better (:func:`choose`). A generic
extra lag tried on top says whether structure remains that no named effect explains
(``unexplained``); with no finding the answer is ``none`` -- but only when the nominal
network meets the measured output to the record's noise floor (:func:`~creepcomp.diagnose.output_drift.circuit_noise_floor`,
misfit ratio at most :data:`~creepcomp.fit.noise.MISFIT_LIMIT`); otherwise ``unexplained``
with the misfit that remains, as also after named findings that leave misfit above the floor.

Several faults can change the network's output alike (R2 low and a load resistance; R1 low
and leakage across C1). After each step the candidates that fit the record as well as the
chosen one (:func:`equivalent`) are its ``alternatives``; the cause among them is the most
probable under the faults' prior (:func:`fault_prior`, :func:`most_probable`), and each
alternative carries the measurement that would tell it from the cause
(:func:`separating_measurement`). A fit that needs a part far off anything a built network
holds (each effect's ``implausible``), or misfit far above the floor that no plausible fault
removes, says that the design does not match the record (``design_mismatch``): no part is
named and no fix proposed.

Every circuit effect is one module of :mod:`creepcomp.diagnose.effects` (a
:class:`~creepcomp.diagnose.effects._network.NetworkEffect`) that says all of the above for
its fault; this module iterates over them (:func:`circuit_effects`) and names none. The
search (:func:`diagnose_circuit`) runs in named steps: :func:`screen` fits every candidate
(:class:`Candidate`), :func:`decide` chooses (:class:`StepChoice`), :func:`step_trials` and
:func:`step_finding` record the step, :func:`conclude` gives the verdict.

The extension is the as-built network: written as a design file, checked in ngspice on the
same record, and the fix is the single part change that leaves the least residual creep.
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field, replace

import numpy as np

from creepcomp.analog.faults import suggest_fixes
from creepcomp.analog.quality import step_peak
from creepcomp.diagnose import effects as effects_pkg
from creepcomp.diagnose.output_drift import (SLOW_SHARE, OutputDrift, circuit_noise_floor, floor_window, output_drift,
                                              slow_share)
from creepcomp.diagnose.effects._network import (PART_FACTOR, apply_fault, circuit_effect, circuit_effects,
                                                 exact_equivalents, fault_part)
from creepcomp.fit.circuit import (CircuitData, CircuitFit, fit_model, halves, prepare, uncertainty,
    with_heldout)
from creepcomp.fit.evidence import BIC_STRONG, HELDOUT_Z, Evidence, compare, compare_with_halves
from creepcomp.fit.noise import (MISFIT_LIMIT, NoiseFloor, autocorrelation, explained_share, fit_noise, ljung_box,
                                 misfit_ratio, rows_for, whiten)
from creepcomp.fit.structure import Applied
from creepcomp.io.jsonfiles import Design
from creepcomp.io.formats import read_any
from creepcomp.io.records import Record
from creepcomp.display import Shown
from creepcomp.units import format_quantity

__all__ = ["MAX_EFFECTS", "EQUIVALENT_BIC", "MISMATCH_RATIO", "PART_FACTOR", "fault_prior", "FAULT_PRIOR",
           "CIRCUIT_EFFECTS", "circuit_effects", "circuit_effect", "apply_fault", "fault_part", "exact_equivalents",
           "evidence", "equivalent", "most_probable", "separating_measurement",
           "CircuitFinding", "CircuitTrial", "CircuitDiagnosis", "Candidate", "StepChoice", "CircuitSearch",
           "CircuitConclusion", "diagnose_circuit", "search_effects", "screen", "decide", "step_trials",
           "step_finding", "conclude", "choose", "at_bound", "ngspice_check", "combine"]

#: Most circuit effects added one after the other.
MAX_EFFECTS = 3
#: Two explanations fit a record as well when their BIC differ by less than this (below
#: "strong" evidence, 6, on the Kass-Raftery scale) and neither predicts the held-out blocks
#: better by :data:`~creepcomp.fit.evidence.HELDOUT_Z`, nor each half of the record from the
#: other (see :func:`equivalent`).
EQUIVALENT_BIC = 6.0
#: Misfit ratio (residual RMS over the noise floor) that no finding may leave: above it the
#: design does not match the record (no single plausible fault explains it).
MISMATCH_RATIO = 10.0


def fault_prior() -> dict:
    """The prior of the circuit faults (each effect's
    :attr:`~creepcomp.diagnose.effects._network.NetworkEffect.prior`), by identifier, most
    common first: how often each happens in an assembled network (share of built networks
    that carry it; assumed by the project, not measured) and what values a built network can
    hold (beyond them the fit is taken as a design that does not match the record). Among
    explanations the record cannot tell apart, the cause is the one of highest
    ``rate * exp(-BIC / 2)`` (:func:`most_probable`)."""
    ranked = sorted(circuit_effects(), key=lambda e: -e.prior.rate)  # ties in vocabulary order
    return {e.name: e.prior.to_dict() for e in ranked}


#: :func:`fault_prior` of the registry's effects.
FAULT_PRIOR = fault_prior()
#: The circuit effects' identifiers, in vocabulary order.
CIRCUIT_EFFECTS = tuple(e.name for e in circuit_effects())


def evidence(data: CircuitData, current: CircuitFit, rich: CircuitFit, always_halves: bool = False) -> Evidence:
    """Evidence for ``rich`` over ``current`` (both with held-out predictions) by the sensor
    side's rule (:func:`~creepcomp.fit.evidence.compare_with_halves`): BIC and interleaved
    held-out blocks, and when the richer model's residual holds slow noise (drift of the
    measuring chain), also each half predicted from the other, which drift that a slow
    extension (absorption, leakage) follows between interleaved blocks does not allow.
    ``always_halves``: in any case (the catch-all)."""
    return compare_with_halves(current, rich, lambda: (halves(data, current), halves(data, rich)),
                               always_halves)


# --------------------------------------------------------------------------------------------
# The search
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class CircuitFinding:
    """A circuit effect the evidence supports (or ``unexplained``)."""

    effect: str
    parameters: dict
    evidence: Evidence
    part: str | None = None
    uncertainty: dict = field(default_factory=dict)
    alternatives: tuple = ()
    note: str = ""
    """``alternatives``: explanations that fit the record as well (dicts with ``effect``,
    ``part``, ``parameters``, ``delta_bic`` against this one and the ``measurement`` that
    would tell them apart); ``note``: e.g. ``design_mismatch: ...``."""

    def to_dict(self) -> dict:
        """JSON form (contract keys first)."""
        out = {"effect": self.effect, "parameters": self.parameters, "evidence": self.evidence.to_dict(),
               "alternatives": [dict(a) for a in self.alternatives], "side": "circuit",
               "uncertainty": self.uncertainty}
        if self.part:
            out["part"] = self.part
        if self.note:
            out["note"] = self.note
        return out


@dataclass(frozen=True)
class CircuitTrial:
    """One candidate tried at one step."""

    step: int
    effect: str
    part: str | None
    evidence: Evidence
    outcome: str

    def to_dict(self) -> dict:
        """JSON form."""
        out = {"step": self.step, "effect": self.effect, "side": "circuit", "outcome": self.outcome}
        if self.part:
            out["part"] = self.part
        out.update(self.evidence.to_dict())
        return out


@dataclass(frozen=True, eq=False)
class CircuitDiagnosis(Shown):
    """Result of :func:`diagnose_circuit` (equal only to itself: it holds arrays)."""

    data: CircuitData
    baseline: CircuitFit
    extended: CircuitFit
    findings: tuple
    trials: tuple
    catch_all: Evidence | None
    fixes: tuple
    seconds: float
    spice_check: dict | None = None
    floor: NoiseFloor | None = None
    mismatch: str | None = None
    drift: OutputDrift | None = None
    """``floor``: the noise floor of the comparison (:func:`~creepcomp.diagnose.output_drift.circuit_noise_floor`, with the
    output's drift when ``drift`` is set); ``mismatch``: why the design does not match the
    record (None: it does); ``drift``: a drift of the output's measuring chain that the floor
    counts (:func:`~creepcomp.diagnose.output_drift.output_drift`)."""

    @property
    def cause(self) -> str:
        """The most important finding's effect, ``none`` or ``unexplained``."""
        return self.findings[0].effect if self.findings else "none"

    def misfit(self, fit: CircuitFit) -> float | None:
        """Residual RMS of a model over the noise floor."""
        return misfit_ratio(fit.rms, self.floor) if self.floor is not None else None

    @property
    def explained_share(self) -> float | None:
        """Share of the nominal network's misfit variance above the floor that the as-built
        network removes."""
        return explained_share(self.baseline.rms, self.extended.rms, self.floor) if self.floor else None

    def verdict(self) -> str:
        """One sentence on what the circuit side found, against the noise floor."""
        base = self.misfit(self.baseline)
        if self.mismatch:
            return (f"the design does not match the record: the nominal network misses the measured "
                    f"output by {base:.3g} times the noise floor, and {self.mismatch}")
        if self.cause == "none" and self.drift is not None:
            d = self.drift
            return (f"the nominal network explains the measured output to its noise (misfit {base:.3g} times "
                    f"the noise floor), counting as noise a slow drift of the output's measuring chain "
                    f"(RMS {d.format(d.rms)}, peak-to-peak {d.format(d.span)}): over the white noise "
                    f"alone the misfit is {d.misfit_ratio_white:.3g} times, {d.misfit_ratio_without_drift:.3g} "
                    f"without the drift, and no circuit effect nor a generic lag driven by the signal follows "
                    f"it (re-zero or log the output channel's offset to confirm)")
        if self.cause == "none":
            return (f"the nominal network explains the measured output to its noise "
                    f"(misfit {base:.3g} times the noise floor)")
        ext = self.misfit(self.extended)
        named = [f.effect + (f" ({f.part})" if f.part else "") for f in self.findings if f.effect != "unexplained"]
        text = (f"the nominal network misses the measured output by {base:.3g} times the noise floor; "
                + (f"as built with {', '.join(named)} by {ext:.3g} times" if named else "no circuit effect explains it"))
        if named and ext > MISFIT_LIMIT:
            text += " (misfit above the floor remains: unexplained)"
        return text

    @property
    def as_built(self) -> Design:
        """The as-built network as a design (the nominal design's creep block)."""
        extra = {"as_built": {"from": self.data.source,
                              "findings": [f.to_dict() for f in self.findings]}}
        return Design(self.data.design.model, self.extended.network, extra)

    @property
    def gain(self) -> dict:
        """Held-out residual RMS ratio and the ratio of the simulated network output's error
        against the measured ``corrected`` (nominal / as built)."""
        b, e = self.baseline, self.extended
        held = b.heldout.rms / e.heldout.rms if b.heldout and e.heldout and e.heldout.rms > 0 else None
        return {"heldout_rms_ratio": held, "correction_error_ratio": b.rms / e.rms if e.rms > 0 else None,
                "correction_error_baseline": b.rms, "correction_error_extended": e.rms}

    @property
    def residual_creep(self) -> dict:
        """Peak residual creep of a load step (fraction of the step) of the nominal network
        and of the as-built one, for the design's creep model."""
        model = self.data.design.model
        return {"nominal": step_peak(model, self.baseline.network)[0],
                "as_built": step_peak(model, self.extended.network)[0]}

    def explanation(self) -> list[str]:
        """The verdict and, for each finding with alternatives, what the record cannot tell
        apart and the measurement that would: lines of text for the report."""
        lines = [self.verdict()]
        for f in self.findings:
            for a in f.alternatives:
                params = ", ".join(f"{k} = {_format(k, v)}" for k, v in a["parameters"].items())
                mine = ", ".join(f"{k} = {_format(k, v)}" for k, v in f.parameters.items())
                lines.append(f"{f.effect} {f.part or ''} ({mine}) fits the record as well as {a['effect']} "
                             f"{a['part'] or ''} ({params}), BIC {a['delta_bic']:+.1f}; {f.effect} is named, more "
                             f"probable under the prior ({circuit_effect(f.effect).prior.why}); to tell them apart: "
                             f"{a['measurement']}".replace("  ", " "))
        return lines

    def summary(self, fit: CircuitFit) -> dict:
        """Residual figures of one model."""
        rows = rows_for(self.data, None, 5)
        noise = fit_noise(fit.residual, rows)
        _, p = ljung_box(whiten(fit.residual, rows, noise))
        return {"residual_rms": fit.rms, "misfit_ratio": self.misfit(fit),
                "heldout_residual_rms": fit.heldout.rms if fit.heldout else None,
                "residual_rms_relative": fit.rms / self.data.scale, "bic": fit.bic,
                "structure": fit.describe(),
                "residual_lag1_autocorrelation": float(autocorrelation(fit.residual, 1)[1]),
                "whitened_ljung_box_p": p}

    def __repr__(self) -> str:
        return (f"<CircuitDiagnosis of {self.data.source!r}: cause {self.cause}, residual RMS "
                f"{format_quantity(self.baseline.rms, 'V')} nominal, {format_quantity(self.extended.rms, 'V')} "
                f"as built, {len(self.fixes)} fix{'' if len(self.fixes) == 1 else 'es'}>")

    def to_dict(self) -> dict:
        """The circuit side's JSON (``docs/diagnosis.md`` keys plus the as-built network and fix)."""
        return {"cause": self.cause, "findings": [f.to_dict() for f in self.findings],
                "baseline": self.summary(self.baseline), "extended": self.summary(self.extended),
                "gain": self.gain, "tried": [t.to_dict() for t in self.trials],
                "catch_all": self.catch_all.to_dict() if self.catch_all else None,
                "as_built": self.as_built.to_dict(), "residual_creep_peak": self.residual_creep,
                "fixes": [f.to_dict() for f in self.fixes],
                "spice_check": self.spice_check, "seconds": self.seconds,
                "noise_floor": self.floor.rms if self.floor else None,
                "noise_floor_method": self.floor.method if self.floor else None,
                "explained_share": self.explained_share, "design_mismatch": self.mismatch,
                "output_drift": self.drift.to_dict() if self.drift else None,
                "verdict": self.verdict(),
                "decision_rule": {"delta_bic_at_most": -BIC_STRONG, "heldout_z_at_least": HELDOUT_Z,
                                  "misfit_limit": MISFIT_LIMIT, "equivalent_bic_below": EQUIVALENT_BIC,
                                  "mismatch_ratio": MISMATCH_RATIO},
                "fault_prior": fault_prior()}


def _format(name: str, value: float) -> str:
    unit = {"R": "Ω", "C": "F", "tau": "s"}.get(name)
    if name == "fraction":
        return f"{100 * value:.3g} %"
    return format_quantity(value, unit) if unit else f"{value:.4g}"


def _candidates(data: CircuitData, current: CircuitFit, pool: list) -> list[Applied]:
    out = []
    taken = {a.name for a in current.applied}
    for effect in pool:
        if effect.name not in taken:
            out.extend(Applied(effect, settings) for settings in effect.network_settings(data.design.network))
    return out


def _fit_with(data: CircuitData, current: CircuitFit, applied: Applied) -> CircuitFit:
    known = {p.name: current.values[p.name] for p in current.params}
    starts = []
    for own in applied.effect.network_starts(data, dict(applied.settings)):
        s = dict(known)
        s.update({f"{applied.name}.{k}": v for k, v in own.items()})
        starts.append(s)
    return fit_model(data, current.applied + (applied,), starts)


# --------------------------------------------------------------------------------------------
# The decision loop: screen the candidates, choose, record, and the verdict at the end
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class Candidate:
    """A circuit effect fitted on top of the current model at one step of the search.

    Attributes
    ----------
    applied : Applied
        The effect and where it sits (its settings).
    fit : CircuitFit
        The model with it, with its held-out prediction.
    evidence : Evidence
        For it over the current model (:func:`evidence`).
    edge : str or None
        Its parameter at a bound of its range (:func:`at_bound`), if any.
    """

    applied: Applied
    fit: CircuitFit
    evidence: Evidence
    edge: str | None = None

    @property
    def effect(self):
        """The effect (a :class:`~creepcomp.diagnose.effects._network.NetworkEffect`)."""
        return self.applied.effect

    @property
    def name(self) -> str:
        """The effect's identifier."""
        return self.applied.name

    @property
    def settings(self) -> dict:
        """Where it sits (``cell`` or ``part``)."""
        return dict(self.applied.settings)

    @property
    def values(self) -> dict:
        """Its own fitted parameters (natural units)."""
        return self.applied.own(self.fit.values)

    def part(self, network) -> str | None:
        """The designator it sits on."""
        return self.effect.part_of(network, self.settings)

    def implausible(self, network) -> str | None:
        """Why its fitted values are no fault a built ``network`` holds, or None."""
        return self.effect.implausible(network, self.values, self.settings)

    def reported(self) -> dict:
        """Its parameters as a finding reports them."""
        return self.effect.report_network(self.values, self.settings)


@dataclass(frozen=True, eq=False)
class StepChoice:
    """What one step of the search decided.

    Attributes
    ----------
    tried : list of Candidate
        Every candidate of the step, in the order tried.
    best : Candidate or None
        The supported candidate :func:`choose` keeps (None: none is supported).
    overrode : str or None
        The effect with the lowest BIC when ``best`` is not it.
    group : list of Candidate
        ``best`` and the supported candidates the record cannot tell from it (:func:`equivalent`).
    chosen : Candidate or None
        The most probable of ``group`` (:func:`most_probable`); None when none is plausible
        or the design does not match the record.
    mismatch : str or None
        Why the design does not match the record: the best fit needs a part no built
        network holds, and no plausible fault fits as well.
    """

    tried: list
    best: Candidate | None = None
    overrode: str | None = None
    group: list = field(default_factory=list)
    chosen: Candidate | None = None
    mismatch: str | None = None


@dataclass
class CircuitSearch:
    """The state of the search after its steps.

    Attributes
    ----------
    current : CircuitFit
        The model with the effects found so far.
    findings : list of CircuitFinding
    trials : list of CircuitTrial
    mismatch : str or None
        See :attr:`StepChoice.mismatch`.
    """

    current: CircuitFit
    findings: list = field(default_factory=list)
    trials: list = field(default_factory=list)
    mismatch: str | None = None


@dataclass(frozen=True)
class CircuitConclusion:
    """The end of a diagnosis: the as-built model, the findings and the floor they are
    judged against (see :func:`conclude`)."""

    current: CircuitFit
    findings: tuple
    catch_all: Evidence
    floor: NoiseFloor
    mismatch: str | None = None
    drift: OutputDrift | None = None


def diagnose_circuit(record, design: Design, spice_check: bool = True,
                     resistor_series: str = "E24", capacitor_series: str = "E6",
                     candidates: list[str] | None = None) -> CircuitDiagnosis:
    """What the simulated network gets wrong against the measured output, and why.

    Parameters
    ----------
    record : Record, path, open file, data frame or mapping of arrays
        With ``signal`` and ``corrected``; read by :func:`~creepcomp.io.formats.read_any`
        unless a :class:`Record`.
    design : Design
        The nominal design of the network that produced ``corrected``.
    spice_check : bool
        Run the as-built network through ngspice on the same record.
    resistor_series, capacitor_series : str
        E-series of the fix.
    candidates : list of str, optional
        Circuit effects to try, in this order (default: all, by identifier).

    Returns
    -------
    CircuitDiagnosis
    """
    start = _time.perf_counter()
    # by identifier: the order the benchmarks were run with (it orders the trials and breaks ties)
    pool = (sorted(circuit_effects(), key=lambda e: e.name) if candidates is None
            else [effects_pkg.get(c) for c in candidates])
    record = read_any(record)
    data = prepare(record, design)
    floor = circuit_noise_floor(data)
    baseline = with_heldout(data, fit_model(data, (), [{}]))
    search = search_effects(data, baseline, pool)
    end = conclude(data, baseline, search, floor, record.unit("corrected") or record.unit("signal"))
    named = any(f.effect != "unexplained" for f in end.findings)
    fixes = tuple(suggest_fixes(end.current.network, design.model, resistor_series, capacitor_series)) if named else ()
    check = ngspice_check(data, end.current) if spice_check and not end.mismatch else None
    return CircuitDiagnosis(data, baseline, end.current, end.findings, tuple(search.trials), end.catch_all, fixes,
                            _time.perf_counter() - start, check, end.floor, end.mismatch, end.drift)


def search_effects(data: CircuitData, baseline: CircuitFit, pool: list) -> CircuitSearch:
    """Add circuit effects one after the other (at most :data:`MAX_EFFECTS`) while the
    evidence supports one: each step screens the candidates (:func:`screen`), chooses
    (:func:`decide`) and records every trial (:func:`step_trials`) and the finding
    (:func:`step_finding`)."""
    search = CircuitSearch(baseline)
    for step in range(1, MAX_EFFECTS + 1):
        choice = decide(data, screen(data, search.current, pool))
        search.trials.extend(step_trials(step, choice, data.design.network))
        search.mismatch = choice.mismatch
        if choice.chosen is None:
            break
        search.findings.append(step_finding(data, choice))
        search.current = choice.chosen.fit
    return search


def screen(data: CircuitData, current: CircuitFit, pool: list) -> list[Candidate]:
    """Every effect of ``pool`` not yet in ``current``, on every part where it may sit,
    fitted on top of it with its held-out prediction and evidence."""
    tried = []
    for applied in _candidates(data, current, pool):
        fit = with_heldout(data, _fit_with(data, current, applied))
        tried.append(Candidate(applied, fit, evidence(data, current, fit), at_bound(fit, applied)))
    return tried


def decide(data: CircuitData, tried: list[Candidate]) -> StepChoice:
    """The choice of one step: of the supported candidates not at a bound, the one
    :func:`choose` keeps, those the record cannot tell from it, and the most probable of
    them; none when the best fit of all needs a part no built network holds and no
    plausible fault fits as well (another design)."""
    supported = [c for c in tried if c.evidence.supported and not c.edge]
    if not supported:
        return StepChoice(tried, mismatch=_needs_another_design(data, tried, None))
    best, overrode = choose(data, supported)
    group = [best] + [c for c in supported if c.applied is not best.applied and equivalent(data, best, c)]
    chosen = most_probable(group, data.design)
    mismatch = _needs_another_design(data, tried, chosen)
    return StepChoice(tried, best, overrode, group, None if mismatch else chosen, mismatch)


def _needs_another_design(data: CircuitData, tried: list[Candidate], chosen: Candidate | None) -> str | None:
    """Why the design does not match the record, when the supported candidate of lowest BIC
    is implausible and ``chosen`` (the plausible choice) fits worse by
    :data:`EQUIVALENT_BIC` or more; else None."""
    fitting = sorted((c for c in tried if c.evidence.supported), key=lambda c: c.evidence.delta_bic)
    if not fitting:
        return None
    why = fitting[0].implausible(data.design.network)
    if why and (chosen is None or chosen.evidence.delta_bic - fitting[0].evidence.delta_bic >= EQUIVALENT_BIC):
        return f"the best fit needs {why}"
    return None


def step_trials(step: int, choice: StepChoice, network) -> list[CircuitTrial]:
    """Every candidate of a step with what became of it (:func:`_outcome`)."""
    trials = []
    chosen = choice.chosen
    for c in choice.tried:
        picked = chosen is not None and c is chosen
        alternative = chosen is not None and not picked and any(c is g for g in choice.group)
        outcome = _outcome(picked, choice.overrode if picked and chosen is choice.best else None, c.edge,
                           c.evidence, chosen.name if alternative else None,
                           c.implausible(network) if choice.mismatch else None)
        trials.append(CircuitTrial(step, c.name, c.part(network), c.evidence, outcome))
    return trials


def step_finding(data: CircuitData, choice: StepChoice) -> CircuitFinding:
    """The finding of a step: its chosen candidate, with the others of its group as
    ``alternatives`` (best fitting first), each with the measurement that tells it apart."""
    network = data.design.network
    chosen = choice.chosen
    where = chosen.part(network)
    alternatives = tuple(_alternative(network, chosen, where, c)
                         for c in sorted(choice.group, key=lambda c: c.evidence.delta_bic) if c is not chosen)
    return CircuitFinding(chosen.name, chosen.reported(), chosen.evidence, where,
                          uncertainty(data, chosen.fit, chosen.applied), alternatives)


def _alternative(network, chosen: Candidate, where: str | None, other: Candidate) -> dict:
    part = other.part(network)
    return {"effect": other.name, "part": part, "parameters": other.reported(),
            "delta_bic": float(other.evidence.delta_bic - chosen.evidence.delta_bic),
            "measurement": separating_measurement(network, (chosen.effect, where), (other.effect, part))}


def conclude(data: CircuitData, baseline: CircuitFit, search: CircuitSearch, floor: NoiseFloor,
            unit: str = "") -> CircuitConclusion:
    """The end of a diagnosis after the search: the catch-all (a generic lag on top), whether
    the design matches the record (:data:`MISMATCH_RATIO`), the output channel's drift in the
    floor when nothing is found (:func:`~creepcomp.diagnose.output_drift.output_drift`; ``unit``: the output's), and
    ``unexplained`` when structure or misfit above the floor remains."""
    current, findings = search.current, list(search.findings)
    catch = with_heldout(data, fit_model(data, current.applied,
                                         [{p.name: current.values[p.name] for p in current.params}], generic=True))
    catch_ev = evidence(data, current, catch, always_halves=True)
    left = misfit_ratio(current.rms, floor)
    base_ratio = misfit_ratio(baseline.rms, floor)
    mismatch = search.mismatch or _mismatch_left(findings, left, base_ratio)
    drift = None
    if not mismatch and not findings and not catch_ev.supported:
        drift = output_drift(data, current, floor, unit)
        if drift is not None:
            floor = replace(floor, rms=float(np.hypot(floor.rms, drift.rms)),
                            method=floor.method + f"; with the output channel's slow drift (a cubic spline of "
                                                  f"the nominal network's residual, knots {drift.knot_spacing:.4g} s "
                                                  f"apart), which no circuit effect nor a generic lag follows")
            left = misfit_ratio(current.rms, floor)
    if mismatch:
        finding = CircuitFinding("unexplained", {"misfit_ratio": base_ratio},
                                 catch_ev if not findings else findings[0].evidence,
                                 note=f"design_mismatch: {mismatch}")
        return CircuitConclusion(baseline, (finding,), catch_ev, floor, mismatch, drift)
    if catch_ev.supported or (left is not None and left > MISFIT_LIMIT):
        findings.append(_unexplained(data, current, catch, catch_ev, floor, left))
    return CircuitConclusion(current, tuple(findings), catch_ev, floor, None, drift)


def _mismatch_left(findings: list, left: float | None, base_ratio: float | None) -> str | None:
    """Why the design does not match the record after the search: the plausible faults found
    leave more than :data:`MISMATCH_RATIO` times the floor, or none was found and the nominal
    network misses by that much; else None."""
    if findings and left is not None and left > MISMATCH_RATIO:
        return (f"the best plausible faults ({', '.join(f.effect for f in findings)}) leave "
                f"{left:.3g} times the noise floor")
    if not findings and base_ratio is not None and base_ratio > MISMATCH_RATIO:
        return "no single plausible fault explains it"
    return None


def _unexplained(data: CircuitData, current: CircuitFit, catch: CircuitFit, catch_ev: Evidence,
                 floor: NoiseFloor, left: float | None) -> CircuitFinding:
    """The ``unexplained`` finding: the generic lag when it is supported, else the misfit
    above the floor and how much of it is slow (:func:`~creepcomp.diagnose.output_drift.slow_share`)."""
    params = {"misfit_ratio": left}
    note = ""
    if catch_ev.supported:
        params.update({"tau": catch.generic[1], "gain": catch.generic[0]})
    else:
        slow = slow_share(current.residual, floor, floor_window(data))
        params["slow_share"] = slow
        note = "misfit above the noise floor that no circuit effect explains"
        if slow is not None and slow >= SLOW_SHARE:
            note += (f"; {100 * slow:.0f} % of it is slower than the floor's windows and nothing "
                     f"driven by the signal follows it: a drift of the output's measuring chain "
                     f"would look like this (re-zero or log the output channel's offset to tell)")
    return CircuitFinding("unexplained", params, catch_ev, note=note)


def equivalent(data: CircuitData, chosen: Candidate, rival: Candidate) -> bool:
    """True when the record cannot tell ``rival`` from ``chosen`` (two candidates of one
    step): their BIC differ by less than :data:`EQUIVALENT_BIC`, neither predicts the
    held-out blocks better by :data:`~creepcomp.fit.evidence.HELDOUT_Z` standard deviations,
    nor each half of the record from the other. Two faults that change the network's transfer
    function in exactly the same way (:func:`exact_equivalents`: ``R1 || leakage``,
    ``R2 || load``) need only the BIC: no record tells them apart, and the held-out tests
    would measure the one-step refits of two parametrisations of one network (a leakage far
    above R1 moves the output little per unit of its logarithm), not the record (three
    benchmark leakages came back as a wrong R1 with no alternative that way)."""
    if abs(rival.evidence.delta_bic - chosen.evidence.delta_bic) >= EQUIVALENT_BIC:
        return False
    network = data.design.network
    if (rival.name, rival.part(network)) in exact_equivalents(network, chosen.effect, chosen.part(network)):
        return True
    if abs(compare(chosen.fit, rival.fit).heldout_z) >= HELDOUT_Z:
        return False
    return not (_predicts_better(data, chosen.fit, rival.fit) or _predicts_better(data, rival.fit, chosen.fit))


def most_probable(group: list[Candidate], design: Design) -> Candidate | None:
    """Of candidates the record cannot tell apart, the most probable under each effect's
    prior (:func:`fault_prior`): highest ``ln(rate) - delta_bic / 2``, implausible values
    excluded (None when all are)."""
    scored = [(math.log(c.effect.prior.rate) - 0.5 * c.evidence.delta_bic, i)
              for i, c in enumerate(group) if c.implausible(design.network) is None]
    return group[max(scored)[1]] if scored else None


def separating_measurement(network, cause: tuple, other: tuple) -> str:
    """The measurement that tells two explanations of a record apart, each ``(effect, part)``
    (effect: identifier or object): the one either effect knows
    (:meth:`~creepcomp.diagnose.effects._network.NetworkEffect.separating_measurement`, the
    lower precedence first), else the parts a meter measures out of circuit, else a record
    with another load program."""
    (a, a_part), (b, b_part) = (circuit_effect(cause[0]), cause[1]), (circuit_effect(other[0]), other[1])
    exact = (b.name, b_part) in exact_equivalents(network, a, a_part)
    known = [m for m in (a.separating_measurement(b, a_part, b_part, exact),
                         b.separating_measurement(a, b_part, a_part, exact)) if m is not None]
    if known:
        return min(known, key=lambda m: m[0])[1]
    parts = [p for e, p in ((a, a_part), (b, b_part)) if e.measured_out_of_circuit and p]
    if parts:
        return f"measure {' and '.join(parts)} out of circuit"
    return ("a second record with another load program (steps held for other times weigh the network's "
            "fast and slow parts differently)")


def _outcome(chosen: bool, overrode: str | None, edge: str | None, ev: Evidence, alternative_to: str | None = None,
             absurd: str | None = None) -> str:
    """What became of a candidate at its step (see :func:`choose`, :func:`at_bound`,
    :func:`equivalent`, :meth:`~creepcomp.diagnose.effects._network.NetworkEffect.implausible`)."""
    if chosen:
        return f"accepted: predicts each half from the other better than {overrode} (lower BIC)" if overrode \
            else "accepted"
    if alternative_to:
        return f"alternative: fits as well as {alternative_to}, less probable under the prior"
    if absurd and ev.supported:
        return f"rejected: {absurd} (not a fault of this design)"
    if edge:
        return f"rejected: {edge} at the edge of its range (not resolved by the record)"
    return "supported, not the best" if ev.supported else "rejected"


def choose(data: CircuitData, supported: list[Candidate]) -> tuple[Candidate, str | None]:
    """The supported candidate to keep, and the name of the one with the lowest BIC if that
    is not it (else None).

    The lowest BIC wins unless another candidate predicts each half of the record from the
    other better by :data:`~creepcomp.fit.evidence.HELDOUT_Z`. BIC under AR noise, and the
    interleaved held-out blocks, weigh the fast part of the residual; there the sensor's
    measurement noise in ``signal``, which the network never saw, can be partly explained
    by an effect that lowers the network's high-frequency gain (a source resistance for a
    load resistance) while the record's slow part, which the halves test, says otherwise.
    """
    ranked = sorted(supported, key=lambda c: c.evidence.delta_bic)
    best = ranked[0]
    for rival in ranked[1:]:
        if _predicts_better(data, best.fit, rival.fit):
            best = rival
    return best, (ranked[0].name if best is not ranked[0] else None)


def _predicts_better(data: CircuitData, fit: CircuitFit, rival: CircuitFit) -> bool:
    """True when ``rival`` predicts each half from the other better than ``fit`` (see
    :func:`choose`)."""
    across = compare(replace(fit, heldout=halves(data, fit)), replace(rival, heldout=halves(data, rival)))
    return across.heldout_z >= HELDOUT_Z


def at_bound(fit: CircuitFit, applied: Applied) -> str | None:
    """The first parameter of an applied effect that sits at a bound of its range (e.g. an
    absorption as slow as the record: not told apart from drift), or None."""
    for p in fit.params:
        if p.name.startswith(applied.name + "."):
            x, (lo, hi) = p.to_search(fit.values[p.name]), p.bounds()
            if min(x - lo, hi - x) < 1e-3 * (hi - lo):
                return p.name[len(applied.name) + 1:]
    return None


def ngspice_check(data: CircuitData, fit: CircuitFit) -> dict:
    """The as-built network in ngspice on the same record, against the measured output."""
    from creepcomp.verify.compare import at_sample_times, compare_record

    try:
        comparison = compare_record(fit.network, data.time, data.signal, name=data.source)
    except Exception as exc:  # ngspice missing or failing: say so, do not fail the diagnosis
        return {"error": str(exc)}
    if comparison.spice is None:
        return {"error": comparison.unavailable or "ngspice not available"}
    t = data.time - data.time[0]
    out = at_sample_times(comparison.spice.time, comparison.spice.output, t)
    # the fit's output is the network's plus the measuring offset and the decays of its
    # initial state and input breaks: ngspice gives the network's part
    linear = data.corrected - fit.residual - fit.network.lag_expansion().simulate(t, data.signal, initial="settled")
    diff = data.corrected - (out + linear)
    return {"rms_ngspice_vs_measured": float(np.sqrt(np.mean(diff ** 2))),
            "residual_rms_of_the_fit": fit.rms,
            "ratio": float(np.sqrt(np.mean(diff ** 2)) / fit.rms) if fit.rms > 0 else None,
            "ngspice_seconds": comparison.ngspice_seconds}


def combine(sensor: dict, circuit: CircuitDiagnosis) -> dict:
    """One ``docs/diagnosis.md`` object for a record diagnosed on both sides.

    The circuit side leads when it names a cause (the record was given with its network's
    design to ask about the network); otherwise the sensor side does. ``cause``,
    ``baseline``, ``extended`` and ``gain`` are the leading side's; ``findings`` holds both
    sides' (leading side first, each with its ``side``); ``sensor`` and ``circuit`` hold each
    side's whole result.
    """
    c = circuit.to_dict()
    s = dict(sensor)
    s_findings = [dict(f, side=f.get("side", "sensor")) for f in s.get("findings", [])]
    lead_circuit = c["cause"] != "none" or s.get("cause", "none") == "none"
    lead = c if lead_circuit else s
    findings = c["findings"] + s_findings if lead_circuit else s_findings + c["findings"]
    out = {"cause": lead["cause"], "side": "circuit" if lead_circuit else "sensor", "findings": findings,
           "baseline": lead["baseline"], "extended": lead["extended"], "gain": lead["gain"]}
    out.update({"sensor": s, "circuit": c})
    return out
