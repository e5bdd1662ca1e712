"""How well the load comes back from a sensor's reading, held out: each model is fitted on the
first 60 % of a record's time and gives the load on the last 40 %; the error is the RMS of
(estimate - measured load) over that part, in percent of the load's range over the whole
record.

Side by side, per record:

- **static line**: a least-squares line of load against signal (numpy);
- **static monotone**: a monotone calibration curve of load against signal
  (``sklearn.isotonic.IsotonicRegression``, increasing or decreasing as the training part's
  correlation says, clipped outside the trained signal range);
- **NARX**: the black-box peer (``sysidentpy``): a degree-2 polynomial of lagged load and
  signal, terms selected by FROLS (AIC), output = load, input = signal (its lag 1 being the
  signal at the load's own sample), the lags chosen among :data:`NARX_LAGS` on the training part (fitted on its first 70 %, free-run simulated, compared on its last 30 %), then
  refitted on the whole training part and free-run simulated over the record. Records of more
  than :data:`NARX_SAMPLES` samples are averaged in blocks for it (its estimate is interpolated
  between the blocks' centres);
- **baseline**: what ``creepcomp fit`` + ``creepcomp correct`` give today
  (:func:`creepcomp.fit.data.prepare`, :func:`creepcomp.fit.prony.fit_prony`, then
  :func:`creepcomp.digital.correctors.compensate` with ``correct``'s defaults); the load is
  ``(compensated - offset) / gain``;
- **recommended**: the model ``creepcomp diagnose`` recommends from the training part
  (:func:`recommended_estimate`: :func:`creepcomp.diagnose.recommend.recommend`), its load by
  its whole inverse (:func:`creepcomp.diagnose.recommend.model_load`).

A creepcomp call that raises gives ``failed: <reason>`` in its cell. For each record the model
files creepcomp would write (the baseline's as ``fit`` writes it, the recommended one as
``diagnose`` writes ``model.json``) are read back and checked as ``correct`` does
(:func:`creepcomp.diagnose.recommend.usable`) and as ``firmware`` does
(:func:`creepcomp.digital.firmware.generate_firmware`): a refusal is counted, naming the command.

Records: the shipped insole taxels (``creepcomp.data``), taxels of insole ``.mat`` files given
with ``--insole`` (``--taxels``: numbers, or ``best:N`` for the N that follow the pressure best),
record files given with ``--record`` (``--columns`` maps their columns, as for ``creepcomp fit``)
and ``--soft`` generated soft-sensor records (:mod:`creepcomp.synth.soft`, every kind in turn).

Usage::

    python benchmarks/real_load_error.py [--quick] [--soft 42] [--insole FILE.mat ...]
        [--taxels best:2] [--record FILE ... [--columns MAP]] [--json] [--plots DIR]

``--quick`` runs 12 generated records of at most 2000 samples and shorter NARX searches
(about a minute on one core).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")  # the plots go to files

import numpy as np

from creepcomp.errors import InputError
from creepcomp.io.records import Record
from creepcomp.synth.soft import MAX_SOFT_SAMPLES

#: Share of the record's time the models are fitted on (the rest is held out).
TRAIN_FRACTION = 0.6
#: Columns of the table, in order.
METHODS = ("static line", "static monotone", "NARX", "baseline", "recommended")
#: The NARX peer runs on at most this many samples (block means of longer records).
NARX_SAMPLES = 6000
#: Lags (output, input) the NARX peer chooses among on its training part; no output lag is a
#: polynomial of the lagged signal alone (sysidentpy's NFIR), which cannot diverge.
NARX_LAGS = ((0, 1), (0, 4), (0, 8), (1, 1), (2, 2), (1, 4), (4, 4))
#: Generated records of a run, and of a ``--quick`` one.
SOFT_COUNT, QUICK_SOFT_COUNT = 42, 12
#: Most samples of a generated record in a ``--quick`` run (otherwise the generator's default).
QUICK_SAMPLES = 2000
#: What ``--quick`` changes in the NARX peer: at most QUICK_SAMPLES samples, fewer lags and AIC values.
QUICK_NARX = {"most": QUICK_SAMPLES, "lags": ((0, 1), (0, 4), (1, 1), (2, 2)), "info_values": 8}
#: Share of the training part the NARX lag choice is fitted on (the rest validates it).
NARX_VALIDATION_SPLIT = 0.7
NOT_AVAILABLE = "n/a (not available)"


@dataclass
class Cell:
    """One method's outcome on one record."""

    error: float | None = None        # % of the load range
    seconds: float = 0.0
    note: str = ""                    # "failed: ...", "n/a (not available)"
    estimate: np.ndarray | None = field(default=None, repr=False)

    def text(self) -> str:
        if self.error is None:
            return self.note
        return f"{self.error:.3g} % ({self.seconds:.1f} s)"


@dataclass
class Outcome:
    """A record's cells and its model files' fate."""

    name: str
    samples: int
    cells: dict
    refused: dict                     # method -> reason (str) or None (accepted) for written files
    truth: dict | None = None         # a generated record's drawn parameters


# --------------------------------------------------------------------------------------------
# The protocol
# --------------------------------------------------------------------------------------------

def split_index(record: Record, fraction: float = TRAIN_FRACTION) -> int:
    """Index of the first held-out sample: the first at or after ``fraction`` of the time."""
    k = int(np.searchsorted(record.time, record.time[0] + fraction * record.duration))
    if not 2 <= k <= len(record) - 2:
        raise InputError(f"{record.source}: too few samples ({len(record)}) to hold out "
                         f"{1 - fraction:.0%} of the record")
    return k


def check_record(record: Record) -> None:
    """Refuse a record the protocol cannot score: a load that never changes (no range to scale
    the error by) or too few samples to split."""
    if not np.ptp(record.load) > 0:
        raise InputError(f"{record.source}: the load does not change over the record, so there is "
                         "no load range to give the error in (a creep test at one load?)")
    split_index(record)


def training_part(record: Record, k: int) -> Record:
    """The first ``k`` samples as a record of their own."""
    return Record(record.time[:k], record.load[:k], record.signal[:k], metadata=dict(record.metadata),
                  source=f"{record.source} (first {TRAIN_FRACTION:.0%})")


def heldout_error(record: Record, estimate: np.ndarray, k: int) -> float:
    """RMS of ``estimate - load`` over samples ``k:`` in % of the whole record's load range."""
    span = float(np.ptp(record.load))
    e = np.asarray(estimate, float)[k:] - record.load[k:]
    if not np.all(np.isfinite(e)):
        raise FloatingPointError("the estimate is not finite on the held-out part")
    return 100.0 * float(np.sqrt(np.mean(e ** 2))) / span


# --------------------------------------------------------------------------------------------
# The methods: each gives the load estimate over the whole record from the training part
# --------------------------------------------------------------------------------------------

def static_line(record: Record, k: int, extra: dict) -> np.ndarray:
    slope, intercept = np.polyfit(record.signal[:k], record.load[:k], 1)
    return intercept + slope * record.signal


def static_monotone(record: Record, k: int, extra: dict) -> np.ndarray:
    from sklearn.isotonic import IsotonicRegression

    x, y = record.signal[:k], record.load[:k]
    increasing = bool(np.corrcoef(x, y)[0, 1] >= 0) if np.ptp(x) > 0 else True
    iso = IsotonicRegression(increasing=increasing, out_of_bounds="clip").fit(x, y)
    return iso.predict(record.signal)


def _blocks(n: int, most: int) -> int:
    return max(1, math.ceil(n / most))


def _block_means(x: np.ndarray, q: int) -> np.ndarray:
    m = len(x) // q * q
    head = x[:m].reshape(-1, q).mean(axis=1)
    return np.concatenate([head, [x[m:].mean()]]) if m < len(x) else head


def _narx_fit(x: np.ndarray, y: np.ndarray, lags: tuple[int, int], info_values: int):
    from sysidentpy.basis_function import Polynomial
    from sysidentpy.model_structure_selection import FROLS
    from sysidentpy.parameter_estimation import LeastSquares

    model = FROLS(order_selection=True, n_info_values=info_values, ylag=max(lags[0], 1), xlag=lags[1],
                  info_criteria="aic", estimator=LeastSquares(), basis_function=Polynomial(degree=2),
                  model_type="NARMAX" if lags[0] else "NFIR")
    with warnings.catch_warnings():
        # (the number of AIC values is capped at the regressors there are, with a warning)
        warnings.filterwarnings("ignore", "n_info_values is greater", UserWarning)
        model.fit(X=x[:, None], y=y[:, None])
    return model


def _narx_run(model, x: np.ndarray, y_start: np.ndarray) -> np.ndarray:
    """Free-run simulation over ``x`` from the measured outputs ``y_start`` (max-lag samples)."""
    y0 = np.zeros((len(x), 1))
    y0[:len(y_start), 0] = y_start
    with np.errstate(all="ignore"):
        return np.asarray(model.predict(X=x[:, None], y=y0), float).ravel()


def _rms(a: np.ndarray, b: np.ndarray) -> float:
    with np.errstate(all="ignore"):
        value = float(np.sqrt(np.mean((a - b) ** 2)))
    return value if math.isfinite(value) else math.inf


def narx(record: Record, k: int, extra: dict, most: int = NARX_SAMPLES, lags=NARX_LAGS,
         info_values: int = 12) -> np.ndarray:
    """The NARX peer's estimate (see the module's docstring); its chosen lags go to ``extra``.

    Each lag choice is fitted on the first 70 % of the training part and free-run over the
    training part, then refitted on the whole training part and free-run over it again; its
    score is the larger of the RMS on the last 30 % (held out from the first fit) and the
    refitted model's over the whole training part (a refit that drifts away is not chosen)."""
    q = _blocks(len(record), most)
    x, y = _block_means(record.signal, q), _block_means(record.load, q)
    kb = k // q
    # scaled on the training part (FROLS's regressors stay well conditioned)
    xm, xs = x[:kb].mean(), x[:kb].std() or 1.0
    ym, ys = y[:kb].mean(), y[:kb].std() or 1.0
    # sysidentpy's input lags start at 1: the input advanced by one sample makes lag 1 the
    # signal at the load's own sample, as the static calibrations read it
    xn, yn = (np.append(x[1:], x[-1]) - xm) / xs, (y - ym) / ys
    fit_to = int(NARX_VALIDATION_SPLIT * kb)
    best, chosen = math.inf, None
    for lag in lags:
        if fit_to <= 10 * (max(lag) + 1):
            continue
        try:
            model = _narx_fit(xn[:fit_to], yn[:fit_to], lag, info_values)
            held = _rms(_narx_run(model, xn[:kb], yn[:model.max_lag])[fit_to:], yn[fit_to:kb])
            if held >= best:
                continue
            model = _narx_fit(xn[:kb], yn[:kb], lag, info_values)
            score = max(held, _rms(_narx_run(model, xn[:kb], yn[:model.max_lag]), yn[:kb]))
        except (np.linalg.LinAlgError, ValueError):
            continue
        if score < best:
            best, chosen = score, (lag, model)
    if chosen is None:
        raise RuntimeError("no lag choice gave a finite simulation on the training part")
    lag, model = chosen
    extra.update(lags=lag, block=q)
    sim = _narx_run(model, xn, yn[:model.max_lag]) * ys + ym
    if q == 1:
        return sim
    centres = _block_means(record.time, q)
    return np.interp(record.time, centres, sim)


def baseline(record: Record, k: int, extra: dict) -> np.ndarray:
    """``fit`` + ``correct`` of today: the model file ``fit`` writes, the load from the
    compensated signal."""
    from creepcomp.digital.correctors import compensate
    from creepcomp.fit.data import prepare
    from creepcomp.fit.prony import fit_prony

    result = fit_prony(prepare(training_part(record, k)))
    extra["file"] = result.to_dict()
    model = result.model()
    compensated = compensate(record.time, record.signal, model)
    return (compensated - model.offset) / model.gain


def recommended_estimate(train: Record, record: Record, extra: dict):
    """The model ``creepcomp diagnose`` recommends (and writes as ``model.json``) for ``train``
    (its file put in ``extra["file"]``: it is read back and checked), and the load it gives over
    ``record`` (its whole inverse: static maps and extensions included)."""
    from creepcomp.diagnose.recommend import model_load, recommend
    from creepcomp.diagnose.sensor import diagnose
    from creepcomp.model import CreepModel

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        chosen = recommend(train, diagnose(train))
        extra["file"] = chosen.model
        extra["chosen"] = chosen.chosen
        with np.errstate(all="ignore"):
            return model_load(CreepModel.from_dict(chosen.model), record.time, record.signal)


def recommended(record: Record, k: int, extra: dict) -> np.ndarray:
    return np.asarray(recommended_estimate(training_part(record, k), record, extra), float)


def model_file_refusal(method: str, extra: dict | None, folder: Path, record: Record) -> str | None:
    """Write the method's model file, read it back and check it as ``correct`` does and as
    ``firmware`` does (at the record's median sample rate, over its signal's range): the
    reasons it is refused (naming the command), or None."""
    from creepcomp.diagnose.recommend import usable
    from creepcomp.digital.firmware import generate_firmware
    from creepcomp.io.jsonfiles import read_json, read_model, write_json

    path = folder / f"{method}.json"
    reasons = []
    try:
        write_json(path, extra["file"])
        why = usable(read_json(path, "model file"))
        if why is not None:
            reasons.append(f"correct: {why}")
        else:
            model = read_model(path)
            rate = 1.0 / float(np.median(np.diff(record.time)))
            low, high = float(np.min(record.signal)), float(np.max(record.signal))
            full_scale = ((low, high) if model.transfer is not None or model.is_static
                          else max(abs(low - model.offset), abs(high - model.offset)) or 1.0)
            generate_firmware(model, rate=rate, full_scale=full_scale)
    except Exception as exc:            # any refusal, worded by creepcomp
        reasons.append(("firmware: " if not reasons else "") + _reason(exc).replace(str(path), path.name))
    return "; ".join(reasons) or None


def _reason(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) <= 160 else text[:157] + "..."


RUNNERS = {"static line": static_line, "static monotone": static_monotone, "NARX": narx,
           "baseline": baseline, "recommended": recommended}


def run_record(name: str, record: Record, narx_options: dict | None = None) -> Outcome:
    """Every method on one record (see the module's docstring)."""
    k = split_index(record)
    cells, refused = {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        for method in METHODS:
            run = RUNNERS[method]
            extra = {}
            t0 = time.perf_counter()
            try:
                estimate = (run(record, k, extra, **(narx_options or {})) if method == "NARX"
                            else run(record, k, extra))
                cell = Cell(heldout_error(record, estimate, k), estimate=estimate)
            except ImportError as exc:
                cell = Cell(note=NOT_AVAILABLE if method == "recommended" else f"failed: {_reason(exc)}")
            except Exception as exc:    # a failing method is a result of the benchmark
                cell = Cell(note=f"failed: {_reason(exc)}")
            cell.seconds = time.perf_counter() - t0
            if "file" in extra or "model" in extra:
                # the file creepcomp would write, even when the estimate then failed
                refused[method] = model_file_refusal(method, extra, Path(tmp), record)
            if "lags" in extra and cell.error is not None:
                cell.note = f"lags (y, u) = {extra['lags']}, block of {extra['block']}"
            cells[method] = cell
    return Outcome(name, len(record), cells, refused)


# --------------------------------------------------------------------------------------------
# Records
# --------------------------------------------------------------------------------------------

def shipped_records() -> list[tuple[str, Record]]:
    from creepcomp import data

    return [("insole left, taxel 128 (shipped)", data.insole_left_steps()),
            ("insole right, taxel 123 (shipped)", data.insole_right_staircase())]


def insole_records(paths: list[Path], taxels: str) -> list[tuple[str, Record]]:
    """Taxels of insole ``.mat`` files: ``taxels`` = numbers (``3,17``) or ``best:N``."""
    from creepcomp.io.insole import insole_record, rank_taxels, read_insole_file

    out = []
    for path in paths:
        insole = read_insole_file(path)
        if taxels.startswith("best:"):
            try:
                n = int(taxels[5:])
            except ValueError:
                raise InputError(f"--taxels {taxels}: give best:N with a whole number N") from None
            chosen = [r["taxel"] for r in rank_taxels(insole) if not r["problems"]][:n]
        else:
            try:
                chosen = [int(v) for v in taxels.split(",") if v.strip()]
            except ValueError:
                raise InputError(f"--taxels {taxels}: give taxel numbers (3,17) or best:N") from None
        for taxel in chosen:
            out.append((f"{Path(path).name}, taxel {taxel}", insole_record(insole, taxel)))
    return out


def file_records(paths: list[Path], columns: str | None) -> list[tuple[str, Record]]:
    """Records read from files as ``creepcomp fit`` reads them (:func:`creepcomp.io.formats.read_any`)."""
    from creepcomp.io.formats import read_any
    from creepcomp.io.records import parse_columns

    mapping = parse_columns(columns)
    return [(Path(path).name, read_any(path, mapping)) for path in paths]


def soft_cases(count: int, first_seed: int, max_samples: int) -> list[tuple[str, Record, dict]]:
    """Generated records with their drawn parameters (kept apart from the record: no method
    sees them)."""
    from creepcomp.synth.soft import soft_records

    out = []
    for s in soft_records(count, first_seed, max_samples):
        p = s.parameters
        clip = f", {100 * p['clipped_fraction']:.2g} % clipped" if p["clipped_fraction"] > 0 else ""
        out.append((f"{p['kind']} seed {p['seed']} ({p['program']}, {p['readout']}, "
                    f"creep {100 * p['creep_total']:+.0f} %{clip})", s.record, p))
    return out


# --------------------------------------------------------------------------------------------
# Summary, table, plots
# --------------------------------------------------------------------------------------------

def _best_static(outcome: Outcome) -> float:
    """The lower error of the two static calibrations (inf where neither gave one)."""
    errors = [outcome.cells[m].error for m in ("static line", "static monotone")]
    return min((e for e in errors if e is not None), default=math.inf)


def summary(outcomes: list[Outcome]) -> dict:
    """Per column the median error and the records with a number; how often the recommended
    model is at most the best static calibration and at most NARX; refused model files."""
    out = {"records": len(outcomes), "columns": {}}
    for method in METHODS:
        errors = [o.cells[method].error for o in outcomes if o.cells[method].error is not None]
        out["columns"][method] = {"median_error_percent": float(np.median(errors)) if errors else None,
                                  "records_with_an_estimate": len(errors),
                                  "failed": sum(o.cells[method].note.startswith("failed") for o in outcomes)}
    rec = [o for o in outcomes if o.cells["recommended"].error is not None]
    out["recommended_at_most_best_static"] = sum(o.cells["recommended"].error <= _best_static(o) for o in rec)
    with_narx = [o for o in rec if o.cells["NARX"].error is not None]
    out["recommended_at_most_narx"] = sum(o.cells["recommended"].error <= o.cells["NARX"].error
                                          for o in with_narx)
    out["records_compared_with_narx"] = len(with_narx)
    base = [o for o in outcomes if o.cells["baseline"].error is not None]
    out["baseline_at_most_best_static"] = sum(o.cells["baseline"].error <= _best_static(o) for o in base)
    out["model_files_written"] = {m: sum(m in o.refused for o in outcomes) for m in ("baseline", "recommended")}
    out["model_files_refused"] = {m: sum(o.refused.get(m) is not None for o in outcomes)
                                  for m in ("baseline", "recommended")}
    return out


def _escape(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def markdown(outcomes: list[Outcome], summ: dict) -> str:
    lines = ["| record | samples | " + " | ".join(METHODS) + " | model files refused |",
             "|---|---:|" + "---|" * len(METHODS) + "---|"]
    for o in outcomes:
        refused = "; ".join(f"{m}: {_escape(r)}" for m, r in o.refused.items() if r) or "none"
        lines.append(f"| {_escape(o.name)} | {o.samples} | "
                     + " | ".join(_escape(o.cells[m].text()) for m in METHODS) + f" | {refused} |")
    lines += ["", "Held-out RMS load error in % of the record's load range (seconds to fit and "
              "estimate); the NARX lags chosen and failures per record are in `--json`.", "",
              "| column | median error | records with an estimate | failed |", "|---|---:|---:|---:|"]
    for m, c in summ["columns"].items():
        med = "-" if c["median_error_percent"] is None else f"{c['median_error_percent']:.3g} %"
        lines.append(f"| {m} | {med} | {c['records_with_an_estimate']} of {summ['records']} | {c['failed']} |")
    n_rec = summ["columns"]["recommended"]["records_with_an_estimate"]
    lines += ["",
              f"- recommended <= best static calibration: {summ['recommended_at_most_best_static']} of {n_rec}",
              f"- recommended <= NARX: {summ['recommended_at_most_narx']} of {summ['records_compared_with_narx']}",
              f"- baseline <= best static calibration: {summ['baseline_at_most_best_static']} of "
              f"{summ['columns']['baseline']['records_with_an_estimate']}",
              "- model files refused (read back and checked as `correct` and `firmware` do): "
              + ", ".join(f"{m} {summ['model_files_refused'][m]} of {summ['model_files_written'][m]} written"
                          for m in ("baseline", "recommended"))]
    return "\n".join(lines)


def to_json(outcomes: list[Outcome], summ: dict) -> dict:
    return {"train_fraction": TRAIN_FRACTION, "summary": summ,
            "records": [{"record": o.name, "samples": o.samples, "model_files_refused": o.refused,
                         "truth": o.truth,
                         "cells": {m: {"error_percent": c.error, "seconds": c.seconds, "note": c.note}
                                   for m, c in o.cells.items()}} for o in outcomes]}


def plot(record: Record, outcome: Outcome, path: Path) -> None:
    """Measured load and each estimate on the held-out part (the static calibrations and the
    baseline faint, NARX and the recommended model on top), and below a stretch of an eighth of
    it around its largest load change, where noise and lag show."""
    import matplotlib.pyplot as plt

    k = split_index(record)
    t = record.time[k:] - record.time[0]
    load = record.load[k:]
    fig, (whole, zoom) = plt.subplots(2, 1, figsize=(9, 6.5), gridspec_kw={"height_ratios": [3, 2]})
    lo, hi = np.min(record.load), np.max(record.load)
    pad = 0.25 * (hi - lo)
    centre = t[int(np.argmax(np.abs(np.diff(load))))] if load.size > 1 else t[0]
    half = (t[-1] - t[0]) / 16
    shown = (t >= centre - half) & (t <= centre + half)
    for ax, part in ((whole, slice(None)), (zoom, shown)):
        for method in METHODS:
            c = outcome.cells[method]
            if c.estimate is None:
                continue
            front = method in ("NARX", "recommended")
            ax.plot(t[part], c.estimate[k:][part], lw=1.0 if front else 0.6, alpha=0.95 if front else 0.35,
                    zorder=3 if front else 2, label=f"{method} ({c.error:.3g} %)")
        ax.plot(t[part], load[part], color="black", lw=1.2, zorder=4, label="measured load")
        ax.set_ylim(lo - pad, hi + pad)       # a diverging estimate leaves the frame, not the scale
        ax.set_ylabel(f"load ({record.unit('load') or 'load units'})")
    zoom.set_xlabel("time since the record's start (s)")
    whole.set_title(f"{outcome.name}: the held-out 40 % (below: an eighth of it, about its largest load change)",
                    fontsize=9)
    whole.legend(fontsize=7, loc="best")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def _slug(name: str) -> str:
    keep = "".join(ch if ch.isalnum() else "-" for ch in name.lower())
    return "-".join(part for part in keep.split("-") if part)[:50]


# --------------------------------------------------------------------------------------------

def _distinct(cases: list[tuple], quiet: bool) -> list[tuple]:
    """The cases without repeats of an earlier one's data (a shipped taxel read again from its
    ``.mat`` file), each repeat said on stderr."""
    out = []
    for case in cases:
        name, record = case[:2]
        same = next((n for n, r, *_ in out if len(r) == len(record) and np.array_equal(r.signal, record.signal)
                     and np.array_equal(r.load, record.load)), None)
        if same is None:
            out.append(case)
        elif not quiet:
            print(f"{name}: the same data as {same}, left out", file=sys.stderr)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true",
                    help=f"{QUICK_SOFT_COUNT} generated records, shorter NARX search")
    ap.add_argument("--soft", type=int, default=None,
                    help=f"generated soft-sensor records (default {SOFT_COUNT}; --quick {QUICK_SOFT_COUNT})")
    ap.add_argument("--soft-seed", type=int, default=0, help="seed of the first generated record")
    ap.add_argument("--max-samples", type=int, default=None,
                    help=f"most samples of a generated record (default {MAX_SOFT_SAMPLES}; "
                         f"--quick {QUICK_SAMPLES})")
    ap.add_argument("--insole", type=Path, nargs="*", default=[], metavar="FILE.mat",
                    help="insole .mat files whose taxels to add")
    ap.add_argument("--taxels", default="best:2", help="taxels of each --insole file: 3,17 or best:N")
    ap.add_argument("--record", type=Path, nargs="*", default=[], metavar="FILE",
                    help="other records (CSV, as creepcomp reads them) to add")
    ap.add_argument("--columns", default=None, metavar="MAP",
                    help="column mapping of the --record files, e.g. time=tR,load=P,signal=Ri")
    ap.add_argument("--no-shipped", action="store_true", help="leave out the shipped insole records")
    ap.add_argument("--json", action="store_true", help="print one JSON object instead of the tables")
    ap.add_argument("--plots", type=Path, default=None, metavar="DIR",
                    help="write measured load vs each estimate on the held-out part for a few records")
    args = ap.parse_args(argv)
    try:
        return _run(args)
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


def _run(args) -> int:
    count = args.soft if args.soft is not None else (QUICK_SOFT_COUNT if args.quick else SOFT_COUNT)
    if count < 0:
        raise InputError(f"--soft {count}: give a count of 0 or more")
    for option, paths in (("--insole", args.insole), ("--record", args.record)):
        for path in paths:
            if not path.is_file():
                raise InputError(f"{option} {path}: no such file")
    if args.plots is not None:
        if args.plots.exists() and not args.plots.is_dir():
            raise InputError(f"--plots {args.plots}: exists and is not a folder")
        args.plots.mkdir(parents=True, exist_ok=True)
    narx_options = QUICK_NARX if args.quick else {}
    measured = ([] if args.no_shipped else shipped_records()) + insole_records(args.insole, args.taxels)
    measured += file_records(args.record, args.columns)
    for _, record in measured:
        check_record(record)
    cases = [(name, record, None) for name, record in measured]
    most = args.max_samples if args.max_samples is not None else (QUICK_SAMPLES if args.quick else MAX_SOFT_SAMPLES)
    if most < 50:
        raise InputError(f"--max-samples {most}: give 50 or more")
    cases += soft_cases(count, args.soft_seed, most)
    outcomes, plotted, kinds = [], [], set()
    for name, record, truth in _distinct(cases, quiet=args.json):
        t0 = time.perf_counter()
        outcome = run_record(name, record, narx_options)
        outcome.truth = truth
        outcomes.append(outcome)
        if not args.json:
            print(f"{name}: {time.perf_counter() - t0:.1f} s", file=sys.stderr)
        kind = record.metadata.get("synth.kind", "real")
        if args.plots is not None and (kind == "real" or kind not in kinds):
            kinds.add(kind)
            path = args.plots / f"load-error-{len(outcomes):02d}-{_slug(name)}.png"
            plot(record, outcome, path)
            plotted.append(path)
        for c in outcome.cells.values():
            c.estimate = None           # (memory: only the plotted records need them)
    summ = summary(outcomes)
    if args.json:
        print(json.dumps(to_json(outcomes, summ), indent=1))
    else:
        print(markdown(outcomes, summ))
        for path in plotted:
            print(f"plot written to {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
