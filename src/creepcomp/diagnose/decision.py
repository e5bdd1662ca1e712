"""The decision rule of the sensor diagnosis (:mod:`creepcomp.diagnose.sensor`), apart from
the planning of which fits run, when and where: pure functions of fitted results.

The rule, figure against threshold (ΔBIC: a model's BIC minus the current model's; held-out
z: the held-out improvement in standard deviations of its noise):

1. A candidate is tested on held-out data (:func:`gate`) only when its ΔBIC is at most
   ``-BIC_STRONG`` (:data:`~creepcomp.fit.evidence.BIC_STRONG`, 10); once a candidate is
   accepted at the step, only when it also has fewer parameters than the accepted one and its
   ΔBIC is at most half the accepted one's (it explains at least half as much).
2. A tested candidate (:func:`judge`) is supported when ΔBIC ≤ ``-BIC_STRONG`` and held-out
   z ≥ :data:`~creepcomp.fit.evidence.HELDOUT_Z` (3) with a held-out RMS ratio above 1. The
   first supported one is accepted unless the catch-all predicts held-out data clearly better
   than it (then the step stops with none). A later supported one (simpler, by point 1)
   replaces the accepted one unless the accepted one predicts held-out data better than it
   (held-out z of the richer against the simpler ≥ ``HELDOUT_Z``).
3. ``unexplained`` (:func:`unexplained`) is added when the catch-all on top of the model
   found is supported, or else when the model's residual RMS exceeds the noise floor's RMS
   times :data:`~creepcomp.fit.noise.MISFIT_LIMIT` (1.5), or times :data:`REMAINING_LIMIT`
   (1.3) when there are named findings and the catch-all's ΔBIC is at most ``-BIC_STRONG``.
4. The extension makes the creep correction worse (:func:`correction_is_worse`) when the
   correction-error ratio (baseline model / extended model) is below
   :data:`CORRECTION_WORSE` (0.98), or when the extended model's correction finds no load that
   gives the signal; each finding's own ratio is then measured.
5. The findings are ordered (:func:`order`) by importance (drop of the held-out sum of
   squares), those that make the correction worse after the others, ``unexplained`` between.

Inputs whose computation costs fits (the catch-all's comparison, a held-out comparison of two
candidates) are passed as callables, asked only where the rule needs the answer.
"""

from __future__ import annotations

from typing import Callable, NamedTuple

from creepcomp.diagnose import effects as effects_pkg
from creepcomp.fit.evidence import BIC_STRONG
from creepcomp.fit.noise import MISFIT_LIMIT

__all__ = ["CORRECTION_WORSE", "REMAINING_LIMIT", "Judgement", "gate", "judge", "unexplained",
           "correction_is_worse", "ratio_is_worse", "order"]

#: A correction-error ratio below this: the extension makes the creep-corrected signal worse
#: (the ratio of two RMS errors of the same record moves by a percent or so without any change).
CORRECTION_WORSE = 0.98
#: Named findings that leave a misfit ratio above this get ``unexplained`` added when the
#: catch-all lowers BIC strongly (structure it follows in the fitted samples, even if it does
#: not predict held-out blocks): tighter than ``MISFIT_LIMIT``, which must also allow for the
#: floor's miss of strongly coloured noise on its own; with a named finding whose template
#: only approximates the record (creep that ages, fitted as further terms) the rest is
#: structure (``docs/diagnosis.md``, "The verdict").
REMAINING_LIMIT = 1.3


def gate(candidate, accepted, current) -> str | None:
    """Why a candidate is not tested on held-out data (by its BIC), or None.

    Parameters
    ----------
    candidate : Candidate
        Its ``delta_bic`` (BIC minus ``current``'s) and ``fit.n_params`` are read.
    accepted : Candidate or None
        The candidate accepted so far at this step.
    current : Fit
        The current model (its ``bic``).

    Returns
    -------
    str or None
        ``"not supported (BIC)"`` when ΔBIC > ``-BIC_STRONG``; ``"weaker than the accepted
        one"`` when a candidate is accepted and this one is not both simpler (fewer
        parameters) and at least half as good (ΔBIC ≤ half the accepted one's); None: test it.
    """
    if candidate.delta_bic > -BIC_STRONG:
        return "not supported (BIC)"
    if accepted is not None and not (candidate.fit.n_params < accepted.fit.n_params and
                                     candidate.delta_bic <= 0.5 * (accepted.fit.bic - current.bic)):
        return "weaker than the accepted one"
    return None


class Judgement(NamedTuple):
    """What :func:`judge` decides about a tested candidate.

    Attributes
    ----------
    outcome : str
        The candidate's trial outcome.
    accept : bool
        It becomes the accepted candidate.
    stop : bool
        The step ends here (no later candidate is judged).
    demoted : str or None
        The new outcome of the trial of the candidate accepted before (it is replaced), or
        None (unchanged).
    """

    outcome: str
    accept: bool = False
    stop: bool = False
    demoted: str | None = None


def judge(candidate, accepted, generic_better: Callable[[], bool],
          richer_predicts_better: Callable[[], bool]) -> Judgement:
    """The decision on a candidate that passed :func:`gate` and was tested on held-out data.

    Parameters
    ----------
    candidate : Candidate
        Its ``evidence`` against the current model (``supported``: ΔBIC ≤ ``-BIC_STRONG``,
        held-out z ≥ ``HELDOUT_Z``, held-out RMS ratio > 1) and its effect's name are read.
    accepted : Candidate or None
        The candidate accepted so far at this step (richer than ``candidate``, by the gate).
    generic_better : callable
        Asked only when none is accepted yet and the candidate is supported: whether the
        catch-all on top of the current model predicts held-out data clearly better than it.
    richer_predicts_better : callable
        Asked only when one is accepted and the candidate is supported: whether the accepted
        one predicts held-out data better than the candidate (held-out z ≥ ``HELDOUT_Z``).

    Returns
    -------
    Judgement
    """
    name = candidate.effect.name
    if not candidate.evidence.supported:
        return Judgement("not supported (held-out)")
    if accepted is None:
        if generic_better():
            return Judgement("the generic extension predicts clearly better", stop=True)
        return Judgement("accepted", accept=True)
    if richer_predicts_better():
        # parsimony: the richer one must predict held-out data better than this simpler one
        return Judgement(f"supported, but {accepted.effect.name} predicts better")
    return Judgement("accepted", accept=True,
                     demoted=f"supported, but not better on held-out data than the simpler {name}")


def unexplained(residual_rms: float, catch, named: bool, floor_rms: float) -> str | None:
    """Whether the verdict adds ``unexplained``, and why.

    Parameters
    ----------
    residual_rms : float
        Residual RMS of the model found (signal units).
    catch : Evidence or None
        The catch-all's evidence on top of that model (None: it could not be fitted).
    named : bool
        The search accepted named findings.
    floor_rms : float
        The record's noise floor RMS (signal units).

    Returns
    -------
    str or None
        ``"catch-all"``: the catch-all's evidence is supported; ``"misfit"``: it is not, but
        the residual RMS exceeds ``floor_rms`` times ``MISFIT_LIMIT`` (``REMAINING_LIMIT``
        when ``named`` and the catch-all's ΔBIC ≤ ``-BIC_STRONG``); None: neither.
    """
    if catch is not None and catch.supported:
        return "catch-all"
    limit = MISFIT_LIMIT
    if named and catch is not None and catch.delta_bic <= -BIC_STRONG:
        limit = REMAINING_LIMIT
    # the floor says the misfit is not noise, whatever the evidence for a candidate
    return "misfit" if residual_rms > limit * floor_rms else None


def correction_is_worse(corr: dict) -> bool:
    """Whether the extension's creep correction calls for each finding's own measure.

    Parameters
    ----------
    corr : dict
        :func:`~creepcomp.diagnose.sensor.correction_errors` of the extended model against
        the baseline (empty: not measured). ``ratio``: RMS error of the baseline's corrected
        signal over the extended model's.

    Returns
    -------
    bool
        True when measured and the ratio is below :data:`CORRECTION_WORSE`, or when the
        extended model's correction finds no load that gives the signal (``unsettled``).
    """
    if not corr:
        return False
    return "unsettled" in corr or ratio_is_worse(corr["ratio"])


def ratio_is_worse(ratio: float | None) -> bool:
    """A correction-error ratio (the baseline's corrected RMS error over the extended one's)
    below :data:`CORRECTION_WORSE`: the extension makes the correction worse (None: not
    measured, not worse)."""
    return ratio is not None and ratio < CORRECTION_WORSE


def order(findings: list, unexplained: "object | None") -> list:
    """The findings in the verdict's order.

    Named findings by importance (drop of the held-out sum of squares, largest first),
    extensions that make the correction worse (``worsens_correction``: ratio below
    :data:`CORRECTION_WORSE`) after the others; ``unexplained`` last (first when no named
    finding improves the correction). A fault of the record (its effect's
    ``describes_record``) keeps its place whatever it does to the correction: it is a
    statement about the record, and its note says what the correction makes of it.

    Parameters
    ----------
    findings : list of Finding
        The named findings (any ``unexplained`` among them is left out).
    unexplained : Finding or None

    Returns
    -------
    list of Finding
    """
    named = [f for f in findings if f.effect != "unexplained"]

    def demoted(f) -> bool:
        return f.worsens_correction and not effects_pkg.get(f.effect).describes_record

    good = sorted((f for f in named if not demoted(f)), key=lambda f: -f.importance)
    worse = sorted((f for f in named if demoted(f)), key=lambda f: -f.importance)
    if unexplained is None:
        return good + worse
    if not good:
        return [unexplained] + worse
    return good + [unexplained] + worse
