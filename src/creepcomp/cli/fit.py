"""``creepcomp fit``: fit a creep model (gain, offset, Prony terms) to a measured record, or one
model and its temperature law to records at different temperatures."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Callable, List, Optional

import typer

from creepcomp.errors import InputError
from creepcomp.io.jsonfiles import write_json
from creepcomp.io.outputs import check_outputs
from creepcomp.io.records import Record, parse_columns, read_record, reads_whole
from creepcomp.units import format_percent, format_quantity
from creepcomp.cli.common import (api_default, app, console, count_option, err_console, print_json,
                                  print_summary, progress_bar, quantity, temperatures_option)

if TYPE_CHECKING:
    from creepcomp.fit.prony import PronyResult
    from creepcomp.fit.temperature import TemperatureFit

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
                 sheet: str | None = None, quiet: bool = False,
                 grown_samples: int | None = None, rails: list | None = None
                 ) -> list[tuple[Record, str | None]]:
    """Read a record with the command line's mapping options (and, for insole ``.mat`` files
    and creep ``.xlsx`` workbooks, their taxel or sheet), reduced to each of ``max_samples``
    (or ``grown_samples`` where blocks grow: :func:`creepcomp.fit.reduce.read_reduced`; a long
    CSV is never held whole), with a progress bar. ``rails``, given, gets the signal's samples
    stuck at a rail (:func:`creepcomp.io.rails.stuck_at_rail`)."""
    delim, mode = _reader_options(delimiter, duplicate_times)
    mapping = parse_columns(columns)
    from creepcomp.fit.reduce import read_reduced

    with progress_bar(f"reading {path.name}", disable=quiet) as update:
        def read() -> list[tuple[Record, str | None]]:
            return read_reduced(path, max_samples, mapping, delimiter=delim, duplicate_times=mode,
                                taxel=taxel, sheet=sheet, progress=update,
                                grown_samples=grown_samples, rails=rails)

        if taxel is None and sheet is None:
            # a text record is parsed and reduced while the fit's modules are imported
            return _read_while_importing(read)
        return read()


def _read_while_importing(read: Callable[[], list[tuple[Record, str | None]]]
                          ) -> list[tuple[Record, str | None]]:
    """``read()`` of a text record, in a thread while this one imports the fit's modules
    (scipy's import holds the interpreter; pyarrow's CSV parser and numpy's work on the columns
    do not). The reader's own imports come first, here: the thread then imports nothing that
    the fit's imports might be holding."""
    import threading
    from array import array  # noqa: F401

    import pyarrow.csv  # noqa: F401

    import creepcomp.io.formats  # noqa: F401
    import creepcomp.lti  # noqa: F401

    outcome: dict = {}

    def run() -> None:
        try:
            outcome["read"] = read()
        except BaseException as exc:         # (raised again in the command's thread)
            outcome["error"] = exc

    reader = threading.Thread(target=run, name="creepcomp-read", daemon=True)
    reader.start()
    import creepcomp.fit.prony  # noqa: F401
    reader.join()
    if "error" in outcome:
        raise outcome["error"]
    return outcome["read"]


def warn_rails(rails: list, unit: str = "") -> None:
    """One warning line on stderr for a signal stuck at a rail (:mod:`creepcomp.io.rails`)."""
    from creepcomp.io.rails import rail_warning

    text = rail_warning(rails, unit)
    if text:
        err_console.print(f"creepcomp: warning: {text}", markup=False, highlight=False, soft_wrap=True)


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
    record_paths: List[Path] = typer.Argument(..., metavar="RECORD...",
                                              help="Measured record(s) (CSV, docs/record-format.md); "
                                                   "several: one per temperature, fitted jointly "
                                                   "with a temperature law."),
    columns: Optional[str] = typer.Option(None, "--columns", metavar="MAP", help=COLUMNS_HELP),
    delimiter: Optional[str] = typer.Option(None, "--delimiter", metavar="CHAR",
                                            help="Field delimiter (default: detected; 'tab' for tabs)."),
    duplicate_times: str = typer.Option(api_default(read_record, "duplicate_times"),
                                        "--duplicate-times", metavar="error|mean",
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
    law: Optional[str] = typer.Option(None, "--law", metavar="arrhenius|wlf",
                                      help="Fit a temperature law of the retardation times (default "
                                           "with several records: arrhenius; wlf needs 3+ temperatures)."),
    temperature: Optional[str] = typer.Option(None, "--temperature", metavar="T1,T2,...",
                                              help="Temperature of each record (°C), instead of their "
                                                   "temperature columns."),
    reference_temperature: Optional[str] = typer.Option(
        None, "--reference-temperature", metavar="T",
        help="Temperature (°C) of the fitted terms (default: the middle record's, or one record's mean)."),
    beta_per_kelvin: bool = typer.Option(False, "--beta-per-kelvin",
                                         help="Fit each creep amplitude's change per kelvin too."),
    transfer: str = typer.Option("none", "--transfer", metavar="none|auto",
                                 help="auto: static maps around the creep (power, reciprocal, log, "
                                      "monotone spline) or a static calibration, chosen by the load "
                                      "given back on held-out data (soft sensors: docs/soft-sensors.md)."),
) -> None:
    """Fit gain, offset and creep terms to a record; the number of terms by evidence. With
    several records (or --law), one model and its temperature law, fitted jointly."""
    check_outputs({"-o": output, "--plot": plot}, inputs=list(record_paths))
    init, step = record_options(initial, load_step_at)
    fixed = terms_option(terms)
    over_temperature = (len(record_paths) > 1 or law is not None or temperature is not None
                        or reference_temperature is not None or beta_per_kelvin)
    mapped = transfer_option(transfer)
    if mapped and (over_temperature or flow or fixed is not None or step is not None):
        raise InputError("--transfer auto chooses the maps and the number of creep terms itself on one "
                         "record: it does not take --terms K, --flow, --load-step-at, a temperature law "
                         "or several records")
    if over_temperature:
        fit_over_temperature(record_paths, law or "arrhenius", temperature, reference_temperature,
                             beta_per_kelvin, fixed, max_terms, flow, plot, init, step, output, as_json,
                             (columns, delimiter, duplicate_times, taxel, sheet))
        return
    from creepcomp.fit.reduce import GROWN_FIT_SAMPLES, MAX_FIT_SAMPLES

    [record_path] = record_paths
    rails: list = []
    [(record, reduction)] = load_reduced(record_path, (MAX_FIT_SAMPLES,), columns, delimiter,
                                         duplicate_times, taxel, sheet, quiet=as_json,
                                         grown_samples=GROWN_FIT_SAMPLES, rails=rails)
    warn_rails(rails, record.unit("signal"))
    if mapped:
        fit_path(record, reduction, max_terms, init, output, plot, as_json)
        return
    from creepcomp.fit import Applied, fit_record

    with progress_bar("fitting", disable=as_json):
        extra = ()
        if flow:        # (the diagnosis's effects are imported only for it)
            from creepcomp.diagnose.effects import flow_effect

            extra = (Applied(flow_effect()),)
        result = fit_record(record, init, step, fixed, max_terms, extra)
    data = result.data
    model = result.to_dict()
    if reduction:
        model["record_reduction"] = reduction
    refused = unusable(model)
    if output is not None and refused is None:
        write_json(output, model)
    if plot is not None:
        from creepcomp.report.common import save_axes
        from creepcomp.report.diagnosis import plot_fit

        save_axes(plot_fit(data, result.fit, record=record), plot, dpi=100)
    if as_json:
        print_json(model if refused is None else {**model, "not_written": refused})
    else:
        render_fit(record, result, fixed)
        if reduction:
            console.print(f"[yellow]note:[/yellow] {reduction}", soft_wrap=True)
        if output is not None and refused is None:
            console.print(f"model written to {output}")
        if plot is not None:
            console.print(f"plot written to {plot}")
    if refused is not None:
        not_written(refused, output)


#: Exit status of a fit whose model the creep correction would refuse (nothing written).
NOT_WRITTEN = 3


def transfer_option(text: str) -> bool:
    """``--transfer``: True for auto, False for none."""
    value = text.strip().lower()
    if value not in ("none", "auto"):
        raise InputError(f"--transfer '{text}': use none or auto")
    return value == "auto"


def unusable(model: dict) -> str | None:
    """Why ``correct`` would refuse the fitted model (None: it takes it). A model with an
    extension (``--flow``) is checked by the diagnosis's rule; a plain one here, without
    loading the diagnosis."""
    if model.get("extensions"):
        from creepcomp.diagnose.recommend import usable

        return usable(model)
    from creepcomp.digital.correctors import check_invertible
    from creepcomp.model import CreepModel

    try:
        check_invertible(CreepModel.from_dict(model))
    except InputError as exc:
        return str(exc)
    return None


def not_written(why: str, output: Path | None) -> None:
    """Say that the model is not written, why, and what gives one; exit with status 3."""
    err_console.print(f"creepcomp fit: the fitted model is not written{' to ' + str(output) if output else ''}: "
                      f"{why}. A model that creepcomp correct inverts: creepcomp fit RECORD --transfer auto, "
                      "or the model.json of creepcomp diagnose RECORD -o DIR",
                      markup=False, highlight=False, soft_wrap=True)
    raise typer.Exit(NOT_WRITTEN)


def fit_path(record: Record, reduction: str | None, max_terms: int, initial: str, output: Path | None,
             plot: Path | None, as_json: bool) -> None:
    """``--transfer auto``: the signal path chosen by held-out load error, written and shown."""
    from creepcomp.fit.signal_path import fit_signal_path

    with progress_bar("fitting the signal path", disable=as_json):
        path = fit_signal_path(record, max_terms=min(max_terms, 4),
                               initial="relaxed" if initial == "free" else initial)
    model = path.model.to_dict()
    model["signal_path"] = {k: v for k, v in path.to_dict().items() if k != "model"}
    if reduction:
        model["record_reduction"] = reduction
    if output is not None:
        write_json(output, model)
    if plot is not None:
        from creepcomp.report.common import save_axes

        save_axes(path.plot(), plot, dpi=100)
    if as_json:
        print_json(model)
        return
    console.print(f"[bold]creepcomp fit[/bold]: {record.source}, {len(record)} samples; signal path by "
                  "the load given back on held-out data", soft_wrap=True)
    print_summary(path.tables())
    if reduction:
        console.print(f"[yellow]note:[/yellow] {reduction}", soft_wrap=True)
    if output is not None:
        console.print(f"model written to {output}")
    if plot is not None:
        console.print(f"plot written to {plot}")


def terms_option(terms: str) -> int | None:
    """``--terms``: None for auto, else the fixed number of terms (checked)."""
    if terms.strip().lower() == "auto":
        return None
    try:
        fixed = int(terms)
    except ValueError:
        raise InputError(f"--terms '{terms}': use auto or a whole number") from None
    if not 1 <= fixed <= 20:
        raise InputError(f"--terms {fixed}: use 1 to 20")
    return fixed


def record_temperatures(text: str | None, n_records: int) -> list[float] | None:
    """``--temperature T1,T2,...``: one temperature (°C) per record."""
    values = temperatures_option(text, "--temperature")
    if values is not None and len(values) != n_records:
        raise InputError(f"--temperature '{text}' gives {len(values)} temperature"
                         f"{'s' if len(values) != 1 else ''} for {n_records} record"
                         f"{'s' if n_records != 1 else ''}: give one per record")
    return values


def fit_over_temperature(paths: list[Path], law: str, temperature: str | None, reference: str | None,
                         beta_per_kelvin: bool, fixed: int | None, max_terms: int, flow: bool,
                         plot: Path | None, init: str, step: float | None, output: Path | None,
                         as_json: bool, reader: tuple) -> None:
    """The joint fit of one model and its temperature law (:mod:`creepcomp.fit.temperature`)."""
    law = law.strip().lower()
    if flow:
        raise InputError("--flow: not available with a temperature law fit")
    if plot is not None:
        raise InputError("--plot: available for one record without a temperature law")
    temps = record_temperatures(temperature, len(paths))
    ref = quantity(reference, "number", "--reference-temperature")
    from creepcomp.fit.data import prepare
    from creepcomp.fit.reduce import MAX_FIT_SAMPLES
    from creepcomp.fit.temperature import fit_temperature_law

    records, notes = [], []
    for path in paths:
        rails: list = []
        [(record, reduction)] = load_reduced(path, (MAX_FIT_SAMPLES,), *reader, quiet=as_json, rails=rails)
        warn_rails(rails, record.unit("signal"))
        records.append(record)
        if reduction:
            notes.append(f"{record.source}: {reduction}")
    with progress_bar("fitting", disable=as_json):
        data = [prepare(r, initial=init, load_step_at=step) for r in records]
        result = fit_temperature_law(data, law=law, temperatures=temps, reference=ref,
                                     beta_per_kelvin=beta_per_kelvin, n_terms=fixed, max_terms=max_terms)
    model = result.to_dict()
    if notes:
        model["record_reduction"] = notes
    if output is not None:
        write_json(output, model)
    if as_json:
        print_json(model)
        return
    render_temperature_fit(records, result)
    for note in notes:
        console.print(f"[yellow]note:[/yellow] {note}", soft_wrap=True)
    if output is not None:
        console.print(f"model written to {output}")


def law_lines(result: TemperatureFit) -> list[str]:
    """The fitted law, one line per quantity, with units and standard deviations."""
    from creepcomp.temperature import ZERO_CELSIUS

    law = result.law
    est = result.law_estimates()
    lines = []
    if law.law == "arrhenius":
        ea, sd = est["activation_energy"]
        lines.append(f"activation energy E_a = {ea / 1e3:.2f} ± {sd / 1e3:.2f} kJ/mol (1 sigma)")
    else:
        (c1, s1), (c2, s2) = est["c1"], est["c2"]
        rho = law.uncertainty.get("c1_c2_correlation")
        lines.append(f"WLF c1 = {c1:.4g} ± {s1:.2g}, c2 = {c2:.4g} ± {s2:.2g} K (1 sigma"
                     + (f", correlation {rho:+.3f})" if rho is not None else ")"))
    kappa = law.kappa
    halving = 0.6931471805599453 / kappa if kappa > 0 else float("inf")
    lines.append(f"at {law.reference:.4g} °C ({law.reference + ZERO_CELSIUS:.2f} K): tau changes by "
                 f"{-100 * kappa:.3g} %/K, halves every {halving:.3g} K")
    for k, b in enumerate(law.beta_per_kelvin):
        sd = law.uncertainty.get("beta_per_kelvin", [float("nan")] * len(law.beta_per_kelvin))[k]
        lines.append(f"beta[{k}] changes by {100 * b:+.3g} ± {100 * sd:.2g} %/K (relative)")
    return lines


def render_temperature_fit(records: list[Record], result: TemperatureFit) -> None:
    """Print the records, the model at the reference temperature and its law."""
    from rich.table import Table

    law = result.law
    several = len(records) > 1
    console.print(f"[bold]creepcomp fit[/bold]: {len(records)} record{'s' if several else ''}, one "
                  f"creep model and its {law.law} law fitted "
                  + ("jointly (each record with its own gain and offset)" if several else
                     "to the record's temperature history")
                  + f"; reference {law.reference:.4g} °C", soft_wrap=True)
    table = Table(title="Records (a_T: the retardation times' shift factor)", title_justify="left")
    for col in ("record", "°C", "a_T", "gain", "offset", "residual"):
        table.add_column(col, justify="right")
    for rec, r in zip(records, result.records):
        su, lu = rec.unit("signal"), rec.unit("load")
        if r["temperature_used"] == "column":
            span = f"{r['temperature_min']:.3g}…{r['temperature_max']:.3g}"
            shift = f"{law.shift(r['temperature_min']):.3g}…{law.shift(r['temperature_max']):.3g}"
        else:
            span = f"{r['temperature_mean']:.3g}"
            shift = f"{r['shift_factor']:.4g} ± {r['shift_factor_sigma']:.2g}"
        table.add_row(r["record"], span, shift, f"{r['gain']:.5g} {su}/{lu}" if su and lu else f"{r['gain']:.5g}",
                      f"{r['offset']:.4g} {su}".strip(),
                      f"{r['residual_rms']:.3g} {su}".strip())
    console.print(table)
    model = result.model
    t2 = Table(title=f"Model at {law.reference:.4g} °C: {model.n_terms} creep term"
                     f"{'s' if model.n_terms > 1 else ''}, beta0 = {format_percent(model.beta0)}",
               title_justify="left")
    for col in ("", "value", "± 1 sigma"):
        t2.add_column(col, justify="right")
    for k in range(model.n_terms):
        t2.add_row(f"beta[{k}]", format_percent(model.beta[k], 4), format_percent(result.sigmas[f"beta[{k}]"], 2))
        t2.add_row(f"tau[{k}]", format_quantity(model.tau[k], "s"),
                   format_quantity(result.sigmas[f"tau[{k}]"], "s", 2))
    console.print(t2)
    for line in law_lines(result):
        console.print(line)
    from creepcomp.fit import BIC_STRONG

    tried = ", ".join(f"{o['n_terms']}" + (f" (ΔBIC {o['delta_bic_whitened']:+.1f})" if "delta_bic_whitened" in o
                                          else "") for o in result.orders)
    console.print(f"terms tried: {tried}; {model.n_terms} chosen (a term is kept when it lowers the BIC "
                  f"of the prewhitened residuals by {BIC_STRONG:g}+)", soft_wrap=True)


def render_fit(record: Record, result: PronyResult, fixed: int | None) -> None:
    """Print the order search and the chosen model."""
    from creepcomp.fit import term_table
    from creepcomp.report.results import fit_tables

    data, fit = result.data, result.fit
    su, lu = record.unit("signal"), record.unit("load")
    console.print(f"[bold]creepcomp fit[/bold]: {describe_record(record, data)}")
    console.print(INITIAL_TEXT[data.initial].format(step=data.load_step_at))
    for table in fit_tables(result, su, lu, bool(fixed)):
        console.print(table.to_rich())
    terms = term_table(fit)
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
