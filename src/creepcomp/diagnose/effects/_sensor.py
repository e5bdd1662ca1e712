"""The interface of a sensor-side effect as the synthetic-record generator uses it.

A sensor effect is one complete unit: besides its template for the diagnosis (the stages of
:class:`~creepcomp.diagnose.effects.Effect`) it gives its true forward model, written at the
stages of the generator's signal path (:func:`creepcomp.synth.sensor.simulate_signal`), its
parameter sampler and formulations, the load programs that let it show, and its truth under
the names the diagnosis reports. The generator's signal path, stage by stage (each stage
defaults to "no change" and is applied by every hidden effect, in :attr:`Simulated.stage_order`)::

    sim_lead, sim_terms                 fine grid (how far before the first sample), creep terms
    u --sim_instant--> s --sim_creep_input--> h --lags (sim_tau_factor, sim_lags)--> c_k
    y = s + sum_k beta_k c_k --sim_response--> offset + gain * y --sim_output--> y
    samples = sim_sample(y) (default: y at the sample times) --sim_sampled--> clean record
    noisy record --damage--> the record (faults of the record itself)
"""

from __future__ import annotations

import abc
from dataclasses import dataclass

import numpy as np

from creepcomp.errors import InputError

__all__ = ["Scales", "SignalPath", "Simulated"]


@dataclass(frozen=True)
class Scales:
    """What a random effect's parameters are scaled to.

    Attributes
    ----------
    tau : float
        The baseline's retardation time (s).
    rate : float
        Sample rate (Hz).
    duration : float
        Record length (s).
    beta : float
        The baseline's creep amplitude (relative).
    signal_scale : float
        The full-scale signal (for effects in signal units).
    gain : float
        Signal per load unit.
    """

    tau: float
    rate: float
    duration: float
    beta: float
    signal_scale: float = 1.0
    gain: float = 1.0


@dataclass
class SignalPath:
    """The generator's signal path on its fine time grid, filled in stage by stage.

    Attributes
    ----------
    t_samples : numpy.ndarray
        The record's sample times.
    program : LoadProgram
        The load program.
    full_scale, gain, offset, rate : float
        The synthetic sensor's full-scale load, gain, offset and the sample rate.
    grid : numpy.ndarray
        The fine grid (holds every breakpoint of the load program).
    u_after, u_before : numpy.ndarray
        The load on the grid just after and just before each grid time.
    temperature : numpy.ndarray or None
        Temperature on the grid.
    taus : list of float
        Retardation times of every creep term.
    s_after, s_before, h_after, h_before : numpy.ndarray
        The instantaneous response and the creep input, once computed.
    """

    t_samples: np.ndarray
    program: object
    full_scale: float
    gain: float
    offset: float
    rate: float
    grid: np.ndarray | None = None
    u_after: np.ndarray | None = None
    u_before: np.ndarray | None = None
    temperature: np.ndarray | None = None
    taus: list | None = None
    s_after: np.ndarray | None = None
    s_before: np.ndarray | None = None
    h_after: np.ndarray | None = None
    h_before: np.ndarray | None = None


class Simulated(abc.ABC):
    """What the synthetic-record generator needs of a hidden effect (subclass it).

    Every such effect gives its identifier (``name``), its formulations (:attr:`forms`, the
    first the closest to a fitted template) and a sampler of their parameters
    (:meth:`draw`). The rest are optional hooks: stages of the signal path (``sim_*``,
    default: no change), the default draw (:meth:`draw_default`), the load programs that let
    it show (:attr:`programs`) and the truth (:meth:`truth`).

    Attributes
    ----------
    programs : tuple of str or None
        Kinds of load program that let the effect show (None: the generator's usual ones).
    unloads : bool
        A step program unloads again (the effect shows when the load falls).
    one_sided : bool
        Sweeps run from zero to full scale (not symmetric, where the effect averages out).
    templated : bool
        A diagnosis template describes the effect (False: the diagnosis must say ``unexplained``).
    baseline_terms : int
        Creep terms of the baseline that must not absorb the effect (an effect no template
        describes is kept visible against it).
    record_problem : bool
        A fault of the record itself (:meth:`damage`), made after the noise.
    stage_order : float or None
        Where the effect acts at each stage of the signal path among a record's hidden effects
        (None: at its ``vocabulary_index``; effects with neither act last, in the generator's order).
    """

    name = ""
    needs: tuple[str, ...] = ()
    programs: tuple[str, ...] | None = None
    unloads = False
    one_sided = False
    templated = True
    baseline_terms = 1
    record_problem = False
    stage_order: float | None = None

    # -- parameters ----------------------------------------------------------------------------
    @property
    @abc.abstractmethod
    def forms(self) -> tuple[str, ...]:
        """Formulations the generator can write the effect in (the first is the default)."""

    @abc.abstractmethod
    def draw(self, rng: np.random.Generator, scales: Scales, form: str) -> dict:
        """Random parameters of formulation ``form``, at sizes a designer would care about."""

    def draw_default(self, rng: np.random.Generator, scales: Scales, mixture: bool) -> dict | None:
        """Random parameters when no formulation is asked for (``mixture``: may draw other
        formulations too); None: those of the first formulation."""
        return None

    def random_parameters(self, rng: np.random.Generator, scales: Scales, form: str | None = None,
                          mixture: bool = True) -> dict:
        """Random parameters, with their formulation under ``form`` (default: :meth:`draw_default`,
        else the first of :attr:`forms`)."""
        if form is None:
            default = self.draw_default(rng, scales, mixture)
            if default is not None:
                return default
        form = form or self.forms[0]
        if form not in self.forms:
            raise InputError(f"{self.name}: unknown form '{form}' (known: {', '.join(self.forms)})")
        out = {"form": form}
        out.update(self.draw(rng, scales, form))
        return out

    def finish_draw(self, p: dict, rng: np.random.Generator, noise) -> None:
        """Complete the parameters ``p`` once the record's noise (a ``NoiseSpec``) is drawn."""

    def relax(self, p: dict) -> None:
        """Adapt the parameters ``p`` to a sensor that relaxes (beta < 0)."""

    def program_choices(self, p: dict, tau: float, choices: list, given: bool) -> list:
        """The kinds of load program to draw from for parameters ``p`` (``tau``: the baseline's
        retardation time; ``given``: the caller chose ``choices``)."""
        return choices

    def truth(self, p: dict, synthetic) -> dict:
        """The hidden parameters under the names the diagnosis reports (where they share a
        meaning); ``synthetic`` is the generated record."""
        return {}

    # -- stages of the signal path (defaults: no change) -----------------------------------------
    def sim_lead(self, p: dict) -> float:
        """How far before a sample the fine grid must reach (a delay)."""
        return 0.0

    def sim_terms(self, p: dict) -> tuple[list, list]:
        """Further creep terms: (retardation times, amplitudes)."""
        return [], []

    def sim_instant(self, path: SignalPath, p: dict, s_after, s_before) -> tuple:
        """The instantaneous response (load units) after and before each grid time."""
        return s_after, s_before

    def sim_creep_input(self, path: SignalPath, p: dict, h_after, h_before) -> tuple:
        """What drives the creep terms, after and before each grid time."""
        return h_after, h_before

    def sim_tau_factor(self, path: SignalPath, p: dict, factor: np.ndarray) -> np.ndarray | None:
        """``factor`` (on each term's retardation time over each fine step, shape (N-1, 1) or
        (N-1, K)) with the effect's own applied; None: the effect leaves the times alone."""
        return None

    def sim_lags(self, path: SignalPath, p: dict, lags: np.ndarray) -> np.ndarray:
        """The creep terms' states on the grid (shape (N, K)), with the effect's change."""
        return lags

    def sim_response(self, path: SignalPath, p: dict, y: np.ndarray) -> np.ndarray:
        """The response in load units (instantaneous plus creep), with the effect's addition."""
        return y

    def sim_output(self, path: SignalPath, p: dict, y: np.ndarray) -> np.ndarray:
        """The signal on the grid (signal units), with the effect's change."""
        return y

    def sim_sample(self, path: SignalPath, p: dict, y: np.ndarray) -> np.ndarray | None:
        """The signal at the sample times, when the effect changes how it is sampled (None:
        it does not)."""
        return None

    def sim_sampled(self, path: SignalPath, p: dict, out: np.ndarray) -> np.ndarray:
        """The sampled noise-free signal, with the effect's change."""
        return out

    def damage(self, p: dict, t, load, signal, clean, rng: np.random.Generator) -> tuple:
        """A :attr:`record_problem`'s record: the noisy ``signal`` damaged, and the truth
        (``clean``: the noise-free signal)."""
        return signal, p
