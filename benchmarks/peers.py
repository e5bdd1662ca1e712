"""The same records through creepcomp and a peer, side by side in one run: lmfit (a plain
multi-exponential step fit, the number of terms chosen by BIC, as a user would write it in
15 lines). rheojax, the other peer considered, is not here: pip finds no distribution of it on
the package index this project installs from.

Records: a load step at 30 s on a sensor with three creep terms (beta 2, 3, 4 % at 8, 90,
900 s), 10 Hz for 3600 s, white noise of 0.01 % of the step; and the same with AR(1) noise
of phi 0.99 (same variance), where stated uncertainties are tested against actual errors.

Printed per tool: terms chosen, parameter errors (relative, terms matched by tau), held-out
error (fitted on the first 70 % of the record, RMS of the prediction of the rest, in units
of the noise), warm CPU time (in-process, after a first fit: the least of ``--repeat``
fits, the tools taking turns; also with the number of terms given)
and cold wall time (a fresh interpreter: import and one fit), and the coverage of the stated
one-sigma and two-sigma intervals over seeds.

Usage::

    python benchmarks/peers.py [--seeds 10] [--no-cold] [--repeat 5]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time

import numpy as np

BETAS = (0.02, 0.03, 0.04)
TAUS = (8.0, 90.0, 900.0)
STEP_AT = 30.0
SIGMA = 1e-4


def record(seed: int, phi: float = 0.0, rate: float = 10.0, duration: float = 3600.0):
    """(time, load, signal) of the three-term step record."""
    from scipy.signal import lfilter

    from creepcomp.lti import lag_states

    t = np.arange(0.0, duration, 1.0 / rate)
    load = np.where(t >= STEP_AT, 1.0, 0.0)
    noise = np.random.default_rng(seed).normal(0.0, SIGMA, t.size)
    if phi:
        noise = lfilter([1.0], [1.0, -phi], noise) * np.sqrt(1.0 - phi ** 2)
    return t, load, load + lag_states(t, load, list(TAUS)) @ np.array(BETAS) + noise


def lmfit_step(t, y, max_terms=4, n_terms=None):
    """The peer: offset + gain * step * (1 + sum beta_k (1 - exp(-(t - t_step) / tau_k))),
    1 ... ``max_terms`` terms, the lowest BIC kept. Returns (betas, taus, sigmas, predict)."""
    import lmfit

    best = None
    for k in ([n_terms] if n_terms else range(1, max_terms + 1)):
        def model(p, tt, k=k):
            x, on = np.clip(tt - STEP_AT, 0.0, None), (tt >= STEP_AT).astype(float)
            creep = sum(p[f"b{i}"] * -np.expm1(-x / p[f"tau{i}"]) for i in range(k))
            return p["offset"] + p["gain"] * on * (1.0 + creep)
        params = lmfit.Parameters()
        params.add("offset", 0.0)
        params.add("gain", float(np.max(y) - np.min(y)))
        for i, tau in enumerate(np.geomspace(5.0, 1000.0, k)):
            params.add(f"b{i}", 0.02)
            params.add(f"tau{i}", float(tau), min=0.2, max=3e4)
        res = lmfit.minimize(lambda p: model(p, t) - y, params)
        if best is None or res.bic < best[0].bic:
            best = (res, k, model)
    res, k, model = best
    p = res.params
    order = np.argsort([p[f"tau{i}"].value for i in range(k)])
    pick = lambda key: np.array([p[f"{key}{i}"].value for i in order])
    err = lambda key: np.array([p[f"{key}{i}"].stderr or np.nan for i in order])
    return pick("b"), pick("tau"), (err("b"), err("tau")), lambda tt: model(p, tt)


def creepcomp_step(t, load, y, n_terms=None, initial="free"):
    """creepcomp: ``fit_prony`` from the record alone (``initial``: the creep state at the
    first sample, fitted by default). Returns (betas, taus, sigmas, predict)."""
    from creepcomp.fit import fit_prony, prepare, term_table
    from creepcomp.io.records import Record

    result = fit_prony(prepare(Record(t, load, y), initial=initial), n_terms=n_terms)
    fit = result.fit
    rows = term_table(fit)
    betas = np.array([r["beta"] for r in rows])
    taus = np.array([r["tau"] for r in rows])
    sig = (np.array([r["beta_sigma"] for r in rows]), np.array([r["tau_sigma"] for r in rows]))

    def predict(tt):
        step = np.where(tt >= STEP_AT, 1.0, 0.0)      # (the signal is not used: the load, to be valid)
        return fit.simulate(prepare(Record(tt, step, step), initial=result.data.initial))
    return betas, taus, sig, predict


TOOLS = {"creepcomp": lambda t, load, y, n=None: creepcomp_step(t, load, y, n),
         "creepcomp --initial relaxed": lambda t, load, y, n=None: creepcomp_step(t, load, y, n, "relaxed"),
         "lmfit": lambda t, load, y, n=None: lmfit_step(t, y, n_terms=n)}


def errors(betas, taus):
    """Largest relative error of beta and of tau over the terms (NaN: other number of terms)."""
    if len(betas) != len(BETAS):
        return float("nan"), float("nan")
    return (float(np.max(np.abs(betas / np.array(BETAS) - 1))),
            float(np.max(np.abs(taus / np.array(TAUS) - 1))))


def heldout_rms(tool, t, load, y) -> float:
    """Fitted on the first 70 %, RMS of the prediction of the rest, in noise units."""
    cut = int(0.7 * len(t))
    *_, predict = TOOLS[tool](t[:cut], load[:cut], y[:cut])
    pred = predict(t)
    return float(np.sqrt(np.mean((y[cut:] - pred[cut:]) ** 2)) / SIGMA)


COLD = """
import time, numpy as np, sys
sys.path.insert(0, {here!r})
import peers
t, load, y = peers.record(0)
peers.TOOLS[{tool!r}](t, load, y)
"""


def cold_seconds(tool: str) -> float:
    """Wall time of a fresh interpreter that imports the tool and fits one record."""
    import os
    here = os.path.dirname(os.path.abspath(__file__))
    start = time.perf_counter()
    subprocess.run([sys.executable, "-c", COLD.format(here=here, tool=tool)], check=True)
    return time.perf_counter() - start


def coverage(tool: str, seeds: int, phi: float) -> tuple[float, float, int]:
    """Share of |error| / stated sigma below 1 and below 2 over every beta and tau, over
    seeds (the number of terms fixed at the truth), and the number of estimates."""
    z = []
    for seed in range(seeds):
        t, load, y = record(100 + seed, phi)
        betas, taus, (sb, st), _ = TOOLS[tool](t, load, y, 3)
        z += list(np.abs(betas - np.array(BETAS)) / sb) + list(np.abs(taus - np.array(TAUS)) / st)
    z = np.array(z, float)
    return float(np.mean(z < 1)), float(np.mean(z < 2)), len(z)


def warm_seconds(t, load, y, repeat: int) -> dict:
    """Per tool, the least CPU time of ``repeat`` in-process fits (terms chosen, and 3 given)
    and the last fit's result. The tools take turns, so that the machine's other work falls on
    all of them alike."""
    for tool in TOOLS:
        TOOLS[tool](t, load, y)                          # warm up
    out = {tool: [float("inf"), float("inf"), None] for tool in TOOLS}
    for _ in range(repeat):
        for tool, run in TOOLS.items():
            start = time.process_time()
            out[tool][2] = run(t, load, y)
            middle = time.process_time()
            run(t, load, y, 3)
            out[tool][0] = min(out[tool][0], middle - start)
            out[tool][1] = min(out[tool][1], time.process_time() - middle)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--no-cold", action="store_true")
    ap.add_argument("--repeat", type=int, default=5, help="warm fits timed per tool, in turns (the least counts)")
    args = ap.parse_args(argv)
    t, load, y = record(0)
    print(f"record: step at {STEP_AT:g} s, beta {BETAS}, tau {TAUS} s, {len(t)} samples at 10 Hz, "
          f"white noise {SIGMA:g}")
    print(f"{'tool':28s} {'terms':>5s} {'beta err':>9s} {'tau err':>9s} {'held-out':>9s} "
          f"{'warm s':>8s} {'3 given':>8s} {'cold s':>8s} {'cover 1sd':>9s} {'cover 2sd':>9s}")
    timed = warm_seconds(t, load, y, args.repeat)
    for tool in TOOLS:
        warm, warm3, (betas, taus, _, _) = timed[tool]
        eb, et = errors(betas, taus)
        held = heldout_rms(tool, t, load, y)
        cold = float("nan") if args.no_cold else cold_seconds(tool)
        c1, c2, n = coverage(tool, args.seeds, 0.99)
        print(f"{tool:28s} {len(betas):5d} {eb:9.2%} {et:9.2%} {held:9.2f} {warm:8.2f} {warm3:8.2f} "
              f"{cold:8.2f} {c1:9.0%} {c2:9.0%}")
    print(f"warm: CPU seconds of one in-process fit choosing the terms (least of {args.repeat}); "
          "3 given: with 3 terms given; cold: wall seconds of a fresh interpreter (import and one fit)")
    print("held-out: RMS over the last 30 % when fitted on the first 70 %, in noise sigmas (1 = ideal); "
          "coverage: AR(1) noise phi 0.99, 3 terms, over "
          f"{args.seeds} seeds (ideal 68 % and 95 %)")


if __name__ == "__main__":
    main()
