"""The creep model: Prony terms ``G(s) = 1 + sum_k beta_k / (1 + s tau_k)``.

See ``docs/physics.md``, section 1.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping, TYPE_CHECKING

import numpy as np

from creepcomp.display import Shown
from creepcomp.errors import InputError
from creepcomp.units import check_number
from creepcomp.load_filter import LoadFilter
from creepcomp.lti import LagExpansion, varying_lag_states
from creepcomp.temperature import TemperatureLaw, step_temperatures
from creepcomp.transfer import Transfer

if TYPE_CHECKING:
    import control

__all__ = ["CreepModel", "MAX_TERMS", "VALUE_RANGE", "TAU_RANGE", "MAX_BETA"]

#: Magnitudes a model's gain and offset may have (signal units): float32, the firmware's type,
#: holds up to 3.4e38 and down to 1.2e-38 without losing precision, and the corrector's sums
#: and a record's squared error stay finite in float64 well inside this range.
VALUE_RANGE = (1e-30, 1e30)
#: Retardation times a model may have (s): a nanosecond to 31 million years (the longest
#: record time a fit reads).
TAU_RANGE = (1e-9, 1e15)
#: Largest relative amplitude of one creep term: 10,000 %; a measured creep is a few %.
MAX_BETA = 100.0


def _check_parameters(value, name: str) -> None:
    """Every number in an extension's parameters (nested objects and lists) is a real, finite
    number; text (a form, a switch) stays text."""
    if isinstance(value, Mapping):
        for key, item in value.items():
            _check_parameters(item, f"{name}.{key}")
    elif isinstance(value, list):
        for k, item in enumerate(value):
            _check_parameters(item, f"{name}[{k}]")
    elif value is not None and not isinstance(value, str):
        check_number(value, name)


def _without_beta_law(law: TemperatureLaw) -> TemperatureLaw:
    """The same shift law with no per-term amplitude law (for another number of terms)."""
    return TemperatureLaw(law.reference, law.law, law.activation_energy, law.c1, law.c2, (),
                          dict(law.uncertainty))


#: Most creep terms a model may have: a measured sensor's creep needs one to four, and every
#: size-driven computation downstream (cells, states, Monte Carlo arrays) grows with it.
MAX_TERMS = 20


@dataclass(frozen=True)
class CreepModel(Shown):
    """Linear creep of a sensor: raw signal = ``offset + gain * G(s) [load]``.

    Parameters
    ----------
    beta : tuple of float
        Relative creep amplitude of each term (may be negative: overshooting sensors).
    tau : tuple of float
        Retardation time of each term in seconds.
    gain : float
        Instantaneous signal per unit load (signal units / load units).
    offset : float
        Signal at zero load.
    extensions : mapping
        Fitted extensions of the model (see ``docs/diagnosis.md``), kept as given.
    temperature : TemperatureLaw, optional
        How ``beta`` and ``tau`` follow temperature; they hold at its reference. Without it
        the model has one temperature.
    transfer : Transfer, optional
        Static monotone maps on either side of the creep (:mod:`creepcomp.transfer`): the
        raw signal is then ``h^-1(offset + gain * G(s)[f(load)])``. Without it (or with no
        map) the signal is linear in load.
    load_filter : LoadFilter, optional
        A moving average of the load estimate (:mod:`creepcomp.load_filter`): noise traded
        against lag, chosen on held-out data. It acts on the load only, not on the
        compensated signal.

    Notes
    -----
    A model with no creep terms (``beta = tau = ()``) is a static calibration: the
    zero-creep member of the family, which a soft sensor's creep model must beat.
    """

    beta: tuple[float, ...]
    tau: tuple[float, ...]
    gain: float = 1.0
    offset: float = 0.0
    extensions: Mapping[str, Any] = field(default_factory=dict, compare=False)
    temperature: TemperatureLaw | None = None
    transfer: Transfer | None = None
    load_filter: LoadFilter | None = None

    def __post_init__(self):
        beta = self.beta if isinstance(self.beta, (list, tuple, np.ndarray)) else [self.beta]
        tau = self.tau if isinstance(self.tau, (list, tuple, np.ndarray)) else [self.tau]
        single = len(beta) == 1
        names = (lambda k: ("beta0", "tau")) if single else (lambda k: (f"beta[{k}]", f"tau[{k}]"))
        if len(beta) != len(tau):
            raise InputError(f"beta has {len(beta)} entries and tau has {len(tau)}: one of each per term")
        if len(beta) > MAX_TERMS:
            raise InputError(f"{len(beta)} creep terms: at most {MAX_TERMS} (a measured sensor's creep "
                             "needs a few; each term costs a network cell and a corrector state)")
        b = tuple(check_number(x, names(k)[0], high=MAX_BETA) for k, x in enumerate(beta))
        t = tuple(check_number(x, names(k)[1]) for k, x in enumerate(tau))
        for k, (bk, tk) in enumerate(zip(b, t)):
            if bk == 0:
                raise InputError(f"{names(k)[0]} = 0: a creep term needs a non-zero amplitude "
                                 "(with no creep there is nothing to correct)")
            if tk <= 0:
                raise InputError(f"{names(k)[1]} = {tk:g} s: retardation times must be positive")
            check_number(tk, names(k)[1], *TAU_RANGE, unit=" s")
        if 1.0 + sum(b) <= 0:
            raise InputError(f"beta0 = {sum(b):g}: creep of -100 % or less would reverse the "
                             "signal; beta0 must be greater than -1")
        object.__setattr__(self, "beta", b)
        object.__setattr__(self, "tau", t)
        object.__setattr__(self, "gain", check_number(self.gain, "gain", *VALUE_RANGE))
        object.__setattr__(self, "offset", check_number(self.offset, "offset", high=VALUE_RANGE[1]))
        if not isinstance(self.extensions, Mapping):
            raise InputError(f"extensions: expected an object (name -> parameters), found "
                             f"{type(self.extensions).__name__}")
        if self.gain == 0:
            raise InputError("gain = 0: the sensor would not respond to load")
        law = self.temperature
        if law is not None and law.beta_per_kelvin and len(law.beta_per_kelvin) != len(b):
            raise InputError(f"temperature: beta_per_kelvin has {len(law.beta_per_kelvin)} entries "
                             f"for {len(b)} creep terms")
        if law is not None and not b:
            raise InputError("a temperature law needs creep terms to act on")
        if self.transfer is not None and not isinstance(self.transfer, Transfer):
            raise InputError("transfer must be a creepcomp.transfer.Transfer")
        if self.transfer is not None and self.transfer.is_identity:
            object.__setattr__(self, "transfer", None)
        if self.load_filter is not None and not isinstance(self.load_filter, LoadFilter):
            raise InputError("load_filter must be a creepcomp.load_filter.LoadFilter")
        if self.load_filter is not None and self.load_filter.samples == 1:
            object.__setattr__(self, "load_filter", None)

    @classmethod
    def voigt(cls, beta0: float, tau: float) -> "CreepModel":
        """The paper's one-term (Voigt) model."""
        return cls(beta=(beta0,), tau=(tau,))

    @property
    def beta0(self) -> float:
        """Total creep at infinite time relative to the instantaneous signal."""
        return float(sum(self.beta))

    @property
    def n_terms(self) -> int:
        """Number of Prony terms."""
        return len(self.beta)

    @property
    def is_static(self) -> bool:
        """A static calibration: no creep terms."""
        return not self.beta

    def require_creep(self, what: str) -> None:
        """Refuse a static calibration where ``what`` needs creep terms to act on."""
        if self.is_static:
            raise InputError(f"the model is a static calibration (no creep terms): {what} has no creep "
                             "to correct; `creepcomp correct --model` applies its calibration")

    @property
    def sign(self) -> int:
        """+1 when all terms creep up, -1 when all overshoot, 0 for mixed signs."""
        if all(b > 0 for b in self.beta):
            return 1
        if all(b < 0 for b in self.beta):
            return -1
        return 0

    def lag_expansion(self) -> LagExpansion:
        """``G(s)`` as a sum of lags: direct gain 1, gains ``beta``, time constants ``tau``."""
        return LagExpansion(1.0, self.beta, self.tau)

    def transfer_function(self) -> "control.TransferFunction":
        """``G(s)`` as a python-control transfer function (signal per unit instantaneous signal)."""
        return self.lag_expansion().transfer_function()

    def state_space(self) -> "control.StateSpace":
        """``G(s)`` as a diagonal python-control state-space system."""
        return self.lag_expansion().state_space()

    def zeros(self) -> np.ndarray:
        """Zeros of ``G(s)`` (the poles of the ideal correction ``1/G``), in rad/s."""
        import control

        return np.sort_complex(control.zeros(self.transfer_function().minreal()))

    def at_temperature(self, temperature: float) -> "CreepModel":
        """The model at one temperature (°C): ``tau_k a_T``, ``beta_k (1 + b_k dT)``, no law.

        A model without a temperature law is returned as it is.
        """
        law = self.temperature
        if law is None:
            return self
        a_t = float(law.shift(temperature))
        factor = law.beta_factor(float(temperature), self.n_terms)
        return CreepModel(tuple(np.array(self.beta) * factor), tuple(np.array(self.tau) * a_t),
                          self.gain, self.offset, dict(self.extensions), None, self.transfer,
                          self.load_filter)

    def step_lags(self, temperature) -> tuple[np.ndarray, np.ndarray]:
        """Retardation times over each sample step and amplitudes at each sample.

        ``tau_k`` over the step ``[t_n, t_n+1]`` follows the temperature at the step's middle;
        ``beta_k`` the temperature at the sample. Shapes ``(N-1, K)`` and ``(N, K)``.
        """
        t = np.asarray(temperature, dtype=float)
        law = self.temperature
        if law is None:
            raise InputError("the model has no temperature law: it cannot follow a temperature")
        taus = np.array(self.tau) * law.shift(step_temperatures(t))[:, None]
        betas = np.array(self.beta) * law.beta_factor(t, self.n_terms)
        return taus, betas

    def response(self, time, load, hold: str = "linear", initial="relaxed",
                 temperature=None) -> np.ndarray:
        """Raw sensor signal for a load history, ``offset + gain * G(s)[load]`` (through the
        static maps of :attr:`transfer`, when the model has them).

        Parameters
        ----------
        time : array_like or creepcomp.lti.Sampling
            Strictly increasing sample times (s), uniform or irregular.
        load : array_like
            Load at those times.
        hold : {"linear", "zero"}
            Load ramps linearly between samples, or is held from one sample to the next
            (a step at a sample time then shows no creep at that instant).
        initial : {"relaxed", "settled"} or array_like
            ``relaxed``: unloaded before ``time[0]``; ``settled``: held at ``load[0]`` long
            enough for creep to saturate; or the creep states ``c_k`` in load units.
        temperature : array_like, optional
            Temperature (°C) at each sample, for a model with a temperature law (see
            :meth:`step_lags`). Without it the model is at its reference temperature.

        Returns
        -------
        numpy.ndarray
        """
        path = self.transfer
        if path is not None:
            load = path.load_in(load)
        if temperature is None or self.temperature is None:
            if temperature is not None:
                raise InputError("a temperature was given but the model has no temperature law")
            if self.is_static:
                linear = self.offset + self.gain * np.asarray(load, dtype=float)
            else:
                creep = self.lag_expansion().simulate(time, load, hold=hold, initial=initial)
                linear = self.offset + self.gain * creep
        else:
            u = np.asarray(load, dtype=float)
            temp = np.asarray(temperature, dtype=float)
            if temp.shape != u.shape:
                raise InputError(f"temperature has {temp.size} samples and load {u.size}")
            taus, betas = self.step_lags(temp)
            states = varying_lag_states(time, u, taus, hold=hold, initial=initial)
            linear = self.offset + self.gain * (u + np.sum(states * betas, axis=1))
        return linear if path is None else path.delinearise(linear)

    def with_terms(self, beta, tau) -> "CreepModel":
        """A copy with other Prony terms and the same gain, offset and extensions."""
        law = self.temperature
        if law is not None and law.beta_per_kelvin and len(law.beta_per_kelvin) != len(beta):
            law = _without_beta_law(law)
        return CreepModel(tuple(beta), tuple(tau), self.gain, self.offset, dict(self.extensions), law,
                          self.transfer, self.load_filter)

    def creep_block(self) -> dict:
        """A design file's ``creep`` block: ``beta``, ``tau`` and the temperature law if any."""
        out = {"beta": list(self.beta), "tau": list(self.tau)}
        if self.temperature is not None:
            out["temperature"] = self.temperature.to_dict()
        return out

    def __repr__(self) -> str:
        from creepcomp.units import format_percent, format_time

        n, shown = self.n_terms, 3
        terms = ", ".join(f"{format_percent(b)} at {format_time(t)}"
                          for b, t in list(zip(self.beta, self.tau))[:shown])
        terms += f", {n - shown} more" if n > shown else ""
        more = (f"; temperature law about {self.temperature.reference:g} °C" if self.temperature else "") + \
            (f"; extensions {', '.join(map(str, self.extensions))}" if self.extensions else "") + \
            (f"; {self.transfer.describe()}" if self.transfer is not None else "") + \
            (f"; {self.load_filter.describe()}" if self.load_filter is not None else "")
        creep = (f"{n} term{'s' if n > 1 else ''}: {terms} (beta0 {format_percent(self.beta0)})" if n
                 else "static calibration")
        return f"<CreepModel {creep}, gain {self.gain:.4g}, offset {self.offset:.4g}{more}>"

    def to_dict(self) -> dict:
        """Model-file form: ``beta``, ``tau``, ``gain``, ``offset`` and any extensions."""
        out = {"beta": list(self.beta), "tau": list(self.tau), "gain": self.gain, "offset": self.offset}
        if self.temperature is not None:
            out["temperature"] = self.temperature.to_dict()
        if self.extensions:
            out["extensions"] = dict(self.extensions)
        if self.transfer is not None:
            out["transfer"] = self.transfer.to_dict()
        if self.load_filter is not None:
            out["load_filter"] = self.load_filter.to_dict()
        return out

    @classmethod
    def from_dict(cls, data: Mapping, where: str = "model") -> "CreepModel":
        """Read a model-file object (or a design file's ``creep`` block).

        Raises
        ------
        InputError
            Naming ``where`` and the field that is wrong.
        """
        if not isinstance(data, Mapping):
            raise InputError(f"{where}: expected a JSON object with 'beta' and 'tau'")
        missing = [k for k in ("beta", "tau") if k not in data]
        if missing:
            raise InputError(f"{where}: missing {' and '.join(repr(m) for m in missing)} "
                             f"(found keys: {', '.join(map(str, data)) or 'none'})")
        beta, tau = data["beta"], data["tau"]
        if not isinstance(beta, list) or not isinstance(tau, list):
            raise InputError(f"{where}: 'beta' and 'tau' must be lists, one entry per creep term")
        law = None
        if data.get("temperature") is not None:
            law = TemperatureLaw.from_dict(data["temperature"], where=f"{where}: 'temperature'")
        transfer = None
        if data.get("transfer") is not None:
            transfer = Transfer.from_dict(data["transfer"], where=f"{where}: 'transfer'")
        load_filter = None
        if data.get("load_filter") is not None:
            load_filter = LoadFilter.from_dict(data["load_filter"], where=f"{where}: 'load_filter'")
        try:
            extensions = data.get("extensions", {}) or {}
            if not isinstance(extensions, Mapping):
                raise InputError(f"'extensions': expected an object (name -> parameters), found "
                                 f"{type(extensions).__name__}")
            _check_parameters(extensions, "extensions")
            return cls(tuple(beta), tuple(tau), data.get("gain", 1.0), data.get("offset", 0.0),
                       dict(extensions), law, transfer, load_filter)
        except InputError as exc:
            raise InputError(f"{where}: {exc}") from None
