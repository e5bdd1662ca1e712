"""Long records reduced before fitting: blocks within constant-load stretches.

A record sampled far faster than its creep needs (10 M samples at 10 kHz for time constants
of seconds to hours) carries no more information about the creep than a few ten thousand
block values, and fitting it at full rate costs minutes and gigabytes. Each block becomes
one sample: the value at the block's centre of the least-squares parabola through its
samples (:func:`block_weights`), a low-pass filter applied equally to every column, so the
model that relates the columns is unchanged. A plain block mean would not do: it is off by
the creep's curvature times ``h^2 dt^2 / 24``, which over long blocks after a load change is
many times the noise left in a block, and a fit then finds creep terms that are not there.

Blocks of equal length as long as the creep's time constant do not resolve it either: right
after a load change the parabola cannot follow the exponential, and the fit's shortest time
constant (two sample intervals) is then longer than the creep's. Where equal blocks would hold
:data:`GROWING_FROM` samples or more, the blocks therefore grow with the time since each load
change (:data:`BLOCK_GROWTH`), from single samples up to the longest length the target
allows. Their values are then of very unequal noise, and each is weighted by the inverse of its
white-noise variance relative to one full-rate sample (:func:`block_variance`; the metadata
:data:`~creepcomp.fit.data.BLOCK_SAMPLES` and :data:`~creepcomp.fit.data.BLOCK_VARIANCE`):
the fit's residual, its AR noise model (fitted to the weighted residual's sequence, which
whitens what remains correlated between neighbouring blocks), the noise floor and the misfit
ratio are in the full record's noise units, and gaps are judged in full-record intervals. For
noise whose memory is longer than a block the white-noise weights over-weight long blocks a
little; the held-out tests, whose spread follows the residual's spectrum, stay the judge.
"""

from __future__ import annotations

import math
import os
from dataclasses import replace
from pathlib import Path
from typing import Callable, Mapping, Sequence

import numpy as np

from creepcomp.fit.data import BLOCK_SAMPLES, BLOCK_VARIANCE
from creepcomp.io.records import (COLUMNS, STREAM_BYTES, WHOLE_PIECES, Record, open_record_stream,
                                  reads_whole)
from creepcomp.units import format_quantity

__all__ = ["MAX_FIT_SAMPLES", "GROWN_FIT_SAMPLES", "WHOLE_PIECES", "reduce_record", "reduce_all",
           "read_reduced", "block_weights", "block_variance"]

#: Samples a fit works on at most (more are reduced by :func:`reduce_record`).
MAX_FIT_SAMPLES = 50_000
#: Samples ``creepcomp fit`` reduces a record to where its blocks then grow after each load
#: change (``grown_samples`` of :func:`reduce_record`; records of about 200,000 samples and
#: more): growing blocks resolve creep of any time constant with few samples, and on the
#: three-term step record of 250,000 to 3,000,000 samples the parameter errors, the coverage
#: of the stated uncertainties and the number of terms chosen are those of 50,000 samples,
#: for two thirds of the fit's time (``benchmarks/reduced_fit.py``). Equal blocks are not
#: lengthened for it: a record of 100,000 samples in blocks of 6 instead of 3 loses the
#: held-out evidence of its terms.
GROWN_FIT_SAMPLES = 20_000


def reduce_record(record: Record, max_samples: int = MAX_FIT_SAMPLES,
                  grown_samples: int | None = None) -> tuple[Record, str | None]:
    """Reduce a long record to about ``max_samples`` samples by blocks.

    What is preserved:

    - **load steps stay sharp**: blocks never straddle a change of the load; the first and
      the last sample of every constant-load stretch are kept as they are (time, load,
      signal), so a step happens between the same two samples as in the full record;
    - within a stretch, blocks of consecutive samples become one sample at their mean time
      (which keeps irregular times in order; for even sampling the centre) holding the
      parabola-centre value of every other column (signal, load, temperature,
      corrected; :func:`block_weights`): the same linear filter on each of them, exact for
      any part of the signal that is a parabola over the block, and lowering white noise
      by about ``1.5 / sqrt(h)`` for a block of ``h`` samples;
    - metadata and source are kept, and ``metadata["reduced"]`` says what was done.

    When the load changes at most samples (a ramp or a sweep), stretches are too short to
    reduce; the blocks then run over the whole record as plain means (still the same filter
    on every column) and the note says so. Records of at most ``max_samples`` samples are returned
    unchanged. Away from load changes, time constants shorter than a few block lengths (``k``
    sample intervals) are no longer resolved: the note gives the new interval.

    Parameters
    ----------
    record : Record
    max_samples : int
        Target number of samples (at least 100).
    grown_samples : int, optional
        A smaller target taken where its blocks grow after each load change (e.g.
        :data:`GROWN_FIT_SAMPLES`); elsewhere ``max_samples`` holds.

    Returns
    -------
    (Record, str or None)
        The reduced record and a one-line note for the output, or the record and None.
    """
    n = len(record)
    max_samples = max(int(max_samples), 100)
    if n <= max_samples:
        return record, None
    change = np.flatnonzero(record.load[1:] != record.load[:-1]) + 1
    starts, note, within, weighted = _plan(n, record.duration, change, len(change), max_samples,
                                           grown_samples)
    weights = block_weights(starts, n, parabola=within)
    means = block_weights(starts, n, parabola=False)
    columns = {}
    for name in COLUMNS:
        values = getattr(record, name)
        if values is not None:
            columns[name] = np.add.reduceat(values * (means if name == "time" else weights), starts)
    metadata = _reduced_metadata(record.metadata, note, starts, n, within, weighted)
    return replace(record, metadata=metadata, **columns), note


def _reduced_metadata(metadata: Mapping, note: str, starts: np.ndarray, n: int, parabola: bool,
                      weighted: bool) -> dict:
    """The reduced record's metadata: the note, and when its blocks grow after load changes,
    per sample the full record's samples it holds and its white-noise variance relative to one
    of them (:func:`block_variance`), from which a fit weighs it (:class:`~creepcomp.fit.data.Data`);
    both as tuples, so that two reductions compare equal."""
    out = dict(metadata)
    out["reduced"] = note
    if not weighted:
        return out
    h = np.diff(np.append(starts, n))
    out[BLOCK_SAMPLES] = tuple(h.tolist())
    out[BLOCK_VARIANCE] = tuple(block_variance(h, parabola).tolist())
    return out


def block_variance(h: np.ndarray, parabola: bool = True) -> np.ndarray:
    """Variance of the value of blocks of ``h`` samples of unit white noise (the sum of their
    squared :func:`block_weights`): ``1 / h`` for a mean, and for the parabola's centre its
    weight at the centre, ``3 (3 h^2 - 7) / (4 h (h^2 - 4))`` (about ``2.25 / h``; the
    smoothing is a projection, so a point's weight on itself is its weights' sum of squares)."""
    h = np.asarray(h, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        centre = 3.0 * (3.0 * h * h - 7.0) / (4.0 * h * (h * h - 4.0))
    return np.where(h >= 3, centre, 1.0 / h) if parabola else 1.0 / h


def _plan(n: int, duration: float, change: np.ndarray | None, change_count: int,
          max_samples: int, grown_samples: int | None = None) -> tuple[np.ndarray, str, bool, bool]:
    """First sample of every block of :func:`reduce_record`, the note that says so, whether
    the blocks lie within constant-load stretches (then each is its parabola's centre), and
    whether they grow after each load change (then each sample is weighted by what it holds).

    ``change`` holds the samples where the load changes (None: more than ``max_samples // 4``
    of them, ``change_count`` in all). ``grown_samples``: the target where blocks grow.
    """
    if grown_samples is not None and 100 <= grown_samples < max_samples:
        grown = _plan(n, duration, change, change_count, grown_samples)
        if grown[3]:
            return grown
    dt = duration / (n - 1)
    k = math.ceil(n / max_samples)
    interval = "new interval"
    if change is not None and change_count + 1 <= max_samples // 4:
        bounds = np.concatenate(([0], change, [n]))
        # each stretch: its first and last sample, and up to one partly filled block
        k = math.ceil(n / (max_samples - 3 * (len(bounds) - 1)))
        starts, cap = _growing_blocks(bounds, max_samples) if k >= GROWING_FROM else (None, 0)
        within, weighted = True, starts is not None
        if weighted:
            k, interval = cap, "longest interval"
            how = (f"blocks within each of the {len(bounds) - 1} constant-load stretches that "
                   f"grow with the time since the stretch began (at most {BLOCK_GROWTH:g} of it) up "
                   f"to {cap} samples (the centre of each block's least-squares parabola, weighted "
                   "by the samples it holds), the first and last sample of each kept (load steps "
                   "stay sharp)")
        else:
            starts = _stretch_blocks(bounds, k)
            how = (f"blocks of up to {k} samples within each of the {len(bounds) - 1} "
                   "constant-load stretches (the centre of each block's least-squares parabola), "
                   "the first and last sample of each kept (load steps stay sharp)")
    else:
        starts = np.arange(0, n, k)
        within, weighted = False, False
        how = (f"block means of {k} samples over the whole record (the load changes at "
               f"{change_count} samples: it is not held long enough to average within)")
    note = (f"record reduced from {n} to {len(starts)} samples for the fit by {how}: an "
            f"anti-aliasing filter; {interval} about {format_quantity(k * dt, 's')} "
            f"(was {format_quantity(dt, 's')})")
    return starts, note, within, weighted


#: Blocks of equal length within each stretch up to this many samples, blocks that grow after
#: each load change from it on: equal blocks of a few samples are short against any time
#: constant the fit then resolves (down to two of them), and they keep the samples' weights
#: equal, which suits noise of any colour (a block's variance goes as ``1 / h`` only for white
#: noise or over blocks longer than the noise's memory).
GROWING_FROM = 10
#: A block after a load change spans at most this share of the time since the change: creep of
#: any time constant is resolved while it moves, and the parabola through a block stays exact to
#: far below the noise left in it (its error grows with the fourth power of the block's length
#: over the time constant, times the creep left, which decays as the blocks grow).
BLOCK_GROWTH = 0.1


def _block_offsets(length: int, cap: int) -> np.ndarray:
    """First sample of every block within ``length`` samples after a stretch's first sample:
    ``max(1, BLOCK_GROWTH * p)`` samples at ``p`` samples since the stretch began, at most ``cap``."""
    out, p = [], 0
    while p < length:
        out.append(p)
        h = int(BLOCK_GROWTH * (p + 1))
        if h >= cap:
            return np.concatenate((np.array(out, dtype=np.int64),
                                   np.arange(p + cap, length, cap, dtype=np.int64)))
        p += max(1, h)
    return np.array(out, dtype=np.int64)


def _growing_blocks(bounds: np.ndarray, max_samples: int) -> tuple[np.ndarray | None, int]:
    """First sample of every block: per constant-load stretch ``[s, e)``, the samples ``s``
    and ``e - 1`` alone and between them blocks that grow with the time since ``s``
    (:func:`_block_offsets`), capped at the smallest length that keeps the total within
    ``max_samples``; None when even uncapped growth needs more."""
    inner = np.maximum(np.diff(bounds) - 2, 0)
    longest = int(inner.max())
    singles = int(np.sum(np.minimum(np.diff(bounds), 2)))

    def count(cap):
        offsets = _block_offsets(longest, cap)
        return singles + int(np.sum(np.searchsorted(offsets, inner)))

    if longest == 0 or count(longest) > max_samples:
        return None, 0
    lo, hi = 1, longest                          # count(hi) fits; find the smallest cap that does
    while lo < hi:
        mid = (lo + hi) // 2
        if count(mid) <= max_samples:
            hi = mid
        else:
            lo = mid + 1
    offsets = _block_offsets(longest, lo)
    pieces = []
    for s, e, m in zip(bounds[:-1], bounds[1:], inner):
        pieces.append(np.array([s]))
        pieces.append(s + 1 + offsets[:np.searchsorted(offsets, m)])
        if e - s > 1:
            pieces.append(np.array([e - 1]))
    return np.concatenate(pieces), lo


def block_weights(starts: np.ndarray, n: int, lo: int = 0, hi: int | None = None,
                  parabola: bool = True) -> np.ndarray:
    """Weights of samples ``lo .. hi-1`` in their block's value (each block's weights sum to 1).

    A block of ``h >= 3`` samples gives the value at its centre of the least-squares parabola
    through them (a Savitzky-Golay filter of order 2): exact for any signal that is a
    parabola over the block, so the curvature of creep after a load change leaves no bias
    (the plain mean is off by ``h^2 dt^2 / 24`` times the second derivative, many times
    the noise of a long block). Blocks of one or two samples, and every block when
    ``parabola`` is false, are plain means.
    """
    hi = n if hi is None else hi
    # the blocks that overlap lo .. hi-1, and how many of their samples lie there
    first = int(np.searchsorted(starts, lo, side="right")) - 1
    last = int(np.searchsorted(starts, hi, side="left"))
    begin = starts[first:last]
    end = np.append(starts[first + 1:last + 1], n)[:len(begin)]
    inside = np.minimum(end, hi) - np.maximum(begin, lo)
    size = (end - begin).astype(float)
    if not parabola:
        return np.repeat(1.0 / size, inside)
    h = np.repeat(size, inside)
    z = np.arange(lo, hi) - np.repeat(begin + (size - 1.0) / 2.0, inside)
    with np.errstate(divide="ignore", invalid="ignore"):
        centre = (3.0 * (3.0 * h * h - 7.0) - 60.0 * z * z) / (4.0 * h * (h * h - 4.0))
    return np.where(h >= 3, centre, 1.0 / h)


def _stretch_blocks(bounds: np.ndarray, k: int) -> np.ndarray:
    """First sample of every block: per constant-load stretch ``[s, e)``, the samples ``s``
    and ``e - 1`` alone and blocks of ``k`` samples between them."""
    pieces = []
    for s, e in zip(bounds[:-1], bounds[1:]):
        pieces.append(np.array([s]))
        pieces.append(np.arange(s + 1, e - 1, k))
        if e - s > 1:
            pieces.append(np.array([e - 1]))
    return np.concatenate(pieces)


def read_reduced(path: str | Path, max_samples: Sequence[int] = (MAX_FIT_SAMPLES,),
                 columns: Mapping[str, str] | None = None, delimiter: str | None = None,
                 duplicate_times: str = "error", taxel: int | None = None, sheet: str | None = None,
                 progress: Callable[..., None] | None = None,
                 block_bytes: int = STREAM_BYTES,
                 grown_samples: int | None = None,
                 rails: list | None = None) -> list[tuple[Record, str | None]]:
    """Read a record file and reduce it (:func:`reduce_record`) to each of ``max_samples``.

    A plain CSV file of more than :data:`~creepcomp.io.records.WHOLE_PIECES` pieces
    (:func:`~creepcomp.io.records.reads_whole`) is never held whole: one pass
    finds its length and load steps, a second sums the blocks of every reduction while reading
    (the result equals :func:`reduce_record` of the whole record to rounding). Smaller files,
    other files, records no longer than the largest of ``max_samples``, and anything the
    chunked reader leaves to the full one
    (:attr:`~creepcomp.io.records.RecordStream.whole_reason`) are read whole
    (:func:`creepcomp.io.formats.read_any`) and reduced.

    Parameters
    ----------
    path : str or Path (or anything :func:`~creepcomp.io.formats.read_any` takes, read whole)
    max_samples : sequence of int
        The reductions wanted.
    columns, delimiter, duplicate_times, taxel, sheet
        As :func:`creepcomp.io.formats.read_any`.
    progress : callable, optional
        Called as ``progress(rows_done, rows=None, description=None)``.
    block_bytes : int
        CSV text per piece of the piecewise reading
        (:func:`~creepcomp.io.records.open_record_stream`).
    grown_samples : int, optional
        As :func:`reduce_record`, for every reduction.
    rails : list, optional
        Given, the signal's samples stuck at a rail (:func:`creepcomp.io.rails.stuck_at_rail`,
        on every sample of the record, before any reduction) are appended to it.

    Returns
    -------
    list of (Record, str or None)
        One reduced record and its note per entry of ``max_samples``.
    """
    from creepcomp.io.formats import read_any
    from creepcomp.io.rails import RailCounter, stuck_at_rail

    if isinstance(path, (str, os.PathLike)) and not reads_whole(path, duplicate_times, taxel, sheet,
                                                                block_bytes):
        counter = RailCounter()
        reduced = _read_reduced_chunks(path, _targets(max_samples), columns, delimiter, progress,
                                       block_bytes, grown_samples, counter)
        if reduced is not None:
            if rails is not None:
                rails.extend(counter.result())
            return reduced
    record = read_any(path, columns, delimiter=delimiter, duplicate_times=duplicate_times,
                      taxel=taxel, sheet=sheet)
    if rails is not None:
        rails.extend(stuck_at_rail(record.signal))
    return reduce_all(record, max_samples, grown_samples)


def _targets(max_samples: Sequence[int]) -> list[int]:
    return [max(int(m), 100) for m in max_samples]


def reduce_all(record: Record, max_samples: Sequence[int] = (MAX_FIT_SAMPLES,),
               grown_samples: int | None = None) -> list[tuple[Record, str | None]]:
    """A record read whole, reduced (:func:`reduce_record`) to each of ``max_samples``, as
    :func:`read_reduced` reduces it."""
    return [reduce_record(record, m, grown_samples) for m in _targets(max_samples)]


def _read_reduced_chunks(path, targets, columns, delimiter, progress, block_bytes, grown_samples,
                         rails=None):
    """The reductions made while reading the file in pieces, or None for a file to read whole."""
    stream = open_record_stream(path, columns, delimiter, block_bytes)
    scan = stream.scan(max_changes=max(targets) // 4, progress=progress)
    if scan is None or scan.samples <= max(targets):
        return None                             # not streamable, or short enough to read whole
    n = scan.samples
    plans = [_plan(n, scan.last_time - scan.first_time, scan.load_changes, scan.load_change_count, m,
                   grown_samples) for m in targets]
    sums = [{name: np.zeros(len(starts)) for name in scan.names} for starts, *_ in plans]
    if progress:
        progress(0, n, "reducing the record")
    lo = 0
    for piece in stream:
        hi = lo + len(piece)
        if rails is not None:
            rails.add(piece.signal)
        for (starts, _, within, _), total in zip(plans, sums):
            first = int(np.searchsorted(starts, lo, side="right")) - 1
            inner = starts[first + 1:np.searchsorted(starts, hi, side="left")]
            local = np.concatenate(([0], inner - lo))
            weights = block_weights(starts, n, lo, hi, parabola=within)
            means = block_weights(starts, n, lo, hi, parabola=False)
            for name in scan.names:
                w = means if name == "time" else weights
                total[name][first:first + len(local)] += np.add.reduceat(getattr(piece, name) * w, local)
        lo = hi
        if progress:
            progress(lo, n)
    if stream.whole_reason is not None or lo != n:
        return None                             # the file changed between the passes
    out = []
    for (starts, note, within, weighted), total in zip(plans, sums):
        metadata = _reduced_metadata(scan.metadata, note, starts, n, within, weighted)
        out.append((Record(source=scan.source, metadata=metadata, **total), note))
    return out
