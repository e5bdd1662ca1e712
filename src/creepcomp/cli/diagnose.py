"""``creepcomp diagnose``: what the simulation gets wrong, the cause, the extended model, the gain."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Optional

import typer

from creepcomp.errors import InputError
from creepcomp.io.outputs import check_outputs
from creepcomp.units import format_percent
from creepcomp.cli.common import (api_default, app, console, count_option, print_json, progress_bar,
                                  read_checked_design)
from creepcomp.io.records import read_record
from creepcomp.cli.fit import (COLUMNS_HELP, INITIAL_TEXT, describe_record,
    load_reduced, record_options, SHEET_OPTION, TAXEL_OPTION)

if TYPE_CHECKING:
    from creepcomp.diagnose import CircuitDiagnosis, Diagnosis


@app.command("diagnose")
def diagnose_command(
    record_path: Path = typer.Argument(..., metavar="RECORD", help="Measured record (CSV, docs/record-format.md)."),
    design: Optional[Path] = typer.Option(None, "--design", metavar="FILE",
                                          help="Design file of the network that produced 'corrected' "
                                               "(overrides the record's '# design:' line): the circuit "
                                               "side is diagnosed too."),
    columns: Optional[str] = typer.Option(None, "--columns", metavar="MAP", help=COLUMNS_HELP),
    delimiter: Optional[str] = typer.Option(None, "--delimiter", metavar="CHAR",
                                            help="Field delimiter (default: detected; 'tab' for tabs)."),
    duplicate_times: str = typer.Option(api_default(read_record, "duplicate_times"),
                                        "--duplicate-times", metavar="error|mean",
                                        help="Repeated time stamps: an error, or average the rows."),
    initial: str = typer.Option("free", "--initial", metavar="free|relaxed|settled",
                                help="Creep state at the first sample: fitted, zero, or settled."),
    load_step_at: Optional[str] = typer.Option(None, "--load-step-at", metavar="TIME",
                                               help="Time of a single load step before the first "
                                                    "sample (creep tests), e.g. 0."),
    effects: Optional[str] = typer.Option(None, "--effects", metavar="LIST",
                                          help="Candidate effects to try, comma-separated (default: all)."),
    output: Optional[Path] = typer.Option(None, "-o", "--output", metavar="DIR",
                                          help="Write report.html, diagnosis.json and the extended "
                                               "model.json (and with a design, as-built-design.json) "
                                               "into DIR."),
    spice_check: bool = typer.Option(True, "--spice-check/--no-spice-check",
                                     help="Run the as-built network in ngspice on the record."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object (docs/diagnosis.md)."),
    taxel: Optional[int] = TAXEL_OPTION,
    sheet: Optional[str] = SHEET_OPTION,
    jobs: Optional[int] = typer.Option(None, "--jobs", metavar="N", parser=count_option("--jobs"),
                                       help="Processes that fit the candidate effects side by side "
                                            "(default: one per core available; 1: this one alone). "
                                            "The result is the same."),
) -> None:
    """Fit the paper's model, find what it misses by evidence, extend it, measure the gain."""
    from creepcomp.diagnose import combine, diagnose, diagnose_circuit
    from creepcomp.diagnose.workers import available_cores

    check_outputs(dirs={"-o": output}, inputs=[record_path, design],
                  contents={"-o": ("report.html", "diagnosis.json", "model.json",
                                   "baseline-model.json", "as-built-design.json")})
    init, step = record_options(initial, load_step_at)
    from creepcomp.diagnose.sensor import DIAGNOSE_MAX_SAMPLES
    from creepcomp.fit.reduce import MAX_FIT_SAMPLES

    # one reading, one reduction per side: the circuit side as a fit, the sensor side as the
    # diagnosis would reduce the whole record
    (full, full_reduction), (record, reduction) = load_reduced(
        record_path, (MAX_FIT_SAMPLES, DIAGNOSE_MAX_SAMPLES), columns, delimiter, duplicate_times,
        taxel, sheet, quiet=as_json)
    sensor_candidates, circuit_candidates = split_candidates(effects)
    circuit = None
    if record.corrected is not None or design is not None:
        if record.corrected is None:
            raise InputError(f"{record.source}: --design was given but the record has no "
                             "'corrected' column")
        nominal = read_checked_design(record.design_path(design))
        with progress_bar("diagnosing the circuit side", disable=as_json):
            circuit = diagnose_circuit(full, nominal, spice_check=spice_check, candidates=circuit_candidates)
    else:
        full_reduction = None
    del full
    with progress_bar("diagnosing the sensor side", disable=as_json):
        result = diagnose(record, initial=init, load_step_at=step, candidates=sensor_candidates,
                          jobs=available_cores() if jobs is None else jobs)
    units = {c: record.unit(c) for c in ("signal", "load")}
    from creepcomp.diagnose.recommend import recommend

    with progress_bar("choosing the model to recommend", disable=as_json):
        recommendation = recommend(record, result)
    paths, not_written = {}, None
    if output is not None:
        from creepcomp.report.diagnosis import unreadable_baseline, write_report

        paths = write_report(result, output, units, circuit=circuit, recommendation=recommendation)
        not_written = unreadable_baseline(result)
    if as_json:
        out = result.to_dict() if circuit is None else combine(result.to_dict(), circuit)
        out["recommended"] = recommendation.to_dict()
        if reduction:
            out["record_reduction"] = reduction
        if full_reduction and full_reduction != reduction:
            out["circuit_record_reduction"] = full_reduction
        if paths:
            out["files"] = {k: str(v) for k, v in paths.items()}
            if not_written:
                out["files"]["baseline_model_not_written"] = not_written
        print_json(out)
        return
    render_diagnosis(record, result)
    if circuit is not None:
        render_circuit(circuit, record.unit("signal"))
    for note in dict.fromkeys((reduction, result.reduced)):
        if note:
            console.print(f"[yellow]note:[/yellow] {note}", soft_wrap=True)
    if full_reduction and full_reduction != reduction:
        console.print(f"[yellow]note:[/yellow] circuit side: {full_reduction}", soft_wrap=True)
    _render_recommendation(recommendation, record.unit("load"))
    for label, path in paths.items():
        console.print(f"{label.replace('_', ' ')} written to {path}")
    if paths and not_written:
        console.print(f"[yellow]note:[/yellow] baseline-model.json not written: {not_written}",
                      soft_wrap=True)


def _render_recommendation(rec, load_unit: str) -> None:
    """The held-out load error of each member, and the model recommended."""
    from creepcomp.report.results import members_table

    if rec.candidates:
        console.print(members_table(rec.candidates, rec.chosen, rec.split_time, rec.load_range,
                                    load_unit).to_rich())
    console.print(f"recommended (model.json): the {rec.which} model: {rec.reason}", soft_wrap=True)
    for name, why in rec.refused.items():
        console.print(f"[yellow]note:[/yellow] not recommended: {name}: {why}", soft_wrap=True,
                      markup=True, highlight=False)


def split_candidates(text: str | None) -> tuple[list | None, list | None]:
    """``--effects``: the sensor-side and the circuit-side names (None: all of that side)."""
    if not text:
        return None, None
    from creepcomp.diagnose import effects as effects_pkg

    names = [c.strip() for c in text.split(",") if c.strip()]
    chosen = [effects_pkg.get(n) for n in names]
    return ([e.name for e in chosen if e.side != "circuit"], [e.name for e in chosen if e.side == "circuit"])


def render_diagnosis(record, d: Diagnosis) -> None:
    """Print a diagnosis as tables."""
    from creepcomp.report.results import diagnosis_tables

    su = record.unit("signal")
    console.print(f"[bold]creepcomp diagnose[/bold]: {describe_record(record, d.data)}")
    console.print(INITIAL_TEXT[d.data.initial].format(step=d.data.load_step_at))
    b = d.residual_summary(d.baseline)
    console.print(f"baseline (the paper's model, 1 creep term): residual RMS {b['residual_rms']:.4g} {su} "
                  f"({format_percent(b['residual_rms_relative'])} of the signal's range), held out "
                  f"{b['heldout_residual_rms']:.4g} {su}; noise {b['noise']['model']}, residual lag-1 "
                  f"autocorrelation {b['residual_lag1_autocorrelation']:.3f}")
    if d.floor is not None:
        from creepcomp.fit.noise import MISFIT_LIMIT

        share = d.explained_share
        console.print(f"noise floor {d.floor.rms:.4g} {su} (measured without the model: {d.floor.method}); "
                      f"misfit ratio (residual RMS / floor) baseline {_ratio(d.misfit_ratio(d.baseline))}, "
                      f"extended {_ratio(d.misfit_ratio(d.extended))} (consistent with noise up to "
                      f"{MISFIT_LIMIT:g}); explained share of the excess misfit "
                      f"{'-' if share is None else format_percent(share)}")
    console.print(f"[bold]cause: {d.cause}[/bold]")
    tables = diagnosis_tables(d, {c: record.unit(c) for c in ("signal", "load")})
    if d.findings:
        console.print(tables[0].to_rich())
        for f in d.findings:
            if f.note:
                console.print(f"{f.effect}: {f.note}")
    else:
        from creepcomp.fit.noise import none_statement

        console.print(none_statement(d.floor))
    for t in tables[1 if d.findings else 0:]:
        console.print(t.to_rich())
    g = d.gain
    if g.get("correction_unsettled"):
        console.print(f"The extended model's creep correction finds no load that gives the signal "
                      f"({g['correction_unsettled']}): its error is not measured.")


def render_circuit(cd: CircuitDiagnosis, su: str) -> None:
    """Print the circuit side of a diagnosis as tables."""
    from creepcomp.report.results import circuit_tables

    b, e = cd.baseline, cd.extended
    console.print(f"\n[bold]circuit side[/bold]: the nominal network driven by the measured signal against "
                  f"the measured corrected: residual RMS {b.rms:.4g} {su} ({format_percent(b.rms / cd.data.scale)} of its "
                  f"range), held out {b.heldout.rms:.4g} {su}")
    console.print(f"[bold]circuit cause: {cd.cause}[/bold]")
    for line in cd.explanation():
        console.print(line, markup=False, highlight=False)
    tables = circuit_tables(cd)
    if cd.findings:
        console.print(tables["findings"].to_rich())
        console.print(tables["as_built"].to_rich())
    else:
        console.print("no circuit effect is supported by the evidence: no candidate predicts held-out "
                      "data better than the nominal network (that alone does not show the residual is noise)")
    rc = cd.residual_creep
    console.print(f"peak residual creep of a load step: design {format_percent(rc['nominal'])}, as built {format_percent(rc['as_built'])}")
    if cd.fixes:
        console.print(tables["fixes"].to_rich())
    g = cd.gain
    if e is not b:
        console.print(f"gain: held-out residual RMS {b.heldout.rms:.4g} -> {e.heldout.rms:.4g} {su} "
                      f"(ratio {_ratio(g['heldout_rms_ratio'])}); simulated output error RMS "
                      f"{g['correction_error_baseline']:.4g} -> {g['correction_error_extended']:.4g} {su} "
                      f"(ratio {_ratio(g['correction_error_ratio'])})")
    check = cd.spice_check
    if check is not None:
        if "error" in check:
            console.print(f"ngspice check of the as-built network: not run ({check['error']})")
        else:
            console.print(f"ngspice, as-built network on the measured signal: RMS difference from the measured "
                          f"corrected {check['rms_ngspice_vs_measured']:.4g} {su}, {check['ratio']:.3f} x the "
                          f"fit's residual RMS ({check['ngspice_seconds']:.2f} s)")


def _ratio(x) -> str:
    return "-" if x is None else f"{x:.3g}"

