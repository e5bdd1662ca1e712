"""Each result's tables and plot, found by the result's type.

A result's ``tables()``, ``report()``, ``_repr_html_()`` and ``plot()`` (the
:class:`creepcomp.display.Shown` mixin) come here, inside the method; the command line prints
the same tables. One builder per result type: :func:`summary_of` and :func:`plot_of` choose by
the type's name, so that this module imports no result's module until a result asks.
"""

from __future__ import annotations

import math

from creepcomp.report.tables import Column, Summary, Table
from creepcomp.units import format_percent, format_quantity, format_time

__all__ = ["summary_of", "plot_of", "record_summary", "model_summary", "fit_tables", "fit_summary_of",
           "diagnosis_summary", "diagnosis_tables", "circuit_tables", "circuit_summary",
           "correction_summary", "correction_table", "sizing_summary", "bom_table", "over_range_summary",
           "verdict_lines", "network_design_summary", "design_summary", "comparison_table",
           "comparison_summary", "tolerance_summary", "monte_carlo_summary", "distribution_table",
           "sensitivity_table", "creep_test_summary", "creep_test_table", "creep_test_tables",
           "firmware_summary", "bound_table", "verification_summary", "describe_model", "network_table",
           "SHOWN_ZERO"]


def _of_type(table: dict, result, what: str):
    """The entry of ``table`` for the result's type or the nearest of its bases (by module
    and name, so that no result's module is imported here)."""
    for cls in type(result).__mro__:
        found = table.get(f"{cls.__module__}.{cls.__qualname__}")
        if found is not None:
            return found
    raise TypeError(f"{type(result).__name__} has no {what}")


def summary_of(result) -> Summary:
    """The :class:`~creepcomp.report.tables.Summary` of any result that shows itself."""
    return _of_type(SUMMARIES, result, "report")(result)


def plot_of(result, ax=None, **options):
    """Draw ``result`` into ``ax`` (None: a new figure) with its type's plot function and
    return the Axes. ``options``: that function's keywords."""
    from creepcomp.report import plots

    return getattr(plots, _of_type(PLOTS, result, "plot"))(result, ax=ax, **options)


# --- record and model --------------------------------------------------------------------------

def record_summary(record) -> Summary:
    """A record: its size and span, each column's range in its unit, its metadata."""
    step = float(record.time[1] - record.time[0]) if len(record) > 1 else float("nan")
    sampling = f"uniform, {format_quantity(step, 's')}" if record.is_uniform else "irregular"
    rows = []
    for name in ("time", "load", "signal", "temperature", "corrected"):
        values = getattr(record, name)
        if values is None:
            continue
        unit = "s" if name == "time" else "°C" if name == "temperature" else record.unit(name)
        rows.append((name, unit or "(none given)", format_quantity(float(values.min()), unit),
                     format_quantity(float(values.max()), unit)))
    tables = [Table.of("Columns", [Column("column", "left"), Column("unit", "left"), "min", "max"], rows)]
    meta = [(str(k), str(v)) for k, v in record.metadata.items()]
    if meta:
        tables.append(Table.of("Metadata", [Column("key", "left"), Column("value", "left")], meta))
    return Summary(f"Record {record.source}",
                   (f"{len(record)} samples over {format_time(record.duration)} ({sampling})",),
                   tuple(tables))


def describe_model(model) -> str:
    """One line: the creep terms (and the static maps around them)."""
    maps = "" if model.transfer is None else f"; {model.transfer.describe()}"
    if model.is_static:
        return f"static calibration (no creep terms){maps}"
    terms = ", ".join(f"{format_percent(b)} at {format_time(t)}" for b, t in zip(model.beta, model.tau))
    return (f"{model.n_terms} creep term{'s' if model.n_terms > 1 else ''} ({terms}); "
            f"beta0 = {format_percent(model.beta0)}{maps}")


def model_summary(model) -> Summary:
    """A creep model: its terms, gain and offset, temperature law and extensions."""
    rows = [(f"{k}", format_percent(b, 4), format_quantity(t, "s")) for k, (b, t) in
            enumerate(zip(model.beta, model.tau))]
    lines = [describe_model(model),
             f"gain {model.gain:.6g} signal units per load unit, offset {model.offset:.6g} signal units"
             if model.transfer is None else
             f"gain {model.gain:.6g} per unit of f(load), offset {model.offset:.6g}: both in the signal map's linear domain"]
    if model.temperature is not None:
        law = model.temperature
        lines.append(f"temperature: {law.law} law about {law.reference:g} °C")
    if model.extensions:
        lines.append("extensions: " + ", ".join(str(k) for k in model.extensions))
    if model.load_filter is not None:
        lines.append(f"load filter: {model.load_filter.describe()}; the compensated signal is not filtered")
    tables = (Table.of("Creep terms", ["term", "beta", "tau"], rows),) if rows else ()
    if model.transfer is not None:
        maps = [(side, m.form, ", ".join(f"{k} {v:.6g}" for k, v in m.parameters.items() if k not in ("x", "y"))
                 or f"{len(m.parameters['x'])} knots")
                for side, m in (("load map f (load -> creep input)", model.transfer.load_map),
                                ("signal map h (signal -> linear domain)", model.transfer.signal_map))
                if m is not None]
        tables += (Table.of("Static maps", ["map", "form", "parameters"], maps),)
    return Summary("Creep model", tuple(lines), tables)


# --- fit ---------------------------------------------------------------------------------------

def fit_tables(result, signal_unit: str = "", load_unit: str = "", fixed: bool = False) -> tuple[Table, Table]:
    """The number-of-terms table and the model table of a Prony fit (``creepcomp fit``)."""
    from creepcomp.fit import BIC_STRONG, HELDOUT_Z, term_table

    su, lu, data, fit = signal_unit, load_unit, result.data, result.fit
    rows = []
    for i, s in enumerate(result.steps):
        ev = s.evidence
        rows.append((str(s.n_terms), f"{s.fit.residual_rms:.4g} {su}".strip(),
                     f"{s.fit.heldout.rms:.4g} {su}".strip() if s.fit.heldout else "-",
                     f"{s.fit.bic:.1f}", f"{ev.delta_bic:+.1f}" if ev else "-",
                     f"{ev.heldout_z:.1f}" if ev else "-", "chosen" if i == result.chosen else ""))
    orders = Table.of("Number of creep terms (fixed)" if fixed else
                      f"Number of creep terms: added while BIC drops by {BIC_STRONG:g}+ and "
                      f"held-out blocks are predicted better by {HELDOUT_Z:g}+ sigma",
                      ("terms", "residual RMS", "held-out RMS", "BIC", "ΔBIC", "held-out z", ""), rows)
    terms = term_table(fit)
    gain = fit.estimate(lambda v: v["gain"])
    rows = [(f"gain ({su or 'signal'} per {lu or 'load unit'})", f"{gain[0]:.6g}", f"{gain[1]:.2g}")]
    if data.fixed_offset:
        rows.append(("offset", "0 (fixed: the load never changes)", ""))
    else:
        off = fit.estimate(lambda v: v["offset"])
        rows.append((f"offset ({su or 'signal units'})", f"{off[0]:.6g}", f"{off[1]:.2g}"))
    for k, t in enumerate(terms):
        rows.append((f"beta[{k}]", format_percent(t["beta"], 4), format_percent(t["beta_sigma"], 2)))
        rows.append((f"tau[{k}]", format_quantity(t["tau"], "s"), format_quantity(t["tau_sigma"], "s", 2)))
    if fit.structure.effects:
        from creepcomp.diagnose.effects import flow_effect

        flow = flow_effect()
        if flow is not None and fit.structure.has(flow.name):
            rate = flow.rate(fit)
            rows.append(("viscous flow rate (1/s, of the instantaneous signal)", f"{rate[0]:.4g}",
                         f"{rate[1]:.2g}"))
    n = fit.structure.n_terms
    model = Table.of(f"Model: {n} creep term{'s' if n > 1 else ''}, "
                     f"beta0 = {format_percent(sum(t['beta'] for t in terms))}",
                     ("", "value", "± 1 sigma"), rows)
    return orders, model


def fit_summary_of(result) -> Summary:
    """A Prony fit: the record fitted, the number of terms tried and the chosen model."""
    data, fit = result.data, result.fit
    scale = data.signal_scale
    su = data.units.get("signal", "signal units")
    line = (f"residual RMS {fit.residual_rms:.4g} {su} ({format_percent(fit.residual_rms / scale)} "
            "of the signal's range)")
    if fit.heldout is not None:
        line += f"; held-out {fit.heldout.rms:.4g} {su} ({format_percent(fit.heldout.rms / scale)})"
    return Summary(f"Prony fit of {data.source}",
                   (f"{data.n} samples over {format_time(data.duration)}", line),
                   fit_tables(result, su, data.units.get("load", "")))


# --- diagnosis ---------------------------------------------------------------------------------

#: What a table prints for a number that is missing or not finite (the JSON's null): one mark
#: for the terminal and the HTML tables alike (:func:`creepcomp.report.common.format_cell`).
MISSING = "–"


def _num(x, spec: str) -> str:
    """``x`` formatted by ``spec``, or :data:`MISSING` for None and non-finite values (never
    ``nan``)."""
    return MISSING if x is None or not math.isfinite(x) else format(x, spec)


def _ratio(x) -> str:
    return _num(x, ".3g")


def diagnosis_tables(d, units: dict | None = None) -> tuple[Table, ...]:
    """The findings, candidates and gain tables of a sensor diagnosis (``creepcomp diagnose``)."""
    from creepcomp.fit import BIC_STRONG, HELDOUT_Z

    units = units or {}
    su = units.get("signal", "")
    tables = []
    if d.findings:
        cols = [Column(c, "right" if c.startswith(("Δ", "held")) else "left")
                for c in ("effect", "parameters (± 1 sigma)", "ΔBIC", "held-out RMS ratio", "held-out z")]
        tables.append(Table.of("Findings (most important first)", cols,
                               [(f.effect, f.parameters_text(units), _num(f.evidence.delta_bic, ".1f"),
                                 _num(f.evidence.heldout_rms_ratio, ".3g"), _num(f.evidence.heldout_z, ".1f"))
                                for f in d.findings]))
    cols = [Column(c, "right" if c in ("step", "ΔBIC", "held-out z") else "left")
            for c in ("step", "effect", "ΔBIC", "held-out z", "outcome")]
    tables.append(Table.of(f"Candidates (accepted: ΔBIC <= -{BIC_STRONG:g} and held-out z >= {HELDOUT_Z:g})",
                           cols, [(str(t.step), t.effect, _num(t.delta_bic, ".1f"),
                                   _num(t.evidence.heldout_z, ".1f") if t.evidence else MISSING, t.outcome)
                                  for t in d.trials]))
    b, e, g = d.baseline, d.extended, d.gain
    rows = [(f"held-out residual RMS ({su or 'signal units'})",
             _num(b.heldout.rms, ".4g") if b.heldout else MISSING, _num(e.heldout.rms, ".4g") if e.heldout else MISSING,
             _ratio(g.get("heldout_rms_ratio")))]
    if g.get("correction_error_ratio") is not None:
        rows.append((f"corrected signal vs load, RMS error ({su or 'signal units'})",
                     _num(g['correction_error_baseline'], ".4g"), _num(g['correction_error_extended'], ".4g"),
                     _ratio(g["correction_error_ratio"])))
    elif g.get("correction_unsettled"):
        rows.append((f"corrected signal vs load, RMS error ({su or 'signal units'})",
                     _num(g['correction_error_baseline'], ".4g"), "not measured", MISSING))
    tables.append(Table.of("Gain", ("", "baseline", "extended", "ratio"), rows))
    return tuple(tables)


def diagnosis_summary(d) -> Summary:
    """A sensor diagnosis: the cause, the residual against the noise floor, the tables."""
    units = dict(getattr(d.data, "units", {}))
    su = units.get("signal", "signal units")
    lines = [f"{d.data.n} samples over {format_time(d.data.duration)}",
             f"baseline residual RMS {d.baseline.residual_rms:.4g} {su}, extended "
             f"{d.extended.residual_rms:.4g} {su}"]
    if d.floor is not None:
        lines.append(f"noise floor {d.floor.rms:.4g} {su} ({d.floor.method}); misfit ratio "
                     f"baseline {_ratio(d.misfit_ratio(d.baseline))}, extended "
                     f"{_ratio(d.misfit_ratio(d.extended))}")
    notes = tuple(f"{f.effect}: {f.note}" for f in d.findings if f.note)
    return Summary(f"Diagnosis of {d.data.source}: cause {d.cause}", tuple(lines),
                   diagnosis_tables(d, units), notes)


def circuit_tables(cd) -> dict:
    """The circuit side's tables (``creepcomp diagnose --design``) by name: ``findings`` and
    ``as_built`` (when it found an effect), ``fixes`` (when it has single-part fixes)."""
    from creepcomp.report.circuit_diagnosis import element_text, elements, quantity

    out = {}
    if cd.findings:
        cols = [Column(c, "right" if c.startswith(("Δ", "held")) else "left")
                for c in ("effect", "part", "parameters (± 1 sigma)", "ΔBIC", "held-out RMS ratio", "held-out z")]
        out["findings"] = Table.of("Circuit findings (most important first)", cols, [
            (f.effect, f.part or MISSING, "; ".join(f"{k} = {quantity(k, v)} ± {quantity(k, f.uncertainty.get(k))}"
                                                for k, v in f.parameters.items()),
             _num(f.evidence.delta_bic, ".1f"), _num(f.evidence.heldout_rms_ratio, ".3g"),
             _num(f.evidence.heldout_z, ".1f"))
            for f in cd.findings])
        design, built = elements(cd.baseline.network), elements(cd.extended.network)
        out["as_built"] = Table.of("As-built network", [Column("element", "left"), "design", "as built"],
                                   [(label, element_text(*design[label]), element_text(*built[label]))
                                    for label in design
                                    if design[label][1] is not None or built[label][1] is not None])
    if cd.fixes:
        cols = [Column(c, "left" if c in ("part", "note") else "right")
                for c in ("part", "as built", "replace by", "peak residual creep", "note")]
        out["fixes"] = Table.of("Fix: single-part changes, best first", cols, [
            (f.part, format_quantity(f.value_from, _fix_unit(f.part)),
             f"{format_quantity(f.value_to, _fix_unit(f.part))} ({f.series})", format_percent(f.residual_creep_peak),
             f.note) for f in cd.fixes])
    return out


def _fix_unit(part: str) -> str:
    return "F" if part.startswith("C") else "Ω"


def circuit_summary(cd) -> Summary:
    """A circuit diagnosis: the verdict, the fits against the noise floor, the findings, the
    as-built network and the fixes."""
    fits = Table.of("Fits", [Column("network", "left"), "residual RMS", "misfit ratio (of the noise floor)", "BIC"],
                    [(name, format_quantity(fit.rms, "V"), _ratio(cd.misfit(fit)), f"{fit.bic:.1f}")
                     for name, fit in (("nominal", cd.baseline), ("as built", cd.extended))])
    rc = cd.residual_creep
    return Summary(f"Circuit diagnosis of {cd.data.source}: cause {cd.cause}", (cd.verdict(),),
                   (fits,) + tuple(circuit_tables(cd).values()),
                   (f"peak residual creep of a load step: design {format_percent(rc['nominal'])}, "
                    f"as built {format_percent(rc['as_built'])}",))


# --- correction --------------------------------------------------------------------------------

def _value(x, unit: str) -> str:
    return "n/a" if x is None else format_quantity(x, unit) if unit else f"{x:.4g}"


def correction_table(before, after, unit: str, fitted: tuple | None = None) -> Table:
    """The creep error of the raw and the compensated signal (``creepcomp correct``)."""
    rows = [("peak", _value(before.peak, unit), _value(after.peak, unit)),
            ("peak (of full scale)", format_percent(before.peak_fraction), format_percent(after.peak_fraction)),
            ("  at", format_quantity(before.peak_time, "s"), format_quantity(after.peak_time, "s")),
            ("RMS", _value(before.rms, unit), _value(after.rms, unit)),
            ("RMS (of full scale)", format_percent(before.rms_fraction), format_percent(after.rms_fraction))]
    if fitted is not None and fitted[1] is not None:
        rows.append(("RMS, load scaled by least squares", _value(fitted[0], unit), _value(fitted[1], unit)))
    return Table.of("Creep error against the load reference", (Column("", "left"), "raw signal", "compensated"),
                    rows)


def correction_summary(c) -> Summary:
    """A corrected record: the creep error before and after."""
    unit = c.record.unit("signal")
    lines = [f"{c.method} correction, {describe_model(c.model)}",
             f"full scale {_value(c.after.full_scale, unit or 'signal units')}"]
    footer = (f"peak creep error reduced {c.reduction:.3g}-fold",) if c.reduction is not None else ()
    return Summary(f"Correction of {c.record.source}", tuple(lines),
                   (correction_table(c.before, c.after, unit),), footer)


# --- sizing and designs ------------------------------------------------------------------------

def _part_unit(kind: str) -> str:
    return "Ω" if kind == "R" else "F"


def _peak_time(q) -> str:
    if q.residual_creep_peak < 1e-12:
        return "-"
    return "settled" if math.isinf(q.residual_creep_peak_time) else f"{q.residual_creep_peak_time:.4g} s"


def network_table(network, title: str = "Parts") -> Table:
    """A network's parts and values."""
    return Table.of(title, (Column("part", "left"), "value"),
                    [(label, format_quantity(v, _part_unit(kind))) for label, kind, v in network.parts()])


def sizing_summary(report, title: str | None = None) -> Summary:
    """A sizing report (``creepcomp size``): the parts, the predicted quality of each design,
    the search and the warnings."""
    net = report.chosen
    snapped = report.resistor_series is not None
    if snapped:
        parts = Table.of("Parts", (Column("part", "left"), "ideal",
                                   f"chosen ({report.resistor_series} R, {report.capacitor_series} C)",
                                   "snap error", "peak residual creep if only this part snapped"),
                         [(p.label, format_quantity(p.ideal, _part_unit(p.kind)),
                           format_quantity(p.chosen, _part_unit(p.kind)), f"{100 * p.deviation:+.2f} %",
                           format_percent(p.residual_if_only_this)) for p in report.parts])
    else:
        parts = Table.of("Parts", (Column("part", "left"), "ideal"),
                         [(label, format_quantity(v, _part_unit(kind))) for label, kind, v in net.parts()])
    columns = [("ideal parts", report.ideal_quality)]
    if snapped:
        columns.append(("chosen parts", report.chosen_quality))
        if report.nearest_quality is not None:
            c_near = max(v for _, k, v in report.nearest.parts() if k == "C")
            columns.append((f"nearest values (C = {format_quantity(c_near, 'F')})", report.nearest_quality))
    columns.append(("uncorrected", report.uncorrected_quality))
    qs = [q for _, q in columns]
    period = report.chosen_quality.sweep_period
    predicted = Table.of("Predicted (exact transfer functions)",
                         [Column("", "left")] + [name for name, _ in columns],
                         [["residual creep, peak (of a load step)"] + [format_percent(q.residual_creep_peak)
                                                                       for q in qs],
                          ["  at (s after the step)"] + [_peak_time(q) for q in qs],
                          ["residual creep, final"] + [format_percent(q.residual_creep_final) for q in qs],
                          [f"hysteresis, ±FS sweep of {period:.4g} s (of FS)"]
                          + [format_percent(q.hysteresis) for q in qs]])
    footer = ()
    if report.nearest is not None and snapped:
        footer = (f"searched {report.candidates_evaluated} part combinations; nearest-value parts: "
                  + ", ".join(f"{label} {format_quantity(v, _part_unit(k))}"
                              for label, k, v in report.nearest.parts()),)
    lines = (f"{report.rule} rule, {net.topology} network; {describe_model(report.model)}",
             f"source resistance {format_quantity(net.source_resistance, 'Ω')}, "
             f"load resistance {format_quantity(net.load_resistance, 'Ω')}")
    return Summary(title or "creepcomp size", lines, (parts, predicted), footer, tuple(report.warnings))


def bom_table(rows) -> Table:
    """The bill of materials (``creepcomp size``)."""
    from creepcomp.analog.bom import BOM_COLUMNS

    return Table.of("Bill of materials (tc in ppm/K)",
                    [Column(c, "right" if c in ("value", "tolerance", "tc") else "left") for c in BOM_COLUMNS],
                    [[getattr(r, c) for c in BOM_COLUMNS] for r in rows])


def over_range_summary(comparison) -> Summary:
    """The designs over a temperature range: the worst cases, the residual at every
    temperature, the written design's parts (its thermistors), and its warnings."""
    designs = comparison.designs
    bare = designs[0].prediction
    k = max(range(len(bare.uncorrected)), key=bare.uncorrected.__getitem__)
    worst = Table.of("Worst case over the range",
                     [Column("design", "left"), "worst peak residual creep", "at", "written"],
                     [(d.label, format_percent(d.prediction.worst), f"{d.prediction.worst_at:g} °C",
                       "yes" if d.key == comparison.chosen else "") for d in designs]
                     + [("uncorrected", format_percent(bare.uncorrected[k]), f"{bare.temperatures[k]:g} °C", "")])
    per_t = Table.of("Peak residual creep of a full-scale step at each temperature",
                     ["°C"] + [d.label.split(")")[0] + ")" for d in designs] + ["uncorrected"],
                     [[f"{t:g}"] + [format_percent(d.prediction.peak_residual[i]) for d in designs]
                      + [format_percent(bare.uncorrected[i])] for i, t in enumerate(bare.temperatures)])
    written = comparison.written
    parts = Table.of(f"Written design: {written.label}",
                     [Column("part", "left"), "value at 25 °C", Column("made of", "left")],
                     [(label, format_quantity(v, _part_unit(kind)), _made_of(written.plan, label, kind))
                      for label, kind, v in written.network.parts()])
    return Summary(f"Over {comparison.low:g} .. {comparison.high:g} °C", (designs[0].prediction.note,),
                   (worst, per_t, parts), warnings=tuple(written.warnings))


def _made_of(plan, label: str, kind: str) -> str:
    use = plan.thermistors.get(label)
    if use is None:
        return f"{plan.resistor if kind == 'R' else plan.capacitor}"
    made = f"NTC {use.part} (R25 = {format_quantity(use.r25, 'Ω')}, B = {use.b:g} K)"
    if use.series:
        made += f" + {format_quantity(use.series, 'Ω')} in series"
    if use.parallel is not None:
        made += f", {format_quantity(use.parallel, 'Ω')} across"
    return made


def verdict_lines(design) -> tuple[str, ...]:
    """What the verdict on a written design says: practical with its figures (an active
    stage's op amps and offset too), or each reason it is not."""
    v, report = design.verdict, design.sizing
    if not v.practical:
        why = "ideal values" if design.ideal_values else "--allow-impractical"
        return tuple(f"impractical ({why}): {reason}" for reason in v.reasons)
    leak = format_quantity(v.to_dict()["leakage_to_ground"], "Ω")
    figures = (f"the peak residual creep is {format_percent(v.leakage_peak)}, at the worst tolerance "
               f"corner {format_percent(v.worst_case_peak)} (uncorrected {format_percent(v.uncorrected_peak)})")
    if report.chosen.topology != "active":
        return (f"practical: every part is made; with a {leak} leakage path {figures}",)
    from creepcomp.analog.active import OP_AMP, output_offset

    temps = design.span if design.span is not None else (25.0,)
    offset = max(output_offset(report.chosen, report.plan, t) for t in temps)
    return (f"practical: every part is made; with the capacitors' insulation and a {leak} board path "
            f"across each {figures}",
            f"op amps: {OP_AMP.text()}; at those limits their constant output offset is at most "
            f"{format_quantity(offset, 'V')} over the range (tared, not creep)")


def network_design_summary(design) -> Summary:
    """A network design (``creepcomp size``): the sizing, the designs over the range, the
    bill of materials and the verdict; a refused design's reasons and the way out."""
    refusal = ()
    if design.refused:
        refusal = tuple(f"impractical: {reason}" for reason in design.reasons) + (
            f"way out: {design.way_out.description}",)
    if design.sizing is None:
        return Summary("creepcomp size: refused", (describe_model(design.model),), (), refusal)
    sizing = sizing_summary(design.at_reference)
    tables, warnings = list(sizing.tables), list(sizing.warnings)
    lines = list(sizing.lines)
    if design.comparison is not None:
        over = over_range_summary(design.comparison)
        lines.append(f"{over.heading}: {over.lines[0]}")
        tables += over.tables
        warnings += over.warnings
    if design.bom:
        tables.append(bom_table(design.bom))
    footer = sizing.footer + (refusal or verdict_lines(design))
    return Summary(sizing.heading, tuple(lines), tuple(tables), footer, tuple(warnings))


def design_summary(design) -> Summary:
    """A design file: the creep it cancels and the network's parts."""
    net = design.network
    lines = [describe_model(design.model), f"{net.topology} network"]
    return Summary("Design", tuple(lines), (network_table(net),))


# --- verification ------------------------------------------------------------------------------

def _peak(comparison, which: str) -> str:
    e = comparison.residual(which)
    if e is None:
        return "n/a"
    k = int(abs(e).argmax())
    if abs(e[k]) < 1e-12:
        return format_percent(abs(float(e[k])))
    return f"{format_percent(abs(float(e[k])))} at {comparison.reference.time[k]:.4g} s"


def comparison_table(c) -> Table:
    """python-control against ngspice (``creepcomp simulate``): the residual creep of a
    program, or a record's output range and end (V)."""
    import numpy as np

    ran = c.spice is not None
    cols = [Column("", "left"), "python-control", "ngspice"]
    if c.reference.instantaneous is not None:
        d = c.to_dict()
        return Table.of("", cols, [
            ("residual creep, peak (of full scale)", _peak(c, "reference"), _peak(c, "spice") if ran else "not run"),
            ("residual creep, final", format_percent(d["python_control"]["residual_creep_final"]),
             format_percent(d["ngspice"].get("residual_creep_final")) if ran else "not run")])

    def volts(w, f):
        return format_quantity(float(f(w.output)), "V") if w is not None else "not run"

    return Table.of("", cols, [("output range", volts(c.reference, np.ptp), volts(c.spice, np.ptp)),
                               ("output at the end", volts(c.reference, lambda y: y[-1]),
                                volts(c.spice, lambda y: y[-1]))])


def comparison_summary(c) -> Summary:
    """An ngspice comparison: residual creep and the agreement of the two simulators."""
    ran = c.spice is not None
    lines = [f"full scale {format_quantity(c.full_scale, 'V')}, H(inf) = {c.hf_gain:.6g}, "
             f"reference {c.reference_method}",
             "largest |ngspice - python-control|: " + (f"{c.agreement_max_abs:.3g} of full scale" if ran
                                                        else f"not run ({c.unavailable})")]
    return Summary(f"Simulation of {c.drive}" + ("" if c.temperature is None else f" at {c.temperature:g} °C"),
                   tuple(lines), (comparison_table(c),))


_METRICS = {"peak": "residual creep, peak", "final": "residual creep, final (abs)", "hysteresis": "hysteresis"}


def distribution_table(result, nominal=None) -> Table:
    """Each metric's percentiles over a Monte Carlo run (``nominal``: the nominal design's
    figures in a first column)."""
    cols = [Column("", "left")] + (["nominal"] if nominal is not None else []) + ["p50", "p95", "p99", "max"]
    rows = []
    for m in ("peak", "final", "hysteresis"):
        first = [format_percent(nominal.get(m)[0])] if nominal is not None else []
        rows.append([_METRICS[m]] + first + [format_percent(v) for v in result.percentiles(m).values()])
    return Table.of("Distribution (% of FS)", cols, rows)


def monte_carlo_summary(r) -> Summary:
    """A Monte Carlo run: samples, time and the distribution of the metrics."""
    lines = [f"{r.n:,} samples, seed {r.seed}, {r.seconds:.2f} s"]
    if r.limit is not None:
        y, se = r.yield_against(r.limit, r.limit_metric)
        lines.append(f"yield against {_METRICS[r.limit_metric]} ≤ {format_percent(r.limit)}: "
                     f"{100 * y:.2f} % (± {100 * se:.2f} %)")
    return Summary("Monte Carlo run", tuple(lines), (distribution_table(r),))


def sensitivity_table(sensitivities) -> Table:
    """Each factor's share of the spread and the p99 when only it varies."""
    return Table.of("Sensitivity", [Column("factor", "left"), "share of the spread", "p99 when only it varies"],
                    [(s.factor, f"{100 * s.share:.1f} %", format_percent(s.p99_alone)) for s in sensitivities])


def tolerance_summary(report) -> Summary:
    """A tolerance analysis (``creepcomp mc``): distribution, yield, worst case, sensitivity."""
    r = report.result
    lines = [f"{r.n:,} samples, seed {r.seed}, {r.seconds:.2f} s"]
    if report.limit is not None:
        y, se = r.yield_against(report.limit, report.metric)
        lines.append(f"yield against {_METRICS[report.metric]} ≤ {format_percent(report.limit)}: "
                     f"{100 * y:.2f} % (± {100 * se:.2f} %)")
    if report.worst is not None:
        w = report.worst
        lines.append(f"worst case of {_METRICS[w.metric]}: {format_percent(w.value)} ({w.method})")
    tables = [distribution_table(r, report.nominal)]
    if report.sensitivities:
        tables.append(sensitivity_table(report.sensitivities))
    return Summary("Tolerance analysis", tuple(lines), tuple(tables))


#: Names of the readings in the creep test's margin column.
_SHORT = {"creep_30min": "30 min", "creep_20_30min": "20-30 min", "dr": "DR"}
#: Readings below this (fraction of FS) are round-off, shown as 0.
SHOWN_ZERO = 1e-12


def _v(value: float, n_max: int) -> str:
    return "0" if abs(value) < SHOWN_ZERO else f"{value * n_max:.3g}"


def creep_test_table(title: str, rows: list, limits) -> Table:
    """The readings of a creep test at each temperature, in verification intervals v."""
    cols = [Column(c, "left" if c == "result" else "right")
            for c in ("°C", "creep 30 min (v)", "creep 20-30 min (v)", "DR (v)", "DR at 30 min (v)",
                      "result", "smallest margin (v)")]
    out = []
    for r in rows:
        worst = min(r["margin"], key=lambda k: r["margin"][k] / getattr(limits, k))
        out.append((f"{r['temperature']:g}", *(_v(r[k], limits.n_max) for k in
                                              ("creep_30min", "creep_20_30min", "dr", "dr_30min")),
                    "pass" if r["pass"] else "FAIL", f"{_SHORT[worst]}: {r['margin'][worst] * limits.n_max:+.3g}"))
    out.append(("limit", *(_v(v, limits.n_max) for v in (limits.creep_30min, limits.creep_20_30min, limits.dr)),
                "–", "", ""))
    return Table.of(title, cols, out, marks={"pass": "green", "FAIL": "red"})


def creep_test_tables(result) -> tuple[Table, ...]:
    """The readings at each temperature, and those of each variant (the corrector fixed at
    the reference temperature ...)."""
    lim = result.limits
    tables = [creep_test_table(f"Readings in verification intervals (1 v = {100 * lim.interval:.4g} % of FS)",
                               result.rows, lim)]
    for key, rows in result.variants.items():
        title = {"corrector_at_reference": "Corrector fixed at the reference temperature "
                                           f"({result.settings.get('reference_temperature')} °C)"}.get(key, key)
        tables.append(creep_test_table(title, rows, lim))
    return tuple(tables)


def creep_test_summary(result) -> Summary:
    """A creep test: the class, and each temperature's readings against its limits."""
    lim = result.limits
    lines = (f"target {result.target}; OIML R 60 class {lim.label} (n_max = {lim.n_max}, "
             f"v = {100 * lim.interval:.4g} % of FS); {'pass' if result.passed else 'FAIL'}",)
    return Summary("Creep test", lines, creep_test_tables(result), tuple(result.notes))


def firmware_summary(fw) -> Summary:
    """Generated firmware: method, precision, rate and the proven error bound."""
    rate = (format_quantity(fw.rate, "Hz") if fw.max_interval is None else
            f"dt step (up to {format_quantity(fw.max_interval, 's')})")
    lines = (f"{fw.method} method, {fw.precision}, {rate}, full scale {fw.full_scale:.6g} signal units; "
             f"files {', '.join(fw.filenames)}",)
    return Summary(f"Firmware {fw.name}", lines, () if fw.bound is None else (bound_table(fw.bound),))


def bound_table(bound) -> Table:
    """The parts of a firmware's proven error bound and their sum (``creepcomp firmware``)."""
    rows = [(part, f"{value:.3e}") for part, value in bound.terms.items()]
    rows.append(("bound", f"{bound.total_fs:.3e}"))
    return Table.of("Proven worst-case error against the float64 corrector",
                    [Column("part", "left"), "of full scale"], rows, marks={"bound": "bold"})


def maps_bound_table(firmware, unit: str = "") -> Table:
    """The proven bound of a corrector with static maps, stage by stage (``firmware``)."""
    maps = firmware.maps
    rows = [(part, f"{value:.3e}") for part, value in maps["terms"].items()]
    unit = unit or "signal units"
    rows.append(("compensated signal", f"{maps['bound_signal']:.3e} {unit} "
                                       f"({firmware.bound.total_fs:.3e} of full scale)"))
    rows.append(("load", f"{maps['bound_load']:.3e} load units"))
    return Table.of("Proven worst-case error against the float64 compensate and estimate_load",
                    [Column("part (in the units of its stage)", "left"), "error"], rows,
                    marks={"compensated signal": "bold", "load": "bold"})


def verification_summary(v) -> Summary:
    """A firmware check: the C corrector's largest error against its bound, speed and size."""
    rows = [("samples", f"{v.samples}"),
            ("largest error (of full scale)", f"{v.max_error_fs:.3e}"),
            ("proven bound (of full scale)", "none" if v.bound_fs is None else f"{v.bound_fs:.3e}"),
            ("time per sample", format_quantity(v.ns_per_sample * 1e-9, "s")),
            ("code and constant data", f"{v.object_bytes} bytes")]
    return Summary("Firmware check: " + ("within the bound" if v.passed else "ABOVE THE BOUND"), (),
                   (Table.of("", [Column("", "left"), "value"], rows),))


# --- signal path and recommendation ---------------------------------------------------------

def members_table(candidates, chosen: str, split_time, load_range: float, load_unit: str = "") -> Table:
    """Each member of the signal-path family with its held-out load error (``diagnose``'s
    recommendation, ``fit --transfer auto``)."""
    def percent(x):
        return f"{100 * x:.3g} %" if math.isfinite(x) else MISSING

    rows = []
    for c in candidates:
        windows = " / ".join(percent(w) for w in c.windows) if c.windows else MISSING
        rows.append((c.name, percent(c.heldout_load_rms), windows,
                     "chosen" if c.name == chosen else (c.reason or "")))
    unit = f" {load_unit}" if load_unit else ""
    where = f"from {split_time:.4g} s, " if split_time is not None else ""
    return Table.of(f"Load given back on held-out data ({where}each member fitted before it): RMS error, "
                    f"of the load range ({load_range:.4g}{unit})",
                    [Column("member", "left"), "score", "earlier / last window", Column("", "left")],
                    rows, marks={"chosen": "bold"})


def signal_path_summary(fit) -> Summary:
    """A signal-path fit: its members and the model chosen (``creepcomp fit --transfer auto``)."""
    model = model_summary(fit.model)
    filtered = ()
    if fit.model.load_filter is not None:
        filtered = (f"held-out score with the load filter: {100 * fit.filtered_load_rms:.3g} % of the load "
                    f"range (without: {100 * fit.candidate(fit.chosen).heldout_load_rms:.3g} %)",)
    return Summary(f"Signal path: {fit.chosen}", (f"fitted in {fit.seconds:.3g} s",) + model.lines + filtered,
                   (members_table(fit.candidates, fit.chosen, fit.split_time, fit.load_range,
                                  fit.units.get("load", "")),) + model.tables)


def recommendation_summary(rec) -> Summary:
    """A diagnosis's recommendation: the members, the model written and why."""
    tables = (members_table(rec.candidates, rec.chosen, rec.split_time, rec.load_range),) if rec.candidates else ()
    notes = tuple(f"not recommended: {name}: {why}" for name, why in rec.refused.items())
    return Summary(f"Recommended: the {rec.which} model", (rec.reason,), tables, notes)


SUMMARIES = {
    "creepcomp.fit.signal_path.SignalPathFit": signal_path_summary,
    "creepcomp.diagnose.recommend.Recommendation": recommendation_summary,
    "creepcomp.io.records.Record": record_summary,
    "creepcomp.model.CreepModel": model_summary,
    "creepcomp.fit.prony.PronyResult": fit_summary_of,
    "creepcomp.diagnose.sensor.Diagnosis": diagnosis_summary,
    "creepcomp.diagnose.circuit.CircuitDiagnosis": circuit_summary,
    "creepcomp.digital.correction.Correction": correction_summary,
    "creepcomp.analog.sizing.SizingReport": sizing_summary,
    "creepcomp.analog.network_design.NetworkDesign": network_design_summary,
    "creepcomp.io.jsonfiles.Design": design_summary,
    "creepcomp.verify.compare.Comparison": comparison_summary,
    "creepcomp.verify.montecarlo.MonteCarloResult": monte_carlo_summary,
    "creepcomp.verify.tolerance_analysis.ToleranceReport": tolerance_summary,
    "creepcomp.verify.creep_test.CreepTestResult": creep_test_summary,
    "creepcomp.digital.firmware.Firmware": firmware_summary,
    "creepcomp.digital.firmware_check.Verification": verification_summary,
}

#: Each result type's function in :mod:`creepcomp.report.plots`.
PLOTS = {
    "creepcomp.fit.signal_path.SignalPathFit": "members_plot",
    "creepcomp.diagnose.recommend.Recommendation": "members_plot",
    "creepcomp.io.records.Record": "record_plot",
    "creepcomp.model.CreepModel": "model_plot",
    "creepcomp.fit.prony.PronyResult": "fit_result_plot",
    "creepcomp.diagnose.sensor.Diagnosis": "diagnosis_plot",
    "creepcomp.diagnose.circuit.CircuitDiagnosis": "circuit_plot",
    "creepcomp.digital.correction.Correction": "correction_plot",
    "creepcomp.analog.sizing.SizingReport": "sizing_plot",
    "creepcomp.analog.network_design.NetworkDesign": "network_design_plot",
    "creepcomp.io.jsonfiles.Design": "design_plot",
    "creepcomp.verify.compare.Comparison": "comparison_plot",
    "creepcomp.verify.montecarlo.MonteCarloResult": "monte_carlo_plot",
    "creepcomp.verify.tolerance_analysis.ToleranceReport": "tolerance_plot",
    "creepcomp.verify.creep_test.CreepTestResult": "creep_test_plot",
    "creepcomp.digital.firmware.Firmware": "firmware_plot",
    "creepcomp.digital.firmware_check.Verification": "verification_plot",
}
