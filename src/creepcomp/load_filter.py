"""The load filter: a moving average of the load estimate, noise traded against lag.

A taxel read to a few counts, or a pad whose reading scatters by a percent, gives a load
estimate that carries that scatter sample by sample, whatever the creep model. Averaging the
last ``N`` estimates divides white noise's RMS by ``sqrt(N)`` and delays a step by
``(N - 1) / 2`` samples; which ``N`` gives the load back best is a property of the record (its
noise, how fast its load changes), so the signal path chooses it on held-out data
(:func:`creepcomp.fit.signal_path.choose_load_filter`), and ``N = 1`` (no filter) unless a
longer one wins.

The filter acts on the load estimate only: the compensated signal (creep removed, in signal
units) is not filtered. The model file holds it as ``load_filter``::

    "load_filter": {"form": "moving_average", "samples": 16, "interval": 0.02}

``samples`` is ``N`` at the sample interval ``interval`` (s) the filter was chosen at: a record
or a firmware at another interval averages over the same time, ``round(samples * interval /
its interval)`` samples (:meth:`LoadFilter.samples_at`). The first ``N - 1`` outputs average
the estimates there are so far.

Examples
--------
>>> import numpy as np
>>> from creepcomp.load_filter import LoadFilter
>>> f = LoadFilter(samples=4, interval=0.01)
>>> [round(float(v), 3) for v in f.apply(np.array([0.0, 4.0, 4.0, 4.0, 4.0, 4.0]))]
[0.0, 2.0, 2.667, 3.0, 4.0, 4.0]
>>> f.samples_at(0.02)
2
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from creepcomp.errors import InputError
from creepcomp.units import check_number

__all__ = ["LoadFilter", "MAX_SAMPLES", "moving_average"]

#: Most samples a moving average may hold: the firmware keeps every one in its state.
MAX_SAMPLES = 256


def moving_average(values, samples: int, history=None) -> tuple[np.ndarray, np.ndarray]:
    """The mean of each value and the ``samples - 1`` before it (fewer at the start).

    Parameters
    ----------
    values : array_like
        The values, in order.
    samples : int
        How many to average (1: the values themselves).
    history : array_like, optional
        The last values before these (a record corrected piece by piece): at most
        ``samples - 1`` of them, the oldest first.

    Returns
    -------
    averaged : numpy.ndarray
    history : numpy.ndarray
        The last ``samples - 1`` values, for the next piece.

    Examples
    --------
    >>> import numpy as np
    >>> from creepcomp.load_filter import moving_average
    >>> whole, _ = moving_average(np.arange(6.0), 3)
    >>> first, kept = moving_average(np.arange(4.0), 3)
    >>> rest, _ = moving_average(np.arange(4.0, 6.0), 3, kept)
    >>> bool(np.array_equal(whole, np.concatenate([first, rest])))
    True
    """
    x = np.asarray(values, dtype=float)
    if samples <= 1:
        return x.copy(), np.zeros(0)
    before = np.zeros(0) if history is None else np.asarray(history, dtype=float)[-(samples - 1):]
    joined = np.concatenate([before, x])
    centre = float(np.mean(joined)) if joined.size else 0.0
    # running sums about the mean: their rounding stays at the scale of the load's variation
    sums = np.concatenate([[0.0], np.cumsum(joined - centre)])
    end = np.arange(before.size, joined.size) + 1
    start = np.maximum(0, end - samples)
    averaged = centre + (sums[end] - sums[start]) / (end - start)
    return averaged, joined[-(samples - 1):].copy()


@dataclass(frozen=True)
class LoadFilter:
    """A moving average of the load estimate.

    Parameters
    ----------
    samples : int
        How many load estimates it averages, at ``interval`` (1 to :data:`MAX_SAMPLES`).
    interval : float
        The sample interval (s) it was chosen at.
    """

    samples: int
    interval: float

    def __post_init__(self):
        if isinstance(self.samples, bool) or not isinstance(self.samples, (int, np.integer)):
            raise InputError(f"load_filter: 'samples' = {self.samples!r}: a whole number of samples")
        if not 1 <= int(self.samples) <= MAX_SAMPLES:
            raise InputError(f"load_filter: 'samples' = {self.samples}: 1 to {MAX_SAMPLES} samples")
        object.__setattr__(self, "samples", int(self.samples))
        interval = check_number(self.interval, "load_filter: 'interval'", unit=" s")
        if not interval > 0:
            raise InputError(f"load_filter: 'interval' = {interval:g} s: a sample interval is positive")
        object.__setattr__(self, "interval", interval)

    @property
    def window(self) -> float:
        """The time it averages over (s)."""
        return self.samples * self.interval

    def samples_at(self, interval: float | None) -> int:
        """How many samples average over the same time at another sample interval (s); the
        filter's own ``samples`` where the interval is unknown."""
        if interval is None or not interval > 0:
            return self.samples
        return int(min(MAX_SAMPLES, max(1, round(self.window / interval))))

    def apply(self, load, interval: float | None = None, history=None) -> np.ndarray:
        """The filtered load estimate (``history``: see :func:`moving_average`)."""
        return moving_average(load, self.samples_at(interval), history)[0]

    def describe(self, interval: float | None = None) -> str:
        """One line: what it averages; at another sample interval (s), what it averages there.

        Examples
        --------
        >>> from creepcomp.load_filter import LoadFilter
        >>> LoadFilter(12, 0.06).describe()
        'a moving average of 12 load estimates (0.72 s at 0.06 s a sample)'
        >>> LoadFilter(12, 0.06).describe(0.02)
        'a moving average of 36 load estimates (0.72 s at 0.02 s a sample)'
        """
        at = self.interval if interval is None or not interval > 0 else interval
        return (f"a moving average of {self.samples_at(at)} load estimates ({self.window:.3g} s at "
                f"{at:.3g} s a sample)")

    def to_dict(self) -> dict:
        """Model-file ``load_filter`` block."""
        return {"form": "moving_average", "samples": self.samples, "interval": self.interval}

    @classmethod
    def from_dict(cls, data, where: str = "load_filter") -> "LoadFilter":
        """Read a model file's ``load_filter`` block."""
        if not isinstance(data, Mapping):
            raise InputError(f"{where}: expected an object with 'form', 'samples' and 'interval'")
        form = data.get("form", "moving_average")
        if form != "moving_average":
            raise InputError(f"{where}: form {form!r} is not known (known: 'moving_average')")
        missing = [k for k in ("samples", "interval") if k not in data]
        if missing:
            raise InputError(f"{where}: missing {' and '.join(repr(m) for m in missing)}")
        try:
            return cls(data["samples"], data["interval"])
        except InputError as exc:
            raise InputError(f"{where}: {str(exc).removeprefix('load_filter: ')}") from None
