"""What the diagnosis's extended model gains in the creep correction, per hidden effect.

For each sensor effect of the confusion benchmark (:mod:`benchmarks.diagnose_confusion`, the
records of :func:`creepcomp.synth.random_spec`), each record is diagnosed and corrected as
``creepcomp correct`` does with the two model files ``diagnose -o`` writes: the extended model
(``model.json``, every extension undone, :func:`creepcomp.diagnose.effects.compensate_extended`)
and the baseline (``baseline-model.json``, the digital correction). The start is relaxed when
the load starts at zero, settled otherwise; the load ramps between samples (the diagnosis's
reading of a record). Printed per effect: the median, lowest and highest correction-error
ratio (baseline / extended RMS error, the load scaled by least squares: the diagnosis's
figure, here in load units, so that two models of different gains compare), the same against
the model's own reference (``offset + gain * load``), the uncorrected signal's error over the
extended model's, the diagnosis's own figure, and the records the correction refused.

A baseline the model file refuses (``beta0 <= -1``: the correction ``1/G`` would have a pole
in the right half-plane) is not what a user corrects with. A delay of a few samples gives one
on every record: the one-term model's best likeness of ``exp(-s d)`` has a zero in the right
half-plane, like the first-order Pade all-pass ``(1 - s d/2) / (1 + s d/2)`` (gain ``-G``,
``beta = -2``): fitted, a negative instantaneous gain, ``beta`` -3 to -4.6 and ``tau`` 0.7 to
0.95 times the delay, the same with and without the step-time columns. Such a record is
compared with the best readable baseline instead (:func:`readable_baseline`: the same
one-term model restricted to ``beta > -1``; on a delay it is nearly a pure lag, a small
instantaneous gain and a large ``beta``, whose correction amplifies the noise by
``1 + beta``), and the row says how many records that was (``readable``).

A model with a ``time_offset`` knows the load at a sample from the signal up to ``latency``
seconds later: the load of the record's last ``latency`` seconds is not in it. Every error of
such a record (baseline, extended, uncorrected) is taken over the samples before that.

Usage::

    python benchmarks/correct_extensions.py [--per-effect 20] [--seed 0] [--max-samples 4000]
                                            [--effects a,b] [--jobs 1] [--json out.json]
    python benchmarks/correct_extensions.py --report out.json   # summary of a (partial) run
"""

from __future__ import annotations

import argparse
import json
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from creepcomp import synth
from creepcomp.diagnose.effects import compensate_extended, time_offset
from creepcomp.diagnose.sensor import DIAGNOSE_MAX_SAMPLES, diagnose
from creepcomp.fit.data import prepare
from creepcomp.fit.reduce import reduce_record
from creepcomp.fit.solver import Fit, fit_structure
from creepcomp.fit.starts import tau_grid
from creepcomp.fit.structure import Structure
from creepcomp.digital.correctors import compensate, creep_error, fitted_reference_error
from creepcomp.errors import InputError
from creepcomp.model import CreepModel


def load_unit_rms(values, load) -> float:
    """RMS error of ``values`` against the load scaled to them by least squares
    (:func:`~creepcomp.digital.correctors.fitted_reference_error`), in load units: divided by
    the fitted scale, so that models of different gains compare (a corrected signal is
    ``offset + gain * load`` in the model's own gain)."""
    err = fitted_reference_error(values, load)
    scale = np.ptp(np.asarray(values) - err) / np.ptp(load)
    return float(np.sqrt(np.mean(err ** 2))) / scale if scale > 0 else float("inf")


def corrected_errors(record, model: CreepModel, known: int | None = None) -> tuple[float, float]:
    """RMS error of the corrected signal over the first ``known`` samples (default all), in
    load units: against the load scaled by least squares, and against the model's reference
    ``offset + gain * load``."""
    initial = "relaxed" if record.load[0] == 0 else "settled"
    if model.extensions:
        comp = compensate_extended(record.time, record.signal, model, record.temperature,
                                   initial=initial, hold="linear", strict=True)
    else:
        comp = compensate(record.time, record.signal, model, "subtractive", initial=initial,
                          hold="linear")
    n = len(record) if known is None else known
    own = creep_error(record.time[:n], comp[:n], record.load[:n], model).rms / abs(model.gain)
    return load_unit_rms(comp[:n], record.load[:n]), own


def known_samples(record, model: CreepModel) -> int:
    """Samples whose load the model's correction can know: a signal read later than the load
    (:func:`~creepcomp.diagnose.effects.time_offset.latency`) leaves the load of the record's
    last ``latency`` seconds out of it, whatever the correction."""
    entry = (model.extensions or {}).get(time_offset.EFFECT.name)
    if not entry:
        return len(record)
    end = record.time[-1] - time_offset.latency(entry)
    return max(int(np.searchsorted(record.time, end, side="right")), 2)


def _readable(fit: Fit) -> bool:
    return fit.gain != 0 and np.all(np.isfinite(fit.betas)) and float(np.sum(fit.betas)) > -1.0


def readable_baseline(record, per_decade: float = 12.0) -> CreepModel | None:
    """The best one-term baseline a model file accepts (``beta > -1``), on the record as the
    diagnosis sees it (reduced, free initial state): each retardation time of a fine grid with
    the initial state fitted, the best readable one refined when it stays readable. None when
    no grid time gives a readable model."""
    reduced, _ = reduce_record(record, DIAGNOSE_MAX_SAMPLES)
    data = prepare(reduced, initial="free")
    structure = Structure(1)
    best = None
    for tau in tau_grid(data, per_decade=per_decade):
        fit = fit_structure(data, structure, [{}], frozen={"tau[0]": float(tau)}, n_refine=1,
                            with_cov=False)
        if _readable(fit) and (best is None or fit.residual_rms < best.residual_rms):
            best = fit
    if best is None:
        return None
    refined = fit_structure(data, structure, [dict(best.values)], n_refine=1, with_cov=False)
    if _readable(refined) and refined.residual_rms < best.residual_rms:
        best = refined
    return CreepModel((float(best.betas[0]),), (float(best.taus[0]),), best.gain, best.offset)


def run_one(effect: str, seed: int, max_samples: int) -> dict:
    spec = synth.random_spec(effect, seed, max_samples=max_samples)
    syn = synth.generate(spec)
    t0 = time.perf_counter()
    d = diagnose(syn.record)
    out = {"effect": effect, "seed": seed, "cause": d.cause, "n": len(syn.record),
           "extensions": sorted(d.extended_model.get("extensions") or {}),
           "diagnosis_ratio": d.gain.get("correction_error_ratio")}
    try:
        base = CreepModel.from_dict(d.baseline_model, where="baseline model")
    except InputError as exc:
        # a baseline term standing in for another effect (an all-pass of beta below -1 for a
        # delay) makes the file unreadable: the best readable baseline in its place
        out["baseline_unreadable"] = str(exc)
        base = readable_baseline(syn.record)
        if base is not None:
            out["readable_baseline"] = {"beta": base.beta[0], "tau": base.tau[0], "gain": base.gain}
    try:
        ext = CreepModel.from_dict(d.extended_model, where="extended model")
        known = known_samples(syn.record, ext)
        if known < len(syn.record):
            out["compared_samples"] = known
        e_fit, e_ref = corrected_errors(syn.record, ext, known)
        b_fit, b_ref = corrected_errors(syn.record, base, known) if base is not None else (None, None)
    except InputError as exc:
        out["refused"] = str(exc)
        return out
    if b_fit is None:
        return out
    raw = load_unit_rms(syn.record.signal[:known], syn.record.load[:known])
    out.update(ratio=b_fit / e_fit if e_fit > 0 else None, ratio_reference=b_ref / e_ref if e_ref > 0 else None,
               ratio_uncorrected=raw / e_fit if e_fit > 0 else None, seconds=time.perf_counter() - t0)
    return out


def summary(rows: list[dict]) -> None:
    """One line per effect: ratios (baseline / extended RMS error), records refused, and the
    records whose diagnosis baseline the model file refuses (compared with the readable one)."""
    print(f"{'effect':30s} {'n':>3s} {'median':>7s} {'lowest':>7s} {'highest':>7s} {'med.ref':>7s} "
          f"{'raw':>7s} {'diag.':>7s} {'refused':>7s} {'readable':>8s}")
    for effect in dict.fromkeys(r["effect"] for r in rows):
        mine = [r for r in rows if r["effect"] == effect]
        ratios = [r["ratio"] for r in mine if r.get("ratio") is not None]
        refs = [r["ratio_reference"] for r in mine if r.get("ratio_reference") is not None]
        diag = [r["diagnosis_ratio"] for r in mine if r.get("diagnosis_ratio") is not None]
        raw = [r["ratio_uncorrected"] for r in mine if r.get("ratio_uncorrected") is not None]
        refused = sum("refused" in r for r in mine)
        unreadable = sum("baseline_unreadable" in r for r in mine)
        readable = sum("readable_baseline" in r for r in mine)
        figures = (f"{np.median(ratios):7.3f} {min(ratios):7.3f} {max(ratios):7.3f} {np.median(refs):7.3f} "
                   f"{np.median(raw):7.3f}" if ratios else " ".join(f"{'-':>7s}" for _ in range(5)))
        line = (f"{effect:30s} {len(mine):3d} {figures} "
                f"{np.median(diag) if diag else float('nan'):7.3f} {refused:7d} {readable:4d}/{unreadable:<3d}")
        if unreadable:
            line += ("  (the diagnosis's baseline has beta0 <= -1 on this many records: compared "
                     "with the best readable one-term baseline, beta > -1)")
        print(line)
    print("ratios: baseline RMS error / extended RMS error of the corrected signal (1 = no gain); "
          "med.ref: the same against the model's own reference; raw: the uncorrected signal's error / "
          "the extended correction's; readable: records compared with the readable baseline / records whose baseline file "
          "is refused")


def _task(args) -> dict:
    effect, seed, max_samples = args
    try:
        return run_one(effect, seed, max_samples)
    except Exception as exc:  # noqa: BLE001 - a benchmark reports every failure and goes on
        return {"effect": effect, "seed": seed, "error": f"{type(exc).__name__}: {exc}"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--per-effect", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--max-samples", type=int, default=4000)
    ap.add_argument("--effects", default=None)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--json", default=None)
    ap.add_argument("--report", default=None, metavar="JSON", help="only summarise a saved run")
    args = ap.parse_args()
    if args.report:
        with open(args.report) as fh:
            summary(json.load(fh))
        return
    effects = args.effects.split(",") if args.effects else [e for e in synth.EFFECTS]
    # round-robin over the effects: an interrupted run is balanced
    tasks = [(effect, args.seed + k, args.max_samples) for k in range(args.per_effect) for effect in effects]
    rows = []
    with ProcessPoolExecutor(args.jobs) if args.jobs > 1 else _Serial() as pool:
        for row in pool.map(_task, tasks):
            rows.append(row)
            print(json.dumps(row), flush=True)
            if args.json:
                with open(args.json, "w") as fh:
                    json.dump(rows, fh)
    summary(rows)


class _Serial:
    """In-process stand-in for a process pool (``--jobs 1``)."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def map(self, fn, items):
        return map(fn, items)


if __name__ == "__main__":
    main()
