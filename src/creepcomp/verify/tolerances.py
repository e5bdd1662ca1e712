"""What varies in a design and by how much: tolerances, dielectrics, the tolerance box.

Every factor that moves the residual creep is a :class:`Factor`: each part's value, the
source and load resistance, the sensor's own creep parameters, and the capacitor's dielectric
(absorption fraction and time constant; leakage follows from the dielectric's insulation
resistance at the chosen temperature). Tolerances are relative; a normal distribution's
tolerance is its 3-sigma value.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from creepcomp.analog.parts import DIELECTRICS, Dielectric
from creepcomp.errors import InputError
from creepcomp.io.jsonfiles import Design

__all__ = ["Dielectric", "DIELECTRICS", "ABSORPTION_TAU_RANGE", "Tolerance", "Factor",
           "ToleranceSpec", "factors", "draw"]


#: Time constants of the dielectric-absorption branch (s), drawn log-uniformly. An
#: assumption: absorption has a spread of time constants; the standard soak-and-recover test
#: (minutes) probes seconds to a quarter of an hour.
ABSORPTION_TAU_RANGE = (1.0, 1000.0)


@dataclass(frozen=True)
class Tolerance:
    """A relative tolerance: ``rel`` is 3 sigma of a normal distribution, or the half-width
    of a uniform one."""

    rel: float
    distribution: str = "normal"

    def __post_init__(self):
        if not (math.isfinite(self.rel) and self.rel >= 0):
            raise InputError(f"tolerance {self.rel!r}: must be zero or positive")
        if self.rel >= 1:
            raise InputError(f"tolerance {100 * self.rel:.4g} %: must be below 100 % (the "
                             "tolerance box would reach zero or negative values)")
        if self.distribution not in ("normal", "uniform"):
            raise InputError(f"distribution '{self.distribution}': use normal or uniform")


@dataclass(frozen=True)
class Factor:
    """One quantity that varies: its nominal value, its range (the tolerance box) and how it
    is drawn (``normal``: relative, tolerance at 3 sigma, clipped to the box; ``uniform``;
    ``log-uniform``)."""

    name: str
    nominal: float
    low: float
    high: float
    distribution: str = "normal"
    tolerance: float = 0.0

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """Draw ``n`` values."""
        if self.low == self.high:
            return np.full(n, self.nominal)
        if self.distribution == "normal":
            dev = rng.normal(0.0, self.tolerance / 3.0, n)
            return np.clip(self.nominal * (1.0 + dev), self.low, self.high)
        if self.distribution == "uniform":
            return rng.uniform(self.low, self.high, n)
        return np.exp(rng.uniform(math.log(self.low), math.log(self.high), n))


@dataclass(frozen=True)
class ToleranceSpec:
    """What varies and by how much.

    Parameters
    ----------
    resistor, capacitor : Tolerance
        Default tolerance of every resistor and capacitor.
    parts : mapping
        Per-part tolerances by label (``R1``, ``C1``, ``R2`` ...), overriding the defaults.
    dielectric : str or None
        A key of :data:`DIELECTRICS`: adds absorption and leakage to every cell capacitor.
    temperature : float
        Temperature for the leakage (degrees C).
    source_resistance, load_resistance : (float, float) or None
        Ranges (ohm), uniform and log-uniform; None keeps the design's value.
    beta, tau : Tolerance or None
        Spread of the sensor's own creep amplitude and retardation time, per term.
    """

    resistor: Tolerance = Tolerance(0.01)
    capacitor: Tolerance = Tolerance(0.05)
    parts: Mapping[str, Tolerance] = field(default_factory=dict)
    dielectric: str | None = None
    temperature: float = 25.0
    source_resistance: tuple[float, float] | None = None
    load_resistance: tuple[float, float] | None = None
    beta: Tolerance | None = None
    tau: Tolerance | None = None

    def __post_init__(self):
        if self.dielectric is not None and self.dielectric not in DIELECTRICS:
            raise InputError(f"dielectric '{self.dielectric}': choose one of {', '.join(DIELECTRICS)}")
        for name, rng in (("source resistance", self.source_resistance),
                          ("load resistance", self.load_resistance)):
            if rng is not None and not (0 <= rng[0] <= rng[1] and math.isfinite(rng[1])):
                raise InputError(f"{name} range {rng}: expected 0 <= LOW <= HIGH")
        if self.load_resistance is not None and self.load_resistance[0] <= 0:
            raise InputError("load resistance range must be positive")

    def tolerance_of(self, label: str, kind: str) -> Tolerance:
        """The tolerance of one part."""
        if label in self.parts:
            return self.parts[label]
        return self.resistor if kind == "R" else self.capacitor


def factors(design: Design, spec: ToleranceSpec) -> list[Factor]:
    """The tolerance box of a design: every factor with its nominal value and range."""
    out = []
    known = {label for label, _, _ in design.network.parts()}
    unknown = set(spec.parts) - known
    if unknown:
        raise InputError(f"no part named {', '.join(sorted(unknown))} in the design "
                         f"(parts: {', '.join(sorted(known))})")
    for label, kind, value in design.network.parts():
        tol = spec.tolerance_of(label, kind)
        out.append(_relative_factor(label, value, tol))
    if spec.source_resistance is not None:
        lo, hi = spec.source_resistance
        out.append(Factor("source_resistance", design.network.source_resistance, lo, hi, "uniform"))
    if spec.load_resistance is not None:
        lo, hi = spec.load_resistance
        out.append(Factor("load_resistance", math.sqrt(lo * hi), lo, hi, "log-uniform"))
    for k, (b, t) in enumerate(zip(design.model.beta, design.model.tau)):
        if spec.beta is not None:
            out.append(_relative_factor(f"beta[{k}]", b, spec.beta))
        if spec.tau is not None:
            out.append(_relative_factor(f"tau[{k}]", t, spec.tau))
    if spec.dielectric is not None:
        d = DIELECTRICS[spec.dielectric]
        for label, kind, value in design.network.parts():
            if kind == "C" and label.startswith("C1"):
                lo, hi = d.absorption
                out.append(Factor(f"{label}.absorption", 0.5 * (lo + hi), lo, hi, "uniform"))
                lo, hi = ABSORPTION_TAU_RANGE
                out.append(Factor(f"{label}.absorption_tau", math.sqrt(lo * hi), lo, hi, "log-uniform"))
    return out


def _relative_factor(name: str, nominal: float, tol: Tolerance) -> Factor:
    lo, hi = sorted((nominal * (1 - tol.rel), nominal * (1 + tol.rel)))
    if tol.distribution == "normal":
        return Factor(name, nominal, lo, hi, "normal", tol.rel)
    return Factor(name, nominal, lo, hi, "uniform", tol.rel)


def draw(box: list[Factor], n: int, seed: int) -> dict[str, np.ndarray]:
    """Draw ``n`` samples of every factor (one generator, factors in order: reproducible)."""
    rng = np.random.default_rng(seed)
    return {f.name: f.sample(rng, n) for f in box}
