"""A record corrected in one call: the compensated signal with its creep error before and after.

:func:`correct_record` runs :func:`~creepcomp.digital.correctors.compensate` over a record and
measures :func:`~creepcomp.digital.correctors.creep_error` of the raw and the compensated
signal; the :class:`Correction` it returns shows itself (report, HTML table, plot).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from creepcomp.digital.correctors import CreepError, compensate, creep_error
from creepcomp.display import Shown, data_frame
from creepcomp.io.formats import read_any
from creepcomp.io.records import Record
from creepcomp.model import CreepModel
from creepcomp.units import format_percent

__all__ = ["Correction", "correct_record"]


@dataclass(frozen=True, eq=False)
class Correction(Shown):
    """A record's creep-compensated signal and the creep error before and after.

    Attributes
    ----------
    record : Record
        The raw record.
    model : CreepModel
    method : str
        ``subtractive`` or ``supplemental``.
    compensated : numpy.ndarray
        The compensated signal (signal units).
    before, after : CreepError
        The raw and the compensated signal's error against the load reference.
    """

    record: Record
    model: CreepModel
    method: str
    compensated: np.ndarray
    before: CreepError
    after: CreepError

    @property
    def reduction(self) -> float | None:
        """How many times smaller the peak error is after the correction (None: no error left)."""
        return self.before.peak / self.after.peak if self.after.peak > 0 else None

    def __repr__(self) -> str:
        return (f"<Correction {self.method} of {self.record.source!r}: peak creep error "
                f"{format_percent(self.before.peak_fraction)} -> {format_percent(self.after.peak_fraction)} of FS>")

    def to_dict(self) -> dict:
        """JSON form: method, the model, and the creep error before and after."""
        return {"record": self.record.source, "samples": len(self.record), "method": self.method,
                "model": self.model.to_dict(), "reduction": self.reduction,
                "creep_error": {"before": self.before.to_dict(), "after": self.after.to_dict()}}

    def to_pandas(self):
        """A DataFrame of ``time``, ``load``, ``signal`` and ``compensated`` (pandas needed)."""
        r = self.record
        return data_frame({"time": r.time, "load": r.load, "signal": r.signal,
                           "compensated": self.compensated})


def correct_record(record, model: CreepModel, method: str = "subtractive", initial=None,
                   hold: str = "zero", temperature=None) -> Correction:
    """Correct a record's creep and measure the error before and after.

    Parameters
    ----------
    record : Record, path, open file, data frame or mapping of arrays
        Needs ``time``, ``load`` and ``signal`` (the load gives the reference the error is
        measured against); read by :func:`~creepcomp.io.formats.read_any` unless a Record.
    model : CreepModel
    method, initial, hold, temperature
        As :func:`~creepcomp.digital.correctors.compensate` takes them.

    Returns
    -------
    Correction

    Examples
    --------
    >>> import numpy as np
    >>> from creepcomp.io.records import Record
    >>> from creepcomp.model import CreepModel
    >>> model = CreepModel(beta=(0.03,), tau=(45.0,))
    >>> t = np.arange(0.0, 300.0, 0.5)
    >>> load = (t >= 10).astype(float)
    >>> signal = model.response(t, load, hold="zero")
    >>> c = correct_record(Record(t, load, signal, source="step"), model)
    >>> c.after.peak < 1e-9 < c.before.peak
    True
    """
    record = read_any(record)
    record.require(n_samples=2, what="creep correction")
    compensated = compensate(record.time, record.signal, model, method, initial=initial, hold=hold,
                             temperature=temperature)
    return Correction(record, model, method, compensated,
                      creep_error(record.time, record.signal, record.load, model, method),
                      creep_error(record.time, compensated, record.load, model, method))
