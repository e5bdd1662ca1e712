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
network meets the measured output to the record's noise floor (:func:`circuit_noise_floor`,
misfit ratio at most :data:`~creepcomp.fit.noise.MISFIT_LIMIT`); otherwise ``unexplained``
with the misfit that remains, as also after named findings that leave misfit above the floor.

Several faults can change the network's output alike (R2 low and a load resistance; R1 low
and leakage across C1). After each step the candidates that fit the record as well as the
chosen one (:func:`equivalent`) are its ``alternatives``; the cause among them is the most
probable under the prior of :data:`FAULT_PRIOR` (:func:`most_probable`), and each
alternative carries the measurement that would tell it from the cause
(:func:`separating_measurement`). A fit that needs a part far off anything a built network
holds (:func:`implausible`), or misfit far above the floor that no plausible fault removes,
says that the design does not match the record (``design_mismatch``): no part is named and
no fix proposed.

The extension is the as-built network: written as a design file, checked in ngspice on the
same record, and the fix is the single part change that leaves the least residual creep.
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.stats import f as f_distribution

from creepcomp.analog.faults import exact_equivalents, fault_part, resistor_parts, suggest_fixes
from creepcomp.analog.quality import step_peak
from creepcomp.diagnose import effects as effects_pkg
from creepcomp.fit.circuit import (CircuitData, CircuitFit, fit_model, halves, prepare, uncertainty,
    with_heldout)
from creepcomp.fit.evidence import BIC_STRONG, HELDOUT_Z, Evidence, compare, compare_with_halves
from creepcomp.fit.noise import (FEW_WINDOWS, FLOOR_WINDOW, MISFIT_LIMIT, NoiseFloor, autocorrelation,
    explained_share, fit_noise, ljung_box, misfit_ratio, noise_floor, rows_for, slow_drift, whiten)
from creepcomp.fit.structure import Applied
from creepcomp.io.jsonfiles import Design
from creepcomp.io.records import Record
from creepcomp.lti import lag_states
from creepcomp.units import format_quantity

__all__ = ["SLOW_SHARE", "slow_share", "floor_window", "DRIFT_INDEPENDENCE_P", "DRIFT_DRIVEN_SHARE", "OutputDrift",
           "signal_follows", "output_drift",
           "MAX_EFFECTS", "EQUIVALENT_BIC", "MISMATCH_RATIO", "PART_FACTOR", "FAULT_PRIOR", "evidence",
           "circuit_noise_floor", "implausible", "equivalent", "most_probable", "separating_measurement",
           "CircuitFinding", "CircuitTrial", "CircuitDiagnosis", "circuit_effects", "diagnose_circuit",
           "choose", "at_bound", "ngspice_check", "combine"]

#: A misfit left unexplained is called slow (a drift of the measuring chain would look like it)
#: when at least this share of its excess variance over the floor is slower than the floor's
#: windows (:func:`slow_share`).
SLOW_SHARE = 0.8
#: A slow misfit that no circuit effect explains is not a drift of the output's measuring
#: chain when its changes follow the signal's with a p-value under this and what follows
#: the signal makes at least :data:`DRIFT_DRIVEN_SHARE` of its excess variance over the floor
#: (:func:`signal_follows`, :func:`output_drift`).
#: Loose on purpose: a drift wrongly refused is ``unexplained``, a fault wrongly taken for
#: drift is ``none`` (a random walk is refused on 2-10 % of records, a resistor fault outside
#: the candidates at 3.3 times the floor gave p = 0.06).
DRIFT_INDEPENDENCE_P = 0.1
#: See :data:`DRIFT_INDEPENDENCE_P` (on the benchmark's records: faults outside the candidates
#: 0.5 and more, clean drifting outputs 0.04-0.41 where the test was significant).
DRIFT_DRIVEN_SHARE = 0.5
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
#: A part (resistor or capacitor) off its nominal value by more than this factor either way
#: is not a fault of a built network (tolerance, drift, a neighbouring value placed) but
#: another design.
PART_FACTOR = 1.6

#: The prior of the circuit faults: how often each happens in an assembled network (share of
#: built networks that carry it; assumed by the project, not measured) and what values a
#: built network can hold (beyond them the fit is taken as a design that does not match the
#: record, see :func:`implausible`). Among explanations the record cannot tell apart, the
#: cause is the one of highest ``rate * exp(-BIC / 2)`` (:func:`most_probable`).
FAULT_PRIOR = {
    "resistor_value": {"rate": 0.05, "plausible": f"within a factor {PART_FACTOR:g} of the design value",
                       "why": "wrong value placed, a 5 % part at its limit, drift with heat or humidity: "
                              "the most common fault"},
    "capacitor_value": {"rate": 0.04, "plausible": f"within a factor {PART_FACTOR:g} of the design value",
                        "why": "capacitors are +-10 to +-20 % parts, and age"},
    "source_impedance": {"rate": 0.01, "plausible": "at most half the network's resistance level",
                         "why": "the sensor's output resistance left out of the design"},
    "load_impedance": {"rate": 0.01, "plausible": "at least the network's resistance level",
                       "why": "the next stage's input resistance left out of the design"},
    "dielectric_absorption": {"rate": 0.01, "plausible": "up to 10 % of the capacitance",
                              "why": "a ceramic or electrolytic placed where a film part was designed"},
    "capacitor_leakage": {"rate": 0.005, "plausible": "at least the cell's own resistor",
                          "why": "contamination on the board, an electrolytic part"},
}


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


@dataclass(frozen=True)
class OutputDrift:
    """A slow drift of the output's measuring chain, counted in the noise floor
    (:func:`output_drift`).

    Attributes
    ----------
    rms, span : float
        RMS and peak-to-peak of the drift, output units.
    knot_spacing : float
        Spacing of its spline's knots, s.
    white_floor : float
        The floor without the drift (:func:`circuit_noise_floor`).
    misfit_ratio_white, misfit_ratio_without_drift : float
        The nominal network's misfit over the white floor, with the drift and once it is
        taken out.
    unit : str
        The output's unit (of ``rms`` and ``span``).
    curve : numpy.ndarray
        The drift at the record's sample times (mean included).
    """

    rms: float
    span: float
    knot_spacing: float
    white_floor: float
    misfit_ratio_white: float
    misfit_ratio_without_drift: float
    unit: str = ""
    curve: np.ndarray | None = field(default=None, compare=False, repr=False)

    def format(self, value: float) -> str:
        """A value in the output's unit (output units when the record names none)."""
        return format_quantity(value, self.unit) if self.unit else f"{value:.3g} output units"

    def to_dict(self) -> dict:
        """JSON form."""
        return {"rms": self.rms, "span": self.span, "knot_spacing": self.knot_spacing,
                "white_noise_floor": self.white_floor, "misfit_ratio_over_white_floor": self.misfit_ratio_white,
                "misfit_ratio_without_drift": self.misfit_ratio_without_drift}


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
    floor: NoiseFloor | None = None
    mismatch: str | None = None
    drift: OutputDrift | None = None
    """``floor``: the noise floor of the comparison (:func:`circuit_noise_floor`, with the
    output's drift when ``drift`` is set); ``mismatch``: why the design does not match the
    record (None: it does); ``drift``: a drift of the output's measuring chain that the floor
    counts (:func:`output_drift`)."""

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
                             f"probable under the prior ({FAULT_PRIOR[f.effect]['why']}); to tell them apart: "
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
                "fault_prior": {k: dict(v) for k, v in FAULT_PRIOR.items()}}


def _format(name: str, value: float) -> str:
    unit = {"R": "Ω", "C": "F", "tau": "s"}.get(name)
    if name == "fraction":
        return f"{100 * value:.3g} %"
    return format_quantity(value, unit) if unit else f"{value:.4g}"


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


def circuit_noise_floor(data: CircuitData) -> NoiseFloor:
    """The noise floor that the nominal network's misfit is judged against
    (:func:`creepcomp.fit.noise.noise_floor`, no model fitted): of the measured ``corrected``
    minus the nominal network's simulation on the measured ``signal``. The comparison's noise
    is the output's measurement noise and, where the built network saw the sensor's
    continuous signal, the signal's measurement noise as the simulation passes it; both are
    in that difference, and neither in ``corrected`` alone. Slow misfit (a wrong part) is
    what each window's quadratic takes up.

    The windows span half the network's fastest time constant (at least
    :data:`~creepcomp.fit.noise.FLOOR_WINDOW` samples, and at most what leaves
    2 x :data:`~creepcomp.fit.noise.FEW_WINDOWS` windows): within that a quadratic follows any
    response of the network, nominal or faulty, to a few parts in a thousand, and noise of
    the measuring chain correlated over seconds (coloured noise of a fast-sampled record)
    stays in the floor instead of being taken for misfit. A drift over the whole record is
    still not in it."""
    nominal = data.design.network.lag_expansion().simulate(data.time, data.signal, initial="settled")
    floor = noise_floor(data.corrected - nominal, None, data.time, floor_window(data))
    return replace(floor, method="the measured corrected minus the nominal network's simulation on the "
                                 "measured signal: " + floor.method)


def floor_window(data: CircuitData) -> int:
    """Samples per window of the circuit side's noise floor (see :func:`circuit_noise_floor`)."""
    taus = data.design.network.lag_expansion().taus
    span = 0.5 * min(taus) / data.dt_median if taus else 0.0
    return int(min(max(round(span), FLOOR_WINDOW), max(data.n // (2 * FEW_WINDOWS), FLOOR_WINDOW)))


def slow_share(residual: np.ndarray, floor: NoiseFloor, window: int = FLOOR_WINDOW) -> float | None:
    """Share of a residual's variance above the noise floor that is slower than the floor's
    windows: the variance of its moving average over a window (less the floor's part that
    passes the average, ``floor**2 / window``) over its excess variance ``rms**2 - floor**2``,
    clipped to [0, 1] (None when there is no excess; ``window``: the floor's, in samples). The
    floor takes up everything that slow within its windows (a drift of the measuring chain too), so a misfit above the floor
    that is mostly this slow is drift or a slow fault, not faster structure."""
    excess = float(np.mean(residual ** 2)) - floor.rms ** 2
    w = int(min(window, max(8, len(residual) // 4)))
    if excess <= 0 or len(residual) < 2 * w:
        return None
    average = np.convolve(residual, np.ones(w) / w, mode="valid")
    slow = float(np.mean(average ** 2)) - floor.rms ** 2 / w
    return float(min(1.0, max(0.0, slow / excess)))


def signal_follows(data: CircuitData, residual: np.ndarray, window: int,
                   floor: NoiseFloor) -> tuple[float, float | None]:
    """How far a residual's slow changes follow the signal: (p-value, driven share).

    The residual's means over blocks of ``window`` samples are regressed on the block means
    of what the signal drives -- the signal, the nominal network's output, and first-order
    lags of the signal at a third, one and three times each of the network's time
    constants -- all differenced from block to block (the increments of a random-walk
    drift are independent of the signal's; its levels would correlate spuriously with any
    slow input). The p-value is that regression's F test; the driven share is the variance
    of the fitted combination of the regressors (in levels, sample by sample) over the
    residual's excess variance above ``floor`` (None without excess). A long record makes
    even a tiny correlation significant, hence the share. (0, 1) when there are too few
    blocks to tell."""
    network = data.design.network.lag_expansion()
    taus = sorted({round(math.log(f * t), 1) for t in network.taus for f in (1 / 3, 1.0, 3.0)})
    columns = [data.signal, network.simulate(data.time, data.signal, initial="settled")]
    if taus:
        states = lag_states(data.time, data.signal, np.exp(taus), initial="settled")
        columns.extend(states.T)
    levels = np.column_stack(columns)
    blocks = len(residual) // max(int(window), 1)
    if blocks - 1 < levels.shape[1] + 10:
        return 0.0, 1.0
    means = np.asarray(residual, float)[:blocks * window].reshape(blocks, window).mean(axis=1)
    x = np.diff(levels[:blocks * window].reshape(blocks, window, -1).mean(axis=1), axis=0)
    scale = np.maximum(np.sqrt(np.mean(x ** 2, axis=0)), 1e-300)
    y = np.diff(means)
    coef, *_ = np.linalg.lstsq(x / scale, y, rcond=None)
    rank = np.linalg.matrix_rank(x / scale)
    fitted = (x / scale) @ coef
    rss = float(np.sum((y - fitted) ** 2))
    dof = len(y) - rank
    if rank == 0 or dof <= 0 or rss <= 0:
        return 0.0, 1.0
    p = float(f_distribution.sf((float(np.sum(fitted ** 2)) / rank) / (rss / dof), rank, dof))
    driven = (levels / scale) @ coef
    excess = float(np.mean(np.asarray(residual, float) ** 2)) - floor.rms ** 2
    share = float(np.var(driven) / excess) if excess > 0 else None
    return p, share


def output_drift(data: CircuitData, fit: CircuitFit, floor: NoiseFloor, unit: str = "") -> OutputDrift | None:
    """A drift of the output's measuring chain that explains the misfit of ``fit`` above the
    floor, or None.

    The slow part of the residual (:func:`~creepcomp.fit.noise.slow_drift`, knots one slowest
    time constant of the network apart, but at least 8 and at most 100 intervals over the
    record, so that a drift over the whole record can be followed) is the drift when,
    taken out, it leaves a misfit ratio of at most :data:`~creepcomp.fit.noise.MISFIT_LIMIT`.
    Called only when no circuit effect and no generic lag is supported, and a drift only
    when the residual's slow changes do not follow the signal's (:func:`signal_follows`: not
    both a p-value under :data:`DRIFT_INDEPENDENCE_P` and a driven share of at least
    :data:`DRIFT_DRIVEN_SHARE`): a fault outside the templates is driven by the signal, a
    drift of the measuring chain is not."""
    ratio = misfit_ratio(fit.rms, floor)
    if ratio is None or ratio <= MISFIT_LIMIT or data.n < 64:
        return None
    span = float(data.time[-1] - data.time[0])
    taus = data.design.network.lag_expansion().taus
    spacing = max(min(max(taus) if taus else span, span / 8), span / 100)
    slow = slow_drift(fit.residual, data.time, spacing)
    left = misfit_ratio(float(np.sqrt(np.mean((fit.residual - slow) ** 2))), floor)
    if left > MISFIT_LIMIT:
        return None
    p, share = signal_follows(data, fit.residual, floor_window(data), floor)
    if p < DRIFT_INDEPENDENCE_P and (share is None or share >= DRIFT_DRIVEN_SHARE):
        return None
    drift = slow - np.mean(slow)
    return OutputDrift(float(np.sqrt(np.mean(drift ** 2))), float(np.ptp(drift)), spacing, floor.rms, ratio, left,
                       unit, slow)


def implausible(effect: str, values: dict, design: Design, part: str | None = None,
                cell: int | None = None) -> str | None:
    """Why a fitted circuit fault is not one a built network of this design can hold (see
    :data:`FAULT_PRIOR`), or None."""
    net = design.network
    level = (net.R2 if net.R2 is not None else 0.0) + sum(c.R for c in net.cells)

    def off(value, nominal, what):
        factor = value / nominal
        if not 1.0 / PART_FACTOR <= factor <= PART_FACTOR:
            return f"{what} fitted at {factor:.3g} times its design value"
        return None

    if effect == "resistor_value":
        return off(values["R"], resistor_parts(net)[part], part)
    if effect == "capacitor_value":
        return off(values["C"], net.cells[cell].C, fault_part(net, effect, cell))
    if effect == "source_impedance" and values["R"] > 0.5 * level:
        return f"a source resistance of {values['R'] / level:.3g} times the network's resistance level"
    if effect == "load_impedance" and values["R"] < level:
        return f"a load resistance of {values['R'] / level:.3g} times the network's resistance level"
    if effect == "capacitor_leakage" and values["R"] < net.cells[cell].R:
        return f"a leakage of {values['R'] / net.cells[cell].R:.3g} times the cell's resistor"
    if effect == "dielectric_absorption" and values["fraction"] > 0.1:
        return f"an absorption of {100 * values['fraction']:.3g} % of the capacitance"
    return None


def _implausible(applied: Applied, fit: CircuitFit, design: Design) -> str | None:
    settings = dict(applied.settings)
    return implausible(applied.name, applied.own(fit.values), design, settings.get("part"), settings.get("cell"))


def equivalent(data: CircuitData, chosen: tuple, rival: tuple) -> bool:
    """True when the record cannot tell ``rival`` from ``chosen`` (both ``(applied, fit,
    evidence, ...)`` of one step): their BIC differ by less than :data:`EQUIVALENT_BIC`,
    neither predicts the held-out blocks better by :data:`~creepcomp.fit.evidence.HELDOUT_Z`
    standard deviations, nor each half of the record from the other. Two faults that change
    the network's transfer function in exactly the same way
    (:func:`~creepcomp.analog.faults.exact_equivalents`: ``R1 || leakage``, ``R2 || load``)
    need only the BIC: no record tells them apart, and the held-out tests would measure the
    one-step refits of two parametrisations of one network (a leakage far above R1 moves the
    output little per unit of its logarithm), not the record (three benchmark leakages came
    back as a wrong R1 with no alternative that way)."""
    if abs(rival[2].delta_bic - chosen[2].delta_bic) >= EQUIVALENT_BIC:
        return False
    design = data.design
    if (rival[0].name, _part(rival[0], design)) in exact_equivalents(design.network, chosen[0].name,
                                                                      _part(chosen[0], design)):
        return True
    if abs(compare(chosen[1], rival[1]).heldout_z) >= HELDOUT_Z:
        return False
    return not (_predicts_better(data, chosen[1], rival[1]) or _predicts_better(data, rival[1], chosen[1]))


def most_probable(group: list, design: Design) -> tuple | None:
    """Of candidates the record cannot tell apart, the most probable under
    :data:`FAULT_PRIOR`: highest ``ln(rate) - delta_bic / 2``, implausible values excluded
    (None when all are)."""
    scored = [(math.log(FAULT_PRIOR.get(t[0].name, {"rate": 1e-3})["rate"]) - 0.5 * t[2].delta_bic, i)
              for i, t in enumerate(group) if _implausible(t[0], t[1], design) is None]
    return group[max(scored)[1]] if scored else None


def separating_measurement(network, cause: tuple, other: tuple) -> str:
    """The measurement that tells two explanations of a record apart, each ``(effect, part)``."""
    pair = {cause[0], other[0]}
    exact = other in exact_equivalents(network, *cause)
    parts = [p for e, p in (cause, other) if e == "resistor_value" or e == "capacitor_value" and p]
    if pair == {"resistor_value", "load_impedance"}:
        return ("measure R2 out of circuit, and the next stage's input resistance with the network "
                "unplugged" + (" (the output alone cannot: R2 || RL is all it sees)" if exact else ""))
    if pair == {"resistor_value", "capacitor_leakage"}:
        part = parts[0] if parts else "the resistor"
        return (f"measure {part} out of circuit; or repeat the record after a temperature step (a leakage "
                "grows with temperature, a film resistor hardly moves)"
                + (" (the output alone cannot: R1 || leakage is all it sees)" if exact else ""))
    if pair == {"resistor_value", "source_impedance"}:
        return (f"measure {parts[0]} out of circuit, and the sensor's output resistance"
                + (" (the output alone cannot: the two add)" if exact else ""))
    if "capacitor_leakage" in pair:
        return "repeat the record after a temperature step (a leakage grows with temperature)"
    if "dielectric_absorption" in pair:
        return ("a second record with another load program: holds longer than the absorption's time "
                "constant, then a step back (absorption recovers slowly, a wrong part does not)")
    if parts:
        return f"measure {' and '.join(parts)} out of circuit"
    return ("a second record with another load program (steps held for other times weigh the network's "
            "fast and slow parts differently)")


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
    floor = circuit_noise_floor(data)
    baseline = with_heldout(data, fit_model(data, (), [{}]))
    base_ratio = misfit_ratio(baseline.rms, floor)
    current = baseline
    findings, trials = [], []
    mismatch = None
    for step in range(1, MAX_EFFECTS + 1):
        tried = []
        for applied in _candidates(data, current, pool):
            fit = _fit_with(data, current, applied)
            fit = with_heldout(data, fit)
            tried.append((applied, fit, evidence(data, current, fit), at_bound(fit, applied)))
        supported = [t for t in tried if t[2].supported and not t[3]]
        best, overrode = choose(data, supported) if supported else (None, None)
        group = [best] + [t[:3] for t in supported if best is not None and t[0] is not best[0]
                          and equivalent(data, best, t)] if best is not None else []
        chosen = most_probable(group, design) if group else None
        fitting = sorted((t for t in tried if t[2].supported), key=lambda t: t[2].delta_bic)
        if fitting and _implausible(fitting[0][0], fitting[0][1], design) and (
                chosen is None or chosen[2].delta_bic - fitting[0][2].delta_bic >= EQUIVALENT_BIC):
            # the record is fitted best by a part no built network holds, and no plausible
            # fault fits it as well: another design
            mismatch = f"the best fit needs {_implausible(fitting[0][0], fitting[0][1], design)}"
            chosen = None
        for applied, fit, ev, edge in tried:
            picked = chosen is not None and applied is chosen[0]
            alternative = chosen is not None and not picked and any(applied is g[0] for g in group)
            trials.append(CircuitTrial(step, applied.name, _part(applied, design), ev,
                                       _outcome(picked, overrode if picked and chosen is best else None, edge, ev,
                                                chosen[0].name if alternative else None,
                                                _implausible(applied, fit, design) if mismatch else None)))
        if chosen is None:
            break
        applied, fit, ev = chosen
        where = (applied.name, _part(applied, design))
        alternatives = tuple(
            {"effect": g[0].name, "part": _part(g[0], design),
             "parameters": g[0].effect.report_network(g[0].own(g[1].values), dict(g[0].settings)),
             "delta_bic": float(g[2].delta_bic - ev.delta_bic),
             "measurement": separating_measurement(design.network, where, (g[0].name, _part(g[0], design)))}
            for g in sorted(group, key=lambda g: g[2].delta_bic) if g is not chosen)
        findings.append(CircuitFinding(applied.name, applied.effect.report_network(applied.own(fit.values),
                                                                                     dict(applied.settings)),
                                       ev, where[1], uncertainty(data, fit, applied), alternatives))
        current = fit
    catch = fit_model(data, current.applied, [{p.name: current.values[p.name] for p in current.params}],
                      generic=True)
    catch = with_heldout(data, catch)
    catch_ev = evidence(data, current, catch, always_halves=True)
    left = misfit_ratio(current.rms, floor)
    if mismatch is None and findings and left is not None and left > MISMATCH_RATIO:
        mismatch = (f"the best plausible faults ({', '.join(f.effect for f in findings)}) leave "
                    f"{left:.3g} times the noise floor")
    elif mismatch is None and not findings and base_ratio is not None and base_ratio > MISMATCH_RATIO:
        mismatch = "no single plausible fault explains it"
    drift = None
    if not mismatch and not findings and not catch_ev.supported:
        drift = output_drift(data, current, floor, record.unit("corrected") or record.unit("signal"))
        if drift is not None:
            floor = replace(floor, rms=float(np.hypot(floor.rms, drift.rms)),
                            method=floor.method + f"; with the output channel's slow drift (a cubic spline of "
                                                  f"the nominal network's residual, knots {drift.knot_spacing:.4g} s "
                                                  f"apart), which no circuit effect nor a generic lag follows")
            left = misfit_ratio(current.rms, floor)
    if mismatch:
        findings = [CircuitFinding("unexplained", {"misfit_ratio": base_ratio}, catch_ev if not findings
                                   else findings[0].evidence, note=f"design_mismatch: {mismatch}")]
        current = baseline
    elif catch_ev.supported or (left is not None and left > MISFIT_LIMIT):
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
        findings.append(CircuitFinding("unexplained", params, catch_ev, note=note))
    model = design.model
    named = any(f.effect != "unexplained" for f in findings)
    fixes = tuple(suggest_fixes(current.network, model, resistor_series, capacitor_series)) if named else ()
    check = ngspice_check(data, current) if spice_check and not mismatch else None
    return CircuitDiagnosis(data, baseline, current, tuple(findings), tuple(trials), catch_ev, fixes,
                            _time.perf_counter() - start, check, floor, mismatch, drift)


def _outcome(chosen: bool, overrode: str | None, edge: str | None, ev: Evidence, alternative_to: str | None = None,
             absurd: str | None = None) -> str:
    """What became of a candidate at its step (see :func:`choose`, :func:`at_bound`,
    :func:`equivalent`, :func:`implausible`)."""
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
    settings = dict(applied.settings)
    return fault_part(design.network, applied.name, settings.get("cell"), settings.get("part"))


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
