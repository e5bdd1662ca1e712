"""``extra_retardation``: a further exponential creep term (paper eq. 8), faster or slower."""

from __future__ import annotations

import itertools
import math

import numpy as np

from creepcomp.fit.data import Data
from creepcomp.fit.prony import COALESCED_RATIO, coalesced
from creepcomp.fit.structure import Applied, Structure
from creepcomp.fit.solver import Fit, fit_structure
from creepcomp.fit.starts import extra_term_starts
from creepcomp.diagnose.effects import QuickFit, SensorEffect

__all__ = ["ExtraRetardation", "EFFECT"]


class ExtraRetardation(SensorEffect):
    name = "extra_retardation"
    vocabulary_index = 1
    # one term; a log-normal band of terms
    forms = ("exponential", "spectrum")
    parameters = ("tau", "beta")
    repeatable = True
    summary = "a further exponential creep term (Prony term), faster or slower than the others"

    def settings(self, data: Data, base: Fit) -> tuple:
        return (("term", base.structure.n_terms), ("base_taus", tuple(float(t) for t in base.taus)),
                ("base_betas", tuple(float(b) for b in base.betas)), ("longest", data.tau_limits()[1]))

    def extend(self, structure: Structure, applied: Applied) -> Structure:
        grown = Structure(structure.n_terms + 1, structure.effects)
        return grown.with_effect(applied)

    def fit_on(self, data: Data, base: Fit, refine: str = "all", start: dict | None = None,
               quick_fit: QuickFit | None = None) -> Fit:
        applied = Applied(self, self.settings(data, base))
        structure = self.extend(base.structure, applied)
        known = {p.name: base.values[p.name] for p in base.params}
        starts = [start] if start is not None else extra_term_starts(data, base, structure)
        return fit_structure(data, structure, starts,
                             n_refine=2 if refine == "all" else 1,
                             refine=refine != "none", frozen=known if refine == "own" else None,
                             with_cov=refine == "all", screening=quick_fit is not None)

    def added_term(self, fit: Fit, applied: Applied) -> int:
        """The term the base did not have: the one left over when the others are matched to
        the base's terms (closest in log tau plus log beta: a base term fitted where two
        terms are has a time between theirs, and most of the larger one's amplitude)."""
        n = applied.setting("term") + 1
        base = np.column_stack([np.log(applied.setting("base_taus")),
                                np.log(np.abs(applied.setting("base_betas")) + 1e-300)])
        new = np.column_stack([np.log(fit.taus[:n]), np.log(np.abs(fit.betas[:n]) + 1e-300)])
        best, best_cost = n - 1, math.inf
        for left_out in range(n):
            rest = [k for k in range(n) if k != left_out]
            cost = min(sum(np.abs(new[r] - base[b]).sum() for r, b in zip(rest, perm))
                       for perm in itertools.permutations(range(len(base))))
            if cost < best_cost:
                best, best_cost = left_out, cost
        return best

    def unphysical(self, fit: Fit, applied: Applied) -> str | None:
        k = self.added_term(fit, applied)
        tau = fit.values[f"tau[{k}]"]
        settled = 1.0 + float(np.sum(fit.betas))
        if settled <= 0:
            # creep and relaxation both allowed (either sign, mixed); not a response that
            # settles against the load's direction
            return (f"1 + sum(beta) = {settled:.3g}: the settled response would have the opposite "
                    f"sign of the instantaneous one, which no passive material does")
        n = applied.setting("term") + 1
        if coalesced(fit.taus[:n]):
            return (f"tau = {tau:.3g} s: within {(COALESCED_RATIO - 1) * 100:.0f} % of another term's time "
                    f"constant; two terms there are one term")
        longest = applied.setting("longest")
        if tau > longest:
            # its free initial state then decays as a ramp in time: drift, not creep
            return f"tau = {tau:.3g} s: longer than the record can resolve ({longest:.3g} s)"
        return None

    def report(self, fit: Fit, applied: Applied) -> dict:
        k = self.added_term(fit, applied)
        return {"tau": fit.estimate(lambda v: v[f"tau[{k}]"]),
                "beta": fit.estimate(lambda v: v[f"a[{k}]"] / v["gain"])}

    def restore(self, entry, model, data):
        return Applied(self, ()), {}

    def inverse(self, entry, model):
        return "its creep term is one of the model's terms, inverted with them"

    # -- generator ---------------------------------------------------------------------------
    def draw_default(self, rng, scales, mixture):
        s = scales
        slow = s.tau * rng.uniform(4.0, 12.0)
        fast = s.tau / rng.uniform(4.0, 12.0)
        t2 = slow if (rng.uniform() < 0.5 and slow <= s.duration / 3.0) or fast < 10.0 / s.rate else fast
        t2 = min(t2, s.duration / 3.0)
        return {"tau": float(t2), "beta": float(s.beta * rng.uniform(0.4, 1.0))}

    def draw(self, rng, scales, form):
        out = self.draw_default(rng, scales, False)
        if form == "spectrum":
            out["spread"] = float(rng.uniform(0.15, 0.35))
        return out

    def relax(self, p):
        p["beta"] = -abs(p["beta"])

    def program_choices(self, p, tau, choices, given):
        if p["tau"] < tau and len(choices) > 1:
            # a fast further term shows after load steps, hardly in a slow sweep
            return [c for c in choices if c != "sweep"]
        return choices

    def truth(self, p, synthetic):
        return {"tau": p["tau"], "beta": p["beta"]}

    def sim_terms(self, p):
        if p.get("form", "exponential") == "spectrum":
            # a band of retardation times, log-normal weights over +-spread decades
            grid_tau = float(p["tau"]) * 10.0 ** np.linspace(-p["spread"], p["spread"], 7)
            w = np.exp(-0.5 * (np.linspace(-2.0, 2.0, 7)) ** 2)
            return list(grid_tau), list(float(p["beta"]) * w / w.sum())
        return [float(p["tau"])], [float(p["beta"])]


EFFECT = ExtraRetardation()
