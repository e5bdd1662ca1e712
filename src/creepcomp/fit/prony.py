"""Prony identification of a creep model from a record: 1, 2, ... terms, each added while
the evidence supports it, and the model file with uncertainties and fit statistics."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Sequence

import numpy as np
from scipy import linalg

from creepcomp.display import Shown, data_frame
from creepcomp.errors import InputError
from creepcomp.fit.blas import one_blas_thread
from creepcomp.fit.data import Data, prepare
from creepcomp.fit.evidence import BIC_STRONG, FOLDS, Evidence, compare, heldout
from creepcomp.fit.noise import ARNoise, ar_order, fit_noise, is_sparse
from creepcomp.fit.solver import (Fit, Problem, _coarse, _finish, best_of_starts, fit_structure,
                                  refined_ftol, small_sample_inflation, with_covariance, with_noise)
from creepcomp.fit.starts import cluster_taus, extra_term_starts, nnls_spectrum, one_term_starts, tau_grid
from creepcomp.fit.structure import Applied, Structure
from creepcomp.model import CreepModel

__all__ = ["OrderStep", "PronyResult", "fit_terms", "spectrum_of", "fit_prony", "FIT_MAX_TERMS",
           "fit_record", "term_table", "fit_summary",
           "model_file_dict"]


class OrderStep:
    """One candidate number of terms: its fit and the evidence against the previous number
    of terms (None for the first).

    A number of terms rejected on BIC alone (:func:`_rejected_loosely`) is given its held-out
    prediction, and its evidence the held-out figures, when first read (model file, ``fit``'s
    table): the choice does not need them.
    """

    def __init__(self, n_terms: int, fit: Fit, evidence: Evidence | None = None,
                 held_out_later: tuple | None = None):
        self.n_terms = n_terms
        self._fit, self._evidence = fit, evidence
        self._later = held_out_later        # (data, previous fit, folds)

    @classmethod
    def rejected(cls, n_terms: int, fit: Fit, data: Data, previous: Fit, folds: int) -> "OrderStep":
        """A number of terms rejected on BIC alone: held out when first read."""
        return cls(n_terms, fit, None, (data, previous, folds))

    def _held_out(self) -> None:
        if self._later is not None:
            data, previous, folds = self._later
            self._later = None
            try:
                self._fit = heldout(data, self._fit, folds, linearised=True)
            except (InputError, linalg.LinAlgError):
                pass        # (its evidence then has no held-out figures)
            self._evidence = compare(previous, self._fit)

    @property
    def fit(self) -> Fit:
        """The fit of this number of terms."""
        self._held_out()
        return self._fit

    @property
    def evidence(self) -> Evidence | None:
        """Against the previous number of terms."""
        self._held_out()
        return self._evidence

    def __repr__(self) -> str:
        return f"OrderStep(n_terms={self.n_terms}, bic={self._fit.bic:.6g})"


@dataclass(frozen=True)
class PronyResult(Shown):
    """Prony fits for 1, 2, ... terms and the one the evidence chose."""

    data: Data
    steps: tuple[OrderStep, ...]
    chosen: int                     # index into steps

    @property
    def fit(self) -> Fit:
        """The chosen fit."""
        return self.steps[self.chosen].fit

    def model(self) -> CreepModel:
        """The chosen creep model."""
        return self.fit.creep_model()

    def to_dict(self) -> dict:
        """Model-file form: the model plus uncertainties and fit statistics."""
        return model_file_dict(self.data, self.fit, self.steps, self.chosen)

    def __repr__(self) -> str:
        from creepcomp.units import format_percent

        fit, tried = self.fit, [s.n_terms for s in self.steps]
        n = fit.structure.n_terms
        return (f"<PronyResult of {self.data.source!r}: {n} term{'s' if n > 1 else ''} chosen of "
                f"{min(tried)}..{max(tried)} tried, beta0 {format_percent(self.model().beta0)}, "
                f"residual RMS {format_percent(fit.residual_rms / self.data.signal_scale)} of the signal's range>")

    def to_pandas(self):
        """The chosen model's terms (``beta``, ``tau`` in s, their standard deviations) as a
        pandas DataFrame (pandas needed)."""
        rows = term_table(self.fit)
        return data_frame({k: [r[k] for r in rows] for k in ("beta", "beta_sigma", "tau", "tau_sigma")})


def fit_terms(data: Data, n_terms: int, previous: Fit | None = None, noise: ARNoise | None = None,
              effects: tuple[Applied, ...] = (), start: dict | None = None, with_cov: bool = True,
              ftol: float = 1e-8, spectrum: tuple | None = None,
              coarse_ftol: float | None = None) -> Fit:
    """Fit ``n_terms`` Prony terms (plus ``effects`` applied to every model, e.g. viscous flow):
    starts from the non-negative spectrum and, when given, from the previous fit plus one grid
    time (or from the values ``start`` alone); refine; keep the best. ``spectrum``: the
    record's (:func:`spectrum_of`), when known; ``coarse_ftol``: see
    :func:`~creepcomp.fit.solver.fit_structure`."""
    structure = Structure(n_terms, tuple(effects))
    starts = _term_starts(data, structure, previous, start, spectrum)
    return fit_structure(data, structure, starts, noise=noise, n_refine=3, with_cov=with_cov,
                         ftol=ftol, coarse_ftol=coarse_ftol)


def _term_starts(data: Data, structure: Structure, previous: Fit | None, start: dict | None,
                 spectrum: tuple | None) -> list[dict]:
    """The start values of :func:`fit_terms`."""
    if start is not None:
        return [start]
    if structure.n_terms == 1:
        return one_term_starts(data)
    grid, amps = spectrum or spectrum_of(data)
    starts = [{f"tau[{k}]": t for k, t in enumerate(cluster_taus(grid, amps, structure.n_terms))}]
    if previous is not None:
        starts += extra_term_starts(data, previous, structure)
    return starts


#: Relative change of the cost at which the starts of the order search stop on the coarse
#: record: they only seed the refinement on the full record, which converges from any of them
#: (a change of the coarse log-likelihood of about 0.01).
ORDER_COARSE_FTOL = 1e-5
#: Noise model of the fits only compared (their BIC is that of white noise in any case).
_WHITE = ARNoise()


#: Ratio of two time constants below which two terms are one: no record resolves them, and a
#: fit that puts two terms there pairs huge amplitudes of opposite sign (the pair then models
#: t·exp(-t/tau), not two exponentials).
COALESCED_RATIO = 1.05


def coalesced(taus) -> bool:
    """Whether two of the time constants ``taus`` are within :data:`COALESCED_RATIO`."""
    ordered = np.sort(np.asarray(taus, dtype=float))
    return bool(np.any(ordered[1:] < COALESCED_RATIO * ordered[:-1]))


#: Smallest relative amplitude of a term the fit adds by evidence: below 1e-7 of the
#: instantaneous signal no sensor's converter resolves creep (a 24-bit one resolves 6e-8 of
#: its full scale), and the network for such a term needs resistances beyond a petaohm. A
#: noiseless record's rounding errors can otherwise support such a term.
SMALLEST_BETA = 1e-7


def _undetermined(fit: Fit) -> str | None:
    """Why ``fit`` has more parameters than its samples determine, or None."""
    if fit.n_params - 1 < fit.n_rows:
        return None
    return (f"{fit.structure.n_terms} terms, gain and offset are {fit.n_params - 1} parameters "
            f"for {fit.n_rows} usable samples: fewer terms, or a longer record")


def _another_term(data: Data, previous: Fit, fit: Fit, evidence: Evidence) -> bool:
    """Whether ``fit`` (one more term than ``previous``) is supported: strongly by BIC and
    held-out prediction (:attr:`~creepcomp.fit.evidence.Evidence.supported`); on a sparse
    record (:func:`~creepcomp.fit.noise.is_sparse`) by a lower small-sample corrected AIC
    (:func:`corrected_aic`). A handful of samples gives the held-out test no power and cannot
    meet the strong margin, and held to one term such a record predicts its continuation
    worse; a plain lower BIC, on the other hand, takes a second term on a third of
    one-term records of eight samples. (Measured in ``docs/benchmarks.md``, "Sparse records (spruce)".)"""
    if not is_sparse(data):
        return evidence.supported
    return corrected_aic(fit) < corrected_aic(previous)


def corrected_aic(fit: Fit) -> float:
    """Akaike's criterion with its small-sample correction (AICc), ``-2 loglik + 2 k +
    2 k (k + 1) / (n - k - 1)`` for ``k`` parameters (as BIC counts them) and ``n`` rows;
    infinite when ``n <= k + 1``."""
    k, n = fit.n_params, fit.n_rows
    if n <= k + 1:
        return math.inf
    return -2.0 * fit.loglik + 2.0 * k + 2.0 * k * (k + 1) / (n - k - 1)


def spectrum_of(data: Data) -> tuple[np.ndarray, np.ndarray]:
    """The grid of time constants the starts of :func:`fit_terms` come from (six a decade)
    and the record's non-negative creep spectrum on it."""
    grid = tau_grid(data, per_decade=6)
    return grid, nnls_spectrum(data, grid)[0]


def fit_prony(data: Data, max_terms: int = 6, n_terms: int | None = None,
              folds: int = FOLDS, effects: tuple[Applied, ...] = ()) -> PronyResult:
    """Identify gain, offset and Prony terms, adding terms while the evidence supports them.

    A term is added when it lowers BIC by at least :data:`BIC_STRONG` *and* predicts held-out
    data better by at least :data:`HELDOUT_Z` standard deviations, and its time constant is not
    one an earlier term holds (:func:`coalesced`); the search stops at the first term that is
    not supported (or at ``max_terms``). ``n_terms`` fixes the number.
    Each model's likelihood has its own AR noise (its parameters counted by BIC).
    ``effects`` are applied to every model (e.g. ``(Applied(effects.get("viscous_flow")),)``
    for the Burgers model). With a free initial state, the record is also fitted as starting
    settled at its first load (at rest when that load is zero), and that fit is kept unless
    the free start lowers BIC by :data:`BIC_STRONG` (its initial states are parameters too).
    Two shortcuts leave the choice as it is: a term that fails BIC's margin already on the
    coarse record is refined loosely first, and fully only when a refinement could still
    bring it within the margin (:func:`_rejected_loosely`); the free start is not refined
    where it cannot win by the margin (:func:`_free_start_may_win`).

    Examples
    --------
    A load step at 20 s on a sensor with 3 % of creep at 45 s, sampled at 2 Hz with noise of
    0.01 % of the step:

    >>> import numpy as np
    >>> from creepcomp.io.records import Record
    >>> from creepcomp.lti import lag_states
    >>> from creepcomp.fit.data import prepare
    >>> from creepcomp.fit.prony import fit_prony
    >>> t = np.arange(0.0, 900.0, 0.5)
    >>> load = np.where(t >= 20.0, 1.0, 0.0)
    >>> noise = np.random.default_rng(0).normal(0.0, 1e-4, t.size)
    >>> signal = load + 0.03 * lag_states(t, load, [45.0])[:, 0] + noise
    >>> model = fit_prony(prepare(Record(t, load, signal), initial="relaxed")).model()
    >>> print(f"{model.n_terms} term: beta = {model.beta[0]:.3f}, tau = {model.tau[0]:.0f} s")
    1 term: beta = 0.030, tau = 45 s
    """
    with one_blas_thread():     # (small matrices: see creepcomp.fit.blas)
        return _fit_prony(data, max_terms, n_terms, folds, effects)


#: Most creep terms tried for a record by :func:`fit_record` (``creepcomp fit --max-terms``).
FIT_MAX_TERMS = 8


def fit_record(record, initial: str = "free", load_step_at: float | None = None,
               n_terms: int | None = None, max_terms: int = FIT_MAX_TERMS,
               effects: tuple[Applied, ...] = ()) -> PronyResult:
    """Prepare a record (:func:`~creepcomp.fit.data.prepare`) and fit it (:func:`fit_prony`):
    what ``creepcomp fit`` does with one record once it is read (and, when long, reduced).

    Parameters
    ----------
    record : Record (or anything :func:`~creepcomp.fit.data.prepare` takes)
    initial, load_step_at
        As :func:`~creepcomp.fit.data.prepare`.
    n_terms, max_terms, effects
        As :func:`fit_prony`.

    Returns
    -------
    PronyResult
    """
    data = prepare(record, initial=initial, load_step_at=load_step_at)
    return fit_prony(data, max_terms=max_terms, n_terms=n_terms, effects=effects)


def _fit_prony(data: Data, max_terms: int, n_terms: int | None, folds: int,
               effects: tuple[Applied, ...]) -> PronyResult:
    """:func:`fit_prony`'s work."""
    if data.initial != "free":
        return _orders(data, max_terms, n_terms, folds, effects)
    # a record that starts settled (at rest, or long at its first load) is told from one that
    # starts creeping by the evidence: the free start must earn its parameters. The free
    # start is first tried at the settled choice's number of terms (from the settled fit: the
    # free model holds it); only when it wins there are its own numbers of terms searched.
    try:
        settled = _orders(replace(data, initial="settled"), max_terms, n_terms, folds, effects)
    except InputError:
        return _orders(data, max_terms, n_terms, folds, effects)
    if not _free_start_may_win(data, settled.fit, effects):
        return settled
    try:
        # (converged far enough to tell a BIC difference of BIC_STRONG)
        trial = fit_terms(data, settled.fit.structure.n_terms, noise=_WHITE, effects=effects,
                          start=settled.fit.values, with_cov=False, ftol=0.1 * BIC_STRONG / data.n,
                          coarse_ftol=ORDER_COARSE_FTOL)
    except (InputError, linalg.LinAlgError):
        trial = None
    if trial is not None and not trial.bic < settled.fit.bic - BIC_STRONG:
        return settled
    try:
        result = _orders(data, max_terms, n_terms, folds, effects)
    except InputError:   # (a sparse record may not carry the initial states as well)
        return settled
    return settled if settled.fit.bic < result.fit.bic + BIC_STRONG else result


def _free_start_may_win(data: Data, settled: Fit, effects: tuple[Applied, ...]) -> bool:
    """Whether the free start, refined from the ``settled`` fit, might lower BIC by
    :data:`BIC_STRONG`: False when its BIC there, less what a refinement can reach
    (:func:`_reachable_bic`), does not (the free start's initial states add parameters
    that a record starting settled does not pay back)."""
    try:
        problem = Problem(data, Structure(settled.structure.n_terms, tuple(effects)))
        x = problem.start_vector(settled.values)
        start = _finish(problem, x, _WHITE, False)
        return start.bic - _reachable_bic(problem, x, start.n_rows) <= settled.bic - BIC_STRONG
    except (InputError, linalg.LinAlgError):
        return True


def _orders(data: Data, max_terms: int, n_terms: int | None, folds: int,
            effects: tuple[Applied, ...]) -> PronyResult:
    """Fits of 1, 2, ... terms while the evidence supports another (see :func:`fit_prony`)."""
    steps: list[OrderStep] = []
    chosen = 0
    previous = None
    top = n_terms or max_terms
    spectrum = None
    coarse_cost = None
    for k in range(1, top + 1):
        try:
            if k > 1 and spectrum is None:
                spectrum = spectrum_of(data)
            # (the noise model and covariance only of the fit chosen, below: the order is
            # chosen by the white likelihood and the held-out test, which need neither)
            structure = Structure(k, tuple(effects))
            starts = _term_starts(data, structure, previous, None, spectrum)
            searched = _coarse_search(data, structure, starts)
            fit = None
            if searched is None:
                fit = fit_terms(data, k, previous, _WHITE, effects, with_cov=False,
                                spectrum=spectrum, coarse_ftol=ORDER_COARSE_FTOL)
            elif (previous is not None and n_terms is None and not is_sparse(data)
                  and _coarse_unpromising(coarse_cost, searched)):
                rejected = _rejected_loosely(data, previous, searched)
                if rejected is not None:
                    steps.append(OrderStep.rejected(k, rejected, data, previous, folds))
                    break
            if fit is None:
                problem, x = searched.problem, searched.x
                fit = heldout(data, _finish(problem, problem.refine(x, None, refined_ftol(problem)),
                                            _WHITE, False), folds, linearised=True)
            elif fit.heldout is None:
                fit = heldout(data, fit, folds, linearised=True)
            coarse_cost = searched.cost if searched is not None else None
        except InputError:
            if n_terms is not None and is_sparse(data):
                raise   # (the terms asked for are more than a sparse record carries: the reason)
            break
        except linalg.LinAlgError:
            break
        undetermined = _undetermined(fit)
        if undetermined is not None:
            if n_terms is not None:
                raise InputError(f"{data.source}: --terms {n_terms}: {undetermined}")
            break
        ev = compare(previous, fit) if previous is not None else None
        steps.append(OrderStep(k, fit, ev))
        if n_terms is not None:
            chosen = len(steps) - 1
        elif ev is None or (_another_term(data, previous, fit, ev) and not coalesced(fit.taus)
                            and np.min(np.abs(fit.betas)) >= SMALLEST_BETA):
            chosen = len(steps) - 1
        else:
            break
        previous = fit
    if not steps:
        raise InputError(f"{data.source}: no creep model could be fitted")
    fit = steps[chosen].fit
    fit = with_noise(fit, fit_noise(fit.residual, fit.extras["rows"], ar_order(data)))
    steps[chosen] = OrderStep(steps[chosen].n_terms, with_covariance(data, fit), steps[chosen].evidence)
    return PronyResult(data, tuple(steps), chosen)


@dataclass(frozen=True)
class _Searched:
    """The starts of one structure searched on the coarse record, as
    :func:`~creepcomp.fit.solver.fit_structure` searches them."""

    problem: Problem            # on all samples
    x: np.ndarray               # the coarse record's best search point
    cost: float                 # its squared residual on the coarse record
    coarse_rows: int


def _coarse_search(data: Data, structure: Structure, starts: list[dict]) -> _Searched | None:
    """:func:`~creepcomp.fit.solver.fit_structure`'s search of ``starts`` on the coarse record
    (three refined at :data:`ORDER_COARSE_FTOL`, the best kept), from which the refinement on
    all samples can be taken loosely first (:func:`_rejected_loosely`); None when that fit
    has no coarse record (then it is :func:`fit_terms`')."""
    problem = Problem(data, structure)
    coarse = _coarse(problem)
    if coarse is None:
        return None
    if not starts:
        raise InputError("no start values")
    x = best_of_starts(coarse.residual, [problem.start_vector(s) for s in starts], 3,
                       lambda x0: coarse.refine(x0, None, ORDER_COARSE_FTOL))
    r = coarse.residual(x)
    return _Searched(problem, x, float(r @ r), len(coarse.rows))


#: Parameters a Prony term adds at least (amplitude and time constant), for the coarse
#: record's information criterion of :func:`_coarse_unpromising`.
_TERM_PARAMS = 2
#: Factor on the decrease of the cost one Gauss-Newton step predicts from a point, taken as
#: the most a refinement from there can lower it: on the three-term step records of
#: ``benchmarks/peers.py`` (white and AR(1) noise, 600 and 3600 s) refinements fell by at most
#: 1.1 times the prediction from a settled fit with free initial states added, and by at
#: most 4.2 times from an extra term after its first three evaluations (but see
#: :data:`LOOSE_MARGIN`).
REACH_FACTOR = 10.0
#: Evaluations of the loose refinement of an extra term on all samples
#: (:func:`_rejected_loosely`): the first steps take the cost to its plateau, the rest of a
#: full refinement moves a term the record does not hold about the flat valley of its cost.
LOOSE_EVALUATIONS = 3
#: BIC by which a loosely refined extra term must fail the strong margin beyond what a
#: refinement can reach (:func:`_reachable_bic`) to be rejected without the full refinement:
#: an extra term's refinement sometimes leaves the Gauss-Newton step's valley (on random
#: synthetic records, ``creepcomp.synth.sensor.random_record``, the full refinement lowered
#: BIC up to 78 times the prediction, by at most 3.5 more than :data:`REACH_FACTOR` times it).
LOOSE_MARGIN = BIC_STRONG


def _coarse_unpromising(previous_cost: float | None, searched: _Searched) -> bool:
    """Whether one more term fails the strong BIC margin already on the coarse record (its
    own criterion, ``_TERM_PARAMS`` more parameters): then the term is first fitted loosely,
    which most likely suffices to reject it."""
    if previous_cost is None or not searched.cost > 0:
        return False
    n = searched.coarse_rows
    return n * math.log(previous_cost / searched.cost) < _TERM_PARAMS * math.log(n) + BIC_STRONG


def _rejected_loosely(data: Data, previous: Fit, searched: _Searched) -> Fit | None:
    """The fit of one more term than ``previous``, refined on all samples only for
    :data:`LOOSE_EVALUATIONS` evaluations (or until the cost moves BIC by under a tenth of
    :data:`BIC_STRONG`), when the term is rejected however far the refinement went on: the
    fit's BIC, less what a refinement can reach from it (:func:`_reachable_bic`), still fails
    the strong margin over ``previous`` by :data:`LOOSE_MARGIN`; the number of terms is then
    the full search's (its held-out test is not needed: both must pass, and
    :meth:`OrderStep.rejected` holds it out when read). None otherwise: the full refinement,
    from the same point, decides. The loose fit is the full one's first steps, so a rejected
    order's figures in the model file are those of its first steps."""
    problem = searched.problem
    if _finish(problem, searched.x, _WHITE, False).bic <= previous.bic - BIC_STRONG:
        return None     # (BIC supports the term already from the start: the refinement decides)
    x = problem.refine(searched.x, LOOSE_EVALUATIONS,
                       max(refined_ftol(problem), 0.1 * BIC_STRONG / len(problem.rows)))
    fit = _finish(problem, x, _WHITE, False)
    if not fit.bic - _reachable_bic(problem, x, fit.n_rows) > previous.bic - BIC_STRONG + LOOSE_MARGIN:
        return None
    return fit


def _reachable_bic(problem: Problem, x: np.ndarray, n_rows: int) -> float:
    """How far a refinement from the search point ``x`` can lower the white BIC of
    ``n_rows`` rows at most: :data:`REACH_FACTOR` times the decrease of the cost one
    Gauss-Newton step predicts (infinite when that is all of the cost, or the Jacobian is
    not analytic)."""
    if not problem.analytic():
        return math.inf
    r = problem.residual(x)
    jac = problem.jacobian(x)
    step, *_ = linalg.lstsq(jac, r, lapack_driver="gelsy")
    cost, decrease = float(r @ r), float(np.sum((jac @ step) ** 2))
    if not REACH_FACTOR * decrease < cost:
        return math.inf
    return -n_rows * math.log1p(-REACH_FACTOR * decrease / cost)


def term_table(fit: Fit) -> list[dict]:
    """Each term's beta and tau with standard deviations, sorted by tau."""
    rows = []
    for k in range(fit.structure.n_terms):
        beta = fit.estimate(lambda v, k=k: v[f"a[{k}]"] / v["gain"])
        tau = fit.estimate(lambda v, k=k: v[f"tau[{k}]"])
        rows.append({"beta": beta[0], "beta_sigma": beta[1], "tau": tau[0], "tau_sigma": tau[1]})
    return sorted(rows, key=lambda r: r["tau"])


def fit_summary(data: Data, fit: Fit) -> dict:
    """Fit statistics for model files and JSON output."""
    out = {
        "record": data.source,
        "n_samples": data.n,
        "duration_s": data.duration,
        "initial_state": {"free": "fitted (free initial creep states)",
                          "relaxed": "relaxed (assumed)",
                          "settled": "settled at the first load (assumed, or chosen over a free "
                                     "start by BIC)",
                          "step": f"load step at {data.load_step_at} s"}[data.initial],
        "structure": fit.structure.describe(),
        "residual_rms": fit.residual_rms,
        "residual_rms_relative": fit.residual_rms / data.signal_scale,
        "loglik": fit.loglik,
        "bic": fit.bic,
        "n_params": fit.n_params,
        "noise": fit.noise.to_dict(data.dt_median),
    }
    if fit.heldout is not None:
        out["heldout_residual_rms"] = fit.heldout.rms
        out["heldout_residual_rms_relative"] = fit.heldout.rms / data.signal_scale
    if data.fixed_offset:
        out["offset_note"] = "the load is constant within the record: offset fixed at 0"
    return out


def _uncertainty_note(data: Data, fit: Fit) -> str:
    """What the stated standard deviations are."""
    note = ("one standard deviation: Jacobian of the prewhitened residual, Gaussian AR noise, "
            "locally linear model")
    if not is_sparse(data):
        return note
    dof = fit.n_rows - (fit.n_params - 1)
    return (note + f"; a sparse record ({data.n} samples, {dof} degrees of freedom): white noise, "
            f"covariance times {small_sample_inflation(fit.n_rows, fit.n_params - 1):.3g} (unbiased "
            "variance and Student's t one-sigma quantile)")


def model_file_dict(data: Data, fit: Fit, steps: Sequence[OrderStep] = (), chosen: int = 0,
                    extensions: dict | None = None) -> dict:
    """Model file: ``beta``, ``tau``, ``gain``, ``offset`` (+ ``extensions``), with
    ``uncertainty`` and ``fit`` statistics as extra keys. Without ``extensions`` given, the
    fit's own effects write theirs."""
    if extensions is None:
        extensions = {}
        for a in fit.structure.effects:
            entry = a.effect.extension(fit, a)
            if entry is not None:
                extensions[a.name] = entry
    terms = term_table(fit)
    gain = fit.estimate(lambda v: v["gain"])
    offset = fit.estimate(lambda v: v.get("offset", 0.0))
    model = {"beta": [t["beta"] for t in terms], "tau": [t["tau"] for t in terms],
             "gain": gain[0], "offset": offset[0]}
    if extensions:
        model["extensions"] = extensions
    model["uncertainty"] = {"beta": [t["beta_sigma"] for t in terms],
                            "tau": [t["tau_sigma"] for t in terms],
                            "gain": gain[1], "offset": offset[1] if not data.fixed_offset else 0.0,
                            "note": _uncertainty_note(data, fit)}
    model["fit"] = fit_summary(data, fit)
    if steps:
        model["fit"]["orders"] = [{
            "n_terms": s.n_terms, "bic": s.fit.bic, "residual_rms": s.fit.residual_rms,
            "heldout_residual_rms": s.fit.heldout.rms if s.fit.heldout else None,
            **({"evidence": s.evidence.to_dict()} if s.evidence else {}),
            **({"coalesced": True} if coalesced(s.fit.taus) else {}),
            "chosen": i == chosen} for i, s in enumerate(steps)]
    return model
