"""``data_problem``: the record itself is at fault.

Five kinds, each found with ``where`` it is (times, s):

- ``jump``: the signal steps where no load change explains it (a connector, a range switch,
  a re-zeroed amplifier). Fitted: candidate times are found in the current model's residual
  (a change of the local mean, ``JUMP_Z`` standard errors, away from load changes); each
  gets a step column whose height is fitted, and the evidence (BIC and held-out prediction)
  decides like for any effect. ``where``: the first sample after each jump; ``size``: the
  heights (signal units).
- ``clipping``: the signal sits at its largest or smallest value while the model says it
  should go beyond (an amplifier or ADC at its rail). ``where``: [first, last] time of each
  clipped run.
- ``out_of_step``: the signal and load channels slip against each other part-way through
  (a dropped or repeated sample in one channel): the delay between the load's changes and
  the signal's changes is not the same before and after. ``where``: the interval in which
  the slip happened; ``slip``: its size (s, signal later than load positive).
- ``quantisation``: the signal's value grid is coarser than its noise (the quantisation's
  step^2/12 is at least half the noise floor's variance): creep and effects smaller than a step are not measured.
  ``where``: the record's span; ``step``: the grid step.
- ``load_toggling``: the load changes at (nearly) every sample, back and forth: there is no
  hold for creep to show in (two channels interleaved, a flag or clock read as the load).
  ``where``: the record's span; ``share``: the share of the load's changes that reverse the
  one before.

Clipping also counts samples stuck at a converter's rail, or in a flat run at the extreme
far longer than any other (:mod:`creepcomp.io.rails`): ``value`` and ``samples`` then give
each rail's value (signal units) and its samples.

The last four are screened from the record and the fitted model (:func:`screen`), not
fitted: no column of a model can undo them.
"""

from __future__ import annotations

import math

import numpy as np

from creepcomp.errors import InputError, NotApplicable
from creepcomp.fit.data import Data
from creepcomp.fit.noise import noise_floor, quantisation_step
from creepcomp.io.rails import CLIP_RUN, RAIL_LONGER, stuck_at_rail
from creepcomp.fit.structure import Applied
from creepcomp.fit.solver import Fit
from creepcomp.diagnose.effects import QuickFit, SensorEffect

__all__ = ["JUMP_Z", "JUMP_WINDOW", "find_jumps", "screen", "DataProblem", "EFFECT"]

#: Least size of a candidate jump in standard errors of the difference of local means.
JUMP_Z = 8.0
#: Samples on each side of a candidate jump whose means are compared.
JUMP_WINDOW = 6
#: A jump is explained by the load when the load moves by more than this fraction of full
#: scale within the compared windows.
LOAD_QUIET = 0.01
#: A load that moves more than that still does not explain a step when its movement could move
#: the signal by less than this share of the step.
LOAD_SHARE = 0.25
#: Most jumps fitted.
MAX_JUMPS = 10
#: Least slip (samples) of a single event against all the others for channels out of step.
SLIP_ALONE = 2


def _robust_sigma(x: np.ndarray) -> float:
    d = np.diff(x)
    return float(1.4826 * np.median(np.abs(d - np.median(d))) / np.sqrt(2.0)) if len(d) else 0.0


def find_jumps(data: Data, residual: np.ndarray, z: float = JUMP_Z, w: int = JUMP_WINDOW,
               sensitivity: float | None = None) -> list[int]:
    """Indices of the first samples after steps of the residual's local mean that no load change
    explains (largest first, at most :data:`MAX_JUMPS`, at least ``2 w`` apart).

    The load explains a step when it moves by more than :data:`LOAD_QUIET` of full scale around
    it, unless ``sensitivity`` (the model's largest signal per unit load, instantaneous plus
    creep) is given and the load's movement times it is less than :data:`LOAD_SHARE` of the
    step: a noisy or slowly ramping load cannot explain a step it could move the signal by only
    a fraction of."""
    r = np.asarray(residual, float)
    n = len(r)
    if n < 4 * w:
        return []
    sigma = _robust_sigma(r)
    if sigma <= 0:
        return []
    c = np.concatenate([[0.0], np.cumsum(r)])
    i = np.arange(w, n - w + 1)
    d = (c[i + w] - c[i]) / w - (c[i] - c[i - w]) / w
    score = np.abs(d) / (sigma * np.sqrt(2.0 / w))
    # the load must be quiet around the jump, and for twice the window before it: a load
    # change a few samples earlier explains a step of a signal that lags the load
    x = data.load
    scale = data.load_scale
    from numpy.lib.stride_tricks import sliding_window_view
    win = sliding_window_view(x, 3 * w + 3)
    movement = np.ptp(win, axis=1)                       # window starting at j covers j..j+3w+2
    quiet = np.zeros(len(i), bool)
    starts = i - 2 * w - 2
    ok = (starts >= 0) & (starts < len(movement))
    moved = movement[starts[ok]]
    small = moved <= LOAD_QUIET * scale
    if sensitivity is not None:
        small |= moved * abs(sensitivity) < LOAD_SHARE * np.abs(d[ok])
    quiet[ok] = small
    # gaps in the sampling are not jumps of the signal's level between neighbours either
    seg = data.segment
    quiet &= seg[i - w] == seg[np.minimum(i + w - 1, n - 1)]
    score = np.where(quiet, score, 0.0)
    found = []
    for k in np.argsort(-score):
        if score[k] < z or len(found) >= MAX_JUMPS:
            break
        if all(abs(int(i[k]) - j) >= 2 * w for j in found):
            found.append(int(i[k]))
    return sorted(found)


def screen(data: Data, fit: Fit, base: Fit | None = None) -> list[dict]:
    """Data problems no model column can undo: clipping, channels out of step, quantisation
    that dominates the noise. Each is ``{"kind", "where", ...}`` (times in s).

    Channels out of step are looked for against ``fit`` and, when given, the ``base`` model
    (before any effect: one that follows a delay, fitted to a record whose delay changes,
    takes up part of the change)."""
    out = []
    toggling = _load_toggling(data)
    if toggling:
        out.append(toggling)
    floor = noise_floor(data.signal, data.load, data.time, follows_lag=True)
    clip = _clipping(data, fit, floor)
    rails = stuck_at_rail(data.signal)
    for rail in rails:
        t = data.time
        for a, b in rail.spans:
            span = [float(t[a]), float(t[b - 1])]
            if not any(c[0] <= span[0] and span[1] <= c[1] for c in clip):
                clip.append(span)
    if clip:
        problem = {"kind": "clipping", "where": sorted(clip)}
        if rails:
            problem["value"] = [r.value for r in rails]
            problem["samples"] = [r.samples for r in rails]
        out.append(problem)
    slip = _out_of_step(data, fit)
    if slip is None and base is not None and base is not fit:
        slip = _out_of_step(data, base)
    if slip:
        out.append(slip)
    q = quantisation_step(data.signal)
    if q > 0 and q * q / 12.0 >= QUANTISATION_SHARE * floor.rms ** 2:
        out.append({"kind": "quantisation", "where": [data.t0, float(data.time[-1])], "step": q})
    return out


#: A load toggles when it reverses at least this share of its successive changes, each more
#: than :data:`LOAD_QUIET` of its range ...
TOGGLE_SHARE = 0.9
#: ... over at least this many samples.
TOGGLE_SAMPLES = 20


def _load_toggling(data: Data) -> dict | None:
    """The load changing at (nearly) every sample, back and forth: no hold for creep to show
    in (two channels interleaved, a flag or clock read as the load, the load and another
    column swapped). ``where``: the record's span; ``share``: the share of the successive
    load changes that reverse the one before."""
    x = np.asarray(data.load, float)
    if len(x) < TOGGLE_SAMPLES:
        return None
    dx = np.diff(x)
    big = np.abs(dx) > LOAD_QUIET * max(float(np.ptp(x)), 1e-300)
    reverses = big[1:] & big[:-1] & (np.sign(dx[1:]) == -np.sign(dx[:-1]))
    share = float(np.mean(reverses))
    if share < TOGGLE_SHARE:
        return None
    return {"kind": "load_toggling", "where": [data.t0, float(data.time[-1])], "share": share}


#: Quantisation dominates when its variance step^2/12 is at least this share of the noise floor's.
QUANTISATION_SHARE = 0.5


def _longest_run(y: np.ndarray, tol: float) -> int:
    """The most successive samples of one value (NaN samples break runs)."""
    same = np.abs(np.diff(y)) <= tol          # NaN compares False
    if not same.any():
        return 1
    edges = np.flatnonzero(np.diff(np.concatenate([[0], same.astype(int), [0]])))
    return int(np.max(edges[1::2] - edges[::2])) + 1


def _clipping(data: Data, fit: Fit, floor) -> list:
    """[first, last] times of runs of :data:`~creepcomp.io.rails.CLIP_RUN` or more samples at
    the signal's largest or smallest value. A signal on no value grid does not repeat its
    extreme by chance. On a grid (however fine: noise correlated over a few samples repeats
    grid values) a run counts where the model goes beyond the extreme by more than 3 noise
    floors on average, or where it is :data:`~creepcomp.io.rails.RAIL_LONGER` times longer than
    any run of one value elsewhere in the record (a signal that dithers between grid values
    elsewhere does not sit on one by chance)."""
    y = data.signal
    tol = 1e-9 * max(float(np.max(np.abs(y))), 1e-300)
    on_grid = floor.quantisation_step > 0
    runs = []
    for level, sign in ((np.max(y), 1.0), (np.min(y), -1.0)):
        at = np.abs(y - level) <= tol
        if at.sum() < CLIP_RUN:
            continue
        edges = np.flatnonzero(np.diff(np.concatenate([[0], at.astype(int), [0]])))
        longest = _longest_run(np.where(at, np.nan, y), tol)
        for a, b in zip(edges[::2], edges[1::2]):
            if b - a < CLIP_RUN:
                continue
            beyond = np.mean(sign * (fit.prediction[a:b] - level)) > 3.0 * floor.rms
            unlikely = b - a > RAIL_LONGER * max(longest, 1)
            if not on_grid or beyond or unlikely:
                runs.append([float(data.time[a]), float(data.time[b - 1])])
    return sorted(runs)


def _event_delays(data: Data, fit: Fit, half: int = 12):
    """At each isolated load change, the shift (samples) that best aligns the signal's changes
    with the model's predicted changes."""
    x, y, p = data.load, data.signal, fit.prediction
    dx = np.diff(x)
    big = np.flatnonzero(np.abs(dx) > 0.05 * data.load_scale)
    events = [int(k) for k in big
              if half < k < len(x) - half - 1 and np.sum(np.abs(big - k) <= 2 * half) == 1]
    out = []
    dy, dp = np.diff(y), np.diff(p)
    for k in events:
        seg_p = dp[k - half:k + half + 1]
        best, best_c = 0, -np.inf
        for lag in range(-half // 2, half // 2 + 1):
            seg_y = dy[k - half + lag:k + half + 1 + lag]
            if len(seg_y) != len(seg_p):
                continue
            c = float(seg_y @ seg_p)
            if c > best_c:
                best, best_c = lag, c
        out.append((k, best))
    return out


def _out_of_step(data: Data, fit: Fit) -> dict | None:
    """A change of the delay between load changes and signal changes part-way through."""
    delays = _event_delays(data, fit)
    if len(delays) < 4:
        return None
    lags = np.array([d for _, d in delays])
    best, best_odd = None, np.inf
    for cut in range(1, len(lags)):
        before, after = lags[:cut], lags[cut:]
        # each side consistent (at most a quarter odd events), and the two sides differ; an
        # event is odd when it lies half-way to the other side's delay or beyond (a slip of
        # 3 samples or more stands out of the +-1 sample scatter of jittered sampling)
        b, a = np.median(before), np.median(after)
        half_way = max(abs(a - b) / 2.0, 0.5)
        odd_before = np.sum(np.abs(before - b) >= half_way)
        odd_after = np.sum(np.abs(after - a) >= half_way)
        odd = odd_before + odd_after
        if min(cut, len(lags) - cut) == 1:
            # a slip before the first or after the last event but one: the lone event must
            # differ by SLIP_ALONE samples or more from at least three that agree exactly
            if len(lags) < 4 or np.sum(before != b) + np.sum(after != a) > 0 or abs(a - b) < SLIP_ALONE:
                continue
        # a delay between two sample counts scatters the lags over both: a change of one
        # sample counts only when no event on either side is odd
        allowed = (lambda m: m // 4) if abs(a - b) >= 2 else (lambda m: 0)
        if abs(a - b) >= 1 and odd_before <= allowed(len(before)) \
                and odd_after <= allowed(len(after)) and odd < best_odd:
            best, best_odd = (cut, a - b), odd
    if best is None:
        return None
    cut, slip = best
    t = data.time
    return {"kind": "out_of_step", "where": [float(t[delays[cut - 1][0]]), float(t[delays[cut][0]])],
            "slip": float(slip * data.dt_median)}


def _sensitivity(fit: Fit) -> float:
    """The largest signal per unit load the model gives: its gain times one plus the sum of
    its creep terms' magnitudes."""
    return abs(fit.gain) * (1.0 + float(np.sum(np.abs(fit.betas))))


class DataProblem(SensorEffect):
    name = "data_problem"
    vocabulary_index = 12
    # the kinds the generator makes
    forms = ("jump", "clipping", "out_of_step", "quantisation")
    programs = ("staircase", "step", "cycles")
    unloads = True
    record_problem = True
    parameters = ("kind", "where")
    parameter_units = {"size": "signal", "step": "signal", "value": "signal"}
    summary = ("the record itself is at fault (signal jumps no load explains, clipping, channels out of "
               "step, coarse quantisation, a load that toggles at every sample)")
    describes_record = True

    _override = None

    def settings(self, data: Data, base: Fit) -> tuple:
        if self._override is not None:
            return self._override
        jumps = tuple(find_jumps(data, base.residual, sensitivity=_sensitivity(base)))
        return (("jumps", jumps), ("times", tuple(float(data.time[i]) for i in jumps)))

    def fit_on(self, data: Data, base: Fit, refine: str = "all", start: dict | None = None,
               quick_fit: QuickFit | None = None) -> Fit:
        applied = Applied(self, self.settings(data, base))
        if not applied.setting("jumps"):
            raise NotApplicable("no signal jump that no load change explains")
        fit = super().fit_on(data, base, refine, start, quick_fit=quick_fit)
        # keep the jumps whose fitted height stands out of its uncertainty
        keep = [j for j, i in enumerate(applied.setting("jumps"))
                if abs(fit.values[f"data_problem.jump[{j}]"]) >= JUMP_Z * fit.uncertainty(
                    lambda v, j=j: v[f"data_problem.jump[{j}]"])]
        if fit.cov is None or len(keep) == len(applied.setting("jumps")) or not keep:
            return fit
        jumps = tuple(applied.setting("jumps")[j] for j in keep)
        self._override = (("jumps", jumps), ("times", tuple(float(data.time[i]) for i in jumps)))
        try:
            return super().fit_on(data, base, refine, start, quick_fit=quick_fit)
        finally:
            self._override = None

    columns_from_lags = False

    def columns(self, data, s, h, lags, p, applied):
        index = np.arange(data.n)
        return {f"jump[{j}]": (index >= i).astype(float) for j, i in enumerate(applied.setting("jumps"))}

    def report(self, fit: Fit, applied: Applied) -> dict:
        jumps = applied.setting("jumps")
        sizes = [fit.estimate(lambda v, j=j: v[f"data_problem.jump[{j}]"]) for j in range(len(jumps))]
        return {"kind": ("jump", None),
                "where": (list(applied.setting("times")), None),
                "size": ([s for s, _ in sizes], [u for _, u in sizes])}

    def extension(self, fit: Fit, applied: Applied) -> dict | None:
        # a jump is in the record, not in the sensor: nothing to simulate or correct
        return None

    def worse_correction_note(self, ratio: float, without_fault: float | None) -> str:
        text = (f"the signal jumps are in the record, not in the sensor: the creep correction does "
                f"not remove them, and with the creep model fitted around them the corrected signal "
                f"is further from the load than with the baseline's, whose creep terms took up part "
                f"of the jumps (correction-error ratio {ratio:.3g})")
        if without_fault is None:
            return text
        return (f"{text}; with the fitted jumps taken out of the signal first, the ratio is "
                f"{without_fault:.3g} (the baseline's on the record as it is)")

    def record_fault(self, fit: Fit, applied: Applied, data: Data) -> np.ndarray:
        """The fitted jumps: the steps they add to the signal (signal units)."""
        index = np.arange(data.n)
        out = np.zeros(data.n)
        for j, i in enumerate(applied.setting("jumps")):
            out += fit.values[f"data_problem.jump[{j}]"] * (index >= i)
        return out

    def screen(self, data: Data, fit: Fit, base: Fit) -> list[dict]:
        return screen(data, fit, base)

    def screened_importance(self, problem: dict, fit: Fit, base: Fit, named: bool) -> tuple:
        if problem["kind"] != "quantisation":
            return math.inf, None
        # on a grid coarser than the noise, what the named effects add together nowhere
        # reaching half a step is not measured by the record: the grid is the cause
        reach = float(np.max(np.abs(fit.prediction - base.prediction)))
        if reach < 0.5 * problem["step"] and named:
            return math.inf, _below_step_note(reach, problem["step"])
        return 0.0, None

    # -- generator ---------------------------------------------------------------------------
    def draw(self, rng, scales, form):
        if form == "jump":
            return dict(size=float(rng.uniform(0.005, 0.03)), count=int(rng.integers(1, 4)))
        if form == "clipping":
            return {"fraction": float(rng.uniform(0.03, 0.1))}
        if form == "out_of_step":
            return {"slip": int(rng.integers(2, 7))}
        return {}

    def finish_draw(self, p, rng, noise):
        if p["form"] == "quantisation":
            p["step"] = float(noise.white * rng.uniform(5.0, 12.0))

    def program_choices(self, p, tau, choices, given):
        if p["form"] == "out_of_step" and not given:
            # a slip shows as a change of delay between load steps: programs with many of them
            return ["staircase", "cycles"]
        return choices

    def truth(self, p, synthetic):
        return {"kind": p["kind"], "where": p["where"]}

    def damage(self, p, t, load, signal, clean, rng):
        return _damaged(p, t, load, signal, clean, rng)


def _below_step_note(reach: float, step: float) -> str:
    return (f"the named effects change the model by {reach:.3g} signal units at most, less than half "
            f"the record's quantisation step ({step:.3g}): the record does not measure them")


def _quiet_indices(load: np.ndarray, margin: int) -> np.ndarray:
    """Samples with no load change within ``margin`` samples either side."""
    changed = np.concatenate([[False], np.diff(load) != 0])
    near = np.convolve(changed.astype(float), np.ones(2 * margin + 1), mode="same") > 0
    return np.flatnonzero(~near[margin:len(load) - margin]) + margin


def _damaged(p: dict, t, load, signal, clean, rng):
    """The generator's record with a data problem of kind ``p["form"]``, and the problem's
    truth (kind, where)."""
    kind = p.get("form", "jump")
    y = signal.copy()
    span = float(np.ptp(clean)) or 1.0
    if kind == "jump":
        quiet = _quiet_indices(load, 12)
        quiet = quiet[(quiet > 0.1 * len(t)) & (quiet < 0.9 * len(t))]
        at = np.sort(rng.choice(quiet, size=min(int(p.get("count", 1)), len(quiet)), replace=False))
        sizes = []
        for i in at:
            size = float(rng.choice([-1, 1]) * p["size"] * span)
            y[i:] += size
            sizes.append(size)
        return y, {"form": kind, "kind": kind, "where": [float(t[i]) for i in at], "size": sizes}
    if kind == "clipping":
        level = float(np.max(clean) - p["fraction"] * span)
        y = np.minimum(y, level)
        at = np.flatnonzero(y >= level)
        return y, {"form": kind, "kind": kind, "level": level,
                   "where": [float(t[at[0]]), float(t[at[-1]])] if len(at) else []}
    if kind == "out_of_step":
        # the signal channel repeats ``slip`` samples at one instant: later than the load after it
        quiet = _quiet_indices(load, 12)
        quiet = quiet[(quiet > 0.35 * len(t)) & (quiet < 0.65 * len(t))]
        i = int(rng.choice(quiet))
        k = int(p["slip"])
        y = np.concatenate([y[:i], np.repeat(y[i], k), y[i:len(y) - k]])
        return y, {"form": kind, "kind": kind, "where": [float(t[i])], "slip": k * float(np.median(np.diff(t)))}
    if kind == "quantisation":
        q = float(p["step"])
        return np.round(signal / q) * q, {"form": kind, "kind": kind, "where": [float(t[0]), float(t[-1])],
                                          "step": q}
    raise InputError(f"data problem '{kind}': use one of {', '.join(DataProblem.forms)}")


EFFECT = DataProblem()
