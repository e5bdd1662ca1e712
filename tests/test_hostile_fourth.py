"""Hostile input, the rest of the third pass: a load that toggles every sample, missing numbers
in tables, a signal at an ADC rail, units of the fleet's tau, two runs into one folder,
candidates that do not apply, the record's extra columns through ``correct -o``, and no
file written unasked."""

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

DATA = Path(__file__).resolve().parents[1] / "src" / "creepcomp" / "data"
RECORD = DATA / "hidden_effect.csv"
MODEL = DATA / "default_sensor.json"


def _rows():
    text = RECORD.read_text().splitlines()
    return np.array([line.split(",") for line in text if line[:1].isdigit()], dtype=float)


def _write(path: Path, columns: dict, comments=("# units.load: N", "# units.signal: V")) -> Path:
    names = list(columns)
    lines = list(comments) + [",".join(names)]
    lines += [",".join(repr(float(x)) for x in row) for row in zip(*columns.values())]
    path.write_text("\n".join(lines) + "\n")
    return path


# -- 2. no 'nan' in the findings tables ------------------------------------------------------

def test_findings_and_candidates_tables_print_a_dash_for_a_missing_number():
    from creepcomp.fit.evidence import Evidence
    from creepcomp.report.results import MISSING, diagnosis_tables

    nan = float("nan")
    finding = SimpleNamespace(effect="data_problem", parameters_text=lambda units: "kind = clipping",
                              evidence=Evidence(nan, nan, nan))
    trial = SimpleNamespace(step=1, effect="thermal_drift", delta_bic=None, evidence=None,
                            outcome="does not apply (the record has no 'temperature' column)")
    fit = SimpleNamespace(heldout=SimpleNamespace(rms=nan))
    d = SimpleNamespace(findings=[finding], trials=[trial], baseline=fit, extended=fit,
                        gain={"heldout_rms_ratio": None, "correction_error_ratio": math.nan,
                              "correction_error_baseline": nan, "correction_error_extended": nan})
    cells = [str(c) for t in diagnosis_tables(d, {"signal": "V"}) for row in t.rows for c in row]
    assert not any("nan" in c.lower() for c in cells), cells
    assert MISSING in cells


# -- 6. "does not apply", not "fit failed" ---------------------------------------------------

def test_candidates_that_do_not_fit_the_record_do_not_apply_rather_than_fail(run_cli):
    status, out, err = run_cli("diagnose", RECORD, "--effects", "data_problem,thermal_drift")
    assert status == 0, err
    assert "fit failed" not in out
    assert "does not apply (no signal jump that no load change explains)" in out
    assert "does not apply (the record has no 'temperature' column)" in out
