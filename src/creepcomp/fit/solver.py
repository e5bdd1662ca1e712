"""Fitting one model structure to one record: variable projection (the linear part solved
for each point of the nonlinear search), the best of several starts, the likelihood with
the residual's AR noise, and the covariance of the estimates.

Parameters are estimated by least squares; for fixed nonlinear parameters the linear part
is projected out, and the nonlinear ones are refined by ``scipy.optimize.least_squares``.
Uncertainties come from the Jacobian with the residual's AR(p) noise model (sandwich
covariance; p = 0 ... 5 chosen by BIC, its memory broken at gaps).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Callable, Sequence

import numpy as np
from scipy import linalg, optimize

from creepcomp.errors import InputError
from creepcomp.fit.data import Data
from creepcomp.fit.noise import ARNoise, fit_noise, gaussian_bic, rows_for, whiten
from creepcomp.fit.structure import Param, Structure, basis, lag_jacobian, taus_of
from creepcomp.model import CreepModel

__all__ = ["Fit", "ANCHOR_WEIGHT", "Problem", "best_of_starts", "fit_structure", "with_noise",
           "sandwich_covariance"]


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
        Simulated signal and measured minus simulated, on every sample.
    loglik, bic : float
        Gaussian AR(p) log-likelihood on the prewhitened rows, and its BIC.
    n_params : int
        Parameters counted by BIC (model and noise).
    n_rows : int
        Prewhitened rows in the likelihood.
    vector_names : tuple of str
        Names of the estimated parameters, in the order of ``cov``.
    cov : numpy.ndarray
        Covariance of (search coordinates of nonlinear parameters, linear coefficients),
        from the Jacobian and the innovation variance (Gaussian AR noise, local linearity).
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
    cov: np.ndarray | None = None
    params: tuple[Param, ...] = ()
    heldout: "HeldOut | None" = None
    fixed_offset: bool = False
    extras: dict = field(default_factory=dict, compare=False)

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

    def simulate(self, data: Data) -> np.ndarray:
        """The signal this fit predicts for another load history (same structure)."""
        b = basis(data, self.structure, self.values)
        return b.columns @ np.array([self.values[n] for n in b.names])


#: Ridge weight (relative to each scaled column's norm) that anchors directions the data
#: leave undetermined at given values; identified directions are not moved by it.
ANCHOR_WEIGHT = 1e-6


def _solve(aw: np.ndarray, yw: np.ndarray, prior: np.ndarray | None = None) -> np.ndarray:
    """Least squares by scaled normal equations (fast for tall, narrow bases); falls back to
    a rank-revealing solver when they are too ill-conditioned. With ``prior``, a weak ridge
    pulls the solution towards it in directions the data do not determine."""
    norms = np.sqrt(np.einsum("ij,ij->j", aw, aw))
    norms[norms == 0] = 1.0
    gram = (aw.T @ aw) / np.outer(norms, norms)
    rhs = (aw.T @ yw) / norms
    if prior is not None:
        gram = gram + ANCHOR_WEIGHT * np.eye(len(norms))
        rhs = rhs + ANCHOR_WEIGHT * prior * norms
    eig = np.linalg.eigvalsh(gram)
    if eig[0] > 1e-8 * eig[-1]:          # normal equations lose cond^2: keep them well-posed
        return np.linalg.solve(gram, rhs) / norms
    coef, *_ = linalg.lstsq(aw / norms, yw, lapack_driver="gelsy", cond=1e-13)
    return coef / norms


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
        if len(self.likelihood_rows) < 10:
            raise InputError(f"{data.source}: too few samples left to fit")
        self.y = data.signal[self.take]
        self.fixed = dict(fixed or {})
        self.anchor = dict(anchor or {})
        # the optimiser's tolerances are partly absolute: work on a residual of order one
        self.scale = data.signal_scale
        self.cache: dict = {}

    def values(self, x: np.ndarray) -> dict:
        """Natural values of the nonlinear parameters at search point ``x``."""
        out = dict(self.frozen)
        out.update({p.name: p.from_search(v) for p, v in zip(self.params, x)})
        return out

    def start_vector(self, values: dict) -> np.ndarray:
        """Search point of a start value dictionary (clipped inside the bounds)."""
        return np.array([p.to_search(p.clip(values.get(p.name, p.default))) for p in self.params])

    def project(self, x: np.ndarray):
        """Basis, linear coefficients and residual (on the fitted rows) at ``x``."""
        key = np.asarray(x, float).tobytes()
        last = self.cache.get("project")
        if last is not None and last[0] == key:
            return last[1]
        b = basis(self.data, self.structure, self.values(x), self.cache)
        a = b.columns[self.take]
        held = np.array([n in self.fixed for n in b.names])
        known = np.array([self.fixed.get(n, 0.0) for n in b.names])
        target = self.y - a[:, held] @ known[held] if held.any() else self.y
        coef = known.copy()
        prior = None
        if self.anchor:
            prior = np.array([float(self.anchor.get(n, 0.0)) for n in b.names])[~held]
        if not held.all():
            coef[~held] = _solve(a[:, ~held], target, prior)
        out = (b, coef, self.y - a @ coef)
        self.cache["project"] = (key, out)
        return out

    def residual(self, x: np.ndarray) -> np.ndarray:
        """Residual with the linear part projected out, relative to the signal's range."""
        try:
            return self.project(x)[2] / self.scale
        except (FloatingPointError, ValueError, linalg.LinAlgError):
            return np.full(len(self.rows), 1e30)

    def analytic(self, x: np.ndarray) -> bool:
        """True when the residual's Jacobian at ``x`` is analytic (a plain Prony model)."""
        if self.structure.effects:
            return False
        try:
            b = self.project(x)[0]
        except (FloatingPointError, ValueError, linalg.LinAlgError):
            return False
        return lag_jacobian(self.data, self.structure, self.values(x), b, self.params) is not None

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """Jacobian of :meth:`residual` (variable projection, Golub and Pereyra): for each
        nonlinear parameter, ``-(dA c + A dc)`` with the linear coefficients' response
        ``dc = G^-1 (dA^T r - A^T dA c)`` on the free columns (``G = A^T A``); the lags'
        derivatives come from their own recursion (:func:`creepcomp.fit.structure.lag_jacobian`).
        """
        b, coef, r = self.project(x)
        moves = lag_jacobian(self.data, self.structure, self.values(x), b, self.params)
        a = b.columns[self.take]
        free = np.flatnonzero([n not in self.fixed for n in b.names])
        moved = np.column_stack([coef[col] * d[self.take] for col, d in moves])   # dA c
        jac = -moved
        if len(free):
            af = a[:, free]
            norms = np.sqrt(np.einsum("ij,ij->j", af, af))
            norms[norms == 0] = 1.0
            # G^+ A^T in scaled coordinates: z = (A D^-1)^+ M, and A G^+ e_i = (A D^-1) G_s^+ e_i / D_i
            gram = (af.T @ af) / np.outer(norms, norms)
            eig, vec = np.linalg.eigh(gram)
            keep = eig > (1e-8 if eig[0] > 1e-8 * eig[-1] else 1e-26) * eig[-1]
            inverse = (vec[:, keep] / eig[keep]) @ vec[:, keep].T          # G_s^+
            jac = jac + (af / norms) @ (inverse @ ((af.T @ moved) / norms[:, None]))
            where = {c: i for i, c in enumerate(free)}
            pick = [(j, where[col], float(d[self.take] @ r)) for j, (col, d) in enumerate(moves)
                    if col in where]
            if pick:
                js, cols, dots = map(np.array, zip(*pick))
                weights = inverse[:, cols] / norms[:, None] / norms[cols][None, :] * dots[None, :]
                jac[:, js] -= af @ weights
        return jac / self.scale

    def cost(self, values: dict) -> float:
        """Sum of squared residuals at a start value dictionary."""
        r = self.residual(self.start_vector(values))
        return float(r @ r)

    def refine(self, x0: np.ndarray, max_nfev: int | None = None) -> np.ndarray:
        """Refine the nonlinear parameters from the search point ``x0``; returns the search
        point. ``max_nfev`` caps the iterations (each also evaluates a finite-difference
        Jacobian)."""
        if len(x0) == 0:
            return x0
        lo, hi = zip(*(p.bounds() for p in self.params))
        jac = self.jacobian if self.analytic(x0) else "2-point"
        res = optimize.least_squares(self.residual, x0, jac=jac, bounds=(lo, hi), method="trf",
                                     x_scale=1.0, max_nfev=max_nfev or 40 * (len(x0) + 1),
                                     diff_step=1e-6, xtol=1e-8, ftol=1e-8, gtol=1e-8)
        return res.x


def fit_structure(data: Data, structure: Structure, starts: Sequence[dict], noise: ARNoise | None = None,
                  mask: np.ndarray | None = None, max_nfev: int | None = None,
                  n_refine: int = 2, with_cov: bool = True, fixed: dict | None = None,
                  anchor: dict | None = None, refine: bool = True, frozen: dict | None = None) -> Fit:
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
        Compute the parameter covariance.
    fixed : dict, optional
        Linear coefficients held at given values (by name).
    anchor : dict, optional
        Values the linear coefficients keep in directions the (masked) data leave
        undetermined (see :data:`ANCHOR_WEIGHT`).
    refine : bool
        Refine the nonlinear parameters (False: keep the best start, solve the linear part).
    frozen : dict, optional
        Nonlinear parameters held at given values (not searched).
    """
    problem = Problem(data, structure, mask, fixed=fixed, anchor=anchor, frozen=frozen)
    starts = [problem.start_vector(s) for s in starts]
    if not starts:
        raise InputError("no start values")
    x = best_of_starts(problem.residual, starts, n_refine,
                       (lambda x0: problem.refine(x0, max_nfev)) if refine else None)
    return _finish(problem, x, noise, with_cov)


def _finish(problem: Problem, x: np.ndarray, noise: ARNoise | None, with_cov: bool) -> Fit:
    data, structure = problem.data, problem.structure
    b, coef, _ = problem.project(x)
    values = problem.values(x)
    values.update({name: float(c) for name, c in zip(b.names, coef)})
    prediction = b.columns @ coef
    residual = data.signal - prediction
    if noise is None:
        noise = fit_noise(residual, problem.likelihood_rows)
    fit = Fit(structure=structure, values=values, noise=noise, prediction=prediction,
              residual=residual, loglik=0.0, bic=0.0, n_params=0, n_rows=len(problem.likelihood_rows),
              vector_names=tuple(p.name for p in problem.params) + b.names,
              params=tuple(problem.all_params), fixed_offset=data.fixed_offset,
              extras={"rows": problem.likelihood_rows, "fitted": problem.rows,
                      "nonlinear": len(problem.all_params),
                      "linear": int(np.sum([n not in problem.fixed for n in b.names]))})
    fit = with_noise(fit, noise)
    if with_cov:
        fit = replace(fit, cov=_covariance(problem, x, coef, fit.noise))
    return fit


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
    from scipy import signal as sps

    if noise.order == 0:
        return z
    den = np.concatenate([[1.0], -np.array(noise.phi)])
    return sps.lfilter([1.0], den, z[::-1], axis=0)[::-1]


def _covariance(problem: Problem, x, coef, noise: ARNoise) -> np.ndarray | None:
    """Covariance of the least-squares estimates under AR noise (sandwich):
    ``(J^T J)^-1 J^T Sigma J (J^T J)^-1`` with ``Sigma = sigma^2 W^-1 W^-T``."""
    data, rows = problem.data, problem.rows
    b = basis(data, problem.structure, problem.values(x), problem.cache)
    moves = lag_jacobian(data, problem.structure, problem.values(x), b, problem.params)
    cols = [] if moves is None else [coef[col] * d for col, d in moves]
    for j in range(len(x) if moves is None else 0):
        h = 1e-6 * max(1.0, abs(x[j]))
        xp, xm = x.copy(), x.copy()
        xp[j] += h
        xm[j] -= h
        bp = basis(data, problem.structure, problem.values(xp), problem.cache).columns @ coef
        bm = basis(data, problem.structure, problem.values(xm), problem.cache).columns @ coef
        cols.append((bp - bm) / (2 * h))
    full = np.column_stack(cols + [b.columns]) if cols else b.columns
    held = [len(x) + i for i, n in enumerate(b.names) if n in problem.fixed]
    full[:, held] = 0.0
    z = np.zeros_like(full)
    z[rows] = full[rows]
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
    jac = np.vstack(jacobians)
    norms = np.sqrt(np.sum(jac ** 2, axis=0))
    norms[norms == 0] = 1.0
    jn = jac / norms
    try:
        bread = linalg.pinvh(jn.T @ jn)
    except (linalg.LinAlgError, ValueError):
        return None
    meat = np.zeros_like(bread)
    for block, noise in zip(jacobians, noises):
        zt = _inverse_ar_transpose(block / norms, noise)
        meat += noise.sigma ** 2 * (zt.T @ zt)
    return (bread @ meat @ bread) / np.outer(norms, norms)
