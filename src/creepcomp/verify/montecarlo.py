"""Monte Carlo of a design's residual creep and hysteresis, and its spot check in ngspice.

Samples are drawn in blocks of at most :data:`BLOCK`, each from its own seed, then evaluated
in batches (:func:`creepcomp.verify.variants.evaluate`), in parallel processes when there are
several: the numbers do not depend on how the batches are spread. Memory is bounded by the
block at any ``n``; percentiles are exact up to one block, then from a fine histogram.
"""

from __future__ import annotations

import math
import multiprocessing
import os
import signal
import time as _time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from creepcomp.display import Shown, data_frame
from creepcomp.errors import CreepcompError, InputError
from creepcomp.interrupts import interrupts_held
from creepcomp.io.jsonfiles import Design
from creepcomp.verify.drive import (DEFAULT_SIGNAL, fastest_time_constant, largest_step, rise_time,
                                    slowest_time_constant, synthetic_program, transient_times)
from creepcomp.verify.ngspice_engine import ngspice, run_transient
from creepcomp.verify.tolerances import ToleranceSpec, draw, factors
from creepcomp.verify.variants import (Metrics, evaluate, residual_lags, step_residual,
                                       sweep_period_or_default, variant)

__all__ = ["SPOT_CHECK_SPAN", "SPOT_CHECK_SETTLE", "BLOCK", "BATCH_ROWS", "HISTOGRAM_BINS", "StreamingPercentiles",
           "MonteCarloResult", "block_seed", "run_monte_carlo", "nominal_metrics", "spot_check"]


#: The spot-check's step response spans this many of the slowest time constants, and is
#: compared from this many of the fastest on (ngspice's step is a short ramp).
SPOT_CHECK_SPAN = 12.0
SPOT_CHECK_SETTLE = 1e-3


#: Samples drawn, evaluated and held at once (each block's values and metrics: about 100 MB
#: for a design with 9 factors); the first block is kept for the sensitivity, the report's
#: histograms and the spot check.
BLOCK = 1_000_000
#: Most variants (samples x temperatures) evaluated in one batch: its arrays take about 50 MB.
BATCH_ROWS = 60_000
#: Bins of the streaming histogram that gives the percentiles of a run longer than one block.
HISTOGRAM_BINS = 1 << 16

METRIC_NAMES = ("peak", "final", "hysteresis")


class StreamingPercentiles:
    """Count, minimum, maximum and percentiles of values that arrive in blocks, in bounded
    memory.

    While everything fits in one block the values are kept and the percentiles are exact
    (``numpy.percentile``, linear interpolation). Beyond, the values go into a histogram of
    :data:`HISTOGRAM_BINS` equal bins that covers every value seen (when a block falls outside
    it, neighbouring bins are merged in pairs and the range doubles); a percentile is then
    interpolated within the bin that holds its rank: it is within :attr:`resolution` (one
    bin width) of the sample of that rank (``numpy.percentile`` interpolates between the two
    samples around a fractional rank; their gap is negligible at that many samples). ``min``, ``max`` and ``n`` are always exact.
    """

    def __init__(self, bins: int = HISTOGRAM_BINS):
        if bins < 2 or bins % 2:
            raise ValueError("bins must be even")
        self.bins = bins
        self.n = 0
        self.min = math.inf
        self.max = -math.inf
        self._exact: np.ndarray | None = None
        self._counts: np.ndarray | None = None
        self._lo = 0.0
        self._width = 0.0

    @property
    def exact(self) -> bool:
        """Whether the percentiles are exact (every value kept)."""
        return self._counts is None

    @property
    def resolution(self) -> float:
        """Largest error of a percentile: 0 when exact, else the histogram's bin width."""
        return 0.0 if self.exact else self._width

    def add(self, values: np.ndarray) -> None:
        """Add a block of values (finite)."""
        v = np.asarray(values, float).ravel()
        if not len(v):
            return
        self.n += len(v)
        self.min = min(self.min, float(v.min()))
        self.max = max(self.max, float(v.max()))
        if self._counts is None and self._exact is None:
            self._exact = v.copy()
            return
        if self._counts is None:
            kept, self._exact = self._exact, None
            self._start_histogram()
            self._bin(kept)
        self._cover()
        self._bin(v)

    def _start_histogram(self) -> None:
        span = self.max - self.min
        self._lo = self.min
        self._width = span / (self.bins - 1) if span > 0 else max(abs(self.min), 1e-30) * 1e-12
        self._counts = np.zeros(self.bins, np.int64)

    def _cover(self) -> None:
        # double the range (merging bins in pairs) until it holds min and max
        while self.max >= self._lo + self.bins * self._width:
            merged = self._counts.reshape(-1, 2).sum(axis=1)
            self._counts = np.concatenate([merged, np.zeros(self.bins // 2, np.int64)])
            self._width *= 2
        while self.min < self._lo:
            merged = self._counts.reshape(-1, 2).sum(axis=1)
            self._counts = np.concatenate([np.zeros(self.bins // 2, np.int64), merged])
            self._lo -= self.bins * self._width
            self._width *= 2

    def _bin(self, v: np.ndarray) -> None:
        self._cover()
        index = np.clip(((v - self._lo) / self._width).astype(np.int64), 0, self.bins - 1)
        self._counts += np.bincount(index, minlength=self.bins)

    def percentile(self, q: float) -> float:
        """The ``q``-th percentile (0..100)."""
        if self.n == 0:
            raise ValueError("no values")
        if self._counts is None:
            return float(np.percentile(self._exact, q))
        rank = q / 100 * (self.n - 1)                  # 0-based, as numpy's linear method
        cumulative = np.cumsum(self._counts)
        b = int(np.searchsorted(cumulative, rank, side="right"))
        before = cumulative[b - 1] if b else 0
        inside = (rank - before + 0.5) / self._counts[b]
        value = self._lo + (b + min(inside, 1.0)) * self._width
        return float(min(max(value, self.min), self.max))

    def summary(self) -> dict:
        """``p50``, ``p95``, ``p99`` and ``max``."""
        return {"p50": self.percentile(50), "p95": self.percentile(95),
                "p99": self.percentile(99), "max": self.max}


@dataclass(frozen=True, eq=False)
class MonteCarloResult(Shown):
    """Figures of a Monte Carlo run: exact ``n``, min and max, streaming percentiles, exact
    yield against the limit given to the run, and the first block of samples (``values``,
    ``metrics``: every sample when ``n`` fits in one block)."""

    design: Design
    spec: ToleranceSpec
    box: list
    values: dict
    metrics: Metrics
    seed: int
    seconds: float
    sweep_period: float
    total: int = 0
    stats: dict | None = None
    limit: float | None = None
    limit_metric: str = "peak"
    within_limit: int = 0
    within_limit_by_temperature: tuple[int, ...] = ()
    worst_temperature_counts: tuple[int, ...] = ()

    def __repr__(self) -> str:
        from creepcomp.units import format_percent

        p = self.percentiles("peak")
        return (f"<MonteCarloResult {self.n:,} samples, seed {self.seed}: peak residual creep "
                f"p50 {format_percent(p['p50'])}, p99 {format_percent(p['p99'])}, max {format_percent(p['max'])}>")

    def to_dict(self) -> dict:
        """JSON form: samples, seed, seconds and each metric's percentiles (fractions of FS)."""
        return {"n": self.n, "seed": self.seed, "seconds": self.seconds, "sweep_period": self.sweep_period,
                "residual_creep_peak": self.percentiles("peak"),
                "residual_creep_final": self.percentiles("final"),
                "hysteresis": self.percentiles("hysteresis"), "limit": self.limit}

    def to_pandas(self):
        """The samples kept: each factor's value and each metric (fractions of FS) per unit."""
        columns = {name: np.asarray(v)[:self.kept] for name, v in self.values.items()}
        columns.update({m: self.metrics.get(m) for m in ("peak", "final", "hysteresis")})
        return data_frame(columns)

    @property
    def temperatures(self) -> tuple[float, ...]:
        """The temperatures each unit was evaluated at (°C); empty: the design as it is."""
        over = self.spec.over_temperature
        return over.temperatures if over is not None else ()

    def percentiles_at(self, index: int, metric: str = "peak") -> dict:
        """:meth:`percentiles` at the ``index``-th temperature."""
        if self.stats is None or self.kept == self.n:
            v = self.metrics.per_temperature.get(metric)[:, index]
            p50, p95, p99 = np.percentile(v, [50, 95, 99])
            return {"p50": float(p50), "p95": float(p95), "p99": float(p99), "max": float(v.max())}
        return self.stats[f"{metric}@{index}"].summary()

    def yield_at(self, index: int, limit: float, metric: str = "peak") -> tuple[float, float]:
        """:meth:`yield_against` at the ``index``-th temperature alone."""
        if self.kept == self.n:
            ok = float(np.mean(self.metrics.per_temperature.get(metric)[:, index] <= limit))
        elif self.limit == limit and self.limit_metric == metric:
            ok = self.within_limit_by_temperature[index] / self.n
        else:
            raise InputError(f"the yield against {limit} needs the Monte Carlo run with that limit "
                             f"(it kept {self.kept} of {self.n} samples)")
        return ok, math.sqrt(max(ok * (1 - ok), 1.0 / self.n) / self.n)

    @property
    def n(self) -> int:
        """Number of samples."""
        return self.total or len(self.metrics.peak)

    @property
    def kept(self) -> int:
        """Number of samples kept (``values`` and ``metrics``)."""
        return len(self.metrics.peak)

    def percentiles(self, metric: str = "peak") -> dict:
        """``p50``, ``p95``, ``p99`` and ``max`` of a metric (fractions); exact when every
        sample was kept, else within :meth:`resolution` of it."""
        if self.stats is None or self.kept == self.n:
            v = self.metrics.get(metric)
            p50, p95, p99 = np.percentile(v, [50, 95, 99])
            return {"p50": float(p50), "p95": float(p95), "p99": float(p99), "max": float(v.max())}
        return self.stats[metric].summary()

    def resolution(self, metric: str = "peak") -> float:
        """Largest error of :meth:`percentiles` (0: exact)."""
        return 0.0 if self.stats is None or self.kept == self.n else self.stats[metric].resolution

    def yield_against(self, limit: float, metric: str = "peak") -> tuple[float, float]:
        """Fraction of samples with the metric at or below ``limit``, and its standard error.

        Exact over all samples when every sample was kept or when ``limit`` and ``metric`` are
        the ones the run counted against.
        """
        if self.kept == self.n:
            ok = float(np.mean(self.metrics.get(metric) <= limit))
        elif self.limit == limit and self.limit_metric == metric:
            ok = self.within_limit / self.n
        else:
            raise InputError(f"the yield against {limit} needs the Monte Carlo run with that limit "
                             f"(it kept {self.kept} of {self.n} samples)")
        return ok, math.sqrt(max(ok * (1 - ok), 1.0 / self.n) / self.n)


def block_seed(seed: int, index: int):
    """Seed of block ``index`` of a run: the run's seed for the first block (so a run that fits
    in one block draws what :func:`creepcomp.verify.tolerances.draw` does), then a
    ``(seed, index)`` sequence for each further one."""
    return seed if index == 0 else [seed, index]


def run_monte_carlo(design: Design, spec: ToleranceSpec, n: int, seed: int = 0,
                    sweep_period: float | None = None, chunk: int = 20_000,
                    progress: Callable[[int], None] | None = None,
                    workers: int | None = None, block: int = BLOCK,
                    limit: float | None = None, metric: str = "peak") -> MonteCarloResult:
    """Monte Carlo of a design's residual creep and hysteresis, in bounded memory.

    Samples are drawn and evaluated ``block`` at a time; each block's metrics go into
    running figures (:class:`StreamingPercentiles`) and only the first block is kept.

    Parameters
    ----------
    design : Design
    spec : ToleranceSpec
    n : int
        Number of samples (any: memory is bounded by ``block``).
    seed : int
        Seed of the random generator: the same seed gives the same numbers.
    sweep_period : float, optional
        Hysteresis sweep period (s); default from the design's creep model.
    chunk : int
        Samples evaluated per batch (one task of a worker).
    progress : callable, optional
        Called with the number of samples done after each batch.
    workers : int, optional
        Processes evaluating batches in parallel (default: one per core). The numbers do
        not depend on it: each block's samples are drawn first, from the seed.
    block : int
        Samples drawn and held at once. Percentiles are exact when ``n <= block``, else within
        one bin of a histogram of :data:`HISTOGRAM_BINS` bins (:meth:`MonteCarloResult.resolution`).
    limit : float, optional
        Count the samples with ``metric`` at or below it, for an exact yield at any ``n``.
    metric : str
        The metric ``limit`` is about.

    Returns
    -------
    MonteCarloResult

    Examples
    --------
    The default sensor's network with 1 % resistors and 5 % capacitors (3 sigma), 2,000 draws:

    >>> from creepcomp.model import CreepModel
    >>> from creepcomp.analog.sizing import size
    >>> from creepcomp.io.jsonfiles import Design
    >>> from creepcomp.verify.montecarlo import run_monte_carlo
    >>> from creepcomp.verify.tolerances import Tolerance, ToleranceSpec
    >>> model = CreepModel(beta=(0.03,), tau=(45.0,))
    >>> design = Design(model, size(model).chosen)
    >>> spec = ToleranceSpec(resistor=Tolerance(0.01), capacitor=Tolerance(0.05))
    >>> result = run_monte_carlo(design, spec, n=2000, seed=1, workers=1)
    >>> peak = result.percentiles("peak")
    >>> print(f"residual creep, 95th percentile below 0.1 %: {peak['p95'] < 1e-3}")
    residual creep, 95th percentile below 0.1 %: True
    """
    if n < 1:
        raise InputError(f"--n {n}: need at least one sample")
    start = _time.perf_counter()
    period = sweep_period_or_default(design.model, sweep_period)
    box = factors(design, spec)
    over = spec.over_temperature
    correlation = over.lot_correlation if over is not None else 0.0
    n_temps = len(over.temperatures) if over is not None else 0
    # a batch evaluates chunk x temperatures variants: at most BATCH_ROWS of them (memory)
    chunk = max(1, min(chunk, BATCH_ROWS // max(n_temps, 1)))
    blocks = [(lo, min(block, n - lo)) for lo in range(0, n, block)]
    workers = min(workers or os.cpu_count() or 1, -(-min(block, n) // chunk))
    names = list(METRIC_NAMES) + [f"{m}@{k}" for k in range(n_temps) for m in METRIC_NAMES]
    stats = {m: StreamingPercentiles() for m in names}
    first_values, first_metrics, within, done = None, None, 0, 0
    within_t, worst_counts = np.zeros(n_temps, np.int64), np.zeros(n_temps, np.int64)
    pool = None
    if workers > 1:
        pool = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork"),
                                   initializer=_ignore_interrupts)
    try:
        for index, (_, size) in enumerate(blocks):
            values = draw(box, size, block_seed(seed, index), correlation)
            jobs = [({k: v[lo:lo + chunk] for k, v in values.items()}, min(chunk, size - lo))
                    for lo in range(0, size, chunk)]
            parts = []
            if pool is not None:
                with interrupts_held():  # (the first submit starts the pool's processes)
                    futures = [pool.submit(evaluate, design, sub, period, spec.dielectric,
                                           spec.temperature, s, over) for sub, s in jobs]
                results = (f.result() for f in futures)
            else:
                results = (evaluate(design, sub, period, spec.dielectric, spec.temperature, s, over)
                           for sub, s in jobs)
            for part, (_, s) in zip(results, jobs):
                parts.append(part)
                done += s
                if progress:
                    progress(done)
            metrics = _joined(parts)
            for m in METRIC_NAMES:
                stats[m].add(metrics.get(m))
            per = metrics.per_temperature
            for k in range(n_temps):
                for m in METRIC_NAMES:
                    stats[f"{m}@{k}"].add(per.get(m)[:, k])
            if n_temps:
                worst_counts += np.bincount(np.argmax(per.peak, axis=1), minlength=n_temps)
            if limit is not None:
                within += int(np.count_nonzero(metrics.get(metric) <= limit))
                if n_temps:
                    within_t += np.count_nonzero(per.get(metric) <= limit, axis=0)
            if index == 0:
                first_values, first_metrics = values, metrics
    except BaseException:
        if pool is not None:
            # Ctrl-C (or an error): drop the queued batches and let each worker finish the one
            # it holds (a chunk: tens of ms). Terminating a worker while it writes its result
            # left the pool's result thread waiting for the rest of the message, and the
            # interpreter's exit waiting for that thread: a hang after "interrupted".
            _shut_down(pool)
        raise
    if pool is not None:
        pool.shutdown()
    return MonteCarloResult(design, spec, box, first_values, first_metrics, seed,
                            _time.perf_counter() - start, period, n, stats, limit, metric, within,
                            tuple(int(c) for c in within_t), tuple(int(c) for c in worst_counts))


def _shut_down(pool: ProcessPoolExecutor) -> None:
    """Stop ``pool`` after Ctrl-C or SIGTERM: queued batches dropped, running ones finished. A
    second signal while it waits (SIGTERM is delivered again until the command reports it)
    does not cut the wait short: a pool left half shut down makes the interpreter's exit wait."""
    while True:
        try:
            pool.shutdown(wait=True, cancel_futures=True)
            return
        except KeyboardInterrupt:
            continue


def _joined(parts: list[Metrics]) -> Metrics:
    """One block's metrics from its batches (with their per-temperature figures)."""
    per = None
    if parts[0].per_temperature is not None:
        per = _joined([p.per_temperature for p in parts])
    return Metrics(*(np.concatenate([getattr(m, f) for m in parts])
                     for f in ("peak", "final", "hysteresis")), per)


def _ignore_interrupts() -> None:
    """Worker processes leave Ctrl-C and SIGTERM to the main process, which stops them; a
    worker whose main process dies without stopping it (SIGKILL) is killed by the kernel
    (Linux), never left running on its own."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    _die_with_parent()


def _die_with_parent() -> None:
    """Ask Linux to send this process SIGKILL when its parent ends (``prctl``); elsewhere a
    no-op."""
    import ctypes
    import ctypes.util
    import sys

    if not sys.platform.startswith("linux"):
        return
    pr_set_pdeathsig = 1
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        libc.prctl(pr_set_pdeathsig, signal.SIGKILL, 0, 0, 0)
    except (OSError, AttributeError):
        pass


def nominal_metrics(design: Design, spec: ToleranceSpec, sweep_period: float | None = None) -> Metrics:
    """Metrics of the design with every factor at its nominal value."""
    period = sweep_period_or_default(design.model, sweep_period)
    return evaluate(design, {}, period, spec.dielectric, spec.temperature,
                    over=spec.over_temperature)


def spot_check(result: MonteCarloResult, n: int = 200, points: int = 400) -> dict:
    """Run the first ``n`` samples of a Monte Carlo through ngspice (a load step) and compare
    their residual creep with the engine's at the same times.

    ngspice's step is a ramp (:func:`creepcomp.verify.drive.rise_time`); the engine's
    residual is that of the same ramp, exact from its end on. Over temperature, sample ``i``
    runs at the ``i``-th temperature (cyclically), as a design at that temperature.

    Returns
    -------
    dict
        ``n``, ``agreement_max_abs`` (largest difference, fraction of the step), ``seconds``
        and ``seconds_per_transient``; or ``error`` when ngspice cannot run.
    """
    n = min(n, result.n)
    design, spec = result.design, result.spec
    program = synthetic_program(design.model, "step")
    start = _time.perf_counter()
    worst, transient = 0.0, 0.0
    try:
        engine = ngspice()
        for i in range(n):
            at = None
            if spec.over_temperature is not None:
                temps = spec.over_temperature.temperatures
                at = replace(spec.over_temperature, temperatures=(temps[i % len(temps)],))
            sample = variant(design, result.values, i, spec.dielectric, spec.temperature, at)
            duration = SPOT_CHECK_SPAN * slowest_time_constant(sample.model, sample.network)
            times = transient_times(program, duration, points)
            rise = rise_time(sample.model, sample.network, largest_step(duration, points))
            t0 = _time.perf_counter()
            wave = run_transient(sample.network, sample.model, program, times, engine=engine,
                                 points=points)
            transient += _time.perf_counter() - t0
            late = times > max(SPOT_CHECK_SETTLE * fastest_time_constant(sample.model, sample.network),
                               rise)
            ideal = sample.network.lag_expansion().hf_gain * DEFAULT_SIGNAL
            e_spice = wave.output[late] / ideal - 1.0
            rel, q = residual_lags(design, {k: v[i:i + 1] for k, v in result.values.items()},
                                   spec.dielectric, spec.temperature, 1, at)
            e_engine = step_residual(rel, q, times[late][None, :], rise)[0]
            worst = max(worst, float(np.max(np.abs(e_spice - e_engine))))
    except CreepcompError as exc:
        return {"n": 0, "error": str(exc)}
    return {"n": n, "agreement_max_abs": worst, "seconds": _time.perf_counter() - start,
            "seconds_per_transient": transient / n if n else None}
