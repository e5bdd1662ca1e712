"""The correction network: its parts, and its transfer function ``H(s)``.

Topology (``docs/physics.md``, section 3, generalised): from the sensor (a voltage source behind
``source_resistance``) a series chain of cells, each a resistor ``R`` in parallel with a
capacitor ``C`` (``C = 0`` is a plain resistor), to the output; from the output to ground
``R2`` (optional), the next stage's ``load_resistance`` (optional) and shunt branches, each
a resistor in series with a capacitor (the lag network for overshooting sensors).

``H(s)`` is written once, as the state-space model of that circuit
(:func:`state_matrices`); its transfer function, its sum-of-lags form and every simulation
derive from it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Mapping, TYPE_CHECKING

import numpy as np

from creepcomp.errors import InputError
from creepcomp.units import check_number, format_quantity
from creepcomp.lti import LagExpansion

if TYPE_CHECKING:
    import control

__all__ = ["Cell", "Branch", "Network", "state_matrices", "modal_form", "parallel",
           "RESISTANCE_RANGE", "CAPACITANCE_RANGE", "MAX_CELLS"]

#: Resistances a design may hold (ohm): 1 mΩ to 1 PΩ (beyond it, board leakage decides).
RESISTANCE_RANGE = (1e-3, 1e15)
#: Capacitances a design may hold (farad): 1 fF to 10 F.
CAPACITANCE_RANGE = (1e-15, 10.0)


@dataclass(frozen=True)
class Cell:
    """Series cell: resistor ``R`` (ohm) in parallel with capacitor ``C`` (farad, 0 = none).

    The capacitor's own imperfections are optional: ``leakage``, a resistance across it
    (ohm), and dielectric absorption, a series ``absorption_R``-``absorption_C`` branch
    across it.
    """

    R: float
    C: float
    leakage: float | None = None
    absorption_R: float | None = None
    absorption_C: float | None = None

    def __post_init__(self):
        object.__setattr__(self, "R", float(self.R))
        object.__setattr__(self, "C", float(self.C))
        for name in ("leakage", "absorption_R", "absorption_C"):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, float(value))
        if (self.absorption_R is None) != (self.absorption_C is None):
            raise InputError("dielectric absorption needs both absorption_R and absorption_C")
        if (self.leakage is not None or self.absorption_C is not None) and not self.C > 0:
            raise InputError("leakage and absorption belong to a capacitor: the cell has C = 0")

    @property
    def has_absorption(self) -> bool:
        """True when the capacitor carries a dielectric-absorption branch."""
        return self.absorption_C is not None

    def ideal(self) -> "Cell":
        """The same R and C without the capacitor's imperfections."""
        return Cell(self.R, self.C)


@dataclass(frozen=True)
class Branch:
    """Shunt branch from output to ground: resistor ``R`` (ohm) in series with ``C`` (farad)."""

    R: float
    C: float

    def __post_init__(self):
        object.__setattr__(self, "R", float(self.R))
        object.__setattr__(self, "C", float(self.C))


def _positive(value, name: str, allow_zero: bool = False, allow_none: bool = False):
    if value is None and allow_none:
        return None
    if allow_none and isinstance(value, float) and value == math.inf:  # no resistor
        return None
    x = check_number(value, name)
    if (x == 0 and not allow_zero) or x < 0:
        need = "zero or positive" if allow_zero else "positive"
        raise InputError(f"{name} = {value!r}: must be {need}")
    return x


#: Most cells (and shunt branches) a network may have: one cell per creep term
#: (:data:`creepcomp.model.MAX_TERMS`); the Monte Carlo's arrays grow with the count.
MAX_CELLS = 20


@dataclass(frozen=True)
class Network:
    """A passive RC correction network between a sensor and the next stage.

    Parameters
    ----------
    cells : tuple of Cell
        Series chain from input to output.
    R2 : float or None
        Resistor from output to ground (ohm); None when there is none.
    shunt : tuple of Branch
        Series R-C branches from output to ground.
    source_resistance : float
        Output resistance of the sensor (ohm).
    load_resistance : float or None
        Input resistance of the next stage (ohm); None is infinite.
    """

    cells: tuple[Cell, ...]
    R2: float | None
    shunt: tuple[Branch, ...] = ()
    source_resistance: float = 0.0
    load_resistance: float | None = None

    def __post_init__(self):
        cells = tuple(c if isinstance(c, Cell) else Cell(**c) for c in self.cells)
        shunt = tuple(b if isinstance(b, Branch) else Branch(**b) for b in self.shunt)
        if len(cells) > MAX_CELLS or len(shunt) > MAX_CELLS:
            raise InputError(f"{len(cells)} cells and {len(shunt)} shunt branches: at most {MAX_CELLS} "
                             "of each (one cell per creep term)")
        for k, c in enumerate(cells):
            _positive(c.R, f"cells[{k}].R")
            _positive(c.C, f"cells[{k}].C", allow_zero=True)
            _positive(c.leakage, f"cells[{k}].leakage", allow_none=True)
            _positive(c.absorption_R, f"cells[{k}].absorption_R", allow_none=True)
            _positive(c.absorption_C, f"cells[{k}].absorption_C", allow_none=True)
        for j, b in enumerate(shunt):
            _positive(b.R, f"shunt[{j}].R")
            _positive(b.C, f"shunt[{j}].C")
        object.__setattr__(self, "cells", cells)
        object.__setattr__(self, "shunt", shunt)
        object.__setattr__(self, "R2", _positive(self.R2, "R2", allow_none=True))
        object.__setattr__(self, "source_resistance",
                           _positive(self.source_resistance, "source_resistance", allow_zero=True))
        object.__setattr__(self, "load_resistance",
                           _positive(self.load_resistance, "load_resistance", allow_none=True))

    # --- parts -----------------------------------------------------------------------
    def check_buildable(self, where: str = "design") -> None:
        """Refuse part values no circuit has, or that the simulations cannot handle.

        Resistances (parts, leakage, source and load) must lie in :data:`RESISTANCE_RANGE`,
        capacitances (other than a cell's 0, "no capacitor") in :data:`CAPACITANCE_RANGE`,
        and the network needs at least one capacitor: without one it corrects nothing.

        Raises
        ------
        InputError
            Naming the part, its value and the limits.
        """
        def check(value, name, kind):
            low, high = RESISTANCE_RANGE if kind == "R" else CAPACITANCE_RANGE
            unit = "Ω" if kind == "R" else "F"
            if value is not None and not low <= value <= high:
                raise InputError(f"{where}: {name} = {format_quantity(value, unit)} is outside "
                                 f"{format_quantity(low, unit)} .. {format_quantity(high, unit)}, "
                                 "what a built part can be and the simulations handle")

        for k, c in enumerate(self.cells):
            check(c.R, f"cells[{k}].R", "R")
            if c.C != 0:
                check(c.C, f"cells[{k}].C", "C")
            check(c.leakage, f"cells[{k}].leakage", "R")
            check(c.absorption_R, f"cells[{k}].absorption_R", "R")
            check(c.absorption_C, f"cells[{k}].absorption_C", "C")
        for j, b in enumerate(self.shunt):
            check(b.R, f"shunt[{j}].R", "R")
            check(b.C, f"shunt[{j}].C", "C")
        check(self.R2, "R2", "R")
        if self.source_resistance:
            check(self.source_resistance, "source_resistance", "R")
        check(self.load_resistance, "load_resistance", "R")
        if not self.shunt and all(c.C == 0 for c in self.cells):
            zero = ", ".join(f"cells[{k}].C = 0" for k in range(len(self.cells)))
            raise InputError(f"{where}: the network has no capacitor ({zero}): it cannot correct "
                             "creep; give each cell's capacitance in farad (C > 0)")

    def cell_label(self, kind: str, cell: int) -> str:
        """The designator of a cell's resistor (``kind`` ``"R"``) or capacitor (``"C"``):
        ``R1``/``C1``, or ``R1.k``/``C1.k`` (``k = cell + 1``) in a network of several cells."""
        return f"{kind}1.{cell + 1}" if len(self.cells) > 1 else f"{kind}1"

    def parts(self) -> list[tuple[str, str, float]]:
        """The parts as ``(label, kind, value)``, kind ``"R"`` or ``"C"``, in circuit order."""
        out = []
        for k, c in enumerate(self.cells):
            out.append((self.cell_label("R", k), "R", c.R))
            if c.C > 0:
                out.append((self.cell_label("C", k), "C", c.C))
        if self.R2 is not None:
            out.append(("R2", "R", self.R2))
        for j, b in enumerate(self.shunt, 1):
            suffix = f".{j}" if len(self.shunt) > 1 else ""
            out.append((f"R3{suffix}", "R", b.R))
            out.append((f"C3{suffix}", "C", b.C))
        return out

    def with_parts(self, values) -> "Network":
        """A copy with part values replaced, given in the order of :meth:`parts`."""
        values = list(values)
        it = iter(values)
        cells = []
        for c in self.cells:
            R = next(it)
            C = next(it) if c.C > 0 else 0.0
            cells.append(replace(c, R=R, C=C))
        R2 = next(it) if self.R2 is not None else None
        shunt = [Branch(next(it), next(it)) for _ in self.shunt]
        return replace(self, cells=tuple(cells), R2=R2, shunt=tuple(shunt))

    @property
    def topology(self) -> str:
        """``"lead"`` (Foster chain and R2) or ``"lag"`` (series R and shunt branches)."""
        return "lag" if self.shunt else "lead"

    # --- H(s) --------------------------------------------------------------------------
    def state_space(self) -> "control.StateSpace":
        """State-space model of ``H(s)``; states are the capacitor voltages."""
        import control

        A, B, C, D, _ = state_matrices(*self.as_arrays())
        return control.ss(A[0], B[0][:, None], C[0][None, :], [[D[0]]])

    def transfer_function(self) -> "control.TransferFunction":
        """``H(s)`` as a python-control transfer function."""
        return self.lag_expansion().transfer_function()

    def lag_expansion(self) -> LagExpansion:
        """``H(s) = D + sum_i r_i / (1 + s p_i)`` (RC networks have real, simple poles)."""
        d, r, p = modal_form(*state_matrices(*self.as_arrays()))
        return LagExpansion(float(d[0]), tuple(r[0]), tuple(p[0]))

    def as_arrays(self):
        """Part values as batch-of-one arrays for :func:`state_matrices`."""
        cells_R = np.array([[c.R for c in self.cells]])
        cells_C = np.array([[c.C for c in self.cells]])
        shunt_R = np.array([[b.R for b in self.shunt]]).reshape(1, -1)
        shunt_C = np.array([[b.C for b in self.shunt]]).reshape(1, -1)
        R2 = np.array([np.inf if self.R2 is None else self.R2])
        return (cells_R, cells_C, R2, shunt_R, shunt_C, self.source_resistance, self.load_resistance,
                *self.imperfection_arrays())

    def batch_arrays(self, values) -> tuple:
        """Arrays for :func:`state_matrices` of many copies of this network with other part
        values, given as rows in :meth:`parts` order (imperfections kept as they are)."""
        values = np.atleast_2d(np.asarray(values, dtype=float))
        nb = len(values)
        cols = iter(values.T)
        cells_R, cells_C = [], []
        for c in self.cells:
            cells_R.append(next(cols))
            cells_C.append(next(cols) if c.C > 0 else np.zeros(nb))
        R2 = next(cols) if self.R2 is not None else np.full(nb, np.inf)
        shunt = [(next(cols), next(cols)) for _ in self.shunt]
        shunt_R = np.stack([r for r, _ in shunt], axis=1) if shunt else np.zeros((nb, 0))
        shunt_C = np.stack([c for _, c in shunt], axis=1) if shunt else np.zeros((nb, 0))
        return (np.stack(cells_R, axis=1), np.stack(cells_C, axis=1), R2, shunt_R, shunt_C,
                self.source_resistance, self.load_resistance, *self.imperfection_arrays())

    def imperfection_arrays(self):
        """Capacitor leakage and absorption of the cells as batch-of-one arrays (inf / 0: none)."""
        leak = np.array([[np.inf if c.leakage is None else c.leakage for c in self.cells]])
        r_da = np.array([[np.inf if c.absorption_R is None else c.absorption_R for c in self.cells]])
        c_da = np.array([[0.0 if c.absorption_C is None else c.absorption_C for c in self.cells]])
        return leak, r_da, c_da

    # --- files -------------------------------------------------------------------------
    def to_dict(self) -> dict:
        """Design-file keys of the network (``cells``, ``R2``, resistances, ``shunt``)."""
        out = {"cells": [_cell_dict(c) for c in self.cells], "R2": self.R2,
               "source_resistance": self.source_resistance,
               "load_resistance": self.load_resistance}
        if self.shunt:
            out["shunt"] = [{"R": b.R, "C": b.C} for b in self.shunt]
        return out

    @classmethod
    def from_dict(cls, data: Mapping, where: str = "design") -> "Network":
        """Read the network keys of a design file.

        Raises
        ------
        InputError
            Naming ``where`` and the key that is wrong.
        """
        if not isinstance(data, Mapping):
            raise InputError(f"{where}: expected a JSON object")
        for key in ("cells", "R2"):
            if key not in data:
                raise InputError(f"{where}: missing '{key}' (found keys: {', '.join(map(str, data))})")
        cells = data["cells"]
        if not isinstance(cells, list) or not cells:
            raise InputError(f"{where}: 'cells' must be a non-empty list of {{\"R\": ..., \"C\": ...}}")
        try:
            parsed = []
            for k, c in enumerate(cells):
                if not isinstance(c, Mapping) or "R" not in c or "C" not in c:
                    raise InputError(f"cells[{k}] must be an object with 'R' and 'C'")
                parsed.append(Cell(_positive(c["R"], f"cells[{k}].R"),
                                   _positive(c["C"], f"cells[{k}].C", allow_zero=True),
                                   *(_positive(c.get(key), f"cells[{k}].{key}", allow_none=True)
                                     for key in ("leakage", "absorption_R", "absorption_C"))))
            shunt = []
            branches = data.get("shunt", []) or []
            if not isinstance(branches, list):
                raise InputError("'shunt' must be a list of {\"R\": ..., \"C\": ...}")
            for j, b in enumerate(branches):
                if not isinstance(b, Mapping) or "R" not in b or "C" not in b:
                    raise InputError(f"shunt[{j}] must be an object with 'R' and 'C'")
                shunt.append(Branch(_positive(b["R"], f"shunt[{j}].R"), _positive(b["C"], f"shunt[{j}].C")))
            return cls(tuple(parsed), data["R2"], tuple(shunt),
                       data.get("source_resistance", 0.0) or 0.0, data.get("load_resistance"))
        except InputError as exc:
            raise InputError(f"{where}: {exc}") from None


def _cell_dict(cell: Cell) -> dict:
    out = {"R": cell.R, "C": cell.C}
    for key in ("leakage", "absorption_R", "absorption_C"):
        if getattr(cell, key) is not None:
            out[key] = getattr(cell, key)
    return out


def state_matrices(cells_R, cells_C, R2, shunt_R, shunt_C, source_resistance=0.0,
                   load_resistance=None, cells_leakage=None, absorption_R=None, absorption_C=None):
    """State-space matrices of a batch of networks of one topology.

    Parameters
    ----------
    cells_R, cells_C : array_like, shape (B, K)
        Series cells; ``C = 0`` marks a plain resistor (the same cells in every network).
    R2 : array_like, shape (B,)
        Output-to-ground resistor, ``inf`` for none.
    shunt_R, shunt_C : array_like, shape (B, J)
        Shunt R-C branches.
    source_resistance : float or array_like, shape (B,)
        Sensor output resistance.
    load_resistance : float, array_like of shape (B,), or None
        Next stage's input resistance (None or ``inf``: none).
    cells_leakage : array_like, shape (B, K), optional
        Resistance across each cell's capacitor (``inf``: none).
    absorption_R, absorption_C : array_like, shape (B, K), optional
        Dielectric-absorption branch across each cell's capacitor (``C = 0``: none; which
        cells have one is read from the first network of the batch).

    Returns
    -------
    A : (B, n, n), B : (B, n), C : (B, n), D : (B,), caps : (B, n)
        With states the capacitor voltages (cells, then shunt branches, then absorption
        branches); ``caps`` are the capacitances, which make ``A`` symmetrisable.
    """
    cells_R = np.atleast_2d(np.asarray(cells_R, float))
    cells_C = np.atleast_2d(np.asarray(cells_C, float))
    shunt_R = np.asarray(shunt_R, float).reshape(cells_R.shape[0], -1)
    shunt_C = np.asarray(shunt_C, float).reshape(cells_R.shape[0], -1)
    nb = cells_R.shape[0]
    R2 = np.broadcast_to(np.asarray(R2, float), (nb,))
    RL = np.broadcast_to(np.asarray(np.inf if load_resistance is None else load_resistance, float), (nb,))
    dynamic = cells_C[0] > 0
    Rs = np.broadcast_to(np.asarray(source_resistance, float), (nb,)) + cells_R[:, ~dynamic].sum(axis=1)
    Rk, Ck = cells_R[:, dynamic], cells_C[:, dynamic]
    if cells_leakage is not None:
        leak = np.broadcast_to(np.asarray(cells_leakage, float), cells_R.shape)[:, dynamic]
        Rk = 1.0 / (1.0 / Rk + 1.0 / leak)
    K, J = Rk.shape[1], shunt_R.shape[1]
    g = 1.0 / shunt_R                                                   # (B,J)
    G0 = 1.0 / R2 + 1.0 / RL                                            # (B,)
    Gt = G0 + g.sum(axis=1)
    # v_out = a.x + b u;  series current i = Gt v_out - g.w
    denom = 1.0 + Rs * Gt
    a = np.concatenate([-np.ones((nb, K)), Rs[:, None] * g], axis=1) / denom[:, None]
    b = 1.0 / denom
    i_x = Gt[:, None] * a - np.concatenate([np.zeros((nb, K)), g], axis=1)
    i_u = Gt * b
    n = K + J
    A = np.zeros((nb, n, n))
    Bv = np.zeros((nb, n))
    A[:, :K, :] = i_x[:, None, :] / Ck[:, :, None]
    A[:, np.arange(K), np.arange(K)] -= 1.0 / (Rk * Ck)
    Bv[:, :K] = i_u[:, None] / Ck
    if J:
        gc = g / shunt_C                                                # (B,J)
        A[:, K:, :] = gc[:, :, None] * a[:, None, :]
        A[:, K + np.arange(J), K + np.arange(J)] -= gc
        Bv[:, K:] = gc * b[:, None]
    caps = np.concatenate([Ck, shunt_C], axis=1)
    if absorption_C is not None:
        c_da_all = np.broadcast_to(np.asarray(absorption_C, float), cells_R.shape)[:, dynamic]
        r_da_all = np.broadcast_to(np.asarray(absorption_R, float), cells_R.shape)[:, dynamic]
        which = np.flatnonzero(c_da_all[0] > 0)
        if which.size:
            A, Bv, a, caps = _add_absorption(A, Bv, a, caps, Ck, which,
                                             r_da_all[:, which], c_da_all[:, which])
    return A, Bv, a, b, caps


def _add_absorption(A, Bv, a, caps, Ck, which, r_da, c_da):
    """Append one state per absorption branch (voltage on its capacitor) to a network."""
    nb, n, _ = A.shape
    m = len(which)
    A2 = np.zeros((nb, n + m, n + m))
    A2[:, :n, :n] = A
    idx = n + np.arange(m)
    g = 1.0 / r_da                                                      # (B,m)
    A2[:, which, which] -= g / Ck[:, which]
    A2[:, which, idx] += g / Ck[:, which]
    A2[:, idx, which] = g / c_da
    A2[:, idx, idx] = -g / c_da
    Bv2 = np.concatenate([Bv, np.zeros((nb, m))], axis=1)
    a2 = np.concatenate([a, np.zeros((nb, m))], axis=1)
    return A2, Bv2, a2, np.concatenate([caps, c_da], axis=1)


def modal_form(A, B, C, D, caps):
    """Sum-of-lags form ``D + sum r_i / (1 + s p_i)`` of a batch of RC networks.

    ``diag(sqrt(caps)) A diag(1/sqrt(caps))`` is symmetric for an RC network, so the
    decomposition uses a symmetric eigensolver: real poles, orthogonal modes, no loss of
    accuracy when time constants are close.

    Returns
    -------
    direct : (B,), gains : (B, n), taus : (B, n)
    """
    s = np.sqrt(caps)
    M = A * s[:, :, None] / s[:, None, :]
    asym = np.abs(M - np.swapaxes(M, 1, 2)).max(initial=0.0)
    scale = np.abs(M).max(initial=1.0)
    if asym > 1e-9 * scale:
        raise AssertionError(f"network matrix not symmetrisable (asymmetry {asym:.3g})")
    lam, V = np.linalg.eigh(0.5 * (M + np.swapaxes(M, 1, 2)))
    if np.any(lam >= 0):
        raise InputError("the network has a pole at or right of zero: check its parts")
    left = np.einsum("bn,bnm->bm", C / s, V)                            # C S^-1 V
    right = np.einsum("bnm,bn->bm", V, B * s)                           # V^T S B
    taus = -1.0 / lam
    return np.asarray(D, float), left * right * taus, taus


def parallel(*resistances: float | None) -> float | None:
    """Parallel combination; None stands for an open circuit."""
    conductance = sum(1.0 / r for r in resistances if r is not None)
    return None if conductance == 0 else 1.0 / conductance
