"""The signal path of a soft sensor, chosen by how well it gives the load back.

A force-sensing resistor, a Velostat pad, a carbon-black stretch sensor or a capacitive foam
taxel is strongly nonlinear and creeps by tens of percent. :func:`fit_signal_path` fits the
family ``signal = h^-1(offset + gain * G(s)[f(load)])`` (:mod:`creepcomp.transfer`) from its
zero-creep members (a static line; a static monotone calibration curve) to static maps on
either side of linear creep, and keeps the member that recovers the load best on the last
part of the record, held out of its fit:

1. the record is split in time: the first ``1 - validation`` is fitted, the rest predicted;
2. the static members are fitted (the floor every creep model must beat);
3. every pair of static maps is screened statically (no creep), and the best few, and the
   identity, are fitted with one creep term (the linear creep of
   :func:`creepcomp.fit.prony.fit_prony` between ``f(load)`` and ``h(signal)``); a monotone
   spline signal map is fitted by alternating the spline and the creep; the best mapped
   member's power exponents are refined (:func:`refine_exponents`);
4. the best of them is given its number of creep terms by the Prony fit's own evidence;
5. every member is judged on a second, earlier window too (fitted on the first
   ``1 - 2 validation``, judged on the next ``validation``): its score is the geometric mean
   of the two windows' errors;
6. the member whose score is lowest is chosen; a member with more parts must beat a simpler
   one by :data:`MARGIN` to be kept. It is refitted on the whole record, unless the refit
   gives the load back worse on the last part (which it was fitted on) than the member held
   out of it did: a nonlinear fit that went elsewhere;
7. its load filter (:mod:`creepcomp.load_filter`, a moving average of the load estimate) is
   chosen on the same two windows (:func:`choose_load_filter`): none unless one lowers the
   error on both.

Every creep model kept has a stable inverse (:func:`creepcomp.digital.correctors.check_invertible`),
so that what is written is what ``correct`` and ``firmware`` accept, and no retardation time
longer than the part it was fitted on (a drift the part cannot tell from creep, which runs the
load away on later data).
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field, replace

import numpy as np

from creepcomp.digital.correctors import check_invertible, estimate_load, mean_interval
from creepcomp.display import Shown
from creepcomp.errors import InputError
from creepcomp.io.records import Record
from creepcomp.load_filter import LoadFilter, moving_average
from creepcomp.model import CreepModel
from creepcomp.transfer import MAX_KNOTS, StaticMap, Transfer

__all__ = ["Candidate", "SignalPathFit", "fit_signal_path", "static_line", "monotone_calibration",
           "settled_points", "choose", "held_out_load_rms", "refine_exponents", "window_score",
           "choose_load_filter", "VALIDATION", "MARGIN", "STATIC_MARGIN", "SPLINE_KNOTS", "STATIC_KNOTS",
           "FILTER_SAMPLES"]

#: Share of the record's time held out at its end to choose the signal path.
VALIDATION = 0.25
#: A member with more parts is kept only when its held-out load error is at most this share of
#: the simpler member's (5 % better): a spline or a map that wins by less is noise.
MARGIN = 0.95
#: A member with creep (linear creep included) is kept only when its held-out load error is at
#: most this share of the best static calibration's (20 % better): the windows held out of a
#: record of a few minutes are short, and a creep model that won them narrowly lost to the
#: static calibration on the record's later part as often as it won (generated soft sensors,
#: ``benchmarks/real_load_error.py``: a liquid-metal sensor's single step, linear creep 1.09 %
#: against a monotone calibration's 1.11 % on the windows, 3.7 % against 0.77 % later).
STATIC_MARGIN = 0.8
#: Knots of the monotone spline signal map fitted with creep (fewer on short records: 20
#: samples a knot at least).
SPLINE_KNOTS = 12
#: Knots of the static monotone calibration (the most a spline map holds): on 36 generated soft
#: sensors its held-out load error was above a monotone step calibration's (scikit-learn's
#: isotonic regression) by 5 % or more on 13 with 12 knots, on 7-8 with 48-64.
STATIC_KNOTS = MAX_KNOTS
#: Exponents of the power maps screened on either side (the reciprocal is the -1 of the signal side).
SIGNAL_EXPONENTS = (-2.0, -1.5, -1.0, -0.7, -0.5, -0.3, 0.3, 0.5, 0.7, 1.5, 2.0)
LOAD_EXPONENTS = (0.3, 0.5, 0.7, 1.5, 2.0)
#: Map pairs fitted with creep after the static screen (the identity pair is always fitted).
SCREENED = 3
#: Alternations of a spline signal map with its creep.
SPLINE_ROUNDS = 3
#: Most one-term fits spent refining the exponents of the best mapped member.
REFINE_EVALUATIONS = 16
#: The one-term fits that screen and refine the members run on the record reduced to about this
#: many samples (blocks within constant-load stretches, of the mapped columns): the maps move
#: the fit by far more than the reduction does. The chosen member is refitted in full.
SCREEN_SAMPLES = 1500
#: Lengths of the load filter tried (samples of the record): a moving average of the load
#: estimate; 1 is none. On the insole taxels (50 samples/s, noise of several counts) the
#: held-out error of a static line fell steadily up to 16 samples and beyond.
FILTER_SAMPLES = (1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64)
#: A filter is tried only where the judged part holds this many of its lengths at least.
FILTER_SPAN = 8


@dataclass(frozen=True)
class Candidate:
    """One member of the family, fitted on the first part of the record.

    Attributes
    ----------
    name : str
        What it is (``static line``, ``static monotone``, ``linear creep``, or the maps and
        the number of creep terms).
    model : CreepModel or None
        The fitted model (None when its fit failed).
    heldout_load_rms : float
        RMS load error on the held-out part, as a fraction of the record's load range
        (``inf`` when it failed).
    parts : int
        How many parts it has (static maps, creep terms): the rule prefers fewer.
    reason : str
        Why it failed, or empty.
    windows : tuple of float
        The held-out load error of each window it was judged on (fitted on the first half,
        judged on the next quarter; fitted on the first three quarters, judged on the last):
        ``heldout_load_rms`` is their geometric mean (:func:`window_score`).
    """

    name: str
    model: CreepModel | None
    heldout_load_rms: float
    parts: int
    reason: str = ""
    windows: tuple = ()

    def to_dict(self) -> dict:
        """JSON form: name, held-out error (fraction of the load range; each window's too),
        parts, reason."""
        def finite(x):
            return x if math.isfinite(x) else None

        return {"name": self.name, "heldout_load_rms": finite(self.heldout_load_rms),
                "windows": [finite(x) for x in self.windows], "parts": self.parts,
                "reason": self.reason or None}


@dataclass(frozen=True, eq=False)
class SignalPathFit(Shown):
    """The chosen signal path and the members it was chosen from.

    Attributes
    ----------
    model : CreepModel
        The chosen member refitted on the whole record: static maps (``transfer``), creep
        terms (none for a static calibration), gain and offset.
    chosen : str
        Its name among ``candidates``.
    candidates : tuple of Candidate
        Every member tried, fitted on the first part and judged on the held-out part.
    load_range : float
        The record's load range (load units), the scale of the errors.
    split_time : float
        Where the held-out part starts (s).
    seconds : float
        Time the fit took.
    units : dict
        The record's units of ``signal`` and ``load`` (for reports).
    filter_scores : dict
        The chosen member's held-out score with each load filter tried (samples -> fraction of
        the load range, 1 = no filter); the model's ``load_filter`` is the one chosen.
    """

    model: CreepModel
    chosen: str
    candidates: tuple[Candidate, ...]
    load_range: float
    split_time: float
    seconds: float
    units: dict = field(default_factory=dict)
    filter_scores: dict = field(default_factory=dict)

    @property
    def filtered_load_rms(self) -> float:
        """The chosen member's held-out score with its load filter (without one: its own)."""
        f = self.model.load_filter
        if f is None or f.samples not in self.filter_scores:
            return self.candidate(self.chosen).heldout_load_rms
        return self.filter_scores[f.samples]

    def __repr__(self) -> str:
        best = self.candidate(self.chosen).heldout_load_rms
        return (f"<SignalPathFit {self.chosen}: held-out load error {100 * best:.3g} % of the range "
                f"({self.load_range:.4g}), {len(self.candidates)} members>")

    def candidate(self, name: str) -> Candidate:
        """The member of that name."""
        for c in self.candidates:
            if c.name == name:
                return c
        raise KeyError(name)

    @property
    def best_static(self) -> Candidate:
        """The better of the two static calibrations on the held-out part."""
        statics = [c for c in self.candidates if c.model is not None and c.model.is_static]
        return min(statics, key=lambda c: c.heldout_load_rms)

    def to_dict(self) -> dict:
        """JSON form: the chosen member, its model, every member's held-out load error."""
        return {"chosen": self.chosen, "model": self.model.to_dict(), "load_range": self.load_range,
                "split_time": self.split_time, "candidates": [c.to_dict() for c in self.candidates],
                "filter_scores": {str(n): v for n, v in self.filter_scores.items()},
                "seconds": self.seconds}


def _split(record: Record, validation: float) -> tuple[np.ndarray, float]:
    t = record.time
    cut = t[0] + (1.0 - validation) * (t[-1] - t[0])
    return t < cut, float(cut)


def _part(record: Record, mask: np.ndarray) -> Record:
    return Record(record.time[mask], record.load[mask], record.signal[mask], metadata=dict(record.metadata),
                  source=record.source)


def static_line(load, signal) -> CreepModel:
    """The least-squares line of load against signal, as a model with no creep.

    Examples
    --------
    >>> import numpy as np
    >>> from creepcomp.fit.signal_path import static_line
    >>> m = static_line([0.0, 1.0, 2.0], [1.0, 3.0, 5.0])
    >>> print(f"gain {m.gain:.3g}, offset {m.offset:.3g}, terms {m.n_terms}")
    gain 2, offset 1, terms 0
    """
    x = np.asarray(signal, float)
    y = np.asarray(load, float)
    slope, intercept = np.polyfit(x, y, 1)
    if not slope or not math.isfinite(slope):
        raise InputError("the signal does not follow the load: no static line")
    return CreepModel((), (), gain=1.0 / slope, offset=-intercept / slope)


def monotone_calibration(signal, target, knots: int = SPLINE_KNOTS) -> StaticMap:
    """A monotone piecewise-linear map ``h`` with ``h(signal) ~ target`` (least squares).

    Knots at quantiles of the signal; the map increases or decreases as the signal's
    correlation with the target says, each segment by at least a millionth of the target's
    range (a strictly monotone map has an inverse).

    Examples
    --------
    >>> import numpy as np
    >>> from creepcomp.fit.signal_path import monotone_calibration
    >>> s = np.linspace(1.0, 10.0, 200)
    >>> h = monotone_calibration(s, np.sqrt(s), knots=8)
    >>> bool(np.max(np.abs(h.forward(s) - np.sqrt(s))) < 0.03)
    True
    """
    from scipy.optimize import lsq_linear

    x = np.asarray(signal, float)
    y = np.asarray(target, float)
    k = int(max(2, min(knots, x.size // 20)))
    xs = np.unique(np.quantile(x, np.linspace(0.0, 1.0, k)))
    if xs.size < 2:
        raise InputError("the signal does not change: no calibration curve")
    # hat functions of linear interpolation between the knots
    idx = np.clip(np.searchsorted(xs, x, side="right") - 1, 0, xs.size - 2)
    w = np.clip((x - xs[idx]) / (xs[idx + 1] - xs[idx]), 0.0, 1.0)
    basis = np.zeros((x.size, xs.size))
    basis[np.arange(x.size), idx] = 1.0 - w
    basis[np.arange(x.size), idx + 1] = w
    # knot values as the first one plus increments of one sign
    sign = 1.0 if np.corrcoef(x, y)[0, 1] >= 0 else -1.0
    cumulative = np.tril(np.ones((xs.size, xs.size)))
    design = basis @ cumulative
    design[:, 1:] *= sign
    floor = 1e-6 * max(float(np.ptp(y)), 1e-300)
    lower = np.r_[-np.inf, np.full(xs.size - 1, floor)]
    sol = lsq_linear(design, y, bounds=(lower, np.full(xs.size, np.inf)))
    values = cumulative @ (sol.x * np.r_[1.0, np.full(xs.size - 1, sign)])
    return StaticMap("spline", {"x": xs.tolist(), "y": values.tolist()})


def held_out_load_rms(estimate, record: Record, heldout: np.ndarray, load_range: float) -> float:
    """RMS of ``estimate - load`` over the held-out samples, as a fraction of the load range
    (``inf`` where it is not finite)."""
    err = np.asarray(estimate, float)[heldout] - record.load[heldout]
    rms = float(np.sqrt(np.mean(err * err))) / load_range
    return rms if math.isfinite(rms) else math.inf


def _load_rms(model: CreepModel, record: Record, heldout: np.ndarray, load_range: float) -> float:
    with np.errstate(all="ignore"):     # a model whose inverse runs away scores inf
        estimate = estimate_load(record.time, record.signal, model)
    return held_out_load_rms(estimate, record, heldout, load_range)


def _signal_maps(signal: np.ndarray) -> list[StaticMap]:
    """Power (reciprocal) and log maps the signal's sign allows, about zero."""
    lo = float(np.min(signal))
    maps = [StaticMap("power", {"exponent": e, "origin": 0.0}) for e in SIGNAL_EXPONENTS if e > 0]
    if lo > 0:
        maps += [StaticMap("log", {"origin": 0.0})]
        maps += [StaticMap("reciprocal", {"origin": 0.0}) if e == -1.0 else
                 StaticMap("power", {"exponent": e, "origin": 0.0}) for e in SIGNAL_EXPONENTS if e < 0]
    return [m for m in maps if not (m.form == "power" and m.parameters["exponent"] == 1.0)]


def _load_maps() -> list[StaticMap]:
    return [StaticMap("power", {"exponent": e, "origin": 0.0}) for e in LOAD_EXPONENTS]


def settled_points(record: Record, min_samples: int = 5) -> tuple[np.ndarray, np.ndarray] | None:
    """Load and signal at the end of each hold (the last fifth of each run of constant load):
    where creep has come furthest, the static shape of the sensor shows best. None when the
    record has fewer than four holds at three load levels."""
    y, x = record.load, record.signal
    span = float(np.ptp(y)) or 1.0
    moving = np.abs(np.diff(y)) > 1e-3 * span
    edges = np.r_[0, np.flatnonzero(moving) + 1, y.size]
    loads, signals = [], []
    for lo, hi in zip(edges[:-1], edges[1:]):
        if hi - lo >= min_samples:
            tail = slice(hi - max((hi - lo) // 5, 1), hi)
            loads.append(float(np.mean(y[tail])))
            signals.append(float(np.mean(x[tail])))
    if len(loads) < 4 or np.unique(np.round(np.array(loads) / span, 2)).size < 3:
        return None
    return np.array(loads), np.array(signals)


def _static_screen(fit_rec: Record, pairs: list[Transfer]) -> list[tuple[float, Transfer]]:
    """Each pair of maps judged without creep: the load error of the line through
    ``f(load)`` against ``h(signal)`` at the ends of the holds (a map that linearises the
    sensor leaves the least), or at every sample of a record without holds."""
    points = settled_points(fit_rec)
    y, x = points if points is not None else (fit_rec.load, fit_rec.signal)
    span = float(np.ptp(y)) or 1.0
    scored = []
    for path in pairs:
        with np.errstate(all="ignore"):
            z = path.linearise(x)
            u = path.load_in(y)
        if not (np.all(np.isfinite(z)) and np.all(np.isfinite(u))) or np.ptp(z) == 0:
            continue
        slope, intercept = np.polyfit(u, z, 1)
        if not slope:
            continue
        with np.errstate(all="ignore"):
            back = path.load_out((z - intercept) / slope)
        rms = float(np.sqrt(np.nanmean((back - y) ** 2))) / span
        if math.isfinite(rms):
            scored.append((rms, path))
    scored.sort(key=lambda s: s[0])
    return scored


def _screened(fit_rec: Record) -> list[Transfer]:
    """The pairs of maps worth a creep fit: the best few of the static screen, and the best
    with a map on one side only."""
    signal_maps = _signal_maps(fit_rec.signal)
    pairs = [Transfer(signal_map=h) for h in signal_maps]
    pairs += [Transfer(load_map=f) for f in _load_maps()]
    pairs += [Transfer(load_map=f, signal_map=h) for f in _load_maps() for h in signal_maps]
    ranked = [p for _, p in _static_screen(fit_rec, pairs)]
    chosen = ranked[:SCREENED]
    for one_side in (lambda p: p.load_map is None, lambda p: p.signal_map is None):
        best = next((p for p in ranked if one_side(p)), None)
        if best is not None and best not in chosen:
            chosen.append(best)
    return chosen


def _linear_fit(fit_rec: Record, path: Transfer | None, n_terms: int | None, max_terms: int,
                initial: str, most: int | None = None):
    """The Prony fit of linear creep between ``f(load)`` and ``h(signal)`` (on a record
    reduced to about ``most`` samples when given: :func:`creepcomp.fit.reduce.reduce_record`,
    of the mapped columns)."""
    from creepcomp.fit.data import prepare
    from creepcomp.fit.prony import fit_prony
    from creepcomp.fit.reduce import reduce_record

    load, signal = fit_rec.load, fit_rec.signal
    if path is not None:
        load, signal = path.load_in(load), path.linearise(signal)
    inner = Record(fit_rec.time, load, signal, metadata={}, source=fit_rec.source)
    if most is not None:
        inner, _ = reduce_record(inner, most)
    return fit_prony(prepare(inner, initial=initial), max_terms=max_terms, n_terms=n_terms)


def _creep_fit(fit_rec: Record, path: Transfer | None, n_terms: int | None, max_terms: int,
               initial: str, most: int | None = None) -> CreepModel:
    """Linear creep between ``f(load)`` and ``h(signal)``, with the maps attached."""
    model = _linear_fit(fit_rec, path, n_terms, max_terms, initial, most).model()
    model = CreepModel(model.beta, model.tau, model.gain, model.offset, transfer=path)
    check_invertible(model)
    span = float(fit_rec.time[-1] - fit_rec.time[0])
    if max(model.tau) > span:
        # a term slower than the part it was fitted on is a drift the part cannot tell from
        # creep: extrapolated to the rest of the record, it runs the load away
        raise InputError(f"a creep term of tau {max(model.tau):.4g} s, longer than the {span:.4g} s it "
                         "was fitted on, is not determined")
    return model


def _as_power(m: StaticMap | None) -> StaticMap | None:
    """A reciprocal as the power -1 it is; a power as it is; other forms None."""
    if m is None or m.form not in ("power", "reciprocal"):
        return None
    return StaticMap("power", {"exponent": m.parameters.get("exponent", -1.0), "origin": m.parameters["origin"]})


def _with_exponents(path: Transfer, exponents: dict) -> Transfer:
    maps = {}
    for side in ("load_map", "signal_map"):
        m = getattr(path, side)
        if side in exponents:
            e = exponents[side]
            m = (StaticMap("reciprocal", {"origin": m.parameters["origin"]}) if e == -1.0 else
                 StaticMap("power", {"exponent": e, "origin": m.parameters["origin"]}))
        maps[side] = m
    return Transfer(**maps)


def refine_exponents(fit_rec: Record, path: Transfer, initial: str = "relaxed",
                     evaluations: int = REFINE_EVALUATIONS) -> Transfer:
    """The power maps' exponents of a signal path, refined from their screened values.

    The criterion is the profile likelihood of the signal under white noise in the map's
    linear domain: ``n log(rms_z) - sum log|h'(signal)|`` (the Box-Cox form: the Jacobian of
    the signal map makes maps of different scales comparable), with one creep term. Nelder-
    Mead from the screened exponents; a map of another form keeps its parameters, and the
    path is returned as it is when no exponent moves by 0.01.
    """
    from scipy.optimize import minimize

    sides = {side: _as_power(getattr(path, side)) for side in ("load_map", "signal_map")}
    sides = {k: v for k, v in sides.items() if v is not None}
    if not sides:
        return path
    names = list(sides)
    start = np.array([sides[k].parameters["exponent"] for k in names])
    bounds = {"load_map": (0.1, 4.0), "signal_map": (-4.0, 4.0)}

    def cost(v):
        e = dict(zip(names, v))
        if any(not bounds[k][0] <= e[k] <= bounds[k][1] or abs(e[k]) < 0.05 for k in names):
            return math.inf
        candidate = _with_exponents(path, e)
        try:
            with np.errstate(all="ignore"):
                fit = _linear_fit(fit_rec, candidate, 1, 1, initial, most=SCREEN_SAMPLES).fit
                jac = 0.0
                if candidate.signal_map is not None:
                    jac = float(np.sum(np.log(np.abs(candidate.signal_map.derivative(fit_rec.signal)))))
        except (InputError, ValueError, np.linalg.LinAlgError):
            return math.inf
        value = len(fit_rec) * math.log(fit.residual_rms) - jac
        return value if math.isfinite(value) else math.inf

    simplex = [start] + [start + np.eye(len(names))[i] * 0.15 * np.sign(start[i]) for i in range(len(names))]
    best = minimize(cost, start, method="Nelder-Mead",
                    options={"initial_simplex": np.array(simplex), "maxfev": evaluations,
                             "xatol": 0.01, "fatol": 0.5})
    if not math.isfinite(best.fun) or best.fun >= cost(start) or np.max(np.abs(best.x - start)) < 0.01:
        return path
    return _with_exponents(path, {k: round(float(v), 4) for k, v in zip(names, best.x)})


def _spline_creep(fit_rec: Record, n_terms: int | None, max_terms: int, initial: str,
                  most: int | None = None) -> CreepModel:
    """A monotone spline signal map and linear creep in load units, fitted in turns: the
    spline maps the signal to the load through creep, the creep is fitted to the mapped signal."""
    h = monotone_calibration(fit_rec.signal, fit_rec.load)
    model = None
    for _ in range(SPLINE_ROUNDS):
        model = _creep_fit(fit_rec, Transfer(signal_map=h), n_terms, max_terms, initial, most)
        # what the creep says the mapped signal should be, in load units: G[load]
        target = CreepModel(model.beta, model.tau).response(fit_rec.time, fit_rec.load)
        h = monotone_calibration(fit_rec.signal, target)
    return _creep_fit(fit_rec, Transfer(signal_map=h), n_terms, max_terms, initial, most)


def _try(name: str, parts: int, make, record: Record, heldout, load_range) -> Candidate:
    try:
        model = make()
        return Candidate(name, model, _load_rms(model, record, heldout, load_range), parts)
    except (InputError, ValueError, np.linalg.LinAlgError, FloatingPointError) as exc:
        return Candidate(name, None, math.inf, parts, str(exc).splitlines()[0][:200])


def fit_signal_path(record: Record, max_terms: int = 3, validation: float = VALIDATION,
                    initial: str = "relaxed", maps: bool = True) -> SignalPathFit:
    """Fit the signal path that gives the load back best: static, linear creep, or static
    maps around linear creep.

    Parameters
    ----------
    record : Record
        A measured record with ``time``, ``load`` and ``signal``.
    max_terms : int
        Most creep terms of the chosen path.
    validation : float
        Share of the record's time held out at its end to choose (0.1 to 0.5).
    initial : {"relaxed", "settled", "free"}
        Creep state at the first sample (the correction starts the same way).
    maps : bool
        Try static maps (False: the static calibrations and linear creep only).

    Returns
    -------
    SignalPathFit

    Examples
    --------
    A pad whose conductance is linear in load and creeps by 25 % at 4 s, read as a
    resistance: the reciprocal map with creep gives the load back, a static line does not:

    >>> import numpy as np
    >>> from creepcomp.io.records import Record
    >>> from creepcomp.model import CreepModel
    >>> from creepcomp.transfer import MAX_KNOTS, StaticMap, Transfer
    >>> from creepcomp.fit.signal_path import fit_signal_path
    >>> truth = CreepModel((0.25,), (4.0,), gain=2e-4, offset=1e-4,
    ...                    transfer=Transfer(signal_map=StaticMap("reciprocal", {"origin": 0.0})))
    >>> t = np.arange(0.0, 240.0, 0.1)
    >>> load = np.where((t % 40.0) >= 20.0, 1.0 + (t // 40.0) % 3, 0.0)
    >>> noise = np.random.default_rng(1).normal(0.0, 2.0, t.size)
    >>> record = Record(t, load, truth.response(t, load, hold="zero") + noise)
    >>> result = fit_signal_path(record)
    >>> print(result.chosen)
    reciprocal about 0 (signal map), 1 creep term
    >>> bool(result.candidate(result.chosen).heldout_load_rms < result.best_static.heldout_load_rms / 3)
    True
    """
    start = _time.perf_counter()
    if not 0.1 <= validation <= 0.5:
        raise InputError(f"validation = {validation:g}: hold out 0.1 to 0.5 of the record")
    load_range = float(np.ptp(record.load))
    if not load_range > 0:
        raise InputError(f"{record.source}: the load never changes: nothing to calibrate against")
    fit_mask, cut = _split(record, validation)
    heldout = ~fit_mask
    if fit_mask.sum() < 20 or heldout.sum() < 5:
        raise InputError(f"{record.source}: {len(record)} samples are too few to fit and hold out a part")
    fit_rec = _part(record, fit_mask)

    def judge(name, parts, make):
        return _try(name, parts, make, record, heldout, load_range)

    found = [judge("static line", 0, lambda: static_line(fit_rec.load, fit_rec.signal)),
             judge("static monotone", 1, lambda: CreepModel((), (), transfer=Transfer(
                 signal_map=monotone_calibration(fit_rec.signal, fit_rec.load, STATIC_KNOTS)))),
             judge("linear creep, 1 creep term", 1,
                   lambda: _creep_fit(fit_rec, None, 1, max_terms, initial, SCREEN_SAMPLES))]
    creep = [found[-1]]
    if maps:
        for path in _screened(fit_rec):
            parts = 1 + (path.load_map is not None) + (path.signal_map is not None)
            creep.append(judge(_describe_named(path, 1), parts,
                               lambda path=path: _creep_fit(fit_rec, path, 1, max_terms, initial,
                                                            SCREEN_SAMPLES)))
        creep.append(judge("monotone spline (signal map), 1 creep term", 2,
                           lambda: _spline_creep(fit_rec, 1, max_terms, initial, SCREEN_SAMPLES)))
        mapped = [c for c in creep if c.model is not None and c.model.transfer is not None
                  and any(_as_power(m) for m in (c.model.transfer.load_map, c.model.transfer.signal_map))]
        if mapped:
            top = min(mapped, key=lambda c: c.heldout_load_rms)
            path = refine_exponents(fit_rec, top.model.transfer, initial)
            if path != top.model.transfer:
                creep.append(judge(_describe_named(path, 1), top.parts,
                                   lambda: _creep_fit(fit_rec, path, 1, max_terms, initial,
                                                      SCREEN_SAMPLES)))
        found += creep[1:]
    best = min(creep, key=lambda c: c.heldout_load_rms)
    if best.model is not None and max_terms > 1:
        grown = judge(best.name, best.parts, lambda: _grown(fit_rec, best.model, max_terms, initial))
        if grown.model is not None and grown.model.n_terms > 1:
            grown = replace(grown, name=_describe_named(grown.model.transfer, grown.model.n_terms),
                            parts=best.parts + grown.model.n_terms - 1)
            found.append(grown)
    found, early_models = _earlier_window(record, found, validation, max_terms, initial, load_range)
    chosen = choose(found)
    model = _refit(record, chosen, max_terms, initial)
    try:
        refit = _load_rms(model, record, heldout, load_range)
    except (InputError, ValueError, np.linalg.LinAlgError, FloatingPointError):
        refit = math.inf
    if chosen.windows and refit > chosen.windows[-1]:
        # the refit lands worse on the last part than the member held out of it did: its
        # nonlinear fit went elsewhere; the member as judged stands
        model = chosen.model
    early_model = next(m for c, m in zip(found, early_models) if c is chosen)
    load_filter, filter_scores = choose_load_filter(record, chosen, validation, max_terms, initial, load_range,
                                                    early_model)
    model = replace(model, load_filter=load_filter)
    return SignalPathFit(model, chosen.name, tuple(found), load_range, cut, _time.perf_counter() - start,
                         {c: record.unit(c) for c in ("signal", "load") if record.unit(c)}, filter_scores)


def _describe_named(path: Transfer | None, n_terms: int) -> str:
    if path is None:
        return f"linear creep, {n_terms} creep term{'s' if n_terms != 1 else ''}"
    names = []
    if path.signal_map is not None:
        names.append(("monotone spline" if path.signal_map.form == "spline" else path.signal_map.describe())
                     + " (signal map)")
    if path.load_map is not None:
        names.append(path.load_map.describe() + " (load map)")
    return f"{' + '.join(names)}, {n_terms} creep term{'s' if n_terms != 1 else ''}"


def _grown(fit_rec: Record, model: CreepModel, max_terms: int, initial: str) -> CreepModel:
    """The same maps with the number of creep terms chosen by the Prony fit's evidence."""
    path = model.transfer
    if path is not None and path.signal_map is not None and path.signal_map.form == "spline":
        return _spline_creep(fit_rec, None, max_terms, initial)
    return _creep_fit(fit_rec, path, None, max_terms, initial)


def choose(found) -> Candidate:
    """The lowest held-out load error; more parts must win by :data:`MARGIN`, and a member
    with creep must also beat the best static calibration by :data:`STATIC_MARGIN`."""
    usable = sorted((c for c in found if c.model is not None), key=lambda c: (c.parts, c.heldout_load_rms))
    if not usable:
        reasons = "; ".join(f"{c.name}: {c.reason}" for c in found)
        raise InputError(f"no member of the signal-path family could be fitted ({reasons})")
    statics = [c.heldout_load_rms for c in usable if c.model.is_static]
    floor = min(statics) if statics else math.inf
    chosen = usable[0]
    for c in usable[1:]:
        if not c.model.is_static and not c.heldout_load_rms < STATIC_MARGIN * floor:
            continue
        if c.heldout_load_rms < MARGIN * chosen.heldout_load_rms:
            chosen = c
    return chosen


def _structure_fit(record: Record, member: Candidate, max_terms: int, initial: str,
                   most: int | None = None) -> CreepModel:
    """A member's structure (its maps, its number of creep terms) fitted on another record."""
    m = member.model
    if member.name == "static line":
        return static_line(record.load, record.signal)
    if member.name == "static monotone":
        return CreepModel((), (), transfer=Transfer(signal_map=monotone_calibration(record.signal, record.load,
                                                                                    STATIC_KNOTS)))
    path = m.transfer
    if path is not None and path.signal_map is not None and path.signal_map.form == "spline":
        return _spline_creep(record, m.n_terms, max_terms, initial, most)
    return _creep_fit(record, path, m.n_terms, max_terms, initial, most)


def _refit(record: Record, chosen: Candidate, max_terms: int, initial: str) -> CreepModel:
    """The chosen member's structure fitted on the whole record (its own if that fails)."""
    try:
        return _structure_fit(record, chosen, max_terms, initial)
    except (InputError, ValueError, np.linalg.LinAlgError):
        return chosen.model


def _earlier_window(record: Record, found: list[Candidate], validation: float, max_terms: int,
                    initial: str, load_range: float) -> tuple[list[Candidate], list[CreepModel | None]]:
    """Each member also fitted on the first ``1 - 2 validation`` of the record and judged on the
    next ``validation``: its score is the two windows' :func:`window_score` (one window alone
    chose members that failed on later data). Returns the members so scored and, beside each,
    its fit on that window (None where there is none), which the load filter is judged on."""
    parts = _window_parts(record, validation)
    if parts is None:
        return found, [None] * len(found)
    early, upto = parts
    early_rec, upto_rec = _part(record, early), _part(record, upto)
    judged = ~early[upto]
    out, models = [], []
    for c in found:
        if c.model is None:
            out.append(c)
            models.append(None)
            continue
        reason, model = c.reason, None
        try:
            model = _structure_fit(early_rec, c, max_terms, initial, SCREEN_SAMPLES)
            rms = _load_rms(model, upto_rec, judged, load_range)
        except (InputError, ValueError, np.linalg.LinAlgError, FloatingPointError) as exc:
            rms, reason = math.inf, "earlier window: " + str(exc).splitlines()[0][:180]
        out.append(replace(c, heldout_load_rms=window_score((rms, c.heldout_load_rms)),
                           windows=(rms, c.heldout_load_rms), reason=reason))
        models.append(model)
    return out, models


def window_score(errors) -> float:
    """The score of a member judged on several windows: the geometric mean of its errors.
    Each window weighs by how much better or worse a member is there, whatever the window's
    own level (an early window whose loads the fitted part never reached is hard for all)."""
    e = np.asarray(errors, float)
    if not np.all(np.isfinite(e)):
        return math.inf
    return float(np.exp(np.mean(np.log(np.maximum(e, 1e-300)))))


def _window_parts(record: Record, validation: float) -> tuple[np.ndarray, np.ndarray] | None:
    """The earlier window's masks: fitted (the first ``1 - 2 validation``) and up to the end of
    the judged part (the first ``1 - validation``); None where it is too short."""
    t = record.time
    span = t[-1] - t[0]
    early = t < t[0] + (1.0 - 2.0 * validation) * span
    upto = t < t[0] + (1.0 - validation) * span
    if early.sum() < 20 or (upto & ~early).sum() < 5:
        return None
    return early, upto


def choose_load_filter(record: Record, chosen: Candidate, validation: float = VALIDATION,
                       max_terms: int = 3, initial: str = "relaxed",
                       load_range: float | None = None,
                       early_model: CreepModel | None = None) -> tuple[LoadFilter | None, dict]:
    """The moving average of the load estimate that gives a member's load back best.

    The member's load estimate on each of its two windows (:func:`fit_signal_path`, steps 1 and
    5) is averaged over each of :data:`FILTER_SAMPLES` samples and scored as the members are
    (:func:`window_score`). The longest average tried spans at most 1/:data:`FILTER_SPAN` of
    the judged part. The best is kept only where it lowers the error on both windows:
    averaging trades noise for lag, and a record whose load moves faster than its noise needs
    no filter. (The margin the members need is not asked: the filter does not change the
    member's fit, and an error set by a drift or an offset jump the filter cannot touch would
    hide the noise it takes out.)

    Parameters
    ----------
    record : Record
    chosen : Candidate
        The member (its model fitted on the first ``1 - validation`` of the record).
    validation, max_terms, initial
        As for :func:`fit_signal_path`.
    load_range : float, optional
        The scale of the errors (default: the record's load range).
    early_model : CreepModel, optional
        The member fitted on the earlier window, where the caller has it (else it is fitted
        here).

    Returns
    -------
    load_filter : LoadFilter or None
    scores : dict
        Samples -> score (1: no filter).

    Examples
    --------
    A taxel read with noise of 5 % of its range, pressed smoothly every 20 s: an average of
    some samples halves the error.

    >>> import numpy as np
    >>> from creepcomp.io.records import Record
    >>> from creepcomp.fit.signal_path import Candidate, choose_load_filter, static_line
    >>> t = np.arange(0.0, 200.0, 0.02)
    >>> load = 0.5 - 0.5 * np.cos(2 * np.pi * t / 20.0)
    >>> signal = 2.0 * load + np.random.default_rng(0).normal(0.0, 0.1, t.size)
    >>> record = Record(t, load, signal)
    >>> early = t < 150.0
    >>> member = Candidate("static line", static_line(load[early], signal[early]), 0.0, 0)
    >>> chosen, scores = choose_load_filter(record, member)
    >>> chosen.samples > 1, bool(scores[chosen.samples] < scores[1] / 2)
    (True, True)
    """
    load_range = float(np.ptp(record.load)) if load_range is None else load_range
    fit_mask, _ = _split(record, validation)
    estimates = []
    with np.errstate(all="ignore"):
        estimates.append((estimate_load(record.time, record.signal, chosen.model), record, ~fit_mask))
        parts = _window_parts(record, validation)
        if parts is not None:
            early, upto = parts
            try:
                model = (early_model if early_model is not None else
                         _structure_fit(_part(record, early), chosen, max_terms, initial, SCREEN_SAMPLES))
                upto_rec = _part(record, upto)
                estimates.append((estimate_load(upto_rec.time, upto_rec.signal, model), upto_rec, ~early[upto]))
            except (InputError, ValueError, np.linalg.LinAlgError, FloatingPointError):
                pass
    shortest = min(int(judged.sum()) for _, _, judged in estimates)
    errors = {}
    for n in FILTER_SAMPLES:
        if n > 1 and n * FILTER_SPAN > shortest:
            break
        errors[n] = [held_out_load_rms(moving_average(est, n)[0], rec, judged, load_range)
                     for est, rec, judged in estimates]
    scores = {n: window_score(e) for n, e in errors.items()}
    best = min(scores, key=scores.get)
    if best == 1 or not all(a < b for a, b in zip(errors[best], errors[1])):
        return None, scores
    return LoadFilter(best, mean_interval(record.time)), scores
