"""Design over a temperature range: the residual creep at every temperature, and sizing for it.

At each temperature of :func:`creepcomp.temperature.temperature_grid` the sensor is
``model.at_temperature(T)`` (its retardation times shift by ``a_T``) and the network is
:func:`network_over` (every part at its value at ``T``, thermistors on their ``B`` law, each
cell capacitor leaking through its insulation resistance ``R_ins C`` at ``T``). The peak
residual creep of a full-scale step is the project's exact prediction
(:func:`creepcomp.analog.quality.step_peak`).

Three designs over a range:

- :func:`size_fixed_for_range`: fixed parts. The ideal network is sized for the sensor at an
  *effective temperature*, its amplitudes times a factor, both chosen so that the ideal's
  worst case over the range is smallest (:func:`effective_sizing`); the same E-series
  candidates the sizing screens around it are ranked by their worst case over the range
  (closed-form screen, then the exact prediction on the best few);
- :func:`size_ntc_tracking`: the time-setting resistors of a one-cell lead network (``R1``
  and ``R2``; both, since ``R1 / R2`` sets the gain of the correction) made of catalogue NTC
  thermistors, shaped by a fixed resistor in series with ``R1`` and one across ``R2``.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field, replace

import numpy as np

from creepcomp.analog import eseries
from creepcomp.analog.parts import (DIELECTRICS, NTC_THERMISTORS, PART_REFERENCE, PartsPlan,
                                    Thermistor, ThermistorUse, network_at, ntc_resistance)
from creepcomp.analog.quality import screening_deviation, step_peak
from creepcomp.analog.sizing import (DEFAULT_CAP_RANGE, DEFAULT_RES_RANGE, _combinations,
                                     ideal_network)
from creepcomp.errors import InputError
from creepcomp.model import CreepModel
from creepcomp.network import Cell, Network, modal_form, parallel, state_matrices
from creepcomp.temperature import temperature_grid
from creepcomp.units import format_quantity

__all__ = ["OverTemperature", "network_over", "over_temperature", "worst_case", "effective_sizing",
           "size_fixed_for_range", "TrackingDesign", "check_tracking", "size_ntc_tracking",
           "TRACKING_RECHECKS", "TRACKING_SHORTLIST", "RangeDesign", "RangeComparison",
           "compare_over_range", "TOPOLOGIES"]

#: Candidates re-checked with the exact prediction after the closed-form screen.
TRACKING_RECHECKS = 6
#: Thermistor designs screened over the whole range after a first screen at its ends.
TRACKING_SHORTLIST = 400


def network_over(network: Network, plan: PartsPlan, temperature: float) -> Network:
    """The network at ``temperature`` (°C): every part's value (:func:`network_at`) and each
    cell capacitor's insulation resistance ``R_ins C / C`` across it (in parallel with any
    leakage the network already has)."""
    if getattr(network, "topology", None) == "active":
        from creepcomp.analog.active import stage_over

        return stage_over(network, plan, temperature)
    net = network_at(network, plan, temperature)
    dielectric = DIELECTRICS[plan.capacitor]
    cells = tuple(replace(c, leakage=parallel(c.leakage, dielectric.insulation_time(temperature) / c.C))
                  if c.C > 0 else c for c in net.cells)
    return replace(net, cells=cells)


@dataclass(frozen=True)
class OverTemperature:
    """Peak residual creep of a full-scale step at each temperature of a range.

    Attributes
    ----------
    temperatures : tuple of float
        °C evaluated.
    peak_residual : tuple of float
        Peak residual creep at each (fraction of the step).
    uncorrected : tuple of float
        The uncorrected sensor's peak creep at each (fraction of the step).
    tracking : dict
        ``{"kind": "none"}`` or ``{"kind": "ntc", "thermistors": {...}}``.
    model_has_law : bool
        False when the model has no temperature law: only the parts drift.
    """

    temperatures: tuple[float, ...]
    peak_residual: tuple[float, ...]
    uncorrected: tuple[float, ...]
    tracking: dict = field(default_factory=lambda: {"kind": "none"})
    model_has_law: bool = True

    @property
    def worst(self) -> float:
        """The largest peak residual over the range."""
        return max(self.peak_residual)

    @property
    def worst_at(self) -> float:
        """The temperature (°C) of :attr:`worst`."""
        return self.temperatures[int(np.argmax(self.peak_residual))]

    @property
    def note(self) -> str:
        """What the prediction accounts for."""
        if self.model_has_law:
            return ("the sensor's creep follows its temperature law; every part's value, the "
                    "thermistors' B law and the capacitors' insulation resistance follow temperature")
        return ("the model has no temperature law: the sensor's creep is taken as constant, only "
                "the parts drift (values, thermistors, insulation resistance)")

    def to_dict(self) -> dict:
        """``over_temperature`` of ``size --json`` (``temperatures``, ``peak_residual``,
        ``worst``, ``worst_at``, ``tracking``) and the uncorrected sensor's figures."""
        tracking = "none" if self.tracking.get("kind") == "none" else dict(self.tracking)
        return {"temperatures": list(self.temperatures), "peak_residual": list(self.peak_residual),
                "worst": self.worst, "worst_at": self.worst_at, "tracking": tracking,
                "uncorrected_peak_creep": list(self.uncorrected), "model_has_law": self.model_has_law,
                "note": self.note}


def _tracking_dict(plan: PartsPlan, topology: str = "lead") -> dict:
    if not plan.thermistors:
        return {"kind": "none"}
    out = {"kind": "ntc", "thermistors": {k: v.to_dict() for k, v in plan.thermistors.items()}}
    if topology == "active":
        out["topology"] = "active"
    return out


def over_temperature(model: CreepModel, network: Network, plan: PartsPlan,
                     low: float, high: float) -> OverTemperature:
    """Peak residual creep of ``network`` at every temperature of ``low .. high`` (°C).

    Parameters
    ----------
    model : CreepModel
        The sensor; with a temperature law its terms follow it, without one they stay.
    network : Network
        The design, part values at their catalogue temperature.
    plan : PartsPlan
        The parts' technologies, temperature coefficients and thermistors.
    low, high : float
        The range (°C); evaluated every 5 K at most, the limits included.

    Returns
    -------
    OverTemperature
    """
    grid = temperature_grid(low, high)
    peaks, bare = [], []
    for t in grid:
        sensor = model.at_temperature(float(t))
        peaks.append(step_peak(sensor, network_over(network, plan, float(t)))[0])
        bare.append(step_peak(sensor, None)[0])
    return OverTemperature(tuple(float(t) for t in grid), tuple(peaks), tuple(bare),
                           _tracking_dict(plan, network.topology), model.temperature is not None)


def worst_case(model: CreepModel, network: Network, plan: PartsPlan, temperatures) -> float:
    """The largest exact peak residual creep over ``temperatures`` (°C)."""
    return max(step_peak(model.at_temperature(float(t)), network_over(network, plan, float(t)))[0]
               for t in temperatures)


def _screen_over(model: CreepModel, temperatures, networks_at) -> np.ndarray:
    """Worst closed-form peak residual over ``temperatures`` of a batch of networks.

    ``networks_at(T)`` gives ``(template, values)``: a network at ``T`` and the batch's part
    values there (rows in :meth:`Network.parts` order)."""
    worst = None
    for t in temperatures:
        template, values = networks_at(float(t))
        d, r, p = modal_form(*state_matrices(*template.batch_arrays(values)))
        dev = screening_deviation(model.at_temperature(float(t)), d, r, p)
        worst = dev if worst is None else np.maximum(worst, dev)
    return worst


def _drift_factors(network: Network, plan: PartsPlan, temperature: float) -> np.ndarray:
    """Each part's value at ``temperature`` relative to its catalogue value (fixed parts)."""
    return np.array([plan.value_at(label, kind, 1.0, temperature) for label, kind, _ in network.parts()])


def effective_sizing(model: CreepModel, temperatures, plan: PartsPlan | None = None,
                     rule: str = "exact", source_resistance: float = 0.0,
                     load_resistance: float | None = None) -> tuple[float, float]:
    """The model to size a fixed network for so that its worst peak residual creep over
    ``temperatures`` is smallest: the model at an *effective temperature* (°C), its amplitudes
    times a factor (a network that undercorrects a little balances the range's two ends).

    Golden-section search over the temperature with the amplitudes as they are, then both
    together (Nelder-Mead). A model without a temperature law gives its reference and 1.

    Returns
    -------
    temperature : float
    amplitude_factor : float
    """
    from scipy.optimize import minimize, minimize_scalar

    plan = plan or PartsPlan()
    temps = np.asarray(temperatures, dtype=float)
    if model.temperature is None or temps[-1] == temps[0]:
        return float(model.temperature.reference if model.temperature else temps[0]), 1.0
    lo, hi = float(temps[0]), float(temps[-1])

    def worst(t_eff: float, factor: float = 1.0) -> float:
        sensor = model.at_temperature(min(max(t_eff, lo), hi))
        sensor = sensor.with_terms(np.array(sensor.beta) * factor, sensor.tau)
        net = ideal_network(sensor, rule, 10e-6, source_resistance, load_resistance)
        values = np.array([[v for _, _, v in net.parts()]])
        return float(_screen_over(model, temps, lambda t: (
            network_over(net, plan, t), values * _drift_factors(net, plan, t)))[0])

    first = minimize_scalar(worst, bounds=(lo, hi), method="bounded", options={"xatol": 0.05})
    t0, f0 = float(first.x), float(first.fun)
    best = minimize(lambda x: worst(x[0], math.exp(x[1])), [t0, 0.0], method="Nelder-Mead",
                    options={"initial_simplex": [[t0, 0.0], [t0 + 2.0, 0.0], [t0, -0.1]],
                             "xatol": 1e-3, "fatol": 1e-7, "maxiter": 200})
    t_eff, factor = min(max(float(best.x[0]), lo), hi), math.exp(float(best.x[1]))
    return (t_eff, factor) if best.fun < f0 else (t0, 1.0)


def size_fixed_for_range(model: CreepModel, low: float, high: float, plan: PartsPlan | None = None,
                         rule: str = "exact", resistor_series: str = "E24", capacitor_series: str = "E6",
                         cap_range: tuple[float, float] = DEFAULT_CAP_RANGE,
                         res_range: tuple[float, float] = DEFAULT_RES_RANGE,
                         source_resistance: float = 0.0, load_resistance: float | None = None,
                         capacitance: float | None = None):
    """Fixed E-series parts whose worst peak residual creep over ``low .. high`` °C is smallest.

    The ideal network is sized for :func:`effective_sizing`; around it, at every capacitor
    value of the series in ``cap_range`` (or at ``capacitance`` only), the sizing's
    neighbouring series values of every other part are ranked by their worst case over the
    range (closed form), and the best few re-checked with the exact prediction.

    Returns
    -------
    network : Network
        The chosen parts (values at their catalogue temperature).
    effective : (float, float)
        The effective temperature (°C) and amplitude factor of the ideal network.
    candidates : int
        Part combinations ranked.
    """
    plan = plan or PartsPlan()
    grid = temperature_grid(low, high)
    t_eff, factor = effective_sizing(model, grid, plan, rule, source_resistance, load_resistance)
    sensor = model.at_temperature(t_eff)
    sensor = sensor.with_terms(np.array(sensor.beta) * factor, sensor.tau)
    series_of = {"R": resistor_series, "C": capacitor_series}
    screened, count = [], 0
    levels = [capacitance] if capacitance else [float(f"{c:.12g}") for c in
                                                 eseries.values_in_range(capacitor_series, *cap_range)]
    for c in levels:
        try:
            ideal = ideal_network(sensor, rule, c, source_resistance, load_resistance)
        except InputError:
            continue
        combos = np.array(_combinations(ideal, series_of, res_range, cap_range))
        if not len(combos):
            continue
        count += len(combos)
        scores = _screen_over(model, grid, lambda t: (network_over(ideal, plan, t),
                                                      combos * _drift_factors(ideal, plan, t)))
        screened.extend((float(scores[i]), ideal.with_parts(combos[i])) for i in np.argsort(scores)[:2])
    if not screened:
        raise InputError(f"no {resistor_series}/{capacitor_series} parts in the ranges given fit "
                         "the network over the temperature range (--cap-range, --res-range)")
    screened.sort(key=lambda x: x[0])
    best = min((net for _, net in screened[:TRACKING_RECHECKS]),
               key=lambda net: worst_case(model, net, plan, grid))
    return best, (t_eff, factor), count


@dataclass(frozen=True)
class TrackingDesign:
    """A network whose time-setting resistors are NTC thermistors.

    Attributes
    ----------
    network : Network
        The parts at their catalogue temperature (thermistors at their value there).
    plan : PartsPlan
        The same plan with the thermistors by label.
    worst : float
        Exact worst peak residual creep over the range.
    warnings : tuple of str
        What the designer must know (parts outside what is made).
    """

    network: Network
    plan: PartsPlan
    worst: float
    warnings: tuple[str, ...] = ()


def _use(part: Thermistor, series: float = 0.0, parallel_r: float | None = None) -> ThermistorUse:
    return ThermistorUse(part.part, part.r25, part.b, series, parallel_r, part.tolerance, part.b_tolerance)


def _shaping_values(r25: float, series: str) -> list[float]:
    """Fixed resistors tried with a thermistor: series values from R25 / 30 to 30 R25."""
    return [float(v) for v in eseries.values_in_range(series, r25 / 30.0, r25 * 30.0)]


def check_tracking(model: CreepModel, tracking: str, topology: str = "auto") -> None:
    """Refuse a tracking this module cannot size for ``model``, naming the way out: the
    passive lead network tracks one creep term, the active stage any number, both only
    positive creep."""
    if tracking not in ("none", "ntc"):
        raise InputError(f"--tracking {tracking!r}: expected none or ntc")
    if tracking != "ntc":
        return
    if any(b <= 0 for b in model.beta):
        raise InputError("--tracking ntc: sized for positive creep (every beta > 0); use fixed "
                         "parts or the digital correction")
    if topology == "passive" and model.n_terms != 1:
        raise InputError("--tracking ntc --topology passive: sized for one creep term (a one-cell "
                         "lead network); use --topology active, fixed parts or the digital correction")


def size_ntc_tracking(model: CreepModel, low: float, high: float, plan: PartsPlan | None = None,
                      resistor_series: str = "E24", capacitor_series: str = "E6",
                      thermistors=NTC_THERMISTORS, source_resistance: float = 0.0,
                      load_resistance: float | None = None) -> TrackingDesign:
    """A one-cell lead network whose ``R1`` and ``R2`` are catalogue NTC thermistors.

    ``R1 = R_s + NTC_a`` (a fixed resistor in series) sets the time constant ``R1 C1``, and
    ``R2 = NTC_b || R_p`` (a fixed resistor across) keeps ``R1 / R2`` near ``beta0`` as both
    follow temperature. Every pair of catalogue parts, the fixed resistors (none, or
    ``resistor_series`` values) and the capacitor values of ``capacitor_series`` around the
    one that matches the sensor mid-range are ranked by their worst peak residual over the
    range (closed form); the best few are re-checked exactly.

    Raises
    ------
    InputError
        For a model of several terms or of negative creep (no one-cell lead network).
    """
    check_tracking(model, "ntc", "passive")
    plan = plan or PartsPlan()
    grid = temperature_grid(low, high)
    beta, mid = model.beta[0], 0.5 * (low + high)
    tau_mid = model.at_temperature(mid).tau[0]
    cands = []                      # (part a, R_s, part b, R_p or inf, C1)
    shaping = {t.r25: _shaping_values(t.r25, resistor_series) for t in thermistors}
    cap_values = np.array([float(f"{c:.12g}")
                           for c in eseries.values_in_range(capacitor_series, 1e-12, 10.0)])
    for a, b in itertools.product(thermistors, repeat=2):
        for rs in [0.0] + shaping[a.r25]:
            r1 = rs + float(ntc_resistance(a.r25, a.b, mid))
            nb = float(ntc_resistance(b.r25, b.b, mid))
            for rp in [math.inf] + shaping[b.r25]:
                r2 = nb * rp / (nb + rp) if math.isfinite(rp) else nb
                if not 0.5 < r1 / (r2 * beta) < 2.0:
                    continue
                c_match = tau_mid * (1.0 + beta) / (1.0 + r1 / r2) / r1
                k = int(np.searchsorted(cap_values, c_match))
                cands.extend((a, rs, b, rp, c) for c in cap_values[max(k - 1, 0):k + 1])
    if not cands:
        raise InputError("--tracking ntc: no pair of catalogue thermistors gives R1/R2 near beta0")
    a_r25, a_b, rs, b_r25, b_b, rp, caps = (np.array(col, dtype=float) for col in zip(
        *[(a.r25, a.b, s, b.r25, b.b, p, c) for a, s, b, p, c in cands]))
    template = Network((Cell(1.0, 1.0),), 1.0, (), source_resistance, load_resistance)

    def batch(t: float):
        r1 = rs + ntc_resistance(a_r25, a_b, t)
        nb = ntc_resistance(b_r25, b_b, t)
        r2 = np.where(np.isfinite(rp), nb * rp / (nb + np.where(np.isfinite(rp), rp, 0.0)), nb)
        c1 = caps * (1.0 + plan.capacitor_tc * (t - PART_REFERENCE))
        return network_over(template, plan, t), np.stack([r1, c1, r2], axis=1)

    # the range's ends decide most designs: screen there first, then the whole grid
    ends = _screen_over(model, grid[[0, -1]], batch)
    keep = np.argsort(ends)[:TRACKING_SHORTLIST]
    a_r25, a_b, rs, b_r25, b_b, rp, caps = (x[keep] for x in (a_r25, a_b, rs, b_r25, b_b, rp, caps))
    scores = _screen_over(model, grid, batch)
    results = []
    for i in keep[np.argsort(scores)[:TRACKING_RECHECKS]]:
        a, s_r, b, p_r, c = cands[i]
        u1, u2 = _use(a, s_r), _use(b, 0.0, p_r if math.isfinite(p_r) else None)
        p = replace(plan, thermistors={"R1": u1, "R2": u2})
        net = Network((Cell(float(u1.resistance(PART_REFERENCE)), c),), float(u2.resistance(PART_REFERENCE)),
                      (), source_resistance, load_resistance)
        results.append((worst_case(model, net, p, grid), net, p))
    worst, net, p = min(results, key=lambda x: x[0])
    return TrackingDesign(net, p, worst, tuple(_tracking_warnings(net, p)))


def _tracking_warnings(network: Network, plan: PartsPlan) -> list[str]:
    dielectric = DIELECTRICS[plan.capacitor]
    lo, hi = dielectric.value_range
    out = []
    for label, kind, v in network.parts():
        if kind == "C" and not lo <= v <= hi:
            out.append(f"{label} = {format_quantity(v, 'F')} is outside what {dielectric.name} "
                       f"capacitors are made in ({format_quantity(lo, 'F')} to {format_quantity(hi, 'F')}): "
                       f"{math.ceil(v / hi)} parts of {format_quantity(hi, 'F')} in parallel. R2 = R1 / beta0 "
                       "must track with R1, and no catalogue NTC exceeds about 470 kΩ, so R1 C1 = tau "
                       "sets the capacitor")
    return out


@dataclass(frozen=True)
class RangeDesign:
    """One design compared over the range: its network, parts plan and prediction."""

    key: str
    label: str
    network: Network
    plan: PartsPlan
    prediction: OverTemperature
    warnings: tuple[str, ...] = ()

    def to_dict(self) -> dict:
        out = {k: v for k, v in self.network.to_dict().items()
               if k in ("cells", "R2", "shunt", "topology", "active")}
        out.update(label=self.label, parts=self.plan.to_dict(), worst=self.prediction.worst,
                   worst_at=self.prediction.worst_at, peak_residual=list(self.prediction.peak_residual),
                   warnings=list(self.warnings))
        return out


@dataclass(frozen=True)
class RangeComparison:
    """Designs over a temperature range: (a) fixed parts sized at the reference, (b) fixed parts
    sized for the range, (c) NTC tracking when asked; ``chosen`` names the one to write."""

    low: float
    high: float
    designs: tuple[RangeDesign, ...]
    chosen: str
    effective_temperature: float
    amplitude_factor: float
    candidates: int

    def design(self, key: str) -> RangeDesign:
        """The design of ``key`` (``reference``, ``range`` or ``ntc``)."""
        return next(d for d in self.designs if d.key == key)

    @property
    def written(self) -> RangeDesign:
        """The design to write."""
        return self.design(self.chosen)

    def to_dict(self) -> dict:
        """The comparison: every design's parts and figures, which one is written and why."""
        return {"range": [self.low, self.high], "chosen": self.chosen,
                "effective_temperature": self.effective_temperature,
                "amplitude_factor": self.amplitude_factor,
                "candidates_evaluated": self.candidates,
                "designs": {d.key: d.to_dict() for d in self.designs}}


def compare_over_range(model: CreepModel, reference: Network, low: float, high: float,
                       plan: PartsPlan | None = None, tracking: str = "none", rule: str = "exact",
                       resistor_series: str = "E24", capacitor_series: str = "E6",
                       res_range: tuple[float, float] = DEFAULT_RES_RANGE,
                       reference_warnings=(), topology: str = "auto") -> RangeComparison:
    """(a) ``reference`` (fixed parts sized at the model's reference temperature), (b) fixed
    parts sized for ``low .. high`` °C at the same capacitor, and with ``tracking="ntc"`` (c)
    thermistor tracking, each predicted over the range: the passive lead network
    (``topology`` ``passive``), the active stage (:mod:`creepcomp.analog.active`, ``active``),
    or both with the passive one written when it is practical (``auto``).

    Raises
    ------
    InputError
        For a tracking other than ``none`` or ``ntc``, a topology not in :data:`TOPOLOGIES`.
    """
    if topology not in TOPOLOGIES:
        raise InputError(f"--topology {topology!r}: expected {', '.join(TOPOLOGIES)}")
    check_tracking(model, tracking, topology)
    plan = plan or PartsPlan()
    # near the reference's impedance level: two capacitor values either side of its own
    c_ref = max(v for _, k, v in reference.parts() if k == "C")
    levels = eseries.neighbours(c_ref, capacitor_series, 2)
    fixed, (t_eff, factor), count = size_fixed_for_range(
        model, low, high, plan, rule, resistor_series, capacitor_series,
        cap_range=(float(min(levels)), float(max(levels))), res_range=res_range,
        source_resistance=reference.source_resistance, load_resistance=reference.load_resistance)
    designs = [RangeDesign("reference", "(a) fixed parts sized at the reference", reference, plan,
                           over_temperature(model, reference, plan, low, high), tuple(reference_warnings)),
               RangeDesign("range", "(b) fixed parts sized for the range "
                           + (f"({t_eff:.1f} °C, {factor:.2f} beta)" if model.temperature is not None
                              else "(the parts' drift only)"), fixed, plan,
                           over_temperature(model, fixed, plan, low, high))]
    chosen = "range"
    if tracking == "ntc":
        chosen = _add_tracking(designs, model, low, high, plan, topology, resistor_series,
                               capacitor_series, reference)
    return RangeComparison(low, high, tuple(designs), chosen, t_eff, factor, count)


#: How ``--tracking ntc`` is built: ``auto`` writes the passive lead network when it is
#: practical, else the active stage.
TOPOLOGIES = ("auto", "passive", "active")


def _add_tracking(designs: list, model: CreepModel, low: float, high: float, plan: PartsPlan,
                  topology: str, resistor_series: str, capacitor_series: str, reference: Network) -> str:
    """Append the NTC tracking designs ``topology`` asks for; return the key to write."""
    from creepcomp.analog.active import size_active_tracking

    practical = None
    if topology == "passive" or (topology == "auto" and model.n_terms == 1):
        ntc = size_ntc_tracking(model, low, high, plan, resistor_series, capacitor_series,
                                source_resistance=reference.source_resistance,
                                load_resistance=reference.load_resistance)
        designs.append(RangeDesign("ntc", "(c-passive) NTC thermistor tracking, passive lead network",
                                   ntc.network, ntc.plan,
                                   over_temperature(model, ntc.network, ntc.plan, low, high), ntc.warnings))
        if topology == "passive":
            return "ntc"
        from creepcomp.analog.practicality import judge_network

        practical = judge_network(model, ntc.network, ntc.plan).practical
    try:
        stage, stage_plan, _ = size_active_tracking(model, low, high, plan, resistor_series,
                                                    capacitor_series,
                                                    source_resistance=reference.source_resistance,
                                                    load_resistance=reference.load_resistance)
    except InputError:
        if practical is None:
            raise
        return "ntc"           # the passive network is written; the verdict judges it
    why = "" if practical is None else " (the passive one is impractical)" if not practical else ""
    designs.append(RangeDesign("active", "(c) NTC thermistor tracking, active stage" + why,
                               stage, stage_plan, over_temperature(model, stage, stage_plan, low, high)))
    return "ntc" if practical else "active"
