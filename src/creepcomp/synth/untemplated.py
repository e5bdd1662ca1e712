"""Hidden effects that no diagnosis template describes (the diagnosis must say ``unexplained``),
for the synthetic-record generator only: a multiplicative sensitivity drift over time, a
periodic disturbance, creep whose retardation time ages with the time since the last load
change. Each gives the generator interface of a sensor effect
(:class:`~creepcomp.diagnose.effects.Simulated`), without a diagnosis side."""

from __future__ import annotations

import numpy as np

from creepcomp.diagnose.effects import Scales, SignalPath, Simulated
from creepcomp.synth.loads import PROGRAMS

__all__ = ["Untemplated", "SensitivityDrift", "PeriodicDisturbance", "AgingRetardation", "UNTEMPLATED"]


class Untemplated(Simulated):
    """A generator-only effect: one formulation, its parameters drawn without a ``form``."""

    templated = False
    forms = ()

    def random_parameters(self, rng, scales: Scales, form: str | None = None, mixture: bool = True) -> dict:
        return self.draw(rng, scales, None)


class SensitivityDrift(Untemplated):
    """The gain changes by ``change`` (relative) linearly over the record."""

    name = "sensitivity_drift"
    programs = ("staircase", "step", "mixture", "random", "sweep", "cycles")

    def draw(self, rng, scales, form):
        # the gain changes by 2 ... 6 % over the record
        return {"change": float(rng.choice([-1, 1]) * rng.uniform(0.02, 0.06))}

    def sim_output(self, path: SignalPath, p: dict, y):
        t = path.t_samples
        rel = (path.grid - t[0]) / max(t[-1] - t[0], 1e-12)
        return path.offset + (y - path.offset) * (1.0 + p["change"] * rel)


class PeriodicDisturbance(Untemplated):
    """A sine of ``amplitude`` (signal units), ``period`` and ``phase`` added to the signal."""

    name = "periodic_disturbance"
    programs = PROGRAMS + ("cycles",)

    def draw(self, rng, scales, form):
        # a slow pick-up, 0.2 ... 1 % of full scale
        return {"amplitude": float(rng.uniform(0.002, 0.01) * scales.signal_scale),
                "period": float(rng.uniform(0.04, 0.15) * scales.duration),
                "phase": float(rng.uniform(0, 2 * np.pi))}

    def sim_output(self, path: SignalPath, p: dict, y):
        return y + p["amplitude"] * np.sin(2 * np.pi * path.grid / p["period"] + p["phase"])


class AgingRetardation(Untemplated):
    """Creep whose retardation times grow with the time since the last load change, by a
    factor ``1 + since / age`` (the material stiffens as it rests under a load)."""

    name = "aging_retardation"
    programs = ("staircase", "step", "cycles")
    # aging creep against two creep terms: one further term must not absorb it either
    baseline_terms = 2

    def draw(self, rng, scales, form):
        return {"age": float(scales.tau * rng.uniform(0.5, 2.0))}

    def sim_tau_factor(self, path: SignalPath, p: dict, factor):
        return factor * _aging_factor(path.grid, path.u_after, p["age"])[:, None]


def _aging_factor(grid, u, age: float) -> np.ndarray:
    """Factor on the retardation time over each fine step: ``1 + (time since the last load
    change) / age``."""
    changed = np.concatenate([[True], np.abs(np.diff(u)) > 0])
    last = np.maximum.accumulate(np.where(changed, np.arange(len(grid)), 0))
    since = grid - grid[last]
    return 1.0 + 0.5 * (since[:-1] + since[1:]) / age


#: The generator-only effects, in the order the generator lists them.
UNTEMPLATED = (SensitivityDrift(), PeriodicDisturbance(), AgingRetardation())
