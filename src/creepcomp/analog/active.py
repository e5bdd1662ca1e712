"""The active correction stage: the inverse of the creep built from integrators and fixed gains.

The lead network's ``H = 1 / G`` written as partial fractions (every pole real, every
amplitude positive for a sensor of positive creep)::

    1 / G(s) = 1 - sum_j c_j / (1 + s p_j)

is built *actively*: the input minus ``c_j`` times a low-pass of it, for each ``j``. Only the
low-pass time constants ``p_j`` must follow the material (all of them scale by ``a_T`` when
every ``tau_k`` does); the amplitudes ``c_j`` are ratios of fixed resistors. So one NTC
thermistor per term tracks the creep, and no resistor needs to be ``1 / beta0`` times a
thermistor, which is what forces millifarad capacitors on the passive tracking network.

The circuit is :class:`creepcomp.active_stage.ActiveStage`'s. Node ``e_j`` divides ``in + w_j`` by ``alpha_j = 1 / (2 + RA_j / RG_j)`` (``RA_j = RB_j``),
so the integrator loop is a low-pass of ``in`` (``w_j = -LP_j(in)``, DC gain ``RB_j /
RA_j``) with time constant ``p_j = C_j (RT_j / alpha_j + RA_j)``: the divider lets a 10 uF
film capacitor and a catalogue thermistor reach tens of seconds. The output is
``(in / RS0 + sum w_j / RS_j) / (1 / RS0 + sum 1 / RS_j)``, so ``c_j = RS0 / RS_j``.

Here: the sizing (exact at the reference, :func:`ideal_active`; with catalogue thermistors
over a range, :func:`size_active_tracking`), the stage at a temperature
(:func:`stage_over`), the op amps it needs (:data:`OP_AMP`) and the offset they give.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from creepcomp.analog import eseries
from creepcomp.analog.parts import (DIELECTRICS, NTC_THERMISTORS, PART_REFERENCE, PartsPlan,
                                    ThermistorUse, network_at)
from creepcomp.analog.quality import screening_deviation, step_peak
from creepcomp.errors import InputError
from creepcomp.active_stage import ActiveStage, ActiveTerm
from creepcomp.model import CreepModel
from creepcomp.temperature import temperature_grid
from creepcomp.units import format_quantity

__all__ = ["OpAmpRequirement", "OP_AMP", "inverse_lags",
           "ideal_active", "stage_over", "output_offset", "lag_batch", "size_active_tracking",
           "ACTIVE_CAP_RANGE", "DIVIDER_RESISTANCE", "SUM_RESISTANCE_RANGE", "ALPHA_RANGE"]

#: Integrator capacitors searched (F): film capacitors that are stocked, not special builds.
ACTIVE_CAP_RANGE = (1e-6, 10e-6)
#: The divider's resistors from the input and from the integrator's output (ohm).
DIVIDER_RESISTANCE = 100e3
#: The output summer's resistor from the input is searched in this range (ohm).
SUM_RESISTANCE_RANGE = (10e3, 100e3)
#: Divider ratios allowed: below the lower end the op amp's offset is amplified too much.
ALPHA_RANGE = (0.02, 0.45)


@dataclass(frozen=True)
class OpAmpRequirement:
    """What the stage's op amps must do (one per term and the output follower).

    The integrator's input bias current flows through the thermistor network (megohms
    when cold) and its offset is divided by ``alpha``: both give a constant output offset
    (:func:`output_offset`), removed by taring, not creep; they matter only as zero drift.
    """

    input_type: str = "CMOS or JFET input"
    bias_current: float = 10e-12
    offset: float = 100e-6
    examples: str = ("a JFET-input precision op amp (OPA140 class) or a zero-drift CMOS one "
                     "(AD8628 class); check the datasheet over the temperature range")

    def text(self) -> str:
        """One line for the BOM and the verdict."""
        return (f"{self.input_type}, input bias current at most "
                f"{format_quantity(self.bias_current, 'A')} over the range, offset at most "
                f"{format_quantity(self.offset, 'V')}; e.g. {self.examples}")

    def to_dict(self) -> dict:
        return {"input": self.input_type, "bias_current": self.bias_current,
                "offset": self.offset, "examples": self.examples}


#: The op amps the stage is designed and judged for.
OP_AMP = OpAmpRequirement()


def inverse_lags(model: CreepModel) -> tuple[float, np.ndarray, np.ndarray]:
    """``1 / G(s) = k_inf - sum_j c_j / (1 + s p_j)``: ``k_inf``, ``c_j``, ``p_j`` (s).

    Raises
    ------
    InputError
        When some ``c_j`` is not positive (creep that overshoots): the stage subtracts
        low-passes, it cannot add them.
    """
    A, B, C, D = model.lag_expansion().matrices()
    d = float(D[0, 0])
    Ai = A - B @ C / d
    lam, V = np.linalg.eig(Ai)
    lam, V = lam.real, V.real
    left = (-C / d) @ V
    right = np.linalg.solve(V, B / d)
    p = -1.0 / lam
    c = -(left[0] * right[:, 0] * p)
    order = np.argsort(p)
    c, p = c[order], p[order]
    if np.any(c <= 0):
        raise InputError("the active stage is sized for positive creep (every beta > 0): use the "
                         "lag network or the digital correction")
    return 1.0 / d, c, p


def _alpha_divider(alpha: float, ra: float = DIVIDER_RESISTANCE) -> float:
    """``RG`` for the divider ratio ``alpha`` with ``RA = RB = ra``."""
    return ra / (1.0 / alpha - 2.0)


def ideal_active(model: CreepModel, capacitance: float = 10e-6, alpha: float = 0.1,
                 rs0: float = 10e3, source_resistance: float = 0.0,
                 load_resistance: float | None = None) -> ActiveStage:
    """The active stage with ideal values, exact at the model's reference temperature.

    Each term's ``RT`` gives ``p_j`` with ``C = capacitance`` and divider ratio ``alpha``;
    ``RS_j = RS0 / c_j``. With a source resistance the stage has an input follower.
    """
    _, c, p = inverse_lags(model)
    rg = _alpha_divider(alpha)
    terms = []
    for cj, pj in zip(c, p):
        rt = alpha * (pj / capacitance - DIVIDER_RESISTANCE)
        if rt <= 0:
            raise InputError(f"active stage: a {format_quantity(pj, 's')} pole needs a capacitor "
                             f"above {format_quantity(pj / DIVIDER_RESISTANCE, 'F')}")
        terms.append(ActiveTerm(rt, capacitance, DIVIDER_RESISTANCE, DIVIDER_RESISTANCE, rg, rs0 / cj))
    return ActiveStage(tuple(terms), rs0, source_resistance, load_resistance, source_resistance > 0)


def stage_over(stage: ActiveStage, plan: PartsPlan, temperature: float) -> ActiveStage:
    """The stage at ``temperature`` (°C): every part's value (:func:`network_at`: TCs,
    thermistors) and each capacitor's insulation resistance ``R_ins C / C`` across it."""
    at = network_at(stage, plan, temperature)
    tau_ins = DIELECTRICS[plan.capacitor].insulation_time(temperature)
    return at.with_leakage([tau_ins / t.C for t in at.terms])


def output_offset(stage: ActiveStage, plan: PartsPlan, temperature: float,
                  op_amp: OpAmpRequirement = OP_AMP) -> float:
    """The largest constant output offset (V) op amps at the requirement's limits give at
    ``temperature``: each integrator's offset and bias current through its ``RT`` network and
    divider (``w = RB G_e (V_os + I_b RT) + RB I_b``), weighted by the summer, plus the
    follower's own offset and bias current through the summer's resistance (and an input
    follower's, with its bias current through the source resistance)."""
    at = network_at(stage, plan, temperature)
    g_out = 1.0 / at.RS0 + sum(1.0 / t.RS for t in at.terms)
    total = op_amp.offset + op_amp.bias_current / g_out
    if at.input_buffer:
        total += op_amp.offset + op_amp.bias_current * at.source_resistance
    for t in at.terms:
        ge = 1.0 / t.RA + 1.0 / t.RB + 1.0 / t.RG
        w = t.RB * ge * (op_amp.offset + op_amp.bias_current * t.RT) + t.RB * op_amp.bias_current
        total += w / t.RS / g_out
    return float(total)


def lag_batch(rt, c, ra, rb, rg, rs, rs0, leakage=None):
    """Sum-of-lags arrays of many one-term stages at once, fed without source resistance.

    All arguments are arrays of shape (B,) (``leakage`` None: none). This is the closed form
    of :meth:`ActiveStage.matrices` for one term and a zero source resistance (a test holds
    the two together), for screening many candidates.

    Returns
    -------
    direct : (B,), gains : (B, 1), taus : (B, 1)
    """
    ge = 1.0 / ra + 1.0 / rb + 1.0 / rg
    k = 1.0 + rt * ge                                   # w' = -(x/RA + w/RB) / (C k) - w / (R_l C)
    rate = 1.0 / (rb * c * k) + (0.0 if leakage is None else 1.0 / (leakage * c))
    tau = 1.0 / rate
    dc = (1.0 / (ra * c * k)) * tau                     # |w / x| at DC
    g_out = 1.0 / rs0 + 1.0 / rs
    direct = (1.0 / rs0) / g_out
    gain = -(1.0 / rs) / g_out * dc
    return direct, gain[:, None], tau[:, None]


def _sum_resistors(c, series: str) -> tuple[float, list[float]]:
    """``RS0`` of ``series`` in :data:`SUM_RESISTANCE_RANGE` and the ``RS_j`` of ``series``
    with ``RS0 / RS_j`` nearest to each ``c_j``: the ``RS0`` whose largest ratio error is least."""
    best = None
    for r0 in eseries.values_in_range(series, *SUM_RESISTANCE_RANGE):
        r0 = float(f"{r0:.12g}")
        rs, worst = [], 0.0
        for cj in c:
            r = min((float(f"{float(v):.12g}") for v in eseries.neighbours(r0 / cj, series, 1)),
                    key=lambda v: abs(math.log(r0 / v / cj)))
            rs.append(r)
            worst = max(worst, abs(math.log(r0 / r / cj)))
        if best is None or worst < best[0]:
            best = (worst, r0, rs)
    return best[1], best[2]


def _shapes(thermistors, series: str):
    """Every thermistor with no, or a ``series`` value of, fixed resistor in series and across
    (``R25 / 30`` to ``30 R25``)."""
    out = []
    for th in thermistors:
        fixed = [float(f"{v:.12g}") for v in eseries.values_in_range(series, th.r25 / 30, th.r25 * 30)]
        for s in [0.0] + fixed:
            for p in [math.inf] + fixed:
                out.append((th, s, p))
    return out


def _shape_resistances(shapes, grid) -> np.ndarray:
    """``(series + R_ntc(T)) || parallel`` of every shape at every temperature, shape (S, T):
    :meth:`ThermistorUse.resistance`, for many shapes at once."""
    parts = {th.part: th for th, _, _ in shapes}
    law = {name: np.asarray(_use(th, 0.0, math.inf).resistance(grid)) for name, th in parts.items()}
    r = np.array([law[th.part] for th, _, _ in shapes]) + np.array([s for _, s, _ in shapes])[:, None]
    par = np.array([q for _, _, q in shapes])[:, None]
    return np.where(np.isinf(par), r, r * par / (r + np.where(np.isinf(par), 0.0, par)))


def _use(th, series: float, par: float) -> ThermistorUse:
    return ThermistorUse(th.part, th.r25, th.b, series, None if math.isinf(par) else par,
                         th.tolerance, th.b_tolerance)


#: Thermistor shapes kept per term after the tracking screen.
SHAPE_SHORTLIST = 40


def size_active_tracking(model: CreepModel, low: float, high: float, plan: PartsPlan | None = None,
                         resistor_series: str = "E24", capacitor_series: str = "E6",
                         thermistors=NTC_THERMISTORS, cap_range=ACTIVE_CAP_RANGE,
                         source_resistance: float = 0.0, load_resistance: float | None = None,
                         rechecks: int = 6):
    """An active stage whose time-setting resistors are catalogue NTC thermistors.

    For each pole ``p_j`` of ``1 / G`` (all scale by ``a_T``): every thermistor shape (a
    catalogue part, no or a fixed resistor in series, no or one across) is ranked by how
    far ``RT(T) C(T)`` strays from following ``a_T`` over the range (the spread of
    ``ln(RT C / a_T)``: its level is set later); for the best shapes, every capacitor of
    ``capacitor_series`` in ``cap_range`` gives the divider ratio that centres the stray on
    ``p_j a_T``, snapped to a ``resistor_series`` ``RG``; the summer's ``RS0 / RS_j`` are the
    ``resistor_series`` values nearest to ``c_j``. Candidates are ranked by their worst peak
    residual over the range (closed form for one term; each term's own stray for several)
    and the best few re-checked with the exact prediction. A source resistance gets an
    input follower.

    Returns
    -------
    stage : ActiveStage
        Part values at 25 °C (thermistor networks at their value there).
    plan : PartsPlan
        ``plan`` with the thermistors by label (``RT1`` ...).
    worst : float
        Exact worst peak residual creep over the range.
    """
    if model.temperature is None:
        raise InputError("--tracking ntc: the model has no temperature law (give "
                         "--activation-energy or a model file with a 'temperature' block)")
    plan = plan or PartsPlan()
    _, c, p = inverse_lags(model)
    grid = temperature_grid(low, high)
    shift = model.temperature.shift(grid)
    cap_drift = np.array([plan.value_at("C", "C", 1.0, float(t)) for t in grid])
    shapes = _shapes(thermistors, resistor_series)
    r_t = _shape_resistances(shapes, grid)
    stray = np.log(r_t * cap_drift / shift)
    spread = stray.max(axis=1) - stray.min(axis=1)
    keep = np.argsort(spread)[:SHAPE_SHORTLIST]
    caps = [float(f"{v:.12g}") for v in eseries.values_in_range(capacitor_series, *cap_range)]
    ra = DIVIDER_RESISTANCE
    rs0, rs_all = _sum_resistors(c, resistor_series)
    per_term = []
    for cj, pj, rsj in zip(c, p, rs_all):
        cands = []
        for i in keep:
            # RT/alpha + RA ~ p_j a_T / C at the stray's centre (geometric mean of its ends)
            centre = math.exp(0.5 * (stray[i].max() + stray[i].min()))  # RT / a_T there
            for cap in caps:
                alpha = centre * cap / (pj - ra * cap)
                if not ALPHA_RANGE[0] <= alpha <= ALPHA_RANGE[1]:
                    continue
                for rg in eseries.neighbours(_alpha_divider(alpha, ra), resistor_series, 1):
                    cands.append((i, cap, float(f"{float(rg):.12g}"), rs0, rsj))
        if not cands:
            raise InputError("--tracking ntc: no catalogue thermistor and capacitor in "
                             f"{format_quantity(cap_range[0], 'F')} .. {format_quantity(cap_range[1], 'F')} "
                             f"reach the {format_quantity(pj, 's')} time constant")
        per_term.append(cands)
    if len(per_term) > 1:
        # several poles: each term's best candidate by its own stray, then checked together
        chosen = [min(cands, key=lambda x: _term_stray(x, shapes, r_t, cap_drift, shift, pj, ra))
                  for cands, pj in zip(per_term, p)]
        combos = [tuple(chosen)]
    else:
        cands = per_term[0]
        scores = _screen_batch(model, grid, _one_term_batch(cands, r_t, cap_drift, plan, grid, ra))
        combos = [(cands[i],) for i in np.argsort(scores)[:rechecks]]
    results = []
    for combo in combos:
        uses, terms = {}, []
        for j, (i, cap, rg, _, rsj) in enumerate(combo, 1):
            th, s, q = shapes[i]
            use = _use(th, s, q)
            uses[f"RT{j}"] = use
            terms.append(ActiveTerm(float(use.resistance(PART_REFERENCE)), cap, ra, ra, rg, rsj))
        stage = ActiveStage(tuple(terms), rs0, source_resistance, load_resistance,
                            source_resistance > 0)
        pl = replace(plan, thermistors=uses)
        worst = max(step_peak(model.at_temperature(float(t)), stage_over(stage, pl, float(t)))[0]
                    for t in grid)
        results.append((worst, stage, pl))
    worst, stage, pl = min(results, key=lambda x: x[0])
    return stage, pl, worst


def _screen_batch(model: CreepModel, temperatures, lags_at) -> np.ndarray:
    """Worst closed-form peak residual over ``temperatures`` of a batch of designs given as
    sum-of-lags arrays: ``lags_at(k)`` gives ``(direct, gains, taus)`` at ``temperatures[k]``."""
    worst = None
    for k, t in enumerate(temperatures):
        dev = screening_deviation(model.at_temperature(float(t)), *lags_at(k))
        worst = dev if worst is None else np.maximum(worst, dev)
    return worst


def _term_stray(cand, shapes, r_t, cap_drift, shift, pj, ra) -> float:
    i, cap, rg, _, _ = cand
    alpha = 1.0 / (2.0 + ra / rg)
    tau = cap * cap_drift * (r_t[i] / alpha + ra)
    return float(np.abs(np.log(tau / (pj * shift))).max())


def _one_term_batch(cands, r_t, cap_drift, plan: PartsPlan, grid, ra):
    """``networks_at(T)`` for :func:`_screen_batch`: lag arrays of one-term candidates at T."""
    idx = np.array([x[0] for x in cands])
    cap = np.array([x[1] for x in cands])
    rg = np.array([x[2] for x in cands])
    rs0 = np.array([x[3] for x in cands])
    rs = np.array([x[4] for x in cands])
    diel = DIELECTRICS[plan.capacitor]

    def at(k: int):
        t = float(grid[k])
        fixed = plan.value_at("R", "R", 1.0, t)
        c_t = cap * cap_drift[k]
        return lag_batch(r_t[idx, k], c_t, ra * fixed, ra * fixed, rg * fixed, rs * fixed,
                         rs0 * fixed, diel.insulation_time(t) / c_t)

    return at
