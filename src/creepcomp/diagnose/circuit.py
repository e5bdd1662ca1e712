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
(``unexplained``); with no finding the answer is ``none``.

The extension is the as-built network: written as a design file, checked in ngspice on the
same record, and the fix is the single part change that leaves the least residual creep.
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass, field, replace

import numpy as np

from creepcomp.analog.faults import suggest_fixes
from creepcomp.analog.quality import step_peak
from creepcomp.diagnose import effects as effects_pkg
from creepcomp.fit.circuit import (CircuitData, CircuitFit, fit_model, halves, prepare, uncertainty,
    with_heldout)
from creepcomp.fit.evidence import BIC_STRONG, HELDOUT_Z, Evidence, compare, compare_with_halves
from creepcomp.fit.noise import autocorrelation, fit_noise, ljung_box, rows_for, whiten
from creepcomp.fit.structure import Applied
from creepcomp.io.jsonfiles import Design
from creepcomp.io.records import Record

__all__ = ["MAX_EFFECTS", "evidence", "CircuitFinding", "CircuitTrial", "CircuitDiagnosis",
           "circuit_effects", "diagnose_circuit", "choose", "at_bound", "ngspice_check", "combine"]

#: Most circuit effects added one after the other.
MAX_EFFECTS = 3


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

    def to_dict(self) -> dict:
        """JSON form (contract keys first)."""
        out = {"effect": self.effect, "parameters": self.parameters, "evidence": self.evidence.to_dict(),
               "side": "circuit", "uncertainty": self.uncertainty}
        if self.part:
            out["part"] = self.part
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


@dataclass(frozen=True)
class CircuitDiagnosis:
    """Result of :func:`diagnose_circuit`."""

    data: CircuitData
    baseline: CircuitFit
    extended: CircuitFit
    findings: tuple
    trials: tuple
    catch_all: Evidence | None
    fixes: tuple
    seconds: float
    spice_check: dict | None = None

    @property
    def cause(self) -> str:
        """The most important finding's effect, ``none`` or ``unexplained``."""
        return self.findings[0].effect if self.findings else "none"

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

    def summary(self, fit: CircuitFit) -> dict:
        """Residual figures of one model."""
        rows = rows_for(self.data, None, 5)
        noise = fit_noise(fit.residual, rows)
        _, p = ljung_box(whiten(fit.residual, rows, noise))
        return {"residual_rms": fit.rms,
                "heldout_residual_rms": fit.heldout.rms if fit.heldout else None,
                "residual_rms_relative": fit.rms / self.data.scale, "bic": fit.bic,
                "structure": fit.describe(),
                "residual_lag1_autocorrelation": float(autocorrelation(fit.residual, 1)[1]),
                "whitened_ljung_box_p": p}

    def to_dict(self) -> dict:
        """The circuit side's JSON (``docs/diagnosis.md`` keys plus the as-built network and fix)."""
        return {"cause": self.cause, "findings": [f.to_dict() for f in self.findings],
                "baseline": self.summary(self.baseline), "extended": self.summary(self.extended),
                "gain": self.gain, "tried": [t.to_dict() for t in self.trials],
                "catch_all": self.catch_all.to_dict() if self.catch_all else None,
                "as_built": self.as_built.to_dict(), "residual_creep_peak": self.residual_creep,
                "fixes": [f.to_dict() for f in self.fixes],
                "spice_check": self.spice_check, "seconds": self.seconds,
                "decision_rule": {"delta_bic_at_most": -BIC_STRONG, "heldout_z_at_least": HELDOUT_Z}}


def circuit_effects() -> list:
    """The circuit-side effects of the registry, in vocabulary order."""
    return [e for e in effects_pkg.REGISTRY.values() if e.side == "circuit"]


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


def diagnose_circuit(record: Record, design: Design, spice_check: bool = True,
                     resistor_series: str = "E24", capacitor_series: str = "E6",
                     candidates: list[str] | None = None) -> CircuitDiagnosis:
    """What the simulated network gets wrong against the measured output, and why.

    Parameters
    ----------
    record : Record
        With ``signal`` and ``corrected``.
    design : Design
        The nominal design of the network that produced ``corrected``.
    spice_check : bool
        Run the as-built network through ngspice on the same record.
    resistor_series, capacitor_series : str
        E-series of the fix.
    candidates : list of str, optional
        Circuit effects to try (default: all).

    Returns
    -------
    CircuitDiagnosis
    """
    start = _time.perf_counter()
    pool = circuit_effects() if candidates is None else [effects_pkg.get(c) for c in candidates]
    data = prepare(record, design)
    baseline = with_heldout(data, fit_model(data, (), [{}]))
    current = baseline
    findings, trials = [], []
    for step in range(1, MAX_EFFECTS + 1):
        tried = []
        for applied in _candidates(data, current, pool):
            fit = _fit_with(data, current, applied)
            fit = with_heldout(data, fit)
            tried.append((applied, fit, evidence(data, current, fit), at_bound(fit, applied)))
        supported = [t for t in tried if t[2].supported and not t[3]]
        best, overrode = choose(data, supported) if supported else (None, None)
        for applied, fit, ev, edge in tried:
            chosen = best is not None and applied is best[0]
            trials.append(CircuitTrial(step, applied.name, _part(applied, design), ev,
                                       _outcome(chosen, overrode, edge, ev)))
        if best is None:
            break
        applied, fit, ev = best
        findings.append(CircuitFinding(applied.name, applied.effect.report_network(applied.own(fit.values),
                                                                                     dict(applied.settings)),
                                       ev, _part(applied, design), uncertainty(data, fit, applied)))
        current = fit
    catch = fit_model(data, current.applied, [{p.name: current.values[p.name] for p in current.params}],
                      generic=True)
    catch = with_heldout(data, catch)
    catch_ev = evidence(data, current, catch, always_halves=True)
    if catch_ev.supported:
        findings.append(CircuitFinding("unexplained", {"tau": catch.generic[1], "gain": catch.generic[0]},
                                       catch_ev))
    model = design.model
    fixes = tuple(suggest_fixes(current.network, model, resistor_series, capacitor_series)) if findings else ()
    check = ngspice_check(data, current) if spice_check else None
    return CircuitDiagnosis(data, baseline, current, tuple(findings), tuple(trials), catch_ev, fixes,
                            _time.perf_counter() - start, check)


def _outcome(chosen: bool, overrode: str | None, edge: str | None, ev: Evidence) -> str:
    """What became of a candidate at its step (see :func:`choose`, :func:`at_bound`)."""
    if chosen:
        return f"accepted: predicts each half from the other better than {overrode} (lower BIC)" if overrode \
            else "accepted"
    if edge:
        return f"rejected: {edge} at the edge of its range (not resolved by the record)"
    return "supported, not the best" if ev.supported else "rejected"


def choose(data: CircuitData, supported: list) -> tuple:
    """The supported candidate to keep, and the name of the one with the lowest BIC if that
    is not it (else None).

    The lowest BIC wins unless another candidate predicts each half of the record from the
    other better by :data:`~creepcomp.fit.evidence.HELDOUT_Z`. BIC under AR noise, and the
    interleaved held-out blocks, weigh the fast part of the residual; there the sensor's
    measurement noise in ``signal``, which the network never saw, can be partly explained
    by an effect that lowers the network's high-frequency gain (a source resistance for a
    load resistance) while the record's slow part, which the halves test, says otherwise.
    """
    ranked = sorted(supported, key=lambda t: t[2].delta_bic)
    best = ranked[0]
    for rival in ranked[1:]:
        if _predicts_better(data, best[1], rival[1]):
            best = rival
    return best[:3], (ranked[0][0].name if best is not ranked[0] else None)


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


def _part(applied: Applied, design: Design) -> str | None:
    cell = dict(applied.settings).get("cell")
    if cell is None:
        return None
    return "C1" if len(design.network.cells) == 1 else f"C1.{cell + 1}"


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
