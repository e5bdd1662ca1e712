"""What the diagnosis's extended model gains in the creep correction, per hidden effect.

For each sensor effect of the confusion benchmark (:mod:`benchmarks.diagnose_confusion`, the
records of :func:`creepcomp.synth.random_spec`), each record is diagnosed and corrected as
``creepcomp correct`` does with the two model files ``diagnose -o`` writes: the extended model
(``model.json``, every extension undone, :func:`creepcomp.diagnose.effects.compensate_extended`)
and the baseline (``baseline-model.json``, the digital correction). The start is relaxed when
the load starts at zero, settled otherwise; the load ramps between samples (the diagnosis's
reading of a record). Printed per effect: the median, lowest and highest correction-error
ratio (baseline / extended RMS error, the load scaled by least squares: the diagnosis's
figure), the same against the model's own reference (``offset + gain * load``), and the
records the correction refused.

Usage::

    python benchmarks/correct_extensions.py [--per-effect 20] [--seed 0] [--max-samples 4000]
                                            [--effects a,b] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from creepcomp import synth
from creepcomp.diagnose.effects import compensate_extended
from creepcomp.diagnose.sensor import diagnose
from creepcomp.digital.correctors import compensate, creep_error, fitted_reference_error
from creepcomp.errors import InputError
from creepcomp.model import CreepModel


def corrected_errors(record, model: CreepModel) -> tuple[float, float]:
    """RMS error of the corrected signal: against the load scaled by least squares, and
    against the model's reference (signal units)."""
    initial = "relaxed" if record.load[0] == 0 else "settled"
    if model.extensions:
        comp = compensate_extended(record.time, record.signal, model, record.temperature,
                                   initial=initial, hold="linear", strict=True)
    else:
        comp = compensate(record.time, record.signal, model, "subtractive", initial=initial,
                          hold="linear")
    fitted = float(np.sqrt(np.mean(fitted_reference_error(comp, record.load) ** 2)))
    return fitted, creep_error(record.time, comp, record.load, model).rms


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
        # a baseline term standing in for another effect (a fast term of beta below -1 for a
        # delay) makes the file unreadable: no baseline correction to compare with
        out["baseline_unreadable"] = str(exc)
        base = None
    try:
        ext = CreepModel.from_dict(d.extended_model, where="extended model")
        e_fit, e_ref = corrected_errors(syn.record, ext)
        b_fit, b_ref = corrected_errors(syn.record, base) if base is not None else (None, None)
    except InputError as exc:
        out["refused"] = str(exc)
        return out
    if b_fit is None:
        return out
    out.update(ratio=b_fit / e_fit if e_fit > 0 else None, ratio_reference=b_ref / e_ref if e_ref > 0 else None,
               seconds=time.perf_counter() - t0)
    return out


def summary(rows: list[dict]) -> None:
    print(f"{'effect':30s} {'n':>3s} {'median':>7s} {'lowest':>7s} {'highest':>7s} {'med.ref':>7s} "
          f"{'diag.':>7s} refused")
    for effect in dict.fromkeys(r["effect"] for r in rows):
        mine = [r for r in rows if r["effect"] == effect]
        ratios = [r["ratio"] for r in mine if r.get("ratio") is not None]
        refs = [r["ratio_reference"] for r in mine if r.get("ratio_reference") is not None]
        diag = [r["diagnosis_ratio"] for r in mine if r.get("diagnosis_ratio") is not None]
        refused = sum("refused" in r for r in mine)
        unreadable = sum("baseline_unreadable" in r for r in mine)
        if not ratios:
            print(f"{effect:30s} {len(mine):3d} {'-':>7s} {'-':>7s} {'-':>7s} {'-':>7s} {'-':>7s} {refused}")
            continue
        print(f"{effect:30s} {len(mine):3d} {np.median(ratios):7.3f} {min(ratios):7.3f} {max(ratios):7.3f} "
              f"{np.median(refs):7.3f} {np.median(diag) if diag else float('nan'):7.3f} {refused} ({unreadable} baseline files unreadable)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--per-effect", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--max-samples", type=int, default=4000)
    ap.add_argument("--effects", default=None)
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    effects = args.effects.split(",") if args.effects else [e for e in synth.EFFECTS]
    rows = []
    for k in range(args.per_effect):
        for effect in effects:
            rows.append(run_one(effect, args.seed + k, args.max_samples))
            print(json.dumps(rows[-1]), flush=True)
            if args.json:
                with open(args.json, "w") as fh:
                    json.dump(rows, fh)
    summary(rows)


if __name__ == "__main__":
    main()
