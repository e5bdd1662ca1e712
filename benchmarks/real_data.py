"""Fit and diagnose the measured records shipped in ``creepcomp.data`` (others' data, with
their licences): the two insole taxels and the spruce creep at both load levels.

Prints one markdown table per record: the verdict and findings of ``diagnose``, the baseline
and extended residual RMS, the misfit ratios, noise floor and explained share (where the
diagnosis reports them), the held-out RMS ratio, the correction-error ratio and the seconds;
the model ``fit`` chooses by evidence; and a table of ``fit`` over all shipped spruce
specimens (creep at two load levels). The figures in ``docs/real-data.md`` come from here;
with ``--images DIR`` also each record's residual against time with the noise floor
(``real-<record>-residual.png``, the plot of the diagnosis report).

Usage::

    python benchmarks/real_data.py [--records insole_left,insole_right,wood_0.3,wood_0.5] [--images docs/images]
"""

from __future__ import annotations

import argparse
import base64
import os
import time
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")  # the plots go to files

from creepcomp import data
from creepcomp.diagnose.sensor import diagnose
from creepcomp.fit import fit_prony, prepare, term_table
from creepcomp.fit.noise import FEW_WINDOWS
from creepcomp.units import format_quantity

RECORDS = {
    "insole_left": ("left insole, taxel 128, pressure staircase", data.insole_left_steps, None),
    "insole_right": ("right insole, taxel 123, 0.2 bar staircase", data.insole_right_staircase, None),
    "wood_0.3": ("spruce LR, 90 % RH, loading degree 0.3", lambda: data.wood_creep(0.3), 0.0),
    "wood_0.5": ("spruce LR, 90 % RH, loading degree 0.5", lambda: data.wood_creep(0.5), 0.0),
}


def _num(x, unit="", digits=3):
    if x is None:
        return "not reported"
    return f"{x:.{digits}g} {unit}".strip()


def _params(f: dict) -> str:
    p = ", ".join(f"{k} = {v:.3g}" if isinstance(v, (int, float)) else f"{k} = {v}"
                  for k, v in f.get("parameters", {}).items())
    return f"`{f['effect']}` ({p})" if p else f"`{f['effect']}`"


def record_table(key: str, images: Path | None = None) -> None:
    title, load, step = RECORDS[key]
    record = load()
    su = record.unit("signal")
    t0 = time.perf_counter()
    prony = fit_prony(prepare(record, load_step_at=step))
    fit_s = time.perf_counter() - t0
    terms = term_table(prony.fit)
    gain = prony.fit.estimate(lambda v: v["gain"])[0]
    t0 = time.perf_counter()
    result = diagnose(record, load_step_at=step)
    diag_s = time.perf_counter() - t0
    d = result.to_dict()
    if images is not None:
        _residual_image(result, record, images / f"real-{key.replace('_', '-')}-residual.png")
    b, e, g = d["baseline"], d["extended"], d["gain"]
    spread = _floor_spread(result) if result.floor is not None and result.floor.rough else None
    rows = [
        ("record", f"{record.source.split('/')[-1]}: {len(record)} samples over "
                   f"{format_quantity(record.duration, 's')}"),
        ("`fit` (terms by evidence)", f"{len(terms)} term(s), gain {gain:.4g} {su}/{record.unit('load')}; "
         + "; ".join(f"beta = {t['beta']:+.3g}, tau = {format_quantity(t['tau'], 's')}" for t in terms)
         + f"; residual {prony.fit.residual_rms / prony.data.signal_scale:.2%} of range ({fit_s:.1f} s)"),
        ("verdict (cause)", f"`{d['cause']}`"),
        ("findings", "; ".join(_params(f) for f in d["findings"]) or "none"),
        *((f"note on `{f['effect']}`", f["note"]) for f in d["findings"] if f.get("note")),
        ("baseline residual RMS", f"{_num(b['residual_rms'], su)} ({b['residual_rms_relative']:.2%} of range), "
                                  f"lag-1 autocorrelation {b.get('residual_lag1_autocorrelation', float('nan')):.3f}"),
        ("extended residual RMS", f"{_num(e['residual_rms'], su)} ({e['residual_rms_relative']:.2%} of range)"),
        ("noise floor", f"{_num(d.get('noise_floor'), su)}"
                        + (f" ({d['noise_floor_method']})" if d.get("noise_floor_method") else "")),
        ("noise floor windows", f"{d.get('noise_floor_windows')}"
                                + (f" (rough: fewer than {FEW_WINDOWS})"
                                   if (d.get("noise_floor_windows") or 0) < FEW_WINDOWS else "")),
        *((("rough floor: 5 / 50 / 95 % of floor / true noise on this sampling",
            " / ".join(f"{q:.2f}" for q in spread)
            + f" ({FLOOR_DRAWS} records: the fitted baseline plus white noise at the floor, same sample times)"),)
          if spread is not None else ()),
        *((("readout (full record): held values and scatter", _readout(record)),) if key.startswith("insole") else ()),
        ("misfit ratio, baseline / extended", f"{_num(b.get('misfit_ratio'))} / {_num(e.get('misfit_ratio'))}"),
        ("explained share", _num(d.get("explained_share"))),
        ("held-out RMS ratio", _num(g.get("heldout_rms_ratio"))),
        ("correction-error ratio", _num(g.get("correction_error_ratio"))),
        ("seconds (diagnose)", f"{diag_s:.1f}"),
    ]
    print(f"\n### {title}\n\n| | |\n|---|---|")
    for k, v in rows:
        print(f"| {k} | {v} |")


def _readout(record) -> str:
    """How the signal is read: the share of successive samples that are equal, the mean run
    of one value, and the scatter of differences ``k`` samples apart (/ sqrt 2): flat from
    ``k = 2`` on while ``k = 1`` is lower is white noise held for a few samples."""
    import numpy as np

    y, su = record.signal, record.unit("signal")
    d = np.diff(y)
    runs = np.diff(np.flatnonzero(np.concatenate([[True], d != 0, [True]])))
    held = np.diff(record.time[np.flatnonzero(d != 0)])
    scatter = {k: float(np.std(y[k:] - y[:-k]) / np.sqrt(2)) for k in (1, 2, 4, 8, 16, 32, 64)}
    return (f"{np.mean(d == 0):.0%} of successive samples equal, a value held {runs.mean():.2f} samples on "
            f"average (changes every {np.median(held) * 1e3:.0f} ms at the median); scatter of "
            "differences k samples apart / sqrt 2: "
            + ", ".join(f"k = {k}: {v:.2f}" for k, v in scatter.items()) + f" {su}")


#: Synthetic records drawn to show how far a rough noise floor can be from the true noise.
FLOOR_DRAWS = 400


def _floor_spread(result) -> tuple[float, float, float]:
    """5, 50 and 95 % points of the noise floor over the true noise on records sampled like this
    one: its fitted baseline plus white noise of the floor's RMS."""
    import numpy as np

    from creepcomp.fit.noise import noise_floor

    data, true = result.data, result.floor.rms
    rng = np.random.default_rng(0)
    ratios = [noise_floor(result.baseline.prediction + rng.normal(0.0, true, data.n), data.load, data.time).rms / true
              for _ in range(FLOOR_DRAWS)]
    return tuple(float(q) for q in np.percentile(ratios, [5, 50, 95]))


def _residual_image(result, record, path: Path) -> None:
    """The report's plot of the residual against time (with the noise floor) as a PNG file."""
    from creepcomp.report.diagnosis import diagnosis_figures

    units = {"signal": record.unit("signal"), "load": record.unit("load")}
    png = dict(diagnosis_figures(result, units))["Residual (measured minus simulated) against time"]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(base64.b64decode(png))


def wood_fits() -> None:
    print("\n### `fit` on every shipped spruce specimen (load step at t = 0)\n")
    print("| specimen | loading degree | stress (MPa) | terms | beta (sum) | tau | residual (% of range) | "
          "creep strain at 50 h / stress (1/MPa) |")
    print("|---|---|---|---|---|---|---|---|")
    for level in (0.3, 0.5):
        for name in data.wood_specimens(level):
            r = data.wood_creep(level, name)
            stress = float(r.load[0])
            try:
                p = fit_prony(prepare(r, load_step_at=0.0))
            except Exception as exc:  # a refused record is a result here
                print(f"| {name} | {level} | {stress:.1f} | refused: {exc} | | | | |")
                continue
            terms = term_table(p.fit)
            creep50 = _creep_at(p, 50 * 3600.0) / stress
            print(f"| {name} | {level} | {stress:.1f} | {len(terms)} | {sum(t['beta'] for t in terms):+.3f} | "
                  + ", ".join(format_quantity(t["tau"], "s") for t in terms)
                  + f" | {p.fit.residual_rms / p.data.signal_scale:.2%} | {creep50:.3g} |")


def _creep_at(p, t: float) -> float:
    """Creep strain of the fitted model at time ``t`` after the step (signal minus its value at
    the step)."""
    import numpy as np

    terms = term_table(p.fit)
    gain = p.fit.estimate(lambda v: v["gain"])[0]
    load = float(p.data.load[0])
    return float(sum(gain * load * tt["beta"] * -np.expm1(-t / tt["tau"]) for tt in terms))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--records", default=",".join(RECORDS))
    ap.add_argument("--images", type=Path, default=None, help="folder for the residual plots")
    args = ap.parse_args(argv)
    print(f"load average before: {os.getloadavg()[0]:.2f}")
    for key in [k.strip() for k in args.records.split(",") if k.strip()]:
        record_table(key, args.images)
    wood_fits()


if __name__ == "__main__":
    main()
