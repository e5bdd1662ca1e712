"""``creepcomp correct``: digital creep correction of a record (subtractive / supplemental)."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from creepcomp.errors import InputError
from creepcomp.io.jsonfiles import read_json, read_model
from creepcomp.io.outputs import check_outputs
from creepcomp.io.records import parse_columns, write_record
from creepcomp.units import format_percent, format_quantity
from creepcomp.cli.common import app, console, print_json, progress_bar
from creepcomp.cli.fit import SHEET_OPTION, TAXEL_OPTION
from creepcomp.report.results import correction_table, describe_model

#: A record "starts loaded" when its first load is above this fraction of its largest load.
LOADED_START = 1e-3

HOLD_TEXT = {"zero": "load held between samples", "linear": "load ramping linearly between samples"}
#: Spellings of degrees Celsius after a temperature's number.
CELSIUS_UNITS = ("", "c", "°c", "degc", "celsius")


def celsius(text: str | None, option: str) -> float | None:
    """Read a temperature in °C (``25``, ``25C``, ``-10°C``); None stays None."""
    if text is None:
        return None
    import re

    raw = str(text).strip()
    m = re.match(r"^([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)\s*(.*)$", raw)
    if not m or m.group(2).strip().lower() not in CELSIUS_UNITS:
        raise InputError(f"{option} = '{raw}': expected a temperature in °C, e.g. 25 or 25C")
    value = float(m.group(1))
    if value <= -273.15:
        raise InputError(f"{option} = '{raw}': at or below absolute zero")
    return value


@app.command("correct")
def correct_command(
    record_path: Path = typer.Argument(..., metavar="RECORD", help="Record CSV (time, load, signal)."),
    model_file: Optional[Path] = typer.Option(None, "--model", metavar="FILE",
                                              help="Model file (beta, tau; gain, offset)."),
    method: str = typer.Option("subtractive", "--method", metavar="subtractive|supplemental",
                               help="subtractive: the instantaneous signal; supplemental: the "
                                    "saturated signal, (1 + beta0) times it."),
    initial: Optional[str] = typer.Option(None, "--initial", metavar="relaxed|settled",
                                          help="Creep at the first sample: none (unloaded before) "
                                               "or saturated. Default: relaxed for subtractive, "
                                               "settled for supplemental."),
    hold: str = typer.Option("zero", "--hold", metavar="zero|linear",
                             help="Load held between samples (the paper's case) or ramping."),
    temperature: Optional[str] = typer.Option(None, "--temperature", metavar="T",
                                              help="Constant temperature (°C) for a model with a "
                                                   "temperature law and a record without a "
                                                   "'temperature' column."),
    columns: Optional[str] = typer.Option(None, "--columns", metavar="MAP",
                                          help="Column mapping, e.g. time=tR,load=P,signal=Ri."),
    taxel: Optional[int] = TAXEL_OPTION,
    sheet: Optional[str] = SHEET_OPTION,
    output: Optional[Path] = typer.Option(None, "-o", "--output", metavar="out.csv",
                                          help="Write the record's columns plus 'compensated' and "
                                               "'load_estimate' (the load, in load units)."),
    plot: Optional[Path] = typer.Option(None, "--plot", metavar="FILE.png",
                                        help="Plot raw, compensated and reference, and the errors."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
) -> None:
    """Remove creep from a record sample by sample, and report the creep error left."""
    from creepcomp.digital.correctors import default_initial, mean_interval_of, saturation_factor

    if model_file is None:
        raise InputError("give the sensor's creep model: --model FILE (a JSON object with 'beta' "
                         "and 'tau' lists, as written by creepcomp fit)")
    check_outputs({"-o": output, "--plot": plot}, inputs=[record_path, model_file])
    method = method.strip().lower()
    hold = hold.strip().lower()
    if "creep" in read_json(model_file, "model file") and "beta" not in read_json(model_file, "model file"):
        raise InputError(f"--model {model_file}: is a design file; its 'creep' block has no gain "
                         "or offset, which the correction needs to judge the signal against the "
                         "load: fit the record first (creepcomp fit RECORD -o model.json) and give "
                         "that model")
    model = read_model(model_file)
    start = default_initial(method) if initial is None else initial.strip().lower()
    constant = celsius(temperature, "--temperature")
    out_meta = {"compensated.method": method, "compensated.initial": start, "compensated.hold": hold,
                "compensated.model": str(model_file)}
    if constant is not None:
        out_meta["compensated.temperature"] = f"{constant:g} °C"
    inverses = _extension_inverses(model)
    done = None
    text = not _measured_file(record_path, taxel, sheet)
    if text and plot is None and not inverses and model.transfer is None and not model.is_static:
        done = _correct_in_pieces(record_path, model, method, start, hold, output, out_meta,
                                  parse_columns(columns), as_json, constant)
    if done is None:
        done = _correct_whole(record_path, model, method, start, hold, output, out_meta,
                              parse_columns(columns), plot, as_json, constant, taxel, sheet)
    scan, dt = done.scan, done.dt
    before, after = done.before, done.after
    unit = scan.unit("signal")
    from creepcomp.cli.fit import warn_rails

    warn_rails(list(done.rails), unit)
    notes = _notes(scan, start, method, model)
    if text:
        notes += _renamed_notes(record_path, parse_columns(columns), scan, output)
    temperature_used = None
    if done.temperature is not None:
        temperature_used = {"source": done.temperature, "constant_C": constant}
    elif "temperature" in scan.names:
        temperature_used = {"source": "unused", "constant_C": None,
                            "why": "the model has no temperature law"}
    formula = "offset + gain * load" if method == "subtractive" else "offset + gain * (1 + beta0) * load"
    result = {
        "record": str(record_path), "samples": scan.samples, "uniform": dt is not None,
        "sample_interval": dt, "method": method, "initial": start, "hold": hold,
        "model": model.to_dict(), "reference": formula,
        "saturation_factor": saturation_factor(model, method),
        "units": {"signal": unit, "load": scan.unit("load")},
        "creep_error": {"before": before.to_dict(), "after": after.to_dict()},
        "reduction": (before.peak / after.peak) if after.peak > 0 else None,
        "starts_loaded": _starts_loaded(scan), "notes": notes,
        "output": None if output is None else str(output), "plot": None if plot is None else str(plot),
        "temperature": temperature_used, "extensions": inverses,
        "fitted_reference_rms": {"before": done.fitted_before, "after": done.fitted_after},
        "load_estimate": {**_load_figures(done.load_rms, scan),
                          "load_filter": None if model.load_filter is None else model.load_filter.describe(
                              mean_interval_of(scan.first_time, scan.last_time, scan.samples))},
        "stuck_at_rail": [r.to_dict() for r in done.rails],
    }
    if as_json:
        print_json(result)
        return
    _render(record_path, scan, model, result, before, after, dt, unit, notes)
    if output is not None:
        console.print(f"corrected record written to {output}", soft_wrap=True)
    if plot is not None:
        console.print(f"plot written to {plot}", soft_wrap=True)


def _correct_in_pieces(record_path, model, method, start, hold, output, out_meta, mapping, quiet,
                       constant):
    """The correction of a CSV record read and written in pieces, or None when the file is
    one to read whole."""
    from creepcomp.digital.record_file import correct_record_file

    with progress_bar(f"reading {record_path.name}", disable=quiet) as update:
        return correct_record_file(record_path, model, method, initial=start, hold=hold,
                                   output=output, output_metadata=out_meta, columns=mapping,
                                   progress=update, temperature=constant)


def _measured_file(record_path, taxel, sheet) -> bool:
    """An insole ``.mat`` file or an ``.xlsx`` workbook (read whole, one taxel or sheet, no
    extra columns), not a text record."""
    return taxel is not None or sheet is not None or Path(record_path).suffix.lower() in (".mat", ".xlsx")


def _correct_whole(record_path, model, method, start, hold, output, out_meta, mapping, plot, quiet,
                   constant, taxel=None, sheet=None):
    """The correction of a record held whole (other files, and for the plot)."""
    import numpy as np

    from creepcomp.digital.correctors import (compensate, creep_error, filter_load, load_from_compensated,
                                             uniform_interval)
    from creepcomp.digital.record_file import FileCorrection, temperature_source
    from creepcomp.io.formats import read_any
    from creepcomp.io.rails import stuck_at_rail
    from creepcomp.io.records import RecordScan

    record = read_any(record_path, columns=mapping, taxel=taxel, sheet=sheet)
    record.require(n_samples=2, what="creep correction")
    source = temperature_source(model, record.temperature is not None, constant, str(record_path))
    temps = (None if source is None else record.temperature if source == "column" else constant)
    if model.extensions:
        compensated = _compensate_extended(record, model, method, start, hold, temps)
    else:
        outside = 0 if model.transfer is None or model.transfer.signal_map is None else \
            model.transfer.signal_map.outside(record.signal)
        if outside:
            from creepcomp.cli.common import err_console

            err_console.print(f"creepcomp: note: {outside} signal samples lie outside the model's signal "
                              f"map ({model.transfer.signal_map.describe()}): taken at its edge",
                              markup=False, highlight=False, soft_wrap=True)
        with progress_bar("correcting", total=len(record), disable=quiet) as update:
            compensated = compensate(record.time, record.signal, model, method, initial=start,
                                     hold=hold, progress=update, temperature=temps)
    before = creep_error(record.time, record.signal, record.load, model, method)
    after = creep_error(record.time, compensated, record.load, model, method)
    load_estimate = filter_load(load_from_compensated(compensated, model, method), model, record.time)
    if output is not None:
        extra = {} if _measured_file(record_path, taxel, sheet) else _extra_columns(record_path, mapping, record)
        with progress_bar(f"writing {output.name}", total=len(record), disable=quiet) as update:
            write_record(output, record, extra={**extra, "compensated": compensated, "load_estimate": load_estimate},
                         metadata=out_meta, progress=update)
    if plot is not None:
        from creepcomp.digital.correctors import reference
        from creepcomp.report.common import save_axes
        from creepcomp.report.digital import plot_correction

        save_axes(plot_correction(record.time, record.signal, compensated,
                                  reference(record.load, model, method),
                                  title=f"{record_path.name}: {method} correction",
                                  signal_unit=record.unit("signal"),
                                  full_scale=after.full_scale or None), plot)
    return FileCorrection(RecordScan.of(record), uniform_interval(record.time), before, after,
                          source, _fitted_rms(record.signal, record.load),
                          _fitted_rms(compensated, record.load),
                          float(np.sqrt(np.mean((load_estimate - record.load) ** 2))),
                          tuple(stuck_at_rail(record.signal)))


def _renamed_notes(record_path, mapping, scan, output) -> list[str]:
    """Notes for the extra columns ``-o`` writes under another name than the input's."""
    if output is None:
        return []
    from creepcomp.io.extra_columns import open_extra_columns, output_names

    with open_extra_columns(record_path, mapping) as extra:
        names = output_names(extra.names, [*scan.names, "compensated", "load_estimate"])
        return [f"the record's extra column '{old}' is written as '{new}' in {output} (the output "
                f"has a column '{old}' of its own)" for old, new in zip(extra.names, names) if old != new]


def _extra_columns(record_path, mapping, record) -> dict:
    """The record file's extra columns as the file has them, under their output names
    (:mod:`creepcomp.io.extra_columns`)."""
    from creepcomp.io.extra_columns import open_extra_columns, output_names

    with open_extra_columns(record_path, mapping) as extra:
        cells = extra.take(len(record))
        names = output_names(extra.names, [*dict(record.columns()), "compensated", "load_estimate"])
    return {new: cells[old] for old, new in zip(extra.names, names)}


def _extension_inverses(model) -> dict:
    """How the correction undoes each of the model's extensions (a refusal naming the first
    it cannot undo)."""
    if not model.extensions:
        return {}
    from creepcomp.diagnose.effects import extension_inverses

    return extension_inverses(model)


def _compensate_extended(record, model, method, start, hold, temps):
    """The correction of a model with extensions: the load whose simulation through the whole
    model equals the signal, as an instantaneous (or saturated) signal."""
    import numpy as np

    from creepcomp.diagnose.effects import compensate_extended
    from creepcomp.digital.correctors import saturation_factor

    if temps is not None and np.ndim(temps) == 0:
        temps = np.full(len(record), float(temps))
    if temps is None and record.temperature is not None:
        temps = record.temperature
    path = model.transfer
    signal = record.signal if path is None else path.linearise_within(record.signal)
    out = compensate_extended(record.time, signal, model, temps, initial=start, hold=hold, strict=True)
    out = model.offset + saturation_factor(model, method) * (out - model.offset)
    return out if path is None else path.delinearise(out)


def _load_figures(rms: float | None, scan) -> dict:
    """The load estimate's RMS error in load units and as a fraction of full scale (the
    largest ``|load|``)."""
    import math

    finite = rms is not None and math.isfinite(rms)
    full = scan.largest_load
    return {"column": "load_estimate", "rms": rms if finite else None, "unit": scan.unit("load"),
            "rms_fraction": (rms / full) if finite and full > 0 else None}


def _fitted_rms(values, load) -> float | None:
    """RMS error against the load scaled by least squares (the diagnosis's figure)."""
    from creepcomp.digital.correctors import FittedReferenceSum

    total = FittedReferenceSum()
    total.add(values, load)
    return total.result()


def _starts_loaded(scan) -> bool:
    return scan.largest_load > 0 and abs(scan.first_load) > LOADED_START * scan.largest_load


def _notes(scan, start: str, method: str, model) -> list[str]:
    notes = []
    if _starts_loaded(scan):
        load0 = f"{scan.first_load:.4g} {scan.unit('load')}".strip()
        if start == "relaxed":
            notes.append(f"the record starts loaded (load {load0} at t = {scan.first_time:.4g} s); a "
                         "relaxed start assumes the sensor was unloaded before the first sample "
                         "(as when a creep test starts at its load step). If it had been held at "
                         "this load until its creep settled, use --initial settled.")
        else:
            notes.append(f"the record starts loaded (load {load0} at t = {scan.first_time:.4g} s); a "
                         "settled start assumes its creep had saturated at that level. If the load "
                         "was applied just before, use --initial relaxed.")
    if scan.largest_load == 0:
        notes.append("the load is zero throughout: errors cannot be given as a fraction of full scale")
    return notes


def _value(value: float, unit: str) -> str:
    """A signal value with its unit (SI prefix), or a plain number when the unit is unknown."""
    return format_quantity(value, unit) if unit else f"{value:.4g}"


def _render(path, scan, model, result, before, after, dt, unit, notes) -> None:
    sampling = (f"uniform, every {format_quantity(dt, 's')}" if dt is not None else
                f"irregular, steps {format_quantity(scan.step_min, 's')} to "
                f"{format_quantity(scan.step_max, 's')}") if scan.samples > 1 else "1 sample"
    console.print(f"[bold]creepcomp correct[/bold]: {path}, {scan.samples} samples ({sampling}); "
                  f"{result['method']} method, {result['initial']} start, {HOLD_TEXT[result['hold']]}",
                  soft_wrap=True)
    console.print(f"model: {describe_model(model)}; gain {model.gain:.6g}, offset "
                  f"{_value(model.offset, unit)}", soft_wrap=True)
    if result["temperature"] is not None and result["temperature"]["source"] == "unused":
        console.print("temperature: the record's 'temperature' column is not used (the model has "
                      "no temperature law)", soft_wrap=True)
    elif result["temperature"] is not None:
        law = model.temperature
        where = ("the record's 'temperature' column" if result["temperature"]["source"] == "column"
                 else f"{result['temperature']['constant_C']:g} °C throughout")
        amplitudes = ", each sample with its own beta_k(T)" if law.beta_per_kelvin else ""
        console.print(f"temperature: {where}; {law.law} law about {law.reference:g} °C, each step "
                      f"with its own tau_k(T){amplitudes}", soft_wrap=True)
    for name, how in result["extensions"].items():
        console.print(f"extension {name}: {how}", soft_wrap=True)
    console.print(f"reference: {result['reference']} "
                  f"({'instantaneous' if result['method'] == 'subtractive' else 'saturated'} signal); "
                  f"full scale {_value(after.full_scale, unit)}")
    fitted = result["fitted_reference_rms"]
    table = correction_table(before, after, unit, (fitted["before"], fitted["after"])).to_rich()
    console.print(table)
    if model.is_static:
        console.print("a static calibration: it has no creep to remove; the load comes back "
                      "through its map")
    elif result["reduction"] is not None:
        console.print(f"peak creep error reduced {result['reduction']:.3g}-fold")
    load = result["load_estimate"]
    if load["rms"] is not None:
        share = f" ({format_percent(load['rms_fraction'])} of full scale)" if load["rms_fraction"] else ""
        filtered = f", then {load['load_filter']}" if load["load_filter"] else ""
        console.print(f"load estimate (the model's inverse{filtered}, in load units): RMS error "
                      f"{_value(load['rms'], load['unit'])}{share}", soft_wrap=True)
    for note in notes:
        console.print(f"[yellow]note:[/yellow] {note}")
