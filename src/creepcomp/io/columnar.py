"""Records from named columns in memory: a data frame (pandas, polars, a pyarrow table, or
any object with ``columns`` and ``frame[name]``), a numpy structured array, or a mapping of
column name -> array.

Nothing here imports pandas or polars: a column is taken with ``numpy.asarray``. Names are
matched as in a file (in any case, or through a column mapping), and each column must hold
numbers: a column of dates, text or booleans is refused with its name and type, never
converted. The finiteness and time-order checks are the record's own
(:func:`creepcomp.io.record_check.check_arrays`).
"""

from __future__ import annotations

from typing import Any, Callable, Mapping

import numpy as np

from creepcomp.errors import InputError
from creepcomp.io.record_check import COLUMNS, RecordHead, finish_arrays, resolve_columns

__all__ = ["named_columns", "column_arrays"]


def named_columns(obj: Any) -> tuple[list, Callable[[Any], Any]] | None:
    """The column names of ``obj`` and a function that gives a column by name; None when
    ``obj`` has no named columns."""
    if isinstance(obj, Mapping):
        return list(obj.keys()), obj.__getitem__
    names = getattr(getattr(obj, "dtype", None), "names", None)      # numpy structured array
    if names:
        return list(names), obj.__getitem__
    names = getattr(obj, "column_names", None)                       # pyarrow Table, RecordBatch
    if names is not None and hasattr(obj, "column"):
        return list(names), obj.column
    names = getattr(obj, "columns", None)                            # pandas, polars, ...
    if names is not None and hasattr(obj, "__getitem__"):
        try:
            return list(names), obj.__getitem__
        except TypeError:
            return None
    return None


def column_arrays(obj: Any, mapping: Mapping[str, str], source: str,
                  duplicate_times: str) -> tuple[dict[str, np.ndarray], dict]:
    """Record column -> float array from an object with named columns (:func:`named_columns`),
    and the metadata of the reading (the number of rows merged by ``duplicate_times="mean"``).

    Parameters
    ----------
    obj : object with named columns
    mapping : mapping
        Record column (lower case) -> the object's column name, or a constant number.
    source : str
        What the object is, for messages.
    duplicate_times : {"error", "mean"}
        As :func:`creepcomp.io.records.read_record`.

    Raises
    ------
    InputError
        A missing column (naming those found), a column that is not numbers, or no rows.
    """
    names, get = named_columns(obj)
    header = [str(name) for name in names]
    try:
        column_map = resolve_columns(header, mapping, source, None)
    except InputError as exc:
        raise InputError(f"{exc}{_index_hint(obj, mapping)}") from None
    arrays = {name: _numbers(_column(get, names[index], header[index], source), header[index], source)
              for name, index in column_map.read.items()}
    lengths = {len(v) for v in arrays.values()}
    if lengths == {0}:
        raise InputError(f"{source}: no rows")
    n = len(arrays["time"]) if "time" in arrays else max(lengths)
    arrays.update(column_map.constant_arrays(n))
    if len(lengths) > 1:
        return arrays, {}           # (the record's own check names the column of another length)
    head = RecordHead(source, {}, column_map, ",", 0, None)
    return finish_arrays(arrays, head, 1.0, duplicate_times), head.metadata


def _column(get: Callable[[Any], Any], key: Any, name: str, source: str) -> np.ndarray:
    """The column ``key`` of the object as a numpy array; an InputError when the object does
    not give it (a lazy frame, say, that holds no data yet)."""
    try:
        return np.asarray(get(key))
    except Exception as exc:      # (any library's own error: said in one line)
        first_line = (str(exc).strip().splitlines() or [""])[0]
        raise InputError(f"{source}: cannot take its column '{name}' as an array "
                         f"({type(exc).__name__}: {first_line})") from None


def _numbers(values: np.ndarray, name: str, source: str) -> np.ndarray:
    """A column as a float array; refused, with its name and type, unless it holds numbers."""
    if values.ndim != 1:
        shape = "a single value" if values.ndim == 0 else f"of shape {values.shape}"
        raise InputError(f"{source}: column '{name}' is {shape}, not one value per sample")
    kind = values.dtype.kind
    if kind in "iuf":
        return values.astype(float)
    if kind == "O":
        for i, value in enumerate(values):
            try:
                float(value)
            except (TypeError, ValueError):
                raise InputError(f"{source}: column '{name}', sample {i}: {value!r} is not a "
                                 "number") from None
        return values.astype(float)
    if kind in "Mm":
        raise InputError(f"{source}: column '{name}' holds dates or durations ({values.dtype}), "
                         "not numbers: give the time in seconds, e.g. "
                         "(t - t[0]) / numpy.timedelta64(1, 's')")
    what = {"U": "text", "S": "bytes", "b": "booleans", "c": "complex numbers"}.get(kind, str(values.dtype))
    raise InputError(f"{source}: column '{name}' holds {what} ({values.dtype}), not numbers")


def _index_hint(obj: Any, mapping: Mapping[str, str]) -> str:
    """A hint when a missing column is the frame's index (pandas keeps it apart)."""
    index_name = getattr(getattr(obj, "index", None), "name", None)
    if isinstance(index_name, str) and index_name.lower() in COLUMNS:
        return f"; '{index_name}' is the frame's index: use frame.reset_index()"
    return ""
