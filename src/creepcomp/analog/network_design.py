"""From a creep model to a network that can be built, in one call: size it (and over a
temperature range when asked), judge whether it can be built and still corrects, list its
bill of materials, and name the way out when it cannot.

:func:`design_network` is what ``creepcomp size`` runs; its :class:`NetworkDesign` shows
itself (the tables the command prints) and gives the design file and ``size --json``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from creepcomp.analog.parts import PartsPlan
from creepcomp.analog.sizing import NoNetworkInRange, SizingReport, size
from creepcomp.display import Shown
from creepcomp.errors import InputError
from creepcomp.model import CreepModel
from creepcomp.units import format_percent

__all__ = ["NetworkDesign", "design_network", "size_over_range", "fixed_for_range"]


@dataclass(frozen=True, eq=False)
class NetworkDesign(Shown):
    """A sized network, its verdict, bill of materials, and the way out when impractical.

    Attributes
    ----------
    model : CreepModel
    options : dict
        The :func:`~creepcomp.analog.sizing.size` arguments asked (for the way out).
    plan : PartsPlan
    sizing : SizingReport or None
        The design to write (for a range, the one chosen for it); None when no network of
        the rule has its parts in the ranges searched.
    at_reference : SizingReport or None
        Sized at the model's reference temperature (``sizing`` without a range).
    comparison : RangeComparison or None
        The designs over the temperature range, when one was given.
    verdict : Verdict or None
    bom : tuple of BomRow
    reasons : tuple of str
        Why the design is refused (empty: it is written).
    way_out : WayOut or None
        The nearest practical alternative of a refused design.
    span : tuple of float or None
        The temperature range (°C).
    """

    model: CreepModel
    options: dict
    plan: PartsPlan
    sizing: SizingReport | None
    at_reference: SizingReport | None = None
    comparison: object = None
    verdict: object = None
    bom: tuple = ()
    reasons: tuple[str, ...] = ()
    way_out: object = None
    span: tuple[float, float] | None = None

    @property
    def refused(self) -> bool:
        """True when the design is judged impractical and not written."""
        return bool(self.reasons)

    @property
    def ideal_values(self) -> bool:
        """Ideal values (no E-series): a calculation, judged but never refused."""
        return self.sizing is not None and self.sizing.resistor_series is None

    def __repr__(self) -> str:
        if self.refused:
            return (f"<NetworkDesign refused ({len(self.reasons)} reason{'s' if len(self.reasons) > 1 else ''}); "
                    f"way out: {self.way_out.description[:100]}>")
        v = self.verdict
        state = "practical" if v.practical else "impractical"
        return (f"<NetworkDesign {state}: {self.sizing.chosen.topology} network, peak residual creep "
                f"{format_percent(v.leakage_peak)} with leakage, {format_percent(v.worst_case_peak)} at the "
                f"worst tolerance corner (uncorrected {format_percent(v.uncorrected_peak)})>")

    def design_dict(self) -> dict:
        """The design file (``docs/design-file.md``), with the prediction over the range."""
        design = self.sizing.design_dict()
        if self.comparison is not None:
            design["over_temperature"] = self.comparison.written.prediction.to_dict()
        return design

    def to_dict(self) -> dict:
        """``size --json`` of a design that is written (a refused one:
        :meth:`refusal_dict`)."""
        if self.refused:
            return self.refusal_dict()
        out = self.sizing.to_dict()
        v = self.verdict
        out.update(practical=v.practical, reasons=list(v.reasons), way_out=None,
                   verdict=v.to_dict(), bom=[r.to_dict() for r in self.bom])
        if self.comparison is not None:
            out["parts"] = self.sizing.plan.to_dict()
            out["over_temperature"] = self.comparison.written.prediction.to_dict()
            out["temperature_designs"] = self.comparison.to_dict()
        return out

    def refusal_dict(self) -> dict:
        """The JSON of a refused design: the reasons, the way out, the verdict and the
        designs over the range."""
        out = {"practical": False, "reasons": list(self.reasons), "way_out": self.way_out.to_dict()}
        if self.verdict is not None:
            out["verdict"] = self.verdict.to_dict()
        if self.comparison is not None:
            out["temperature_designs"] = self.comparison.to_dict()
        return out


def design_network(model: CreepModel, plan: PartsPlan | None = None,
                   temperature_range: tuple[float, float] | None = None, tracking: str = "none",
                   topology: str = "auto", allow_impractical: bool = False, **options) -> NetworkDesign:
    """Size the network, judge it, list its parts, or refuse it with the way out.

    Parameters
    ----------
    model : CreepModel
    plan : PartsPlan, optional
        The parts' technologies and tolerances (default :class:`~creepcomp.analog.parts.PartsPlan`).
    temperature_range : (float, float), optional
        Design over ``low .. high`` °C (the model's temperature law).
    tracking : {"none", "ntc"}
        Over a range: fixed parts, or NTC thermistors that follow the creep.
    topology : {"auto", "passive", "active"}
        With NTC tracking: the passive lead network, the active stage, or the passive one
        when it is practical.
    allow_impractical : bool
        Keep a design judged impractical (its reasons become warnings).
    **options
        :func:`~creepcomp.analog.sizing.size`'s arguments (``rule``, ``resistor_series`` ...).

    Returns
    -------
    NetworkDesign
        ``refused`` when impractical and not allowed (ideal values are never refused).

    Examples
    --------
    >>> from creepcomp.model import CreepModel
    >>> design = design_network(CreepModel(beta=(0.03,), tau=(45.0,)))
    >>> design.refused, design.verdict.practical, [r.ref for r in design.bom]
    (False, True, ['R1', 'C1', 'R2'])
    """
    from creepcomp.analog.bom import bom_rows
    from creepcomp.analog.practicality import find_way_out, judge

    plan = plan or PartsPlan()
    if temperature_range is not None:
        _check_tracking(model, tracking, topology)
    try:
        report = size(model, plan=plan, **options)
    except NoNetworkInRange as exc:
        if allow_impractical or exc.fixable:
            raise
        return NetworkDesign(model, options, plan, None, reasons=(str(exc),),
                             way_out=find_way_out(model, options, plan), span=temperature_range)
    at_reference, comparison = report, None
    if temperature_range is not None:
        report, comparison = size_over_range(report, temperature_range, tracking,
                                             options.get("rule", "exact"), topology)
    verdict = judge(report)
    if not verdict.practical and not allow_impractical and report.resistor_series is not None:
        way = (fixed_for_range(comparison, report) if comparison is not None else None) or \
            find_way_out(model, options, plan)
        return NetworkDesign(model, options, plan, report, at_reference, comparison, verdict,
                             reasons=tuple(verdict.reasons), way_out=way, span=temperature_range)
    rows = bom_rows(report.chosen, report.plan, {"R": report.resistor_series, "C": report.capacitor_series},
                    model)
    return NetworkDesign(model, options, plan, report, at_reference, comparison, verdict, tuple(rows),
                         span=temperature_range)


def _check_tracking(model: CreepModel, tracking: str, topology: str) -> None:
    from creepcomp.analog.over_temperature import TOPOLOGIES, check_tracking

    if topology not in TOPOLOGIES:
        raise InputError(f"--topology '{topology}': expected {', '.join(TOPOLOGIES)}")
    check_tracking(model, tracking, topology)


def size_over_range(report: SizingReport, span: tuple[float, float], tracking: str, rule: str,
                    topology: str = "auto"):
    """The comparison over the range, and the sizing report of the design to write."""
    from creepcomp.analog.over_temperature import compare_over_range
    from creepcomp.analog.quality import predict

    comparison = compare_over_range(report.model, report.chosen, *span, plan=report.plan,
                                    tracking=tracking, rule=rule,
                                    resistor_series=report.resistor_series or "E24",
                                    capacitor_series=report.capacitor_series or "E6",
                                    reference_warnings=report.warnings, topology=topology)
    chosen = comparison.written
    if chosen.key == "reference":
        return report, comparison
    quality = predict(report.model, chosen.network, report.chosen_quality.sweep_period)
    warnings = tuple(w for w in report.warnings if not w.startswith("high impedance")) + chosen.warnings
    written = dataclasses.replace(report, chosen=chosen.network, chosen_quality=quality, plan=chosen.plan,
                                  nearest=None, nearest_quality=None, parts=(), warnings=warnings)
    return written, comparison


def fixed_for_range(comparison, report: SizingReport):
    """The way out of an impractical tracking design: the fixed parts sized for the range,
    when they are practical (else None)."""
    from creepcomp.analog.practicality import WayOut, judge

    if comparison.chosen != "ntc":
        return None
    fixed = comparison.design("range")
    candidate = dataclasses.replace(report, chosen=fixed.network, plan=fixed.plan)
    verdict = judge(candidate)
    if not verdict.practical:
        return None
    return WayOut("size", {"tracking": "none"},
                  f"fixed parts sized for the range (worst {format_percent(fixed.prediction.worst)} "
                  f"at {fixed.prediction.worst_at:g} °C)", candidate, verdict)
