"""What varies in a design and by how much: tolerances, dielectrics, the tolerance box.

Every factor that moves the residual creep is a :class:`Factor`: each part's value, the
source and load resistance, the sensor's own creep parameters, and the capacitor's dielectric
(absorption fraction and time constant; leakage follows from the dielectric's insulation
resistance at the chosen temperature). Tolerances are relative; a normal distribution's
tolerance is its 3-sigma value.

Over temperature (:class:`OverTemperature`) each unit's parts are drawn once, at 25 °C, and
then each part's temperature coefficient, and each thermistor's ``R25`` and ``B``: a part's
TC is drawn about the coefficient its technology is sold with, by as much as that coefficient
(3 sigma: a thin-film resistor of +25 ppm/K anywhere in 0..50 ppm/K, a polypropylene
capacitor of -200 ppm/K in -400..0 ppm/K), since a datasheet bounds a TC by its magnitude
and does not centre it. A lot correlation ``rho`` makes that fraction of the variance of the
TCs (per kind of part) and of the B values common to every part of a unit (one lot of parts
builds one unit), the rest each part's own: ``z_part = sqrt(rho) z_unit + sqrt(1 - rho) e_part``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from creepcomp.analog.parts import DIELECTRICS, Dielectric, PartsPlan
from creepcomp.errors import InputError
from creepcomp.io.jsonfiles import Design

__all__ = ["Dielectric", "DIELECTRICS", "ABSORPTION_TAU_RANGE", "TC_SPREAD", "Tolerance", "Factor",
           "OverTemperature", "ToleranceSpec", "factors", "draw"]


#: Time constants of the dielectric-absorption branch (s), drawn log-uniformly. An
#: assumption: absorption has a spread of time constants; the standard soak-and-recover test
#: (minutes) probes seconds to a quarter of an hour.
ABSORPTION_TAU_RANGE = (1.0, 1000.0)
#: Spread of a part's temperature coefficient, relative to the coefficient its technology is
#: sold with (3 sigma of a normal distribution).
TC_SPREAD = 1.0


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
    group: str | None = None

    def sample(self, rng: np.random.Generator, n: int, common: np.ndarray | None = None,
               correlation: float = 0.0) -> np.ndarray:
        """Draw ``n`` values; a normal factor of a ``group`` mixes in the group's standard
        normal draws ``common`` with weight ``sqrt(correlation)`` (see the module's note)."""
        if self.low == self.high:
            return np.full(n, self.nominal)
        if self.distribution == "normal":
            z = rng.standard_normal(n)
            if common is not None and correlation > 0:
                z = math.sqrt(correlation) * common + math.sqrt(1.0 - correlation) * z
            return np.clip(self.nominal * (1.0 + self.tolerance / 3.0 * z), self.low, self.high)
        if self.distribution == "uniform":
            return rng.uniform(self.low, self.high, n)
        return np.exp(rng.uniform(math.log(self.low), math.log(self.high), n))


@dataclass(frozen=True)
class OverTemperature:
    """Evaluate each unit at several temperatures: sensor, parts and leakage at each.

    Parameters
    ----------
    temperatures : tuple of float
        °C.
    plan : PartsPlan
        The parts' temperature coefficients and thermistors (the design's ``parts`` block).
    lot_correlation : float
        Fraction of the variance of the TCs and B values common to all parts of a unit, in
        [0, 1].
    """

    temperatures: tuple[float, ...]
    plan: PartsPlan = field(default_factory=PartsPlan)
    lot_correlation: float = 0.0

    def __post_init__(self):
        temps = tuple(float(t) for t in self.temperatures)
        if not temps or not all(math.isfinite(t) and t > -273.15 for t in temps):
            raise InputError(f"temperatures {self.temperatures!r}: need at least one, each above "
                             "absolute zero")
        object.__setattr__(self, "temperatures", temps)
        if not (math.isfinite(self.lot_correlation) and 0.0 <= self.lot_correlation <= 1.0):
            raise InputError(f"lot correlation {self.lot_correlation!r}: must be in [0, 1]")


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
    over_temperature : OverTemperature or None
        Evaluate every unit at these temperatures (then ``temperature`` is not used): its
        metrics are its worst over them.
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
    over_temperature: OverTemperature | None = None

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
    over = spec.over_temperature
    thermistors = over.plan.thermistors if over is not None else {}
    coefficients = []
    for label, kind, value in design.network.parts():
        if label in thermistors:
            use = thermistors[label]
            r25_tolerance = spec.parts.get(label, Tolerance(use.tolerance))
            out.append(_relative_factor(f"{label}.R25", use.r25, r25_tolerance))
            coefficients.append(_relative_factor(f"{label}.B", use.b, Tolerance(use.b_tolerance), "B"))
            continue
        tol = spec.tolerance_of(label, kind)
        out.append(_relative_factor(label, value, tol))
        if over is not None:
            tc = over.plan.resistor_tc if kind == "R" else over.plan.capacitor_tc
            lo, hi = sorted((tc * (1 - TC_SPREAD), tc * (1 + TC_SPREAD)))
            coefficients.append(Factor(f"{label}.tc", tc, lo, hi, "normal", TC_SPREAD, f"tc {kind}"))
    out += coefficients
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


def _relative_factor(name: str, nominal: float, tol: Tolerance, group: str | None = None) -> Factor:
    lo, hi = sorted((nominal * (1 - tol.rel), nominal * (1 + tol.rel)))
    if tol.distribution == "normal":
        return Factor(name, nominal, lo, hi, "normal", tol.rel, group)
    return Factor(name, nominal, lo, hi, "uniform", tol.rel)


def draw(box: list[Factor], n: int, seed, correlation: float = 0.0) -> dict[str, np.ndarray]:
    """Draw ``n`` samples of every factor (one generator, factors in order: reproducible).

    With ``correlation`` > 0 the factors of a group (TCs of one kind, B values) share one
    standard normal draw per sample, drawn after every factor.
    """
    rng = np.random.default_rng(seed)
    groups = sorted({f.group for f in box if f.group is not None}) if correlation > 0 else []
    common = {g: np.random.default_rng([*np.atleast_1d(seed).tolist(), _COMMON_STREAM, k])
              .standard_normal(n) for k, g in enumerate(groups)}
    return {f.name: f.sample(rng, n, common.get(f.group), correlation) for f in box}


#: Stream of the per-unit common draws of a lot correlation (apart from the factors' own).
_COMMON_STREAM = 7919
