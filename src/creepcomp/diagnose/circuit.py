"""Diagnosis of a built correction network (``diagnosis.md``, circuit side).

When a record holds both the sensor's raw ``signal`` and the measured output of the analog
network (``corrected``), the nominal network of the design is simulated on the measured
signal (exactly, for any sampling: the signal is taken linear between samples) and compared
with ``corrected``. The circuit-side effects of :mod:`creepcomp.diagnose.effects` are extensions of
the network with physical parameters; each is fitted on top of the current model and kept
while the evidence supports it, by the same rules as the sensor side
(:class:`creepcomp.fit.core.Evidence`: BIC lower by :data:`~creepcomp.fit.core.BIC_STRONG` and held-out
blocks predicted better by :data:`~creepcomp.fit.core.HELDOUT_Z` standard deviations); of several
supported, the lowest BIC unless another predicts the record's halves better (:func:`choose`). A generic
extra lag tried on top says whether structure remains that no named effect explains
(``unexplained``); with no finding the answer is ``none``.

Every model of the measured output is ``corrected = H[signal] + offset + decays``: the
(as-built) network driven by the signal from its settled state at the first sample, the
measuring chain's offset, and decays at the network's own poles
from its unknown initial state and from *input breaks* (a load step lands between two
samples, where the signal is not the straight line simulated) — each decay held by a prior
as wide as physics allows. The extension is the as-built network: written as a design file,
checked in ngspice on the same record, and the fix is the single part change that leaves the
least residual creep.
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field, replace

import numpy as np
from scipy import ndimage, optimize

from creepcomp.diagnose import effects as effects_pkg
from creepcomp.analog.faults import FixOption, largest_capacitor, suggest_fixes
from creepcomp.errors import InputError
from creepcomp.io.jsonfiles import Design
from creepcomp.fit.core import (BIC_STRONG, FOLDS, GAP_FACTOR, HELDOUT_Z, SLOW_NOISE_RATIO,
    Applied, Evidence, HeldOut, Param, autocorrelation, block_index, compare, fit_noise, ljung_box,
    rows_for, slow_noise_ratio, whiten)
from creepcomp.lti import lag_states
from creepcomp.network import Network
from creepcomp.analog.quality import step_peak
from creepcomp.io.records import Record

#: Most circuit effects added one after the other.
MAX_EFFECTS = 3


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
    dt = np.diff(record.time)
    gaps = np.concatenate([[False], dt > GAP_FACTOR * np.median(dt)])
    return CircuitData(record.time, record.signal, record.corrected, design, record.source,
                       np.cumsum(gaps), input_breaks(record.signal, gaps), noise_level(record.corrected))


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
    local = ndimage.median_filter(size, size=11, mode="nearest")
    jump = (size > 10.0 * noise) & (size > 4.0 * local) & (size > 0)
    k = np.flatnonzero(jump)
    if len(k) > MAX_BREAKS:
        k = np.sort(k[np.argsort(size[k])[-MAX_BREAKS:]])
    return np.union1d(k + 1, np.flatnonzero(gaps)).astype(int)


# --------------------------------------------------------------------------------------------
# One model of the measured output
# --------------------------------------------------------------------------------------------

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
        """Short text, e.g. ``nominal + capacitor_value``."""
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
    values = {p.name: p.from_search(v) for p, v in zip(params, x)}
    net = network_of(data, applied, values)
    sim, cols, names, spread = _columns(data, net, values.get("generic.tau") if generic else None)
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
    residual = target - cols @ coef
    values.update(dict(zip(names, coef)))
    return residual, values, net


def residual_at(data: CircuitData, effect: str, values: dict, cell: int | None = None) -> np.ndarray:
    """Residual of the nominal network with one circuit effect at ``values`` (natural units;
    ``cell``: its capacitor, by default the largest), the linear terms (offset, decays) solved
    as in every fit."""
    found = effects_pkg.get(effect)
    if found.per_capacitor and cell is None:
        cell = largest_capacitor(data.design.network)
    applied = (Applied(found, (("cell", cell),) if found.per_capacitor else ()),)
    params = model_params(data, applied)
    x = [p.to_search(values[p.name[len(effect) + 1:]]) for p in params]
    return _solve(data, applied, params, x, False)[0]


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
    """
    params = model_params(data, applied)
    if generic:
        lo, hi = generic_tau_range(data)
        params.append(Param("generic.tau", lo, hi, log=True, default=math.sqrt(lo * hi)))
    rows = np.ones(data.n, bool) if mask is None else mask
    if not params:
        residual, values, net = _solve(data, applied, params, [], generic, mask)
        return _finish(data, applied, params, values, net, residual, rows, generic)
    lower = np.array([p.bounds()[0] for p in params])
    upper = np.array([p.bounds()[1] for p in params])

    def x_of(start: dict) -> np.ndarray:
        return np.array([p.to_search(p.clip(start.get(p.name, p.default))) for p in params])

    def cost(x) -> float:
        r = _solve(data, applied, params, np.atleast_1d(x), generic, mask)[0][rows] / data.scale
        return float(r @ r)

    candidates = [x_of(s) for s in starts] or [x_of({})]
    if refit:
        x = _gauss_newton_step(lambda x: _solve(data, applied, params, x, generic, mask)[0][rows] / data.scale,
                               candidates[0], lower, upper)
        residual, values, net = _solve(data, applied, params, x, generic, mask)
        return _finish(data, applied, params, values, net, residual, rows, generic)
    if len(params) == 1:
        x = _scalar_search(cost, [float(c[0]) for c in candidates], lower[0], upper[0])
        residual, values, net = _solve(data, applied, params, [x], generic, mask)
        return _finish(data, applied, params, values, net, residual, rows, generic)
    rss = [cost(x) for x in candidates]
    best = None
    for i in np.argsort(rss)[:2]:
        # residuals in units of the output's spread: the tolerances below are then meaningful
        # whatever the signal's units (a 100 uV sensor or a 1 V one)
        res = optimize.least_squares(
            lambda x: _solve(data, applied, params, x, generic, mask)[0][rows] / data.scale,
            candidates[i], bounds=(lower, upper), x_scale=1.0, ftol=1e-10, xtol=1e-8, gtol=1e-10,
            max_nfev=30 * len(params), method="trf")
        if best is None or res.cost < best.cost:
            best = res
    residual, values, net = _solve(data, applied, params, best.x, generic, mask)
    return _finish(data, applied, params, values, net, residual, rows, generic)


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
    """The fit with its BIC under AR noise (the noise of ``corrected`` need not be white:
    its order is chosen by BIC too). The decays of the initial state and of input breaks are
    held by their priors and not counted as free parameters (every model has them)."""
    k = len(params) + sum(1 for key in values if key in ("offset", "generic.gain"))
    ar_rows = rows_for(data, rows)
    noise = fit_noise(residual, ar_rows)
    n = len(ar_rows)
    rss = float(np.sum(whiten(residual, ar_rows, noise) ** 2))
    bic = n * math.log(rss / n + 1e-300) + (k + len(noise.phi)) * math.log(n)
    gen = (values.get("generic.gain"), values.get("generic.tau")) if generic else None
    return CircuitFit(applied, params, values, net, residual, bic, None, gen)


def with_heldout(data: CircuitData, fit: CircuitFit, folds: int = FOLDS,
                 blocks: np.ndarray | None = None) -> CircuitFit:
    """The fit with its held-out prediction: interleaved blocks left out in turn, the model
    refitted on the rest (from the fit's own values) and used to predict them; ``blocks``
    (with ``folds = 2``): other blocks, e.g. the record's two halves."""
    blocks = block_index(data) if blocks is None else blocks
    fold = blocks % folds
    resid = np.empty(data.n)
    start = {p.name: fit.values[p.name] for p in fit.params}
    for b in range(folds):
        inside = fold == b
        if not inside.any():
            continue
        f = fit_model(data, fit.applied, [start], fit.generic is not None, mask=~inside, refit=True)
        resid[inside] = f.residual[inside]
    return replace(fit, heldout=HeldOut(resid, blocks))


def halves(data: CircuitData, fit: CircuitFit) -> HeldOut:
    """Held-out prediction of each half of the record from the other."""
    return with_heldout(data, fit, 2, np.minimum(np.arange(data.n) * 2 // data.n, 1)).heldout


def evidence(data: CircuitData, current: CircuitFit, rich: CircuitFit, always_halves: bool = False) -> Evidence:
    """Evidence for ``rich`` over ``current`` (both with held-out predictions), as on the
    sensor side: BIC and interleaved held-out blocks; when the richer model's residual holds
    slow noise (drift of the measuring chain, :func:`~creepcomp.fit.core.slow_noise_ratio`), also
    each half predicted from the other, which drift that a slow extension (absorption,
    leakage) follows between interleaved blocks does not allow. The weaker held-out result
    counts. ``always_halves``: in any case (the catch-all)."""
    ev = compare(None, current, rich)
    if ev.supported and (always_halves or slow_noise_ratio(rich.residual) > SLOW_NOISE_RATIO):
        across = compare(None, replace(current, heldout=halves(data, current)),
                         replace(rich, heldout=halves(data, rich)))
        if not across.supported_heldout:
            ev = replace(ev, heldout_z=min(ev.heldout_z, across.heldout_z),
                         heldout_rms_ratio=min(ev.heldout_rms_ratio, across.heldout_rms_ratio))
    return ev


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
        """The circuit side's JSON (``diagnosis.md`` keys plus the as-built network and fix)."""
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
    other better by :data:`~creepcomp.fit.core.HELDOUT_Z`. BIC under AR noise, and the
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
    across = compare(None, replace(fit, heldout=halves(data, fit)), replace(rival, heldout=halves(data, rival)))
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


def uncertainty(data: CircuitData, fit: CircuitFit, applied: Applied) -> dict:
    """1-sigma uncertainty of an applied effect's parameters (natural units), from the
    Jacobian of the fit at its optimum and the residual variance (white noise: a lower bound
    when the noise is coloured)."""
    x0 = np.array([p.to_search(fit.values[p.name]) for p in fit.params])
    lower = np.array([p.bounds()[0] for p in fit.params])
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
    """One ``diagnosis.md`` object for a record diagnosed on both sides.

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
