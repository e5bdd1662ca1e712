"""Tolerance analysis of a design: Monte Carlo, worst case over the tolerance box, sensitivity.

Every factor that moves the residual creep is a :class:`Factor`: each part's value, the
source and load resistance, the sensor's own creep parameters, and the capacitor's dielectric
(absorption fraction and time constant; leakage follows from the dielectric's insulation
resistance at the chosen temperature). Tolerances are relative; a normal distribution's
tolerance is its 3-sigma value.

The engine evaluates all samples at once from the exact transfer functions: the networks'
sum-of-lags forms come from the one state-space model (:func:`network.state_matrices`,
batched symmetric eigensolver), the cascade with the sensor's creep is again a sum of lags
(:func:`lti.cascade_lags`), and its step response and sweep hysteresis are closed forms
(:func:`lti.triangle_lag_gap`). No Python loop per sample.
"""

from __future__ import annotations

import math
import multiprocessing
import os
import time as _time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field, replace
from typing import Callable, Mapping

import numpy as np
from scipy import optimize

from creepcomp.errors import CreepcompError, InputError
from creepcomp.io.jsonfiles import Design
from creepcomp.lti import cascade_lags, triangle_lag_gap
from creepcomp.network import Branch, Cell, Network, modal_form, state_matrices
from creepcomp.analog.quality import default_sweep_period


@dataclass(frozen=True)
class Dielectric:
    """A capacitor technology: the tolerances it is sold in, its dielectric absorption and
    its insulation resistance (as the time constant R_ins * C) at 25 and 85 degrees C.

    Figures: published film and ceramic capacitor data (WIMA), as tabulated in the project's
    ``physics.md``.
    """

    name: str
    tolerances: tuple[float, ...]
    absorption: tuple[float, float]
    insulation_rc: tuple[float, float]          # seconds at 25 C and at 85 C

    def insulation_time(self, temperature: float) -> float:
        """R_ins * C at ``temperature`` (log-linear between 25 and 85 C, extrapolated beyond)."""
        (t25, t85) = self.insulation_rc
        slope = math.log(t85 / t25) / 60.0
        return t25 * math.exp(slope * (temperature - 25.0))


DIELECTRICS: dict[str, Dielectric] = {
    "polypropylene": Dielectric("polypropylene", (0.01, 0.025, 0.05, 0.10), (0.0005, 0.001), (1e5, 1e4)),
    "polyester": Dielectric("polyester", (0.05, 0.10, 0.20), (0.002, 0.0025), (1e4, 1e3)),
    "x7r": Dielectric("X7R ceramic", (0.10, 0.20), (0.006, 0.025), (1e3, 5e2)),
}

#: Time constants of the dielectric-absorption branch (s), drawn log-uniformly. An
#: assumption: absorption has a spread of time constants; the standard soak-and-recover test
#: (minutes) probes seconds to a quarter of an hour.
ABSORPTION_TAU_RANGE = (1.0, 1000.0)

#: The spot-check's step response spans this many of the slowest time constants, and is
#: compared from this many of the fastest on (ngspice's step is a short ramp).
SPOT_CHECK_SPAN = 12.0
SPOT_CHECK_SETTLE = 1e-3

#: Standard tolerances that "a tighter part" steps to.
RESISTOR_TOLERANCES = (0.05, 0.01, 0.001)


@dataclass(frozen=True)
class Tolerance:
    """A relative tolerance: ``rel`` is 3 sigma of a normal distribution, or the half-width
    of a uniform one."""

    rel: float
    distribution: str = "normal"

    def __post_init__(self):
        if not (math.isfinite(self.rel) and self.rel >= 0):
            raise InputError(f"tolerance {self.rel!r}: must be zero or positive")
        if self.rel >= 1 and self.distribution == "uniform":
            raise InputError(f"tolerance {self.rel:.3g}: a part cannot vary by 100 % or more")
        if self.distribution not in ("normal", "uniform"):
            raise InputError(f"distribution '{self.distribution}': use normal or uniform")


@dataclass(frozen=True)
class Factor:
    """One quantity that varies: its nominal value, its range (the tolerance box) and how it
    is drawn (``normal``: relative, tolerance at 3 sigma, clipped to the box; ``uniform``;
    ``log-uniform``)."""

    name: str
    nominal: float
    low: float
    high: float
    distribution: str = "normal"
    tolerance: float = 0.0

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """Draw ``n`` values."""
        if self.low == self.high:
            return np.full(n, self.nominal)
        if self.distribution == "normal":
            dev = rng.normal(0.0, self.tolerance / 3.0, n)
            return np.clip(self.nominal * (1.0 + dev), self.low, self.high)
        if self.distribution == "uniform":
            return rng.uniform(self.low, self.high, n)
        return np.exp(rng.uniform(math.log(self.low), math.log(self.high), n))


@dataclass(frozen=True)
class ToleranceSpec:
    """What varies and by how much.

    Parameters
    ----------
    resistor, capacitor : Tolerance
        Default tolerance of every resistor and capacitor.
    parts : mapping
        Per-part tolerances by label (``R1``, ``C1``, ``R2`` ...), overriding the defaults.
    dielectric : str or None
        A key of :data:`DIELECTRICS`: adds absorption and leakage to every cell capacitor.
    temperature : float
        Temperature for the leakage (degrees C).
    source_resistance, load_resistance : (float, float) or None
        Ranges (ohm), uniform and log-uniform; None keeps the design's value.
    beta, tau : Tolerance or None
        Spread of the sensor's own creep amplitude and retardation time, per term.
    """

    resistor: Tolerance = Tolerance(0.01)
    capacitor: Tolerance = Tolerance(0.05)
    parts: Mapping[str, Tolerance] = field(default_factory=dict)
    dielectric: str | None = None
    temperature: float = 25.0
    source_resistance: tuple[float, float] | None = None
    load_resistance: tuple[float, float] | None = None
    beta: Tolerance | None = None
    tau: Tolerance | None = None

    def __post_init__(self):
        if self.dielectric is not None and self.dielectric not in DIELECTRICS:
            raise InputError(f"dielectric '{self.dielectric}': choose one of {', '.join(DIELECTRICS)}")
        for name, rng in (("source resistance", self.source_resistance),
                          ("load resistance", self.load_resistance)):
            if rng is not None and not (0 <= rng[0] <= rng[1] and math.isfinite(rng[1])):
                raise InputError(f"{name} range {rng}: expected 0 <= LOW <= HIGH")
        if self.load_resistance is not None and self.load_resistance[0] <= 0:
            raise InputError("load resistance range must be positive")

    def tolerance_of(self, label: str, kind: str) -> Tolerance:
        """The tolerance of one part."""
        if label in self.parts:
            return self.parts[label]
        return self.resistor if kind == "R" else self.capacitor


def factors(design: Design, spec: ToleranceSpec) -> list[Factor]:
    """The tolerance box of a design: every factor with its nominal value and range."""
    out = []
    known = {label for label, _, _ in design.network.parts()}
    unknown = set(spec.parts) - known
    if unknown:
        raise InputError(f"no part named {', '.join(sorted(unknown))} in the design "
                         f"(parts: {', '.join(sorted(known))})")
    for label, kind, value in design.network.parts():
        tol = spec.tolerance_of(label, kind)
        out.append(_relative_factor(label, value, tol))
    if spec.source_resistance is not None:
        lo, hi = spec.source_resistance
        out.append(Factor("source_resistance", design.network.source_resistance, lo, hi, "uniform"))
    if spec.load_resistance is not None:
        lo, hi = spec.load_resistance
        out.append(Factor("load_resistance", math.sqrt(lo * hi), lo, hi, "log-uniform"))
    for k, (b, t) in enumerate(zip(design.model.beta, design.model.tau)):
        if spec.beta is not None:
            out.append(_relative_factor(f"beta[{k}]", b, spec.beta))
        if spec.tau is not None:
            out.append(_relative_factor(f"tau[{k}]", t, spec.tau))
    if spec.dielectric is not None:
        d = DIELECTRICS[spec.dielectric]
        for label, kind, value in design.network.parts():
            if kind == "C" and label.startswith("C1"):
                lo, hi = d.absorption
                out.append(Factor(f"{label}.absorption", 0.5 * (lo + hi), lo, hi, "uniform"))
                lo, hi = ABSORPTION_TAU_RANGE
                out.append(Factor(f"{label}.absorption_tau", math.sqrt(lo * hi), lo, hi, "log-uniform"))
    return out


def _relative_factor(name: str, nominal: float, tol: Tolerance) -> Factor:
    lo, hi = sorted((nominal * (1 - tol.rel), nominal * (1 + tol.rel)))
    if tol.distribution == "normal":
        return Factor(name, nominal, lo, hi, "normal", tol.rel)
    return Factor(name, nominal, lo, hi, "uniform", tol.rel)


def draw(box: list[Factor], n: int, seed: int) -> dict[str, np.ndarray]:
    """Draw ``n`` samples of every factor (one generator, factors in order: reproducible)."""
    rng = np.random.default_rng(seed)
    return {f.name: f.sample(rng, n) for f in box}


@dataclass(frozen=True)
class Metrics:
    """Per-sample figures: peak and final residual creep of a load step, sweep hysteresis."""

    peak: np.ndarray
    final: np.ndarray
    hysteresis: np.ndarray

    def get(self, name: str) -> np.ndarray:
        """A metric by name: ``peak``, ``final`` (absolute value) or ``hysteresis``."""
        if name == "final":
            return np.abs(self.final)
        return getattr(self, name)


#: Times of the step-response grid, as multiples of each sample's slowest time constant.
STEP_GRID = np.geomspace(1e-3, 30.0, 28)
#: Positions along the first half of the rising sweep branch (the gap is symmetric).
SWEEP_GRID = np.linspace(0.0, 0.5, 17)


def evaluate(design: Design, values: Mapping[str, np.ndarray], sweep_period: float,
             dielectric: str | None = None, temperature: float = 25.0,
             n: int | None = None) -> Metrics:
    """Metrics of many variants of a design at once.

    Parameters
    ----------
    design : Design
        Nominal design.
    values : mapping
        Factor name -> values (all the same length); factors not given stay nominal.
    sweep_period : float
        Period of the hysteresis sweep (s).
    dielectric : str or None
        Dielectric preset for leakage (absorption comes through ``values``).
    temperature : float
        For the leakage (degrees C).
    n : int, optional
        Number of variants when ``values`` is empty (default 1).

    Returns
    -------
    Metrics
    """
    n = len(next(iter(values.values()))) if values else (n or 1)
    rel, q = _cascade(design, values, dielectric, temperature, n)
    final = rel.sum(axis=1)
    peak = np.maximum(_step_peak(rel, q), np.abs(final))
    hysteresis = _sweep_peak(rel, q, sweep_period)
    return Metrics(peak, final, hysteresis)


def _cascade(design: Design, values: Mapping[str, np.ndarray], dielectric: str | None,
             temperature: float, n: int):
    """Residual-creep form of the corrected sensor of every variant: ``H G / (H G)(inf) - 1
    = sum_m rel_m (1 - 1/(1 + s q_m))``, as arrays ``rel`` and ``q`` of shape (n, M)."""
    arrays, beta, tau = variant_arrays(design, values, dielectric, temperature, n)
    d, r, p = modal_form(*state_matrices(*arrays))
    D, R, q = cascade_lags(np.ones(n), beta, tau, d, r, p)
    return R / D[:, None], q


def variant_arrays(design: Design, values: Mapping[str, np.ndarray], dielectric: str | None,
                   temperature: float, n: int):
    """Network arrays (for :func:`network.state_matrices`) and creep terms of variants."""
    net, model = design.network, design.model
    parts = net.parts()
    matrix = np.column_stack([values.get(label, np.full(n, v)) for label, _, v in parts])
    arrays = list(net.batch_arrays(matrix))
    if "source_resistance" in values:
        arrays[5] = values["source_resistance"]
    if "load_resistance" in values:
        arrays[6] = values["load_resistance"]
    if dielectric is not None:
        arrays[7:10] = _imperfections(net, parts, matrix, values, DIELECTRICS[dielectric], temperature)
    beta = np.column_stack([values.get(f"beta[{k}]", np.full(n, b)) for k, b in enumerate(model.beta)])
    tau = np.column_stack([values.get(f"tau[{k}]", np.full(n, t)) for k, t in enumerate(model.tau)])
    return arrays, beta, tau


def variant(design: Design, values: Mapping[str, np.ndarray], i: int, dielectric: str | None = None,
            temperature: float = 25.0) -> Design:
    """Sample ``i`` of drawn values as a design of its own (network and creep model)."""
    one = {k: v[i:i + 1] for k, v in values.items()}
    arrays, beta, tau = variant_arrays(design, one, dielectric, temperature, 1)
    cells_R, cells_C, R2, shunt_R, shunt_C, rs, rl, leak, r_da, c_da = (
        a[0] if np.ndim(a) else a for a in arrays)
    cells = tuple(Cell(float(r), float(c), None if not np.isfinite(lk) else float(lk),
                       None if cd <= 0 else float(rd), None if cd <= 0 else float(cd))
                  for r, c, lk, rd, cd in zip(cells_R, cells_C, leak, r_da, c_da))
    shunt = tuple(Branch(float(r), float(c)) for r, c in zip(shunt_R, shunt_C))
    network = Network(cells, None if not np.isfinite(R2) else float(R2), shunt, float(rs),
                      None if rl is None or not np.isfinite(rl) else float(rl))
    return Design(design.model.with_terms(beta[0], tau[0]), network)


def spot_check(result: "MonteCarloResult", n: int = 200, points: int = 400) -> dict:
    """Run the first ``n`` samples of a Monte Carlo through ngspice (a load step) and compare
    their residual creep with the engine's at the same times.

    Returns
    -------
    dict
        ``n``, ``agreement_max_abs`` (largest difference, fraction of the step), ``seconds``
        and ``seconds_per_transient``; or ``error`` when ngspice cannot run.
    """
    from creepcomp.verify import spice

    n = min(n, result.n)
    design, spec = result.design, result.spec
    program = spice.synthetic_program(design.model, "step")
    start = _time.perf_counter()
    worst, transient = 0.0, 0.0
    try:
        engine = spice.ngspice()
        for i in range(n):
            sample = variant(design, result.values, i, spec.dielectric, spec.temperature)
            duration = SPOT_CHECK_SPAN * spice.slowest_time_constant(sample.model, sample.network)
            times = spice.transient_times(program, duration, points)
            t0 = _time.perf_counter()
            wave = spice.run_transient(sample.network, sample.model, program, times, engine=engine)
            transient += _time.perf_counter() - t0
            late = times > SPOT_CHECK_SETTLE * spice.fastest_time_constant(sample.model, sample.network)
            ideal = sample.network.lag_expansion().hf_gain * spice.DEFAULT_SIGNAL
            e_spice = wave.output[late] / ideal - 1.0
            rel, q = _cascade(design, {k: v[i:i + 1] for k, v in result.values.items()},
                              spec.dielectric, spec.temperature, 1)
            e_engine = _step_residual(rel, q, times[late][None, :])[0]
            worst = max(worst, float(np.max(np.abs(e_spice - e_engine))))
    except CreepcompError as exc:
        return {"n": 0, "error": str(exc)}
    return {"n": n, "agreement_max_abs": worst, "seconds": _time.perf_counter() - start,
            "seconds_per_transient": transient / n if n else None}


def _step_residual(rel, q, t):
    """Residual creep ``sum_m rel_m (1 - exp(-t / q_m))`` at per-sample times ``t`` (B, T).

    Written as ``sum rel - sum rel exp(-t/q)``: the cancellation at small t costs only
    ~1e-16 of the (small) residual itself.
    """
    rate = 1.0 / q
    decay = np.exp(-(rate[:, :, None] * t[:, None, :]))
    return rel.sum(axis=1)[:, None] - np.einsum("bm,bmt->bt", rel, decay)


def _step_peak(rel, q):
    """Peak |residual creep| after a step.

    Two lags (one creep term, one network pole): the single extremum in closed form.
    More: a log grid, then two rounds of parabolic refinement.
    """
    if q.shape[1] == 2:
        return _step_peak_two_lags(rel, q)
    slowest = q.max(axis=1)
    log_t = np.log(slowest)[:, None] + np.log(STEP_GRID)[None, :]
    v = np.abs(_step_residual(rel, q, np.exp(log_t)))
    best, at = _grid_peak(v, log_t)
    step = np.log(STEP_GRID[1] / STEP_GRID[0])
    for width in (step / 4, step / 32):
        pts = at[:, None] + width * np.array([-1.0, 0.0, 1.0])[None, :]
        vals = np.abs(_step_residual(rel, q, np.exp(pts)))
        vertex = _vertex(pts, vals)
        at = np.where(np.isfinite(vertex), vertex, at)
        best = np.maximum(best, np.abs(_step_residual(rel, q, np.exp(at)[:, None]))[:, 0])
        best = np.maximum(best, vals.max(axis=1))
    return best


def _step_peak_two_lags(rel, q):
    """``e(t) = sum_m rel_m (1 - exp(-t/q_m))`` for two lags has one extremum, where
    ``rel_1/q_1 exp(-t/q_1) = -rel_2/q_2 exp(-t/q_2)``."""
    slope1, slope2 = rel[:, 0] / q[:, 0], rel[:, 1] / q[:, 1]
    rate_gap = 1.0 / q[:, 0] - 1.0 / q[:, 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = -slope2 / slope1
        t_star = -np.log(ratio) / rate_gap
    ok = (ratio > 0) & np.isfinite(t_star) & (t_star > 0)
    t_star = np.where(ok, t_star, 0.0)
    inner = np.abs(_step_residual(rel, q, t_star[:, None])[:, 0])
    return np.where(ok, inner, 0.0)


def _sweep_peak(rel, q, period):
    """Largest |up - down| gap of the sweep (fraction of the ideal output).

    The gap is symmetric about the middle of the branch, so half of it is evaluated, on a
    uniform grid where ``exp(-t/q)`` are powers of one exponential (products, no overflow),
    then refined by a parabola.
    """
    h = period / 2.0
    x = SWEEP_GRID
    qq = q[:, :, None]
    powers = np.cumprod(np.broadcast_to(np.exp(-(x[1] - x[0]) * h / qq), q.shape + (len(x) - 1,)), axis=2)
    early = np.concatenate([np.ones(q.shape + (1,)), powers], axis=2)       # exp(-t_j/q)
    late = early[:, :, -1:] * early[:, :, ::-1]                              # exp(-(h-t_j)/q)
    gap = np.abs(np.einsum("bm,bmx->bx", rel, triangle_lag_gap(qq, h, x, (early, late))))
    best, at = _grid_peak(gap, np.broadcast_to(x, gap.shape))
    pts = np.clip(at[:, None] + (x[1] - x[0]) / 4 * np.array([-1.0, 0.0, 1.0])[None, :], 0.0, 0.5)
    vals = np.abs(np.einsum("bm,bmx->bx", rel, triangle_lag_gap(qq, h, pts[:, None, :])))
    return np.maximum(best, vals.max(axis=1))


def _grid_peak(v, coords):
    """Row maxima of ``v`` and the parabolic estimate of where they are."""
    k = np.argmax(v, axis=1)
    rows = np.arange(len(v))
    lo, hi = np.clip(k - 1, 0, v.shape[1] - 1), np.clip(k + 1, 0, v.shape[1] - 1)
    pts = np.stack([coords[rows, lo], coords[rows, k], coords[rows, hi]], axis=1)
    vals = np.stack([v[rows, lo], v[rows, k], v[rows, hi]], axis=1)
    vertex = _vertex(pts, vals)
    return v[rows, k], np.where(np.isfinite(vertex), vertex, coords[rows, k])


def _vertex(pts, vals):
    """Abscissa of the parabola through three equally spaced points (nan where it is not a
    maximum inside them)."""
    a, b, c = vals[:, 0], vals[:, 1], vals[:, 2]
    h = pts[:, 1] - pts[:, 0]
    curv = a - 2 * b + c
    with np.errstate(divide="ignore", invalid="ignore"):
        x = pts[:, 1] + h * (a - c) / (2 * curv)
    ok = (curv < 0) & (x >= pts[:, 0]) & (x <= pts[:, 2]) & (h > 0)
    return np.where(ok, x, np.nan)


def _imperfections(net: Network, parts, matrix, values, dielectric: Dielectric, temperature: float):
    """Leakage and absorption arrays of the cell capacitors for sampled values."""
    n = len(matrix)
    col = {label: j for j, (label, _, _) in enumerate(parts)}
    insulation = dielectric.insulation_time(temperature)
    leak, r_da, c_da = (np.repeat(a, n, axis=0) for a in net.imperfection_arrays())
    many = len(net.cells) > 1
    for k, cell in enumerate(net.cells):
        if cell.C <= 0:
            continue
        label = f"C1.{k + 1}" if many else "C1"
        c = matrix[:, col[label]]
        leak[:, k] = insulation / c
        frac = values.get(f"{label}.absorption", np.full(n, np.mean(dielectric.absorption)))
        tau_da = values.get(f"{label}.absorption_tau", np.full(n, math.sqrt(np.prod(ABSORPTION_TAU_RANGE))))
        c_da[:, k] = frac * c
        r_da[:, k] = tau_da / c_da[:, k]
    return leak, r_da, c_da


# --- the analyses ---------------------------------------------------------------------

@dataclass(frozen=True)
class MonteCarloResult:
    """Samples and metrics of a Monte Carlo run."""

    design: Design
    spec: ToleranceSpec
    box: list
    values: dict
    metrics: Metrics
    seed: int
    seconds: float
    sweep_period: float

    @property
    def n(self) -> int:
        """Number of samples."""
        return len(self.metrics.peak)

    def percentiles(self, metric: str = "peak") -> dict:
        """``p50``, ``p95``, ``p99`` and ``max`` of a metric (fractions)."""
        v = self.metrics.get(metric)
        p50, p95, p99 = np.percentile(v, [50, 95, 99])
        return {"p50": float(p50), "p95": float(p95), "p99": float(p99), "max": float(v.max())}

    def yield_against(self, limit: float, metric: str = "peak") -> tuple[float, float]:
        """Fraction of samples with the metric at or below ``limit``, and its standard error."""
        ok = float(np.mean(self.metrics.get(metric) <= limit))
        return ok, math.sqrt(max(ok * (1 - ok), 1.0 / self.n) / self.n)


def run(design: Design, spec: ToleranceSpec, n: int, seed: int = 0,
        sweep_period: float | None = None, chunk: int = 20_000,
        progress: Callable[[int], None] | None = None, workers: int | None = None) -> MonteCarloResult:
    """Monte Carlo of a design's residual creep and hysteresis.

    Parameters
    ----------
    design : Design
    spec : ToleranceSpec
    n : int
        Number of samples.
    seed : int
        Seed of the random generator: the same seed gives the same numbers.
    sweep_period : float, optional
        Hysteresis sweep period (s); default from the design's creep model.
    chunk : int
        Samples evaluated per batch (memory bound).
    progress : callable, optional
        Called with the number of samples done after each batch.
    workers : int, optional
        Processes evaluating batches in parallel (default: one per core). The numbers do
        not depend on it: all samples are drawn first, from the seed.

    Returns
    -------
    MonteCarloResult
    """
    if n < 1:
        raise InputError(f"--n {n}: need at least one sample")
    start = _time.perf_counter()
    period = default_sweep_period(design.model) if sweep_period is None else float(sweep_period)
    box = factors(design, spec)
    values = draw(box, n, seed)
    jobs = [({k: v[lo:lo + chunk] for k, v in values.items()}, min(chunk, n - lo))
            for lo in range(0, n, chunk)]
    workers = min(workers or os.cpu_count() or 1, len(jobs))
    parts, done = [], 0
    if workers > 1:
        with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork")) as pool:
            futures = [pool.submit(evaluate, design, sub, period, spec.dielectric, spec.temperature, size)
                       for sub, size in jobs]
            for fut, (_, size) in zip(futures, jobs):
                parts.append(fut.result())
                done += size
                if progress:
                    progress(done)
    else:
        for sub, size in jobs:
            parts.append(evaluate(design, sub, period, spec.dielectric, spec.temperature, size))
            done += size
            if progress:
                progress(done)
    metrics = Metrics(*(np.concatenate([getattr(m, f) for m in parts]) for f in ("peak", "final", "hysteresis")))
    return MonteCarloResult(design, spec, box, values, metrics, seed,
                            _time.perf_counter() - start, period)


@dataclass(frozen=True)
class WorstCase:
    """The largest metric over the tolerance box and where it is."""

    metric: str
    value: float
    at: dict
    corners: int
    method: str


def worst_case(design: Design, spec: ToleranceSpec, metric: str = "peak",
               sweep_period: float | None = None, max_corners: int = 4096, seed: int = 0) -> WorstCase:
    """Worst case of a metric over the whole tolerance box, not only sampled points.

    Every corner of the box is evaluated (a random subset when there are more than
    ``max_corners``), then a bounded local search (L-BFGS-B) starts from the worst corners
    and from the nominal point.
    """
    period = default_sweep_period(design.model) if sweep_period is None else float(sweep_period)
    box = [f for f in factors(design, spec) if f.high > f.low]
    if not box:
        m = evaluate(design, {}, period, spec.dielectric, spec.temperature).get(metric)
        return WorstCase(metric, float(m[0]), {}, 1, "nominal (nothing varies)")
    m = len(box)
    lows = np.array([f.low for f in box])
    highs = np.array([f.high for f in box])
    if 2 ** m <= max_corners:
        bits = (np.arange(2 ** m)[:, None] >> np.arange(m)[None, :]) & 1
        method = f"all {2 ** m} corners"
    else:
        bits = np.random.default_rng(seed).integers(0, 2, (max_corners, m))
        method = f"{max_corners} random corners of {2 ** m}"
    corners = np.where(bits == 1, highs, lows)

    def metric_at(points: np.ndarray) -> np.ndarray:
        vals = {f.name: points[:, j] for j, f in enumerate(box)}
        return evaluate(design, vals, period, spec.dielectric, spec.temperature).get(metric)

    corner_values = metric_at(corners)
    starts = list(corners[np.argsort(corner_values)[-3:]]) + [np.array([f.nominal for f in box])]
    scale = highs - lows
    best_x, best_v = corners[np.argmax(corner_values)], float(corner_values.max())
    for x0 in starts:
        res = optimize.minimize(lambda z: -metric_at((lows + z * scale)[None, :])[0],
                                (x0 - lows) / scale, method="L-BFGS-B", bounds=[(0, 1)] * m,
                                options={"maxiter": 60})
        if -res.fun > best_v:
            best_v, best_x = float(-res.fun), lows + res.x * scale
    return WorstCase(metric, best_v, {f.name: float(v) for f, v in zip(box, best_x)},
                     len(corners), method + " + bounded local search")


@dataclass(frozen=True)
class Sensitivity:
    """What one factor does to the metric.

    Attributes
    ----------
    factor : str
    share : float
        First-order variance index ``Var(E[Y | X]) / Var(Y)`` from the Monte Carlo samples:
        the fraction of the spread this factor explains on its own.
    p99_alone : float
        p99 of the metric when only this factor varies (the others nominal).
    """

    factor: str
    share: float
    p99_alone: float


def first_order_index(x: np.ndarray, y: np.ndarray, bins: int = 50) -> float:
    """``Var(E[y | x]) / Var(y)`` estimated by averaging ``y`` in equal-count bins of ``x``,
    less the variance the bin means would show by chance."""
    var = float(np.var(y))
    if var == 0 or len(y) < 4 * bins:
        return 0.0
    groups = np.array_split(np.argsort(x, kind="stable"), bins)
    means = np.array([y[g].mean() for g in groups])
    chance = var / (len(y) / bins)
    return float(max(means.var() - chance, 0.0) / var)


def sensitivity(result: MonteCarloResult, metric: str = "peak", n_alone: int = 20_000) -> list[Sensitivity]:
    """Each factor's first-order share of the spread (from the Monte Carlo samples) and the
    p99 with that factor alone varying; largest share first."""
    y = result.metrics.get(metric)
    design, spec = result.design, result.spec
    out = []
    for f in result.box:
        if f.high <= f.low:
            continue
        share = first_order_index(result.values[f.name], y)
        alone = f.sample(np.random.default_rng(result.seed), n_alone)
        v = evaluate(design, {f.name: alone}, result.sweep_period, spec.dielectric,
                     spec.temperature).get(metric)
        out.append(Sensitivity(f.name, share, float(np.percentile(v, 99))))
    return sorted(out, key=lambda s: -s.share)


@dataclass(frozen=True)
class Tightening:
    """What a tighter part buys."""

    factor: str
    tolerance_from: float
    tolerance_to: float
    p99_from: float
    p99_to: float
    dielectric: str | None = None


def tighter_parts(design: Design, spec: ToleranceSpec, n: int = 20_000, seed: int = 0,
                  metric: str = "peak", sweep_period: float | None = None) -> list[Tightening]:
    """For every part, the p99 of the metric with that part one standard tolerance tighter.

    Resistors step to 1 % then 0.1 %. Capacitors step to the next tolerance their dielectric
    is sold in; where there is none, to a 1 % polypropylene part (which also changes the
    absorption and leakage).
    """
    base = run(design, spec, n, seed, sweep_period, workers=1).percentiles(metric)["p99"]
    out = []
    for label, kind, _ in design.network.parts():
        tol = spec.tolerance_of(label, kind)
        dielectric = spec.dielectric
        if kind == "C":
            offered = DIELECTRICS[dielectric].tolerances if dielectric else (0.2, 0.1, 0.05, 0.01)
            tighter = [t for t in offered if t < tol.rel - 1e-12]
            if not tighter and tol.rel > 0.01 + 1e-12:
                tighter, dielectric = [0.01], ("polypropylene" if dielectric else None)
        else:
            tighter = [t for t in RESISTOR_TOLERANCES if t < tol.rel - 1e-12]
        if not tighter:
            continue
        new = max(tighter)
        parts = dict(spec.parts)
        parts[label] = replace(tol, rel=new)
        variant = replace(spec, parts=parts, dielectric=dielectric)
        p99 = run(design, variant, n, seed, sweep_period, workers=1).percentiles(metric)["p99"]
        out.append(Tightening(label, tol.rel, new, base, p99,
                              dielectric if dielectric != spec.dielectric else None))
    return sorted(out, key=lambda t: t.p99_to)


def nominal_metrics(design: Design, spec: ToleranceSpec, sweep_period: float | None = None) -> Metrics:
    """Metrics of the design with every factor at its nominal value."""
    period = default_sweep_period(design.model) if sweep_period is None else float(sweep_period)
    return evaluate(design, {}, period, spec.dielectric, spec.temperature)


@dataclass(frozen=True)
class ToleranceReport:
    """Everything ``creepcomp mc`` reports."""

    result: MonteCarloResult
    metric: str
    limit: float | None
    nominal: Metrics
    worst: WorstCase | None
    sensitivities: list
    tightenings: list
    sensitivity_samples: int = 0
    spot_check: dict | None = None

    def to_dict(self) -> dict:
        """``mc --json``: ``n``, ``residual_creep_peak`` percentiles, ``seconds`` and the rest."""
        r = self.result
        out = {"n": r.n, "seed": r.seed, "seconds": r.seconds,
               "residual_creep_peak": r.percentiles("peak"),
               "residual_creep_final": r.percentiles("final"),
               "hysteresis": r.percentiles("hysteresis"),
               "sweep_period": r.sweep_period,
               "nominal": {"residual_creep_peak": float(self.nominal.peak[0]),
                           "residual_creep_final": float(self.nominal.final[0]),
                           "hysteresis": float(self.nominal.hysteresis[0])},
               "factors": [{"name": f.name, "nominal": f.nominal, "low": f.low, "high": f.high,
                            "distribution": f.distribution} for f in r.box],
               "metric": self.metric}
        if self.limit is not None:
            y, se = r.yield_against(self.limit, self.metric)
            out["spec"] = {"metric": self.metric, "limit": self.limit, "yield": y, "yield_standard_error": se}
        if self.worst is not None:
            out["worst_case"] = {"metric": self.worst.metric, "value": self.worst.value,
                                 "at": self.worst.at, "method": self.worst.method}
        out["sensitivity"] = [{"factor": s.factor, "share": s.share, "p99_alone": s.p99_alone}
                              for s in self.sensitivities]
        out["tighter_parts"] = [{"part": t.factor, "tolerance_from": t.tolerance_from,
                                 "tolerance_to": t.tolerance_to, "dielectric": t.dielectric,
                                 "p99_from": t.p99_from, "p99_to": t.p99_to,
                                 "samples": self.sensitivity_samples} for t in self.tightenings]
        if self.spot_check is not None:
            out["spot_check"] = self.spot_check
        return out


def analyse(design: Design, spec: ToleranceSpec, n: int, seed: int = 0, metric: str = "peak",
            limit: float | None = None, sweep_period: float | None = None, worst: bool = True,
            sensitivity_samples: int = 20_000, progress: Callable[[str, int, int], None] | None = None,
            workers: int | None = None, spot_check_samples: int = 0) -> ToleranceReport:
    """Monte Carlo, nominal, worst case, sensitivity and tighter-part figures of a design.

    Parameters
    ----------
    design : Design
    spec : ToleranceSpec
    n : int
        Monte Carlo samples.
    seed : int
        Random seed.
    metric : {"peak", "final", "hysteresis"}
        The figure the specification, the worst case and the sensitivity are about.
    limit : float, optional
        Specification limit of that metric (fraction), for the yield.
    sweep_period : float, optional
        Hysteresis sweep period (s).
    worst : bool
        Search the worst case over the tolerance box.
    sensitivity_samples : int
        Samples per factor for the sensitivity and tighter-part runs (0: skip them).
    progress : callable, optional
        ``progress(stage, done, total)``.
    workers : int, optional
        Processes for the main run.
    spot_check_samples : int
        Samples to run through ngspice and compare (0: none).

    Returns
    -------
    ToleranceReport
    """
    if metric not in ("peak", "final", "hysteresis"):
        raise InputError(f"metric '{metric}': use peak, final or hysteresis")
    result = run(design, spec, n, seed, sweep_period, workers=workers,
                 progress=(lambda done: progress("Monte Carlo", done, n)) if progress else None)
    period = result.sweep_period
    nominal = nominal_metrics(design, spec, period)
    wc = worst_case(design, spec, metric, period) if worst else None
    sens, tight = [], []
    if sensitivity_samples:
        if progress:
            progress("sensitivity", 0, 1)
        sens = sensitivity(result, metric, sensitivity_samples)
        tight = tighter_parts(design, spec, sensitivity_samples, seed, metric, period)
        if progress:
            progress("sensitivity", 1, 1)
    spot = None
    if spot_check_samples:
        if progress:
            progress("ngspice spot-check", 0, 1)
        spot = spot_check(result, spot_check_samples)
        if progress:
            progress("ngspice spot-check", 1, 1)
    return ToleranceReport(result, metric, limit, nominal, wc, sens, tight, sensitivity_samples, spot)
