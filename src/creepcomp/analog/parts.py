"""The parts a network is built from: technologies, how they move with temperature, thermistors.

Tables of what makers sell, each entry with its source (makers' catalogues; typical figures,
to be checked against the datasheet of the part ordered):

- resistor technologies: the values made, the tolerances and temperature coefficients sold;
- capacitor dielectrics: the values made, tolerances, temperature coefficient, dielectric
  absorption and insulation resistance (as the time constant ``R_ins C``);
- NTC thermistors: ``R25`` and ``B`` of catalogue parts.

A design records the parts it assumed in its ``parts`` block (:class:`PartsPlan`), which
gives every part's value at any temperature (:func:`network_at`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from creepcomp.errors import InputError
from creepcomp.network import Network
from creepcomp.temperature import ZERO_CELSIUS
from creepcomp.units import check_number

__all__ = ["PART_REFERENCE", "ResistorTechnology", "RESISTORS", "Dielectric", "DIELECTRICS",
           "Thermistor", "NTC_THERMISTORS", "ntc_resistance", "ThermistorUse", "PartsPlan",
           "network_at", "plan_of"]

#: Temperature (°C) at which catalogue values, tolerances and ``R25`` hold.
PART_REFERENCE = 25.0


@dataclass(frozen=True)
class ResistorTechnology:
    """A resistor technology: values made (ohm), tolerances and TCRs sold (1/K), source."""

    name: str
    value_range: tuple[float, float]
    tolerances: tuple[float, ...]
    tcs: tuple[float, ...]
    source: str

    @property
    def tc(self) -> float:
        """The usual temperature coefficient (the middle one sold), 1/K."""
        return self.tcs[len(self.tcs) // 2]


RESISTORS: dict[str, ResistorTechnology] = {
    "thin film": ResistorTechnology(
        "thin film", (10.0, 8.87e6), (0.001, 0.005, 0.01), (10e-6, 25e-6, 50e-6),
        "Vishay TNPW e3 datasheet (doc. 28758): 10 Ω to 8.87 MΩ over sizes 0402-2512, "
        "±0.1/0.5/1 %, ±10/15/25/50 ppm/K"),
    "thick film": ResistorTechnology(
        "thick film", (1.0, 10e6), (0.01, 0.05), (100e-6, 200e-6),
        "general-purpose thick-film chip resistors (e.g. Yageo RC, Vishay CRCW): 1 Ω to 10 MΩ, "
        "±1/5 %, ±100 ppm/K (±200 ppm/K at the range ends)"),
    "high-ohmic thick film": ResistorTechnology(
        "high-ohmic thick film", (1e6, 1e9), (0.01, 0.05), (100e-6, 200e-6),
        "high-ohmic thick-film chip resistors (e.g. Vishay CRHV, Ohmite HVC): up to 1 GΩ in "
        "catalogue sizes, ±1/5 %, ±100-200 ppm/K"),
}


@dataclass(frozen=True)
class Dielectric:
    """A capacitor technology: values made (F), tolerances sold, temperature coefficient
    (1/K, linear about 25 °C), dielectric absorption (fraction range) and insulation
    resistance as the time constant ``R_ins C`` at 25 and 85 °C; its source."""

    name: str
    tolerances: tuple[float, ...]
    absorption: tuple[float, float]
    insulation_rc: tuple[float, float]          # seconds at 25 C and at 85 C
    tc: float = 0.0
    value_range: tuple[float, float] = (100e-12, 100e-6)
    source: str = ""

    def insulation_time(self, temperature: float) -> float:
        """R_ins * C at ``temperature`` (log-linear between 25 and 85 C, extrapolated beyond)."""
        (t25, t85) = self.insulation_rc
        slope = math.log(t85 / t25) / 60.0
        return t25 * math.exp(slope * (temperature - 25.0))


_FILM = ("WIMA film capacitor catalogue (MKP/FKP polypropylene, MKS polyester): tolerances, "
         "dielectric absorption, insulation resistance at 25 and 85 °C, ΔC/C over temperature")
DIELECTRICS: dict[str, Dielectric] = {
    "polypropylene": Dielectric("polypropylene", (0.01, 0.025, 0.05, 0.10), (0.0005, 0.001), (1e5, 1e4),
                                -200e-6, (100e-12, 100e-6), _FILM),
    "polyester": Dielectric("polyester", (0.05, 0.10, 0.20), (0.002, 0.0025), (1e4, 1e3),
                            400e-6, (1e-9, 100e-6), _FILM),
    "x7r": Dielectric("X7R ceramic", (0.10, 0.20), (0.006, 0.025), (1e3, 5e2),
                      0.0, (100e-12, 22e-6),
                      "EIA class II X7R: ±15 % over -55..125 °C, not a linear coefficient "
                      "(taken as 0 here; its tolerance covers it)"),
}


@dataclass(frozen=True)
class Thermistor:
    """A catalogue NTC thermistor: ``R25`` (ohm), ``B`` (K, ``B25/50``), tolerances."""

    part: str
    r25: float
    b: float
    tolerance: float
    b_tolerance: float
    source: str


_MURATA = "Murata NTC thermistor catalogue R44E (NCP18 series, 0603), B25/50"
_VISHAY = "Vishay NTCLE100E3 datasheet, B25/85"
NTC_THERMISTORS: tuple[Thermistor, ...] = (
    Thermistor("Murata NCP18XQ471", 470.0, 3650.0, 0.05, 0.03, _MURATA),
    Thermistor("Murata NCP18XM472", 4.7e3, 3500.0, 0.05, 0.03, _MURATA),
    Thermistor("Murata NCP18XH103", 10e3, 3380.0, 0.01, 0.01, _MURATA),
    Thermistor("Murata NCP18XW223", 22e3, 3950.0, 0.05, 0.02, _MURATA),
    Thermistor("Murata NCP18WB473", 47e3, 4050.0, 0.05, 0.03, _MURATA),
    Thermistor("Murata NCP18WF104", 100e3, 4250.0, 0.01, 0.01, _MURATA),
    Thermistor("Murata NCP18WM154", 150e3, 4500.0, 0.05, 0.03, _MURATA),
    Thermistor("Vishay NTCLE100E3103", 10e3, 3977.0, 0.02, 0.0075, _VISHAY),
)


def ntc_resistance(r25: float, b: float, temperature) -> np.ndarray:
    """``R(T) = R25 exp(B (1/T - 1/298.15 K))``, the B-parameter law of an NTC thermistor."""
    t = np.asarray(temperature, dtype=float) + ZERO_CELSIUS
    return r25 * np.exp(b * (1.0 / t - 1.0 / (PART_REFERENCE + ZERO_CELSIUS)))


@dataclass(frozen=True)
class ThermistorUse:
    """One time-setting resistor made of an NTC thermistor, with an optional fixed resistor
    in series and one in parallel: ``R(T) = (series + R_ntc(T)) || parallel``."""

    part: str
    r25: float
    b: float
    series: float = 0.0
    parallel: float | None = None
    tolerance: float = 0.01
    b_tolerance: float = 0.01

    def resistance(self, temperature) -> np.ndarray:
        """The resistance the network sees at ``temperature`` (°C)."""
        r = self.series + ntc_resistance(self.r25, self.b, temperature)
        return r if self.parallel is None else r * self.parallel / (r + self.parallel)

    def to_dict(self) -> dict:
        return {"part": self.part, "R25": self.r25, "B": self.b, "series": self.series,
                "parallel": self.parallel, "tolerance": self.tolerance, "B_tolerance": self.b_tolerance}


def _choice(data, kind: str, table: Mapping, where: str) -> tuple[str, float, float]:
    if not isinstance(data, Mapping):
        raise InputError(f"{where}: '{kind}' must be an object with 'technology'")
    tech = str(data.get("technology", ""))
    if tech not in table:
        raise InputError(f"{where}: {kind} technology {tech!r}; expected one of {', '.join(table)}")
    tol = check_number(data.get("tolerance", min(table[tech].tolerances)), f"{where}: {kind} tolerance")
    tc = check_number(data.get("tc", table[tech].tc), f"{where}: {kind} tc")
    if not (0 <= tol < 1):
        raise InputError(f"{where}: {kind} tolerance {tol!r} must be in [0, 1)")
    return tech, tol, tc


@dataclass(frozen=True)
class PartsPlan:
    """The parts a design assumes (a design file's ``parts`` block).

    Parameters
    ----------
    resistor, capacitor : str
        Technology keys of :data:`RESISTORS` and :data:`DIELECTRICS`.
    resistor_tolerance, capacitor_tolerance : float
        Relative tolerances bought.
    resistor_tc, capacitor_tc : float
        Temperature coefficients (1/K) about :data:`PART_REFERENCE`.
    thermistors : mapping of str to ThermistorUse
        Resistors (by label, ``R1``, ``R1.2`` ...) made of NTC thermistors.
    """

    resistor: str = "thin film"
    capacitor: str = "polypropylene"
    resistor_tolerance: float = 0.01
    capacitor_tolerance: float = 0.05
    resistor_tc: float = 25e-6
    capacitor_tc: float = -200e-6
    thermistors: Mapping[str, ThermistorUse] = field(default_factory=dict)

    @property
    def tracking(self) -> str:
        """``ntc`` when some resistors are thermistors, else ``none``."""
        return "ntc" if self.thermistors else "none"

    def value_at(self, label: str, kind: str, nominal: float, temperature: float) -> float:
        """A part's value at ``temperature`` (°C); ``nominal`` holds at :data:`PART_REFERENCE`."""
        if label in self.thermistors:
            return float(self.thermistors[label].resistance(temperature))
        tc = self.resistor_tc if kind == "R" else self.capacitor_tc
        return nominal * (1.0 + tc * (temperature - PART_REFERENCE))

    def to_dict(self) -> dict:
        """Design-file form."""
        out = {"resistors": {"technology": self.resistor, "tolerance": self.resistor_tolerance,
                             "tc": self.resistor_tc},
               "capacitors": {"technology": self.capacitor, "tolerance": self.capacitor_tolerance,
                              "tc": self.capacitor_tc}}
        if self.thermistors:
            out["thermistors"] = {k: v.to_dict() for k, v in self.thermistors.items()}
        return out

    @classmethod
    def from_dict(cls, data: Mapping, where: str = "parts") -> "PartsPlan":
        """Read a design file's ``parts`` block, naming ``where`` and the key that is wrong."""
        if not isinstance(data, Mapping):
            raise InputError(f"{where}: expected an object with 'resistors' and 'capacitors'")
        r, rtol, rtc = _choice(data.get("resistors", {"technology": "thin film"}), "resistors",
                               RESISTORS, where)
        c, ctol, ctc = _choice(data.get("capacitors", {"technology": "polypropylene"}), "capacitors",
                               DIELECTRICS, where)
        therm = {}
        for label, t in (data.get("thermistors") or {}).items():
            try:
                name = f"{where}: thermistor {str(label)[:40]!r}"
                therm[str(label)] = ThermistorUse(
                    str(t.get("part", "NTC")), check_number(t["R25"], f"{name} R25"),
                    check_number(t["B"], f"{name} B"),
                    check_number(t.get("series", 0.0) or 0.0, f"{name} series"),
                    None if t.get("parallel") is None else check_number(t["parallel"], f"{name} parallel"),
                    check_number(t.get("tolerance", 0.01), f"{name} tolerance"),
                    check_number(t.get("B_tolerance", 0.01), f"{name} B_tolerance"))
            except (KeyError, AttributeError):
                raise InputError(f"{where}: thermistor {label!r} needs numbers 'R25' and 'B' "
                                 "(optional 'series', 'parallel', 'tolerance', 'B_tolerance')") from None
            u = therm[str(label)]
            if not (u.r25 > 0 and u.b > 0 and u.series >= 0 and (u.parallel is None or u.parallel > 0)):
                raise InputError(f"{where}: thermistor {label!r}: R25, B, parallel must be positive, "
                                 "series zero or positive")
            if not (0 <= u.tolerance < 1 and 0 <= u.b_tolerance < 1):
                raise InputError(f"{where}: thermistor {label!r}: tolerance and B_tolerance must be "
                                 "in [0, 1)")
        return cls(r, c, rtol, ctol, rtc, ctc, therm)


def network_at(network: Network, plan: PartsPlan, temperature: float) -> Network:
    """The network with every part at its value at ``temperature`` (°C).

    Part values in ``network`` hold at :data:`PART_REFERENCE`; thermistors take their value
    from their ``R25`` and ``B`` (the network's value for them is not used).
    """
    labels = network.parts()
    unknown = set(plan.thermistors) - {label for label, kind, _ in labels if kind == "R"}
    if unknown:
        raise InputError(f"parts: thermistor {', '.join(sorted(unknown))} is not a resistor of "
                         f"the network ({', '.join(lab for lab, k, _ in labels if k == 'R')})")
    values = [plan.value_at(label, kind, value, temperature) for label, kind, value in labels]
    return network.with_parts(values)


def plan_of(design, where: str = "design") -> PartsPlan:
    """The parts a design file assumed (its ``parts`` block), or the defaults without one."""
    data = design.extra.get("parts")
    return PartsPlan() if data is None else PartsPlan.from_dict(data, where=f"{where}: 'parts'")
