"""Fitting one model structure to one record: variable projection (the linear part solved
for each point of the nonlinear search), the best of several starts, the likelihood with
the residual's AR noise, and the covariance of the estimates.

Parameters are estimated by least squares; for fixed nonlinear parameters the linear part
is projected out, and the nonlinear ones are refined by ``scipy.optimize.least_squares``.
Uncertainties come from the Jacobian with the residual's AR(p) noise model (sandwich
covariance; p = 0 ... 5 chosen by BIC, its memory broken at gaps).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field, fields, replace
from typing import Callable, Sequence

import numpy as np
from scipy import linalg, optimize
from scipy.linalg import lapack

from creepcomp.errors import InputError
from creepcomp.fit.data import Data, load_steps
from creepcomp.fit.normal import normal_solution
from creepcomp.fit.noise import ARNoise, ar_order, fit_noise, gaussian_bic, is_sparse, rows_for, whiten
from creepcomp.fit.structure import (DIFF_STEP, Basis, Param, Structure, basis, basis_derivatives,
                                     taus_of, with_step_times)
from creepcomp.model import CreepModel

__all__ = ["Fit", "DeferredCovariance", "ANCHOR_WEIGHT", "Problem", "best_of_starts", "fit_structure", "refined_ftol",
           "with_noise", "with_covariance", "sandwich_covariance", "small_sample_inflation", "unit_scaled"]


def best_of_starts(residual: Callable[[np.ndarray], np.ndarray], starts: Sequence[np.ndarray],
                   n_refine: int, refine: Callable[[np.ndarray], np.ndarray] | None) -> np.ndarray:
    """The best search point from several starts: the ``n_refine`` starts of lowest cost
    (all of them when there are no more) are refined by ``refine`` (None: kept as they
    are), and the point of least squared ``residual`` is kept (the first of equals).

    Both fits use it: :func:`fit_structure` and :func:`creepcomp.fit.circuit.fit_model`.
    """
    starts = list(starts)
    if len(starts) > n_refine:
        costs = [float(r @ r) for r in map(residual, starts)]
        starts = [starts[i] for i in np.argsort(costs)[:n_refine]]
    best_x, best_cost = None, np.inf
    for x0 in starts:
        x = refine(x0) if refine is not None else x0
        r = residual(x)
        c = float(r @ r)
        if c < best_cost:
            best_x, best_cost = x, c
    return best_x


@dataclass(frozen=True)
class Fit:
    """One model fitted to one record.

    Attributes
    ----------
    structure : Structure
    values : dict
        Natural values of every parameter, nonlinear (``tau[k]``, ``effect.param``) and
        linear (``offset``, ``gain``, ``a[k]`` = gain * beta_k, effect columns); ``c0[k]`` is
        the initial creep state of term k relative to the first load (free initial state).
    noise : ARNoise
        Noise model of the residual.
    prediction, residual : numpy.ndarray
        Simulated signal and measured minus simulated, on every sample (of a reduced record,
        times the square root of each sample's weight: :meth:`~creepcomp.fit.data.Data.weighted`).
    loglik, bic : float
        Gaussian AR(p) log-likelihood on the prewhitened rows, and its BIC.
    n_params : int
        Parameters counted by BIC (model and noise).
    n_rows : int
        Prewhitened rows in the likelihood.
    vector_names : tuple of str
        Names of the estimated parameters, in the order of ``cov``.
    covariance : numpy.ndarray or DeferredCovariance or None
        What :attr:`cov` reads: the matrix, or what computes it when first read.
    params : tuple of Param
        The nonlinear parameters' definitions.
    heldout : HeldOut or None
        Prediction of held-out blocks, when computed.
    """

    structure: Structure
    values: dict
    noise: ARNoise
    prediction: np.ndarray
    residual: np.ndarray
    loglik: float
    bic: float
    n_params: int
    n_rows: int
    vector_names: tuple[str, ...] = ()
    covariance: "np.ndarray | DeferredCovariance | None" = field(default=None, repr=False, compare=False)
    params: tuple[Param, ...] = ()
    heldout: "HeldOut | None" = None
    fixed_offset: bool = False
    extras: dict = field(default_factory=dict, compare=False)

    @property
    def cov(self) -> np.ndarray | None:
        """Covariance of (search coordinates of nonlinear parameters, linear coefficients),
        from the Jacobian and the innovation variance (Gaussian AR noise, local linearity);
        None when not computed or singular."""
        c = self.covariance
        return c() if isinstance(c, DeferredCovariance) else c

    @property
    def taus(self) -> np.ndarray:
        """Retardation times."""
        return taus_of(self.values, self.structure.n_terms)

    @property
    def gain(self) -> float:
        """Instantaneous signal per unit load."""
        return float(self.values["gain"])

    @property
    def offset(self) -> float:
        """Signal at zero load."""
        return float(self.values.get("offset", 0.0))

    @property
    def betas(self) -> np.ndarray:
        """Relative creep amplitudes ``beta_k``."""
        return np.array([self.values[f"a[{k}]"] for k in range(self.structure.n_terms)]) / self.gain

    @property
    def residual_rms(self) -> float:
        """RMS of measured minus simulated, all samples."""
        return float(np.sqrt(np.mean(self.residual ** 2)))

    def vector(self) -> np.ndarray:
        """Estimated parameters in covariance order (search coordinates for nonlinear ones)."""
        by_name = {p.name: p for p in self.params}
        return np.array([by_name[n].to_search(self.values[n]) if n in by_name else self.values[n]
                         for n in self.vector_names])

    def values_from(self, vector: np.ndarray) -> dict:
        """A value dictionary from a covariance-ordered vector."""
        by_name = {p.name: p for p in self.params}
        out = dict(self.values)
        for name, x in zip(self.vector_names, vector):
            out[name] = by_name[name].from_search(x) if name in by_name else float(x)
        return out

    def uncertainty(self, quantity: Callable[[dict], float]) -> float:
        """Standard deviation of a function of the parameter values (delta method)."""
        if self.cov is None:
            return float("nan")
        x = self.vector()
        sd = np.sqrt(np.clip(np.diag(self.cov), 0, None))
        grad = np.zeros(len(x))
        for j in range(len(x)):
            h = 1e-6 * max(abs(x[j]), sd[j], 1e-300)
            if h == 0 or not np.isfinite(h):
                continue
            xp, xm = x.copy(), x.copy()
            xp[j] += h
            xm[j] -= h
            grad[j] = (quantity(self.values_from(xp)) - quantity(self.values_from(xm))) / (2 * h)
        var = float(grad @ self.cov @ grad)
        return math.sqrt(var) if var >= 0 else float("nan")

    def estimate(self, quantity: Callable[[dict], float]) -> tuple[float, float]:
        """Value and standard deviation of a function of the parameter values."""
        return float(quantity(self.values)), self.uncertainty(quantity)

    def creep_model(self, extensions: dict | None = None) -> CreepModel:
        """The fitted Prony model (terms with |beta| too small to keep are dropped)."""
        betas, taus = self.betas, self.taus
        keep = [k for k in range(len(betas)) if betas[k] != 0 and np.isfinite(betas[k])]
        if not keep:
            raise InputError("the fit found no creep term (all beta = 0)")
        return CreepModel(tuple(betas[keep]), tuple(taus[keep]), self.gain, self.offset,
                          extensions or {})

    def step_times_part(self, data: Data) -> np.ndarray:
        """The part of :attr:`prediction` that is the record's load steps landing off the
        middles of their sample intervals (:func:`~creepcomp.fit.structure.with_step_times`):
        a property of the record, which a model file leaves out."""
        b = with_step_times(data, basis(data, self.structure, self.values), self.taus)
        out = np.zeros(data.n)
        for i, name in enumerate(b.names):
            if name.startswith("step_time["):
                out += self.values.get(name, 0.0) * b.columns[:, i]
        return out

    def simulate(self, data: Data) -> np.ndarray:
        """The signal this fit predicts for another load history (same structure)."""
        b = basis(data, self.structure, self.values)
        return b.columns @ np.array([self.values[n] for n in b.names])


#: Ridge weight (relative to each scaled column's norm) that anchors directions the data
#: leave undetermined at given values; identified directions are not moved by it.
ANCHOR_WEIGHT = 1e-6


def unit_scaled(gram: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The column norms behind a Gram matrix (1 for an empty column) and the Gram matrix of the
    columns scaled to unit norm."""
    norms = np.sqrt(gram.diagonal())
    norms[norms == 0] = 1.0
    return norms, gram / (norms[:, None] * norms)


def _block(matrix: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """The rows and columns of a matrix (positions or masks; ``np.ix_``'s block, without its
    overhead on the small Gram matrices of a fit's thousands of evaluations)."""
    return matrix[rows][:, cols]


def _solve(aw: np.ndarray, yw: "np.ndarray | Callable[[], np.ndarray]", prior: np.ndarray | None = None,
           gram: np.ndarray | None = None, rhs: np.ndarray | None = None,
           rows: np.ndarray | None = None, cols: np.ndarray | None = None) -> np.ndarray:
    """Least squares by scaled normal equations (fast for tall, narrow bases); falls back to
    a rank-revealing solver when they are too ill-conditioned. With ``prior``, a weak ridge
    pulls the solution towards it in directions the data do not determine. ``gram`` and
    ``rhs``: ``aw.T @ aw`` and ``aw.T @ yw`` when known; ``rows``: the rows of ``aw`` and
    ``yw`` they are of (default all); ``cols``: the columns of ``aw`` they are of (default
    all). ``yw`` may be a function that gives it, called only when the rows are needed."""
    gram = aw.T @ aw if gram is None else gram
    rhs = aw.T @ (yw() if callable(yw) else yw) if rhs is None else rhs
    live = gram.diagonal() != 0.0             # (a column of NaN stays, to fail as before)
    if prior is None and not live.all():
        # an empty column (a step the creep input does not take) keeps 0, as the minimum-norm
        # solution would: solved without it, the normal equations stay well-posed
        coef = np.zeros(len(live))
        if live.any():
            at = np.flatnonzero(live) if cols is None else np.asarray(cols)[live]
            coef[live] = _solve(aw, yw, None, _block(gram, live, live), rhs[live], rows, at)
        return coef
    norms, gram = unit_scaled(gram)
    rhs = rhs / norms
    if prior is not None:
        gram = gram + ANCHOR_WEIGHT * np.eye(len(norms))
        rhs = rhs + ANCHOR_WEIGHT * prior * norms
    coef = normal_solution(gram, rhs)
    if coef is not None:
        return coef / norms
    yw = yw() if callable(yw) else yw
    if cols is not None:
        aw = aw[:, cols]
    if rows is not None:
        aw, yw = aw[rows], yw[rows]
    coef, *_ = linalg.lstsq(aw / norms, yw, lapack_driver="gelsy", cond=1e-13)
    return coef / norms


@dataclass(frozen=True)
class _Layout:
    """What a :class:`Problem` reads off the names of a basis's columns, once per basis
    layout: the coefficients held at given values and those values, the anchor's prior, and
    each step-time column (:attr:`Basis.step_bounds`) with the column of the creep amplitude
    that bounds it and its half interval."""

    held: np.ndarray
    given: np.ndarray
    prior: np.ndarray | None
    steps: np.ndarray
    amplitudes: np.ndarray
    halves: np.ndarray


def _step_limits(layout: _Layout, a: np.ndarray, y: np.ndarray, coef: np.ndarray, free: np.ndarray,
                 gram: np.ndarray, aty: np.ndarray) -> np.ndarray:
    """Bounds of the step-time coefficients (:attr:`Basis.step_bounds`): ``|a_k|`` times half
    the step's interval, ``a_k`` from the model solved without them (``gram``, ``aty``:
    ``a.T @ a`` and ``a.T @ y``)."""
    steps, prior = layout.steps, layout.prior
    plain = free.copy()
    plain[steps] = False
    trial = coef.copy()
    trial[steps] = 0.0
    if plain.any():
        trial[plain] = _solve_free(a, y, gram, aty, trial, plain, prior)
    return np.abs(trial[layout.amplitudes]) * layout.halves


def _solve_free(a: np.ndarray, y: np.ndarray, gram: np.ndarray, aty: np.ndarray, coef: np.ndarray,
                free: np.ndarray, prior: np.ndarray | None) -> np.ndarray:
    """The coefficients ``free`` by :func:`_solve`, the others held at their values in
    ``coef``: their normal equations read off the whole basis's (``gram``, ``aty``: ``a.T @ a``
    and ``a.T @ y``), no column copied and no row visited unless they are too
    ill-conditioned."""
    cols, held = np.flatnonzero(free), np.flatnonzero(~free)
    rhs = aty[cols]
    if coef[held].any():
        rhs = rhs - _block(gram, cols, held) @ coef[held]
    return _solve(a, lambda: y - a[:, held] @ coef[held], None if prior is None else prior[free],
                  _block(gram, cols, cols), rhs, cols=cols)


def _within_step_bounds(layout: _Layout, coef: np.ndarray, free: np.ndarray, limits: np.ndarray) -> np.ndarray:
    """Step-time coefficients beyond their ``limits`` set to them and taken out of the free
    ones; the free mask returned unchanged when all are within."""
    steps = layout.steps
    over = free[steps] & (np.abs(coef[steps]) > limits)
    if not over.any():
        return free
    at = steps[over]
    coef[at] = np.copysign(limits[over], coef[at])
    out = free.copy()
    out[at] = False
    return out


def _scaled_inverse(a: np.ndarray | None, gram: np.ndarray | None = None):
    """The norms of the columns and the pseudo-inverse of the Gram matrix of the columns
    scaled to unit norm (directions below a relative 1e-8 of its largest eigenvalue dropped
    when ill-posed): ``(a / norms)^+ = inverse @ (a / norms).T``. ``gram``: ``a.T @ a`` when
    known (then ``a`` is not read)."""
    norms, scaled = unit_scaled(a.T @ a if gram is None else gram)
    eig, vec = np.linalg.eigh(scaled)
    keep = eig > (1e-8 if eig[0] > 1e-8 * eig[-1] else 1e-26) * eig[-1]
    return norms, (vec[:, keep] / eig[keep]) @ vec[:, keep].T


def _anchored_inverse(gram: np.ndarray):
    """The norms of the columns and the inverse of their unit-scaled Gram matrix plus the
    anchor's ridge (:data:`ANCHOR_WEIGHT`): the response of the coefficients :func:`_solve`
    finds with a ``prior``, as :func:`_scaled_inverse` is of those it finds without."""
    norms, scaled = unit_scaled(gram)
    return norms, np.linalg.inv(scaled + ANCHOR_WEIGHT * np.eye(len(norms)))


def _zeroed(values: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """``values`` with ``rows`` set to zero (a copy; ``values`` itself when there are none)."""
    if not len(rows):
        return values
    out = values.copy()
    out[rows] = 0.0
    return out


#: Points whose projection a :class:`Problem` keeps.
_PROJECTIONS_KEPT = 3
#: Most values (samples times columns) of the bases of the projections a :class:`Problem` keeps
#: in all, that of the last point included (a record of many load steps has hundreds of
#: step-time columns): beyond it fewer points are kept, down to the last one.
_PROJECTIONS_KEPT_VALUES = 10_000_000


class Problem:
    """Variable projection (least squares) for one structure on one record, or part of it."""

    def __init__(self, data: Data, structure: Structure, mask: np.ndarray | None = None,
                 fixed: dict | None = None, anchor: dict | None = None, frozen: dict | None = None):
        self.data = data
        self.structure = structure
        self.all_params = structure.params(data)
        self.frozen = dict(frozen or {})
        self.params = [p for p in self.all_params if p.name not in self.frozen]
        self.rows = np.arange(data.n) if mask is None else np.flatnonzero(mask)   # fitted
        self.take = slice(None) if mask is None else self.rows    # (a view when all are fitted)
        self.likelihood_rows = rows_for(data, mask)                               # prewhitened
        self.sparse = is_sparse(data)
        if not self.sparse and len(self.likelihood_rows) < 10:
            raise InputError(f"{data.source}: too few samples left to fit")
        # a reduced record's samples weighed by what each holds (Data.weights): rows of the
        # signal and of the basis times the square root of their weights (:meth:`on_rows`)
        self.root_weight = None if data.weights is None else np.sqrt(data.weights[self.take])
        self.y = self.on_rows(data.signal)
        self.fixed = dict(fixed or {})
        self.anchor = dict(anchor or {})
        # the optimiser's tolerances are partly absolute: work on a residual of order one
        self.scale = data.signal_scale
        self.cache: dict = {}
        if self.sparse:
            # a sparse record must leave the noise a degree of freedom beyond the parameters
            names = self.basis(np.array([0.5 * sum(p.bounds()) for p in self.params])).names
            k = len(self.params) + _counted_linear(names, self.fixed)
            if len(self.likelihood_rows) <= k:
                raise InputError(f"{data.source}: {len(self.likelihood_rows)} samples cannot "
                                 f"determine {structure.describe()} ({k} parameters and the "
                                 f"noise need at least {k + 1})")

    def values(self, x: np.ndarray) -> dict:
        """Natural values of the nonlinear parameters at search point ``x``."""
        out = dict(self.frozen)
        out.update({p.name: p.from_search(v) for p, v in zip(self.params, x)})
        return out

    def start_vector(self, values: dict) -> np.ndarray:
        """Search point of a start value dictionary (clipped inside the bounds)."""
        return np.array([p.to_search(p.clip(values.get(p.name, p.default))) for p in self.params])

    def basis(self, x: np.ndarray) -> Basis:
        """The model's linear basis at ``x``, with the record's unknown step times
        (:func:`~creepcomp.fit.structure.with_step_times`)."""
        return basis(self.data, self.structure, self.values(x), self.cache, step_times=True)

    def straddled(self, b: Basis) -> np.ndarray:
        """Positions among the fitted rows of the samples the basis leaves free
        (:attr:`Basis.straddling`): each has a parameter of its own, so its residual is zero
        and it takes no part in the fit of the others."""
        samples = b.straddling
        if not len(samples) or isinstance(self.take, slice):
            return samples
        at = np.minimum(np.searchsorted(self.rows, samples), len(self.rows) - 1)   # (rows sorted)
        return at[self.rows[at] == samples]

    def on_fitted(self, values: np.ndarray, straddled: np.ndarray) -> np.ndarray:
        """:meth:`on_rows`, with the rows ``straddled`` (:meth:`straddled`) set to zero."""
        return _zeroed(self.on_rows(values), straddled)

    def fitted_signal(self, straddled: np.ndarray) -> np.ndarray:
        """The signal on the fitted rows (:attr:`y`), zero on the rows ``straddled``."""
        return _zeroed(self.y, straddled)

    def on_rows(self, values: np.ndarray) -> np.ndarray:
        """The fitted rows of a per-sample array or of basis columns, each times the square
        root of its sample's weight (a view when every sample is fitted unweighted)."""
        out = values[self.take]
        if self.root_weight is None:
            return out
        return out * (self.root_weight if out.ndim == 1 else self.root_weight[:, None])

    def project(self, x: np.ndarray):
        """Basis, linear coefficients and residual (on the fitted rows) at ``x``."""
        return self._projection(x)[:3]

    def _projection(self, x: np.ndarray):
        """:meth:`project` and the mask of the coefficients solved for (not held at given
        values or at a step time's bound); the last few points' are kept (the optimiser's
        last evaluation need not be its result, nor the last start the best)."""
        key = np.asarray(x, float).tobytes()
        kept = self.cache.setdefault("project", {})
        if key in kept:
            return kept[key][0]
        if kept:
            # room for this point's basis (about as large as the last) before it is made
            room = next(reversed(kept.values()))[0][0].columns.size
            while kept and sum(v[0][0].columns.size for v in kept.values()) + room > _PROJECTIONS_KEPT_VALUES:
                kept.pop(next(iter(kept)))
        b = self.basis(x)
        straddled = self.straddled(b)
        a = self.on_fitted(b.columns, straddled)
        y = self.fitted_signal(straddled)
        gram = a.T @ a
        layout = self._layout(b)
        coef = layout.given.copy()
        prior = layout.prior
        free = ~layout.held
        aty = a.T @ y
        limits = _step_limits(layout, a, y, coef, free, gram, aty) if b.step_bounds else None
        for _ in range(4):   # the step times found beyond their bounds are set to them
            if not free.any():
                break
            if free.all():
                coef = _solve(a, y, prior, gram, aty)
            else:
                coef[free] = _solve_free(a, y, gram, aty, coef, free, prior)
            if limits is None:
                break
            narrowed = _within_step_bounds(layout, coef, free, limits)
            if narrowed is free:
                break
            free = narrowed
        out = (b, coef, y - a @ coef, free)
        while len(kept) >= _PROJECTIONS_KEPT:
            kept.pop(next(iter(kept)))
        kept[key] = (out, gram)
        return out

    def _layout(self, b: Basis) -> _Layout:
        """The :class:`_Layout` of ``b``'s columns (kept by their names)."""
        layouts = self.cache.setdefault("layouts", {})
        layout = layouts.get(b.names)
        if layout is None:
            names = b.names
            steps = np.array([col for col, _, _ in b.step_bounds], dtype=np.intp)
            layout = _Layout(held=np.array([n in self.fixed for n in names], dtype=bool),
                             given=np.array([self.fixed.get(n, 0.0) for n in names], dtype=float),
                             prior=(np.array([float(self.anchor.get(n, 0.0)) for n in names])
                                    if self.anchor else None),
                             steps=steps,
                             amplitudes=np.array([names.index(f"a[{k}]") for _, k, _ in b.step_bounds], dtype=np.intp),
                             halves=np.array([half for _, _, half in b.step_bounds], dtype=float))
            layouts[b.names] = layout
        return layout

    def _gram(self, x: np.ndarray) -> np.ndarray:
        """``A^T A`` of the (weighted) basis on the fitted rows at ``x``."""
        self._projection(x)
        return self.cache["project"][np.asarray(x, float).tobytes()][1]

    def full_residual(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Prediction and measured minus predicted on every sample (those not fitted too;
        weighted as :attr:`Fit.residual`), the linear part solved on the fitted rows."""
        b, coef, _ = self.project(x)
        prediction = b.columns @ coef
        straddled = self.rows[self.straddled(b)]
        prediction[straddled] = self.data.signal[straddled]       # (each fitted by its own parameter)
        return prediction, self.data.weighted(self.data.signal - prediction)

    def residual(self, x: np.ndarray) -> np.ndarray:
        """Residual with the linear part projected out, relative to the signal's range. A row
        the basis leaves free (:meth:`straddled`) holds the price of its parameter instead of
        zero: squared, the noise variance times log n, what the criterion charges for it (so
        the search does not favour points that free more rows)."""
        try:
            b, _, r = self.project(x)
            straddled = self.straddled(b)
            if len(straddled):
                kept = len(r) - len(straddled)
                r = r.copy()
                r[straddled] = math.sqrt(math.log(len(r)) * float(r @ r) / max(kept, 1))
            return r / self.scale
        except (FloatingPointError, ValueError, linalg.LinAlgError):
            return np.full(len(self.rows), 1e30)

    def analytic(self) -> bool:
        """True when the basis's derivatives are analytic for every parameter (a Prony model
        without effects): the covariance then uses them (else central differences)."""
        return not self.structure.effects and all(
            p.name.startswith(("tau[", "c0[")) for p in self.params)

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """Jacobian of :meth:`residual` (variable projection, Golub and Pereyra): for each
        nonlinear parameter, ``-(dA c + A dc)`` with the linear coefficients' response
        ``dc = G^-1 (dA^T r - A^T dA c)`` on the free columns (``G = A^T A``); the columns'
        derivatives are analytic where the lag recursion gives them, else forward differences
        of the basis alone (:func:`creepcomp.fit.structure.basis_derivatives`). A step
        time held at its bound moves with the creep amplitude that sets the bound."""
        b, coef, r, free = self._projection(x)
        gram = self._gram(x)
        moves = basis_derivatives(self.data, self.structure, self.values(x), b, self.params,
                                  with_effects=True, cache=self.cache)
        straddled = self.straddled(b)
        a = self.on_fitted(b.columns, straddled)
        dot_r = np.zeros((len(b.names), len(moves)))                  # dA^T r
        moved = np.zeros((len(moves), len(r)))                         # (dA c)^T
        for j, m in enumerate(moves):
            for col, d in m:
                dj = self.on_fitted(d, straddled)
                moved[j] += coef[col] * dj
                dot_r[col, j] = dj @ r
        # (worked on transposed: one row per parameter, each contiguous)
        if any(not free[col] for col, _, _ in b.step_bounds):
            moved += self._bound_response(b, a, coef, free, moves, straddled, gram).T @ a.T    # + A dc (held)
        free = np.flatnonzero(free)
        if not len(free):
            return -moved.T / self.scale
        af = a if len(free) == a.shape[1] else a[:, free]
        sub = _block(gram, free, free)
        norms, inverse = _anchored_inverse(sub) if self.anchor else _scaled_inverse(af, sub)
        # -(dA c + A dc) with dc = G^-1 (dA^T r - A^T dA c) on the free columns
        shift = inverse @ (((moved @ af).T - dot_r[free]) / norms[:, None])
        jac = (shift / norms[:, None]).T @ af.T
        jac -= moved
        return jac.T / self.scale

    def _bound_response(self, b: Basis, a: np.ndarray, coef: np.ndarray, free: np.ndarray,
                        moves, straddled: np.ndarray, gram: np.ndarray) -> np.ndarray:
        """Derivatives of the coefficients (rows; zero but for step times held at their
        bound, ``|a_k|`` times a half interval with ``a_k`` solved without the step times)
        by the nonlinear parameters (columns); ``gram``: ``a.T @ a``."""
        out = np.zeros((len(b.names), len(moves)))
        layout = self._layout(b)
        bound = np.flatnonzero(~free[layout.steps] & ~layout.held[layout.steps])   # (of the step columns)
        if not len(bound):
            return out
        steps = np.zeros(len(b.names), bool)
        steps[layout.steps] = True
        plain = ~layout.held & ~steps
        if not plain.any():
            return out                  # the amplitudes setting the bounds are held too
        # (the plain columns are not copied out of the basis: products with all columns, the
        # others' coefficients zero or left out)
        trial = layout.given.copy()
        target = self.fitted_signal(straddled) - a @ np.where(plain, 0.0, trial)
        sub = _block(gram, plain, plain)
        norms, inverse = _anchored_inverse(sub) if self.anchor else _scaled_inverse(None, sub)
        rhs = (a.T @ target)[plain] / norms
        if self.anchor:          # as _step_limits solves it: pulled towards the anchor
            rhs += ANCHOR_WEIGHT * layout.prior[plain] * norms
        trial[plain] = (inverse @ rhs) / norms
        rp = target - a @ np.where(plain, trial, 0.0)
        moved = np.zeros((len(rp), len(moves)))
        dot_r = np.zeros((len(b.names), len(moves)))
        for j, m in enumerate(moves):
            for col, d in m:
                if not steps[col]:
                    dj = self.on_fitted(d, straddled)
                    moved[:, j] += trial[col] * dj
                    dot_r[col, j] = dj @ rp
        dtrial = (inverse @ ((dot_r[plain] - (a.T @ moved)[plain]) / norms[:, None])) / norms[:, None]
        where = {c: i for i, c in enumerate(np.flatnonzero(plain))}
        for i in bound:
            col, amplitude, half = layout.steps[i], layout.amplitudes[i], layout.halves[i]
            if amplitude in where:
                out[col] = (np.sign(coef[col]) * half * np.sign(trial[amplitude])
                            * dtrial[where[amplitude]])
        return out

    def _search_jacobian(self, x: np.ndarray) -> np.ndarray:
        """:meth:`jacobian` for the optimiser, with the derivatives by a parameter that moves
        the residual less than its rounding over a step of :data:`DIFF_STEP` set to zero: a
        direction the fitted samples do not see (an initial state decayed before them) would
        otherwise be moved as far as the trust region allows, by a gradient of rounding
        size. Zero where the model cannot be evaluated (:meth:`residual` is then constant)."""
        try:
            jac = self.jacobian(x)
        except (FloatingPointError, ValueError, linalg.LinAlgError):
            return np.zeros((len(self.rows), len(x)))
        r = self.residual(x)
        unseen = (np.abs(jac).max(axis=0) * DIFF_STEP * np.maximum(1.0, np.abs(x))
                  <= np.finfo(float).eps * np.abs(r).max())
        if unseen.any():
            jac[:, unseen] = 0.0
        return jac

    def cost(self, values: dict) -> float:
        """Sum of squared residuals at a start value dictionary."""
        r = self.residual(self.start_vector(values))
        return float(r @ r)

    def refine(self, x0: np.ndarray, max_nfev: int | None = None, ftol: float = 1e-8) -> np.ndarray:
        """Refine the nonlinear parameters from the search point ``x0``; returns the search
        point. ``max_nfev`` caps the iterations (each also evaluates the Jacobian,
        :meth:`jacobian`). The refinement also stops where it stalls (:data:`STALL_STEPS`,
        :data:`STALL_LOGLIK`), at its best point."""
        if len(x0) == 0:
            return x0
        lo, hi = zip(*(p.bounds() for p in self.params))
        stall = _Stall(len(self.rows))

        def jac(x):
            stall.check()
            return self._search_jacobian(x)

        def residual(x):
            r = self.residual(x)
            stall.seen(x, r)
            return r

        try:
            res = optimize.least_squares(residual, x0, jac=jac, bounds=(lo, hi), method="trf",
                                         x_scale=1.0, max_nfev=max_nfev or 40 * (len(x0) + 1),
                                         xtol=1e-8, ftol=ftol, gtol=1e-8)
        except _Stalled:
            return stall.best_x
        return res.x


#: A refinement (:meth:`Problem.refine`) stops when its last :data:`STALL_STEPS` accepted
#: steps raised the log-likelihood by less than :data:`STALL_LOGLIK` together (its cost taken
#: as white noise's) and the optimiser rejected a trial step in between: near a kink of the
#: cost (a mode that switches, a step time at its bound) its local model fails, and it
#: alternates rejected steps with accepted ones that gain next to nothing, never meeting its
#: relative tolerance (a refinement of 36 evaluations gained under 0.1 in its last 25). Steps
#: accepted one after the other are not a stall: a trust region growing again after
#: rejections crawls before it gains (1.4 in one fit after gains of 0.001 per step).
#: 0.005: the tolerance of a screening fit (:func:`refined_ftol`), each parameter within
#: about a tenth of its standard deviation of the optimum.
STALL_STEPS = 2
STALL_LOGLIK = 0.005


class _Stalled(Exception):
    """Raised inside the optimiser to stop a refinement that no longer gains."""


class _Stall:
    """What :data:`STALL_STEPS` reads off a refinement: its best point, and at each accepted
    step (the optimiser evaluates the Jacobian at each) the best cost and the evaluations of
    the cost so far; gains in log-likelihood units for ``n`` rows."""

    def __init__(self, n: int):
        self.n = n
        self.best_cost, self.best_x = math.inf, None
        self.evaluations = 0
        self.accepted: list[tuple[float, int]] = []

    def seen(self, x: np.ndarray, r: np.ndarray) -> None:
        """An evaluation of the cost at ``x`` (residual ``r``)."""
        self.evaluations += 1
        cost = float(r @ r)
        if cost < self.best_cost:
            self.best_cost, self.best_x = cost, np.array(x, float)

    def check(self) -> None:
        """At an accepted step: raises :class:`_Stalled` when the refinement stalls."""
        self.accepted.append((self.best_cost, self.evaluations))
        if len(self.accepted) <= STALL_STEPS or not 0 < self.best_cost < math.inf:
            return
        before, evaluations = self.accepted[-1 - STALL_STEPS]
        rejected = self.evaluations - evaluations > STALL_STEPS
        if rejected and 0.5 * self.n * math.log(before / self.best_cost) < STALL_LOGLIK:
            raise _Stalled


def fit_structure(data: Data, structure: Structure, starts: Sequence[dict], noise: ARNoise | None = None,
                  mask: np.ndarray | None = None, max_nfev: int | None = None,
                  n_refine: int = 2, with_cov: bool = True, fixed: dict | None = None,
                  anchor: dict | None = None, refine: bool = True, frozen: dict | None = None,
                  ftol: float = 1e-8, coarse_ftol: float | None = None,
                  screening: bool = False) -> Fit:
    """Fit a structure by least squares (variable projection); likelihood, BIC and
    uncertainties with an AR noise model.

    The parameters are estimated by ordinary least squares, which stays unbiased whatever the
    noise's colour; the noise model only weighs the evidence. (Prewhitened, generalised least
    squares would be more efficient for a correct noise model, but a noise model estimated
    from a residual that still holds structure comes out close to a unit root, and
    prewhitening with it leaves slow misfit unconstrained.)

    Parameters
    ----------
    data : Data
    structure : Structure
    starts : sequence of dict
        Candidate start values of the nonlinear parameters; the best ``n_refine`` (by cost)
        are refined.
    noise : ARNoise, optional
        Noise model of the residual (default: AR(p) of this fit's own residual, p chosen by
        BIC), for the covariance; the likelihood that ranks models is white (see
        :func:`with_noise`).
    mask : numpy.ndarray of bool, optional
        Samples to fit (the rest is held out).
    max_nfev : int, optional
        Cap on model evaluations per refinement.
    n_refine : int
    with_cov : bool
        Give the fit its parameter covariance (computed when first read:
        :class:`DeferredCovariance`).
    fixed : dict, optional
        Linear coefficients held at given values (by name).
    anchor : dict, optional
        Values the linear coefficients keep in directions the (masked) data leave
        undetermined (see :data:`ANCHOR_WEIGHT`).
    refine : bool
        Refine the nonlinear parameters (False: keep the best start, solve the linear part).
    frozen : dict, optional
        Nonlinear parameters held at given values (not searched).
    ftol : float
        Relative change of the cost at which a refinement stops (looser after a coarse
        search and when ``screening``: :func:`refined_ftol`).
    coarse_ftol : float, optional
        The same for the search of a long record's starts on its coarse record (default
        :data:`COARSE_FTOL`).
    screening : bool
        The fit only ranks candidates: every refinement stops at :func:`refined_ftol`. (A fit
        whose held-out prediction is measured is refined to ``ftol``: the held-out refit, a
        few evaluations from the fit's values, follows where the fit stopped.)
    """
    problem = Problem(data, structure, mask, fixed=fixed, anchor=anchor, frozen=frozen)
    starts = [problem.start_vector(s) for s in starts]
    if not starts:
        raise InputError("no start values")
    coarse = _coarse(problem) if refine and mask is None and not fixed and not anchor else None
    if coarse is not None:
        # the starts are searched on the coarse record; its best point is refined on all
        coarse_ftol = max(ftol, coarse_ftol or COARSE_FTOL)
        starts = [best_of_starts(coarse.residual, starts, n_refine,
                                 lambda x0: coarse.refine(x0, max_nfev, coarse_ftol))]
    if coarse is not None or screening:
        ftol = refined_ftol(problem, ftol)
    x = best_of_starts(problem.residual, starts, n_refine,
                       (lambda x0: problem.refine(x0, max_nfev, ftol)) if refine else None)
    return _finish(problem, x, noise, with_cov)


def refined_ftol(problem: Problem, ftol: float = 1e-8) -> float:
    """The tolerance of the refinement on all samples from the best point of a coarse search,
    and of every refinement of a fit that is ``screening``: ``ftol``, or converged until the cost
    moves the log-likelihood by under 0.005 when that is looser (a change of the cost of 0.01
    noise variances: each parameter within about a tenth of its standard deviation of the
    optimum)."""
    return max(ftol, 0.01 / len(problem.rows))


#: Samples of the coarse record on which the starts of a long record's fit are searched.
COARSE_SAMPLES = 2000
#: Relative change of the cost at which a refinement on the coarse record stops.
COARSE_FTOL = 1e-6


def _coarse(problem: Problem) -> "Problem | None":
    """The problem on a coarse record (every m-th sample, and both samples of every load
    step and the ends of every segment: a load that steps or holds between kept samples is
    the same load, and so are the lags), with the full problem's parameters and bounds; None
    for a model with effects (they may depend on every sample) or a record too short to
    gain by it."""
    data = problem.data
    step = data.n // COARSE_SAMPLES
    if problem.structure.effects or step < 4:
        return None
    keep = np.zeros(data.n, bool)
    keep[::step] = True
    keep[-1] = True
    steps = load_steps(data)
    keep[steps] = keep[steps + 1] = True
    ends = np.flatnonzero(np.diff(data.segment) != 0)
    keep[ends] = keep[ends + 1] = True
    if np.count_nonzero(keep) * 4 > data.n:
        return None
    rows = np.flatnonzero(keep)
    per_sample = {f.name: getattr(data, f.name)[rows] for f in fields(data)
                  if isinstance(getattr(data, f.name), np.ndarray) and len(getattr(data, f.name)) == data.n}
    coarse = replace(data, **per_sample)
    try:
        out = Problem(coarse, problem.structure, frozen=problem.frozen)
    except InputError:
        return None
    out.all_params, out.params = problem.all_params, problem.params
    out.scale = problem.scale
    return out


def _counted_linear(names, fixed: dict, empty=()) -> int:
    """Free linear coefficients as the criterion counts them: a load step's time is one
    unknown, however many creep terms its columns span (so that a further term is not
    charged for the record's steps again); an ``empty`` column (all zero: a step the delayed
    creep input does not take) is none."""
    free = [n for n in names if n not in fixed and n not in empty]
    steps = {n.split("]")[0] for n in free if n.startswith("step_time[")}
    return sum(not n.startswith("step_time[") for n in free) + len(steps)


def _empty(b: Basis) -> set:
    """Names of the basis's columns that are all zero."""
    return {n for n, live in zip(b.names, np.any(b.columns != 0.0, axis=0)) if not live}


def _finish(problem: Problem, x: np.ndarray, noise: ARNoise | None, with_cov: bool) -> Fit:
    data, structure = problem.data, problem.structure
    b, coef, _ = problem.project(x)
    values = problem.values(x)
    values.update({name: float(c) for name, c in zip(b.names, coef)})
    prediction, residual = problem.full_residual(x)
    if noise is None:
        noise = fit_noise(residual, problem.likelihood_rows, ar_order(data))
    fit = Fit(structure=structure, values=values, noise=noise, prediction=prediction,
              residual=residual, loglik=0.0, bic=0.0, n_params=0, n_rows=len(problem.likelihood_rows),
              vector_names=tuple(p.name for p in problem.params) + b.names,
              params=tuple(problem.all_params), fixed_offset=data.fixed_offset,
              extras={"rows": problem.likelihood_rows, "fitted": problem.rows,
                      "nonlinear": len(problem.all_params),
                      "linear": _counted_linear(b.names, problem.fixed, _empty(b)) + len(problem.straddled(b))})
    fit = with_noise(fit, noise)
    if with_cov:
        fit = replace(fit, covariance=DeferredCovariance(problem, x, coef, fit))
    return fit


class DeferredCovariance:
    """A fit's covariance (:func:`_fit_covariance`), computed when first read: a diagnosis
    fits many candidates and reports the uncertainties of few. The fitting problem is kept
    with the one projection the computation starts from; the result is the one computed at
    once."""

    def __init__(self, problem: Problem, x: np.ndarray, coef: np.ndarray, fit: Fit):
        key = np.asarray(x, float).tobytes()
        kept = problem.cache.get("project", {})
        problem.cache = {"project": {key: kept[key]}} if key in kept else {}
        self._inputs = (problem, x, coef, fit)
        self._value = None

    def __call__(self) -> np.ndarray | None:
        inputs = self._inputs
        if inputs is not None:
            self._value = _fit_covariance(*inputs)
            self._inputs = None             # (the problem freed; the value set first)
        return self._value

    def __getstate__(self):
        return {"_inputs": None, "_value": self()}

    def deferred_reduction(self) -> tuple:
        """A reduction (:meth:`pickle.Pickler.reducer_override`) whose copy defers the
        computation still: the problem and point travel instead of the value, without the
        kept projection (the basis columns: most of the bytes; computed again, the same, if
        the copy is read)."""
        inputs = self._inputs
        if inputs is not None:
            problem = copy.copy(inputs[0])
            problem.cache = {}
            inputs = (problem, *inputs[1:])
        return _deferred_covariance, (inputs, self._value)


def _deferred_covariance(inputs, value) -> DeferredCovariance:
    out = DeferredCovariance.__new__(DeferredCovariance)
    out._inputs, out._value = inputs, value
    return out


def _fit_covariance(problem: Problem, x: np.ndarray, coef: np.ndarray, fit: Fit) -> np.ndarray | None:
    """The covariance of ``fit`` at its search point ``x`` and coefficients ``coef``: sandwich
    under its noise model, widened for a sparse record (:func:`small_sample_inflation`)."""
    cov = _covariance(problem, x, coef, fit.noise)
    if cov is not None and problem.sparse:
        cov = cov * small_sample_inflation(len(problem.likelihood_rows), fit.n_params - 1)
    return cov


def with_covariance(data: Data, fit: Fit) -> Fit:
    """A fit of :func:`fit_structure` made without its covariance (``with_cov=False``, on
    every sample, no coefficients held), with it: as :func:`fit_structure` would have
    computed it."""
    problem = Problem(data, fit.structure)
    x = np.array([p.to_search(fit.values[p.name]) for p in problem.params])
    _, coef, _ = problem.project(x)
    return replace(fit, covariance=_fit_covariance(problem, x, coef, fit))


#: Share of a normal distribution within one standard deviation of its mean, each side.
_ONE_SIGMA = 0.5 * (1.0 + math.erf(1.0 / math.sqrt(2.0)))


def small_sample_inflation(n_rows: int, n_params: int) -> float:
    """Factor on the covariance of a sparse record's estimates (fewer than
    :data:`~creepcomp.fit.noise.SPARSE_SAMPLES` samples) so that one stated standard deviation
    spans what it would with the noise known: the innovation variance estimated without bias
    (``n / (n - k)`` on the maximum-likelihood one) and Student's t with ``n - k`` degrees of
    freedom, whose one-sigma quantile is ``t_(n-k)(0.841)`` instead of 1 (1.84 with one degree
    of freedom, 1.32 with two, 1.14 with four). Linearised: the profile would be exact but
    costs a refit per parameter and point, and on so few samples its shape is itself uncertain."""
    from scipy.special import stdtrit   # (Student's t quantile, as scipy.stats has it)

    dof = n_rows - n_params
    if dof < 1:
        return float("inf")
    return (n_rows / dof) * float(stdtrit(dof, _ONE_SIGMA)) ** 2


def with_noise(fit: Fit, noise: ARNoise) -> Fit:
    """The fit with a noise model (AR coefficients; innovation variance from the prewhitened
    residual) and its Gaussian log-likelihood and BIC.

    The likelihood that ranks models is that of independent errors on all fitted samples:
    it is nested (a richer model never has a lower likelihood), and it counts slow misfit in
    full. It overstates evidence when the noise is coloured; the held-out test of
    :func:`creepcomp.fit.evidence.compare`, whose spread follows the noise spectrum, guards against that.
    ``k`` counts the nonlinear and free linear parameters and the noise variance.
    """
    rows = fit.extras["rows"]
    rw = whiten(fit.residual, rows, noise)
    noise = replace(noise, sigma=math.sqrt(max(float(rw @ rw) / len(rows), 1e-300)))
    fitted = fit.extras["fitted"]
    k = fit.extras["nonlinear"] + fit.extras["linear"] + 1
    loglik, bic = gaussian_bic(float(np.sum(fit.residual[fitted] ** 2)), len(fitted), k)
    return replace(fit, noise=noise, loglik=loglik, bic=bic, n_params=k)


def _inverse_ar_transpose(z: np.ndarray, noise: ARNoise) -> np.ndarray:
    """``W^-T z`` for the AR prewhitening filter ``W`` (the inverse filter run backwards)."""
    if noise.order == 0:
        return z
    # the all-pole filter 1 / (1 - sum phi_i q^-i) run backwards: a banded triangular solve
    z = np.asarray(z, dtype=float)
    band = np.zeros((noise.order + 1, len(z)))
    band[0] = 1.0
    for i, phi in enumerate(noise.phi, start=1):
        band[i, :len(z) - i] = -phi
    out, info = lapack.dtbtrs(band, z[::-1].reshape(len(z), -1), uplo="L")
    if info != 0:
        raise linalg.LinAlgError(f"AR filter: LAPACK dtbtrs info {info}")
    return out.reshape(z.shape)[::-1]


def _covariance(problem: Problem, x, coef, noise: ARNoise) -> np.ndarray | None:
    """Covariance of the least-squares estimates under AR noise (sandwich):
    ``(J^T J)^-1 J^T Sigma J (J^T J)^-1`` with ``Sigma = sigma^2 W^-1 W^-T``."""
    rows = problem.rows
    b, _, _, free = problem._projection(x)
    moves = (basis_derivatives(problem.data, problem.structure, problem.values(x), b, problem.params)
             if problem.analytic() else None)
    cols = [] if moves is None else [sum(coef[col] * d for col, d in m) for m in moves]
    for j in range(len(x) if moves is None else 0):
        h = 1e-6 * max(1.0, abs(x[j]))
        xp, xm = x.copy(), x.copy()
        xp[j] += h
        xm[j] -= h
        bp = problem.basis(xp).columns @ coef
        bm = problem.basis(xm).columns @ coef
        cols.append((bp - bm) / (2 * h))
    full = np.column_stack(cols + [b.columns]) if cols else b.columns.copy()
    # a step time held at its bound moves with the creep amplitude that sets the bound
    for col, k, half in b.step_bounds:
        amplitude = b.names.index(f"a[{k}]")
        if not free[col] and b.names[col] not in problem.fixed and free[amplitude]:
            full[:, len(x) + amplitude] += (np.sign(coef[col]) * half * np.sign(coef[amplitude])
                                           * b.columns[:, col])
    # coefficients held at given values or at a step time's bound are not estimated
    full[:, len(x) + np.flatnonzero(~free)] = 0.0
    weighted = problem.data.weighted(full)
    if isinstance(problem.take, slice):
        z = weighted                  # (every row fitted: no copy of the basis's size besides)
    else:
        z = np.zeros_like(full)
        z[rows] = weighted[rows]
    z[rows[problem.straddled(b)]] = 0.0          # (each fitted by its own parameter)
    return sandwich_covariance([z], [noise])


def sandwich_covariance(jacobians, noises) -> np.ndarray | None:
    """Covariance of least-squares estimates under AR noise (sandwich):
    ``(J^T J)^-1 J^T Sigma J (J^T J)^-1`` with ``Sigma = sigma^2 W^-1 W^-T``, block-diagonal
    over records whose noises are independent.

    Parameters
    ----------
    jacobians : sequence of numpy.ndarray
        Per record, the Jacobian of the residual on every sample in time order (rows of
        samples not fitted are zero), one column per estimated parameter.
    noises : sequence of ARNoise
        Per record, its residual's noise.

    Returns
    -------
    numpy.ndarray or None
        None when the normal matrix cannot be inverted.
    """
    # (of one record: its Jacobian and the scaled one are the only arrays of its size made)
    jac = jacobians[0] if len(jacobians) == 1 else np.vstack(jacobians)
    norms = np.sqrt(np.sum(jac ** 2, axis=0))
    norms[norms == 0] = 1.0
    jn = jac / norms
    try:
        bread = linalg.pinvh(jn.T @ jn)
    except (linalg.LinAlgError, ValueError):
        return None
    meat = np.zeros_like(bread)
    for block, noise in zip(jacobians, noises):
        zt = _inverse_ar_transpose(jn if len(jacobians) == 1 else block / norms, noise)
        meat += noise.sigma ** 2 * (zt.T @ zt)
    return (bread @ meat @ bread) / np.outer(norms, norms)
