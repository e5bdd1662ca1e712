"""The fleet's results table: one row per unit, its columns (type, unit, meaning), and writing
it as Parquet (pyarrow) and CSV.

In the CSV file a text cell that a spreadsheet would read as a formula (one starting with
``=``, ``+``, ``-``, ``@``, a tab or a carriage return) starts with ``'`` instead, as OWASP
recommends against CSV injection (:func:`creepcomp.io.outputs.csv_cell`, as in a bill of
materials); numbers stay numbers, and the Parquet file keeps the text as it is.
"""

from __future__ import annotations

from pathlib import Path

from creepcomp.io.atomic import atomic_path

__all__ = ["MAX_TERMS", "COLUMNS", "COLUMN_NAMES", "arrow_table", "csv_safe", "write_table"]

#: Creep terms given their own columns (``beta_1`` ... ``tau_4``, sorted by tau); a model with
#: more terms has them in its ``model.json`` (``n_terms`` says how many).
MAX_TERMS = 4

_TERMS = [c for k in range(1, MAX_TERMS + 1) for c in (
    (f"beta_{k}", "float64", "fraction", f"creep amplitude of term {k} (terms sorted by tau)"),
    (f"tau_{k}", "float64", "s", f"retardation time of term {k}"))]

#: ``(name, type, unit, meaning)`` of every column, in table order. Units: ``signal`` and
#: ``load`` are the record's own (columns ``signal_unit``, ``load_unit``); ``FS`` is a
#: fraction of the output of a full-scale load step.
COLUMNS: tuple[tuple[str, str, str, str], ...] = (
    ("file", "string", "", "record file"),
    ("unit", "string", "", "unit name (its folder under units/)"),
    ("status", "string", "", "ok, or failed (see error)"),
    ("cause", "string", "", "diagnosis: most important effect, none or unexplained"),
    ("findings", "string", "", "effects found, most important first, comma-separated"),
    ("n_samples", "int64", "", "samples in the record"),
    ("duration_s", "float64", "s", "record length"),
    ("signal_unit", "string", "", "unit of the record's signal"),
    ("load_unit", "string", "", "unit of the record's load"),
    ("gain", "float64", "signal/load", "fitted instantaneous gain"),
    ("offset", "float64", "signal", "fitted signal at zero load"),
    ("n_terms", "int64", "", "creep terms of the fitted model (chosen by evidence)"),
    ("beta0", "float64", "fraction", "total creep amplitude (sum of beta)"),
    *_TERMS,
    ("misfit_ratio_baseline", "float64", "", "baseline residual RMS / noise floor"),
    ("misfit_ratio_extended", "float64", "", "extended model residual RMS / noise floor"),
    ("explained_share", "float64", "fraction", "share of the baseline's excess misfit the extension removes"),
    ("noise_floor", "float64", "signal", "RMS measurement noise, estimated without the model"),
    ("residual_rms_baseline", "float64", "signal", "baseline (1 term) residual RMS"),
    ("residual_rms_extended", "float64", "signal", "extended model residual RMS"),
    ("heldout_rms_ratio", "float64", "", "held-out residual RMS, baseline / extended"),
    ("correction_error_ratio", "float64", "", "corrected-signal RMS error, baseline / extended model"),
    ("creep_step", "float64", "FS", "creep of a full-scale step held for the record's length, uncorrected"),
    ("residual_creep", "float64", "FS", "the same step's creep after correction with the unit's fitted model"),
    ("spec", "float64", "FS", "creep limit residual_creep is compared with"),
    ("in_spec", "bool", "", "residual_creep <= spec (empty when not judged: see notes)"),
    ("corrected_error_rms", "float64", "FS", "with --correct: RMS of corrected record - gain*load (noise included)"),
    ("corrected_error_peak", "float64", "FS", "with --correct: its largest absolute value"),
    ("notes", "string", "", "what was not computed or judged, and why"),
    ("seconds", "float64", "s", "processing time of the unit on its worker"),
    ("error", "string", "", "why the unit failed (one line)"),
)

#: Column names in table order.
COLUMN_NAMES = tuple(c[0] for c in COLUMNS)


def arrow_table(rows: list[dict]):
    """A pyarrow Table of rows (dicts keyed by :data:`COLUMN_NAMES`), with the fixed schema
    (a column that is None in every row keeps its type)."""
    import pyarrow as pa

    types = {"string": pa.string(), "float64": pa.float64(), "int64": pa.int64(), "bool": pa.bool_()}
    schema = pa.schema([pa.field(name, types[kind]) for name, kind, _, _ in COLUMNS])
    return pa.Table.from_pylist([{k: r.get(k) for k in COLUMN_NAMES} for r in rows], schema=schema)


def csv_safe(table):
    """``table`` with every text cell a spreadsheet would run as a formula prefixed by ``'``
    (:func:`creepcomp.io.outputs.csv_cell`): a spreadsheet then shows the text."""
    import pyarrow as pa

    from creepcomp.io.outputs import csv_cell

    for i, column in enumerate(table.schema):
        if not pa.types.is_string(column.type):
            continue
        values = table.column(i).to_pylist()
        safe = [v if v is None else csv_cell(v) for v in values]
        if safe != values:
            table = table.set_column(i, column, pa.array(safe, pa.string()))
    return table


def write_table(table, out_dir: str | Path, stem: str = "fleet") -> dict[str, Path]:
    """Write ``table`` as ``stem.parquet`` and ``stem.csv`` (its text cells made safe for a
    spreadsheet, :func:`csv_safe`) in ``out_dir``, each atomically.

    Returns
    -------
    dict
        ``{"parquet": path, "csv": path}``.
    """
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    out = Path(out_dir)
    paths = {"parquet": out / f"{stem}.parquet", "csv": out / f"{stem}.csv"}
    with atomic_path(paths["parquet"]) as tmp:
        pq.write_table(table, tmp)
    with atomic_path(paths["csv"]) as tmp:
        pacsv.write_csv(csv_safe(table), tmp)
    return paths
