"""Monte Carlo of a design's residual creep and hysteresis, and its spot check in ngspice.

All samples are drawn first, from the seed, then evaluated in batches
(:func:`creepcomp.verify.variants.evaluate`), in parallel processes when there are several:
the numbers do not depend on how the batches are spread.
"""

from __future__ import annotations

import math
import multiprocessing
import os
import signal
import time as _time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from typing import Callable

import numpy as np

from creepcomp.errors import CreepcompError, InputError
from creepcomp.io.jsonfiles import Design
from creepcomp.verify.drive import (DEFAULT_SIGNAL, fastest_time_constant, slowest_time_constant,
                                    synthetic_program, transient_times)
from creepcomp.verify.ngspice_engine import ngspice, run_transient
from creepcomp.verify.tolerances import ToleranceSpec, draw, factors
from creepcomp.verify.variants import (Metrics, evaluate, residual_lags, step_residual,
                                       sweep_period_or_default, variant)

__all__ = ["SPOT_CHECK_SPAN", "SPOT_CHECK_SETTLE", "BYTES_PER_VALUE", "JOIN_COPIES",
           "MonteCarloResult", "run_monte_carlo", "available_memory", "check_memory",
           "nominal_metrics", "spot_check"]


#: The spot-check's step response spans this many of the slowest time constants, and is
#: compared from this many of the fastest on (ngspice's step is a short ramp).
SPOT_CHECK_SPAN = 12.0
SPOT_CHECK_SETTLE = 1e-3


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


def run_monte_carlo(design: Design, spec: ToleranceSpec, n: int, seed: int = 0,
                    sweep_period: float | None = None, chunk: int = 20_000,
                    progress: Callable[[int], None] | None = None,
                    workers: int | None = None) -> MonteCarloResult:
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
    period = sweep_period_or_default(design.model, sweep_period)
    box = factors(design, spec)
    check_memory(n, len(box))
    values = draw(box, n, seed)
    jobs = [({k: v[lo:lo + chunk] for k, v in values.items()}, min(chunk, n - lo))
            for lo in range(0, n, chunk)]
    workers = min(workers or os.cpu_count() or 1, len(jobs))
    parts, done = [], 0
    if workers > 1:
        pool = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork"),
                                   initializer=_ignore_interrupts)
        try:
            futures = [pool.submit(evaluate, design, sub, period, spec.dielectric, spec.temperature, size)
                       for sub, size in jobs]
            for fut, (_, size) in zip(futures, jobs):
                parts.append(fut.result())
                done += size
                if progress:
                    progress(done)
        except BaseException:
            # Ctrl-C (or an error): stop the workers now rather than after their queued batches
            processes = list((getattr(pool, "_processes", None) or {}).values())
            pool.shutdown(wait=False, cancel_futures=True)
            for proc in processes:
                proc.terminate()
            raise
        pool.shutdown()
    else:
        for sub, size in jobs:
            parts.append(evaluate(design, sub, period, spec.dielectric, spec.temperature, size))
            done += size
            if progress:
                progress(done)
    metrics = Metrics(*(np.concatenate([getattr(m, f) for m in parts])
                        for f in ("peak", "final", "hysteresis")))
    return MonteCarloResult(design, spec, box, values, metrics, seed,
                            _time.perf_counter() - start, period)


def _ignore_interrupts() -> None:
    """Worker processes leave Ctrl-C to the main process, which stops them."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


#: Bytes held per Monte Carlo sample and factor (its value) or metric, with the copies made
#: while joining the batches.
BYTES_PER_VALUE = 8
JOIN_COPIES = 2


def available_memory() -> int | None:
    """Memory available to a new allocation (bytes; Linux ``MemAvailable``), or None."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def check_memory(n: int, n_factors: int, available: int | None = None) -> None:
    """Refuse a Monte Carlo whose samples would not fit in memory, before allocating them.

    Every sample's factor values and its three metrics are kept (for the percentiles and
    the sensitivity), so memory grows with ``n``.

    Raises
    ------
    InputError
        Naming the memory needed, the memory available and the largest ``n`` that fits.
    """
    from creepcomp.units import format_quantity

    per_sample = BYTES_PER_VALUE * (n_factors + 3 * JOIN_COPIES)
    available = available_memory() if available is None else available
    if available is None:
        return
    usable = int(0.8 * available)
    if n * per_sample > usable:
        raise InputError(f"--n {n}: the Monte Carlo keeps every sample ({n_factors} factors and "
                         f"3 metrics, {per_sample} bytes each): "
                         f"{format_quantity(n * per_sample, 'B', 3)}, more than the "
                         f"{format_quantity(usable, 'B', 3)} of memory it may use here; use "
                         f"--n {usable // per_sample} or fewer")


def nominal_metrics(design: Design, spec: ToleranceSpec, sweep_period: float | None = None) -> Metrics:
    """Metrics of the design with every factor at its nominal value."""
    period = sweep_period_or_default(design.model, sweep_period)
    return evaluate(design, {}, period, spec.dielectric, spec.temperature)


def spot_check(result: MonteCarloResult, n: int = 200, points: int = 400) -> dict:
    """Run the first ``n`` samples of a Monte Carlo through ngspice (a load step) and compare
    their residual creep with the engine's at the same times.

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
            sample = variant(design, result.values, i, spec.dielectric, spec.temperature)
            duration = SPOT_CHECK_SPAN * slowest_time_constant(sample.model, sample.network)
            times = transient_times(program, duration, points)
            t0 = _time.perf_counter()
            wave = run_transient(sample.network, sample.model, program, times, engine=engine)
            transient += _time.perf_counter() - t0
            late = times > SPOT_CHECK_SETTLE * fastest_time_constant(sample.model, sample.network)
            ideal = sample.network.lag_expansion().hf_gain * DEFAULT_SIGNAL
            e_spice = wave.output[late] / ideal - 1.0
            rel, q = residual_lags(design, {k: v[i:i + 1] for k, v in result.values.items()},
                                   spec.dielectric, spec.temperature, 1)
            e_engine = step_residual(rel, q, times[late][None, :])[0]
            worst = max(worst, float(np.max(np.abs(e_spice - e_engine))))
    except CreepcompError as exc:
        return {"n": 0, "error": str(exc)}
    return {"n": n, "agreement_max_abs": worst, "seconds": _time.perf_counter() - start,
            "seconds_per_transient": transient / n if n else None}
