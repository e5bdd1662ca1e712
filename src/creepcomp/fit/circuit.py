"""The model of a built network's measured output: the circuit side of the diagnosis
(:mod:`creepcomp.diagnose.circuit`) fits it with and without circuit effects.

Every model of the measured output is ``corrected = H[signal] + offset + decays``: the
(as-built) network driven by the signal from its settled state at the first sample, the
measuring chain's offset, and decays at the network's own poles from its unknown initial
state and from *input breaks* (a load step lands between two samples, where the signal is
not the straight line simulated) -- each decay held by a prior as wide as physics allows.
The nominal network is simulated exactly for any sampling (the signal taken linear between
samples); circuit effects (:mod:`creepcomp.diagnose.effects`, given to :func:`fit_model` as
objects) change the network through physical parameters.

From the sensor-side fit this takes the segments of the sampling
(:func:`creepcomp.fit.data.gaps`), the nonlinear parameters (:class:`~creepcomp.fit.structure.Param`),
the AR noise model and its prewhitening (:mod:`creepcomp.fit.noise`), the information
criterion (:func:`~creepcomp.fit.noise.gaussian_bic`), the search from several starts
(:func:`~creepcomp.fit.solver.best_of_starts`), the held-out blocks and their prediction
(:func:`~creepcomp.fit.evidence.predict_held_out`), and through them the comparison of two
fits (:func:`~creepcomp.fit.evidence.compare`). Where it differs, the place says why:
:func:`_project` (the linear part, with priors), :func:`_finish` (the likelihood),
:func:`fit_model` (the search), :func:`with_heldout` (the refit) and :func:`uncertainty`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy import optimize

from creepcomp.errors import InputError
from creepcomp.fit.data import gaps
from creepcomp.fit.evidence import FOLDS, HeldOut, block_index, half_blocks, predict_held_out
from creepcomp.fit.noise import ar_order, fit_noise, gaussian_bic, rows_for, whiten
from creepcomp.fit.solver import best_of_starts
from creepcomp.fit.structure import Applied, Param
from creepcomp.io.jsonfiles import Design
from creepcomp.io.records import Record
from creepcomp.lti import lag_states
from creepcomp.network import Network

__all__ = ["MAX_BREAKS", "USED_SHARE", "CircuitData", "prepare", "noise_level", "input_breaks",
           "CircuitFit", "network_of", "residual_of", "model_params", "fit_model",
           "generic_tau_range", "with_heldout", "halves", "uncertainty"]


@dataclass(frozen=True)
class CircuitData:
    """A record with ``corrected`` and the design of the network that produced it.

    Attributes
    ----------
    time, signal, corrected : numpy.ndarray
    design : Design
        Nominal design (creep model and network).
    source : str
    segment : numpy.ndarray of int
        Segment of each sample (a gap starts a new one), for the noise model.
    breaks : numpy.ndarray of int
        Samples that follow an input the samples do not describe: a jump of the signal (a
        load step at an unknown instant between two samples) or a gap (see
        :func:`input_breaks`).
    noise : float
        Noise level of ``corrected`` (from its second differences), the scale of the
        break coefficients' prior.
    """

    time: np.ndarray
    signal: np.ndarray
    corrected: np.ndarray
    design: Design
    source: str
    segment: np.ndarray
    breaks: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    noise: float = 0.0

    @property
    def n(self) -> int:
        """Number of samples."""
        return len(self.time)

    @property
    def dt_median(self) -> float:
        """Median sampling step (s)."""
        return float(np.median(np.diff(self.time)))

    @property
    def duration(self) -> float:
        """Time span (s)."""
        return float(self.time[-1] - self.time[0])

    @property
    def scale(self) -> float:
        """Spread of the measured output."""
        return float(np.ptp(self.corrected)) or 1.0


def prepare(record: Record, design: Design, min_samples: int = 20) -> CircuitData:
    """Check a record for the circuit side: it needs ``corrected`` and enough samples."""
    record.require(n_samples=min_samples, what="diagnosing the network", columns=("corrected",))
    if float(np.ptp(record.signal)) == 0.0:
        raise InputError(f"{record.source}: the signal is constant: nothing drives the network")
    after_gap = gaps(record.time)
    return CircuitData(record.time, record.signal, record.corrected, design, record.source,
                       np.cumsum(after_gap), input_breaks(record.signal, after_gap),
                       noise_level(record.corrected))


#: Most input breaks given their own decay (the largest jumps).
MAX_BREAKS = 100
#: Smallest share of a linear column's norm in the samples of a fit for the fit to determine
#: it (10 % of its energy): a held-out prediction extrapolates it by a factor 3 at most.
USED_SHARE = math.sqrt(0.1)


def noise_level(x: np.ndarray) -> float:
    """White-noise level of a series from its second differences (a ramp does not move them;
    robust to the few samples at steps)."""
    d2 = np.diff(x, 2)
    if len(d2) == 0:
        return 0.0
    return 1.4826 * float(np.median(np.abs(d2 - np.median(d2)))) / math.sqrt(6.0)


def input_breaks(signal: np.ndarray, gaps: np.ndarray) -> np.ndarray:
    """Samples after which the network's input between samples is not the straight line the
    simulation assumes.

    A load step lands at an unknown instant between two samples: the network's states at
    the next sample then differ from the simulated ones by an unknown amount that decays at
    the network's own poles. So do they after a gap. Such samples are found as changes of
    the signal far above its noise (estimated from second differences, which a ramp does not
    move) and four times the local median change (of the 11 around it): a step, also one
    spread over a few samples; not the samples of a ramp or sweep, nor its turning points,
    whose kinks the straight line between samples misses only to second order.
    """
    du = np.diff(signal)
    noise = noise_level(signal)
    size = np.abs(du)
    from scipy import ndimage      # (imported here: a plain sensor fit does without it)

    local = ndimage.median_filter(size, size=11, mode="nearest")
    jump = (size > 10.0 * noise) & (size > 4.0 * local) & (size > 0)
    k = np.flatnonzero(jump)
    if len(k) > MAX_BREAKS:
        k = np.sort(k[np.argsort(size[k])[-MAX_BREAKS:]])
    return np.union1d(k + 1, np.flatnonzero(gaps)).astype(int)


@dataclass(frozen=True)
class CircuitFit:
    """A model of the measured output fitted to a record.

    Attributes
    ----------
    applied : tuple of Applied
        Effects applied to the nominal network, in order (empty: the nominal network).
    params : list of Param
        Nonlinear parameters (prefixed by the effect's name).
    values : dict
        Their values, and the linear coefficients.
    network : Network
        The as-built network of this model.
    residual : numpy.ndarray
        Measured minus modelled output.
    bic : float
        BIC under AR noise (``n ln(RSS/n) + k ln n`` of the prewhitened residual).
    heldout : HeldOut or None
    generic : tuple or None
        ``(gain, tau)`` of the generic extra lag (the catch-all), if applied.
    """

    applied: tuple
    params: list
    values: dict
    network: Network
    residual: np.ndarray
    bic: float
    heldout: HeldOut | None = None
    generic: tuple | None = None

    @property
    def rms(self) -> float:
        """Residual RMS."""
        return float(np.sqrt(np.mean(self.residual ** 2)))

    def describe(self) -> str:
        """Short text: ``nominal`` and the applied effects' identifiers, e.g. ``nominal + generic lag``."""
        names = [a.name for a in self.applied] + (["generic lag"] if self.generic else [])
        return " + ".join(["nominal"] + names)


def network_of(data: CircuitData, applied: tuple, values: dict) -> Network:
    """The nominal network with the applied effects at the given values."""
    net = data.design.network
    for a in applied:
        net = a.effect.apply_network(net, a.own(values), dict(a.settings))
    return net


def _columns(data: CircuitData, network: Network, generic_tau: float | None):
    """Simulated output, the linear columns of a model (one per column of a Fortran-ordered
    array), their names, and the prior spread of each coefficient (infinite: free)."""
    lag = network.lag_expansion()
    t, u = data.time, data.signal
    sim = lag.direct * u + lag_states(t, u, lag.taus, hold="linear", initial="settled") @ np.array(lag.gains)
    m = 1 + len(lag.taus) * (1 + len(data.breaks)) + (generic_tau is not None)
    cols = np.zeros((data.n, m), order="F")
    names, spread = ["offset"], [np.inf]
    cols[:, 0] = 1.0
    # (a linear drift term in every model was measured in the benchmark: it absorbed part of
    # slow faults and named fewer of them, without fewer false findings)
    j = 1
    # a lag's state before the record is unknown but within the input's excursions: its
    # decay moves the output by at most the lag's gain times their span
    span = 2.0 * max(float(np.ptp(u)), float(np.max(np.abs(u))))
    for i, (g, p) in enumerate(zip(lag.gains, lag.taus)):
        cols[:, j] = np.exp(-(t - t[0]) / p)
        names.append(f"decay[{i}]")
        spread.append(abs(g) * span)
        j += 1
    for k in data.breaks:
        since = t[k:] - t[k]
        for i, (g, p) in enumerate(zip(lag.gains, lag.taus)):
            cols[k:, j] = np.exp(-since / p)
            names.append(f"break[{k}][{i}]")
            # a step anywhere in the interval moves the lag's state by at most
            # jump * interval / tau: its output by that times the lag's gain
            spread.append(abs(u[k] - u[k - 1]) * abs(g) * (t[k] - t[k - 1]) / p)
            j += 1
    if generic_tau is not None:
        cols[:, j] = lag_states(t, u, [generic_tau], hold="linear", initial="settled")[:, 0] - u
        names.append("generic.gain")
        spread.append(np.inf)
    return sim, cols, names, np.array(spread)


def _solve(data: CircuitData, applied, params, x, generic: bool, mask=None):
    """Residual on every sample, all values (nonlinear and linear) and the network of a
    model at the search point ``x`` (fitted on ``mask``, see :func:`_project`)."""
    values = {p.name: p.from_search(v) for p, v in zip(params, x)}
    net = network_of(data, applied, values)
    residual, coef = _project(data, net, values.get("generic.tau") if generic else None, mask)
    values.update(coef)
    return residual, values, net


def _project(data: CircuitData, net: Network, generic_tau: float | None, mask=None):
    """The linear part of a model solved for a given network: residual on every sample and
    the linear coefficients by name (fitted on ``mask``).

    It differs from the sensor side's linear solve (:class:`creepcomp.fit.solver.Problem`)
    in two ways, both for the decays that every circuit model has and no sensor model does:
    a decay's coefficient is held by a Gaussian prior to what its cause can do (the unknown
    initial state, a step between two samples), and a decay mostly outside the samples of
    the fit is left out of it (see below).
    """
    sim, cols, names, spread = _columns(data, net, generic_tau)
    target = data.corrected - sim
    a, b = (cols, target) if mask is None else (cols[mask], target[mask])
    gram = a.T @ a
    scale = np.sqrt(np.diag(gram))
    total = scale if mask is None else np.sqrt(np.einsum("ij,ij->j", cols, cols))
    # a decay mostly outside the samples of the fit (one that has died out before they
    # begin, or lies in a held-out block) is not determined by them: extrapolated from its
    # tail it would predict the held-out samples by noise and drift times a large factor, so
    # it predicts nothing there
    used = scale > USED_SHARE * total
    s = scale[used]
    g = gram[np.ix_(used, used)] / np.outer(s, s)
    # coefficients with a prior spread (decays) are held to it (a Gaussian prior: ridge
    # terms (noise / spread)^2): they absorb what an unknown initial state or a step between
    # two samples can do and not more (nor drift, nor the signal's noise for another term)
    bounded = np.isfinite(spread[used])
    g[bounded, bounded] += (data.noise / (np.maximum(spread[used][bounded], 1e-300) * s[bounded])) ** 2
    rhs = (a.T @ b)[used] / s
    try:
        part = np.linalg.solve(g, rhs)
    except np.linalg.LinAlgError:
        part = np.linalg.lstsq(g, rhs, rcond=None)[0]
    coef = np.zeros(cols.shape[1])
    coef[used] = part / s
    return target - cols @ coef, dict(zip(names, coef))


def residual_of(data: CircuitData, network: Network) -> np.ndarray:
    """Residual of a given (e.g. faulted) network's output against the record, the linear
    terms (offset, decays) solved as in every fit."""
    return _project(data, network, None)[0]


def model_params(data: CircuitData, applied: tuple) -> list[Param]:
    """The nonlinear parameters of the applied effects, named ``effect.parameter``."""
    return [replace(p, name=f"{a.name}.{p.name}") for a in applied
            for p in a.effect.network_params(data, dict(a.settings))]


def fit_model(data: CircuitData, applied: tuple, starts: list[dict], generic: bool = False,
              mask: np.ndarray | None = None, refit: bool = False) -> CircuitFit:
    """Fit a model (nominal network plus ``applied`` effects, optionally the generic lag).

    Parameters
    ----------
    data : CircuitData
    applied : tuple of Applied
    starts : list of dict
        Start values of the nonlinear parameters (missing ones: each parameter's default).
    generic : bool
        Add the catch-all generic lag.
    mask : numpy.ndarray of bool, optional
        Samples the fit uses (others are predicted).
    refit : bool
        A held-out refit from the full fit's values (``starts[0]``): one Gauss-Newton step.

    Returns
    -------
    CircuitFit

    Notes
    -----
    The search differs from the sensor side's (:func:`creepcomp.fit.solver.fit_structure`,
    whose start selection, :func:`~creepcomp.fit.solver.best_of_starts`, it shares for
    several parameters): a single parameter (most circuit effects have one) is found by a
    grid over its whole range and Brent's method (:func:`_scalar_search`), several by
    ``least_squares`` with tighter ``ftol`` and ``gtol`` (1e-10) and its default
    finite-difference step, and a held-out refit by one Gauss-Newton step
    (:func:`_gauss_newton_step`). These are the settings the circuit side's rules were
    benchmarked with (``benchmarks/diagnose_circuit_confusion.py``); they are kept so that its
    results stay as they were.
    """
    params = model_params(data, applied)
    if generic:
        lo, hi = generic_tau_range(data)
        params.append(Param("generic.tau", lo, hi, log=True, default=math.sqrt(lo * hi)))
    rows = np.ones(data.n, bool) if mask is None else mask

    def residual(x) -> np.ndarray:
        # in units of the output's spread: the tolerances below are then meaningful whatever
        # the signal's units (a 100 uV sensor or a 1 V one)
        return _solve(data, applied, params, np.atleast_1d(x), generic, mask)[0][rows] / data.scale

    def cost(x) -> float:
        r = residual(x)
        return float(r @ r)

    def refine(x0: np.ndarray) -> np.ndarray:
        return optimize.least_squares(residual, x0, bounds=(lower, upper), x_scale=1.0, ftol=1e-10,
                                      xtol=1e-8, gtol=1e-10, max_nfev=30 * len(params), method="trf").x

    lower = np.array([p.bounds()[0] for p in params])
    upper = np.array([p.bounds()[1] for p in params])
    candidates = [np.array([p.to_search(p.clip(s.get(p.name, p.default))) for p in params])
                  for s in starts or [{}]]
    if not params:
        x = np.zeros(0)
    elif refit:
        x = _gauss_newton_step(residual, candidates[0], lower, upper)
    elif len(params) == 1:
        x = np.array([_scalar_search(cost, [float(c[0]) for c in candidates], lower[0], upper[0])])
    else:
        x = best_of_starts(residual, candidates, 2, refine)
    res, values, net = _solve(data, applied, params, x, generic, mask)
    return _finish(data, applied, params, values, net, res, rows, generic)


def generic_tau_range(data: CircuitData) -> tuple[float, float]:
    """Time constants the catch-all lag may take (s).

    Not below ten sampling steps nor a thirtieth of the network's fastest time constant: a lag
    faster than that mostly low-passes the measurement noise of ``signal`` (which the network
    never saw), and no circuit fault that matters for creep lives there."""
    taus = data.design.network.lag_expansion().taus
    fastest = min(taus) if taus else data.duration
    lo = max(10.0 * data.dt_median, fastest / 30.0)
    return lo, max(3.0 * data.duration, 10.0 * lo)


def _scalar_search(cost, starts: list[float], lower: float, upper: float) -> float:
    """Minimum of a one-parameter cost: the best of ``starts`` and a grid over the bounds,
    then Brent's method in the bracket around it."""
    grid = sorted(set(np.linspace(lower, upper, 9).tolist() + [min(max(s, lower), upper) for s in starts]))
    f = [cost(x) for x in grid]
    i = int(np.argmin(f))
    a, b = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
    if a == b:
        return grid[i]
    res = optimize.minimize_scalar(cost, bounds=(a, b), method="bounded",
                                   options={"xatol": 1e-7 * max(1.0, upper - lower)})
    return float(res.x) if res.fun <= f[i] else grid[i]


def _gauss_newton_step(residuals, x0: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """One Gauss-Newton step from ``x0`` (forward-difference Jacobian), kept inside the
    bounds, taken only when it lowers the cost: a held-out refit starts at the full fit's
    optimum, so one step is as far as the optimum moves."""
    r0 = residuals(x0)
    h = 1e-6 * np.maximum(1.0, np.abs(x0))
    jac = np.column_stack([(residuals(x0 + h[i] * np.eye(len(x0))[i]) - r0) / h[i] for i in range(len(x0))])
    step, *_ = np.linalg.lstsq(jac, -r0, rcond=None)
    x = np.clip(x0 + step, lower, upper)
    r = residuals(x)
    return x if r @ r < r0 @ r0 else x0


def _finish(data, applied, params, values, net, residual, rows, generic) -> CircuitFit:
    """The fit with its BIC (:func:`~creepcomp.fit.noise.gaussian_bic`, as on the sensor side)
    of the residual *prewhitened* by its own AR noise (order chosen by BIC) on the rows with
    as many predecessors (:func:`~creepcomp.fit.noise.rows_for`), the AR coefficients
    counted with the parameters. The decays of the initial state and of input breaks are held
    by their priors and not counted as free parameters (every model has them).

    The sensor side (:func:`creepcomp.fit.solver.with_noise`) takes the white likelihood of
    the raw residual instead. The circuit side's residual is mostly noise that the network
    coloured: the measurement noise of ``signal``, which the built network never saw, passed
    through the network's simulation, plus the noise of ``corrected``; its whitened
    likelihood is what the circuit side's decision threshold (:data:`BIC_STRONG
    <creepcomp.fit.evidence.BIC_STRONG>`) and its choice among candidates
    (:func:`creepcomp.diagnose.circuit.choose`) were set and benchmarked with.
    """
    k = len(params) + sum(1 for key in values if key in ("offset", "generic.gain"))
    ar_rows = rows_for(data, rows)
    noise = fit_noise(residual, ar_rows, ar_order(data))
    rss = float(np.sum(whiten(residual, ar_rows, noise) ** 2))
    bic = gaussian_bic(rss, len(ar_rows), k + noise.order)[1]
    gen = (values.get("generic.gain"), values.get("generic.tau")) if generic else None
    return CircuitFit(applied, params, values, net, residual, bic, None, gen)


def with_heldout(data: CircuitData, fit: CircuitFit, folds: int = FOLDS,
                 blocks: np.ndarray | None = None) -> CircuitFit:
    """The fit with its held-out prediction (:func:`~creepcomp.fit.evidence.predict_held_out`,
    the sensor side's blocks and folds): interleaved blocks left out in turn, the model
    refitted on the rest from the fit's own values and used to predict them; ``blocks``
    (with ``folds = 2``): other blocks, e.g. the record's two halves.

    The refit is one Gauss-Newton step (:func:`fit_model`), where the sensor side's
    (:func:`creepcomp.fit.evidence.heldout`) takes three evaluations and holds the nonlinear
    parameters that the rest of the record leaves undetermined: here the decays that the
    rest does not see are left out of the linear part instead (:func:`_project`).
    """
    blocks = block_index(data) if blocks is None else blocks
    start = {p.name: fit.values[p.name] for p in fit.params}
    return replace(fit, heldout=predict_held_out(
        blocks, folds,
        lambda keep: fit_model(data, fit.applied, [start], fit.generic is not None, mask=keep,
                               refit=True).residual))


def halves(data: CircuitData, fit: CircuitFit) -> HeldOut:
    """Held-out prediction of each half of the record from the other."""
    return with_heldout(data, fit, 2, half_blocks(data.n)).heldout


def uncertainty(data: CircuitData, fit: CircuitFit, applied: Applied) -> dict:
    """1-sigma uncertainty of an applied effect's parameters (natural units), from the
    Jacobian of the fit at its optimum and the residual variance (white noise: a lower bound
    when the noise is coloured).

    The sensor side's fits carry a sandwich covariance under their AR noise
    (:class:`creepcomp.fit.solver.Fit`); this simpler one is kept so that the circuit
    findings' reported uncertainties stay as they were.
    """
    x0 = np.array([p.to_search(fit.values[p.name]) for p in fit.params])
    upper = np.array([p.bounds()[1] for p in fit.params])
    r0 = fit.residual
    cols = []
    for i, x in enumerate(x0):
        h = 1e-5 * max(1.0, abs(x))
        if x + h > upper[i]:
            h = -h
        xi = x0.copy()
        xi[i] = x + h
        cols.append((_solve(data, fit.applied, fit.params, xi, fit.generic is not None)[0] - r0) / h)
    jac = np.column_stack(cols)
    dof = max(data.n - len(x0) - 1, 1)
    try:
        cov = np.linalg.inv(jac.T @ jac) * float(r0 @ r0) / dof
    except np.linalg.LinAlgError:
        return {}
    out = {}
    for i, p in enumerate(fit.params):
        if p.name.startswith(applied.name + "."):
            sd = math.sqrt(max(cov[i, i], 0.0))
            value = fit.values[p.name]
            out[p.name[len(applied.name) + 1:]] = abs(value) * sd if p.log else p.scale * sd
    return out
