"""Diagnosis (``docs/diagnosis.md``): what the simulation gets wrong, the cause, the extended model,
the gain.

1. The baseline (the paper's model: one creep term, gain, offset; free initial creep state
   unless told otherwise) is fitted; its residual is shown against time and load, with its
   autocorrelation and noise model.
2. Every candidate effect of :mod:`creepcomp.diagnose.effects` is fitted on top of the current model
   (a quick fit of its own parameters, then all parameters together for the most promising).
   A candidate is *supported* when the evidence is strong on both counts:

   - BIC lower by at least :data:`~creepcomp.fit.evidence.BIC_STRONG` (a penalty of log n per
     parameter), and
   - data held out of the fit (interleaved blocks, refitted without them, simulated from the
     load) predicted better, by at least :data:`~creepcomp.fit.evidence.HELDOUT_Z` standard
     deviations of a spread computed from the noise spectrum; when the residual holds slow
     noise (drift), each half of the record must also be predicted from the other.

   Of the supported candidates the best by BIC is accepted, unless one with fewer parameters
   that explains at least half as much (in BIC) is also supported and the richer one does not
   predict held-out data better than it (parsimony), or unless the catch-all below predicts held-out data clearly better than it
   (then the structure is not what the candidate says). Effects are added one at a time
   while a candidate is supported.
3. A catch-all extension (generic load-, rate-, direction- and temperature-driven terms) is
   tried on top: if the evidence supports it, structure remains that no named effect
   explains, and the answer includes ``unexplained``; it is ordered with the named findings
   by how much each improves the held-out prediction. Misfit above the noise floor adds it
   too (:data:`REMAINING_LIMIT` after named findings, ``MISFIT_LIMIT`` with none). With no
   finding the answer is
   ``none``: the baseline explains the data to its noise (coloured noise is reported as the
   noise model, not as a cause).
4. The gain: held-out residual RMS, and the error of the creep-corrected signal (digital
   correction, :func:`creepcomp.diagnose.effects.compensate_extended`) against the load, baseline model /
   extended model.

The rule of steps 2 and 3 (which figure against which threshold) is in
:mod:`creepcomp.diagnose.decision`; this module plans the fits it needs: which run, in what
order, side by side in worker processes, and which run ahead.
"""

from __future__ import annotations

import numbers
import time as _time
from dataclasses import dataclass, field, replace

import numpy as np

from creepcomp.diagnose import effects as effects_pkg
from creepcomp.diagnose.decision import (CORRECTION_WORSE, REMAINING_LIMIT, correction_is_worse, gate, judge,
                                        order, ratio_is_worse)
from creepcomp.diagnose.decision import unexplained as _unexplained_reason
from creepcomp.diagnose.effects import Effect, UnsettledInverse, compensate_extended
from creepcomp.diagnose.workers import Workers, last_seconds
from creepcomp.display import Shown, data_frame
from creepcomp.errors import InputError, NotApplicable
from creepcomp.fit.blas import one_blas_thread
from creepcomp.fit.data import Data, prepare
from creepcomp.fit.structure import Applied, Structure
from creepcomp.fit.noise import (MISFIT_LIMIT, SPARSE_SAMPLES, NoiseFloor, autocorrelation, explained_share,
    ljung_box, misfit_ratio as ratio_to_floor, noise_floor, rows_for, whiten, with_reference_noise)
from creepcomp.fit.solver import Fit, Problem, fit_structure
from creepcomp.fit.evidence import (BIC_STRONG, HELDOUT_Z, Evidence, compare, compare_with_halves,
    FoldRefits, fold_refit, halves, heldout)
from creepcomp.fit.starts import one_term_starts, tau_grid
from creepcomp.fit.prony import model_file_dict
from creepcomp.fit.reduce import reduce_record
from creepcomp.lti import compiled_loops, lag_states
from creepcomp.io.formats import read_any
from creepcomp.io.records import Record
from creepcomp.units import format_parameter

__all__ = ["MAX_EFFECTS", "REFINED", "QUICK_HINT", "CORRECTION_WORSE", "REMAINING_LIMIT", "Finding", "Trial", "Candidate",
           "Search", "Generic", "Diagnosis", "CatchAll",
           "CATCH_ALL", "diagnose", "correction_errors", "DIAGNOSE_MAX_SAMPLES"]

#: Most effects added one after the other.
MAX_EFFECTS = 4
#: Samples the diagnosis works on at most: a longer record is reduced by blocks within
#: constant-load stretches (:func:`~creepcomp.fit.reduce.reduce_record`), which keeps its load
#: steps sharp and, where the blocks would be long, makes them grow after each load change (each
#: sample weighted by what it holds), so creep is resolved while it moves. 6,000: above the 5,001
#: samples of the confusion benchmark's records (``docs/benchmarks.md``), and a 30-minute
#: record at 10 Hz (4,500 samples after reduction) diagnosed within 10 s (a search of four
#: steps over 10,000 samples took up to 23 s).
DIAGNOSE_MAX_SAMPLES = 6_000


@dataclass(frozen=True)
class Finding:
    """An effect the evidence supports.

    Attributes
    ----------
    effect : str
        Identifier (``docs/diagnosis.md``), or ``unexplained``.
    parameters : dict
        Fitted parameters.
    uncertainty : dict
        Their standard deviations.
    evidence : Evidence
        Against the model without it.
    importance : float
        Drop of the held-out sum of squares it brought (signal units squared).
    alternatives : tuple of dict
        Other explanations the record cannot tell from this one (``effect``, ``part``,
        ``parameters``).
    note : str or None
        What the user must know about it (e.g. it makes the creep-corrected signal worse).
    correction_error_ratio : float or None
        Error of the creep-corrected signal without it / with it (measured only when the whole
        extension makes the correction worse).
    """

    effect: str
    parameters: dict
    uncertainty: dict
    evidence: Evidence
    importance: float
    fit: Fit = field(compare=False, repr=False, default=None)
    alternatives: tuple = ()
    note: str | None = None
    correction_error_ratio: float | None = None

    @property
    def worsens_correction(self) -> bool:
        """It makes the creep-corrected signal worse (ratio below :data:`CORRECTION_WORSE`)."""
        return ratio_is_worse(self.correction_error_ratio)

    def parameters_text(self, record_units: dict | None = None) -> str:
        """The parameters as a line of text, each with its unit (``record_units``: the
        record's units by column, ``signal`` and ``load``) and its standard deviation: ``±
        n/a`` where one is stated but not finite, none where none is stated (a kind, a place);
        each item of a list with its own; ``-`` when there are none."""
        effect = CATCH_ALL if self.effect == CATCH_ALL.name else effects_pkg.REGISTRY.get(self.effect)
        declared = effect.parameter_units if effect is not None else {}
        parts = []
        for name, value in self.parameters.items():
            unit = declared.get(name)
            unit = None if unit is None else effects_pkg.in_record_units(unit, record_units or {})
            sigma = self.uncertainty.get(name)
            listed = isinstance(value, (list, tuple)) and isinstance(sigma, (list, tuple))
            pairs = zip(value, sigma) if listed and len(value) == len(sigma) else [(value, sigma)]
            parts.append(f"{name} = " + ", ".join(
                format_parameter(name, v, unit) + ("" if s is None else f" ± {format_parameter(name, s, unit)}")
                for v, s in pairs))
        return "; ".join(parts) or "-"

    def to_dict(self) -> dict:
        """JSON form (contract keys first)."""
        out = {"effect": self.effect, "parameters": self.parameters,
               "uncertainty": self.uncertainty, "evidence": self.evidence.to_dict(),
               "alternatives": list(self.alternatives)}
        if self.note:
            out["note"] = self.note
        if self.correction_error_ratio is not None:
            out["correction_error_ratio"] = self.correction_error_ratio
        return out


@dataclass(frozen=True)
class Trial:
    """One candidate tried at one step of the search."""

    step: int
    effect: str
    delta_bic: float | None
    evidence: Evidence | None
    outcome: str

    def to_dict(self) -> dict:
        """JSON form."""
        out = {"step": self.step, "effect": self.effect, "outcome": self.outcome,
               "delta_bic": self.delta_bic}
        if self.evidence is not None:
            out.update(self.evidence.to_dict())
        return out


@dataclass(frozen=True, eq=False)
class Diagnosis(Shown):
    """Result of :func:`diagnose` (equal only to itself: it holds arrays)."""

    data: Data
    baseline: Fit
    extended: Fit
    findings: tuple[Finding, ...]
    trials: tuple[Trial, ...]
    catch_all: Evidence | None
    gain: dict
    seconds: float
    extended_model: dict
    baseline_model: dict
    correction: dict = field(default_factory=dict, repr=False)
    floor: NoiseFloor | None = None
    reduced: str | None = None

    @property
    def cause(self) -> str:
        """The most important finding's effect, or ``none``."""
        return self.findings[0].effect if self.findings else "none"

    def misfit_ratio(self, fit: Fit) -> float | None:
        """A fit's residual RMS over the noise floor."""
        return ratio_to_floor(fit.residual_rms, self.floor) if self.floor is not None else None

    @property
    def explained_share(self) -> float | None:
        """Share of the baseline's misfit variance above the floor that the extended model
        removes (None: the baseline is at the floor)."""
        if self.floor is None:
            return None
        return explained_share(self.baseline.residual_rms, self.extended.residual_rms, self.floor)

    def residual_summary(self, fit: Fit) -> dict:
        """Residual RMS (all samples and held out), noise model and whiteness of a fit."""
        rows = rows_for(self.data, None, fit.noise.order)
        white = whiten(fit.residual, rows, fit.noise)
        q, p = ljung_box(white)
        acf = autocorrelation(fit.residual, 1)[1] if self.data.n > 2 else float("nan")
        return {"residual_rms": fit.residual_rms,
                "heldout_residual_rms": fit.heldout.rms if fit.heldout else None,
                "misfit_ratio": self.misfit_ratio(fit),
                "residual_rms_relative": fit.residual_rms / self.data.signal_scale,
                "bic": fit.bic, "structure": fit.structure.describe(),
                "noise": fit.noise.to_dict(self.data.dt_median),
                "residual_lag1_autocorrelation": float(acf),
                "whitened_ljung_box_p": p}

    def __repr__(self) -> str:
        ratio = self.misfit_ratio(self.extended)
        misfit = "" if ratio is None else f", misfit ratio {ratio:.3g} (noise floor 1)"
        return (f"<Diagnosis of {self.data.source!r}: cause {self.cause}, {len(self.findings)} "
                f"finding{'' if len(self.findings) == 1 else 's'}{misfit}, {self.seconds:.3g} s>")

    def to_pandas(self):
        """The findings (effect, ΔBIC, held-out z, held-out RMS ratio) as a pandas DataFrame."""
        return data_frame({"effect": [f.effect for f in self.findings],
                           "delta_bic": [f.evidence.delta_bic for f in self.findings],
                           "heldout_z": [f.evidence.heldout_z for f in self.findings],
                           "heldout_rms_ratio": [f.evidence.heldout_rms_ratio for f in self.findings]})

    def to_dict(self) -> dict:
        """The JSON object of ``creepcomp diagnose --json`` (``docs/diagnosis.md``)."""
        return {
            "cause": self.cause,
            "findings": [f.to_dict() for f in self.findings],
            "baseline": self.residual_summary(self.baseline),
            "extended": self.residual_summary(self.extended),
            "noise_floor": self.floor.rms if self.floor else None,
            "noise_floor_method": self.floor.method if self.floor else None,
            "noise_floor_windows": self.floor.windows if self.floor else None,
            "quantisation_step": (self.floor.quantisation_step or None) if self.floor else None,
            "explained_share": self.explained_share,
            "gain": self.gain,
            "record": {"source": self.data.source, "n_samples": self.data.n,
                       "duration_s": self.data.duration, "sample_step_s": self.data.dt_median,
                       "uniform": bool(np.ptp(np.diff(self.data.time)) <= 1e-9 * self.data.dt_median),
                       "initial_state": self.data.initial,
                       "temperature": self.data.temperature is not None,
                       "reduced": self.reduced},
            "tried": [t.to_dict() for t in self.trials],
            "catch_all": self.catch_all.to_dict() if self.catch_all else None,
            "decision_rule": {"delta_bic_at_most": -BIC_STRONG, "heldout_z_at_least": HELDOUT_Z,
                              "none_when_misfit_ratio_at_most": MISFIT_LIMIT,
                              "named_leave_unexplained_above": REMAINING_LIMIT,
                              "correction_worse_below": CORRECTION_WORSE},
            "extended_model": self.extended_model,
            "seconds": self.seconds,
        }


# --------------------------------------------------------------------------------------------
# The catch-all: generic structure no named effect stands for
# --------------------------------------------------------------------------------------------

class CatchAll(Effect):
    """Generic extension used only to tell ``unexplained`` structure from noise: lags of the
    load at further time constants, of its square and of its rising part, its integral and
    rate, and temperature terms (level, square, lagged, and times the load and creep)."""

    name = "unexplained"
    parameter_units = {"excess_rms": "signal"}

    def settings(self, data: Data, base: Fit) -> tuple:
        return (("taus", tuple(float(t) for t in base.taus)),)

    def columns(self, data, s, h, lags, p, applied):
        t = data.time
        taus = np.array(applied.setting("taus"))
        scale = data.load_scale
        lo, hi = 2.0 * data.dt_resolved, data.span
        grid = np.geomspace(lo, hi, max(2, int(2 * np.log10(hi / lo)) + 1))
        grid = [g for g in grid if np.min(np.abs(np.log(taus / g))) > np.log(1.5)]
        out = {}
        if grid:
            extra = lag_states(data.sampling, s, grid, hold=data.hold)
            for j, g in enumerate(grid):
                out[f"lag_{g:.3g}s"] = extra[:, j]
        square = s * np.abs(s) / scale
        even = s ** 2 / scale
        ds = np.diff(s, prepend=s[0])
        rising = np.cumsum(np.clip(ds, 0, None))
        out["square"] = square
        out["even"] = even
        out["cube"] = s ** 3 / scale ** 2
        for name, x in (("square", square), ("even", even), ("rising", rising)):
            lx = lag_states(data.sampling, x, taus, hold=data.hold)
            for k in range(len(taus)):
                out[f"lag_{name}_{k}"] = lx[:, k]
        out["integral"] = np.concatenate([[0.0], np.cumsum(0.5 * (s[:-1] + s[1:]) * np.diff(t))])
        out["rate"] = np.gradient(s, t) * data.dt_median
        if data.temperature is not None:
            dT = data.temperature - np.mean(data.temperature)
            out["temperature"] = dT
            out["temperature_squared"] = dT ** 2
            for g in (data.span / 20, data.span / 5):
                out[f"temperature_lag_{g:.3g}s"] = lag_states(data.sampling, dT, [g], hold=data.hold)[:, 0]
            out["temperature_load"] = dT * s
            for k in range(lags.shape[1]):
                out[f"temperature_creep_{k}"] = dT * lags[:, k]
        return out


CATCH_ALL = CatchAll()


# --------------------------------------------------------------------------------------------
# The engine
# --------------------------------------------------------------------------------------------

def _heldout_sse(fit: Fit) -> float:
    return float(np.sum(fit.heldout.residual ** 2))


def _plain(x):
    """A reported value as JSON holds it: numbers as float, kinds and lists of times as they are."""
    return x if x is None or isinstance(x, (str, list, tuple)) else float(x)


def _finding(effect: Effect, applied: Applied, fit: Fit, evidence: Evidence, before: Fit) -> Finding:
    reported = effect.report(fit, applied)
    params = {k: _plain(v[0]) for k, v in reported.items()}
    sigma = {k: _plain(v[1]) for k, v in reported.items()}
    return Finding(effect.name, params, sigma, evidence, _heldout_sse(before) - _heldout_sse(fit), fit,
                   note=effect.note(fit, applied))


def _applied_of(fit: Fit, effect: Effect) -> Applied:
    return [a for a in fit.structure.effects if a.effect is effect][-1]


def _catch_all(data: Data, current: Fit) -> Fit | None:
    """The generic extension on top of ``current`` (its nonlinear parameters kept)."""
    try:
        return CATCH_ALL.fit_on(data, current, refine="none")
    except (InputError, np.linalg.LinAlgError, ValueError):
        return None


def _polish(data: Data, current: Fit, candidate: Fit, workers: Workers) -> Fit:
    """``current`` refitted from the candidate's values of the parameters they share, kept
    when that fits better: an improvement must come from the candidate's own parameters,
    not from a better optimum of the shared ones (:func:`_polish_refit`, :func:`_polish_kept`)."""
    return _polish_kept(data, current, _polish_refit(data, current, candidate), workers)


def _polish_refit(data: Data, current: Fit, candidate: Fit) -> Fit | None:
    """``current`` refitted from the candidate's values of the parameters they share, when
    that fits better (else None)."""
    shared = {p.name: candidate.values[p.name] for p in current.params if p.name in candidate.values}
    try:
        alt = fit_structure(data, current.structure, [shared], n_refine=1)
    except (InputError, np.linalg.LinAlgError, ValueError):
        return None
    return alt if alt.bic < current.bic - 1e-6 else None


def _polish_kept(data: Data, current: Fit, alt: Fit | None, workers: Workers) -> Fit:
    """The refit ``alt`` of :func:`_polish_refit` in place of ``current``, unless it predicts
    held-out data worse by the evidence rule's margin
    (:data:`~creepcomp.fit.evidence.HELDOUT_Z`): the optimum then sits where the record
    leaves a parameter free (a time offset's width), and against that reference any
    candidate would seem to predict better. Its held-out refits run side by side in
    ``workers``."""
    if alt is None:
        return current
    alt = _heldout_side_by_side(data, alt, workers)
    return current if compare(current, alt).heldout_z <= -HELDOUT_Z else alt


def _heldout_side_by_side(data: Data, fit: Fit, workers: Workers) -> Fit:
    """:func:`~creepcomp.fit.evidence.heldout` with the folds' refits side by side in
    ``workers`` (when it has processes side by side): the same prediction."""
    if workers.width == 1:
        return heldout(data, fit)
    return heldout(data, fit, refit_all=lambda keeps: workers.map(fold_refit, FoldRefits(fit), keeps))


#: Candidates refined fully at each step (the best by the quick fit, plus any that already
#: lower BIC).
REFINED = 3
#: A quick fit whose own parameters raise the log-likelihood by less than this is not refined
#: with every parameter free, even among the :data:`REFINED` best: nothing in the record points
#: to the effect. (On 60 fleet units and the 22 timing records of ``docs/benchmarks.md``, none
#: of the 116 candidates below it came within the evidence rule's BIC when refined; of the 102
#: above it whose quick fit still raised BIC, one did.)
QUICK_HINT = 1.0


def _restart_taus(data: Data, fit: Fit) -> Fit:
    """The fit refined again from the best of a log grid of values for each retardation time
    (the others and the effects' parameters held), when one fits better than where it is: the
    effect may have moved the optimum of the time constants far from the baseline's."""
    values = {p.name: fit.values[p.name] for p in fit.params}
    problem = Problem(data, fit.structure)
    here = problem.cost(values)
    best, best_cost = None, here
    for k in range(fit.structure.n_terms):
        for tau in tau_grid(data, per_decade=3):
            trial = dict(values, **{f"tau[{k}]": float(tau)})
            c = problem.cost(trial)
            if c < best_cost:
                best, best_cost = trial, c
    if best is None or best_cost > 0.999 * here:
        return fit
    try:
        alt = fit_structure(data, fit.structure, [best], n_refine=1)
    except (InputError, np.linalg.LinAlgError, ValueError):
        return fit
    return alt if alt.bic < fit.bic else fit


@dataclass(frozen=True)
class Candidate:
    """A candidate effect fitted on top of the current model at one step of the search.

    Attributes
    ----------
    effect : Effect
    fit : Fit
        The current model extended by the effect.
    delta_bic : float
        Its BIC minus the current model's.
    evidence : Evidence or None
        Against the current model, once tested on held-out data.
    trial : int or None
        Index of its entry among the trials, once accepted.
    """

    effect: Effect
    fit: Fit
    delta_bic: float
    evidence: Evidence | None = None
    trial: int | None = None


@dataclass
class Search:
    """The state of the search for effects, step by step.

    Attributes
    ----------
    current : Fit
        The model found so far (the baseline before any effect).
    base : Fit or None
        The baseline (as refitted at the first step).
    findings : list of Finding
        The effects accepted, in order.
    trials : list of Trial
        Every candidate tried.
    catch_all_on : tuple
        ``(model, Generic or None)``: the catch-all on top of the last model it was fitted on
        (the current model only moves on: an earlier one is not needed again).
    verdict_on : tuple
        ``((model, baseline), parts)``: the verdict's parts (:func:`_verdict_part`) computed
        ahead for a model and baseline (none yet: both None).
    floor : NoiseFloor
        The record's noise floor, computed beside the baseline's fit (given with it).
    """

    current: Fit
    base: Fit | None = None
    findings: list = field(default_factory=list)
    trials: list = field(default_factory=list)
    catch_all_on: tuple = (None, None)
    verdict_on: tuple = ((None, None), None)
    floor: NoiseFloor | None = None

    def catch_all(self, data: Data) -> "Generic | None":
        """The catch-all on top of the current model (:func:`_generic`), fitted once."""
        if not self.has_catch_all():
            self.catch_all_on = (self.current, _generic(data, self.current))
        return self.catch_all_on[1]

    def has_catch_all(self) -> bool:
        """Whether the catch-all on top of the current model is fitted already."""
        return self.catch_all_on[0] is self.current


@dataclass(frozen=True)
class Generic:
    """The catch-all on top of a model, and its evidence against it."""

    fit: Fit
    evidence: Evidence


def _no_evidence() -> Evidence:
    return Evidence(float("nan"), float("nan"), float("nan"))


def _quick(data: Data, current: Fit, effect: Effect, step: int, trials: list,
           fresh: dict | None = None) -> Candidate | None:
    """The effect on top of ``current``, its own parameters fitted (the current model's held)
    by a quick fit that only ranks it (:class:`~creepcomp.diagnose.effects.QuickFit`, with the
    fits ``fresh`` that ran ahead); None when it cannot be tried (the trial says why)."""
    reason = effect.applicable(data, current.structure)
    if reason:
        if step == 1:
            trials.append(Trial(step, effect.name, None, None, f"does not apply ({reason})"))
        return None
    try:
        f = effect.fit_on(data, current, refine="own", quick_fit=effects_pkg.QuickFit(fresh or {}))
    except NotApplicable as exc:
        trials.append(Trial(step, effect.name, None, None, f"does not apply ({exc})"))
        return None
    except (InputError, np.linalg.LinAlgError, ValueError) as exc:
        trials.append(Trial(step, effect.name, None, None, f"fit failed: {exc}"))
        return None
    return Candidate(effect, f, f.bic - current.bic)


def _refined(data: Data, current: Fit, candidate: Candidate) -> Candidate:
    """The candidate with every parameter fitted together, when that fits better."""
    f = candidate.fit
    try:
        full = candidate.effect.fit_on(data, current, refine="all",
                                       start={p.name: f.values[p.name] for p in f.params})
    except (InputError, np.linalg.LinAlgError, ValueError):
        return candidate
    if full.bic >= f.bic:
        return candidate
    return Candidate(candidate.effect, full, full.bic - current.bic)


def _screen(data: Data, current: Fit, pool, step: int, trials: list, workers: Workers,
            verdict: tuple | None = None, fresh: dict | None = None) -> tuple[list[Candidate], tuple | None]:
    """Every applicable candidate fitted on top of ``current``: a quick fit of its own
    parameters first (the current model's held); then all parameters together for the
    :data:`REFINED` best and for any other that already lowers BIC, when they raise the
    likelihood at all (:data:`QUICK_HINT`): the best by BIC is accepted, and a quick fit
    understates what a candidate explains (a static nonlinearity's quick fit lowered BIC by
    3,661, refined by 13,050, more than the hysteresis accepted without it). Best first.
    The candidates' fits run side by side in ``workers``: one that lowers BIC, or with two
    processes or more raises it by less than :data:`~creepcomp.fit.evidence.BIC_STRONG`, is
    refined right after its quick fit (:func:`_refined_ahead`: a refinement left until the
    ranks are known would run in a short map of its own, one process waiting for the other).
    ``verdict``: ``(baseline, correction)`` (baseline None: ``current`` is it); when
    refinements are left after the screen and no other candidate is strong enough to be
    tested, the step likely ends here: the verdict's parts (:func:`_verdict_part`) for
    ``current``, and the catch-all on top of it, run beside those refinements. ``fresh``:
    fits with the creep term started afresh, run ahead
    (:attr:`~creepcomp.diagnose.effects.QuickFit.fresh`).

    Returns
    -------
    candidates : list of Candidate
    verdict : tuple or None
        ``(((current, baseline), parts), (current, catch-all))`` when the verdict's parts ran
        (:attr:`Search.verdict_on`, :attr:`Search.catch_all_on`), else None.
    """
    # (a candidate's quick fit takes longer at the first step, from the one-term baseline: its
    # time there is known apart, for the longest to run first)
    done = workers.map(_quick_task, (current, step, workers.width > 1, fresh or {}), pool,
                       [(e.name, step == 1) for e in pool])
    screened = []        # [quick fit, its refinement or None]
    for candidate, full, tried in done:
        trials.extend(tried)
        if candidate is not None:
            screened.append([candidate, full])
    screened.sort(key=lambda pair: pair[0].delta_bic)
    for rank, pair in enumerate(screened):
        if pair[1] is not None and not _worth_refining(current, pair[0], rank):
            pair[1] = None        # (refined ahead, but not among the REFINED best)
    later = [pair for rank, pair in enumerate(screened)
             if pair[1] is None and _worth_refining(current, pair[0], rank)]
    ahead = None
    if later:
        parts = []
        if verdict is not None and not any((quick if full is None else full).delta_bic <= -BIC_STRONG
                                           for quick, full in screened):
            parts = ["correction", "record", "catch-all"]
            base = current if verdict[0] is None else verdict[0]
        common = (current, base, verdict[1]) if parts else (current, None, None)
        done = workers.map(_later_task, common, [pair[0] for pair in later] + parts,
                           [pair[0].effect.name for pair in later] + parts)
        for pair, full in zip(later, done):
            pair[1] = full
        if parts:
            correction, record, generic = done[len(later):]
            ahead = (((current, base), [correction, record]), (current, generic))
    fitted = [c for c in (quick if full is None else full for quick, full in screened)
              if not _unphysical(c, step, trials)]
    return sorted(fitted, key=lambda c: c.delta_bic), ahead


def _later_task(data: Data, common: tuple, item: "Candidate | str"):
    """A task of :class:`Workers` after the screen: a candidate's refinement (:func:`_refined`),
    or a part of the verdict (:func:`_verdict_part`; ``common``: the current model, the
    baseline, whether the correction is measured)."""
    if isinstance(item, str):
        return _verdict_part(data, common, item)
    return _refined(data, common[0], item)


def _worth_refining(current: Fit, candidate: Candidate, rank: int) -> bool:
    """The quick fit is refined with every parameter free: it is among the :data:`REFINED`
    best (``rank``) or lowers BIC already, and it raises the likelihood by
    :data:`QUICK_HINT` at least."""
    return (rank < REFINED or candidate.delta_bic < 0) and candidate.fit.loglik - current.loglik >= QUICK_HINT


def _quick_task(data: Data, common: tuple, effect: Effect) -> tuple:
    """:func:`_quick` as a task of :class:`Workers`: the candidate, its refinement when it is
    refined ahead of its rank (:func:`_refined_ahead`; else None), and the trials it adds.
    ``common``: the current model, the step, whether to refine ahead, the fits with a creep
    term started afresh that ran ahead (:attr:`~creepcomp.diagnose.effects.QuickFit.fresh`)."""
    current, step, ahead, fresh = common
    tried = []
    candidate = _quick(data, current, effect, step, tried, fresh)
    full = None
    if candidate is not None and _refined_ahead(current, candidate, ahead):
        full = _refined(data, current, candidate)
    return candidate, full, tried


def _refined_ahead(current: Fit, candidate: Candidate, ahead: bool) -> bool:
    """The quick fit is refined in its own task (:func:`_quick_task`): it raises the likelihood
    by :data:`QUICK_HINT` at least, and it lowers BIC (then it is refined whatever its rank)
    or, with ``ahead`` (processes side by side), raises it by less than
    :data:`~creepcomp.fit.evidence.BIC_STRONG` (then it is likely among the :data:`REFINED`
    best, refined after the screen otherwise: the refinement is dropped when it is not; in one
    process that is time lost)."""
    limit = BIC_STRONG if ahead else 0.0
    return candidate.delta_bic < limit and candidate.fit.loglik - current.loglik >= QUICK_HINT


def _unphysical(candidate: Candidate, step: int, trials: list) -> bool:
    """The candidate's fitted parameters cannot be its effect (its trial says why)."""
    effect = candidate.effect
    reason = effect.unphysical(candidate.fit, _applied_of(candidate.fit, effect))
    if reason:
        trials.append(Trial(step, effect.name, candidate.delta_bic, None, f"unphysical: {reason}"))
    return bool(reason)


def _polish_from(fitted: list[Candidate]) -> Fit | None:
    """The fit of the best candidate when it lowers BIC strongly: the current model is then
    refitted from its values (:func:`_polish`) before the candidates are judged."""
    return fitted[0].fit if fitted and fitted[0].delta_bic <= -BIC_STRONG else None


def _against(fitted: list[Candidate], current: Fit) -> list[Candidate]:
    """The candidates with their BIC against ``current``, best first."""
    return sorted((replace(c, delta_bic=c.fit.bic - current.bic) for c in fitted), key=lambda c: c.delta_bic)


def _plain_form(data: Data, current: Fit, candidate: Candidate) -> Candidate:
    """When an effect's shaped template is not supported, its plain form
    (:meth:`~creepcomp.diagnose.effects.SensorEffect.plain_settings`) in its place if that is:
    a free shape parameter can trade off against others (a thermal lag against flow) and
    predict held-out data worse than the plain template."""
    effect = candidate.effect
    plain = effect.plain_settings(data, current)
    if plain is None:
        return candidate
    try:
        g = effect.fit_on(data, current, refine="all", settings=plain)
        if g.bic - current.bic > -BIC_STRONG or effect.unphysical(g, _applied_of(g, effect)):
            return candidate
        g = heldout(data, _restart_taus(data, g))
    except (InputError, np.linalg.LinAlgError, ValueError):
        return candidate
    ev_plain = _evidence(data, current, g)
    return Candidate(effect, g, g.bic - current.bic, ev_plain) if ev_plain.supported else candidate


def _tested(data: Data, current: Fit, item: "_Test | _PolishRefit | None"):
    """A task of the held-out tests (:func:`_test_batch`). For a :class:`_Test`: the
    candidate's fit refitted from a grid of retardation times (:func:`_restart_taus`), with
    its held-out prediction, and the candidate judged on it (:func:`_judged`), as ``(refit,
    judged)`` (the refit alone when it is not ``whole``). For None: the catch-all on top of
    ``current`` (:func:`_generic`). For a :class:`_PolishRefit`: :func:`_polish_refit`."""
    if item is None:
        return _generic(data, current)
    if isinstance(item, _PolishRefit):
        return _polish_refit(data, current, item.candidate)
    fit, held_out = item.refit or (_restart_taus(data, item.candidate.fit), False)
    if not item.whole:
        return fit
    if not held_out:
        fit = heldout(data, fit)
    return fit, _judged(data, current, item.candidate, fit)


@dataclass(frozen=True)
class _Test:
    """A candidate's held-out test (a task of :func:`_tested`): from its refit when made
    already (``refit``: the fit, and whether its held-out prediction is made); to its refit
    alone unless ``whole``."""

    candidate: Candidate
    refit: tuple | None = None
    whole: bool = True


@dataclass(frozen=True)
class _PolishRefit:
    """The current model to be refitted from a candidate's values (a task of
    :func:`_tested`)."""

    candidate: Fit


def _judged(data: Data, current: Fit, candidate: Candidate, fit: Fit) -> Candidate:
    """The candidate with ``fit`` (refitted, with its held-out prediction) and its evidence
    against ``current`` (its plain form in its place when only that is supported) and, when
    supported, its covariance computed (a finding reports it)."""
    candidate = replace(candidate, fit=fit, evidence=_evidence(data, current, fit))
    if not candidate.evidence.supported:
        candidate = _plain_form(data, current, candidate)
    if candidate.evidence.supported:
        candidate.fit.cov       # (computed where the test runs, beside the others)
    return candidate


#: A candidate's held-out test is split (:func:`_test_batch`) when it is known to take at
#: least this many times as long as the tasks beside it together (the catch-all, and the
#: polish's refit when it runs). (Its refit takes about a quarter of it, its five held-out
#: refits two thirds, which two processes share at best as three to two, each computing the
#: fit's Jacobian: by those shares the split gains from about 2.2 times on.)
SPLIT_TEST = 2.5


def _test_is_longer(name: str, beside: list) -> bool:
    """The test of the effect ``name`` took :data:`SPLIT_TEST` times as long as the tasks
    ``beside`` it (their keys) together, each when last run side by side."""
    test, others = last_seconds(_tested, name), [last_seconds(_tested, key) for key in beside]
    return test is not None and None not in others and test >= SPLIT_TEST * sum(others)


def _test_batch(data: Data, current: Fit, candidates: list[Candidate], catch_all: bool,
                workers: Workers, refits: dict, polish: Fit | None = None) -> tuple:
    """:func:`_tested` of each candidate, of the catch-all when ``catch_all`` and of the
    current model's refit from ``polish`` (:func:`_polish_refit`) when given, side by side in
    ``workers``. ``refits``: each candidate's refit, by effect name (:attr:`_Test.refit`),
    made already (used) and made here (added). A lone candidate beside the catch-all whose test
    is known to take :data:`SPLIT_TEST` times as long as the tasks beside it is tested in
    parts, the same test: its refit beside them, then its held-out refits side by side, then
    its evidence here (else one process would wait for the other).

    Returns
    -------
    judged : list of Candidate or None
        None when the refit from ``polish`` is kept.
    catch_all : Generic or None
    current : Fit
        The current model: polished (:func:`_polish_kept`), or ``current``.
    """
    names = [c.effect.name for c in candidates]
    tests = [_Test(c, refits.get(name)) for c, name in zip(candidates, names)]
    keys = [name + " (judged)" if name in refits else name for name in names]
    # (the catch-all's time is known apart on the baseline and on each larger model: whether
    # it needs held-out refits, and so its time, changes with the model)
    more, more_keys = [None] * catch_all, [("catch-all", len(current.structure.effects))] * catch_all
    if polish is not None:
        more, more_keys = more + [_PolishRefit(polish)], more_keys + ["polish"]
    split = (workers.width > 1 and catch_all and len(candidates) == 1 and names[0] not in refits
             and _test_is_longer(names[0], more_keys))
    if split:
        tests, keys = [replace(tests[0], whole=False)], [names[0] + " (refit)"]
    done = workers.map(_tested, current, tests + more, keys + more_keys)
    polished = current if polish is None else _polish_kept(data, current, done.pop(), workers)
    generic = done.pop() if catch_all else None
    if split:
        refits[names[0]] = (done[0], False)
    else:
        refits.update((name, (fit, True)) for name, (fit, _) in zip(names, done))
    if polished is not current:
        return None, None, polished
    if split:
        refits[names[0]] = (_heldout_side_by_side(data, done[0], workers), True)
        return [_judged(data, current, candidates[0], refits[names[0]][0])], generic, current
    return [judged for _, judged in done], generic, current


def _generic_better(data: Data, search: Search, fit: Fit) -> bool:
    """The catch-all on top of the current model predicts held-out data clearly better than
    ``fit`` (then the structure is not what the candidate says)."""
    wide = search.catch_all(data)
    return (wide is not None and wide.evidence.supported and wide.fit.bic < fit.bic
            and _evidence(data, fit, wide.fit, refine=False, always_halves=True).supported_heldout)


def _choose(data: Data, search: Search, fitted: list[Candidate], step: int,
            workers: Workers, polish: Fit | None = None, refits: dict | None = None) -> Candidate | None:
    """The candidate accepted at this step (best first; a simpler one that explains at least
    half as much and predicts held-out data as well replaces it), or None; every candidate
    tried gets its trial. Candidates are tested on held-out data as many at a time as
    ``workers`` has processes (the next ones that may need it); the first with the catch-all
    on top of the current model, which the step needs whatever it finds (to judge the
    candidate accepted, or the model found when none is), and with the simpler alternatives
    its acceptance would test.

    ``polish``: the fit from which the current model is refitted first (:func:`_polish`); the
    refit runs beside the first tests, which stand when it is not kept (nearly always). When
    it is, it is the current model, and the candidates are chosen again against it, on the
    refits made (``refits``, by effect name: a candidate's refit does not depend on the
    current model)."""
    current, trials = search.current, search.trials
    refits = {} if refits is None else refits
    accepted = None
    tested: dict[int, Candidate] = {}
    for at, candidate in enumerate(fitted):
        name = candidate.effect.name
        why_not = gate(candidate, accepted, current)
        if why_not:
            trials.append(Trial(step, name, candidate.delta_bic, None, why_not))
            continue
        if at not in tested:
            more = [] if search.has_catch_all() else [None]
            batch = [k for k in range(at, len(fitted))
                     if k not in tested and not gate(fitted[k], accepted, current)]
            if more:    # (the step's first: the first candidate and what its acceptance would test)
                ahead = [k for k in batch[1:] if not gate(fitted[k], fitted[at], current)]
                batch = [at] + ahead[:workers.width - 1]
            else:
                batch = batch[:workers.width]
            done, generic, polished = _test_batch(data, current, [fitted[k] for k in batch], bool(more),
                                                  workers, refits, polish)
            if polished is not current:
                search.current = polished
                return _choose(data, search, _against(fitted, polished), step, workers, None, refits)
            polish = None
            if more:
                search.catch_all_on = (current, generic)
            tested.update(zip(batch, done))
        candidate = tested[at]
        # (the catch-all and the comparison with the accepted one cost fits: asked only when
        # the rule needs them)
        judged = judge(candidate, accepted,
                       generic_better=lambda: _generic_better(data, search, candidate.fit),
                       richer_predicts_better=lambda: compare(candidate.fit, accepted.fit).supported_heldout)
        if judged.demoted is not None:
            trials[accepted.trial] = Trial(step, accepted.effect.name, accepted.delta_bic, accepted.evidence,
                                           judged.demoted)
        if judged.accept:
            accepted = replace(candidate, trial=len(trials))
        trials.append(Trial(step, name, candidate.delta_bic, candidate.evidence, judged.outcome))
        if judged.stop:
            break
    return accepted


def _record(search: Search, accepted: Candidate) -> None:
    """The accepted candidate becomes a finding, its fit the current model."""
    effect, f = accepted.effect, accepted.fit
    search.findings.append(_finding(effect, _applied_of(f, effect), f, accepted.evidence, search.current))
    search.current = f


def _baseline_task(data: Data, common: None, item: "Effect | str"):
    """A task of :class:`Workers` at the start of a diagnosis: the baseline (``"baseline"``:
    the one-term model fitted from a grid of starts, with its held-out prediction, which the
    first screen's ranks need), or what reads the record only: an effect's fit with the creep
    term started afresh (:func:`~creepcomp.diagnose.effects.fresh_fits_ahead`), the noise floor
    (``"floor"``)."""
    if isinstance(item, Effect):
        return effects_pkg.fresh_fits_ahead(data, item)
    if item == "floor":
        return _noise_floor(data)
    return heldout(data, fit_structure(data, Structure(1), one_term_starts(data)))


def _search(data: Data, pool, max_effects: int, workers: Workers, correction: bool = True) -> Search:
    """Effects added one at a time while a candidate is supported (steps 1 and 2 of the
    module's description); the baseline and the candidates of a step fitted side by side in
    ``workers`` (``correction``: the verdict measures the correction, for its parts run ahead,
    :func:`_screen`)."""
    # (with processes side by side, the first screen's fits with a creep term started afresh
    # run beside the baseline's fit: they read the record only; listed first, for a process
    # that has timed none yet: the time offset's is the longest task)
    beside = [e for e in pool if getattr(e, "fresh_ahead", None) and not e.applicable(data, Structure(1))] \
        if workers.width > 1 else []
    names = [e.name for e in beside] + ["baseline", "floor"]
    *fresh_fits, baseline, floor = workers.map(_baseline_task, None, beside + ["baseline", "floor"], names)
    fresh = {key: fit for fits in fresh_fits for key, fit in fits.items()}
    search = Search(baseline, floor=floor)
    for step in range(1, max_effects + 1):
        screened, ahead = _screen(data, search.current, pool, step, search.trials, workers,
                                  (search.base, correction), fresh if step == 1 else {})
        if ahead is not None:
            search.verdict_on, search.catch_all_on = ahead
        polish = _polish_from(screened)
        if polish is not None and workers.width == 1:
            # (nothing runs beside the refit: it runs first, and no test is made twice)
            polished = _polish(data, search.current, polish, workers)
            if polished is not search.current:
                search.current, screened = polished, _against(screened, polished)
            polish = None
        accepted = _choose(data, search, screened, step, workers, polish)
        if search.base is None:
            search.base = search.current
        if accepted is None:
            break
        _record(search, accepted)
    if search.base is None:
        search.base = search.current
    return search


def diagnose(record, initial: str = "free", load_step_at: float | None = None,
             candidates: list[str] | None = None, max_effects: int = MAX_EFFECTS,
             correction: bool = True, max_samples: int | None = DIAGNOSE_MAX_SAMPLES,
             jobs: int = 1) -> Diagnosis:
    """Diagnose a record: baseline, candidate effects by evidence, catch-all, gain.

    Parameters
    ----------
    record : Record, path, open file, data frame or mapping of arrays
        Read by :func:`~creepcomp.io.formats.read_any` unless a :class:`Record`.
    initial : {"free", "relaxed", "settled"}
        Creep state at the first sample (see :func:`creepcomp.fit.data.prepare`).
    load_step_at : float, optional
        Time of a load step before the first sample (material creep tests).
    candidates : list of str, optional
        Effects to try (default: every sensor-side effect the record allows).
    max_effects : int
    correction : bool
        Measure the gain on the creep-corrected signal too.
    max_samples : int or None
        Longer records are reduced to about this many samples first (None: never); one
        already reduced (``metadata["reduced"]``, :func:`~creepcomp.fit.reduce.read_reduced`) is not.
    jobs : int
        Processes that fit the candidates of a step side by side, this one included, forked
        on Linux (1: this one alone, as anywhere else; see :class:`~creepcomp.diagnose.workers.Workers`);
        the result is the same bit for bit.

    Returns
    -------
    Diagnosis

    Examples
    --------
    The bundled record hides a recovery slower than its creep:

    >>> from creepcomp import data
    >>> from creepcomp.diagnose.sensor import diagnose
    >>> result = diagnose(data.hidden_effect())
    >>> result.cause
    'asymmetric_recovery'
    >>> round(result.findings[0].parameters["tau_recovery"], -1)
    150.0
    """
    t_start = _time.perf_counter()
    record = read_any(record)
    if isinstance(jobs, bool) or not isinstance(jobs, numbers.Integral) or jobs < 1:
        raise InputError(f"jobs = {jobs}: use a whole number of processes, 1 or more")
    reduced = record.metadata.get("reduced")    # reduced once already, while read (fit.reduce)
    if max_samples is not None and reduced is None:
        record, reduced = reduce_record(record, max_samples)
    # (a diagnosis needs the noise floor's windows: fit's sparse minimum is not its own)
    data = prepare(record, initial=initial, load_step_at=load_step_at, min_samples=SPARSE_SAMPLES)
    pool = effects_pkg.sensor_effects() if candidates is None else [effects_pkg.get(c) for c in candidates]
    # (small matrices: see creepcomp.fit.blas; lags evaluated thousands of times: see
    # creepcomp.lti.compiled_loops)
    # (more processes than candidates would wait)
    with one_blas_thread(), compiled_loops(), Workers(min(jobs, max(len(pool), 1)), data) as workers:
        search = _search(data, pool, max_effects, workers, correction)
        return _verdict(data, search, correction, reduced, t_start, workers)


def _unexplained(data: Data, search: Search, floor: NoiseFloor) -> tuple:
    """The catch-all's evidence on top of the model found (None: it could not be fitted) and
    the ``unexplained`` finding (None: none), step 3 of the module's description."""
    current, findings = search.current, search.findings
    generic = search.catch_all(data)
    catch = generic.evidence if generic is not None else None
    reason = _unexplained_reason(current.residual_rms, catch, bool(findings), floor.rms)
    if reason == "catch-all":
        return catch, Finding("unexplained", _remaining(current, floor), {}, catch,
                              _heldout_sse(current) - _heldout_sse(generic.fit), generic.fit)
    if reason == "misfit":
        return catch, Finding("unexplained", _remaining(current, floor), {}, catch or _no_evidence(), 0.0, None,
                              note=_misfit_note(current, floor))
    return catch, None


def _faults(data: Data, current: Fit, base: Fit) -> list[tuple[str, dict]]:
    """The faults of the record that no model column undoes (clipping, channels out of step,
    coarse quantisation), each with the name of the sensor effect that screened it."""
    return [(effect.name, problem) for effect in effects_pkg.sensor_effects()
            for problem in effect.screen(data, current, base)]


def _screened(faults: list[tuple[str, dict]], current: Fit, base: Fit,
              findings: list[Finding]) -> list[Finding]:
    """The findings with the faults of the record (:func:`_faults`)."""
    for name, problem in faults:
        effect = effects_pkg.get(name)
        named = any(f.effect != "unexplained" for f in findings)
        importance, note = effect.screened_importance(problem, current, base, named)
        if note is not None:
            findings = [replace(f, note=note) if f.effect != "unexplained" else f for f in findings]
        findings.append(Finding(effect.name, problem, dict.fromkeys(problem), _no_evidence(), importance))
    return findings


def _verdict_part(data: Data, common: tuple, part: str):
    """One of the verdict's independent parts, as a task of :class:`Workers`: the errors of
    the creep-corrected signal (``correction``: :func:`correction_errors`, empty when not
    measured), the rest that needs no model search (``record``: the faults of the record and
    the two model files), or the catch-all on top of the model (``catch-all``: :func:`_generic`,
    when not fitted yet)."""
    current, base, correction = common
    if part == "catch-all":
        return _generic(data, current)
    extensions = _extensions(current)
    if part == "correction":
        return correction_errors(data, base, current, extensions) if correction else {}
    extended_model = _with_temperature_law(model_file_dict(data, current, extensions=extensions), current)
    return _faults(data, current, base), extended_model, model_file_dict(data, base)


def _noise_floor(data: Data) -> NoiseFloor:
    """The record's noise floor (:func:`~creepcomp.fit.noise.noise_floor`) against which the
    verdict judges the misfit."""
    floor = noise_floor(data.signal, data.load, data.time, follows_lag=True, weights=data.weights,
                        samples=data.samples)
    return with_reference_noise(floor, data.signal, data.load, data.reference_noise)


def _verdict(data: Data, search: Search, correction: bool, reduced, t_start: float,
             workers: Workers) -> Diagnosis:
    """The verdict on the search's model (step 3 and 4 of the module's description): the
    catch-all, the gain, the faults of the record, the findings in order. Its parts
    (:func:`_verdict_part`) run side by side in ``workers``, which are released then, unless
    they ran ahead for this model (:attr:`Search.verdict_on`); so does the catch-all on top of
    the model when not fitted yet."""
    current, base, findings = search.current, search.base, list(search.findings)
    (model, baseline), parts = search.verdict_on
    if model is not current or baseline is not base:
        names = ["correction", "record"] + ["catch-all"] * (not search.has_catch_all())
        parts = workers.map(_verdict_part, (current, base, correction), names, names)
        if len(names) > 2:
            search.catch_all_on = (current, parts.pop())
    workers.release()
    corr, (faults, extended_model, baseline_model) = parts
    floor = search.floor
    catch, unexplained = _unexplained(data, search, floor)
    gain = {"heldout_rms_ratio": base.heldout.rms / current.heldout.rms if current.heldout.rms > 0 else None,
            "correction_error_ratio": None}
    if corr:
        gain["correction_error_ratio"] = corr["ratio"]
        gain["correction_error_baseline"] = corr["baseline_rms"]
        gain["correction_error_extended"] = corr["extended_rms"]
        if "unsettled" in corr:
            gain["correction_unsettled"] = corr["unsettled"]
        if correction_is_worse(corr):
            findings = _correction_notes(data, base, findings)
    findings = order(_screened(faults, current, base, findings), unexplained)
    return Diagnosis(data, base, current, tuple(findings), tuple(search.trials), catch, gain,
                     _time.perf_counter() - t_start, extended_model, baseline_model, corr, floor,
                     reduced)


def _extensions(fit: Fit) -> dict:
    out = {}
    for a in fit.structure.effects:
        entry = a.effect.extension(fit, a)
        if entry is not None:
            out[a.name] = entry
    return out


def _with_temperature_law(model: dict, fit: Fit) -> dict:
    """The model file with the ``temperature`` block an effect of the fit implies (the first)."""
    for a in fit.structure.effects:
        law = a.effect.temperature_law(fit, a)
        if law is not None:
            out = {k: v for k, v in model.items() if k not in ("extensions", "uncertainty", "fit")}
            out["temperature"] = law.to_dict()
            out.update({k: v for k, v in model.items() if k not in out})
            return out
    return model


def _remaining(fit: Fit, floor: NoiseFloor) -> dict:
    """What is left above the floor: the misfit ratio and the RMS of the excess (signal units)."""
    ratio = ratio_to_floor(fit.residual_rms, floor)
    excess = float(np.sqrt(max(fit.residual_rms ** 2 - floor.rms ** 2, 0.0)))
    return {"misfit_ratio": ratio, "excess_rms": excess}


def _misfit_note(fit: Fit, floor: NoiseFloor) -> str:
    return (f"the model misses the record by {fit.residual_rms / floor.rms:.3g} times the noise floor "
            f"(residual RMS {fit.residual_rms:.4g}, floor {floor.rms:.4g} signal units): structure no "
            f"candidate explains")


def _correction_notes(data: Data, base: Fit, findings: list[Finding]) -> list[Finding]:
    """Each named finding with the correction-error ratio of adding it (the model before it /
    with it); a finding that makes the creep-corrected signal worse says so, and so does one
    with which the correction finds no load that gives the signal."""
    out, before = [], base
    by_step = [f for f in findings if f.effect != "unexplained"]
    for f in by_step:
        corr = correction_errors(data, before, f.fit, _extensions(f.fit))
        ratio = corr.get("ratio") if corr else None
        f = replace(f, correction_error_ratio=ratio)
        extra = None
        if f.worsens_correction:
            extra = _worse_note(data, before, f, corr)
        elif corr and "unsettled" in corr:
            extra = (f"the creep correction with it finds no load that gives the signal "
                     f"({corr['unsettled']}): its correction error is not measured; "
                     f"{effects_pkg.BASELINE_ADVICE}")
        if extra:
            f = replace(f, note=f"{f.note}; {extra}" if f.note else extra)
        out.append(f)
        before = f.fit
    return out + [f for f in findings if f.effect == "unexplained"]


def _worse_note(data: Data, before: Fit, finding: Finding, corr: dict) -> str:
    """The note of a finding that makes the creep-corrected signal worse (its effect's words);
    for a fault of the record, with the ratio measured with the fault taken out of the signal."""
    effect = effects_pkg.get(finding.effect)
    fault = effect.record_fault(finding.fit, _applied_of(finding.fit, effect), data)
    without = None
    if fault is not None:
        fixed = correction_errors(data.with_signal(data.signal - fault), before, finding.fit,
                                  _extensions(finding.fit))
        if fixed and fixed.get("extended_rms"):
            without = corr["baseline_rms"] / fixed["extended_rms"]
    return effect.worse_correction_note(corr["ratio"], without)


def _evidence(data: Data, current: Fit, rich: Fit, refine: bool = True,
              always_halves: bool = False) -> Evidence:
    """Evidence for ``rich`` over ``current`` (:func:`~creepcomp.fit.evidence.compare_with_halves`):
    BIC and held-out blocks, and when the richer model's residual holds slow noise also the
    prediction of each half of the record from the other (``refine``: refit the richer
    model's nonlinear parameters on each half). ``always_halves``: test across halves in any
    case (the catch-all, whose many slow terms follow drift easily)."""
    return compare_with_halves(current, rich,
                               lambda: (halves(data, current), halves(data, rich, refine=refine)),
                               always_halves)


def _generic(data: Data, current: Fit) -> Generic | None:
    """The catch-all on top of ``current`` with its evidence (held out only when BIC
    supports it)."""
    wide = _catch_all(data, current)
    if wide is None:
        return None
    if wide.bic - current.bic > -BIC_STRONG:
        return Generic(wide, Evidence(wide.bic - current.bic, float("nan"), float("nan")))
    wide = heldout(data, wide, refine=False)
    return Generic(wide, _evidence(data, current, wide, refine=False, always_halves=True))


def correction_errors(data: Data, base: Fit, extended: Fit, extensions: dict) -> dict:
    """Creep-corrected signal with the baseline and with the extended model, and the RMS of
    each one's error against the load scaled to it (least-squares gain and offset).

    The correction assumes a relaxed start when the load starts at zero, a settled one
    otherwise. Where the extended model's correction finds no load that gives the signal
    (:class:`~creepcomp.diagnose.effects.UnsettledInverse`), its error
    is not measured: the ratio is None and ``unsettled`` says how the correction's steps ended
    (a correction stopped half-way would be judged, not the model)."""
    from creepcomp.digital.correctors import fitted_reference_error

    initial = "relaxed" if data.load[0] == 0 else "settled"
    try:
        model_b = base.creep_model()
        model_e = extended.creep_model(extensions)
    except InputError:
        return {}
    out = {"initial": initial}
    for label, model in (("baseline", model_b), ("extended", model_e)):
        try:
            comp = compensate_extended(data.time, data.signal, model, data.temperature,
                                       initial=initial, hold=data.hold, converge=True)
        except UnsettledInverse as exc:
            if label == "baseline":
                return {}
            out.update(extended_rms=None, ratio=None, unsettled=exc.why)
            return out
        except (InputError, ImportError):
            return {}
        err = fitted_reference_error(comp, data.load)
        out[f"{label}_compensated"] = comp
        out[f"{label}_error"] = err
        out[f"{label}_rms"] = float(np.sqrt(np.mean(err ** 2)))
    out["ratio"] = out["baseline_rms"] / out["extended_rms"] if out["extended_rms"] > 0 else None
    return out
