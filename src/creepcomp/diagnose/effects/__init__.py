"""Candidate effects: what a real sensor does beyond the paper's linear creep (``docs/diagnosis.md``).

Every effect is one module of this package holding one object, ``EFFECT``, that follows the
interface of :class:`Effect`: its identifier and side, its parameters, how it is fitted on
top of a base fit, how it is simulated, how it changes the model written out, and how the
creep correction inverts it. Modules are found by scanning the package, so a new effect is
one new module.

Sensor-side effects act at stages of one signal path, which :func:`creepcomp.fit.structure.basis`
evaluates (every stage defaults to "no change")::

    load --load_transform--> x --instant--> s --creep_input--> h --lags (tau_factor)--> c_k
    signal = offset + gain * s + sum_k gain * beta_k * c_k + free decays + columns(...)

A sensor-side effect is a :class:`SensorEffect`: the same module also holds its true forward
model for the synthetic-record generator (at the stages of the generator's signal path), its
parameter sampler and formulations, the load programs that let it show, its truth under the
reported names (:class:`~creepcomp.diagnose.effects._sensor.Simulated`) and its place in the
vocabulary (``vocabulary_index``). The sensor diagnosis (:mod:`creepcomp.diagnose.sensor`) and
the generator (:mod:`creepcomp.synth.sensor`) iterate over :func:`sensor_effects` and name none.

Circuit-side effects (``side = "circuit"``: a resistor's or a capacitor's value, a capacitor's
leakage, the source and load impedances, dielectric absorption) are changes of the built
network itself, subclasses of ``_network.NetworkEffect``: each says how it changes a network,
which part it sits on, how it is fitted against a record's ``corrected`` column (the network
driven by ``signal``), its prior and how the generator draws it. The circuit diagnosis
(:mod:`creepcomp.diagnose.circuit`) and generator (:mod:`creepcomp.synth.circuit`) iterate over
``_network.circuit_effects()``.

An effect defined elsewhere (a plug-in, a test) joins at run time through :func:`register`.
"""

from __future__ import annotations

import abc
import importlib
import math
import pkgutil
import re
import warnings
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from creepcomp.errors import InputError
from creepcomp.fit.data import Data
from creepcomp.fit.structure import Applied, Param, Structure, basis
from creepcomp.fit.solver import Fit, Problem, fit_structure
from creepcomp.model import CreepModel
from creepcomp.temperature import TemperatureLaw
from creepcomp.diagnose.effects._sensor import Scales, SignalPath, Simulated

__all__ = ["Effect", "SensorEffect", "Scales", "SignalPath", "Simulated", "REGISTRY", "register",
           "unregister", "effects_on", "sensor_effects", "flow_effect", "get", "arrays_data", "model_structure",
           "simulate_extended", "compensate_extended", "UnsettledInverse", "extension_inverses", "BASELINE_ADVICE",
           "firmware_output", "in_record_units", "QuickFit", "fresh_fits_ahead"]


#: Most evaluations of each refinement of a quick fit (``refine="own"``) whose creep term starts
#: afresh (:meth:`SensorEffect.with_fresh_term`): from a grid of starts, a flat optimum (a
#: delay near zero on a record without one) takes ten times as many for a BIC lower by a unit
#: or two; a candidate whose quick fit is promising is refined again without the cap.
SCREEN_ITERATIONS = 20
#: Own start values of an effect crossed with the whole grid of time constants when its creep
#: term starts afresh (:meth:`SensorEffect.with_fresh_term`): the best at a few time constants
#: across the grid (a time offset has 21: 111 evaluations on a 30-minute record instead of 252).
FRESH_OWN_STARTS = 4


@dataclass(frozen=True)
class QuickFit:
    """How a diagnosis's quick fit, which only ranks candidates, runs (the ``quick_fit`` of
    :meth:`Effect.fit_on`): every refinement stops at the likelihood tolerance
    (``screening`` of :func:`~creepcomp.fit.solver.fit_structure`), and the fits with the creep
    term started afresh that ran ahead (:func:`fresh_fits_ahead`) are taken from ``fresh``
    instead of fitted again.

    Parameters
    ----------
    fresh : mapping
        Fits that ran ahead, by what :meth:`SensorEffect.with_fresh_term` asks for.
    """

    fresh: Mapping = field(default_factory=dict)


class Effect(abc.ABC):
    """Interface of a candidate effect (subclass it; override what the effect changes).

    Attributes
    ----------
    name : str
        Identifier from ``docs/diagnosis.md`` (a contract).
    side : str
        ``sensor`` (``signal`` against ``load``) or ``circuit`` (``corrected`` against the
        network driven by ``signal``).
    parameters : tuple of str
        Names of the parameters reported in findings.
    needs : tuple of str
        Record columns the effect needs (e.g. ``temperature``).
    repeatable : bool
        May be found more than once (further creep terms).
    changes_lags : bool
        Provides :meth:`tau_factor`.
    state_dependent : bool
        Its ``tau_factor`` depends on the lag states (solved by iteration).
    summary : str
        One line for reports.
    describes_record : bool
        A statement about the record (a fault of it), not an extension of the model: it may
        stay the cause when it makes the creep-corrected signal worse, its note says why.
    vocabulary_index : float
        Position in its side's table of ``docs/diagnosis.md`` (effects without one come last, by name).
    columns_from_lags : bool
        Its :meth:`columns` read the lag states (they then move with the time constants).
    """

    name = ""
    side = "sensor"
    parameters: tuple[str, ...] = ()
    needs: tuple[str, ...] = ()
    repeatable = False
    changes_lags = False
    state_dependent = False
    summary = ""
    describes_record = False
    vocabulary_index: float = math.inf
    columns_from_lags = True
    #: Units of reported parameters that their names do not tell
    #: (:func:`creepcomp.units.format_parameter`), by name; ``signal`` and ``load`` stand for
    #: the record's units of those columns (:func:`in_record_units`).
    parameter_units: dict = {}

    def __reduce_ex__(self, protocol):
        # the registered object is unpickled as the registry's own: the search tells effects
        # apart by identity (a fit's Applied against the candidate)
        if REGISTRY.get(self.name) is self:
            return get, (self.name,)
        return super().__reduce_ex__(protocol)

    # -- applicability and fitting -------------------------------------------------------
    def applicable(self, data: Data, structure: Structure) -> str | None:
        """Why the effect cannot be tried on this record and model, or None."""
        for col in self.needs:
            if getattr(data, col, None) is None:
                return f"the record has no '{col}' column"
        if structure.has(self.name) and not self.repeatable:
            return "already in the model"
        return None

    def settings(self, data: Data, base: Fit) -> tuple:
        """Fixed settings when applied on top of ``base`` (key, value pairs)."""
        return ()

    def extend(self, structure: Structure, applied: Applied) -> Structure:
        """The structure with this effect applied."""
        return structure.with_effect(applied)

    def nonlinear_params(self, data: Data, applied: Applied) -> list[Param]:
        """The effect's own nonlinear parameters (names without the effect prefix)."""
        return []

    def starts(self, data: Data, base: Fit, applied: Applied) -> list[dict]:
        """Start values of the effect's own nonlinear parameters (names without prefix)."""
        return [{}]

    def fit_on(self, data: Data, base: Fit, refine: str = "all", start: dict | None = None,
               settings: tuple | None = None, quick_fit: QuickFit | None = None) -> Fit:
        """Fit the base model extended by this effect (its likelihood with its own AR noise).

        ``refine``: ``all`` (every nonlinear parameter refined together), ``own`` (the
        base's held, the effect's own refined: a quick screening) or ``none`` (the best
        start kept, only the linear part solved); either refines its best start only (a quick
        fit ranks candidates, and one that matters is refined with every parameter free).
        ``start``: start values of every nonlinear parameter (default: the base's values and
        the effect's own start grid).
        ``settings``: other than :meth:`settings` (e.g. :meth:`SensorEffect.plain_settings`).
        ``quick_fit``: the fit only ranks candidates (a diagnosis's quick fit, :class:`QuickFit`);
        an override passes it on to every fit it makes.
        """
        applied, structure = self._on(data, base, settings)
        known = {p.name: base.values[p.name] for p in base.params}
        starts = [start] if start is not None else []
        for own in ([] if start is not None else self.starts(data, base, applied)):
            s = dict(known)
            s.update({self._key(applied, k): v for k, v in own.items()})
            starts.append(s)
        return fit_structure(data, structure, starts, n_refine=1, refine=refine != "none",
                             frozen=known if refine == "own" else None, with_cov=refine == "all",
                             screening=quick_fit is not None)

    def _on(self, data: Data, base: Fit, settings: tuple | None) -> tuple:
        """This effect applied to ``base`` (its :meth:`settings` unless ``settings`` is given)
        and the extended structure: ``(applied, structure)``."""
        applied = Applied(self, self.settings(data, base) if settings is None else settings)
        return applied, self.extend(base.structure, applied)

    @staticmethod
    def _key(applied: Applied, name: str) -> str:
        return name if name.startswith("tau[") else f"{applied.name}.{name}"

    # -- stages of the signal path (defaults: no change) --------------------------------------
    def load_transform(self, data: Data, x: np.ndarray, p: dict, applied: Applied) -> np.ndarray:
        """The load as the sensor sees it."""
        return x

    def instant(self, data: Data, s: np.ndarray, p: dict, applied: Applied) -> np.ndarray:
        """The instantaneous signal (load units) from the load seen."""
        return s

    def creep_input(self, data: Data, h: np.ndarray, p: dict, applied: Applied) -> np.ndarray:
        """What drives the creep terms."""
        return h

    def tau_factor(self, data: Data, h, lags, taus, p: dict, applied: Applied):
        """Factor on each term's time constant over each sample step, shape (N-1, K).

        A ``state_dependent`` effect is called on segments of the record (``h`` and ``lags``
        of a segment, ``data`` the whole record) and must use only what it is given."""
        return 1.0

    def columns(self, data: Data, s, h, lags, p: dict, applied: Applied) -> dict:
        """Extra columns of the linear part, by name (their coefficients are fitted)."""
        return {}

    def straddling(self, data: Data, p: dict, applied: Applied) -> np.ndarray:
        """Samples (indices) whose load seen falls inside the sample interval of a load step
        (:func:`~creepcomp.fit.data.abrupt_intervals`): the record does not tell on which side
        of the step it lies, so the fit leaves each free, one parameter each
        (:class:`~creepcomp.fit.solver.Problem`). None but where the load is read between
        samples (a time offset)."""
        return np.zeros(0, int)

    def held_in_refits(self, data: Data, p: dict, applied: Applied) -> tuple[str, ...]:
        """Own parameters (names without prefix) that every held-out refit keeps at the fit's
        values (:func:`~creepcomp.fit.evidence.heldout`): the fitted samples do not tell them
        apart over a stretch where their cost is flat, from which a refit on part of the
        record would follow rounding. By default none."""
        return ()

    # -- results -------------------------------------------------------------------------------
    def unphysical(self, fit: Fit, applied: Applied) -> str | None:
        """Why the fitted parameters cannot be this effect (then it is not named), or None."""
        return None

    def report(self, fit: Fit, applied: Applied) -> dict:
        """Reported parameters: name -> (value, standard deviation)."""
        return {}

    def note(self, fit: Fit, applied: Applied) -> str | None:
        """What the user must know about the reported parameters (e.g. which the record does
        not determine), or None."""
        return None

    def extension(self, fit: Fit, applied: Applied) -> dict | None:
        """The entry of the model file's ``extensions`` (None: the change is in the terms)."""
        return None

    def temperature_law(self, fit: Fit, applied: Applied) -> TemperatureLaw | None:
        """The model file's ``temperature`` block this effect's fit implies (with its
        uncertainty), or None."""
        return None

    def restore(self, entry: dict, model: CreepModel, data: Data) -> tuple[Applied, dict]:
        """Inverse of :meth:`extension`: the applied effect and its values (prefixed names)."""
        raise InputError(f"extension '{self.name}' cannot be read back")

    def precondition(self, data: Data, delta: np.ndarray, load: np.ndarray, values: dict,
                     applied: Applied) -> np.ndarray:
        """Map a correction increment (load units, after the linear inverse) back through this
        effect's stage, approximately; used by :func:`compensate`. ``values`` holds all the
        model's values (this effect's prefixed)."""
        return delta

    def linear_terms(self, values: dict, applied: Applied, data: Data) -> list[tuple[float, float]]:
        """Prony terms (beta, tau) that approximate the effect for the linear inverse, relaxed at
        the first sample whatever the model's own terms start from (a flow has no settled
        state: its integral starts there)."""
        return []

    def inverse(self, entry: dict, model: CreepModel) -> str | None:
        """How the creep correction undoes this extension of a model file (``entry``: its
        parameters; ``model``: the whole model), in one line for the user; None: it cannot be undone causally, and the
        correction refuses a model with it. The correction (:func:`compensate_extended`) finds
        the load whose simulation through the model equals the signal; :meth:`precondition`
        and :meth:`linear_terms` speed it up, this hook says what it amounts to."""
        return None

    def firmware_output(self, entry: dict, model: CreepModel) -> dict | None:
        """The extension as a map the C corrector writes, sample by sample, when it is one
        the generator can write (``entry``: its parameters; ``X``: the load in signal units
        above the offset): ``{"polynomial": (c2, c3)}``, the load whose instantaneous
        response ``X + c2 X^2 + c3 X^3`` is the linear corrector's output, or one of the maps
        of :mod:`creepcomp.digital.firmware_extension` (``reloading``, ``peak``, ``play``,
        ``recovery``, ``overshoot``), each a dict of its parameters. None: no C corrector;
        an InputError names why where that is not plain."""
        return None


class SensorEffect(Effect, Simulated):
    """A sensor-side effect, one complete unit: its diagnosis template (the stages of
    :class:`Effect`) and its generator side (:class:`Simulated`: forward model, sampler,
    formulations, programs, truth).

    Every sensor effect gives ``name``, its place in the vocabulary (:attr:`vocabulary_index`), its
    formulations (:attr:`~Simulated.forms`) and its sampler (:meth:`~Simulated.draw`); the
    rest are optional hooks with defaults.

    Attributes
    ----------
    flow : bool
        The effect is the model's viscous flow (what ``creepcomp fit --flow`` adds).
    """

    side = "sensor"
    flow = False

    @property
    @abc.abstractmethod
    def vocabulary_index(self) -> float:
        """Position in the sensor table (``docs/diagnosis.md``)."""

    # -- the diagnosis's search --------------------------------------------------------------
    def plain_settings(self, data: Data, base: Fit) -> tuple | None:
        """Settings of the plain form of the template, nested in the fitted one (its shape
        parameters at their plain values: no lag, a Newtonian dashpot), tried when the shaped
        form is not supported; None: the template has no shape parameter."""
        return None

    def with_tau_restarts(self, data: Data, base: Fit, fit: Fit, own: list[dict],
                          settings: tuple | None = None, quick_fit: QuickFit | None = None) -> Fit:
        """``fit`` (this effect on ``base``), or a better one started from a log grid of each
        retardation time (2 per decade) crossed with the effect's own start values ``own``
        (names without prefix), screened by their linear fit alone and the best refined: the
        base's time constants may have mimicked this effect (a fast relaxing term standing in
        for a hysteresis, a very slow one for creep whose speed follows temperature), and the
        effect alone cannot move them away."""
        from creepcomp.fit.starts import tau_grid

        applied, structure = self._on(data, base, settings)
        known = {p.name: base.values[p.name] for p in base.params}
        starts = [dict(known, **{f"tau[{k}]": float(tau)},
                       **{self._key(applied, name): v for name, v in values.items()})
                  for k in range(base.structure.n_terms) for tau in tau_grid(data, per_decade=2)
                  for values in own]
        screened = fit_structure(data, structure, starts, refine=False, with_cov=False,
                                 screening=quick_fit is not None)
        if screened.bic >= fit.bic:
            return fit
        # every parameter refined, with its covariance: it may be kept as the candidate's full fit
        alt = fit_structure(data, structure, [{p.name: screened.values[p.name] for p in screened.params}],
                            n_refine=1, screening=quick_fit is not None)
        return alt if alt.bic < fit.bic else fit

    #: The refinement (``own`` or ``all``) of the quick fit's fit with the creep term started
    #: afresh (:meth:`with_fresh_term`) when that fit reads the record only (the effect's
    #: settings and start values do not read the baseline): a diagnosis runs it beside the
    #: baseline's own fit (:func:`fresh_fits_ahead`). None: not run ahead.
    fresh_ahead: str | None = None

    def with_fresh_term(self, data: Data, base: Fit, fit: Fit, refine: str, start: dict | None,
                        settings: tuple | None, screening: bool | None = None,
                        quick_fit: QuickFit | None = None) -> Fit:
        """``fit`` (this effect on a one-term ``base``), or the effect fitted with the creep term
        started afresh (:meth:`fresh_term_fit`) when that fits better: for effects that the
        base's one term may have mimicked (a delay by a fast term of large beta, flow by a term
        longer than the record), whose fit from the base's values then stays there.
        ``screening``: a quick fit, whose refinements stop after :data:`SCREEN_ITERATIONS`
        (default: when ``refine`` is ``own``). ``quick_fit``: the quick fit's (:meth:`fit_on`), whose
        fits that ran ahead are taken instead of fitted again."""
        if refine == "none" or start is not None or base.structure.n_terms != 1 or base.structure.effects:
            return fit
        quick = screening or (screening is None and refine == "own")
        key = (self.name, refine, settings, bool(quick))
        ahead = quick_fit.fresh if quick_fit is not None else {}
        alt = ahead[key] if key in ahead else self.fresh_term_fit(data, base, refine, settings, quick, quick_fit)
        return alt if alt is not None and alt.bic < fit.bic else fit

    def fresh_term_fit(self, data: Data, base: Fit | None, refine: str, settings: tuple | None,
                       quick: bool, quick_fit: QuickFit | None = None) -> Fit | None:
        """The effect on a one-term ``base`` (None: the one-term structure, for an effect whose
        fit reads the record only, :attr:`fresh_ahead`) with the creep term started afresh from
        a grid of time constants, crossed with the effect's own start values (or the
        :data:`FRESH_OWN_STARTS` best of them); None when it cannot be fitted. ``quick``: its
        refinement stops after :data:`SCREEN_ITERATIONS`; ``quick_fit``: as :meth:`fit_on`'s."""
        from creepcomp.fit.starts import one_term_starts

        if base is None:
            applied = Applied(self, self.settings(data, None) if settings is None else settings)
            structure = self.extend(Structure(1), applied)
        else:
            applied, structure = self._on(data, base, settings)
        grid = one_term_starts(data)
        owns = [{self._key(applied, k): v for k, v in own.items()} for own in self.starts(data, base, applied)]
        try:
            if len(owns) > FRESH_OWN_STARTS:
                # ranked at a few time constants across the grid first: each own start's best
                problem = Problem(data, structure)
                probe = grid[::max(1, len(grid) // 3)]
                cost = [min(problem.cost(dict(t, **own)) for t in probe) for own in owns]
                owns = [owns[i] for i in np.argsort(cost, kind="stable")[:FRESH_OWN_STARTS]]
            fresh = [dict(t, **own) for t in grid for own in owns]
            return fit_structure(data, structure, fresh, n_refine=1, with_cov=refine == "all",
                                 max_nfev=SCREEN_ITERATIONS if quick else None,
                                 screening=quick_fit is not None)
        except (InputError, np.linalg.LinAlgError, ValueError):
            return None

    def record_fault(self, fit: Fit, applied: Applied, data: Data) -> np.ndarray | None:
        """What a fault of the record adds to the signal (signal units), where it can be taken
        out of it (None: it cannot, or the effect is no fault of the record)."""
        return None

    def worse_correction_note(self, ratio: float, without_fault: float | None) -> str:
        """The note of a finding whose addition makes the creep-corrected signal worse
        (``ratio``: correction-error ratio, model before it / with it; ``without_fault``: the
        same with :meth:`record_fault` taken out of the signal, None when there is none)."""
        return (f"fits the signal better but makes the creep-corrected signal worse against the "
                f"load (correction-error ratio {ratio:.3g}): it does not describe how the signal "
                f"follows the load")

    def screen(self, data: Data, fit: Fit, base: Fit) -> list[dict]:
        """Faults of the record found outside the model search (no model column undoes
        them), each the parameters of a finding; ``fit``: the model found, ``base``: the
        baseline."""
        return []

    def screened_importance(self, problem: dict, fit: Fit, base: Fit, named: bool) -> tuple:
        """The importance of a finding of :meth:`screen` and a note for the named findings
        (None: none): ``named`` tells whether there are any."""
        return math.inf, None


def fresh_fits_ahead(data: Data, effect: "SensorEffect") -> dict:
    """The quick fit's fit of ``effect`` with the creep term started afresh on the one-term
    baseline (:attr:`SensorEffect.fresh_ahead`), before the baseline is fitted, for
    :attr:`QuickFit.fresh` (empty when the effect has none, or when its settings or starts fail:
    the quick fit then meets the failure itself, and its trial says why)."""
    refine = getattr(effect, "fresh_ahead", None)
    if refine is None:
        return {}
    try:
        return {(effect.name, refine, None, True): effect.fresh_term_fit(data, None, refine, None, True, QuickFit())}
    except (InputError, np.linalg.LinAlgError, ValueError):
        return {}


def _discover() -> dict[str, Effect]:
    found = {}
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        module = importlib.import_module(f"{__name__}.{info.name}")
        effect = getattr(module, "EFFECT", None)
        if isinstance(effect, Effect):
            found[effect.name] = effect
    return found


#: Every effect found in this package, by identifier (and any :func:`register` added).
REGISTRY: dict[str, Effect] = _discover()


def register(effect: Effect) -> Effect:
    """Add an effect defined outside this package (a plug-in, a test) to :data:`REGISTRY`."""
    if not isinstance(effect, Effect):
        raise InputError(f"cannot register {effect!r}: not an Effect")
    if not effect.name:
        raise InputError("cannot register an effect without a name")
    if effect.side == "sensor" and not isinstance(effect, SensorEffect):
        raise InputError(f"cannot register '{effect.name}': a sensor-side effect is a SensorEffect")
    if effect.name in REGISTRY:
        raise InputError(f"an effect named '{effect.name}' is registered already")
    REGISTRY[effect.name] = effect
    return effect


def unregister(name: str) -> Effect:
    """Remove an effect from :data:`REGISTRY` (the inverse of :func:`register`)."""
    return REGISTRY.pop(get(name).name)


def effects_on(side: str) -> list[Effect]:
    """The registered effects of one side (``sensor`` or ``circuit``), in vocabulary order
    (then by name)."""
    return sorted((e for e in REGISTRY.values() if e.side == side), key=lambda e: (e.vocabulary_index, e.name))


def sensor_effects() -> list[SensorEffect]:
    """The sensor-side effects, in vocabulary order (then by name)."""
    return effects_on("sensor")


def flow_effect() -> SensorEffect:
    """The effect that is the model's viscous flow (:attr:`SensorEffect.flow`)."""
    found = [e for e in sensor_effects() if getattr(e, "flow", False)]
    if not found:
        raise InputError("no registered effect provides viscous flow")
    return found[0]


def in_record_units(unit: str, record_units: dict) -> str:
    """A unit of :attr:`Effect.parameter_units` with ``signal`` and ``load`` written in the
    record's units of those columns (``signal units``, ``load units`` where it names none)."""
    return re.sub(r"\b(signal|load)\b", lambda m: record_units.get(m.group(1)) or f"{m.group(1)} units", unit)


def get(name: str) -> Effect:
    """The effect with this identifier."""
    try:
        return REGISTRY[name]
    except KeyError:
        raise InputError(f"unknown effect '{name}' (known: {', '.join(sorted(REGISTRY))})") from None


# ------------------------------------------------------------------------------------------
# Extended models: simulation and correction
# ------------------------------------------------------------------------------------------

def arrays_data(time, load, signal=None, temperature=None, initial: str = "relaxed",
                hold: str = "linear", source: str = "arrays") -> Data:
    """A :class:`Data` from arrays, for simulation (no fitting checks)."""
    t = np.asarray(time, float)
    return Data(time=t, load=np.asarray(load, float),
                signal=np.zeros_like(t) if signal is None else np.asarray(signal, float),
                temperature=None if temperature is None else np.asarray(temperature, float),
                source=source, initial=initial, load_step_at=None, hold=hold,
                segment=np.zeros(len(t), int), fixed_offset=False)


def model_structure(model: CreepModel, data: Data) -> tuple[Structure, dict]:
    """Structure and values of an (extended) model file, ready for :func:`basis`."""
    values = {"gain": model.gain, "offset": model.offset}
    for k, (b, t) in enumerate(zip(model.beta, model.tau)):
        values[f"tau[{k}]"] = t
        values[f"a[{k}]"] = model.gain * b
    structure = Structure(model.n_terms)
    for name, entry in (model.extensions or {}).items():
        effect = get(name)
        if not isinstance(entry, dict):
            raise InputError(f"model extension '{name}': expected an object of parameters")
        try:
            applied, own = effect.restore(entry, model, data)
        except KeyError as exc:
            raise InputError(f"model extension '{name}': missing parameter {exc}") from None
        except (TypeError, ValueError) as exc:
            raise InputError(f"model extension '{name}': a parameter is not what it should be "
                             f"({exc})") from None
        structure = structure.with_effect(applied)
        values.update(own)
    return structure, values


def simulate_extended(model: CreepModel, time, load, temperature=None, initial: str = "relaxed",
             hold: str = "linear") -> np.ndarray:
    """Signal of an extended model (model file with ``extensions``) for a load history.

    Parameters
    ----------
    model : CreepModel
    time, load : array_like
    temperature : array_like, optional
        Needed by thermal extensions.
    initial : {"relaxed", "settled"}
    hold : {"linear", "zero"}
    """
    data = arrays_data(time, load, temperature=temperature, initial=initial, hold=hold)
    structure, values = model_structure(model, data)
    for a in structure.effects:
        for col in a.effect.needs:
            if getattr(data, col) is None:
                raise InputError(f"the model's '{a.name}' extension needs a {col} history")
    b = basis(data, structure, values)
    missing = [n for n in b.names if n not in values]
    if missing:
        raise InputError(f"the model lacks values for {', '.join(missing)}")
    return b.columns @ np.array([values[n] for n in b.names])


def _linear_inverse(time, residual, gain: float, betas, taus, initial: str, hold: str,
                    own: int) -> np.ndarray:
    """Load-unit increment that the linear creep model maps to ``residual``: the digital
    subtractive correction (:func:`creepcomp.digital.correctors.compensate`). The terms after
    the first ``own`` (extensions' equivalents, :meth:`Effect.linear_terms`) start relaxed."""
    from creepcomp.digital.correctors import compensate as digital_compensate

    lin = CreepModel(tuple(betas), tuple(taus), gain, 0.0)
    start = initial
    if initial == "settled" and own < len(betas):
        level = float(residual[0]) / (1.0 + float(np.sum(betas[:own])))
        start = np.concatenate([np.full(own, level), np.zeros(len(betas) - own)])
    return np.asarray(digital_compensate(time, residual, lin, method="subtractive",
                                         initial=start, hold=hold), float) / gain


#: What a user whose extended model cannot be used in a correction can do instead.
BASELINE_ADVICE = ("correct with the baseline model instead: --model baseline-model.json, which "
                   "creepcomp diagnose -o writes next to model.json")

#: Largest last step of the defect correction, relative to the load's largest, for the inverse
#: to count as found (where no load gives the signal exactly, as in the first samples of a
#: delayed signal, which answer the load before the record, the steps still settle).
INVERSE_TOLERANCE = 1e-6

#: Most steps of the defect correction when the inverse must be found (``strict``,
#: ``converge``): a delay's or a flow's correction may take a hundred and more.
STRICT_ITERATIONS = 400
#: Most steps of the defect correction otherwise.
ITERATIONS = 60
#: A step of the defect correction larger than this many times the load's largest: its steps
#: diverge (when the inverse must be found, they stop there).
DIVERGED = 1e6
#: Steps over which ``converge`` alone reads the rate at which the defect correction's steps
#: shrink, from :data:`ITERATIONS` on: it stops where that rate would need more than twice
#: :data:`STRICT_ITERATIONS` to settle (a correction stuck at a level, or slowing down, as an
#: averaging window's at the frequencies it removes).
RATE_WINDOW = 30


def law_from_extension(model: CreepModel) -> bool:
    """Whether the model's ``temperature`` block restates one of its extensions (the law of
    the same slope a diagnosis writes beside, e.g., ``thermal_retardation``): the creep
    correction then applies the extension, the form that was fitted, and not the block too."""
    return model.temperature is not None and any(
        type(get(name)).temperature_law is not Effect.temperature_law for name in model.extensions or {})


def extension_inverses(model: CreepModel) -> dict[str, str]:
    """How the creep correction undoes each extension of ``model`` (:meth:`Effect.inverse`),
    by name; one clear refusal naming the first it cannot undo, or a temperature block
    beside extensions that it does not restate."""
    out = {}
    for name, entry in (model.extensions or {}).items():
        effect = get(name)
        how = effect.inverse(entry if isinstance(entry, dict) else {}, model)
        if how is None:
            raise InputError(f"the model's extension '{name}' cannot be inverted causally by the "
                             f"creep correction; {BASELINE_ADVICE}")
        out[name] = how
    if out and model.temperature is not None and not law_from_extension(model):
        raise InputError(f"the model's temperature law cannot be applied together with its "
                         f"extensions ({', '.join(out)}); {BASELINE_ADVICE}")
    return out


def compensate_extended(time, signal, model: CreepModel, temperature=None, initial: str = "relaxed",
               hold: str = "linear", tolerance: float = 1e-10, max_iterations: int | None = None,
               strict: bool = False, converge: bool | None = None) -> np.ndarray:
    """Creep-corrected signal of an extended model: the instantaneous signal
    ``offset + gain * load`` whose simulation through the model equals the measured signal.

    Solved by defect correction: the model's linear creep (plus the Prony equivalents of
    linear extensions) is inverted by the digital subtractive correction, each extension maps
    the increment back through its own stage (:meth:`Effect.precondition`), and the step is
    repeated on what remains. A model without extensions is inverted in one step. Every
    template is causal (its signal at a sample depends on the load up to that sample), so the
    load found at a sample depends only on the signal up to it: the same as a correction
    sample by sample.

    ``strict``: refuse (:class:`InputError`, naming the extensions) a model with an extension
    that :meth:`Effect.inverse` cannot undo, and a signal whose inverse is not found.
    ``converge``: refuse only a signal whose inverse is not found (:class:`UnsettledInverse`:
    the steps do not settle below :data:`INVERSE_TOLERANCE` of the load, or at the rate they
    shrink would need more than twice the steps, :data:`RATE_WINDOW`); default ``strict``.
    ``max_iterations``: default :data:`ITERATIONS`, or :data:`STRICT_ITERATIONS` when the
    inverse must be found. The steps stop once they are below ``tolerance`` (a few suffice
    for most models; a delay's or a flow's correction converges slowly); with ``converge``
    alone, also once they are settled after :data:`ITERATIONS` (the result is then the one
    the default gives, or the first settled one after it). Without either, a signal whose
    inverse is not found gives the last step's load with a :class:`RuntimeWarning` saying so.

    Returns
    -------
    numpy.ndarray
        Compensated signal in signal units.
    """
    if strict:
        extension_inverses(model)
    t = np.asarray(time, float)
    y = np.asarray(signal, float)
    data = arrays_data(t, np.zeros_like(t), temperature=temperature, initial=initial, hold=hold)
    structure, values = model_structure(model, data)
    betas, taus = list(model.beta), list(model.tau)
    for a in structure.effects:
        for b, tau in a.effect.linear_terms(values, a, data):
            betas.append(b)
            taus.append(tau)
    converge = strict if converge is None else converge
    if max_iterations is None:
        max_iterations = STRICT_ITERATIONS if converge else ITERATIONS
    load = np.zeros_like(t)
    scale = max(float(np.max(np.abs(y - model.offset))), 1e-300) / abs(model.gain)
    step = 0.0
    settled_after = ITERATIONS if converge and not strict else max_iterations
    steps, too_slow, done = [], False, 0
    for done in range(1, max_iterations + 1):
        with np.errstate(**({"all": "ignore"} if converge else {})):
            sim = simulate_extended(model, t, load, temperature, initial, hold)
        if converge and not np.all(np.isfinite(sim)):
            step = math.inf
            break
        delta = _linear_inverse(t, y - sim, model.gain, betas, taus, initial, hold, len(model.beta))
        for a in reversed(structure.effects):
            delta = a.effect.precondition(data, delta, load, values, a)
        load = load + delta
        step = float(np.max(np.abs(delta)))
        if step <= tolerance * scale or (done >= settled_after and step <= INVERSE_TOLERANCE * scale):
            break
        if converge and not step <= DIVERGED * scale:
            step = math.inf
            break
        steps.append(step)
        if converge and not strict and done >= ITERATIONS and _too_slow(steps, INVERSE_TOLERANCE * scale,
                                                                         2 * max_iterations - done):
            too_slow = True
            break
    if structure.effects and not step <= INVERSE_TOLERANCE * scale:
        names = ", ".join(a.name for a in structure.effects)
        why = _how_steps_ended(steps, step / scale, done, max_iterations, too_slow)
        message = (f"the creep correction finds no load whose simulation through the model's "
                   f"extensions ({names}) gives the signal ({why})")
        if converge:
            raise UnsettledInverse(f"{message}; {BASELINE_ADVICE}", why)
        warnings.warn(f"{message}: the corrected signal is the last step's", RuntimeWarning, stacklevel=2)
    return model.offset + model.gain * load


def _how_steps_ended(steps: list, last: float, done: int, budget: int, too_slow: bool) -> str:
    """Why the defect correction's steps did not settle (``last``: the last step relative to
    the load's largest)."""
    if not math.isfinite(last):
        return "its steps diverge"
    out = f"its steps still move the load by {last:.2g} of its largest after {done} iterations"
    if not too_slow:
        return out
    if steps[-1] >= steps[-1 - RATE_WINDOW]:
        return out + ", not shrinking"
    return out + f", shrinking too slowly to settle within {budget}"


def _too_slow(steps: list, settled: float, left: int) -> bool:
    """Whether steps shrinking at their rate over the last :data:`RATE_WINDOW` would need
    more than ``left`` more to fall to ``settled``."""
    if len(steps) <= RATE_WINDOW:
        return False
    now, before = steps[-1], steps[-1 - RATE_WINDOW]
    if not now < before:
        return True
    rate = math.log(now / before) / RATE_WINDOW          # (negative: per step)
    return math.log(settled / now) / rate > left


class UnsettledInverse(InputError):
    """The creep correction of a model with extensions finds no load that gives the signal
    (:func:`compensate_extended`); ``why`` says how its steps ended."""

    def __init__(self, message: str, why: str):
        super().__init__(message)
        self.why = why


def firmware_output(model: CreepModel) -> dict | None:
    """The C corrector's output map of the model's extensions (:meth:`Effect.firmware_output`),
    None without extensions; one clear refusal naming an extension it cannot write, or a
    second one (the generator writes one map)."""
    maps = []
    for name, entry in (model.extensions or {}).items():
        extension_inverses(CreepModel(model.beta, model.tau, model.gain, model.offset, {name: entry}))
        out = get(name).firmware_output(entry if isinstance(entry, dict) else {}, model)
        if out is None or maps:
            why = "no C corrector" if out is None else "no C corrector together with another extension"
            raise InputError(f"the model's extension '{name}' has {why}: generate the firmware of the "
                             f"baseline model (baseline-model.json, which creepcomp diagnose -o writes), "
                             f"or correct records in Python with creepcomp correct, which applies it")
        maps.append(out)
    return maps[0] if maps else None
