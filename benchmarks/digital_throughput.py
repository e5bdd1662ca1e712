"""Throughput of the digital creep correctors, on one core.

    .venv/bin/python benchmarks/digital_throughput.py [--samples 10000000] [--literal-samples 100000]

Measures (best of several runs, wall clock):
- batch correction of a uniform record, 3 creep terms (``digital.compensate``);
- ``scipy.signal.lfilter`` of the same order (3) on the same samples, with the polynomial
  coefficients of the inverse filter ``1/G(z)``: the speed yardstick; its error shows why
  the correctors do not use it;
- streaming in chunks of 1000 samples (``digital.Corrector``);
- batch correction of an irregularly sampled record;
- the paper's eq. 7 as printed (O(N^2)) against the production corrector at N samples.
Prints a Markdown table for docs/benchmarks.md.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"                                   # one core, before numpy loads

import argparse  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from scipy import signal  # noqa: E402

from creepcomp.digital import paper_methods  # noqa: E402
from creepcomp.digital.correctors import Corrector, compensate  # noqa: E402
from creepcomp.lti import lag_coefficients  # noqa: E402
from creepcomp.model import CreepModel  # noqa: E402
from creepcomp.digital.scenarios import paper_model  # noqa: E402


def best_of(function, repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        best = min(best, time.perf_counter() - start)
    return best


def direct_form(model: CreepModel, dt: float):
    """Polynomial (direct-form) coefficients of 1/G(z) for held loads: b = den G, a = num G."""
    beta, taus = np.array(model.beta), np.array(model.tau)
    e, b0, _ = lag_coefficients(dt, taus, "zero")
    den = np.array([1.0])
    for ek in e:
        den = np.polymul(den, [1.0, -ek])
    num = den.copy()
    for k in range(len(beta)):
        part = np.array([0.0, beta[k] * b0[k]])
        for j in range(len(beta)):
            if j != k:
                part = np.polymul(part, [1.0, -e[j]])
        num = np.polyadd(num, part)
    return den, num


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=10_000_000)
    parser.add_argument("--chunk", type=int, default=1000)
    parser.add_argument("--literal-samples", type=int, default=100_000)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()

    model = paper_model()                       # 3 terms, tau 6 s, 45 s, 150 s
    n, dt = args.samples, 0.01                  # 100 Hz
    rng = np.random.default_rng(0)
    t = np.arange(n) * dt
    load = np.repeat(rng.uniform(-1, 1, n // 5000 + 1), 5000)[:n]
    raw = model.response(t, load, hold="zero")
    rows = []
    load_before = os.getloadavg()[0]

    batch = best_of(lambda: compensate(t, raw, model), args.repeats)
    corrected = compensate(t, raw, model)
    rows.append(("batch, uniform, 3 terms (`compensate`)", n, batch,
                 f"max error {np.max(np.abs(corrected - load)):.1e} of FS"))

    den, num = direct_form(model, dt)
    lfilter = best_of(lambda: signal.lfilter(den, num, raw), args.repeats)
    direct = signal.lfilter(den, num, raw)
    rows.append(("`scipy.signal.lfilter`, order 3, same samples", n, lfilter,
                 f"max error {np.max(np.abs(direct - load)):.1e} of FS (direct form: not exact)"))

    chunk = args.chunk

    def stream():
        corrector = Corrector(model, dt=dt)
        return np.concatenate([corrector.process(raw[i:i + chunk]) for i in range(0, n, chunk)])

    streaming = best_of(stream, max(1, args.repeats // 2))
    rows.append((f"streaming, chunks of {chunk} (`Corrector.process`)", n, streaming,
                 f"max difference from batch {np.max(np.abs(stream() - corrected)):.1e}"))

    m = min(n, 2_000_000)
    ti = np.cumsum(rng.uniform(0.5, 1.5, m) * dt)
    raw_i = model.response(ti, load[:m], hold="zero")
    irregular = best_of(lambda: compensate(ti, raw_i, model), max(1, args.repeats // 2))
    rows.append(("batch, irregular sampling, 3 terms", m, irregular,
                 f"max error {np.max(np.abs(compensate(ti, raw_i, model) - load[:m])):.1e} of FS"))

    voigt = CreepModel.voigt(0.03, 45.0)
    nl = args.literal_samples
    tl = np.arange(nl) * 1e-3                  # t / tau stays below 709: the printed form works
    raw_l = voigt.response(tl, load[:nl], hold="zero")
    start = time.perf_counter()
    literal = paper_methods.subtractive(tl, raw_l, voigt.beta, voigt.tau)
    literal_time = time.perf_counter() - start
    production = best_of(lambda: compensate(tl, raw_l, voigt), args.repeats)
    agree = np.max(np.abs(literal - compensate(tl, raw_l, voigt)))
    rows.append(("paper eq. 7 as printed, 1 term (O(N^2))", nl, literal_time,
                 f"agrees with production to {agree:.1e}"))
    rows.append(("production, same record", nl, production,
                 f"{literal_time / production:.3g}x faster than eq. 7"))

    print(f"one core; {platform.processor() or platform.machine()}, Python {platform.python_version()}, "
          f"numpy {np.__version__}; load average {load_before:.2f} before, "
          f"{os.getloadavg()[0]:.2f} after\n")
    print("| run | samples | time | M samples/s | note |")
    print("|---|---:|---:|---:|---|")
    for name, count, seconds, note in rows:
        print(f"| {name} | {count:.3g} | {seconds * 1e3:.4g} ms | {count / seconds / 1e6:.3g} | {note} |")
    print(f"\nbatch / lfilter time: {batch / lfilter:.2f}")


if __name__ == "__main__":
    main()
