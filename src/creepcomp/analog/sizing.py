"""Sizing the correction network by the paper's rule or exactly, and snapping it to E-series parts.

Rules (``docs/physics.md``, section 3):

* ``paper``: ``tau_p = C R1 R2 / (R1 + R2) = tau`` and ``R1 / R2 = beta0 / (1 + beta0)``,
  exactly as the paper states it (one creep term; source and load resistance ignored, as
  in the paper).
* ``exact``: pole-zero cancellation ``H(s) G(s) = const``. All terms positive: a Foster
  chain ``R_k = beta_k (R2' + Rs)``, ``C_k = tau_k / R_k`` with ``R2' = R2 || RL``. All
  terms negative: a series resistor and one shunt R-C branch per term (a lag network).

The impedance level is free; it is set by the largest capacitor of the network.

Snapping searches every capacitor value of the chosen series and range, and around each the
neighbouring series values of every other part, for the combination whose step response is
closest to the rule's ideal one (for the exact rule: the smallest residual creep). A
closed-form screen ranks all combinations; python-control re-checks the best few.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from creepcomp.analog import eseries
from creepcomp.analog.parts import DIELECTRICS, PartsPlan
from creepcomp.display import Shown, data_frame
from creepcomp.errors import InputError, NotRealisableError
from creepcomp.model import CreepModel
from creepcomp.network import Branch, Cell, Network, modal_form, parallel, state_matrices
from creepcomp.analog.quality import (Quality, predict, screening_deviation, step_deviation,
    screening_times, step_peak)
from creepcomp.units import format_percent, format_quantity

__all__ = ["RULES", "DEFAULT_CAPACITANCE", "DEFAULT_CAP_RANGE", "DEFAULT_RES_RANGE",
           "FILM_CAP_RANGE", "HIGH_IMPEDANCE", "ASSUMED_LEAKAGE", "MAX_COMBINATIONS_PER_LEVEL",
           "EXACT_RECHECKS", "SIZING_WORK", "NoNetworkInRange", "explain_unrealisable", "ideal_network", "PartChoice", "SizingReport",
           "size", "TAU_RANGE", "check_time_constants", "nearest_snap", "output_resistance", "design_warnings"]

RULES = ("exact", "paper")
#: Capacitance of the largest capacitor when the user fixes nothing and does not snap.
DEFAULT_CAPACITANCE = 10e-6
#: Capacitor values searched when snapping (F).
DEFAULT_CAP_RANGE = (1e-6, 100e-6)
#: Resistor values allowed when snapping (ohm).
DEFAULT_RES_RANGE = (10.0, 1e9)
#: What film capacitors are made in (F).
FILM_CAP_RANGE = (100e-12, 100e-6)
#: Above this a resistor makes the network a high-impedance node (ohm).
HIGH_IMPEDANCE = 10e6
#: A leakage path to ground assumed for the impedance warning (ohm): board surface, next stage.
ASSUMED_LEAKAGE = 10e9
#: Combinations of neighbouring part values tried per capacitor value.
MAX_COMBINATIONS_PER_LEVEL = 1024
#: Candidates re-checked with python-control after the closed-form screen.
EXACT_RECHECKS = 5
#: Values (candidates x sensor terms x network lags x screening times) the closed-form screen
#: of one sizing computes at most: a model of many terms gets fewer combinations per
#: capacitor value, and a sizing of seconds instead of hours.
SIZING_WORK = 100_000_000


class NoNetworkInRange(InputError):
    """No network of the rule has its parts in the ranges searched (with this source and
    load resistance).

    ``fixable`` is True when parts that are made would do (the message says which options
    reach them), False when no capacitor of the plan's dielectric would.
    """

    def __init__(self, message: str, fixable: bool = True):
        super().__init__(message)
        self.fixable = fixable


def explain_unrealisable(model: CreepModel) -> str:
    """Why a model with terms of both signs cannot be cancelled by this tool's networks."""
    zeros = model.zeros()
    terms = ", ".join(f"{b * 100:+.3g} % at {t:g} s" for b, t in zip(model.beta, model.tau))
    msg = (f"the creep model has terms of both signs ({terms}). A Foster chain cancels only "
           "creep that rises (all beta > 0) and a lag network only creep that overshoots "
           "(all beta < 0).")
    if np.any(np.abs(np.imag(zeros)) > 1e-12 * np.abs(zeros)):
        poles = ", ".join(f"{z.real:.4g}{z.imag:+.4g}j" for z in zeros if z.imag >= 0)
        msg += (f" Here the ideal correction 1/G(s) has complex poles (s = {poles} rad/s), "
                "and no passive RC network has complex poles.")
    else:
        msg += (" Here 1/G(s) has real poles, so an RC network exists in principle, but not "
                "in the topologies this tool sizes.")
    return msg + " Use the digital correction (creepcomp correct) or a model of one sign."


def ideal_network(model: CreepModel, rule: str = "exact", capacitance: float = DEFAULT_CAPACITANCE,
                  source_resistance: float = 0.0, load_resistance: float | None = None) -> Network:
    """The network that the rule asks for, with unrounded part values.

    Parameters
    ----------
    model : CreepModel
        Creep to cancel.
    rule : {"exact", "paper"}
        Sizing rule.
    capacitance : float
        Value of the network's largest capacitor (F): sets the impedance level.
    source_resistance : float
        Sensor output resistance (ohm).
    load_resistance : float or None
        Next stage's input resistance (ohm); None for none.

    Returns
    -------
    Network

    Raises
    ------
    NotRealisableError
        For a model with terms of both signs, or the paper's rule on a model it does not cover.
    InputError
        When the source or load resistance leaves no room for the network at this capacitance.
    """
    if rule not in RULES:
        raise InputError(f"rule '{rule}': choose one of {', '.join(RULES)}")
    if not capacitance > 0 or not math.isfinite(capacitance):
        raise InputError(f"capacitance = {capacitance!r}: must be positive")
    rs, rl = float(source_resistance), load_resistance
    if rule == "paper":
        if model.n_terms != 1 or model.beta[0] <= 0:
            raise NotRealisableError("the paper's rule covers one creep term with beta0 > 0; "
                                     "use --rule exact")
        b, tau = model.beta[0], model.tau[0]
        r1 = tau * (1 + 2 * b) / (capacitance * (1 + b))
        return Network((Cell(r1, capacitance),), r1 * (1 + b) / b, (), rs, rl)
    if model.sign > 0:
        return _foster_chain(model, capacitance, rs, rl)
    if model.sign < 0:
        return _lag_network(model, capacitance, rs, rl)
    raise NotRealisableError(explain_unrealisable(model))


def _foster_chain(model, capacitance, rs, rl) -> Network:
    beta, tau = np.array(model.beta), np.array(model.tau)
    ref = int(np.argmax(tau / beta))                 # the term that gets the largest capacitor
    r_total = tau[ref] / capacitance / beta[ref]      # R2' + Rs
    r2_eff = r_total - rs
    if r2_eff <= 0:
        raise InputError(f"source resistance {format_quantity(rs, 'Ω')} is too large for "
                         f"C = {format_quantity(capacitance, 'F')}: the exact rule needs "
                         f"R2' + Rs = {format_quantity(r_total, 'Ω')}; use a smaller capacitor")
    if rl is None:
        r2 = r2_eff
    elif r2_eff >= rl:
        raise InputError(f"load resistance {format_quantity(rl, 'Ω')} is too low for "
                         f"C = {format_quantity(capacitance, 'F')}: R2 || RL must be "
                         f"{format_quantity(r2_eff, 'Ω')}; use a larger capacitor")
    else:
        r2 = 1.0 / (1.0 / r2_eff - 1.0 / rl)
    cells = tuple(Cell(b * r_total, t / (b * r_total)) for b, t in zip(beta, tau))
    return Network(cells, r2, (), rs, rl)


def _lag_network(model, capacitance, rs, rl) -> Network:
    mag, tau = -np.array(model.beta), np.array(model.tau)
    one_plus = 1.0 + model.beta0
    g_load = 0.0 if rl is None else 1.0 / rl
    ref = int(np.argmax(mag * tau))                    # largest shunt capacitor
    g_a = capacitance * one_plus / (mag[ref] * tau[ref]) - g_load
    if g_a <= 0:
        raise InputError(f"load resistance {format_quantity(rl, 'Ω')} is too low for "
                         f"C = {format_quantity(capacitance, 'F')}; use a larger capacitor")
    r_a = 1.0 / g_a                                      # series R + Rs
    if r_a <= rs:
        raise InputError(f"source resistance {format_quantity(rs, 'Ω')} is too large for "
                         f"C = {format_quantity(capacitance, 'F')}: the lag network needs a "
                         f"series resistance of {format_quantity(r_a, 'Ω')} in all; use a "
                         "smaller capacitor")
    c = (1.0 + r_a * g_load) / one_plus
    shunt = tuple(Branch(r_a / (c * m), t * c * m / r_a) for m, t in zip(mag, tau))
    return Network((Cell(r_a - rs, 0.0),), None, shunt, rs, rl)


def _largest_capacitor_label(network: Network) -> str:
    caps = [(v, label) for label, kind, v in network.parts() if kind == "C"]
    return max(caps)[1]


@dataclass(frozen=True)
class PartChoice:
    """One part of a snapped design.

    Attributes
    ----------
    label, kind : str
        Designator (``R1``, ``C1``, ``R2`` ...) and ``"R"`` or ``"C"``.
    ideal, chosen : float
        Exact value at the chosen impedance level, and the value picked.
    series : str
        E-series the part comes from.
    residual_if_only_this : float
        Peak residual creep if only this part were snapped (the others ideal).
    """

    label: str
    kind: str
    ideal: float
    chosen: float
    series: str
    residual_if_only_this: float

    @property
    def deviation(self) -> float:
        """``chosen / ideal - 1``."""
        return self.chosen / self.ideal - 1.0


@dataclass(frozen=True)
class SizingReport(Shown):
    """Everything ``creepcomp size`` reports: ideal, snapped and nearest designs and their quality."""

    model: CreepModel
    rule: str
    ideal: Network
    ideal_quality: Quality
    chosen: Network
    chosen_quality: Quality
    uncorrected_quality: Quality
    resistor_series: str | None = None
    capacitor_series: str | None = None
    nearest: Network | None = None
    nearest_quality: Quality | None = None
    parts: tuple[PartChoice, ...] = ()
    candidates_evaluated: int = 0
    warnings: tuple[str, ...] = field(default_factory=tuple)
    plan: PartsPlan = field(default_factory=PartsPlan)

    def __repr__(self) -> str:
        parts = (f"{self.resistor_series}/{self.capacitor_series} parts" if self.resistor_series
                 else "ideal values")
        return (f"<SizingReport {self.rule} rule, {self.chosen.topology} network of {parts}: peak residual "
                f"creep {format_percent(self.chosen_quality.residual_creep_peak)} (uncorrected "
                f"{format_percent(self.uncorrected_quality.residual_creep_peak)}), "
                f"{len(self.warnings)} warning{'' if len(self.warnings) == 1 else 's'}>")

    def to_pandas(self):
        """The chosen network's parts (label, kind, value in Ω or F) as a pandas DataFrame."""
        parts = self.chosen.parts()
        ideal = dict((label, v) for label, _, v in self.ideal.parts())
        return data_frame({"part": [p[0] for p in parts], "kind": [p[1] for p in parts],
                           "ideal": [ideal.get(p[0]) for p in parts], "chosen": [p[2] for p in parts]})

    def design_dict(self) -> dict:
        """The design file (``docs/design-file.md``) of the chosen parts."""
        out = {"creep": self.model.creep_block()}
        out.update(self.chosen.to_dict())
        out["rule"] = self.rule
        out["series"] = {"resistors": self.resistor_series, "capacitors": self.capacitor_series}
        out["predicted"] = self.chosen_quality.to_dict()
        out["parts"] = self.plan.to_dict()
        return out

    def to_dict(self) -> dict:
        """``size --json``: the design, ``predicted``, ``ideal``, ``nearest``, parts and warnings."""
        out = self.design_dict()

        def block(net: Network, q: Quality) -> dict:
            d = {k: v for k, v in net.to_dict().items() if k in ("cells", "R2", "shunt")}
            d["predicted"] = q.to_dict()
            return d

        out["ideal"] = block(self.ideal, self.ideal_quality)
        if self.nearest is not None:
            out["nearest"] = block(self.nearest, self.nearest_quality)
        out["uncorrected"] = {"predicted": self.uncorrected_quality.to_dict()}
        out["parts"] = [{"part": p.label, "kind": p.kind, "series": p.series, "ideal": p.ideal,
                         "chosen": p.chosen, "deviation": p.deviation,
                         "residual_creep_peak_if_only_this_snapped": p.residual_if_only_this}
                        for p in self.parts]
        out["candidates_evaluated"] = self.candidates_evaluated
        out["warnings"] = list(self.warnings)
        return out


def size(model: CreepModel, rule: str = "exact", resistor_series: str | None = "E24",
         capacitor_series: str | None = "E6", cap_range: tuple[float, float] = DEFAULT_CAP_RANGE,
         res_range: tuple[float, float] = DEFAULT_RES_RANGE, capacitance: float | None = None,
         source_resistance: float = 0.0, load_resistance: float | None = None,
         sweep_period: float | None = None, plan: PartsPlan | None = None) -> SizingReport:
    """Size a correction network and snap it to E-series parts.

    Parameters
    ----------
    model : CreepModel
        Creep to cancel.
    rule : {"exact", "paper"}
        Sizing rule.
    resistor_series, capacitor_series : str or None
        E-series of the parts; None keeps ideal values (no snapping).
    cap_range : (float, float)
        Capacitor values to search (F).
    res_range : (float, float)
        Resistor values allowed (ohm).
    capacitance : float, optional
        Fix the largest capacitor to this value instead of searching ``cap_range``.
    source_resistance : float
        Sensor output resistance (ohm).
    load_resistance : float or None
        Next stage's input resistance (ohm).
    sweep_period : float, optional
        Period of the hysteresis sweep (s).
    plan : PartsPlan, optional
        The parts' technologies and tolerances, recorded in the design file (default:
        thin-film resistors, polypropylene capacitors).

    Returns
    -------
    SizingReport

    Examples
    --------
    The default sensor, 3 % of creep at a retardation time of 45 s, with E24 resistors and
    E6 capacitors:

    >>> from creepcomp.model import CreepModel
    >>> from creepcomp.analog.sizing import size
    >>> report = size(CreepModel(beta=(0.03,), tau=(45.0,)))
    >>> cell = report.chosen.cells[0]
    >>> print(f"R1 = {cell.R:.3g} ohm, C1 = {cell.C:.3g} F, R2 = {report.chosen.R2:.3g} ohm")
    R1 = 3e+06 ohm, C1 = 1.5e-05 F, R2 = 1e+08 ohm
    >>> report.chosen_quality.residual_creep_peak < 1e-12
    True
    """
    check_time_constants(model)
    plan = plan or PartsPlan()

    def quality(net):
        return predict(model, net, sweep_period)

    uncorrected = quality(None)
    if resistor_series is None or capacitor_series is None:
        net = ideal_network(model, rule, capacitance or DEFAULT_CAPACITANCE,
                            source_resistance, load_resistance)
        q = quality(net)
        return SizingReport(model, rule, net, q, net, q, uncorrected,
                            warnings=tuple(design_warnings(model, net, rule, q)), plan=plan)
    eseries.series_values(resistor_series)
    eseries.series_values(capacitor_series)
    levels = ([capacitance] if capacitance else
              list(eseries.values_in_range(capacitor_series, *cap_range)))
    if not levels:
        raise InputError(f"no {capacitor_series} capacitor between "
                         f"{format_quantity(cap_range[0], 'F')} and {format_quantity(cap_range[1], 'F')}")
    ideals, problems = [], []
    for c in levels:
        try:
            ideals.append(ideal_network(model, rule, c, source_resistance, load_resistance))
        except InputError as exc:
            problems.append(str(exc))
    if not ideals:
        made = DIELECTRICS[plan.capacitor]
        advice = "use a larger capacitor"
        fixable = not (problems[-1].endswith(advice) and max(levels) >= made.value_range[1])
        if not fixable:
            problems[-1] = (problems[-1][:-len(advice)] + f"and {made.name} capacitors are not "
                            f"made above {format_quantity(made.value_range[1], 'F')}")
        raise NoNetworkInRange(problems[-1], fixable)
    series_of = {"R": resistor_series, "C": capacitor_series}
    candidates, origin = [], []
    lags = len(ideals[0].cells) + len(ideals[0].shunt)
    per_candidate = model.n_terms * lags * len(screening_times(model))
    most = int(min(MAX_COMBINATIONS_PER_LEVEL, max(16, SIZING_WORK // (len(ideals) * per_candidate))))
    for net in ideals:
        combos = _combinations(net, series_of, res_range, cap_range, most)
        candidates.extend(combos)
        origin.extend([net] * len(combos))
    if not candidates:
        net = ideals[-1]
        outside = ", ".join(f"{label} = {format_quantity(v, 'Ω')}" for label, kind, v in net.parts()
                            if kind == "R" and not res_range[0] <= v <= res_range[1])
        c0 = max(v for _, k, v in net.parts() if k == "C")
        made = DIELECTRICS[plan.capacitor]
        if not outside:  # every resistor fits: a smaller cell's capacitor does not
            low, high = min(cap_range[0], FILM_CAP_RANGE[0]), max(cap_range[1], FILM_CAP_RANGE[1])
            small = ", ".join(f"{label} = {format_quantity(v, 'F')}" for label, kind, v in net.parts()
                              if kind == "C" and not low <= v <= high)
            raise NoNetworkInRange(f"at C = {format_quantity(c0, 'F')} the {rule} rule needs {small}, "
                                   f"outside the capacitors searched, {format_quantity(low, 'F')} .. "
                                   f"{format_quantity(high, 'F')}: widen --cap-range, or correct "
                                   "fewer terms", True)
        advice, fixable = _capacitance_needed(net, c0, res_range, made.value_range, made.name)
        raise NoNetworkInRange(f"at C = {format_quantity(c0, 'F')} the {rule} rule needs {outside}, "
                               f"outside the resistor range {format_quantity(res_range[0], 'Ω')} .. "
                               f"{format_quantity(res_range[1], 'Ω')} (--res-range); " + advice,
                               fixable)
    # Snapping keeps the rule's behaviour: closest to the rule's ideal step response (for the
    # exact rule, that is the smallest residual creep; for the paper's, its own residual).
    reference = None if rule == "exact" else ideals[0]
    scores = _screen(model, ideals[0], np.array(candidates), reference)
    order = np.argsort(scores)[:EXACT_RECHECKS]
    best = min(order, key=lambda i: step_deviation(model, origin[i].with_parts(candidates[i]),
                                                   reference))
    ideal = origin[best]
    chosen = ideal.with_parts(candidates[best])
    best_q = quality(chosen)
    nearest = nearest_snap(model, rule, resistor_series, capacitor_series,
                           capacitance or DEFAULT_CAPACITANCE, source_resistance, load_resistance)
    ideal_parts = ideal.parts()
    parts = []
    for k, ((label, kind, v), c) in enumerate(zip(ideal_parts, candidates[best])):
        only = [p[2] for p in ideal_parts]
        only[k] = c
        parts.append(PartChoice(label, kind, v, float(c), series_of[kind],
                                step_peak(model, ideal.with_parts(only))[0]))
    ideal_q = quality(ideal)
    return SizingReport(model, rule, ideal, ideal_q, chosen, best_q, uncorrected,
                        resistor_series.upper(), capacitor_series.upper(), nearest,
                        quality(nearest) if nearest else None,
                        tuple(parts), len(candidates),
                        tuple(design_warnings(model, chosen, rule, best_q)), plan)


#: Retardation times a network is sized for (s): 1 µs to 1 Gs (32 years). Beyond them the
#: parts leave every E-series decade and the arithmetic of the search overflows.
TAU_RANGE = (1e-6, 1e9)


def check_time_constants(model: CreepModel) -> None:
    """Refuse retardation times outside :data:`TAU_RANGE`, naming the limits."""
    for k, t in enumerate(model.tau):
        if not TAU_RANGE[0] <= t <= TAU_RANGE[1]:
            raise InputError(f"tau[{k}] = {format_quantity(t, 's')}: outside the "
                             f"{format_quantity(TAU_RANGE[0], 's')} .. {format_quantity(TAU_RANGE[1], 's')} "
                             "a correction network can be sized for")


def _capacitance_needed(net: Network, c0: float, res_range: tuple[float, float],
                        made: tuple[float, float] = FILM_CAP_RANGE,
                        dielectric: str = "film") -> tuple[str, bool]:
    """Advice for an infeasible size: the capacitance, among those made, that brings every
    resistor into range; and whether there is one (False: no capacitor made would do).

    The network's time constants are fixed by the creep, so its resistors scale as ``1/C``
    (the source and load resistances aside).
    """
    rs = [v for _, k, v in net.parts() if k == "R"]
    low, high = c0 * max(rs) / res_range[1], c0 * min(rs) / res_range[0]
    if low > high:
        return (f"no single capacitance brings all resistors into range (their ratio "
                f"{max(rs) / min(rs):.3g} exceeds the range's): widen --res-range"), True
    low_made, high_made = max(low, made[0]), min(high, made[1])
    if low_made > high_made:
        return (f"only a capacitor of {format_quantity(low, 'F', 3)} .. {format_quantity(high, 'F', 3)} "
                f"would bring every resistor into range, and {dielectric} capacitors are made "
                f"only in {format_quantity(made[0], 'F')} .. {format_quantity(made[1], 'F')}: "
                "buffer the output, correct fewer terms, or use the digital corrector "
                "(creepcomp firmware)"), False
    text = format_quantity(low_made, 'F', 3)
    return (f"a capacitor of {text} .. {format_quantity(high_made, 'F', 3)} "
            f"brings every resistor into range: e.g. --capacitance {text.replace(' ', '')}, "
            "or --cap-range; or widen --res-range"), True


def nearest_snap(model: CreepModel, rule: str, resistor_series: str, capacitor_series: str,
                 capacitance: float, source_resistance: float = 0.0,
                 load_resistance: float | None = None) -> Network | None:
    """What rounding each part to its nearest series value gives: the capacitor nearest to
    ``capacitance``, then every other part of the rule's ideal network nearest to its value.

    Returns None when the rule has no network at that capacitance.
    """
    c = eseries.nearest(capacitance, capacitor_series)
    try:
        ideal = ideal_network(model, rule, c, source_resistance, load_resistance)
    except InputError:
        return None
    series_of = {"R": resistor_series, "C": capacitor_series}
    ref = _largest_capacitor_label(ideal)
    return ideal.with_parts([v if label == ref else eseries.nearest(v, series_of[kind])
                             for label, kind, v in ideal.parts()])


def _combinations(net: Network, series_of, res_range, cap_range,
                  most: int = MAX_COMBINATIONS_PER_LEVEL) -> list[tuple[float, ...]]:
    """Neighbouring series values of every part; the largest capacitor stays as it is. When
    there are more than ``most`` combinations (many parts), the one of each part's nearest
    value and a fixed random draw of the others, ``most`` in all."""
    ref = _largest_capacitor_label(net)
    parts = net.parts()
    free = sum(1 for label, _, _ in parts if label != ref)
    per_side = 1
    for n in (3, 2):
        if (2 * n) ** free <= most:
            per_side = n
            break
    choices = []
    for label, kind, v in parts:
        if label == ref:
            choices.append([v])
            continue
        lo, hi = res_range if kind == "R" else cap_range
        if kind == "C":
            lo, hi = min(lo, FILM_CAP_RANGE[0]), max(hi, FILM_CAP_RANGE[1])
        vals = [x for x in eseries.neighbours(v, series_of[kind], per_side) if lo <= x <= hi]
        if not vals:
            return []
        choices.append(vals)
    if math.prod(len(c) for c in choices) <= most:
        return list(itertools.product(*choices))
    nearest = tuple(min(c, key=lambda x, v=v: abs(math.log(x / v))) for c, (_, _, v) in zip(choices, parts))
    rng = np.random.default_rng(0)
    drawn = {nearest}
    for _ in range(10 * most):
        if len(drawn) >= most:
            break
        drawn.add(tuple(c[rng.integers(len(c))] for c in choices))
    return [nearest] + sorted(drawn - {nearest})


def _screen(model: CreepModel, template: Network, values: np.ndarray,
            reference: Network | None, batch: int = 2048) -> np.ndarray:
    """Closed-form deviation from the reference's step response (None: peak residual creep)
    of many part-value sets of one topology."""
    out = np.empty(len(values))
    for start in range(0, len(values), batch):
        chunk = values[start:start + batch]
        arrays = template.batch_arrays(chunk)
        d, r, p = modal_form(*state_matrices(*arrays))
        out[start:start + batch] = screening_deviation(model, d, r, p, reference)
    return out


def output_resistance(network: Network) -> float:
    """Resistance seen into the network's output at DC (capacitors open)."""
    series = network.source_resistance + sum(c.R for c in network.cells)
    return parallel(series, network.R2, network.load_resistance)


def design_warnings(model: CreepModel, network: Network, rule: str, quality: Quality) -> list[str]:
    """What a designer must know about a network: impedance level, capacitor technology, rule limits."""
    out = []
    resistors = [(v, label) for label, kind, v in network.parts() if kind == "R"]
    big, big_label = max(resistors)
    if big > HIGH_IMPEDANCE:
        r_out = output_resistance(network)
        out.append(
            f"high impedance: {big_label} = {format_quantity(big, 'Ω')}, output resistance "
            f"{format_quantity(r_out, 'Ω')}. An input bias current of 1 pA (CMOS/JFET op amp) "
            f"gives {format_quantity(r_out * 1e-12, 'V')} of offset, 1 nA (bipolar) "
            f"{format_quantity(r_out * 1e-9, 'V')}, against sensor signals of order 0.1 mV "
            "(constant offsets, removed by taring; leakage is judged by the practicality "
            "verdict). Buffer the output with a CMOS/JFET-input amplifier and guard the node, "
            "or use a larger capacitor (--cap-range) to lower the impedance.")
    for label, kind, v in network.parts():
        if kind == "C" and not FILM_CAP_RANGE[0] <= v <= FILM_CAP_RANGE[1]:
            out.append(f"{label} = {format_quantity(v, 'F')} is outside what film capacitors "
                       f"offer ({format_quantity(FILM_CAP_RANGE[0], 'F')} to "
                       f"{format_quantity(FILM_CAP_RANGE[1], 'F')}); electrolytic and high-k "
                       "ceramic parts leak and absorb too much for time constants of tens of "
                       "seconds.")
    if rule == "paper" and (network.source_resistance or network.load_resistance):
        out.append("the paper's rule does not account for source and load resistance; "
                   "the prediction includes them, the part values do not (use --rule exact)")
    return out
