"""Long records reduced before fitting: block means within constant-load stretches.

A record sampled far faster than its creep needs (10 M samples at 10 kHz for time constants
of seconds to hours) carries no more information about the creep than a few ten thousand
block means, and fitting it at full rate costs minutes and gigabytes. Averaging blocks of
``k`` samples is an anti-aliasing low-pass filter (a moving average, then keeping every
``k``-th value) applied equally to every column, so the model that relates the columns is
unchanged for time constants well above the new interval.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from creepcomp.io.records import COLUMNS, Record
from creepcomp.units import format_quantity

__all__ = ["MAX_FIT_SAMPLES", "reduce_record"]

#: Samples a fit works on at most (more are reduced by :func:`reduce_record`).
MAX_FIT_SAMPLES = 50_000


def reduce_record(record: Record, max_samples: int = MAX_FIT_SAMPLES) -> tuple[Record, str | None]:
    """Reduce a long record to about ``max_samples`` samples by block means.

    What is preserved:

    - **load steps stay sharp**: blocks never straddle a change of the load; the first sample
      of every constant-load stretch is kept as it is (its time, load and signal), so a step
      happens at the same sample time as in the full record;
    - within a stretch, blocks of ``k`` consecutive samples become one sample at their mean
      time holding the mean of every column (signal, load, temperature, corrected): the
      same linear filter on every column, exact for any part of the signal that is linear
      over the block, and lowering white noise by ``sqrt(k)``;
    - metadata and source are kept, and ``metadata["reduced"]`` says what was done.

    When the load changes at most samples (a ramp or a sweep), stretches are too short to
    reduce; the blocks then run over the whole record (still the same filter on every
    column) and the note says so. Records of at most ``max_samples`` samples are returned
    unchanged. Time constants shorter than a few block lengths (``k`` sample intervals) are
    no longer resolved: the note gives the new interval.

    Parameters
    ----------
    record : Record
    max_samples : int
        Target number of samples (at least 100).

    Returns
    -------
    (Record, str or None)
        The reduced record and a one-line note for the output, or the record and None.
    """
    n = len(record)
    max_samples = max(int(max_samples), 100)
    if n <= max_samples:
        return record, None
    k = math.ceil(n / max_samples)
    load = record.load
    change = np.flatnonzero(load[1:] != load[:-1]) + 1
    if len(change) + 1 <= max_samples // 2:
        bounds = np.concatenate(([0], change, [n]))
        pieces = []
        for s, e in zip(bounds[:-1], bounds[1:]):
            pieces.append(np.array([s]))
            pieces.append(np.arange(s + 1, e, k))
        starts = np.concatenate(pieces)
        how = (f"block means of up to {k} samples within each of the {len(bounds) - 1} "
               "constant-load stretches, the first sample of each kept (load steps stay sharp)")
    else:
        starts = np.arange(0, n, k)
        how = (f"block means of {k} samples over the whole record (the load changes at "
               f"{len(change)} samples: it is not held long enough to average within)")
    counts = np.diff(np.append(starts, n))
    columns = {}
    for name in COLUMNS:
        values = getattr(record, name)
        if values is not None:
            columns[name] = np.add.reduceat(values, starts) / counts
    dt = record.duration / (n - 1)
    note = (f"record reduced from {n} to {len(starts)} samples for the fit by {how}: an "
            f"anti-aliasing filter; new interval about {format_quantity(k * dt, 's')} "
            f"(was {format_quantity(dt, 's')})")
    metadata = dict(record.metadata)
    metadata["reduced"] = note
    return replace(record, metadata=metadata, **columns), note
