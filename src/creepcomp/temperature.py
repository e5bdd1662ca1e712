"""Temperature laws of creep: how retardation times and amplitudes follow temperature.

A creep model holds at its reference temperature ``T_ref`` (°C). Every retardation time
shifts by one factor, ``tau_k(T) = tau_k a_T(T)``:

- ``arrhenius``: ``a_T = exp(E_a / R (1/T - 1/T_ref))`` with absolute temperatures (K) and
  the activation energy ``E_a`` in J/mol (elastomers far above their glass transition);
- ``wlf``: ``log10 a_T = -c1 (T - T_ref) / (c2 + T - T_ref)`` (Williams-Landel-Ferry, near
  the glass transition; ``c2`` in K).

Optionally each amplitude changes linearly: ``beta_k(T) = beta_k (1 + b_k (T - T_ref))``.
See ``docs/physics.md``, section "Over temperature".
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from creepcomp.errors import InputError
from creepcomp.units import check_number

__all__ = ["GAS_CONSTANT", "ZERO_CELSIUS", "LAWS", "TemperatureLaw", "step_temperatures",
           "temperature_grid"]

#: Molar gas constant, J/(mol K) (CODATA 2018, exact).
GAS_CONSTANT = 8.314462618
#: 0 °C in kelvin.
ZERO_CELSIUS = 273.15
#: The laws a model file may name.
LAWS = ("arrhenius", "wlf")


#: Largest activation energy of a creep law (J/mol): a covalent bond's is about 350 kJ/mol,
#: an elastomer's creep tens to a few hundred kJ/mol.
MAX_ACTIVATION_ENERGY = 1e6


def _finite(value, name: str, where: str) -> float:
    try:
        return check_number(value, name)
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None


@dataclass(frozen=True)
class TemperatureLaw:
    """How a creep model's terms change with temperature.

    Parameters
    ----------
    reference : float
        Temperature (°C) at which the model's ``beta`` and ``tau`` hold.
    law : {"arrhenius", "wlf"}
        Shift of every retardation time.
    activation_energy : float, optional
        ``E_a`` in J/mol (``arrhenius``), >= 0.
    c1, c2 : float, optional
        WLF constants (``wlf``; ``c2`` in K, > 0).
    beta_per_kelvin : tuple of float
        Per term, relative change of ``beta_k`` per kelvin; empty means none.
    uncertainty : mapping
        One standard uncertainty per fitted key (e.g. ``activation_energy``), kept as given.
    """

    reference: float
    law: str = "arrhenius"
    activation_energy: float | None = None
    c1: float | None = None
    c2: float | None = None
    beta_per_kelvin: tuple[float, ...] = ()
    uncertainty: Mapping[str, float] = field(default_factory=dict, compare=False)

    def __post_init__(self):
        where = "temperature law"
        ref = _finite(self.reference, "reference", where)
        if ref <= -ZERO_CELSIUS:
            raise InputError(f"{where}: reference = {ref:g} °C is at or below absolute zero")
        object.__setattr__(self, "reference", ref)
        if self.law not in LAWS:
            raise InputError(f"{where}: law = {self.law!r}; expected one of {', '.join(LAWS)}")
        if self.law == "arrhenius":
            if self.activation_energy is None:
                raise InputError(f"{where}: an arrhenius law needs 'activation_energy' (J/mol)")
            ea = _finite(self.activation_energy, "activation_energy", where)
            if ea < 0:
                raise InputError(f"{where}: activation_energy = {ea:g} J/mol; it must be >= 0 "
                                 "(retardation speeds up with temperature)")
            if ea > MAX_ACTIVATION_ENERGY:
                raise InputError(f"{where}: activation_energy = {ea:g} J/mol; at most "
                                 f"{MAX_ACTIVATION_ENERGY:g} J/mol (a covalent bond's is 3.5e+05)")
            object.__setattr__(self, "activation_energy", ea)
        else:
            if self.c1 is None or self.c2 is None:
                raise InputError(f"{where}: a wlf law needs 'c1' and 'c2' (K)")
            c1 = _finite(self.c1, "c1", where)
            c2 = _finite(self.c2, "c2", where)
            if c2 <= 0:
                raise InputError(f"{where}: c2 = {c2:g} K; it must be > 0")
            object.__setattr__(self, "c1", c1)
            object.__setattr__(self, "c2", c2)
        bpk = tuple(_finite(b, f"beta_per_kelvin[{k}]", where)
                    for k, b in enumerate(self.beta_per_kelvin or ()))
        object.__setattr__(self, "beta_per_kelvin", bpk)

    @classmethod
    def arrhenius(cls, activation_energy: float, reference: float = 20.0, beta_per_kelvin=()) -> "TemperatureLaw":
        """An Arrhenius law of ``activation_energy`` J/mol about ``reference`` °C."""
        return cls(reference, "arrhenius", activation_energy, beta_per_kelvin=tuple(beta_per_kelvin))

    @classmethod
    def from_kappa(cls, kappa: float, reference: float) -> "TemperatureLaw":
        """The Arrhenius law whose slope at ``reference`` is ``d ln(1/a_T)/dT = kappa`` (1/K)."""
        return cls.arrhenius(kappa * GAS_CONSTANT * (reference + ZERO_CELSIUS) ** 2, reference)

    @property
    def kappa(self) -> float:
        """Slope ``-d ln a_T / dT`` at the reference temperature (1/K)."""
        if self.law == "arrhenius":
            return self.activation_energy / (GAS_CONSTANT * (self.reference + ZERO_CELSIUS) ** 2)
        return self.c1 * math.log(10.0) / self.c2

    def _check(self, t: np.ndarray) -> None:
        if not np.all(np.isfinite(t)):
            raise InputError("temperature: a value is not a finite number")
        if np.any(t <= -ZERO_CELSIUS):
            raise InputError(f"temperature {float(np.min(t)):g} °C is at or below absolute zero")
        if self.law == "wlf" and np.any(t - self.reference <= -self.c2):
            raise InputError(f"temperature {float(np.min(t)):g} °C is at or below the WLF law's "
                             f"singularity T_ref - c2 = {self.reference - self.c2:g} °C")

    def shift(self, temperature) -> np.ndarray:
        """The shift factor ``a_T``: ``tau_k(T) = tau_k a_T`` (1 at the reference)."""
        t = np.asarray(temperature, dtype=float)
        self._check(t)
        if self.law == "arrhenius":
            inv = 1.0 / (t + ZERO_CELSIUS) - 1.0 / (self.reference + ZERO_CELSIUS)
            return np.exp(self.activation_energy / GAS_CONSTANT * inv)
        d = t - self.reference
        return 10.0 ** (-self.c1 * d / (self.c2 + d))

    def beta_factor(self, temperature, n_terms: int) -> np.ndarray:
        """Factor on each ``beta_k``, shape ``temperature.shape + (n_terms,)``."""
        t = np.asarray(temperature, dtype=float)
        b = np.array(self.beta_per_kelvin) if self.beta_per_kelvin else np.zeros(n_terms)
        if len(b) != n_terms:
            raise InputError(f"temperature law: beta_per_kelvin has {len(b)} entries for "
                             f"{n_terms} creep terms")
        return 1.0 + b * (t[..., None] - self.reference)

    def to_dict(self) -> dict:
        """Model-file form (``docs/design-file.md``)."""
        out: dict[str, Any] = {"reference": self.reference, "law": self.law}
        if self.law == "arrhenius":
            out["activation_energy"] = self.activation_energy
        else:
            out["c1"], out["c2"] = self.c1, self.c2
        if self.beta_per_kelvin:
            out["beta_per_kelvin"] = list(self.beta_per_kelvin)
        if self.uncertainty:
            out["uncertainty"] = dict(self.uncertainty)
        return out

    @classmethod
    def from_dict(cls, data: Mapping, where: str = "temperature") -> "TemperatureLaw":
        """Read a model file's ``temperature`` block.

        Raises
        ------
        InputError
            Naming ``where`` and the key that is wrong.
        """
        if not isinstance(data, Mapping):
            raise InputError(f"{where}: expected a JSON object with 'reference' and 'law'")
        if "reference" not in data:
            raise InputError(f"{where}: missing 'reference' (°C at which beta and tau hold)")
        bpk = data.get("beta_per_kelvin", ()) or ()
        if not isinstance(bpk, (list, tuple)):
            raise InputError(f"{where}: 'beta_per_kelvin' must be a list, one entry per term")
        unc = data.get("uncertainty", {}) or {}
        if not isinstance(unc, Mapping):
            raise InputError(f"{where}: 'uncertainty' must be an object")
        try:
            return cls(data["reference"], data.get("law", "arrhenius"), data.get("activation_energy"),
                       data.get("c1"), data.get("c2"), tuple(bpk), dict(unc))
        except InputError as exc:
            raise InputError(f"{where}: {str(exc).removeprefix('temperature law: ')}") from None


def step_temperatures(temperature) -> np.ndarray:
    """Temperature over each sample step: the mean of its two ends (shape ``N-1``)."""
    t = np.asarray(temperature, dtype=float)
    return 0.5 * (t[:-1] + t[1:])


def temperature_grid(low: float, high: float, step: float = 5.0) -> np.ndarray:
    """Temperatures from ``low`` to ``high`` (°C), at most ``step`` K apart, both limits included."""
    if not (math.isfinite(low) and math.isfinite(high)) or high < low:
        raise InputError(f"temperature range {low:g}:{high:g} °C: expected LOW:HIGH with LOW <= HIGH")
    if low <= -ZERO_CELSIUS:
        raise InputError(f"temperature range {low:g}:{high:g} °C reaches absolute zero")
    n = max(int(math.ceil((high - low) / step - 1e-9)), 0) + 1
    return np.linspace(low, high, n) if n > 1 else np.array([low])
