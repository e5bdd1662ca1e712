"""One unit of a fleet: read its record (on the worker), fit, diagnose, optionally correct,
write its files, and return its row of the results table.

A unit's files go to ``DIR/units/<unit>/``, each written atomically: ``model.json`` (the
diagnosis's baseline model, as ``creepcomp diagnose -o`` writes ``baseline-model.json``: the
unit pays for one analysis), ``diagnosis.json`` (as ``creepcomp diagnose --json``),
``extended-model.json``, with ``correct`` ``corrected.csv`` (as ``creepcomp correct -o``), with
``unit_reports`` ``report.html``; and last ``result.json``, whose presence marks the unit done.
"""

from __future__ import annotations

import json
import math
import time as _time
from pathlib import Path

import numpy as np

from creepcomp.errors import InputError
from creepcomp.fleet.table import COLUMN_NAMES, MAX_TERMS
from creepcomp.io.atomic import atomic_path, write_text_atomic
from creepcomp.io.jsonfiles import to_json
from creepcomp.model import CreepModel
from creepcomp.verify.creep_test import C3_CREEP_LIMIT

__all__ = ["OIML_C3_CREEP", "STEP_POINTS", "RESULT_FILE", "RESULT_VERSION", "run_settings", "empty_row", "row_from",
           "step_creep", "process_unit", "done_row", "one_line", "uninvertible_note"]

#: Default creep limit: OIML R60, accuracy class C (3000 intervals), as a fraction of the
#: full-scale output (class C3), derived in :mod:`creepcomp.verify.creep_test`.
OIML_C3_CREEP = C3_CREEP_LIMIT

#: Most samples of the simulated load step (longer records are sampled more coarsely).
STEP_POINTS = 20000

#: The file whose presence marks a unit done.
RESULT_FILE = "result.json"

#: Version of the result layout: results of another version are recomputed.
RESULT_VERSION = 1


def run_settings(spec: float, correct: bool, unit_reports: bool) -> dict:
    """The run settings a unit's result depends on (a re-run with other settings recomputes)."""
    return {"version": RESULT_VERSION, "spec": float(spec), "correct": bool(correct),
            "unit_reports": bool(unit_reports)}


def one_line(text: str, limit: int = 300) -> str:
    """An error message on one line, shortened to ``limit`` characters."""
    line = " ".join(str(text).split())
    return line if len(line) <= limit else line[:limit - 3] + "..."


def empty_row(file: str, unit: str) -> dict:
    """A row with every column None but the record's path and the unit's name."""
    row = dict.fromkeys(COLUMN_NAMES)
    row["file"], row["unit"] = str(file), unit
    return row


def _float(x) -> float | None:
    if x is None:
        return None
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def row_from(row: dict, model: dict, diagnosis: dict) -> dict:
    """Fill a row from a model file (``fit``) and a diagnosis (``diagnose --json``).

    Keys that a diagnosis may not yet carry (``noise_floor``, ``misfit_ratio``,
    ``explained_share``) are read with ``get`` and left None when absent.

    Parameters
    ----------
    row : dict
        From :func:`empty_row`; filled in place and returned.
    model : dict
        The unit's fitted model file (``beta``, ``tau`` sorted by tau, ``gain``, ``offset``).
    diagnosis : dict
        ``Diagnosis.to_dict()``.
    """
    beta, tau = list(model["beta"]), list(model["tau"])
    row.update(gain=_float(model.get("gain")), offset=_float(model.get("offset")),
               n_terms=len(beta), beta0=_float(sum(beta)))
    for k in range(min(len(beta), MAX_TERMS)):
        row[f"beta_{k + 1}"], row[f"tau_{k + 1}"] = _float(beta[k]), _float(tau[k])
    findings = [f.get("effect") for f in diagnosis.get("findings", [])]
    base, ext = diagnosis.get("baseline") or {}, diagnosis.get("extended") or {}
    gain = diagnosis.get("gain") or {}
    row.update(cause=diagnosis.get("cause"), findings=",".join(findings),
               misfit_ratio_baseline=_float(base.get("misfit_ratio")),
               misfit_ratio_extended=_float(ext.get("misfit_ratio")),
               explained_share=_float(diagnosis.get("explained_share")),
               noise_floor=_float(diagnosis.get("noise_floor")),
               residual_rms_baseline=_float(base.get("residual_rms")),
               residual_rms_extended=_float(ext.get("residual_rms")),
               heldout_rms_ratio=_float(gain.get("heldout_rms_ratio")),
               correction_error_ratio=_float(gain.get("correction_error_ratio")))
    return row


def step_creep(correcting: CreepModel, actual: CreepModel, duration: float, dt: float,
               level: float, temperature: float | None = None) -> tuple[float, float]:
    """Creep of a load step, without and with correction.

    ``actual`` (the unit's extended model, with its fitted extensions) is driven by a step from
    zero to ``level`` held for ``duration``; its output is corrected digitally (subtractive
    method, relaxed start) with ``correcting`` (the unit's fitted linear model, the one a
    user puts into the corrector). For each signal the creep is the largest change of the
    indication after the step, from the first sample after it, as a fraction of the step's
    instantaneous change (as OIML R60 reads creep: the change under constant load after
    the first reading).

    Parameters
    ----------
    correcting, actual : CreepModel
    duration : float
        How long the load is held (s).
    dt : float
        Sample step (s); coarsened so that at most :data:`STEP_POINTS` samples are simulated.
    level : float
        Load of the step (load units).
    temperature : float, optional
        Constant temperature for thermal extensions.

    Returns
    -------
    (float, float)
        Creep uncorrected, creep after correction (fractions of the step's output).
    """
    from creepcomp.diagnose.effects import simulate_extended
    from creepcomp.digital.correctors import compensate

    n = int(min(STEP_POINTS, max(3, round(duration / dt) + 1)))
    t = np.linspace(0.0, duration, n)
    load = np.full(n, float(level))
    load[0] = 0.0
    temp = None if temperature is None else np.full(n, float(temperature))
    raw = simulate_extended(actual, t, load, temp, initial="relaxed", hold="zero")
    corrected = compensate(t, raw, correcting, "subtractive", initial="relaxed", hold="zero")

    def creep(y: np.ndarray) -> float:
        jump = y[1] - y[0]
        if jump == 0:
            raise InputError("the simulated load step gives no output change")
        return float(np.max(np.abs(y[1:] - y[1])) / abs(jump))

    return creep(raw), creep(corrected)


def _stat(path: Path) -> dict:
    st = path.stat()
    return {"size": st.st_size, "mtime_ns": st.st_mtime_ns}


def done_row(path: str | Path, unit_dir: str | Path, settings: dict) -> dict | None:
    """The row of a unit already done with the same record (size and modification time) and
    settings, or None. Reads only the unit's small ``result.json``, never the record."""
    result = Path(unit_dir) / RESULT_FILE
    try:
        saved = json.loads(result.read_text(encoding="utf-8"))
        same = (saved.get("settings") == settings and saved.get("record") == _stat(Path(path))
                and saved["row"]["file"] == str(path))
    except (OSError, ValueError, KeyError, TypeError):
        return None
    if not same:
        return None
    row = empty_row(path, saved["row"]["unit"])
    row.update({k: v for k, v in saved["row"].items() if k in row})
    return row


def uninvertible_note(model: dict, error: Exception) -> str:
    """The ``notes`` entry of a unit whose fitted model no corrector can use (the unit is
    reported, not judged against the spec)."""
    beta0 = _float(sum(model.get("beta") or [0.0]))
    if beta0 is not None and beta0 <= -1:
        return (f"in_spec not judged: the fitted model has beta0 = {beta0:.4g} (sum of beta; -1 "
                "or less is a creep of -100 % or more, not a physical creep model), which no "
                "corrector can invert, so no step creep, residual creep or correction was "
                "computed (the terms are in model.json)")
    return (f"in_spec not judged: the fitted model cannot be used for correction "
            f"({one_line(error, 160)}): no step creep, residual creep or correction")


def process_unit(path: str, unit: str, out_dir: str, spec: float = OIML_C3_CREEP,
                 correct: bool = False, unit_reports: bool = False) -> dict:
    """Process one record (this runs on a worker): read, fit, diagnose, the step creep
    against ``spec``, optionally correct; write the unit's files; return its row.

    A record that cannot be read, fitted or diagnosed gives a row with ``status`` ``failed``
    and a one-line ``error``; this function raises only on interrupts.

    Parameters
    ----------
    path : str
        The record file.
    unit : str
        The unit's name (its folder under ``out_dir/units``).
    out_dir : str
        The run's output folder.
    spec : float
        Creep limit (fraction of full scale) that ``residual_creep`` is compared with.
    correct : bool
        Also correct the record with the unit's own model and measure the corrected error.
    unit_reports : bool
        Also write the unit's diagnosis report (``report.html``, with plots).
    """
    start = _time.perf_counter()
    settings = run_settings(spec, correct, unit_reports)
    row = empty_row(path, unit)
    folder = Path(out_dir) / "units" / unit
    record_stat = None
    try:
        record_stat = _stat(Path(path))
        _analyse(Path(path), folder, row, spec, correct, unit_reports)
        row["status"] = "ok"
    except InputError as exc:
        row.update(status="failed", error=one_line(exc))
    except Exception as exc:  # a bug or a numerical breakdown: one failed row, the batch goes on
        row.update(status="failed", error=one_line(f"{type(exc).__name__}: {exc}"))
    row["seconds"] = _time.perf_counter() - start
    folder.mkdir(parents=True, exist_ok=True)
    write_text_atomic(folder / RESULT_FILE, to_json({"row": row, "settings": settings,
                                                      "record": record_stat}) + "\n")
    return row


def _analyse(path: Path, folder: Path, row: dict, spec: float, correct: bool,
             unit_reports: bool) -> None:
    from creepcomp.diagnose import diagnose
    from creepcomp.digital.correctors import compensate, creep_error
    from creepcomp.fit import prepare
    from creepcomp.io.records import read_record, write_record

    record = read_record(path)
    row.update(n_samples=len(record), duration_s=record.duration,
               signal_unit=record.unit("signal"), load_unit=record.unit("load"))
    data = prepare(record)
    diagnosis = diagnose(record)
    model = diagnosis.baseline_model     # one analysis per unit: the diagnosis's own baseline fit
    result = diagnosis.to_dict()
    row_from(row, model, result)
    folder.mkdir(parents=True, exist_ok=True)
    write_text_atomic(folder / "model.json", to_json(model) + "\n")
    write_text_atomic(folder / "extended-model.json", to_json(diagnosis.extended_model) + "\n")
    write_text_atomic(folder / "diagnosis.json", to_json(result) + "\n")

    notes = []
    correcting = None
    try:
        correcting = CreepModel.from_dict(model, where="fitted model")
    except InputError as exc:
        # the fit may return a model no corrector can invert: the unit is reported, not judged
        notes.append(uninvertible_note(model, exc))
    if correcting is not None:
        try:
            actual = CreepModel.from_dict(diagnosis.extended_model, where="extended model")
            level = float(record.load[np.argmax(np.abs(record.load))])
            temp = float(np.mean(record.temperature)) if record.temperature is not None else None
            row["creep_step"], row["residual_creep"] = step_creep(
                correcting, actual, record.duration, data.dt_median, level, temp)
        except (InputError, np.linalg.LinAlgError) as exc:
            notes.append(f"in_spec not judged: the step creep could not be computed "
                         f"({one_line(exc, 160)})")
    row["spec"] = spec
    if row["residual_creep"] is not None:
        if "unexplained" in row["findings"].split(","):
            notes.append("in_spec not judged: structure remains that the extended model does not "
                         "explain, so its prediction of the step creep is not trusted")
        else:
            row["in_spec"] = bool(row["residual_creep"] <= spec)
    if correct and correcting is not None:
        initial = "relaxed" if record.load[0] == 0 else "settled"
        comp = compensate(record.time, record.signal, correcting, "subtractive", initial=initial,
                          hold=data.hold)
        err = creep_error(record.time, comp, record.load, correcting)
        row["corrected_error_rms"], row["corrected_error_peak"] = err.rms_fraction, err.peak_fraction
        with atomic_path(folder / "corrected.csv") as tmp:
            write_record(tmp, record, extra={"compensated": comp},
                         metadata={"creepcomp.model": "model.json (subtractive, "
                                                      f"{initial} start)"})
    if unit_reports:
        from creepcomp.report.diagnosis import render_html

        units = {c: record.unit(c) for c in ("signal", "load")}
        write_text_atomic(folder / "report.html", render_html(diagnosis, units))
    row["notes"] = "; ".join(notes) or None
