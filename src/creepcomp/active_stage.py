"""The active correction stage's circuit: its parts and its transfer function ``H(s)``.

Circuit (ideal op amps; term ``j`` of ``K``)::

    in --RA_j--+--RB_j-- w_j           U_j: inverting integrator, C_j from its - input to w_j,
               |                             RT_j from node e_j to its - input
              RG_j                      U0: follower of node s (the output)
               |                        s: in through RS0, each w_j through RS_j
              gnd

Each integrator loop is a low-pass of the input (``w_j = -LP_j(in)``, DC gain
``RB_j / RA_j``, time constant ``RB_j C_j (1 + RT_j (1/RA_j + 1/RB_j + 1/RG_j))``), and the
output is ``(in / RS0 + sum w_j / RS_j) / (1 / RS0 + sum 1 / RS_j)``: the input minus fixed
fractions of its low-passes, which is ``1 / G`` of a Prony sensor when sized for it
(:mod:`creepcomp.analog.active`). ``H(s)`` is written once, in :meth:`ActiveStage.matrices`.
The class offers what the predictions and the netlists use of a
:class:`~creepcomp.network.Network` (``parts``, ``with_parts``, ``lag_expansion``,
``state_space``, ``source_resistance``, ``load_resistance``, ``topology``), so a design
of either kind goes through the same code.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Mapping, TYPE_CHECKING

import numpy as np

from creepcomp.errors import InputError
from creepcomp.lti import LagExpansion
from creepcomp.network import CAPACITANCE_RANGE, MAX_CELLS, RESISTANCE_RANGE, parallel
from creepcomp.units import format_quantity

if TYPE_CHECKING:
    import control

__all__ = ["ActiveTerm", "ActiveStage", "is_active"]


def is_active(design_data: Mapping) -> bool:
    """True for a design file's data (or a design) of the active stage."""
    return design_data.get("topology") == "active"


@dataclass(frozen=True)
class ActiveTerm:
    """One integrator loop: ``RT`` (ohm, the time-setting resistor: an NTC network when the
    plan says so), ``C`` (F), the divider ``RA`` (from the input), ``RB`` (from the
    integrator's output), ``RG`` (to ground), the summing resistor ``RS`` and the
    capacitor's ``leakage`` (ohm across it, None: none)."""

    RT: float
    C: float
    RA: float
    RB: float
    RG: float
    RS: float
    leakage: float | None = None

    @property
    def alpha(self) -> float:
        """The divider ratio from the input to node ``e`` (``RT`` not loading it)."""
        return (1.0 / self.RA) / (1.0 / self.RA + 1.0 / self.RB + 1.0 / self.RG)

    @property
    def time_constant(self) -> float:
        """The low-pass time constant ``RB C (1 + RT (1/RA + 1/RB + 1/RG))`` (no leakage)."""
        return self.RB * self.C * (1.0 + self.RT * (1.0 / self.RA + 1.0 / self.RB + 1.0 / self.RG))


_TERM_PARTS = (("RT", "R", "RT"), ("C", "C", "C"), ("RA", "R", "RA"), ("RB", "R", "RB"),
               ("RG", "R", "RG"), ("RS", "R", "RS"))


@dataclass(frozen=True)
class ActiveStage:
    """The active correction stage (see the module's description).

    Parameters
    ----------
    terms : tuple of ActiveTerm
        One integrator loop per pole of ``1 / G``.
    RS0 : float
        The output summer's resistor from the input (ohm).
    source_resistance : float
        Output resistance of the sensor (ohm).
    load_resistance : float or None
        Input resistance of the next stage (ohm); the follower drives it, so it changes nothing.
    input_buffer : bool
        A follower ``Uin`` between the sensor and the stage: the stage's input current then
        does not flow through the source resistance (which otherwise changes ``H``).
    """

    terms: tuple[ActiveTerm, ...]
    RS0: float
    source_resistance: float = 0.0
    load_resistance: float | None = None
    input_buffer: bool = False

    topology = "active"

    def __post_init__(self):
        terms = tuple(t if isinstance(t, ActiveTerm) else ActiveTerm(**t) for t in self.terms)
        object.__setattr__(self, "terms", terms)
        if not terms or len(terms) > MAX_CELLS:
            raise InputError(f"an active stage has 1 to {MAX_CELLS} terms (one per creep term), "
                             f"not {len(terms)}")
        for j, t in enumerate(terms, 1):
            for name in ("RT", "C", "RA", "RB", "RG", "RS"):
                v = getattr(t, name)
                if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                    raise InputError(f"active term {j}: {name} = {v!r} must be a positive number")
            if t.leakage is not None and not (math.isfinite(t.leakage) and t.leakage > 0):
                raise InputError(f"active term {j}: leakage = {t.leakage!r} must be positive or null")
        if not (math.isfinite(self.RS0) and self.RS0 > 0):
            raise InputError(f"active stage: RS0 = {self.RS0!r} must be positive")

    # --- parts -----------------------------------------------------------------------
    def parts(self) -> list[tuple[str, str, float]]:
        """``(label, kind, value)`` in circuit order: per term ``RTj, Cj, RAj, RBj, RGj, RSj``,
        then ``RS0``."""
        out = []
        for j, t in enumerate(self.terms, 1):
            out += [(f"{prefix}{j}", kind, getattr(t, attr)) for prefix, kind, attr in _TERM_PARTS]
        out.append(("RS0", "R", self.RS0))
        return out

    def with_parts(self, values) -> "ActiveStage":
        """A copy with part values replaced, in the order of :meth:`parts`."""
        v = [float(x) for x in values]
        n = len(_TERM_PARTS)
        terms = tuple(replace(t, **{attr: v[j * n + i] for i, (_, _, attr) in enumerate(_TERM_PARTS)})
                      for j, t in enumerate(self.terms))
        return replace(self, terms=terms, RS0=v[len(self.terms) * n])

    def with_leakage(self, leakages) -> "ActiveStage":
        """A copy with a resistance across each capacitor (in parallel with any it has)."""
        return replace(self, terms=tuple(replace(t, leakage=parallel(t.leakage, r))
                                         for t, r in zip(self.terms, leakages)))

    def check_buildable(self, where: str = "design") -> None:
        """Refuse values no circuit has (:data:`RESISTANCE_RANGE`, :data:`CAPACITANCE_RANGE`)."""
        for label, kind, value in self.parts():
            low, high = RESISTANCE_RANGE if kind == "R" else CAPACITANCE_RANGE
            unit = "Ω" if kind == "R" else "F"
            if not low <= value <= high:
                raise InputError(f"{where}: {label} = {format_quantity(value, unit)} is outside "
                                 f"{format_quantity(low, unit)} .. {format_quantity(high, unit)}")

    # --- H(s) --------------------------------------------------------------------------
    def matrices(self):
        """State-space ``A, B, C, D`` of ``H(s)``; state ``j`` is integrator ``j``'s output.

        Nodal analysis with ideal op amps: the nodes ``in`` (behind the source resistance),
        ``e_j`` and ``s`` are solved for the input and the states; each integrator's
        capacitor takes the current ``e_j / RT_j`` (and its leakage ``w_j / R_leak``).
        """
        K = len(self.terms)
        rs = 0.0 if self.input_buffer else self.source_resistance
        # unknown nodes: [in (only with a source resistance)], e_1..e_K, s
        off = 1 if rs > 0 else 0
        n = off + K + 1
        M = np.zeros((n, n))
        Nu = np.zeros(n)
        Nw = np.zeros((n, K))
        si = n - 1

        # each divider node e_j: to the input (node or source), to w_j, to ground, to RT_j
        for j, t in enumerate(self.terms):
            e = off + j
            ga, gb, gg, gt = 1 / t.RA, 1 / t.RB, 1 / t.RG, 1 / t.RT
            M[e, e] += ga + gb + gg + gt
            Nw[e, j] += gb
            if off:
                M[e, 0] -= ga
                M[0, 0] += ga
                M[0, e] -= ga
            else:
                Nu[e] += ga
        g0 = 1 / self.RS0
        M[si, si] += g0 + sum(1 / t.RS for t in self.terms)
        for j, t in enumerate(self.terms):
            Nw[si, j] += 1 / t.RS
        if off:
            M[si, 0] -= g0
            M[0, 0] += g0 + 1 / rs
            M[0, si] -= g0
            Nu[0] += 1 / rs
        else:
            Nu[si] += g0
        Pu = np.linalg.solve(M, Nu)
        Pw = np.linalg.solve(M, Nw)
        caps = np.array([t.C for t in self.terms])
        gt = np.array([1 / t.RT for t in self.terms])
        gl = np.array([0.0 if t.leakage is None else 1 / t.leakage for t in self.terms])
        rows = slice(off, off + K)
        A = -(gt[:, None] * Pw[rows, :] + np.diag(gl)) / caps[:, None]
        B = -(gt * Pu[rows]) / caps
        return A, B, Pw[si, :], float(Pu[si])

    def lag_expansion(self) -> LagExpansion:
        """``H(s) = D + sum_i r_i / (1 + s p_i)`` (real poles; checked)."""
        A, B, C, D = self.matrices()
        lam, V = np.linalg.eig(A)
        if np.abs(lam.imag).max(initial=0.0) > 1e-9 * np.abs(lam).max() or np.any(lam.real >= 0):
            raise InputError("the active stage has a pole off the negative real axis: check its parts")
        lam, V = lam.real, V.real
        left = C @ V
        right = np.linalg.solve(V, B)
        taus = -1.0 / lam
        return LagExpansion(D, tuple(left * right * taus), tuple(taus))

    def state_space(self) -> "control.StateSpace":
        """``H(s)`` as a python-control state-space system."""
        import control

        A, B, C, D = self.matrices()
        return control.ss(A, B[:, None], C[None, :], [[D]])

    def transfer_function(self) -> "control.TransferFunction":
        """``H(s)`` as a python-control transfer function."""
        return self.lag_expansion().transfer_function()

    # --- files -------------------------------------------------------------------------
    def to_dict(self) -> dict:
        """Design-file keys: ``topology`` ``"active"`` and the ``active`` block."""
        terms = []
        for t in self.terms:
            d = {"RT": t.RT, "C": t.C, "RA": t.RA, "RB": t.RB, "RG": t.RG, "RS": t.RS}
            if t.leakage is not None:
                d["leakage"] = t.leakage
            terms.append(d)
        return {"topology": "active",
                "active": dict({"terms": terms, "RS0": self.RS0},
                               **({"input_buffer": True} if self.input_buffer else {})),
                "source_resistance": self.source_resistance,
                "load_resistance": self.load_resistance}

    @classmethod
    def from_dict(cls, data: Mapping, where: str = "design") -> "ActiveStage":
        """Read the ``active`` block of a design file (and its resistances)."""
        block = data.get("active")
        if not isinstance(block, Mapping) or not isinstance(block.get("terms"), list) or not block["terms"]:
            raise InputError(f"{where}: 'active' must be an object with a non-empty list 'terms' "
                             "and 'RS0'")
        terms = []
        for j, t in enumerate(block["terms"], 1):
            try:
                terms.append(ActiveTerm(*(float(t[k]) for k in ("RT", "C", "RA", "RB", "RG", "RS")),
                                        None if t.get("leakage") is None else float(t["leakage"])))
            except (KeyError, TypeError, ValueError, AttributeError):
                raise InputError(f"{where}: active term {j} needs numbers RT, C, RA, RB, RG, RS "
                                 "(ohm and farad)") from None
        try:
            rs0 = float(block["RS0"])
            rs = float(data.get("source_resistance") or 0.0)
            rl = data.get("load_resistance")
            rl = None if rl is None else float(rl)
        except (KeyError, TypeError, ValueError):
            raise InputError(f"{where}: 'active' needs a number RS0 (ohm); source_resistance and "
                             "load_resistance numbers or null") from None
        try:
            return cls(tuple(terms), rs0, rs, rl, bool(block.get("input_buffer", False)))
        except InputError as exc:
            raise InputError(f"{where}: {exc}") from None
