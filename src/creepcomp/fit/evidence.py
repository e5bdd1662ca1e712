"""Evidence for a richer model over a simpler one: prediction of held-out data and the
information criterion.

Models are compared by BIC (:func:`creepcomp.fit.noise.gaussian_bic`) *and* by prediction
of held-out data: interleaved blocks are left out in turn, the model is refitted on the rest
and simulated over them; the spread of the held-out improvement is computed from the noise
spectrum, so that coloured noise does not pass for structure. When the residual holds slow
noise (drift), each half of the record must also be predicted from the other. Both sides of
the diagnosis decide by these rules.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np
from scipy import linalg

from creepcomp.errors import InputError
from creepcomp.fit.data import Data
from creepcomp.fit.noise import is_sparse, spectral_variance
from creepcomp.fit.solver import (ANCHOR_WEIGHT, Fit, Problem, _solve, best_of_starts, fit_structure,
                                  unit_scaled)
from creepcomp.fit.structure import basis, basis_derivatives

__all__ = ["BIC_STRONG", "HELDOUT_Z", "FOLDS", "BLOCKS", "MIN_BLOCK_SAMPLES",
           "UNDETERMINED_VARIANCE_RATIO", "SLOW_NOISE_RATIO", "HeldOut", "block_index",
           "half_blocks", "load_halves", "predict_held_out", "jacobian", "halves", "heldout", "fold_refit", "FoldRefits", "Evidence",
           "compare", "slow_noise_ratio", "BLOCK_MEMORY", "block_memory", "compare_with_halves"]

#: BIC difference that counts as strong evidence (Kass & Raftery 1995: 2 ln B > 10 is
#: "very strong"; a Bayes factor above ~150). With white-noise likelihoods this is a
#: parsimony filter more than a test: coloured noise inflates it, the held-out test decides.
BIC_STRONG = 10.0
#: Held-out improvement needed, in standard deviations of its noise (one-sided 0.13 % for
#: noise whose memory is shorter than a block; slow noise that spans blocks makes the test
#: optimistic, hence the margin over 2).
HELDOUT_Z = 3.0
#: Number of contiguous blocks held out in turn.
FOLDS = 5


@dataclass(frozen=True)
class HeldOut:
    """Prediction of data held out of the fit: contiguous blocks, one at a time.

    Attributes
    ----------
    residual : numpy.ndarray
        Measured minus predicted on every sample, each predicted by the fit without its block.
    blocks : numpy.ndarray of int
        Block of each sample.
    """

    residual: np.ndarray
    blocks: np.ndarray

    @property
    def rms(self) -> float:
        """RMS of the held-out residual."""
        return float(np.sqrt(np.mean(self.residual ** 2)))


#: Blocks the record is cut into; block ``b`` is held out in fold ``b % FOLDS``. Many short
#: blocks keep data from every part of the record (every load step's neighbourhood) in each
#: fit, so that held-out data test what the model predicts, not what one block alone shows.
BLOCKS = 40
#: Fewest samples in a block.
MIN_BLOCK_SAMPLES = 50


def block_index(data, blocks: int = BLOCKS) -> np.ndarray:
    """Contiguous blocks of equal numbers of samples (fewer blocks when the record is short);
    equal counts rather than equal durations keep log-spaced material tests balanced.
    ``data``: any prepared record (its number of samples ``n``)."""
    return _blocks_of(data.n, blocks)


def _blocks_of(n: int, blocks: int = BLOCKS) -> np.ndarray:
    """Block of each of ``n`` samples (see :func:`block_index`)."""
    blocks = max(FOLDS, min(blocks, n // MIN_BLOCK_SAMPLES))
    return np.minimum(np.arange(n) * blocks // n, blocks - 1)


def half_blocks(n: int) -> np.ndarray:
    """The two halves of ``n`` samples as blocks 0 and 1 (held out with ``folds = 2``)."""
    return np.minimum(np.arange(n) * 2 // n, 1)


def predict_held_out(blocks: np.ndarray, folds: int,
                     refit: Callable[[np.ndarray], np.ndarray] | None,
                     refit_all: Callable[[list], list] | None = None) -> HeldOut:
    """Held-out prediction: block ``b`` is in fold ``b % folds``; for each fold,
    ``refit(keep)`` fits the model on the samples ``keep`` (the other folds) and returns its
    residual on every sample, of which the fold's samples are kept. ``refit_all``: the
    refits of a list of ``keep`` side by side, in place of ``refit``. Both fits use it:
    :func:`heldout` and :func:`creepcomp.fit.circuit.with_heldout`."""
    fold = blocks % folds
    inside = [held for held in (fold == b for b in range(folds)) if held.any()]
    keeps = [~i for i in inside]
    residuals = refit_all(keeps) if refit_all is not None else [refit(keep) for keep in keeps]
    resid = np.empty(len(blocks))
    for held, r in zip(inside, residuals):
        resid[held] = r[held]
    return HeldOut(resid, blocks)


#: A nonlinear parameter whose variance would grow more than this factor without the held-out
#: data is kept at the full fit's value in that fold (the rest of the record does not
#: determine it: e.g. a recovery time when all unloading is held out).
UNDETERMINED_VARIANCE_RATIO = 10.0


def jacobian(data: Data, fit: Fit) -> np.ndarray:
    """Derivatives of the fitted signal by every nonlinear parameter (search coordinates;
    analytic for a plain Prony model, else by central differences) and by the linear
    coefficients (the basis), all samples (zero on those the basis leaves free,
    :attr:`~creepcomp.fit.structure.Basis.straddling`)."""
    values = fit.values
    cache: dict = {}
    b = basis(data, fit.structure, values, cache)
    coef = np.array([values[n] for n in b.names])
    moves = basis_derivatives(data, fit.structure, values, b, fit.params)
    if moves is not None:
        return np.column_stack([sum(coef[col] * d for col, d in m) for m in moves] + [b.columns])
    cols = []
    straddled = b.straddling            # (each fitted by its own parameter: no rows of the others)
    for p in fit.params:
        x = p.to_search(values[p.name])
        h = 1e-6 * max(1.0, abs(x))
        plus = dict(values, **{p.name: p.from_search(x + h)})
        minus = dict(values, **{p.name: p.from_search(x - h)})
        cols.append((basis(data, fit.structure, plus, cache).columns @ coef
                     - basis(data, fit.structure, minus, cache).columns @ coef) / (2 * h))
    out = np.column_stack(cols + [b.columns])
    out[straddled] = 0.0
    return out


def _variances(gram: np.ndarray, count: int) -> np.ndarray:
    """Variances (up to the noise's) of the first ``count`` parameters of a linear least-squares
    problem with Gram matrix ``gram``."""
    norms, scaled = unit_scaled(gram)
    inv = linalg.pinvh(scaled)
    with np.errstate(over="ignore"):     # (a column the rows hardly see: its variance is infinite)
        return np.diag(inv)[:count] / norms[:count] ** 2


def _unseen(jac: np.ndarray, count: int) -> np.ndarray:
    """Which of the first ``count`` columns of ``jac`` (the nonlinear parameters', in shared
    units: the model's change per step of the search) are of rounding size against the
    largest: the model does not change with that parameter."""
    norms = np.sqrt(np.sum(jac[:, :count] ** 2, axis=0))
    return norms <= np.sqrt(np.finfo(float).eps) * np.max(norms, initial=0.0)


def _undetermined(jac: np.ndarray, keep: np.ndarray, names: list, values: dict,
                  kept_gram: np.ndarray | None = None, full: np.ndarray | None = None,
                  held: dict | None = None) -> dict | None:
    """The nonlinear parameters (first columns of ``jac``) that the kept samples leave
    undetermined, with their values (``kept_gram``: ``jac[keep].T @ jac[keep]``, and ``full``:
    the variances on all samples, when known), and those ``held`` in any case. One the whole
    record does not determine (:func:`_unseen`: e.g. an averaging window's width at zero) is
    held in every fold: the pseudo-inverse gives it a variance of zero plus rounding, so a
    fold would hold it or refit it as rounding falls."""
    full = _variances(jac.T @ jac, len(names)) if full is None else full
    part = _variances(jac[keep].T @ jac[keep] if kept_gram is None else kept_gram, len(names))
    unseen = _unseen(jac, len(names))
    out = {n: values[n] for n, vf, vp, u in zip(names, full, part, unseen)
           if u or not vp <= UNDETERMINED_VARIANCE_RATIO * vf}
    return {**out, **(held or {})} or None


def _gauss_newton_step(gram: np.ndarray, rhs: np.ndarray, free: np.ndarray) -> np.ndarray:
    """The least-squares step ``G^-1 rhs`` on the ``free`` columns (zero on the others), by
    scaled normal equations with the weak ridge of :data:`~creepcomp.fit.solver.ANCHOR_WEIGHT`
    (directions the rows leave undetermined are not moved)."""
    step = np.zeros(len(rhs))
    norms, scaled = unit_scaled(gram[np.ix_(free, free)])
    eig, vec = np.linalg.eigh(scaled + ANCHOR_WEIGHT * np.eye(len(norms)))
    keep = eig > 1e-13 * eig[-1]
    step[free] = (vec[:, keep] @ ((vec[:, keep].T @ (rhs[free] / norms)) / eig[keep])) / norms
    return step


def _linear_refit(data: Data, fit: Fit, values: dict, keep: np.ndarray,
                  anchor: dict) -> tuple[np.ndarray, float]:
    """The residual on every sample (weighted as :attr:`Fit.residual`) of ``fit``'s structure at
    the nonlinear ``values`` (moved inside their bounds) with the linear part fitted on the
    ``keep`` samples (weakly anchored, as :class:`~creepcomp.fit.solver.Problem` does), and
    its squared sum over them. For a fit without step-time columns: the kept rows' sums are
    all rows' less the others' (a fifth of the work), unless that loses a column."""
    values = dict(values, **{p.name: p.clip(values[p.name]) for p in fit.params})
    b = basis(data, fit.structure, values)
    aw, yw = data.weighted(b.columns), data.weighted(data.signal)
    out = ~keep
    ao, yo = aw[out], yw[out]
    gram_all = aw.T @ aw
    gram = gram_all - ao.T @ ao
    prior = np.array([float(anchor.get(n, 0.0)) for n in b.names])
    if np.any(np.diag(gram) < 1e-6 * np.diag(gram_all)):
        coef = _solve(aw[keep], yw[keep], prior)
    else:
        coef = _solve(aw, yw, prior, gram, rhs=aw.T @ yw - ao.T @ yo, rows=keep)
    r = yw - aw @ coef
    return r, float(r @ r - r[out] @ r[out])


def load_halves(load: np.ndarray) -> np.ndarray:
    """Two parts of a record as blocks 0 and 1, each with a load change when it can be:
    its two halves (:func:`half_blocks`), unless every load change falls in one of them (a
    single step and its release, early in a long record); then the split between two
    consecutive load changes nearest the middle. A part without any load change does not
    determine the load's gain against the offset, nor any term that only a load change
    excites: across halves it would test an extrapolation, not the structure. When that
    split would leave a part shorter than a tenth of the record, the halves again (a part too
    short to fit on predicts nothing)."""
    n = len(load)
    blocks = half_blocks(n)
    changes = np.flatnonzero(np.diff(load) != 0) + 1
    if len(changes) < 2 or (changes[0] < n // 2 <= changes[-1]):
        return blocks
    splits = (changes[:-1] + changes[1:]) // 2
    at = int(splits[np.argmin(np.abs(splits - n / 2))])
    if min(at, n - at) < n // 10:
        return blocks
    return (np.arange(n) >= at).astype(int)


def halves(data: Data, fit: Fit, refine: bool = True) -> HeldOut:
    """Held-out prediction across the record's two parts (:func:`load_halves`): fitted on
    one, simulated over the other. Slow noise (drift) that interleaved blocks would let a
    slow extension interpolate is not predictable across halves; structure driven by the
    load is."""
    return heldout(data, fit, folds=2, refine=refine, blocks=load_halves(data.load)).heldout


def heldout(data: Data, fit: Fit, folds: int = FOLDS, refine: bool = True,
            blocks: np.ndarray | None = None, linearised: bool = False,
            refit_all: Callable[[list], list] | None = None) -> Fit:
    """The fit with its held-out prediction: the record is cut into :data:`BLOCKS` blocks;
    for each of ``folds`` folds its (interleaved) blocks are left out, the model is refitted on the rest
    (from the fit's own values, same noise model) and simulated from the load over them.

    The refit is a few steps of :func:`~creepcomp.fit.solver.fit_structure`'s least squares
    (three evaluations). ``linearised``: one Gauss-Newton step from the full fit instead, with
    its Jacobian restricted to the kept samples (kept only when it lowers their cost), the
    linear part then solved exactly at the new nonlinear values: where the model holds, the
    full fit is close to each fold's optimum and the step lands where the iteration does,
    without its set-up; where it does not (a model short of terms), the step is the
    reproducible first-order refit, which the few iterations are not (they stop wherever their
    third evaluation falls). Models compared by :func:`compare` must be held out alike. A fit
    with step-time columns (:func:`~creepcomp.fit.structure.with_step_times`, which
    :func:`jacobian` leaves out) is refitted iteratively in any case.

    Directions the remaining data leave undetermined keep the full fit's values: linear ones
    weakly (gain against offset when the rest has one load level,
    :data:`~creepcomp.fit.solver.ANCHOR_WEIGHT`), nonlinear ones whose variance the rest of
    the record would multiply by more than :data:`UNDETERMINED_VARIANCE_RATIO` (the initial
    creep state once the start is held out, a recovery time when the rest has no unloading).
    A held-out error then measures what the model predicts, not an extrapolation of what
    nothing constrained. So do parameters that an effect holds in every refit
    (:meth:`~creepcomp.diagnose.effects.Effect.held_in_refits`: a time offset where the
    samples it reads across a step are left free).

    ``refit_all``: refits a list of ``keep`` masks side by side, each as
    :func:`fold_refit` gives it with a :class:`FoldRefits` of ``fit`` (default: one after the
    other here).
    """
    blocks = block_index(data) if blocks is None else blocks
    refit = None if refit_all is not None else _refitter(data, fit, refine, linearised)
    return replace(fit, heldout=predict_held_out(blocks, folds, refit, refit_all))


class FoldRefits:
    """The refits of :func:`heldout`'s folds of one fit on one record, wherever they run
    (:func:`fold_refit`): what the folds share (the fit's Jacobian) is computed at the first
    refit and kept on the object. A copy sent to another process carries the fit only, and
    computes its own there.

    Parameters
    ----------
    fit : Fit
    refine, linearised : bool
        As :func:`heldout` takes them.
    """

    def __init__(self, fit: Fit, refine: bool = True, linearised: bool = False):
        self.fit, self.refine, self.linearised = fit, refine, linearised
        self._refit: Callable[[np.ndarray], np.ndarray] | None = None
        self._lock = threading.Lock()          # (a fleet's worker runs units on several threads)

    def __getstate__(self) -> dict:
        return {"fit": self.fit, "refine": self.refine, "linearised": self.linearised}

    def __setstate__(self, state: dict) -> None:
        self.__init__(**state)

    def __call__(self, data: Data, keep: np.ndarray) -> np.ndarray:
        """The fit refitted on the samples ``keep`` of ``data`` (its record); its residual on
        every sample."""
        with self._lock:
            if self._refit is None:
                self._refit = _refitter(data, self.fit, self.refine, self.linearised)
        return self._refit(keep)


def fold_refit(data: Data, refits: FoldRefits, keep: np.ndarray) -> np.ndarray:
    """One refit of :func:`heldout` (the fit refitted on the samples ``keep``; its residual on
    every sample), as a task of :class:`~creepcomp.diagnose.workers.Workers` (``refits``: the
    task's common part): the same as there, wherever it runs."""
    return refits(data, keep)


def _refitter(data: Data, fit: Fit, refine: bool, linearised: bool) -> Callable[[np.ndarray], np.ndarray]:
    """``refit(keep)`` of :func:`heldout`: what the folds share computed here once."""
    start = {p.name: fit.values[p.name] for p in fit.params}
    held = {f"{a.name}.{n}": fit.values[f"{a.name}.{n}"] for a in fit.structure.effects
            for n in a.effect.held_in_refits(data, a.own(fit.values), a)}
    anchor = {n: v for n, v in fit.values.items() if n not in start}
    jac = data.weighted(jacobian(data, fit)) if refine and start else None
    names = list(start)
    by_name = {p.name: p for p in fit.params}
    # (the Jacobian leaves out the step-time columns: no linearised refit with them)
    linearised = linearised and not any(n.startswith("step_time[") for n in fit.values)
    gram_all = jac.T @ jac if jac is not None else None
    sparse = is_sparse(data)
    full = _variances(gram_all, len(names)) if jac is not None else None
    if jac is not None and linearised:
        rhs_all, rr_all = jac.T @ fit.residual, float(fit.residual @ fit.residual)

    def stepped(keep: np.ndarray) -> tuple[dict, dict | None, float]:
        """The nonlinear values one Gauss-Newton step from the full fit on the kept rows,
        those held at the full fit's values, and the kept rows' squared residual at the full
        fit's nonlinear values with the linear part refitted."""
        # the kept rows' sums as all rows' less the held-out ones' (a fifth of the work), unless
        # a column lives mostly in the held-out rows (then the difference would lose it)
        out = ~keep
        jo, ro = jac[out], fit.residual[out]
        gram = gram_all - jo.T @ jo
        if np.any(np.diag(gram) < 1e-6 * np.diag(gram_all)):
            jk = jac[keep]
            gram = jk.T @ jk
        rhs = rhs_all - jo.T @ ro
        rr = rr_all - float(ro @ ro)
        frozen = _undetermined(jac, keep, names, start, gram, full, held)
        linear = np.arange(jac.shape[1]) >= len(names)
        free = linear | np.array([i < len(names) and names[i] not in (frozen or {})
                                  for i in range(jac.shape[1])])
        step = _gauss_newton_step(gram, rhs, free)
        # (a step out of a parameter's bounds ends at the bound: a log-scaled one would overflow)
        values = {n: by_name[n].from_search(float(np.clip(by_name[n].to_search(start[n]) + step[i],
                                                          *by_name[n].bounds())))
                  for i, n in enumerate(names)}
        at_start = float(rr - rhs @ _gauss_newton_step(gram, rhs, linear))
        return values, frozen, at_start

    def refit(keep: np.ndarray) -> np.ndarray:
        try:  # (refit from the fit's own values, same noise model)
            if jac is not None and linearised:
                values, frozen, at_start = stepped(keep)
                if not sparse:
                    # the step is kept only when it lowers the kept samples' cost, as a refit's
                    r, cost = _linear_refit(data, fit, values, keep, anchor)
                    return r if cost <= at_start else _linear_refit(data, fit, start, keep, anchor)[0]
                problem = Problem(data, fit.structure, keep, anchor=anchor, frozen=frozen)
                x = problem.start_vector(values)
                r = problem.residual(x) * problem.scale
                if float(r @ r) > at_start:
                    x = best_of_starts(problem.residual, [x, problem.start_vector(start)], 2, None)
                return problem.full_residual(x)[1]
            frozen = _undetermined(jac, keep, names, start, full=full, held=held) if jac is not None else held or None
            return fit_structure(data, fit.structure, [start], noise=fit.noise, mask=keep,
                                 max_nfev=3, with_cov=False, anchor=anchor, refine=refine,
                                 frozen=frozen).residual
        except InputError:
            if not sparse or not start:
                return fit.residual
        try:  # a sparse record's remaining samples: the linear part alone is refitted
            return fit_structure(data, fit.structure, [start], noise=fit.noise, mask=keep,
                                 with_cov=False, anchor=anchor, refine=False,
                                 frozen=start).residual
        except InputError:
            return fit.residual

    return refit


@dataclass(frozen=True)
class Evidence:
    """How much better a model explains a record than a simpler one.

    Attributes
    ----------
    delta_bic : float
        BIC of the richer model minus the simpler's (negative: evidence for the richer).
    heldout_rms_ratio : float
        Held-out residual RMS, simpler / richer.
    heldout_z : float
        Improvement of the prewhitened held-out squared error, in standard deviations.
    """

    delta_bic: float
    heldout_rms_ratio: float
    heldout_z: float

    @property
    def supported_heldout(self) -> bool:
        """Held-out data predicted better, by :data:`HELDOUT_Z` standard deviations and in RMS."""
        return self.heldout_z >= HELDOUT_Z and self.heldout_rms_ratio > 1.0

    @property
    def supported(self) -> bool:
        """Strong evidence by both BIC and held-out prediction (which must also be better in
        plain RMS)."""
        return (self.delta_bic <= -BIC_STRONG and self.heldout_z >= HELDOUT_Z
                and self.heldout_rms_ratio > 1.0)

    def to_dict(self) -> dict:
        """JSON form."""
        return {"delta_bic": self.delta_bic, "heldout_rms_ratio": self.heldout_rms_ratio,
                "heldout_z": self.heldout_z}


def compare(simple, rich) -> Evidence:
    """Evidence for ``rich`` over ``simple``: two fits of the same record (sensor
    :class:`~creepcomp.fit.solver.Fit` or circuit :class:`~creepcomp.fit.circuit.CircuitFit`),
    each with its ``bic``, and with held-out predictions (else the held-out figures are NaN).

    With ``D`` the drop of the held-out sum of squares and ``delta`` the difference of the two
    held-out predictions, ``D = sum delta^2 + 2 sum delta e`` when ``rich`` is right and
    ``-sum delta^2 + 2 sum delta e`` when ``simple`` is, ``e`` the noise. The spread of
    ``sum delta e`` is computed in the frequency domain from the spectrum of the richer
    model's held-out residual (a smoothed periodogram), so slow noise (drift) that a fitted
    extension happens to follow does not count as evidence: ``z = D / (2 sd)``.
    """
    delta_bic = rich.bic - simple.bic
    if simple.heldout is None or rich.heldout is None:
        return Evidence(delta_bic, float("nan"), float("nan"))
    ratio = simple.heldout.rms / rich.heldout.rms if rich.heldout.rms > 0 else float("inf")
    rs, rr = simple.heldout.residual, rich.heldout.residual
    d = float(np.sum(rs ** 2 - rr ** 2))
    sd = math.sqrt(max(spectral_variance(rr - rs, rr), 0.0))
    z = d / (2.0 * sd) if sd > 0 else (float("inf") if d > 0 else 0.0)
    return Evidence(float(delta_bic), float(ratio), float(z))


#: Residual power below the held-out block rate, relative to the next two octaves, above
#: which the noise counts as slow (drift): white noise gives 1 (+-0.2).
SLOW_NOISE_RATIO = 2.0


def slow_noise_ratio(residual: np.ndarray, blocks: int = BLOCKS) -> float:
    """Mean periodogram over the frequencies below the held-out blocks' rate (bins 1 ...
    ``blocks``) over its mean in the next two octaves (``blocks`` ... ``4 blocks``): about 1
    for white or short-memory coloured noise, large for drift that spans several blocks."""
    e = residual - np.mean(residual)
    power = np.abs(np.fft.rfft(e)) ** 2
    if len(power) < 4 * blocks + 1:
        return 1.0
    low = np.mean(power[1:blocks + 1])
    mid = np.mean(power[blocks + 1:4 * blocks + 1])
    return float(low / mid) if mid > 0 else float("inf")


#: Correlation of neighbouring held-out blocks' mean residuals above which slow noise spans
#: blocks: white noise, or coloured noise whose memory is shorter than a block, gives about 0
#: (+-0.16 over 40 blocks); a random walk close to 1.
BLOCK_MEMORY = 0.3


def block_memory(residual: np.ndarray) -> float:
    """Lag-1 correlation of the residual's means over the held-out blocks
    (:func:`block_index`): how far noise carries from one block into the next."""
    index = _blocks_of(len(residual))
    means = np.bincount(index, residual) / np.bincount(index)
    means = means - np.mean(means)
    power = float(np.sum(means ** 2))
    return float(np.sum(means[1:] * means[:-1]) / power) if power > 0 else 0.0


def compare_with_halves(simple, rich, across: Callable[[], tuple[HeldOut, HeldOut]],
                        always_halves: bool = False) -> Evidence:
    """Evidence for ``rich`` over ``simple`` (:func:`compare`); and when it is supported and
    the richer model's residual holds slow noise that carries from block to block (drift:
    :func:`slow_noise_ratio` and :func:`block_memory`), also the prediction of each half of the
    record from the other (``across()``: the two fits' held-out predictions across halves):
    drift that a slow extension follows between interleaved blocks is not predictable across
    halves, structure driven by the input is. The weaker of the two held-out results counts.
    Coloured noise whose memory is shorter than a block is not followed between blocks, and
    the interleaved blocks' test already counts its spectrum.
    ``always_halves``: test across halves in any case (a catch-all, whose slow terms follow
    drift easily)."""
    ev = compare(simple, rich)
    if ev.supported and (always_halves or (slow_noise_ratio(rich.residual) > SLOW_NOISE_RATIO
                                           and block_memory(rich.residual) > BLOCK_MEMORY)):
        held_simple, held_rich = across()
        other = compare(replace(simple, heldout=held_simple), replace(rich, heldout=held_rich))
        if not other.supported_heldout:
            ev = replace(ev, heldout_z=min(ev.heldout_z, other.heldout_z),
                         heldout_rms_ratio=min(ev.heldout_rms_ratio, other.heldout_rms_ratio))
    return ev
