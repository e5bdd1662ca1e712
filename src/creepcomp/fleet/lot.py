"""The lot seen as a whole: spread of the fitted parameters, outliers by a robust z-score,
how often each effect is found, units out of spec, and the units to look at first."""

from __future__ import annotations

import math
from collections import Counter

import numpy as np

__all__ = ["ROBUST_Z_LIMIT", "MIN_UNITS", "PARAMETERS", "robust_z", "dominant_tau", "lot_summary"]

#: A unit is an outlier in a parameter when its modified z-score (median and MAD) exceeds
#: this in magnitude (Iglewicz and Hoaglin's recommended 3.5).
ROBUST_Z_LIMIT = 3.5

#: Fewest units with a value before outliers are judged.
MIN_UNITS = 5

#: ``(label, column or key, unit, log scale, judged for outliers)`` of the parameters whose
#: spread is shown; ``tau_dominant`` is the retardation time of the term with the largest
#: |beta|. The creep figures are judged against the spec, not against the lot.
PARAMETERS = (
    ("gain", "gain", "signal/load", False, True),
    ("offset", "offset", "signal", False, True),
    ("beta0 (total creep)", "beta0", "", False, True),
    ("tau of the largest term", "tau_dominant", "s", True, True),
    ("creep of a step, uncorrected", "creep_step", "FS", False, False),
    ("residual creep after correction", "residual_creep", "FS", False, False),
)


def robust_z(values) -> np.ndarray:
    """Modified z-scores ``0.6745 (x - median) / MAD`` (NaN where a value is missing, and
    everywhere when the median absolute deviation is zero: no spread to judge against).

    Parameters
    ----------
    values : array_like of float (NaN for missing)
    """
    x = np.asarray(values, dtype=float)
    ok = np.isfinite(x)
    z = np.full(x.shape, np.nan)
    if ok.sum() == 0:
        return z
    med = np.median(x[ok])
    mad = np.median(np.abs(x[ok] - med))
    if mad > 0:
        z[ok] = 0.6745 * (x[ok] - med) / mad
    return z


def dominant_tau(row: dict) -> float | None:
    """Retardation time of the fitted term with the largest |beta| (None without terms)."""
    best, tau = -1.0, None
    k = 1
    while f"beta_{k}" in row:
        b, t = row.get(f"beta_{k}"), row.get(f"tau_{k}")
        if b is not None and t is not None and abs(b) > best:
            best, tau = abs(b), t
        k += 1
    return tau


def _value(row: dict, key: str, log: bool) -> float:
    v = dominant_tau(row) if key == "tau_dominant" else row.get(key)
    if v is None or not math.isfinite(v) or (log and v <= 0):
        return float("nan")
    return math.log10(v) if log else float(v)


def _common(values) -> str | None:
    """The one non-empty value of ``values``, or None (none, or several)."""
    seen = {v for v in values if v}
    return seen.pop() if len(seen) == 1 else None


def lot_summary(rows: list[dict], look_first: int = 20) -> dict:
    """What the lot report shows, computed from the table's rows.

    Parameters
    ----------
    rows : list of dict
        The results table as rows (``table.to_pylist()``).
    look_first : int
        Most units listed to look at first.

    Returns
    -------
    dict
        ``n``, ``ok``, ``failed`` (rows), ``effects`` (effect -> units, most frequent first,
        ``none`` included), ``parameters`` (label -> ``values``, ``median``, ``p5``, ``p95``,
        ``unit``, ``log``), ``outliers`` (unit, parameter, value, z; largest first),
        ``out_of_spec`` (rows, worst first), ``not_judged`` (ok rows whose spec verdict was
        not given), ``look_first`` (unit, reasons, row), ``z_limit`` and ``record_units``
        (``signal`` and ``load``: the unit every processed record gives, or None when they
        differ or none is given).
    """
    ok = [r for r in rows if r.get("status") == "ok"]
    failed = [r for r in rows if r.get("status") != "ok"]
    effects = Counter()
    for r in ok:
        names = [f for f in (r.get("findings") or "").split(",") if f]
        effects.update(names or ["none"])
    params, outliers = {}, []
    z_of: dict[str, dict[str, float]] = {}
    for label, key, unit, log, judged in PARAMETERS:
        vals = np.array([_value(r, key, log) for r in ok])
        finite = vals[np.isfinite(vals)]
        if finite.size == 0:
            continue
        shown = 10 ** finite if log else finite
        params[label] = {"key": key, "unit": unit, "log": log, "values": shown.tolist(),
                         "median": float(np.median(shown)), "p5": float(np.percentile(shown, 5)),
                         "p95": float(np.percentile(shown, 95))}
        if finite.size < MIN_UNITS or not judged:
            continue
        z = robust_z(vals)
        for r, zi, v in zip(ok, z, vals):
            if np.isfinite(zi) and abs(zi) > ROBUST_Z_LIMIT:
                value = 10 ** v if log else v
                outliers.append({"unit": r["unit"], "parameter": label, "value": float(value),
                                 "unit_of_value": unit, "z": float(zi)})
                z_of.setdefault(r["unit"], {})[label] = float(zi)
    outliers.sort(key=lambda o: -abs(o["z"]))
    out_of_spec = sorted((r for r in ok if r.get("in_spec") is False),
                         key=lambda r: -(r.get("residual_creep") or 0.0))
    not_judged = [r for r in ok if r.get("in_spec") is None]
    ranked = []
    for r in ok + failed:
        reasons, rank = [], None
        if r.get("in_spec") is False:
            reasons.append(f"out of spec: residual creep {r['residual_creep'] / r['spec']:.3g} x the limit")
            rank = (0, -r["residual_creep"] / r["spec"])
        if r.get("status") != "ok":
            reasons.append(f"failed: {r.get('error')}")
            rank = rank or (1, 0.0)
        if r["unit"] in z_of:
            worst = max(z_of[r["unit"]].items(), key=lambda kv: abs(kv[1]))
            reasons.append("outlier: " + ", ".join(f"{k} z = {v:+.1f}" for k, v in z_of[r["unit"]].items()))
            rank = rank or (2, -abs(worst[1]))
        if "unexplained" in (r.get("findings") or "").split(","):
            reasons.append("structure no named effect explains")
            rank = rank or (3, -(r.get("misfit_ratio_extended") or r.get("residual_rms_extended") or 0.0))
        if rank is not None:
            ranked.append((rank, r["unit"], reasons, r))
    ranked.sort(key=lambda x: (x[0], x[1]))
    return {"n": len(rows), "ok": len(ok), "failed": failed,
            "effects": dict(sorted(effects.items(), key=lambda kv: (-kv[1], kv[0]))),
            "parameters": params, "outliers": outliers, "out_of_spec": out_of_spec,
            "not_judged": not_judged, "z_limit": ROBUST_Z_LIMIT,
            "record_units": {k: _common(r.get(f"{k}_unit") for r in ok) for k in ("signal", "load")},
            "look_first": [{"unit": u, "reasons": reasons, "row": r}
                           for _, u, reasons, r in ranked[:look_first]]}
