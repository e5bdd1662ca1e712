"""``creepcomp fit``: fit a creep model (gain, offset, Prony terms) to a measured record."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Optional

import typer
from rich.table import Table

from creepcomp.errors import InputError
from creepcomp.io.jsonfiles import write_json
from creepcomp.io.outputs import check_outputs
from creepcomp.io.records import Record, parse_columns
from creepcomp.units import format_percent, format_quantity
from creepcomp.cli.common import app, console, count_option, print_json, progress_bar, quantity

if TYPE_CHECKING:
    from creepcomp.fit.prony import PronyResult

COLUMNS_HELP = ("Map the file's columns to time, load, signal (temperature, corrected), e.g. "
                "'time=Step time,signal=Strain,load=Stress'; a number is a constant column (load=1).")
# other measured files (creepcomp.io.formats): the insole .mat files' taxel, the workbooks' sheet
TAXEL_OPTION = typer.Option(None, "--taxel", metavar="N", help="Taxel (0-279) of an insole .mat file.")
SHEET_OPTION = typer.Option(None, "--sheet", metavar="NAME", help="Sheet (specimen) of an .xlsx creep workbook.")


def _reader_options(delimiter: str | None, duplicate_times: str) -> tuple[str | None, str]:
    """The command line's delimiter (names allowed) and duplicate-times mode, checked."""
    mode = duplicate_times.strip().lower()
    if mode not in ("error", "mean"):
        raise InputError(f"--duplicate-times '{duplicate_times}': use error or mean")
    delim = {"tab": "\t", "\\t": "\t", "comma": ",", "semicolon": ";"}.get(
        (delimiter or "").lower(), delimiter) or None
    return delim, mode


def load_reduced(path: Path, max_samples: tuple[int, ...], columns: str | None,
                 delimiter: str | None, duplicate_times: str, taxel: int | None = None,
                 sheet: str | None = None, quiet: bool = False) -> list[tuple[Record, str | None]]:
    """Read a record with the command line's mapping options (and, for insole ``.mat`` files
    and creep ``.xlsx`` workbooks, their taxel or sheet), reduced to each of ``max_samples``
    (:func:`creepcomp.fit.reduce.read_reduced`: a long CSV is never held whole), with a
    progress bar."""
    from creepcomp.fit.reduce import read_reduced

    delim, mode = _reader_options(delimiter, duplicate_times)
    with progress_bar(f"reading {path.name}", disable=quiet) as update:
        return read_reduced(path, max_samples, parse_columns(columns), delimiter=delim,
                            duplicate_times=mode, taxel=taxel, sheet=sheet, progress=update)


def record_options(initial: str, load_step_at: str | None) -> tuple[str, float | None]:
    """Initial-state and load-step options, checked."""
    init = initial.strip().lower()
    if init not in ("free", "relaxed", "settled"):
        raise InputError(f"--initial '{initial}': use free, relaxed or settled")
    step = quantity(load_step_at, "second", "--load-step-at") if load_step_at is not None else None
    return init, step


def describe_record(record: Record, data) -> str:
    """One line about the record as fitted."""
    step = format_quantity(data.dt_median, 's')
    if record.metadata.get("reduced"):
        # block means within constant-load stretches: the steps differ only where a stretch ends
        sampling = f"reduced to block means, median step {step}"
    else:
        sampling = f"uniform, {step}" if record.is_uniform else f"irregular, median step {step}"
    merged = record.metadata.get("merged_duplicate_times")
    extra = f"; {merged} rows with repeated time stamps averaged" if merged else ""
    return (f"{record.source}: {len(record)} samples over {format_quantity(record.duration, 's')} "
            f"({sampling}){extra}")


INITIAL_TEXT = {"free": "initial creep state fitted (the record may start loaded or creeping)",
                "relaxed": "relaxed start assumed (no creep before the first sample)",
                "settled": "settled start assumed (load held long before the first sample)",
                "step": "load step at {step} s before the first sample"}


@app.command("fit")
def fit_command(
    record_path: Path = typer.Argument(..., metavar="RECORD", help="Measured record (CSV, docs/record-format.md)."),
    columns: Optional[str] = typer.Option(None, "--columns", metavar="MAP", help=COLUMNS_HELP),
    delimiter: Optional[str] = typer.Option(None, "--delimiter", metavar="CHAR",
                                            help="Field delimiter (default: detected; 'tab' for tabs)."),
    duplicate_times: str = typer.Option("error", "--duplicate-times", metavar="error|mean",
                                        help="Repeated time stamps: an error, or average the rows."),
    terms: str = typer.Option("auto", "--terms", metavar="auto|K",
                              help="Number of creep terms: chosen by evidence, or fixed."),
    max_terms: int = typer.Option(8, "--max-terms", parser=count_option("--max-terms", 1, 20),
                                  help="Most terms tried with --terms auto."),
    flow: bool = typer.Option(False, "--flow", help="Add viscous flow (a dashpot in series, Burgers "
                                                   "model) to every model: creep that never saturates."),
    initial: str = typer.Option("free", "--initial", metavar="free|relaxed|settled",
                                help="Creep state at the first sample: fitted, zero, or settled."),
    load_step_at: Optional[str] = typer.Option(None, "--load-step-at", metavar="TIME",
                                               help="Time of a single load step before the first "
                                                    "sample (creep tests), e.g. 0."),
    output: Optional[Path] = typer.Option(None, "-o", "--output", metavar="model.json",
                                          help="Write the model file."),
    plot: Optional[Path] = typer.Option(None, "--plot", metavar="FILE.png",
                                        help="Plot measured vs fitted and the residual."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object (the model file)."),
    taxel: Optional[int] = TAXEL_OPTION,
    sheet: Optional[str] = SHEET_OPTION,
) -> None:
    """Fit gain, offset and creep terms to a record; the number of terms by evidence."""
    check_outputs({"-o": output, "--plot": plot}, inputs=[record_path])
    init, step = record_options(initial, load_step_at)
    from creepcomp.fit.reduce import MAX_FIT_SAMPLES

    [(record, reduction)] = load_reduced(record_path, (MAX_FIT_SAMPLES,), columns, delimiter,
                                         duplicate_times, taxel, sheet, quiet=as_json)
    fixed = None
    if terms.strip().lower() != "auto":
        try:
            fixed = int(terms)
        except ValueError:
            raise InputError(f"--terms '{terms}': use auto or a whole number") from None
        if not 1 <= fixed <= 20:
            raise InputError(f"--terms {fixed}: use 1 to 20")
    from creepcomp.diagnose import effects
    from creepcomp.fit import Applied, fit_prony, prepare

    with progress_bar("fitting", disable=as_json):
        data = prepare(record, initial=init, load_step_at=step)
        extra = (Applied(effects.flow_effect()),) if flow else ()
        result = fit_prony(data, max_terms=max_terms, n_terms=fixed, effects=extra)
    model = result.to_dict()
    if reduction:
        model["record_reduction"] = reduction
    if output is not None:
        write_json(output, model)
    if plot is not None:
        from creepcomp.report.diagnosis import plot_fit

        plot_fit(data, result.fit, plot, record)
    if as_json:
        print_json(model)
        return
    render_fit(record, result, fixed)
    if reduction:
        console.print(f"[yellow]note:[/yellow] {reduction}", soft_wrap=True)
    if output is not None:
        console.print(f"model written to {output}")
    if plot is not None:
        console.print(f"plot written to {plot}")


def render_fit(record: Record, result: PronyResult, fixed: int | None) -> None:
    """Print the order search and the chosen model."""
    from creepcomp.diagnose.effects import flow_effect
    from creepcomp.fit import BIC_STRONG, HELDOUT_Z, term_table

    data, fit = result.data, result.fit
    su, lu = record.unit("signal"), record.unit("load")
    console.print(f"[bold]creepcomp fit[/bold]: {describe_record(record, data)}")
    console.print(INITIAL_TEXT[data.initial].format(step=data.load_step_at))
    table = Table(title=("Number of creep terms (fixed)" if fixed else
                         f"Number of creep terms: added while BIC drops by {BIC_STRONG:g}+ and "
                         f"held-out blocks are predicted better by {HELDOUT_Z:g}+ sigma"),
                  title_justify="left")
    for col in ("terms", "residual RMS", "held-out RMS", "BIC", "ΔBIC", "held-out z", ""):
        table.add_column(col, justify="right")
    for i, s in enumerate(result.steps):
        ev = s.evidence
        table.add_row(str(s.n_terms), f"{s.fit.residual_rms:.4g} {su}".strip(),
                      f"{s.fit.heldout.rms:.4g} {su}".strip() if s.fit.heldout else "-",
                      f"{s.fit.bic:.1f}", f"{ev.delta_bic:+.1f}" if ev else "-",
                      f"{ev.heldout_z:.1f}" if ev else "-", "chosen" if i == result.chosen else "")
    console.print(table)
    terms = term_table(fit)
    t2 = Table(title=f"Model: {fit.structure.n_terms} creep term{'s' if fit.structure.n_terms > 1 else ''}, "
                     f"beta0 = {format_percent(sum(t['beta'] for t in terms))}", title_justify="left")
    for col in ("", "value", "± 1 sigma"):
        t2.add_column(col, justify="right")
    gain = fit.estimate(lambda v: v["gain"])
    t2.add_row(f"gain ({su or 'signal'} per {lu or 'load unit'})", f"{gain[0]:.6g}", f"{gain[1]:.2g}")
    if data.fixed_offset:
        t2.add_row("offset", "0 (fixed: the load never changes)", "")
    else:
        off = fit.estimate(lambda v: v["offset"])
        t2.add_row(f"offset ({su or 'signal units'})", f"{off[0]:.6g}", f"{off[1]:.2g}")
    for k, t in enumerate(terms):
        t2.add_row(f"beta[{k}]", format_percent(t["beta"], 4), format_percent(t["beta_sigma"], 2))
        t2.add_row(f"tau[{k}]", format_quantity(t["tau"], "s"), format_quantity(t["tau_sigma"], "s", 2))
    flow = flow_effect()
    if fit.structure.has(flow.name):
        rate = flow.rate(fit)
        t2.add_row("viscous flow rate (1/s, of the instantaneous signal)", f"{rate[0]:.4g}", f"{rate[1]:.2g}")
    console.print(t2)
    scale = data.signal_scale
    console.print(f"residual RMS {fit.residual_rms:.4g} {su} ({format_percent(fit.residual_rms / scale)} of the signal's "
                  f"range); held-out {fit.heldout.rms:.4g} {su} ({format_percent(fit.heldout.rms / scale)})"
                  if fit.heldout else f"residual RMS {fit.residual_rms:.4g}")
    n = fit.noise
    console.print(f"noise model AR({n.order}), innovation sigma {n.sigma:.3g} {su}, memory "
                  f"{format_quantity(n.correlation_samples() * data.dt_median, 's')}")
    lo, hi = data.tau_limits()
    for t in terms:
        if t["tau"] > data.span:
            console.print(f"[yellow]note:[/yellow] tau = {format_quantity(t['tau'], 's')} is longer than the "
                          f"record ({format_quantity(data.span, 's')}): its beta and tau are poorly "
                          "separated (it may be flow: see creepcomp diagnose)")
        elif t["tau"] < lo * 2:
            console.print(f"[yellow]note:[/yellow] tau = {format_quantity(t['tau'], 's')} is near the "
                          f"sampling step: it is barely resolved")
