"""Can a sized network be built and does it still correct on a real board? The verdict and the way out.

A design is judged impractical when

* a part lies outside what is made: a resistor outside every technology of
  :data:`~creepcomp.analog.parts.RESISTORS`, a capacitor outside the values of the plan's
  dielectric (:data:`~creepcomp.analog.parts.DIELECTRICS`);
* leakage undoes it: with a path of :data:`~creepcomp.analog.sizing.ASSUMED_LEAKAGE` from the
  output to ground (board surface, the next stage) and each capacitor's insulation resistance
  (its dielectric's ``R_ins C`` at 25 °C), the peak residual creep is no better than without
  correction;
* its parts' tolerances undo it: the worst corner of the plan's tolerance box (every part at
  ``±tolerance``, closed-form step response) leaves a peak residual creep no better than
  without correction.

An op amp's input bias current is not part of the verdict: a constant current into the
output node gives a constant offset (removed by taring), not creep; the offset it gives is
reported (:attr:`Verdict.bias_offset`).

The corner bound is computed here, in the analog stage, rather than with ``verify``'s worst
case (a later stage, which ``analog`` may not import): it needs only the closed-form step
response of many networks at once, which the sizing's screen already has.

The way out of an impractical design (:func:`find_way_out`) is the first practical design of
a short list of changes, nearest first: buffer the output (infinite load), search every
capacitor the dielectric is made in and every resistor made, both, then fewer cells (the
terms of larger amplitude kept). When none is practical, the digital corrector is the way.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field, replace

import numpy as np

from creepcomp.analog.parts import DIELECTRICS, RESISTORS, PART_REFERENCE, PartsPlan
from creepcomp.analog.quality import screening_deviation, screening_times, step_peak
from creepcomp.analog.sizing import (ASSUMED_LEAKAGE, NoNetworkInRange, SizingReport,
                                     output_resistance, size)
from creepcomp.errors import NotRealisableError
from creepcomp.model import CreepModel
from creepcomp.network import Network, modal_form, parallel, state_matrices
from creepcomp.units import format_percent, format_quantity

__all__ = ["ASSUMED_BIAS", "MAX_CORNERS", "CORNER_WORK", "corner_count", "Verdict", "WayOut", "made_range",
           "resistor_technology", "part_tolerance", "judge", "judge_network", "judge_active",
           "find_way_out"]

#: Input bias current of a CMOS/JFET-input buffer (A), for the offset reported.
ASSUMED_BIAS = 1e-12
#: Corners of the tolerance box evaluated at most (a random subset beyond).
MAX_CORNERS = 4096
#: Values (corners x sensor terms x network lags x screening times) the corners' screening
#: computes at most: a model of many terms gets fewer random corners, and a bounded time
#: (a few seconds), instead of minutes.
CORNER_WORK = 50_000_000


def corner_count(model: CreepModel, lags: int) -> int:
    """How many tolerance corners to screen for ``model`` and a network of ``lags`` lags:
    :data:`MAX_CORNERS`, fewer when :data:`CORNER_WORK` would be exceeded (at least 64)."""
    per_corner = model.n_terms * max(1, lags) * len(screening_times(model))
    return int(min(MAX_CORNERS, max(64, CORNER_WORK // per_corner)))


def made_range(kind: str, plan: PartsPlan) -> tuple[float, float]:
    """Values made: resistors of any technology (ohm), capacitors of the plan's dielectric (F)."""
    if kind == "R":
        return (min(t.value_range[0] for t in RESISTORS.values()),
                max(t.value_range[1] for t in RESISTORS.values()))
    return DIELECTRICS[plan.capacitor].value_range


def resistor_technology(value: float, plan: PartsPlan) -> str | None:
    """The plan's resistor technology when it makes ``value``, else the first one that does."""
    order = [plan.resistor] + [k for k in RESISTORS if k != plan.resistor]
    for key in order:
        lo, hi = RESISTORS[key].value_range
        if lo <= value <= hi:
            return key
    return None


def part_tolerance(label: str, kind: str, value: float, plan: PartsPlan) -> float:
    """The tolerance a part is bought with: the plan's, or the tightest its technology sells
    when that is looser (a resistor outside the plan's technology), or the thermistor's."""
    if label in plan.thermistors:
        return plan.thermistors[label].tolerance
    if kind == "C":
        return plan.capacitor_tolerance
    tech = resistor_technology(value, plan)
    if tech is None or tech == plan.resistor:
        return plan.resistor_tolerance
    return max(plan.resistor_tolerance, min(RESISTORS[tech].tolerances))


@dataclass(frozen=True)
class Verdict:
    """Whether a design can be built and still corrects, and why not.

    Attributes
    ----------
    practical : bool
    reasons : tuple of str
        One sentence per failed check.
    uncorrected_peak, leakage_peak, worst_case_peak : float
        Peak residual creep without correction, with the leakage paths, and at the worst
        corner of the tolerance box.
    output_resistance : float
        The network's DC output resistance (ohm).
    bias_offset : float
        Offset an input bias current of :data:`ASSUMED_BIAS` gives (V).
    corners : int
        Tolerance corners evaluated.
    """

    practical: bool
    reasons: tuple[str, ...]
    uncorrected_peak: float
    leakage_peak: float
    worst_case_peak: float
    output_resistance: float
    bias_offset: float
    corners: int
    op_amp: dict | None = None

    def to_dict(self) -> dict:
        extra = {} if self.op_amp is None else {"op_amp": self.op_amp}
        return {**extra, "practical": self.practical, "reasons": list(self.reasons),
                "uncorrected_peak": self.uncorrected_peak, "leakage_peak": self.leakage_peak,
                "worst_case_peak": self.worst_case_peak,
                "output_resistance": self.output_resistance,
                "bias_current": self.op_amp["bias_current"] if self.op_amp else ASSUMED_BIAS,
                "bias_offset": self.bias_offset,
                "leakage_to_ground": ASSUMED_LEAKAGE, "tolerance_corners": self.corners}


def _range_text(r, unit):
    return f"{format_quantity(r[0], unit)} .. {format_quantity(r[1], unit)}"


def _outside_made(network: Network, plan: PartsPlan) -> list[str]:
    out = []
    for label, kind, value in network.parts():
        if label in plan.thermistors:
            continue
        lo, hi = made_range(kind, plan)
        if not lo <= value <= hi:
            unit = "Ω" if kind == "R" else "F"
            what = ("resistors are made in" if kind == "R"
                    else f"{DIELECTRICS[plan.capacitor].name} capacitors are made in")
            out.append(f"{label} = {format_quantity(value, unit)} is outside what {what} "
                       f"({_range_text((lo, hi), unit)})")
    return out


def leaky_network(network: Network, plan: PartsPlan) -> Network:
    """The network with a leakage path of :data:`ASSUMED_LEAKAGE` at its output and each cell
    capacitor's insulation resistance across it (the plan's dielectric at 25 °C)."""
    tau_ins = DIELECTRICS[plan.capacitor].insulation_time(PART_REFERENCE)
    cells = tuple(c if c.C <= 0 else replace(c, leakage=parallel(c.leakage, tau_ins / c.C))
                  for c in network.cells)
    return replace(network, cells=cells,
                   load_resistance=parallel(network.load_resistance, ASSUMED_LEAKAGE))


def tolerance_corners(parts, plan: PartsPlan, seed: int = 0, most: int = MAX_CORNERS) -> np.ndarray:
    """Part values at the corners of the tolerance box (one row per corner; a random
    ``most`` of them when there are more), from ``(label, kind, value)`` parts."""
    nominal = np.array([v for _, _, v in parts])
    tol = np.array([part_tolerance(label, kind, v, plan) for label, kind, v in parts])
    m = len(parts)
    if 2 ** m <= most:
        bits = (np.arange(2 ** m)[:, None] >> np.arange(m)[None, :]) & 1
    else:
        bits = np.random.default_rng(seed).integers(0, 2, (most, m))
    return nominal * (1.0 + np.where(bits == 1, tol, -tol))


def worst_corner(model: CreepModel, network: Network, plan: PartsPlan,
                 seed: int = 0) -> tuple[float, int]:
    """Largest peak residual creep over the corners of the parts' tolerance box (closed form).

    Returns the value and the number of corners evaluated.
    """
    lags = len(network.cells) + len(network.shunt)
    values = tolerance_corners(network.parts(), plan, seed, corner_count(model, lags))
    d, r, p = modal_form(*state_matrices(*network.batch_arrays(values)))
    return float(screening_deviation(model, d, r, p).max()), len(values)


def judge_network(model: CreepModel, network: Network, plan: PartsPlan | None = None) -> Verdict:
    """The verdict on one network correcting ``model`` (see the module's description).

    Parameters
    ----------
    model : CreepModel
        The sensor's whole creep (also for a network that corrects only some terms).
    network : Network
        Part values at 25 °C.
    plan : PartsPlan, optional
        Technologies and tolerances (default: the default plan).

    Returns
    -------
    Verdict
    """
    plan = plan or PartsPlan()
    if getattr(network, "topology", None) == "active":
        return judge_active(model, network, plan)
    reasons = _outside_made(network, plan)
    uncorrected = step_peak(model, None)[0]
    leak = step_peak(model, leaky_network(network, plan))[0]
    if leak >= uncorrected:
        reasons.append(
            f"a {format_quantity(ASSUMED_LEAKAGE, 'Ω')} leakage path at the output (board, next "
            f"stage) and the capacitors' insulation leave a peak residual creep of "
            f"{format_percent(leak)}, no better than the uncorrected {format_percent(uncorrected)}")
    worst, corners = worst_corner(model, network, plan)
    if worst >= uncorrected:
        reasons.append(
            f"at the worst corner of the parts' tolerances (R ±{format_percent(plan.resistor_tolerance)}, "
            f"C ±{format_percent(plan.capacitor_tolerance)}) the peak residual creep is "
            f"{format_percent(worst)}, no better than the uncorrected {format_percent(uncorrected)}")
    r_out = output_resistance(network)
    return Verdict(not reasons, tuple(reasons), uncorrected, leak, worst, r_out,
                   r_out * ASSUMED_BIAS, corners)


def judge_active(model: CreepModel, stage, plan: PartsPlan | None = None) -> Verdict:
    """The verdict on an active stage (:class:`~creepcomp.analog.active.ActiveStage`).

    The same three checks as a passive network's: parts made; leakage (each integrator
    capacitor's insulation at 25 °C and a :data:`~creepcomp.analog.sizing.ASSUMED_LEAKAGE`
    board path across it, where a leak makes the integrator lossy; the follower drives the
    output, so a leak there changes nothing); the worst corner of the tolerance box
    (thermistors at their ``R25`` tolerance). ``bias_offset`` is the largest constant output
    offset op amps at :data:`~creepcomp.analog.active.OP_AMP`'s limits give at the coldest
    end of the parts' use (25 °C here; ``size`` reports the range's), ``op_amp`` the requirement.
    """
    from creepcomp.analog.active import OP_AMP, output_offset

    plan = plan or PartsPlan()
    reasons = _outside_made(stage, plan)
    uncorrected = step_peak(model, None)[0]
    tau_ins = DIELECTRICS[plan.capacitor].insulation_time(PART_REFERENCE)
    leaky = stage.with_leakage([parallel(tau_ins / t.C, ASSUMED_LEAKAGE) for t in stage.terms])
    leak = step_peak(model, leaky)[0]
    if leak >= uncorrected:
        reasons.append(
            f"the capacitors' insulation and a {format_quantity(ASSUMED_LEAKAGE, 'Ω')} board path "
            f"across each leave a peak residual creep of {format_percent(leak)}, no better than "
            f"the uncorrected {format_percent(uncorrected)}")
    values = tolerance_corners(stage.parts(), plan, most=corner_count(model, len(stage.terms)))
    lags = [stage.with_parts(v).lag_expansion() for v in values]
    worst = float(screening_deviation(model, np.array([g.direct for g in lags]),
                                      np.array([g.gains for g in lags]),
                                      np.array([g.taus for g in lags])).max())
    if worst >= uncorrected:
        reasons.append(
            f"at the worst corner of the parts' tolerances the peak residual creep is "
            f"{format_percent(worst)}, no better than the uncorrected {format_percent(uncorrected)}")
    return Verdict(not reasons, tuple(reasons), uncorrected, leak, worst, 0.0,
                   output_offset(stage, plan, PART_REFERENCE), len(values), OP_AMP.to_dict())


def judge(report: SizingReport) -> Verdict:
    """The verdict on a sizing's chosen parts, with the plan it records."""
    return judge_network(report.model, report.chosen, report.plan)


@dataclass(frozen=True)
class WayOut:
    """The nearest practical alternative of an impractical design.

    Attributes
    ----------
    kind : {"size", "firmware"}
        A changed sizing, or the digital corrector.
    changes : dict
        For ``size``: the :func:`~creepcomp.analog.sizing.size` arguments that change
        (``load_resistance`` None is a buffer; ``cap_range``, ``res_range``; ``terms``: the
        indices of the creep terms kept).
    description : str
        What the change is, in words.
    report : SizingReport or None
        The practical sizing (for ``size``).
    verdict : Verdict or None
    """

    kind: str
    changes: dict = field(default_factory=dict)
    description: str = ""
    report: SizingReport | None = None
    verdict: Verdict | None = None

    def to_dict(self) -> dict:
        out = {"kind": self.kind, "description": self.description,
               "changes": {k: (list(v) if isinstance(v, tuple) else v)
                           for k, v in self.changes.items()}}
        if self.report is not None:
            q = self.verdict
            out["predicted_peak"] = q.leakage_peak if q else None
            out["worst_case_peak"] = q.worst_case_peak if q else None
        return out


#: Up to this many creep terms the way out tries every subset of them; beyond, only the
#: largest terms (the k largest for each k), so the tries grow with the terms, not 2**terms.
ALL_SUBSETS_TERMS = 4


def _term_subsets(model: CreepModel):
    """The subsets of the model's terms a way out may correct, nearest (most terms, largest
    first) first."""
    n = model.n_terms
    by_size = sorted(range(n), key=lambda k: -abs(model.beta[k]))
    for keep in range(n - 1, 0, -1):
        if n <= ALL_SUBSETS_TERMS:
            yield from itertools.combinations(by_size, keep)
        else:
            yield tuple(by_size[:keep])


def _candidates(model: CreepModel, options: dict, plan: PartsPlan):
    """Changes to try, nearest first."""
    made = {"cap_range": made_range("C", plan), "res_range": made_range("R", plan),
            "capacitance": None}
    buffered = options.get("load_resistance") is not None
    out = []
    if buffered:
        out.append(({"load_resistance": None}, "buffer the output (a CMOS/JFET-input amplifier: "
                                               "infinite load)"))
    ranges = ("search every capacitor made (" + _range_text(made["cap_range"], "F")
              + ") and every resistor made (" + _range_text(made["res_range"], "Ω") + ")")
    out.append((made, ranges))
    if buffered:
        out.append((dict(made, load_resistance=None), "buffer the output and " + ranges))
    for subset in _term_subsets(model):
        terms = tuple(sorted(subset))
        kept = ", ".join(f"{format_percent(model.beta[k])} at {format_quantity(model.tau[k], 's')}"
                         for k in terms)
        out.append(({"terms": terms}, f"correct only {kept}"))
        out.append((dict(made, terms=terms), f"correct only {kept}; {ranges}"))
        if buffered:
            out.append(({"terms": terms, "load_resistance": None},
                        f"correct only {kept}, buffered"))
            out.append((dict(made, terms=terms, load_resistance=None),
                        f"correct only {kept}, buffered; {ranges}"))
    return out


def find_way_out(model: CreepModel, options: dict, plan: PartsPlan | None = None) -> WayOut:
    """The nearest practical design, or the digital corrector when there is none.

    Parameters
    ----------
    model : CreepModel
        The sensor's creep.
    options : dict
        The keyword arguments of :func:`~creepcomp.analog.sizing.size` the design was asked with.
    plan : PartsPlan, optional

    Returns
    -------
    WayOut
    """
    plan = plan or PartsPlan()
    for changes, text in _candidates(model, options, plan):
        kwargs = {k: v for k, v in dict(options, **changes).items() if k != "terms"}
        terms = changes.get("terms")
        corrected = model if terms is None else CreepModel(
            beta=tuple(model.beta[k] for k in terms), tau=tuple(model.tau[k] for k in terms))
        try:
            report = size(corrected, plan=plan, **kwargs)
        except (NoNetworkInRange, NotRealisableError):
            continue
        verdict = judge_network(model, report.chosen, plan)
        if verdict.practical:
            return WayOut("size", changes, text, report, verdict)
    return WayOut("firmware", {}, "no practical network: use the digital corrector (C firmware)")
