"""Creep correction of a record file in pieces: memory of one piece at any record length.

Two passes over the file (:class:`creepcomp.io.records.RecordStream`): the first finds
the sampling (uniform or not) and the load range, the second runs the :class:`Corrector`,
whose state carries from piece to piece, takes the creep errors and writes the output
pieces through the atomic writer. The result equals :func:`compensate` and
:func:`creep_error` on the whole record (to rounding). A model with a temperature law takes
each piece's ``temperature`` column, or one constant temperature.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Mapping

from creepcomp.digital.correctors import (CreepError, CreepErrorSum, Corrector, check_temperature,
                                          default_initial, load_from_compensated, mean_interval_of,
                                          uniform_interval_of,
                                          FittedReferenceSum)
from creepcomp.errors import InputError
from creepcomp.load_filter import moving_average
from creepcomp.io.rails import RailCounter
from creepcomp.io.extra_columns import ExtraColumns, open_extra_columns, output_names
from creepcomp.io.records import STREAM_BYTES, RecordScan, open_record_stream, record_writer
from creepcomp.model import CreepModel

__all__ = ["FileCorrection", "correct_record_file", "temperature_source"]


@dataclass(frozen=True)
class FileCorrection:
    """What :func:`correct_record_file` did.

    Attributes
    ----------
    scan : RecordScan
        The record's length, sampling, load range and metadata.
    dt : float or None
        The uniform sampling interval (s), or None for irregular sampling.
    before, after : CreepError
        Creep error of the raw and the compensated signal.
    temperature : str or None
        Where the temperature came from: ``"column"`` (the record's), ``"constant"``, or None
        (a model without a temperature law).
    fitted_before, fitted_after : float or None
        RMS error of the raw and the compensated signal against the load scaled to each by
        least squares (:class:`~creepcomp.digital.correctors.FittedReferenceSum`); None when
        the load does not vary.
    load_rms : float or None
        RMS error of the load estimate (the whole model's inverse) against the record's load,
        in load units.
    rails : tuple of Rail
        The signal's samples stuck at a rail (:func:`creepcomp.io.rails.stuck_at_rail`): kept
        and corrected as they are.
    """

    scan: RecordScan
    dt: float | None
    before: CreepError
    after: CreepError
    temperature: str | None = None
    fitted_before: float | None = None
    fitted_after: float | None = None
    load_rms: float | None = None
    rails: tuple = ()


def temperature_source(model: CreepModel, has_column: bool, constant: float | None,
                       source: str) -> str | None:
    """Where the correction of a record takes its temperature from, checked.

    A model with a law takes the record's ``temperature`` column or the constant (not both);
    a model without a law refuses the constant and leaves the column unused.

    Returns
    -------
    str or None
        ``"column"``, ``"constant"``, or None when no temperature is used.
    """
    if constant is not None and has_column and model.temperature is not None:
        raise InputError(f"{source}: the record has a 'temperature' column and a constant "
                         "temperature was given (--temperature): give one of them")
    if model.temperature is None:
        check_temperature(model, constant is not None)      # refuses a constant
        return None
    check_temperature(model, constant is not None or has_column)
    return "constant" if constant is not None else "column"


def correct_record_file(path: str | Path, model: CreepModel, method: str = "subtractive",
                        initial=None, hold: str = "zero", output: str | Path | None = None,
                        output_metadata: Mapping[str, str] | None = None,
                        columns: Mapping[str, str] | None = None,
                        progress: Callable[..., None] | None = None,
                        block_bytes: int = STREAM_BYTES,
                        temperature: float | None = None) -> FileCorrection | None:
    """Compensate a record file piece by piece; optionally write its columns, its extra
    columns as they are (:mod:`creepcomp.io.extra_columns`), ``compensated`` and
    ``load_estimate`` to ``output`` (atomically).

    Parameters
    ----------
    path : str or Path
        Record CSV.
    model, method, initial, hold
        As :func:`creepcomp.digital.correctors.compensate`.
    output : str or Path, optional
        The corrected record.
    output_metadata : mapping, optional
        ``# key: value`` lines added to the record's in the output.
    columns : mapping, optional
        Column mapping (:func:`creepcomp.io.records.read_record`).
    progress : callable, optional
        Called as ``progress(rows_done, rows=None, description=None)``.
    temperature : float, optional
        One temperature (°C) for the whole record, for a model with a temperature law and a
        record without a ``temperature`` column (:func:`temperature_source`).

    Returns
    -------
    FileCorrection or None
        None for a file the chunked reader leaves to :func:`creepcomp.io.records.read_record`
        (:attr:`~creepcomp.io.records.RecordStream.whole_reason`), or fewer than 2 samples:
        correct the whole record instead. No output is left then.
    """
    stream = open_record_stream(path, columns, block_bytes=block_bytes)
    scan = stream.scan(progress=progress)
    if scan is None or scan.samples < 2:
        return None
    dt = uniform_interval_of(scan.first_time, scan.last_time, scan.samples, scan.step_min,
                             scan.step_max)
    source = temperature_source(model, "temperature" in scan.names, temperature, str(path))
    start = default_initial(method) if initial is None else initial
    corrector = Corrector(model, method, dt=dt, initial=start, hold=hold)
    before, after = CreepErrorSum(model, method), CreepErrorSum(model, method)
    fitted_before, fitted_after = FittedReferenceSum(), FittedReferenceSum()
    if progress:
        progress(0, scan.samples, "correcting")
    extras = (open_extra_columns(path, columns) if output is not None
              else contextlib.nullcontext(ExtraColumns([], [], None)))
    done = 0
    load_square = 0.0
    rails = RailCounter()
    load_filter = model.load_filter
    filter_samples = (1 if load_filter is None else
                      load_filter.samples_at(mean_interval_of(scan.first_time, scan.last_time, scan.samples)))
    history = None
    with extras as extra, contextlib.ExitStack() as stack:
        names = output_names(extra.names, [*scan.names, "compensated", "load_estimate"])
        write = None
        if output is not None:
            write = stack.enter_context(record_writer(
                output, [*scan.names, *names, "compensated", "load_estimate"],
                {**scan.metadata, **(output_metadata or {})}))
        for piece in stream:
            temps = (None if source is None else
                     piece.temperature if source == "column" else temperature)
            compensated = (corrector.process(piece.signal, temperature=temps) if dt is not None
                           else corrector.process(piece.signal, piece.time, temperature=temps))
            rails.add(piece.signal)
            before.add(piece.time, piece.signal, piece.load)
            after.add(piece.time, compensated, piece.load)
            fitted_before.add(piece.signal, piece.load)
            fitted_after.add(compensated, piece.load)
            load_estimate = load_from_compensated(compensated, model, method)
            if filter_samples > 1:
                load_estimate, history = moving_average(load_estimate, filter_samples, history)
            load_square += float(((load_estimate - piece.load) ** 2).sum())
            if write is not None:
                cells = extra.take(len(piece))
                write({**piece.columns(), **{new: cells[old] for old, new in zip(extra.names, names)},
                       "compensated": compensated, "load_estimate": load_estimate})
            done += len(piece)
            if progress:
                progress(done, scan.samples)
        if stream.whole_reason is not None or done != scan.samples:
            if write is not None:
                write.discard()
            return None                             # the file changed between the passes
    return FileCorrection(scan, dt, before.result(), after.result(), source, fitted_before.result(),
                          fitted_after.result(), (load_square / scan.samples) ** 0.5,
                          tuple(rails.result()))
