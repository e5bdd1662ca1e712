"""Creep models from measured records: Prony terms by variable projection, a noise model,
prediction of held-out data, and the choice of the number of terms by evidence.

The model of a record is

    signal = offset + gain * (s + sum_k beta_k c_k) + ...

with ``s`` the load as the sensor sees it and ``c_k`` the load through a first-order lag of
time constant ``tau_k`` (:func:`creepcomp.lti.lag_states`, exact for any sampling), started
from an initial state that is fitted (a record may start loaded or creeping: ``c0[k]``,
bounded by the loads a sensor sees) or known. For fixed time constants and initial states
the signal is *linear* in offset, gain and ``gain * beta_k``, so only the time constants, the
initial states (and an effect's own nonlinear parameters, see :mod:`creepcomp.diagnose.effects`) are
searched: on a log grid with non-negative least squares for
starting values, then by ``scipy.optimize.least_squares`` with the linear part projected out
(variable projection).

Parameters are estimated by least squares. Models are compared by BIC (Gaussian likelihood,
log n per parameter) *and* by prediction of held-out data: interleaved blocks are left out in
turn, the model is refitted on the rest and simulated from the load over them; the spread of
the held-out improvement is computed from the noise spectrum, so that coloured noise does not
pass for structure. Uncertainties come from the Jacobian with the residual's AR(p) noise
model (sandwich covariance; p = 0 ... 5 chosen by BIC, its memory broken at gaps).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Callable, Sequence

import numpy as np
from scipy import linalg, optimize

from creepcomp.errors import InputError
from creepcomp.lti import lag_states, varying_lag_states
from creepcomp.model import CreepModel
from creepcomp.io.records import Record

#: A time step longer than this many median steps is a gap: the noise model forgets across it.
GAP_FACTOR = 5.0
#: Largest order of the autoregressive noise model.
MAX_AR_ORDER = 5
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
#: Iterations of the mode switching of lags whose time constant depends on their state.
_MODE_ITERATIONS = 50


# --------------------------------------------------------------------------------------------
# The record, prepared for fitting
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Data:
    """A record prepared for fitting.

    Attributes
    ----------
    time, load, signal : numpy.ndarray
    temperature : numpy.ndarray or None
    source : str
    initial : str
        ``free`` (initial creep states fitted), ``relaxed``, ``settled`` or ``step``
        (a load step at ``load_step_at``, before the first sample).
    load_step_at : float or None
    hold : str
        ``linear`` or ``zero``: the load between samples.
    segment : numpy.ndarray of int
        Segment number of each sample; a gap in the sampling starts a new segment.
    fixed_offset : bool
        The load never changes within the record, so offset and gain cannot be told apart:
        the offset is fixed at zero (the signal is taken as zero at zero load).
    """

    time: np.ndarray
    load: np.ndarray
    signal: np.ndarray
    temperature: np.ndarray | None
    source: str
    initial: str
    load_step_at: float | None
    hold: str
    segment: np.ndarray
    fixed_offset: bool

    @property
    def n(self) -> int:
        """Number of samples."""
        return len(self.time)

    @property
    def t0(self) -> float:
        """Time of the first sample (s)."""
        return float(self.time[0])

    @property
    def duration(self) -> float:
        """Time span of the record (s)."""
        return float(self.time[-1] - self.time[0])

    @property
    def span(self) -> float:
        """Time from the load history's start (the step, or the first sample) to the end (s)."""
        start = self.load_step_at if self.load_step_at is not None else self.t0
        return float(self.time[-1] - start)

    @property
    def dt_median(self) -> float:
        """Median sampling step (s)."""
        return float(np.median(np.diff(self.time)))

    @property
    def dt_small(self) -> float:
        """Finest sampling step that the record uses often (5th percentile, s)."""
        return float(np.percentile(np.diff(self.time), 5))

    @property
    def load_scale(self) -> float:
        """Largest absolute load: the full scale of the record."""
        return float(np.max(np.abs(self.load)))

    @property
    def signal_scale(self) -> float:
        """Spread of the signal (for scaling)."""
        return float(np.ptp(self.signal)) or float(np.max(np.abs(self.signal))) or 1.0

    def tau_limits(self) -> tuple[float, float]:
        """Retardation times the record can resolve: from two sampling steps (a faster lag
        cannot be told from the instantaneous response; after a known load step, down to half
        the time to the first sample) to a few times the record's length (s)."""
        low = 2.0 * self.dt_median
        if self.load_step_at is not None:
            low = min(low, 0.5 * (self.t0 - self.load_step_at) or low, 2.0 * self.dt_small)
        return low, 3.0 * self.span

    def lag_initial(self, h: np.ndarray, taus: np.ndarray, values: dict | None = None):
        """Initial states of lags of the input ``h``: zero, settled at ``h[0]``, after the
        known load step, or (``free``) ``h[0]`` plus each term's fitted offset ``c0[k]``."""
        if self.initial == "relaxed":
            return "relaxed"
        if self.initial == "settled":
            return "settled"
        if self.initial == "free":
            values = values or {}
            return h[0] + np.array([values.get(f"c0[{k}]", 0.0) for k in range(len(taus))])
        return h[0] * -np.expm1(-(self.t0 - self.load_step_at) / np.asarray(taus, float))

    def with_signal(self, signal) -> "Data":
        """A copy with another signal (e.g. a simulated one)."""
        return replace(self, signal=np.asarray(signal, float))


#: Relative spread below which a load counts as constant.
CONSTANT_LOAD_TOLERANCE = 1e-6


def prepare(record: Record, initial: str = "free", load_step_at: float | None = None,
            hold: str = "linear", min_samples: int = 20) -> Data:
    """Check a record and prepare it for fitting.

    Parameters
    ----------
    record : Record
    initial : {"free", "relaxed", "settled"}
        Creep state at the first sample: fitted from the data (``free``: the record may start
        loaded or creeping), zero, or settled at the first load.
    load_step_at : float, optional
        Time of a single load step that happened before the first sample (a material creep
        test: the load was zero before it and ``load[0]`` after it).
    hold : {"linear", "zero"}
    min_samples : int

    Returns
    -------
    Data
    """
    record.require(n_samples=min_samples, what="fitting a creep model")
    if hold not in ("linear", "zero"):
        raise InputError(f"hold '{hold}': use 'linear' or 'zero'")
    if initial not in ("free", "relaxed", "settled"):
        raise InputError(f"initial state '{initial}': use free, relaxed or settled")
    load = record.load
    if not np.any(load != 0):
        raise InputError(f"{record.source}: the load is zero throughout: nothing to fit the "
                         "signal against")
    # constant to within an export's rounding (instrument files write a set stress as e.g.
    # 0.0005 and 0.00050000001362507)
    constant = float(np.ptp(load)) <= CONSTANT_LOAD_TOLERANCE * float(np.max(np.abs(load)))
    if load_step_at is not None:
        if load_step_at > record.time[0]:
            raise InputError(f"--load-step-at {load_step_at:g} s: must not be after the first "
                             f"sample ({record.time[0]:g} s)")
        initial = "step"
    elif constant:
        raise InputError(f"{record.source}: the load is constant ({load[0]:g}) throughout, so "
                         "creep cannot be told from offset: give the time of the load step "
                         "(--load-step-at, e.g. 0 for a creep test whose step was at t = 0)")
    dt = np.diff(record.time)
    gaps = np.concatenate([[False], dt > GAP_FACTOR * np.median(dt)])
    return Data(time=record.time, load=load, signal=record.signal, temperature=record.temperature,
                source=record.source, initial=initial, load_step_at=load_step_at, hold=hold,
                segment=np.cumsum(gaps), fixed_offset=constant)


# --------------------------------------------------------------------------------------------
# Parameters and model structures
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Param:
    """A nonlinear parameter: name, bounds in natural units, and how it is searched.

    ``log`` parameters (time constants) are searched on their logarithm; the others on
    ``value / scale``.
    """

    name: str
    lower: float
    upper: float
    log: bool = False
    scale: float = 1.0
    default: float = 0.0

    def to_search(self, value: float) -> float:
        """Natural value to search coordinate."""
        return math.log(value) if self.log else value / self.scale

    def from_search(self, x: float) -> float:
        """Search coordinate to natural value."""
        return math.exp(x) if self.log else x * self.scale

    def bounds(self) -> tuple[float, float]:
        """Bounds in search coordinates."""
        return self.to_search(self.lower), self.to_search(self.upper)

    def clip(self, value: float) -> float:
        """The value moved inside the bounds (strictly)."""
        lo, hi = self.bounds()
        x = min(max(self.to_search(value), lo + 1e-9 * (hi - lo)), hi - 1e-9 * (hi - lo))
        return self.from_search(x)


@dataclass(frozen=True)
class Applied:
    """An effect applied to a model, with its fixed settings (e.g. which term it acts on)."""

    effect: Any
    settings: tuple = ()

    @property
    def name(self) -> str:
        """The effect's identifier."""
        return self.effect.name

    def setting(self, key: str, default=None):
        """One fixed setting."""
        return dict(self.settings).get(key, default)

    def own(self, values: dict) -> dict:
        """This effect's parameter values, without the ``effect.`` prefix."""
        prefix = self.name + "."
        return {k[len(prefix):]: v for k, v in values.items() if k.startswith(prefix)}


@dataclass(frozen=True)
class Structure:
    """Which model: the number of Prony terms and the effects applied, in order."""

    n_terms: int = 1
    effects: tuple[Applied, ...] = ()

    def with_effect(self, applied: Applied) -> "Structure":
        """This structure plus one effect."""
        return replace(self, effects=self.effects + (applied,))

    def has(self, name: str) -> bool:
        """True when the effect ``name`` is applied."""
        return any(a.name == name for a in self.effects)

    def params(self, data: Data) -> list[Param]:
        """The nonlinear parameters: time constants, then each effect's own."""
        lo, hi = data.tau_limits()
        out = [Param(f"tau[{k}]", lo, hi * 10.0, log=True) for k in range(self.n_terms)]
        if data.initial == "free":
            # each term's creep state at the first sample, relative to the first load: within
            # the loads a sensor sees (a free decay amplitude alone could follow any slow trend)
            scale = data.load_scale
            out += [Param(f"c0[{k}]", -2.0 * scale, 2.0 * scale, scale=scale)
                    for k in range(self.n_terms)]
        for a in self.effects:
            out += [replace(p, name=f"{a.name}.{p.name}") for p in a.effect.nonlinear_params(data, a)]
        return out

    def describe(self) -> str:
        """Short text, e.g. ``2 terms + viscous_flow``."""
        text = f"{self.n_terms} term{'s' if self.n_terms > 1 else ''}"
        return " + ".join([text] + [a.name for a in self.effects])


def taus_of(values: dict, n_terms: int) -> np.ndarray:
    """The time constants in a value dictionary."""
    return np.array([values[f"tau[{k}]"] for k in range(n_terms)])


@dataclass(frozen=True)
class Basis:
    """Columns of the linear part of a model for fixed nonlinear parameters."""

    columns: np.ndarray
    names: tuple[str, ...]
    load_seen: np.ndarray        # the load after load-side effects (delay)
    instant: np.ndarray          # s: instantaneous signal in load units
    creep_input: np.ndarray      # h: what drives the lags
    lags: np.ndarray             # (N, K)


#: Samples per segment when lags whose time constant depends on their own state are solved.
_SEGMENT = 4096


def _state_dependent_lags(data: Data, h, taus, init, factor, effects, values):
    """Lags whose time constants depend on their own state (modes such as creep and recovery),
    solved segment by segment: within a segment the modes are found by fixed-point iteration
    (modes from states, states from modes; the causal solution is its only fixed point), and
    the segment's last state starts the next one. Short segments hold few mode switches, so
    the iteration converges in a few rounds whatever the whole record holds."""
    t = data.time
    n, k = len(t), len(taus)
    out = np.empty((n, k))
    modes = np.ones((n - 1, k))
    c = np.full(k, h[0]) if isinstance(init, str) and init == "settled" else (
        np.zeros(k) if isinstance(init, str) else np.asarray(init, float))
    out[0] = c
    start = 0
    while start < n - 1:
        end = min(start + _SEGMENT, n - 1)
        seg_t, seg_h = t[start:end + 1], h[start:end + 1]
        base = factor[start:end]
        seg = varying_lag_states(seg_t, seg_h, taus[None, :] * base, hold=data.hold, initial=c)
        current = None
        for _ in range(_MODE_ITERATIONS):
            new = np.ones_like(base)
            for a in effects:
                new = new * a.effect.tau_factor(data, seg_h, seg, taus, a.own(values), a)
            if current is not None and np.array_equal(new, current):
                break
            current = new
            seg = varying_lag_states(seg_t, seg_h, taus[None, :] * base * current, hold=data.hold,
                                     initial=c)
        out[start:end + 1] = seg
        modes[start:end] = current
        c = seg[-1]
        start = end
    return out, factor * modes


def basis(data: Data, structure: Structure, values: dict, cache: dict | None = None) -> Basis:
    """Evaluate the model's linear basis for given nonlinear parameter values."""
    t = data.time
    effects = structure.effects
    x = data.load
    for a in effects:
        x = a.effect.load_transform(data, x, a.own(values), a)
    s = x
    for a in effects:
        s = a.effect.instant(data, s, a.own(values), a)
    h = s
    for a in effects:
        h = a.effect.creep_input(data, h, a.own(values), a)
    taus = taus_of(values, structure.n_terms)
    init = data.lag_initial(h, taus, values)
    lags = lag_states(t, h, taus, hold=data.hold, initial=init)
    dynamic = [a for a in effects if a.effect.changes_lags]
    factor = None
    if dynamic:
        static = [a for a in dynamic if not a.effect.state_dependent]
        factor = np.ones((len(t) - 1, len(taus)))
        for a in static:
            factor = factor * a.effect.tau_factor(data, h, lags, taus, a.own(values), a)
        states = [a for a in dynamic if a.effect.state_dependent]
        if states:
            lags, factor = _state_dependent_lags(data, h, taus, init, factor, states, values)
        else:
            lags = varying_lag_states(t, h, taus[None, :] * factor, hold=data.hold, initial=init)
    cols, names = [], []
    if not data.fixed_offset:
        cols.append(np.ones_like(t))
        names.append("offset")
    cols.append(s)
    names.append("gain")
    for k in range(len(taus)):
        cols.append(lags[:, k])
        names.append(f"a[{k}]")
    for a in effects:
        for name, col in a.effect.columns(data, s, h, lags, a.own(values), a).items():
            cols.append(col)
            names.append(f"{a.name}.{name}")
    return Basis(np.column_stack(cols), tuple(names), x, s, h, lags)


# --------------------------------------------------------------------------------------------
# Noise: autoregressive model on the sample sequence, broken at gaps
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Noise:
    """AR(p) noise: ``e[n] = sum_i phi_i e[n-i] + w[n]``, ``w`` white with deviation ``sigma``."""

    phi: tuple[float, ...] = ()
    sigma: float = float("nan")

    @property
    def order(self) -> int:
        """p."""
        return len(self.phi)

    def correlation_samples(self) -> float:
        """Rough memory of the noise in samples (``1 / (1 - sum phi)``)."""
        s = sum(self.phi)
        return float("inf") if s >= 1 else 1.0 / (1.0 - s)

    def to_dict(self, dt: float) -> dict:
        """JSON form."""
        return {"model": f"AR({self.order})", "phi": list(self.phi),
                "innovation_sigma": self.sigma,
                "memory_s": self.correlation_samples() * dt}


def rows_for(data: Data, mask: np.ndarray | None = None, order: int = MAX_AR_ORDER) -> np.ndarray:
    """Samples that have ``order`` predecessors in the same segment and inside ``mask``."""
    n = data.n
    ok = np.ones(n, bool) if mask is None else np.asarray(mask, bool).copy()
    good = ok.copy()
    for i in range(1, order + 1):
        prev = np.zeros(n, bool)
        prev[i:] = ok[:-i] & (data.segment[i:] == data.segment[:-i])
        good &= prev
    return np.flatnonzero(good)


def whiten(z: np.ndarray, rows: np.ndarray, noise: Noise) -> np.ndarray:
    """Prewhitened rows: ``z[n] - sum_i phi_i z[n-i]`` for ``n`` in ``rows``."""
    out = z[rows].copy()
    for i, phi in enumerate(noise.phi, start=1):
        out -= phi * z[rows - i]
    return out


def fit_noise(residual: np.ndarray, rows: np.ndarray, max_order: int = MAX_AR_ORDER) -> Noise:
    """AR(p) noise of a residual, p chosen by BIC (least squares on the given rows)."""
    y = residual[rows]
    n = len(rows)
    best, best_bic = Noise((), float(np.sqrt(np.mean(y ** 2)))), n * np.log(np.mean(y ** 2) + 1e-300)
    lagged = np.column_stack([residual[rows - i] for i in range(1, max_order + 1)]) if max_order else None
    for p in range(1, max_order + 1):
        phi, *_ = linalg.lstsq(lagged[:, :p], y, lapack_driver="gelsy")
        rss = float(np.sum((y - lagged[:, :p] @ phi) ** 2))
        bic = n * np.log(rss / n + 1e-300) + p * np.log(n)
        if bic < best_bic - 1e-9:
            best, best_bic = Noise(tuple(float(v) for v in phi), math.sqrt(rss / n)), bic
    return best


def ljung_box(white_residual: np.ndarray, lags: int = 20) -> tuple[float, float]:
    """Ljung-Box statistic and p-value of a (prewhitened) residual: is it white?"""
    from scipy import stats

    w = white_residual - np.mean(white_residual)
    n = len(w)
    lags = min(lags, n // 4)
    if lags < 1:
        return float("nan"), float("nan")
    acf = autocorrelation(w, lags)[1:]
    q = float(n * (n + 2) * np.sum(acf ** 2 / (n - np.arange(1, lags + 1))))
    return q, float(stats.chi2.sf(q, lags))


def autocorrelation(x: np.ndarray, lags: int) -> np.ndarray:
    """Sample autocorrelation at lags 0 ... ``lags`` (FFT)."""
    x = np.asarray(x, float) - np.mean(x)
    n = len(x)
    size = 1 << (2 * n - 1).bit_length()
    f = np.fft.rfft(x, size)
    acov = np.fft.irfft(f * np.conj(f), size)[:lags + 1]
    return acov / acov[0] if acov[0] > 0 else np.zeros(lags + 1)


# --------------------------------------------------------------------------------------------
# Fitting one structure
# --------------------------------------------------------------------------------------------

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
    noise : Noise
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
    noise: Noise
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
        self.likelihood_rows = rows_for(data, mask)                               # prewhitened
        if len(self.likelihood_rows) < 10:
            raise InputError(f"{data.source}: too few samples left to fit")
        self.y = data.signal[self.rows]
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
        b = basis(self.data, self.structure, self.values(x), self.cache)
        a = b.columns[self.rows]
        held = np.array([n in self.fixed for n in b.names])
        known = np.array([self.fixed.get(n, 0.0) for n in b.names])
        target = self.y - a[:, held] @ known[held] if held.any() else self.y
        coef = known.copy()
        prior = None
        if self.anchor:
            prior = np.array([float(self.anchor.get(n, 0.0)) for n in b.names])[~held]
        coef[~held] = _solve(a[:, ~held], target, prior)
        return b, coef, self.y - a @ coef

    def residual(self, x: np.ndarray) -> np.ndarray:
        """Residual with the linear part projected out, relative to the signal's range."""
        try:
            return self.project(x)[2] / self.scale
        except (FloatingPointError, ValueError, linalg.LinAlgError):
            return np.full(len(self.rows), 1e30)

    def cost(self, values: dict) -> float:
        """Sum of squared residuals at a start value dictionary."""
        r = self.residual(self.start_vector(values))
        return float(r @ r)

    def solve(self, start: dict, max_nfev: int | None = None) -> np.ndarray:
        """Refine the nonlinear parameters from ``start``; returns the search point.

        ``max_nfev`` caps the iterations (each also evaluates a finite-difference Jacobian)."""
        x0 = self.start_vector(start)
        if len(x0) == 0:
            return x0
        lo, hi = zip(*(p.bounds() for p in self.params))
        res = optimize.least_squares(self.residual, x0, bounds=(lo, hi), method="trf",
                                     x_scale=1.0, max_nfev=max_nfev or 40 * (len(x0) + 1),
                                     diff_step=1e-6, xtol=1e-8, ftol=1e-8, gtol=1e-8)
        return res.x


def fit_structure(data: Data, structure: Structure, starts: Sequence[dict], noise: Noise | None = None,
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
    noise : Noise, optional
        Noise model for the likelihood (default: AR(p) of this fit's own residual, p chosen
        by BIC, its parameters counted: the profile likelihood of the model with AR noise).
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
    starts = list(starts)
    if not starts:
        raise InputError("no start values")
    if len(starts) > n_refine:
        costs = [problem.cost(s) for s in starts]
        starts = [starts[i] for i in np.argsort(costs)[:n_refine]]
    best_x, best_cost = None, np.inf
    for s in starts:
        x = problem.solve(s, max_nfev) if refine else problem.start_vector(s)
        r = problem.residual(x)
        c = float(r @ r)
        if c < best_cost:
            best_x, best_cost = x, c
    return _finish(problem, best_x, noise, with_cov)


def _finish(problem: Problem, x: np.ndarray, noise: Noise | None, with_cov: bool) -> Fit:
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


def with_noise(fit: Fit, noise: Noise) -> Fit:
    """The fit with a noise model (AR coefficients; innovation variance from the prewhitened
    residual) and its Gaussian log-likelihood and BIC.

    The likelihood that ranks models is that of independent errors on all fitted samples:
    it is nested (a richer model never has a lower likelihood), and it counts slow misfit in
    full. It overstates evidence when the noise is coloured; the held-out test of
    :func:`compare`, whose spread follows the noise spectrum, guards against that.
    """
    rows = fit.extras["rows"]
    rw = whiten(fit.residual, rows, noise)
    noise = replace(noise, sigma=math.sqrt(max(float(rw @ rw) / len(rows), 1e-300)))
    fitted = fit.extras["fitted"]
    n = len(fitted)
    sigma2 = max(float(np.mean(fit.residual[fitted] ** 2)), 1e-300)
    loglik = -0.5 * n * (math.log(2 * math.pi * sigma2) + 1.0)
    k = fit.extras["nonlinear"] + fit.extras["linear"] + 1
    return replace(fit, noise=noise, loglik=loglik, bic=-2.0 * loglik + k * math.log(n), n_params=k)


def _inverse_ar_transpose(z: np.ndarray, noise: Noise) -> np.ndarray:
    """``W^-T z`` for the AR prewhitening filter ``W`` (the inverse filter run backwards)."""
    from scipy import signal as sps

    if noise.order == 0:
        return z
    den = np.concatenate([[1.0], -np.array(noise.phi)])
    return sps.lfilter([1.0], den, z[::-1], axis=0)[::-1]


def _covariance(problem: Problem, x, coef, noise: Noise) -> np.ndarray | None:
    """Covariance of the least-squares estimates under AR noise (sandwich):
    ``(J^T J)^-1 J^T Sigma J (J^T J)^-1`` with ``Sigma = sigma^2 W^-1 W^-T``."""
    data, rows = problem.data, problem.rows
    b = basis(data, problem.structure, problem.values(x))
    cols = []
    for j in range(len(x)):
        h = 1e-6 * max(1.0, abs(x[j]))
        xp, xm = x.copy(), x.copy()
        xp[j] += h
        xm[j] -= h
        bp = basis(data, problem.structure, problem.values(xp)).columns @ coef
        bm = basis(data, problem.structure, problem.values(xm)).columns @ coef
        cols.append((bp - bm) / (2 * h))
    full = np.column_stack(cols + [b.columns]) if cols else b.columns
    held = [len(x) + i for i, n in enumerate(b.names) if n in problem.fixed]
    full[:, held] = 0.0
    jac = full[rows]
    norms = np.sqrt(np.sum(jac ** 2, axis=0))
    norms[norms == 0] = 1.0
    jn = jac / norms
    try:
        bread = linalg.pinvh(jn.T @ jn)
    except (linalg.LinAlgError, ValueError):
        return None
    z = np.zeros_like(full)
    z[rows] = full[rows] / norms
    zt = _inverse_ar_transpose(z, noise)
    meat = noise.sigma ** 2 * (zt.T @ zt)
    return (bread @ meat @ bread) / np.outer(norms, norms)


# --------------------------------------------------------------------------------------------
# Held-out prediction and the comparison of two models
# --------------------------------------------------------------------------------------------

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


def block_index(data: Data, blocks: int = BLOCKS) -> np.ndarray:
    """Contiguous blocks of equal numbers of samples (fewer blocks when the record is short);
    equal counts rather than equal durations keep log-spaced material tests balanced."""
    blocks = max(FOLDS, min(blocks, data.n // MIN_BLOCK_SAMPLES))
    return np.minimum(np.arange(data.n) * blocks // data.n, blocks - 1)


#: A nonlinear parameter whose variance would grow more than this factor without the held-out
#: data is kept at the full fit's value in that fold (the rest of the record does not
#: determine it: e.g. a recovery time when all unloading is held out).
UNDETERMINED_VARIANCE_RATIO = 10.0


def sensitivity(data: Data, fit: Fit) -> np.ndarray:
    """Derivatives of the fitted signal by every nonlinear parameter (search coordinates, by
    central differences) and by the linear coefficients (the basis), all samples."""
    values = fit.values
    b = basis(data, fit.structure, values)
    coef = np.array([values[n] for n in b.names])
    cols = []
    for p in fit.params:
        x = p.to_search(values[p.name])
        h = 1e-6 * max(1.0, abs(x))
        plus = dict(values, **{p.name: p.from_search(x + h)})
        minus = dict(values, **{p.name: p.from_search(x - h)})
        cols.append((basis(data, fit.structure, plus).columns @ coef
                     - basis(data, fit.structure, minus).columns @ coef) / (2 * h))
    return np.column_stack(cols + [b.columns])


def _undetermined(jac: np.ndarray, keep: np.ndarray, names: list, values: dict) -> dict | None:
    """The nonlinear parameters (first columns of ``jac``) that the kept samples leave
    undetermined, with their values."""
    def variances(rows):
        j = jac[rows]
        norms = np.sqrt(np.sum(j ** 2, axis=0))
        norms[norms == 0] = 1.0
        inv = linalg.pinvh((j / norms).T @ (j / norms))
        return np.diag(inv)[:len(names)] / norms[:len(names)] ** 2
    full = variances(slice(None))
    part = variances(keep)
    out = {n: values[n] for n, vf, vp in zip(names, full, part)
           if not vp <= UNDETERMINED_VARIANCE_RATIO * vf}
    return out or None


def halves(data: Data, fit: Fit, refine: bool = True) -> HeldOut:
    """Held-out prediction across the record's two halves: fitted on one half, simulated over
    the other. Slow noise (drift) that interleaved blocks would let a slow extension
    interpolate is not predictable across halves; structure driven by the load is."""
    return heldout(data, fit, folds=2, refine=refine,
                   blocks=np.minimum(np.arange(data.n) * 2 // data.n, 1)).heldout


def heldout(data: Data, fit: Fit, folds: int = FOLDS, refine: bool = True,
            blocks: np.ndarray | None = None) -> Fit:
    """The fit with its held-out prediction: the record is cut into :data:`BLOCKS` blocks;
    for each of ``folds`` folds its (interleaved) blocks are left out, the model is refitted on the rest
    (from the fit's own values, same noise model) and simulated from the load over them.

    Directions the remaining data leave undetermined keep the full fit's values: linear ones
    weakly (gain against offset when the rest has one load level, :data:`ANCHOR_WEIGHT`),
    nonlinear ones whose variance the rest of the record would multiply by more than
    :data:`UNDETERMINED_VARIANCE_RATIO` (the initial creep state once the start is held out,
    a recovery time when the rest has no unloading). A held-out error then measures what the
    model predicts, not an extrapolation of what nothing constrained.
    """
    blocks = block_index(data) if blocks is None else blocks
    fold = blocks % folds
    resid = np.empty(data.n)
    start = {p.name: fit.values[p.name] for p in fit.params}
    fixed = None
    anchor = {n: v for n, v in fit.values.items() if n not in start}
    jac = sensitivity(data, fit) if refine and start else None
    for b in range(folds):
        inside = fold == b
        if not inside.any():
            continue
        frozen = _undetermined(jac, ~inside, list(start), start) if jac is not None else None
        try:  # (refit from the fit's own values, same noise model)
            f = fit_structure(data, fit.structure, [start], noise=fit.noise, mask=~inside,
                              max_nfev=3, with_cov=False, fixed=fixed, anchor=anchor,
                              refine=refine, frozen=frozen)
            resid[inside] = f.residual[inside]
        except InputError:
            resid[inside] = fit.residual[inside]
    return replace(fit, heldout=HeldOut(resid, blocks))


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


def compare(data: Data, simple: Fit, rich: Fit) -> Evidence:
    """Evidence for ``rich`` over ``simple`` (both with held-out predictions).

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


def spectral_variance(weights: np.ndarray, noise_sample: np.ndarray) -> float:
    """Variance of ``sum_n weights[n] e[n]`` for stationary noise ``e`` whose spectrum is
    estimated from ``noise_sample`` (periodogram smoothed over about +-15 % in frequency,
    at least +-4 frequency bins, and not below its +-1-bin local mean); samples are taken as
    equally spaced."""
    n = len(weights)
    m = 1 << (2 * n - 1).bit_length()          # zero padding: no circular wrap-around
    e = noise_sample - np.mean(noise_sample)
    power = np.abs(np.fft.rfft(e, m)) ** 2 / n
    per_bin = max(1, m // n)                   # padded bins per independent frequency
    # smoothed for a steady estimate, but never below the local level: at the lowest
    # frequencies slow noise (drift, 1/f^2) would otherwise be averaged away
    spectrum = np.maximum(_smooth_log(power, min_half=4 * per_bin),
                          _smooth_log(power, min_half=per_bin, fraction=0.0))
    gain = np.abs(np.fft.rfft(weights, m)) ** 2
    w = np.full(len(power), 2.0)
    w[0] = 1.0
    w[-1] = 1.0
    return float(np.sum(w * gain * spectrum) / m)


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


def _smooth_log(x: np.ndarray, min_half: int, fraction: float = 0.15) -> np.ndarray:
    k = np.arange(len(x))
    half = np.maximum(min_half, (fraction * k).astype(int))
    lo = np.clip(k - half, 0, len(x) - 1)
    hi = np.clip(k + half, 0, len(x) - 1)
    c = np.concatenate([[0.0], np.cumsum(x)])
    return (c[hi + 1] - c[lo]) / (hi - lo + 1)


# --------------------------------------------------------------------------------------------
# Starting values: log grid of time constants, non-negative least squares
# --------------------------------------------------------------------------------------------

def tau_grid(data: Data, per_decade: float = 4.0, low: float | None = None,
             high: float | None = None) -> np.ndarray:
    """Log-spaced retardation times the record can resolve."""
    lo, hi = data.tau_limits()
    lo, hi = low or lo, high or hi
    n = max(2, int(round(per_decade * math.log10(hi / lo))) + 1)
    return np.geomspace(lo, hi, n)


def _decimate(data: Data, target: int = 4000) -> np.ndarray:
    step = max(1, data.n // target)
    return np.arange(0, data.n, step)


def nnls_spectrum(data: Data, taus: np.ndarray) -> tuple[np.ndarray, float]:
    """Creep spectrum on a grid: amplitudes ``gain * beta`` of lags at ``taus`` by non-negative
    least squares, tried with all amplitudes positive and with all negative.

    Returns
    -------
    amplitudes : numpy.ndarray
        One per grid time (mostly zero).
    rss : float
    """
    idx = _decimate(data)
    b = basis(data, Structure(len(taus)), {f"tau[{k}]": t for k, t in enumerate(taus)})
    cols = b.columns[idx]
    y = data.signal[idx]
    names = b.names
    lag_cols = [i for i, n in enumerate(names) if n.startswith("a[")]
    free_cols = [i for i, n in enumerate(names) if not n.startswith("a[")]
    scale = np.sqrt(np.sum(cols ** 2, axis=0))
    scale[scale == 0] = 1.0
    cols = cols / scale
    best = (np.zeros(len(taus)), np.inf)
    for sign in (1.0, -1.0):
        mat = np.column_stack([cols[:, free_cols], -cols[:, free_cols], sign * cols[:, lag_cols]])
        try:
            sol, rnorm = optimize.nnls(mat, y, maxiter=50 * mat.shape[1])
        except RuntimeError:
            continue
        amps = sign * sol[2 * len(free_cols):] / scale[lag_cols]
        if rnorm ** 2 < best[1]:
            best = (amps, rnorm ** 2)
    return best


def cluster_taus(taus: np.ndarray, weights: np.ndarray, k: int) -> list[float]:
    """``k`` representative time constants of a spectrum (weighted 1-D k-means on log tau)."""
    w = np.abs(weights)
    logt = np.log(taus)
    if np.count_nonzero(w) == 0:
        return list(np.exp(np.linspace(logt[0], logt[-1], k + 2)[1:-1]))
    nz = np.flatnonzero(w)
    if len(nz) <= k:
        centres = list(logt[nz])
        spare = [x for x in np.linspace(logt[0], logt[-1], k + 2)[1:-1]]
        while len(centres) < k:
            far = max(spare, key=lambda s: min(abs(s - c) for c in centres))
            centres.append(far)
            spare.remove(far)
        return sorted(float(np.exp(c)) for c in centres)
    x, wx = logt[nz], w[nz]
    centres = np.quantile(x, (np.arange(k) + 0.5) / k)
    for _ in range(50):
        assign = np.argmin(np.abs(x[:, None] - centres[None, :]), axis=1)
        new = np.array([np.sum(wx[assign == j] * x[assign == j]) / np.sum(wx[assign == j])
                        if np.any(assign == j) else centres[j] for j in range(k)])
        if np.allclose(new, centres):
            break
        centres = new
    return sorted(float(np.exp(c)) for c in centres)


def one_term_starts(data: Data) -> list[dict]:
    """Start values for the one-term (Voigt) model: a log grid of time constants."""
    return [{"tau[0]": t} for t in tau_grid(data, per_decade=3)]


def extra_term_starts(data: Data, fit: Fit, structure: Structure, per_decade: float = 3) -> list[dict]:
    """Start values for a model with one more term than ``fit``: its values plus a grid time."""
    k = fit.structure.n_terms
    base = {name: v for name, v in fit.values.items() if name in {p.name for p in fit.params}}
    out = []
    for tau in tau_grid(data, per_decade):
        if np.min(np.abs(np.log(fit.taus / tau))) < 0.1:
            continue
        s = dict(base)
        s[f"tau[{k}]"] = float(tau)
        out.append(s)
    return out


# --------------------------------------------------------------------------------------------
# Prony identification with the number of terms chosen by evidence
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class OrderStep:
    """One candidate number of terms."""

    n_terms: int
    fit: Fit
    evidence: Evidence | None      # against the previous number of terms


@dataclass(frozen=True)
class PronyResult:
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


def fit_terms(data: Data, n_terms: int, previous: Fit | None = None, noise: Noise | None = None,
              effects: tuple[Applied, ...] = ()) -> Fit:
    """Fit ``n_terms`` Prony terms (plus ``effects`` applied to every model, e.g. viscous flow):
    starts from the non-negative spectrum and, when given, from the previous fit plus one grid
    time; refine; keep the best."""
    structure = Structure(n_terms, tuple(effects))
    if n_terms == 1:
        starts = one_term_starts(data)
    else:
        grid = tau_grid(data, per_decade=6)
        amps, _ = nnls_spectrum(data, grid)
        starts = [{f"tau[{k}]": t for k, t in enumerate(cluster_taus(grid, amps, n_terms))}]
        if previous is not None:
            starts += extra_term_starts(data, previous, structure)
    return fit_structure(data, structure, starts, noise=noise, n_refine=3)


def fit_prony(data: Data, max_terms: int = 6, n_terms: int | None = None,
              folds: int = FOLDS, effects: tuple[Applied, ...] = ()) -> PronyResult:
    """Identify gain, offset and Prony terms, adding terms while the evidence supports them.

    A term is added when it lowers BIC by at least :data:`BIC_STRONG` *and* predicts held-out
    data better by at least :data:`HELDOUT_Z` standard deviations; the search stops at the
    first term that is not supported (or at ``max_terms``). ``n_terms`` fixes the number.
    Each model's likelihood has its own AR noise (its parameters counted by BIC).
    ``effects`` are applied to every model (e.g. ``(Applied(effects.get("viscous_flow")),)``
    for the Burgers model).
    """
    steps: list[OrderStep] = []
    chosen = 0
    previous = None
    top = n_terms or max_terms
    for k in range(1, top + 1):
        try:
            fit = heldout(data, fit_terms(data, k, previous, None, effects), folds)
        except (InputError, linalg.LinAlgError):
            break
        ev = compare(data, previous, fit) if previous is not None else None
        steps.append(OrderStep(k, fit, ev))
        if n_terms is not None:
            chosen = len(steps) - 1
        elif ev is None or ev.supported:
            chosen = len(steps) - 1
        else:
            break
        previous = fit
    if not steps:
        raise InputError(f"{data.source}: no creep model could be fitted")
    return PronyResult(data, tuple(steps), chosen)


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
                          "relaxed": "relaxed (assumed)", "settled": "settled at the first load (assumed)",
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
                            "note": "one standard deviation: Jacobian of the prewhitened residual, "
                                    "Gaussian AR noise, locally linear model"}
    model["fit"] = fit_summary(data, fit)
    if steps:
        model["fit"]["orders"] = [{
            "n_terms": s.n_terms, "bic": s.fit.bic, "residual_rms": s.fit.residual_rms,
            "heldout_residual_rms": s.fit.heldout.rms if s.fit.heldout else None,
            **({"evidence": s.evidence.to_dict()} if s.evidence else {}),
            "chosen": i == chosen} for i, s in enumerate(steps)]
    return model
