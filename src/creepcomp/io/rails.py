"""Samples stuck at a rail: a signal clipped by its amplifier or converter (an int16 converter
at 32767 or -32768, a 24-bit one at 8388607, or any flat run at the record's largest or
smallest value far longer than the signal sits on one value anywhere else).

The samples are never dropped or altered: ``diagnose`` names them (a ``data_problem`` of kind
``clipping``), ``fit`` and ``correct`` warn in one line with the counts and the value. The
count is taken in one pass over the signal, whole or in pieces (:class:`RailCounter`), so a
record corrected piece by piece is judged as the whole record would be.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["CLIP_RUN", "RAIL_SHARE", "RAIL_LONGER", "CONVERTER_RAILS", "Rail", "RailCounter",
           "stuck_at_rail", "rail_warning"]

#: Least run of equal samples at the signal's extreme that can be a clipped stretch.
CLIP_RUN = 3
#: Without a converter's rail value, the samples in such runs must be at least this share of
#: the record ...
RAIL_SHARE = 0.005
#: ... and the longest run at the extreme this many times longer than the longest run of any
#: other value (a signal that sits on plateaus everywhere does not sit on its top by chance).
RAIL_LONGER = 5.0


def _rails() -> dict[float, str]:
    out = {}
    for bits in (8, 10, 12, 14, 16, 18, 20, 22, 24, 32):
        out[float(2 ** bits - 1)] = f"the largest {bits}-bit unsigned code"
        out[float(2 ** (bits - 1) - 1)] = f"the largest {bits}-bit signed code"
        out[float(-(2 ** (bits - 1)))] = f"the smallest {bits}-bit signed code"
    return out


#: Value -> what it is, for the codes at which a converter's output stops (signed and unsigned,
#: 8 to 32 bits): a run there is a rail whatever its length.
CONVERTER_RAILS = _rails()


@dataclass(frozen=True)
class Rail:
    """Samples stuck at one extreme of the signal.

    Attributes
    ----------
    side : str
        ``largest`` or ``smallest``.
    value : float
        The signal's value there (signal units).
    samples : int
        Samples in runs of :data:`CLIP_RUN` or more at the value.
    runs : int
        How many such runs.
    total : int
        Samples of the record.
    spans : tuple of (int, int)
        Index of the first and one past the last sample of each run (the first 100).
    converter : str or None
        The converter code the value is, if it is one (:data:`CONVERTER_RAILS`).
    """

    side: str
    value: float
    samples: int
    runs: int
    total: int
    spans: tuple
    converter: str | None

    @property
    def share(self) -> float:
        """The samples stuck, as a share of the record's."""
        return self.samples / self.total if self.total else 0.0

    def to_dict(self) -> dict:
        """JSON form (without the spans)."""
        return {"side": self.side, "value": self.value, "samples": self.samples, "runs": self.runs,
                "share": self.share, "converter": self.converter}


class _Side:
    """Runs at the running extreme of one sign."""

    def __init__(self, sign: float):
        self.sign, self.level = sign, None
        self.samples = self.runs = self.longest = 0
        self.spans: list = []

    def offer(self, value: float, start: int, length: int) -> None:
        v = self.sign * value
        if self.level is None or v > self.level:
            self.level, self.samples, self.runs, self.longest, self.spans = v, 0, 0, 0, []
        if v == self.level and length >= CLIP_RUN:
            self.samples += length
            self.runs += 1
            self.longest = max(self.longest, length)
            if len(self.spans) < 100:
                self.spans.append((start, start + length))


class RailCounter:
    """Runs of equal samples at the signal's largest and smallest value, fed in order in
    pieces (:meth:`add`); :meth:`result` names the rails (:func:`stuck_at_rail`)."""

    def __init__(self):
        self._sides = (_Side(1.0), _Side(-1.0))
        self._longest: dict[float, int] = {}      # the longest runs of a few values
        self._run = None                          # (value, start, length) of the open run
        self._n = 0

    def _close(self, value: float, start: int, length: int) -> None:
        for side in self._sides:
            side.offer(value, start, length)
        if length > self._longest.get(value, 0):
            self._longest[value] = length
            if len(self._longest) > 8:
                del self._longest[min(self._longest, key=self._longest.get)]

    def add(self, signal) -> "RailCounter":
        y = np.asarray(signal, float).ravel()
        if not len(y):
            return self
        cut = np.flatnonzero(y[1:] != y[:-1]) + 1
        starts = np.concatenate([[0], cut])
        lengths = np.diff(np.concatenate([starts, [len(y)]]))
        values = y[starts]
        first = 0
        if self._run is not None:
            value, start, length = self._run
            if values[0] == value:
                length += int(lengths[0])
                first = 1
            if first == 1 and len(values) == 1:
                self._run = (value, start, length)
                self._n += len(y)
                return self
            self._close(value, start, length)
        for k in range(first, len(values) - 1):
            self._close(float(values[k]), self._n + int(starts[k]), int(lengths[k]))
        self._run = (float(values[-1]), self._n + int(starts[-1]), int(lengths[-1]))
        self._n += len(y)
        return self

    def result(self) -> list[Rail]:
        """The rails (largest first, then smallest), judged on all the samples added."""
        if self._run is not None:
            self._close(*self._run)
            self._run = None
        out = []
        for side, name in zip(self._sides, ("largest", "smallest")):
            if side.level is None or not side.runs:
                continue
            value = side.sign * side.level
            converter = CONVERTER_RAILS.get(value)
            extremes = (self._sides[0].level, -self._sides[1].level)
            elsewhere = max((length for v, length in self._longest.items() if v not in extremes), default=1)
            if converter is None and not (side.samples >= RAIL_SHARE * self._n
                                          and side.longest >= RAIL_LONGER * elsewhere):
                continue
            out.append(Rail(name, value, side.samples, side.runs, self._n, tuple(side.spans), converter))
        return out


def stuck_at_rail(signal) -> list[Rail]:
    """The rails of a whole signal (:class:`RailCounter`)."""
    return RailCounter().add(signal).result()


def rail_warning(rails: list[Rail], unit: str = "") -> str | None:
    """One line for ``fit`` and ``correct``: the samples stuck at each rail, with the value."""
    if not rails:
        return None
    parts = []
    for r in rails:
        what = f" ({r.converter})" if r.converter else ""
        parts.append(f"{r.samples} samples ({100 * r.share:.3g} % of the record, {r.runs} "
                     f"run{'s' if r.runs != 1 else ''}) stuck at its {r.side} value "
                     f"{r.value:.10g}{(' ' + unit) if unit else ''}{what}")
    return ("the signal looks clipped at a rail: " + ", and ".join(parts)
            + "; they are kept as they are, but they do not measure the sensor there")
