"""A record prepared for fitting a creep model: the samples, the load history's start, and
the segments that gaps in the sampling cut it into."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from creepcomp.errors import InputError
from creepcomp.io.formats import read_any
from creepcomp.io.records import Record
from creepcomp.lti import Sampling

__all__ = ["BLOCK_SAMPLES", "BLOCK_VARIANCE", "check_scales", "MAX_TIME", "VALUE_RANGE", "GAP_FACTOR", "CONSTANT_LOAD_TOLERANCE", "Data", "gaps", "MIN_SAMPLES", "prepare",
           "ABRUPT_FACTOR", "load_steps", "abrupt_intervals", "reference_noise", "THIRD_DIFFERENCE",
           "CHI2_1_MEDIAN"]

#: A time step longer than this many median steps is a gap: the noise model forgets across it.
GAP_FACTOR = 5.0


#: Metadata of a reduced record (:func:`creepcomp.fit.reduce.reduce_record`): the number of
#: samples of the full record each sample holds, and its noise variance relative to one sample's
#: (white noise).
BLOCK_SAMPLES = "reduced.samples"
BLOCK_VARIANCE = "reduced.variance"


def gaps(time: np.ndarray, samples: np.ndarray | None = None) -> np.ndarray:
    """True for each sample that follows a gap in the sampling (a step longer than
    :data:`GAP_FACTOR` median steps); never the first sample.

    ``samples``: of a reduced record, the full record's samples each one holds; a step is
    then measured in the full record's intervals (between the centres of two blocks of ``h1``
    and ``h2`` samples, ``(h1 + h2) / 2`` of them), so blocks of different lengths are no gap.
    """
    dt = np.diff(time)
    if samples is not None:
        dt = dt / (0.5 * (samples[1:] + samples[:-1]))
    return np.concatenate([[False], dt > GAP_FACTOR * np.median(dt)])


#: Weights of the third difference ``x[i] - 3 x[i+1] + 3 x[i+2] - x[i+3]``: it leaves a load's
#: steps at a few samples and its smooth parts (ramps, sweeps, sines) near zero, and white noise
#: of variance ``s**2`` with ``sum(c**2) s**2 = 20 s**2``.
THIRD_DIFFERENCE = np.array([1.0, -3.0, 3.0, -1.0])
#: Median of a chi-squared variable with one degree of freedom: the median of ``z**2`` for
#: ``z`` normal with unit variance.
CHI2_1_MEDIAN = 0.45493642311957283


def reference_noise(load, weights=None) -> float:
    """RMS of a load's own noise, in load units (a reference load cell's, a test machine's):
    0 for a load program.

    From the third differences of the load, each scaled by the variance it would have from
    white noise (a reduced record's blocks have ``1 / weight`` of one sample's variance), their
    median squared over the chi-squared median: steps touch a few differences and do not move
    the median, smooth loads (ramps, sweeps, sines) leave differences near zero, a load
    program's held levels exactly zero.

    Parameters
    ----------
    load : array_like
    weights : array_like, optional
        Of a reduced record (:attr:`Data.weights`).

    Examples
    --------
    >>> import numpy as np
    >>> from creepcomp.fit.data import reference_noise
    >>> t = np.arange(0.0, 600.0, 0.1)
    >>> program = np.where((t // 60) % 2 == 1, 10.0, 0.0) + np.sin(t / 30)
    >>> noisy = program + np.random.default_rng(0).normal(0, 0.01, t.size)
    >>> print(f"{reference_noise(noisy):.3f}", reference_noise(program) < 1e-6)
    0.010 True
    """
    x = np.asarray(load, float)
    if x.size < 8 or np.ptp(x) == 0:
        return 0.0
    d = np.convolve(x, THIRD_DIFFERENCE[::-1], mode="valid")
    inverse_weight = np.ones_like(x) if weights is None else 1.0 / np.asarray(weights, float)
    scale = np.convolve(inverse_weight, THIRD_DIFFERENCE[::-1] ** 2, mode="valid")
    return float(np.sqrt(np.median(d * d / scale) / CHI2_1_MEDIAN))


@dataclass(frozen=True)
class Data:
    """A record prepared for fitting.

    Attributes
    ----------
    time, load, signal : numpy.ndarray
        (``time``: read-only, a copy of the record's when made by :func:`prepare`)
    temperature : numpy.ndarray or None
    source : str
    initial : str
        ``free`` (initial creep states fitted), ``relaxed``, ``settled`` or ``step``
        (a load step at ``load_step_at``, before the first sample).
    load_step_at : float or None
    hold : str
        ``linear`` or ``zero``: the load between samples.
    segment : numpy.ndarray of int
        Segment number of each sample; a gap in the sampling starts a new segment.
    fixed_offset : bool
        The load never changes within the record, so offset and gain cannot be told apart:
        the offset is fixed at zero (the signal is taken as zero at zero load).
    weights : numpy.ndarray or None
        Of a reduced record: each sample's inverse noise variance relative to one sample of the
        full record (:data:`BLOCK_VARIANCE`); residuals are taken times its square root
        (:meth:`weighted`), in the full record's noise units. None: all samples alike.
    samples : numpy.ndarray or None
        Of a reduced record: the full record's samples each sample holds (:data:`BLOCK_SAMPLES`).
    units : dict
        The record's units of ``signal`` and ``load`` (empty where it names none), for reports.
    """

    time: np.ndarray
    load: np.ndarray
    signal: np.ndarray
    temperature: np.ndarray | None
    source: str
    initial: str
    load_step_at: float | None
    hold: str
    segment: np.ndarray
    fixed_offset: bool
    weights: np.ndarray | None = None
    samples: np.ndarray | None = None
    units: dict = field(default_factory=dict, compare=False)

    @property
    def n(self) -> int:
        """Number of samples."""
        return len(self.time)

    @property
    def t0(self) -> float:
        """Time of the first sample (s)."""
        return float(self.time[0])

    @property
    def duration(self) -> float:
        """Time span of the record (s)."""
        return float(self.time[-1] - self.time[0])

    @property
    def span(self) -> float:
        """Time from the load history's start (the step, or the first sample) to the end (s)."""
        start = self.load_step_at if self.load_step_at is not None else self.t0
        return float(self.time[-1] - start)

    @cached_property
    def sampling(self) -> Sampling:
        """The sample times with what the lag recursions compute from them alone
        (:class:`creepcomp.lti.Sampling`): pass it for ``time`` to every lag of this record."""
        return Sampling(self.time)

    def derived(self, key: tuple, make):
        """What ``make()`` computes from this record alone, computed once per record and kept
        on it (read-only where it is an array): ``key`` names what it is and every argument it
        depends on besides the record (e.g. ``("total_variation", dead_band)``)."""
        kept = self.__dict__.setdefault("_derived", {})
        hit = kept.get(key)
        if hit is None:
            hit = make()
            if isinstance(hit, np.ndarray):
                hit.flags.writeable = False
            kept[key] = hit
        return hit

    @cached_property
    def step_floor(self) -> float:
        """The least load change between two samples that can be a step (:func:`step_floor`,
        found once)."""
        return step_floor(self.load)

    @cached_property
    def reference_noise(self) -> float:
        """RMS of the load's own noise in load units (:func:`reference_noise`, found once)."""
        return reference_noise(self.load, self.weights)

    @cached_property
    def abrupt(self) -> np.ndarray:
        """The sample intervals across which the load changes abruptly
        (:func:`abrupt_intervals`, found once)."""
        return abrupt_intervals(self)

    @cached_property
    def dt_median(self) -> float:
        """Median sampling step (s)."""
        return float(np.median(np.diff(self.time)))

    @cached_property
    def dt_resolved(self) -> float:
        """Finest sampling step (s) the record resolves: the median step, or of a reduced
        record, whose blocks after each load change begin as single samples, the full record's."""
        if self.samples is None:
            return self.dt_median
        return float(np.median(np.diff(self.time) / (0.5 * (self.samples[1:] + self.samples[:-1]))))

    def weighted(self, residual: np.ndarray) -> np.ndarray:
        """A residual on every sample (or columns of them) times the square root of each
        sample's weight: unchanged unless the record is reduced."""
        if self.weights is None:
            return residual
        root = self._root_weights
        return residual * (root if np.ndim(residual) == 1 else root[:, None])

    @cached_property
    def _root_weights(self) -> np.ndarray:
        return np.sqrt(self.weights)

    @cached_property
    def dt_small(self) -> float:
        """Finest sampling step that the record uses often (5th percentile, s)."""
        return float(np.percentile(np.diff(self.time), 5))

    @property
    def load_scale(self) -> float:
        """Largest absolute load: the full scale of the record."""
        return float(np.max(np.abs(self.load)))

    @property
    def signal_scale(self) -> float:
        """Spread of the signal (for scaling)."""
        return float(np.ptp(self.signal)) or float(np.max(np.abs(self.signal))) or 1.0

    def tau_limits(self) -> tuple[float, float]:
        """Retardation times the record can resolve: from two sampling steps (a faster lag
        cannot be told from the instantaneous response; after a known load step, down to half
        the time to the first sample) to a few times the record's length (s)."""
        low = 2.0 * self.dt_resolved
        if self.load_step_at is not None:
            low = min(low, 0.5 * (self.t0 - self.load_step_at) or low, 2.0 * self.dt_small)
        return low, 3.0 * self.span

    def lag_initial(self, h: np.ndarray, taus: np.ndarray, values: dict | None = None):
        """Initial states of lags of the input ``h``: zero, settled at ``h[0]``, after the
        known load step, or (``free``) ``h[0]`` plus each term's fitted offset ``c0[k]``."""
        if self.initial == "relaxed":
            return "relaxed"
        if self.initial == "settled":
            return "settled"
        if self.initial == "free":
            values = values or {}
            return h[0] + np.array([values.get(f"c0[{k}]", 0.0) for k in range(len(taus))])
        return h[0] * -np.expm1(-(self.t0 - self.load_step_at) / np.asarray(taus, float))

    def with_signal(self, signal) -> "Data":
        """A copy with another signal (e.g. a simulated one)."""
        copy = replace(self, signal=np.asarray(signal, float))
        if "sampling" in self.__dict__:         # (the same times)
            copy.__dict__["sampling"] = self.sampling
        return copy


#: A load change between two samples is a step when it is this many times larger than the
#: changes between the samples on either side (a ramp changes by equal amounts).
ABRUPT_FACTOR = 10.0


def load_steps(data: Data) -> np.ndarray:
    """Sample intervals ``i`` (from sample ``i`` to ``i + 1``) within which the load steps:
    its change there is :data:`ABRUPT_FACTOR` times those of the neighbouring intervals and at
    least :func:`step_floor`; intervals across a gap are left out."""
    d = np.abs(np.diff(data.load))
    if len(d) == 0:
        return np.zeros(0, int)
    neighbours = np.maximum(np.concatenate([[0.0], d[:-1]]), np.concatenate([d[1:], [0.0]]))
    same_segment = data.segment[1:] == data.segment[:-1]
    big = d >= data.step_floor
    return np.flatnonzero((d > ABRUPT_FACTOR * neighbours) & big & same_segment & (d > 0))


def step_floor(load: np.ndarray) -> float:
    """The least change between two samples that can be a load step: a thousandth of the
    load's range, and :data:`ABRUPT_FACTOR` times the median change between samples. A
    measured load that wanders by a few counts of its converter from sample to sample (a
    pressure read by a sensor) holds it between most of them; a wander by one count between
    two held samples is then ten times its neighbours, but it is the converter's noise, not a
    step (a pressure insole's record: 576 such "steps", each a nuisance column per creep term
    of every fit). A load held between its steps, or ramped, has a median change of zero or
    of its ramps'."""
    d = np.abs(np.diff(load))
    if len(d) == 0:
        return 0.0
    return max(1e-3 * float(np.ptp(load)), ABRUPT_FACTOR * float(np.median(d)))


def abrupt_intervals(data: Data) -> np.ndarray:
    """Sample intervals across which the load changes abruptly: those of its steps
    (:func:`load_steps`), and pairs of consecutive intervals that change it the same way by
    :data:`ABRUPT_FACTOR` times the intervals on either side (a step inside a reduced record's
    block: the block's mean lies between the levels)."""
    d = np.diff(data.load)
    steps = load_steps(data)
    if len(d) < 2:
        return steps
    a = np.abs(d)
    total = a[:-1] + a[1:]
    outside = np.maximum(np.concatenate([[0.0], a[:-2]]), np.concatenate([a[2:], [0.0]]))
    same = (np.sign(d[:-1]) == np.sign(d[1:])) & (d[:-1] != 0)
    same &= (data.segment[2:] == data.segment[:-2])
    pairs = np.flatnonzero(same & (total > ABRUPT_FACTOR * outside) & (total >= data.step_floor))
    return np.unique(np.concatenate([steps, pairs, pairs + 1]))


#: Relative spread below which a load counts as constant.
CONSTANT_LOAD_TOLERANCE = 1e-6


#: Largest magnitude of a time (s) a fit accepts: 31 million years.
MAX_TIME = 1e15
#: Range of magnitudes of a signal's or a load's values a fit accepts (the fit squares and
#: sums them in double precision, which holds about 1e-300 to 1e300).
VALUE_RANGE = (1e-30, 1e30)


def check_scales(record: Record) -> None:
    """Raise :class:`~creepcomp.errors.InputError` for a record whose scales the fit's double
    arithmetic cannot hold: times beyond :data:`MAX_TIME`, a signal or load whose values or
    variation lie outside :data:`VALUE_RANGE`, a signal that does not vary."""
    t = record.time
    if max(abs(float(t[0])), abs(float(t[-1]))) > MAX_TIME:
        raise InputError(f"{record.source}: times reach {max(abs(t[0]), abs(t[-1])):.3g} s, beyond "
                         f"{MAX_TIME:g} s (31 million years): the time column must be in seconds")
    low, high = VALUE_RANGE
    for name, x in (("signal", record.signal), ("load", record.load)):
        size, spread = float(np.max(np.abs(x))), float(np.ptp(x))
        if size > high:
            raise InputError(f"{record.source}: the {name} reaches {size:.3g}, beyond {high:g}: "
                             "rescale it (the fit squares it)")
        if 0 < spread < low:
            raise InputError(f"{record.source}: the {name} varies by only {spread:.3g}, below "
                             f"{low:g}: rescale it")
    spread = float(np.ptp(record.signal))
    if spread <= 1e-12 * float(np.max(np.abs(record.signal))):
        raise InputError(f"{record.source}: the signal does not vary (it stays at "
                         f"{record.signal[0]:g}): nothing to fit a creep model to")


#: Fewest samples a creep model is fitted to: one term (gain, offset or a known load step,
#: beta, tau) and the noise variance; records of fewer than
#: :data:`~creepcomp.fit.noise.SPARSE_SAMPLES` get white noise and a small-sample covariance.
MIN_SAMPLES = 5


def prepare(record, initial: str = "free", load_step_at: float | None = None,
            hold: str = "linear", min_samples: int = MIN_SAMPLES) -> Data:
    """Check a record and prepare it for fitting.

    Parameters
    ----------
    record : Record, path, open file, data frame or mapping of arrays
        Read by :func:`~creepcomp.io.formats.read_any` unless a :class:`Record`.
    initial : {"free", "relaxed", "settled"}
        Creep state at the first sample: fitted from the data (``free``: the record may start
        loaded or creeping), zero, or settled at the first load.
    load_step_at : float, optional
        Time of a single load step that happened before the first sample (a material creep
        test: the load was zero before it and ``load[0]`` after it).
    hold : {"linear", "zero"}
    min_samples : int
        Fewest samples accepted (:data:`MIN_SAMPLES`).

    Returns
    -------
    Data
    """
    record = read_any(record)
    if len(record) < min_samples:
        why = (": one term's gain, offset, beta and tau, and the noise"
               if min_samples == MIN_SAMPLES else "")
        raise InputError(f"{record.source}: {len(record)} samples is too few for fitting a creep "
                         f"model (needs at least {min_samples}{why})")
    if hold not in ("linear", "zero"):
        raise InputError(f"hold '{hold}': use 'linear' or 'zero'")
    if initial not in ("free", "relaxed", "settled"):
        raise InputError(f"initial state '{initial}': use free, relaxed or settled")
    check_scales(record)
    load = record.load
    if not np.any(load != 0):
        raise InputError(f"{record.source}: the load is zero throughout: nothing to fit the "
                         "signal against")
    # constant to within an export's rounding (instrument files write a set stress as e.g.
    # 0.0005 and 0.00050000001362507)
    constant = float(np.ptp(load)) <= CONSTANT_LOAD_TOLERANCE * float(np.max(np.abs(load)))
    if load_step_at is not None:
        if load_step_at > record.time[0]:
            raise InputError(f"--load-step-at {load_step_at:g} s: must not be after the first "
                             f"sample ({record.time[0]:g} s)")
        initial = "step"
    elif constant:
        raise InputError(f"{record.source}: the load is constant ({load[0]:g}) throughout, so "
                         "creep cannot be told from offset: give the time of the load step "
                         "(--load-step-at, e.g. 0 for a creep test whose step was at t = 0)")
    samples, variance = record.metadata.get(BLOCK_SAMPLES), record.metadata.get(BLOCK_VARIANCE)
    weights = None
    if samples is not None and variance is not None and len(samples) == len(record):
        samples = np.asarray(samples, float)
        weights = 1.0 / np.asarray(variance, float)
    else:
        samples = None
    # a copy nobody can change
    time = np.array(record.time, dtype=float)
    time.flags.writeable = False
    return Data(time=time, load=load, signal=record.signal, temperature=record.temperature,
                source=record.source, initial=initial, load_step_at=load_step_at, hold=hold,
                segment=np.cumsum(gaps(record.time, samples)), fixed_offset=constant,
                weights=weights, samples=samples,
                units={c: record.unit(c) for c in ("signal", "load") if record.unit(c)})
