"""``time_offset``: signal and load are not sampled at the same instant; ``delay`` in s,
signal later than load. The load the sensor saw at ``t`` is the load record at ``t - delay``
(interpolated linearly; held at its first value before the record), averaged over a window of
``width`` s centred there (an averaging converter, a filter of finite impulse response: its
group delay is ``delay``; ``width`` 0, the default, is a plain delay)."""

from __future__ import annotations

import numpy as np

from creepcomp.fit.structure import Applied, Param
from creepcomp.fit.solver import Fit
from creepcomp.diagnose.effects import SensorEffect

__all__ = ["shifted", "averaged", "latency", "TimeOffset", "EFFECT"]

#: A window narrower than this share of the shortest sample step is a plain delay.
NARROW = 1e-3
#: Delays shorter than this share of the sample step read every sample within that share of
#: its own time, where the load is known: no sample is left free (:meth:`TimeOffset.straddling`),
#: else a delay of next to nothing would free the first sample after every step.
STRADDLE_DELAY = 0.1
#: Widest averaging window fitted, in sample steps.
MAX_WIDTH_SAMPLES = 32


def shifted(time, values, delay: float) -> np.ndarray:
    """``values`` at ``time - delay`` (linear interpolation, ends held)."""
    return np.interp(np.asarray(time) - delay, time, values)


def _integral_at(time, values, at) -> np.ndarray:
    """Integral from ``time[0]`` to ``at`` of ``values`` interpolated linearly (held flat
    beyond the ends), exact."""
    t = np.asarray(time, float)
    x = np.asarray(values, float)
    at = np.asarray(at, float)
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (x[:-1] + x[1:]) * np.diff(t))])
    i = np.clip(np.searchsorted(t, at, side="right") - 1, 0, len(t) - 2)
    u = np.clip(at, t[0], t[-1]) - t[i]
    slope = (x[i + 1] - x[i]) / (t[i + 1] - t[i])
    inside = cum[i] + x[i] * u + 0.5 * slope * u ** 2
    return inside + x[0] * np.minimum(at - t[0], 0.0) + x[-1] * np.maximum(at - t[-1], 0.0)


def _plain_delay(t: np.ndarray, width: float) -> bool:
    """A window of ``width`` s is a plain delay at these sample times (:data:`NARROW`)."""
    return len(t) < 2 or width <= 0.0 or width <= NARROW * float(np.min(np.diff(t)))


def averaged(time, values, delay: float, width: float) -> np.ndarray:
    """``values`` averaged over ``[t - delay - width/2, t - delay + width/2]`` (``width`` 0: the
    plain delay, :func:`shifted`)."""
    t = np.asarray(time, float)
    if _plain_delay(t, width):
        # the difference of two integrals over a narrow window loses its digits
        return shifted(t, values, delay)
    hi = _integral_at(t, values, t - delay + 0.5 * width)
    lo = _integral_at(t, values, t - delay - 0.5 * width)
    return (hi - lo) / width


def latency(entry: dict) -> float:
    """How far ahead of a sample the signal must reach to give the load there (s): the
    model file's ``delay`` plus half its ``width`` (0 for a signal read early). The load over
    a record's last ``latency`` seconds is not in the record."""
    return max(float(entry["delay"]) + 0.5 * float(entry.get("width", 0.0)), 0.0)


class TimeOffset(SensorEffect):
    name = "time_offset"
    vocabulary_index = 8
    # a delay; a boxcar-averaging ADC (group delay)
    forms = ("delay", "average")
    programs = ("staircase", "step", "mixture", "random", "sweep")
    parameters = ("delay", "width")
    parameter_units = {"width": "s"}
    summary = "signal and load sampled at different instants (or the signal averaged over a window)"
    fresh_ahead = "own"

    def settings(self, data, base):
        return (("window", True),)

    def plain_settings(self, data, base):
        return ()

    def nonlinear_params(self, data, applied):
        limit = min(0.1 * data.duration, 500.0 * data.dt_median)
        delay = Param("delay", -limit, limit, scale=data.dt_median)
        if not applied.setting("window", False):
            return [delay]
        return [delay, Param("width", 0.0, MAX_WIDTH_SAMPLES * data.dt_median, scale=data.dt_median)]

    def starts(self, data, base, applied):
        dt = data.dt_median
        limit = min(0.1 * data.duration, 500.0 * dt)
        steps = [0.3, 1, 2, 4, 8, 16, 32, 64, 128]
        plain = [{"delay": sign * f * dt, "width": 0.0} for f in steps for sign in (1, -1) if f * dt < limit]
        boxes = [{"delay": 0.5 * k * dt, "width": k * dt} for k in (2, 4, 7) if k * dt < limit]
        return plain + boxes

    def fit_on(self, data, base, refine="all", start=None, settings=None, quick_fit=None):
        # a delay of a few samples is mimicked by a fast creep term of large beta, which the
        # baseline may have fitted: fit the effect with the creep term started afresh as well
        fit = super().fit_on(data, base, refine, start, settings, quick_fit)
        return self.with_fresh_term(data, base, fit, refine, start, settings, quick_fit=quick_fit)

    def load_transform(self, data, x, p, applied):
        return averaged(data.time, x, p["delay"], p.get("width", 0.0))

    def straddling(self, data, p, applied):
        # the load between samples is taken linear: across a step that is only its expected
        # value (where in the interval the load stepped is unknown), and a sample read there
        # would be missed by up to the whole step; a window averages the unknown over its width
        width, steps = p.get("width", 0.0), data.abrupt
        if not len(steps) or not _plain_delay(data.time, width):
            return np.zeros(0, int)
        t, delay = data.time, p["delay"]
        if abs(delay) < STRADDLE_DELAY * data.dt_median:
            return np.zeros(0, int)
        first = np.searchsorted(t, t[steps] + delay, side="right")     # reads after the interval's start
        end = np.searchsorted(t, t[steps + 1] + delay, side="left")    # ... and before its end
        inside = [np.arange(a, b) for a, b in zip(first.tolist(), end.tolist()) if b > a]
        return np.unique(np.concatenate(inside)) if inside else np.zeros(0, int)

    def held_in_refits(self, data, p, applied):
        # with the samples read across a step left free, the fitted samples do not tell where
        # in its sample interval the delay lies (its cost moves by rounding there): a refit on
        # part of the record would move it as rounding leads, out of the interval
        return ("delay",) if len(self.straddling(data, p, applied)) else ()

    def report(self, fit: Fit, applied: Applied) -> dict:
        out = {"delay": fit.estimate(lambda v: v["time_offset.delay"])}
        if "time_offset.width" in fit.values:
            out["width"] = fit.estimate(lambda v: v["time_offset.width"])
        return out

    def extension(self, fit: Fit, applied: Applied) -> dict:
        return {"delay": fit.values["time_offset.delay"], "width": fit.values.get("time_offset.width", 0.0)}

    def restore(self, entry, model, data):
        values = {"time_offset.delay": float(entry["delay"])}
        if float(entry.get("width", 0.0)) > 0:
            values["time_offset.width"] = float(entry["width"])
            return Applied(self, (("window", True),)), values
        return Applied(self, ()), values

    def precondition(self, data, delta, load, values, applied):
        # the adjoint of the window (shift back, average again): a window's response turns
        # negative at some frequencies, where dividing by it, or ignoring it, would not converge
        return averaged(data.time, delta, -values["time_offset.delay"], values.get("time_offset.width", 0.0))

    def inverse(self, entry, model):
        delay, width = float(entry["delay"]), float(entry.get("width", 0.0))
        window = f", averaged over {width:.3g} s" if width > 0 else ""
        return (f"the load that, read {delay:.3g} s earlier{window}, gives the signal: the load at t is "
                f"known from the signal up to t + {latency(entry):.3g} s (a latency)")

    # -- generator ---------------------------------------------------------------------------
    def draw_default(self, rng, scales, mixture):
        dt = 1.0 / scales.rate
        return {"delay": float(dt * rng.uniform(2.0, 10.0))}

    def draw(self, rng, scales, form):
        if form == "average":
            k = int(rng.integers(3, 9))
            return dict(samples=k, delay=float((k - 1) / 2.0 / scales.rate))
        return {"delay": float(rng.uniform(2.0, 10.0) / scales.rate)}

    def truth(self, p, synthetic):
        return {"delay": p["delay"]}

    def sim_lead(self, p):
        return 0.0 if p.get("form") == "average" else float(p.get("delay", 0.0))

    def sim_sample(self, path, p, y):
        t = path.t_samples
        if p.get("form") == "average":
            k = int(p["samples"])
            return np.mean([np.interp(t - j / path.rate, path.grid, y) for j in range(k)], axis=0)
        return np.interp(t - self.sim_lead(p), path.grid, y)


EFFECT = TimeOffset()
