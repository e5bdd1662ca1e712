"""Variants of a design drawn from its tolerance box, and their metrics, all at once.

The networks' sum-of-lags forms come from the one state-space model
(:func:`network.state_matrices`, batched symmetric eigensolver), the cascade with the
sensor's creep is again a sum of lags (:func:`lti.cascade_lags`), and its step response and
sweep hysteresis are closed forms (:func:`lti.triangle_lag_gap`). No Python loop per sample.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Mapping

import numpy as np

from creepcomp.analog.parts import PART_REFERENCE
from creepcomp.analog.quality import default_sweep_period
from creepcomp.io.jsonfiles import Design
from creepcomp.lti import cascade_lags, triangle_lag_gap
from creepcomp.model import CreepModel
from creepcomp.network import Branch, Cell, Network, modal_form, state_matrices
from creepcomp.verify.tolerances import ABSORPTION_TAU_RANGE, DIELECTRICS, Dielectric, OverTemperature

__all__ = ["Metrics", "STEP_GRID", "SWEEP_GRID", "sweep_period_or_default", "evaluate",
           "residual_lags", "variant_arrays", "variant", "step_residual"]


@dataclass(frozen=True)
class Metrics:
    """Per-sample figures: peak and final residual creep of a load step, sweep hysteresis.

    Over temperature they are each sample's worst over the temperatures (``final``: the one
    of largest magnitude), and ``per_temperature`` holds the figures at each, shape
    ``(n, temperatures)``.
    """

    peak: np.ndarray
    final: np.ndarray
    hysteresis: np.ndarray
    per_temperature: "Metrics | None" = None

    def get(self, name: str) -> np.ndarray:
        """A metric by name: ``peak``, ``final`` (absolute value) or ``hysteresis``."""
        if name == "final":
            return np.abs(self.final)
        return getattr(self, name)


#: Times of the step-response grid, as multiples of each sample's slowest time constant.
STEP_GRID = np.geomspace(1e-3, 30.0, 28)
#: Positions along the first half of the rising sweep branch (the gap is symmetric).
SWEEP_GRID = np.linspace(0.0, 0.5, 17)


def sweep_period_or_default(model: CreepModel, sweep_period: float | None) -> float:
    """The hysteresis sweep period asked for, or the model's default (s)."""
    return default_sweep_period(model) if sweep_period is None else float(sweep_period)


def evaluate(design: Design, values: Mapping[str, np.ndarray], sweep_period: float,
             dielectric: str | None = None, temperature: float = 25.0,
             n: int | None = None, over: OverTemperature | None = None) -> Metrics:
    """Metrics of many variants of a design at once.

    Parameters
    ----------
    design : Design
        Nominal design.
    values : mapping
        Factor name -> values (all the same length); factors not given stay nominal.
    sweep_period : float
        Period of the hysteresis sweep (s).
    dielectric : str or None
        Dielectric preset for leakage (absorption comes through ``values``).
    temperature : float
        For the leakage (degrees C).
    n : int, optional
        Number of variants when ``values`` is empty (default 1).
    over : OverTemperature, optional
        Evaluate every variant at each temperature, all in one batch (``temperature`` is then
        not used); the metrics are each variant's worst.

    Returns
    -------
    Metrics
    """
    n = len(next(iter(values.values()))) if values else (n or 1)
    rel, q = residual_lags(design, values, dielectric, temperature, n, over)
    final = rel.sum(axis=1)
    peak = np.maximum(_in_blocks(_step_peak, rel, q), np.abs(final))
    hysteresis = _in_blocks(_sweep_peak, rel, q, sweep_period)
    if over is None:
        return Metrics(peak, final, hysteresis)
    shape = (len(over.temperatures), n)
    peak, final, hysteresis = (a.reshape(shape).T for a in (peak, final, hysteresis))
    rows = np.arange(n)
    return Metrics(peak.max(axis=1), final[rows, np.argmax(np.abs(final), axis=1)],
                   hysteresis.max(axis=1), Metrics(peak, final, hysteresis))


def residual_lags(design: Design, values: Mapping[str, np.ndarray], dielectric: str | None,
                  temperature: float, n: int,
                  over: OverTemperature | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Residual-creep form of the corrected sensor of every variant: ``H G / (H G)(inf) - 1
    = sum_m rel_m (1 - 1/(1 + s q_m))``, as arrays ``rel`` and ``q`` of shape (n, M);
    ``over`` temperatures: shape (temperatures * n, M), temperature by temperature."""
    arrays, beta, tau = variant_arrays(design, values, dielectric, temperature, n, over)
    d, r, p = modal_form(*state_matrices(*arrays))
    D, R, q = cascade_lags(np.ones(len(beta)), beta, tau, d, r, p)
    return R / D[:, None], q


def variant_arrays(design: Design, values: Mapping[str, np.ndarray], dielectric: str | None,
                   temperature: float, n: int, over: OverTemperature | None = None):
    """Network arrays (for :func:`network.state_matrices`) and creep terms of variants;
    ``over`` temperatures: every variant at each, stacked temperature by temperature."""
    net, model = design.network, design.model
    parts = net.parts()
    matrix = np.column_stack([values.get(label, np.full(n, v)) for label, _, v in parts])
    beta = np.column_stack([values.get(f"beta[{k}]", np.full(n, b)) for k, b in enumerate(model.beta)])
    tau = np.column_stack([values.get(f"tau[{k}]", np.full(n, t)) for k, t in enumerate(model.tau)])
    temps = np.array([temperature])
    if over is not None:
        temps = np.array(over.temperatures)
        matrix = _parts_at(parts, matrix, values, over, temps)
        values = {k: np.tile(v, len(temps)) for k, v in values.items()}
        beta, tau = _creep_at(model, beta, tau, temps)
    arrays = list(net.batch_arrays(matrix))
    if "source_resistance" in values:
        arrays[5] = values["source_resistance"]
    if "load_resistance" in values:
        arrays[6] = values["load_resistance"]
    if dielectric is not None:
        arrays[7:10] = _imperfections(net, parts, matrix, values, DIELECTRICS[dielectric],
                                      np.repeat(temps, n))
    return arrays, beta, tau


def _parts_at(parts, matrix, values, over: OverTemperature, temps) -> np.ndarray:
    """Part values of every variant at each temperature, shape (temperatures * n, parts):
    fixed parts by their (drawn) TC about 25 °C, thermistors from their (drawn) R25 and B."""
    n = len(matrix)
    plan = over.plan
    dt = (temps - PART_REFERENCE)[:, None]                          # (T, 1)
    out = np.empty((len(temps), n, len(parts)))
    for j, (label, kind, _) in enumerate(parts):
        use = plan.thermistors.get(label)
        if use is None:
            default = plan.resistor_tc if kind == "R" else plan.capacitor_tc
            tc = values.get(f"{label}.tc", np.full(n, default))
            out[:, :, j] = matrix[:, j] * (1.0 + tc * dt)
            continue
        drawn = replace(use, r25=values.get(f"{label}.R25", np.full(n, use.r25)),
                        b=values.get(f"{label}.B", np.full(n, use.b)))
        out[:, :, j] = drawn.resistance(temps[:, None])
    return out.reshape(-1, len(parts))


def _creep_at(model: CreepModel, beta, tau, temps):
    """Creep terms of every variant at each temperature (the model's law), stacked."""
    law = model.temperature
    if law is None:
        return np.tile(beta, (len(temps), 1)), np.tile(tau, (len(temps), 1))
    shift = law.shift(temps)[:, None, None]                         # (T, 1, 1)
    factor = law.beta_factor(temps, model.n_terms)[:, None, :]     # (T, 1, K)
    k = beta.shape[1]
    return (beta[None] * factor).reshape(-1, k), (tau[None] * shift).reshape(-1, k)


def variant(design: Design, values: Mapping[str, np.ndarray], i: int, dielectric: str | None = None,
            temperature: float = 25.0, over: OverTemperature | None = None) -> Design:
    """Sample ``i`` of drawn values as a design of its own (network and creep model); with
    ``over`` of one temperature, the sample at that temperature (its model has no law)."""
    if over is not None and len(over.temperatures) != 1:
        raise ValueError("a variant is at one temperature")
    one = {k: v[i:i + 1] for k, v in values.items()}
    arrays, beta, tau = variant_arrays(design, one, dielectric, temperature, 1, over)
    cells_R, cells_C, R2, shunt_R, shunt_C, rs, rl, leak, r_da, c_da = (
        a[0] if np.ndim(a) else a for a in arrays)
    cells = tuple(Cell(float(r), float(c), None if not np.isfinite(lk) else float(lk),
                       None if cd <= 0 else float(rd), None if cd <= 0 else float(cd))
                  for r, c, lk, rd, cd in zip(cells_R, cells_C, leak, r_da, c_da))
    shunt = tuple(Branch(float(r), float(c)) for r, c in zip(shunt_R, shunt_C))
    network = Network(cells, None if not np.isfinite(R2) else float(R2), shunt, float(rs),
                      None if rl is None or not np.isfinite(rl) else float(rl))
    model = design.model if over is None else design.model.at_temperature(over.temperatures[0])
    return Design(model.with_terms(beta[0], tau[0]), network)


#: Values (variants x lags x grid points) one block of the closed-form metrics holds at once
#: (8 bytes each; a few arrays of that size are alive together).
BLOCK_VALUES = 2_000_000


def _in_blocks(metric, rel, q, *args) -> np.ndarray:
    """``metric(rel, q, *args)`` over blocks of variants (rows), so that its arrays stay within
    :data:`BLOCK_VALUES` values however many lags (cells and creep terms) a design has."""
    grid = max(len(STEP_GRID), len(SWEEP_GRID))
    rows = max(1, BLOCK_VALUES // (max(1, q.shape[1]) * grid))
    if len(q) <= rows:
        return metric(rel, q, *args)
    return np.concatenate([metric(rel[i:i + rows], q[i:i + rows], *args)
                           for i in range(0, len(q), rows)])


def step_residual(rel, q, t, rise: float = 0.0) -> np.ndarray:
    """Residual creep ``sum_m rel_m (1 - exp(-t / q_m))`` at per-sample times ``t`` (B, T).

    Written as ``sum rel - sum rel exp(-t/q)``: the cancellation at small t costs only
    ~1e-16 of the (small) residual itself. With ``rise`` > 0 the step is a ramp of that
    duration (as in a netlist), exact for ``t >= rise``: each lag's ``exp(-t/q)`` becomes
    ``(q / rise) (1 - exp(-rise/q)) exp(-(t - rise)/q)``.
    """
    rate = 1.0 / q
    if rise > 0:
        decay = np.exp(-(rate[:, :, None] * (t[:, None, :] - rise)))
        decay = decay * (-np.expm1(-rise * rate) / (rise * rate))[:, :, None]
    else:
        decay = np.exp(-(rate[:, :, None] * t[:, None, :]))
    return rel.sum(axis=1)[:, None] - np.einsum("bm,bmt->bt", rel, decay)


def _step_peak(rel, q):
    """Peak |residual creep| after a step.

    Two lags (one creep term, one network pole): the single extremum in closed form.
    More: a log grid, then the root of ``e'(t)`` between the grid neighbours of its largest
    value (safeguarded Newton: a flat peak barely above the settled value needs it).
    """
    if q.shape[1] == 2:
        return _step_peak_two_lags(rel, q)
    slowest = q.max(axis=1)
    log_t = np.log(slowest)[:, None] + np.log(STEP_GRID)[None, :]
    v = np.abs(step_residual(rel, q, np.exp(log_t)))
    k = np.argmax(v, axis=1)
    rows = np.arange(len(v))
    a = np.exp(log_t[rows, np.maximum(k - 1, 0)])
    b = np.exp(log_t[rows, np.minimum(k + 1, v.shape[1] - 1)])
    sign = np.sign(step_residual(rel, q, np.exp(log_t[rows, k])[:, None])[:, 0])
    return np.maximum(v[rows, k], _bracketed_peak(rel, q, a, b, sign))


def _bracketed_peak(rel, q, a, b, sign, steps: int = 12) -> np.ndarray:
    """``|e|`` at the root of ``e'`` in ``[a, b]`` (0 where ``sign * e'`` does not fall from
    positive to negative there): Newton steps inside the bracket, bisection (in log t) outside."""
    slope = sign[:, None] * rel / q

    def derivatives(t):
        decay = np.exp(-t[:, None] / q)
        return np.sum(slope * decay, axis=1), -np.sum(slope / q * decay, axis=1)

    valid = (derivatives(a)[0] > 0) & (derivatives(b)[0] < 0)
    t = np.sqrt(a * b)
    for _ in range(steps):
        first, second = derivatives(t)
        a, b = np.where(first > 0, t, a), np.where(first > 0, b, t)
        with np.errstate(divide="ignore", invalid="ignore"):
            newton = t - first / second
        t = np.where((second < 0) & (newton > a) & (newton < b), newton, np.sqrt(a * b))
    value = np.abs(step_residual(rel, q, t[:, None])[:, 0])
    return np.where(valid & np.isfinite(value), value, 0.0)


def _step_peak_two_lags(rel, q):
    """``e(t) = sum_m rel_m (1 - exp(-t/q_m))`` for two lags has one extremum, where
    ``rel_1/q_1 exp(-t/q_1) = -rel_2/q_2 exp(-t/q_2)``."""
    slope1, slope2 = rel[:, 0] / q[:, 0], rel[:, 1] / q[:, 1]
    rate_gap = 1.0 / q[:, 0] - 1.0 / q[:, 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = -slope2 / slope1
        t_star = -np.log(ratio) / rate_gap
    ok = (ratio > 0) & np.isfinite(t_star) & (t_star > 0)
    t_star = np.where(ok, t_star, 0.0)
    inner = np.abs(step_residual(rel, q, t_star[:, None])[:, 0])
    return np.where(ok, inner, 0.0)


def _sweep_peak(rel, q, period):
    """Largest |up - down| gap of the sweep (fraction of the ideal output).

    The gap is symmetric about the middle of the branch, so half of it is evaluated, on a
    uniform grid where ``exp(-t/q)`` are powers of one exponential (products, no overflow),
    then refined by a parabola.
    """
    h = period / 2.0
    x = SWEEP_GRID
    qq = q[:, :, None]
    powers = np.cumprod(np.broadcast_to(np.exp(-(x[1] - x[0]) * h / qq), q.shape + (len(x) - 1,)), axis=2)
    early = np.concatenate([np.ones(q.shape + (1,)), powers], axis=2)       # exp(-t_j/q)
    late = early[:, :, -1:] * early[:, :, ::-1]                              # exp(-(h-t_j)/q)
    gap = np.abs(np.einsum("bm,bmx->bx", rel, triangle_lag_gap(qq, h, x, (early, late))))
    best, at = _grid_peak(gap, np.broadcast_to(x, gap.shape))
    pts = np.clip(at[:, None] + (x[1] - x[0]) / 4 * np.array([-1.0, 0.0, 1.0])[None, :], 0.0, 0.5)
    vals = np.abs(np.einsum("bm,bmx->bx", rel, triangle_lag_gap(qq, h, pts[:, None, :])))
    return np.maximum(best, vals.max(axis=1))


def _grid_peak(v, coords):
    """Row maxima of ``v`` and the parabolic estimate of where they are."""
    k = np.argmax(v, axis=1)
    rows = np.arange(len(v))
    lo, hi = np.clip(k - 1, 0, v.shape[1] - 1), np.clip(k + 1, 0, v.shape[1] - 1)
    pts = np.stack([coords[rows, lo], coords[rows, k], coords[rows, hi]], axis=1)
    vals = np.stack([v[rows, lo], v[rows, k], v[rows, hi]], axis=1)
    vertex = _vertex(pts, vals)
    return v[rows, k], np.where(np.isfinite(vertex), vertex, coords[rows, k])


def _vertex(pts, vals):
    """Abscissa of the parabola through three equally spaced points (nan where it is not a
    maximum inside them)."""
    a, b, c = vals[:, 0], vals[:, 1], vals[:, 2]
    h = pts[:, 1] - pts[:, 0]
    curv = a - 2 * b + c
    with np.errstate(divide="ignore", invalid="ignore"):
        x = pts[:, 1] + h * (a - c) / (2 * curv)
    ok = (curv < 0) & (x >= pts[:, 0]) & (x <= pts[:, 2]) & (h > 0)
    return np.where(ok, x, np.nan)


def _imperfections(net: Network, parts, matrix, values, dielectric: Dielectric, temperature):
    """Leakage and absorption arrays of the cell capacitors for sampled values; ``temperature``
    one for all, or one per row."""
    n = len(matrix)
    col = {label: j for j, (label, _, _) in enumerate(parts)}
    temps = np.atleast_1d(np.asarray(temperature, float))
    unique, index = np.unique(temps, return_inverse=True)
    insulation = np.array([dielectric.insulation_time(float(t)) for t in unique])[index]
    if len(insulation) == 1:
        insulation = insulation[0]
    leak, r_da, c_da = (np.repeat(a, n, axis=0) for a in net.imperfection_arrays())
    for k, cell in enumerate(net.cells):
        if cell.C <= 0:
            continue
        label = net.cell_label("C", k)
        c = matrix[:, col[label]]
        leak[:, k] = insulation / c
        frac = values.get(f"{label}.absorption", np.full(n, np.mean(dielectric.absorption)))
        tau_da = values.get(f"{label}.absorption_tau", np.full(n, math.sqrt(np.prod(ABSORPTION_TAU_RANGE))))
        c_da[:, k] = frac * c
        r_da[:, k] = tau_da / c_da[:, k]
    return leak, r_da, c_da
