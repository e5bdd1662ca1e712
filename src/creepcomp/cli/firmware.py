"""``creepcomp firmware``: the digital corrector of a model as portable C, with its worst-case
error bound, verified against the float64 corrector on a record."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from creepcomp.errors import InputError
from creepcomp.cli.common import app, console, fail, print_json, quantity

#: Exit status when the measured error of ``--verify`` exceeds the proven bound.
BOUND_EXCEEDED = 3


@app.command("firmware")
def firmware_command(
    model_file: Path = typer.Argument(..., metavar="MODEL", help="Model file (beta, tau; offset)."),
    output: Optional[Path] = typer.Option(None, "-o", "--output", metavar="DIR",
                                          help="Folder for NAME.h and NAME.c."),
    method: str = typer.Option("subtractive", "--method", metavar="subtractive|supplemental",
                               help="Output the instantaneous signal, or the saturated one."),
    precision: str = typer.Option("float32", "--precision", metavar="float32|q31",
                                  help="Single-precision floats, or 32-bit words with 64-bit states."),
    state: str = typer.Option("compensated", "--state", metavar="compensated|plain",
                              help="float32 at a fixed rate: each creep state a float with its "
                                   "rounding error carried (compensated), or one float (plain: "
                                   "fewer operations, a bound larger by about u tau/T)."),
    rate: Optional[str] = typer.Option(None, "--rate", metavar="HZ",
                                       help="Sample rate, e.g. 100Hz, 1k. Default with --verify: "
                                            "the record's."),
    max_interval: Optional[str] = typer.Option(None, "--max-interval", metavar="TIME",
                                               help="Generate the dt step for irregular sampling "
                                                    "instead of a fixed rate: intervals from 1 us "
                                                    "to TIME (e.g. 40ms) are accepted."),
    full_scale: Optional[str] = typer.Option(None, "--full-scale", metavar="VALUE",
                                             help="Largest |signal - offset| (signal units) the "
                                                  "bound assumes and q31 scales to; for a model "
                                                  "with static maps also LOW:HIGH, the raw "
                                                  "signal's range. Default with --verify: the "
                                                  "record's."),
    temperature_range: Optional[str] = typer.Option(None, "--temperature-range", metavar="LOW:HIGH",
                                                    help="For a model with a temperature law: "
                                                         "the range (°C) the step clamps to and "
                                                         "its bound holds over. Default -40:85. "
                                                         "The step then takes the temperature with "
                                                         "every sample (float32: °C; q31: °C x 256)."),
    library: Optional[Path] = typer.Option(None, "--library", metavar="DIR",
                                           help="Write the corrector as an Arduino library (library."
                                                "properties, src/, examples for the HX711 and "
                                                "NAU7802) with a PlatformIO library.json."),
    name: str = typer.Option("creep", "--name", metavar="NAME",
                             help="Prefix of the C identifiers and the file names."),
    verify_record: Optional[Path] = typer.Option(None, "--verify", metavar="RECORD",
                                                 help="Compile (gcc, or for --target), run over the "
                                                      "record's samples, compare with the float64 "
                                                      "corrector."),
    target: str = typer.Option("host", "--target", metavar="host|avr|cortex-m0plus|cortex-m4f",
                               help="Where --verify runs the corrector: this machine (gcc), or "
                                    "cross-compiled on a simulated chip: the ATmega328P (simavr, "
                                    "cycles) or a Cortex-M (QEMU, instructions). Reports flash, "
                                    "RAM and the cost per sample."),
    columns: Optional[str] = typer.Option(None, "--columns", metavar="MAP",
                                          help="Column mapping of the record, e.g. time=t,signal=V."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
) -> None:
    """Write the creep corrector of a model as C99 with its proven error bound; verify it."""
    from creepcomp.digital.correctors import uniform_interval
    from creepcomp.digital.firmware import PRECISIONS, STATES, generate_firmware
    from creepcomp.digital.firmware_library import library_contents
    from creepcomp.digital.firmware_target import TARGETS
    from creepcomp.io.jsonfiles import read_model
    from creepcomp.io.outputs import check_outputs
    from creepcomp.io.records import parse_columns, read_record

    check_outputs(dirs={"-o": output, "--library": library}, inputs=[model_file, verify_record],
                  contents={"-o": (f"{name}.h", f"{name}.c"),
                            "--library": library_contents(name)})
    method = method.strip().lower()
    precision = precision.strip().lower()
    if precision not in PRECISIONS:
        raise InputError(f"--precision '{precision}': use float32 or q31")
    state = state.strip().lower()
    if state not in STATES:
        raise InputError(f"--state '{state}': use compensated or plain")
    target = target.strip().lower()
    if target not in TARGETS:
        raise InputError(f"--target '{target}': use {', '.join(TARGETS)}")
    if target != "host" and verify_record is None:
        raise InputError(f"--target {target} runs the corrector over a record: give --verify RECORD")
    model, polynomial, extension = _linear_part(read_model(model_file))
    rate_hz = quantity(rate, "hertz", "--rate", positive=True)
    longest = quantity(max_interval, "second", "--max-interval", positive=True)
    scale = _full_scale(full_scale)
    record, unit = None, "signal units"
    if verify_record is not None:
        import numpy as np

        record = read_record(verify_record, columns=parse_columns(columns))
        unit = record.unit("signal") or unit
        dt = uniform_interval(record.time)
        if rate_hz is None and longest is None and dt is None and model.is_static:
            rate_hz = (len(record.time) - 1) / float(record.time[-1] - record.time[0])  # no dynamics
        if rate_hz is None and longest is None:
            if dt is None:
                raise InputError(f"{verify_record}: not uniformly sampled; give --max-interval TIME "
                                 "for the dt step (irregular sampling)")
            rate_hz = 1.0 / dt
        if scale is None and (model.transfer is not None or model.is_static):
            scale = (float(np.min(record.signal)), float(np.max(record.signal)))
        if scale is None:
            scale = float(np.max(np.abs(record.signal - model.offset)))
            if scale == 0:
                raise InputError(f"{verify_record}: the signal equals the offset throughout; give "
                                 "--full-scale")
    if rate_hz is None and longest is None:
        raise InputError("give the sample rate: --rate HZ (e.g. --rate 100Hz), or --max-interval "
                         "TIME for irregular sampling")
    if scale is None:
        raise InputError("give the input range the bound assumes: --full-scale VALUE, the largest "
                         "|signal - offset| in signal units")
    firmware = generate_firmware(model, method, precision, rate_hz or 1.0, scale, name,
                                 max_interval=longest,
                                 temperature_range=_celsius_range(temperature_range),
                                 output_polynomial=polynomial, extension=extension,
                                 state=state)
    result = {"model": str(model_file), "method": method, "precision": precision,
              "state": firmware.state,
              "rate": firmware.rate, "max_interval": firmware.max_interval, "full_scale": firmware.full_scale, "name": name,
              "signal_unit": unit, "files": [], "bound_fs": firmware.bound.total_fs,
              "bound": firmware.bound.to_dict(),
              "extensions": sorted(read_model(model_file).extensions or {})}
    if firmware.temperature_range is not None:
        result["temperature_range"] = list(firmware.temperature_range)
    if firmware.maps is not None:
        result["maps"] = dict(firmware.maps)
    check = None
    if record is not None:
        from creepcomp.digital.firmware_check import verify_firmware

        if firmware.temperature_range is not None and record.temperature is None:
            raise InputError(f"{verify_record}: the model has a temperature law; verifying its "
                             "firmware needs a 'temperature' column (°C) in the record")
        check = verify_firmware(firmware, record.time, record.signal,
                                temperature=(None if firmware.temperature_range is None
                                             else record.temperature),
                                reference=_extended_reference(read_model(model_file), firmware, record),
                                target=target)
        result.update(check.to_dict())
        result["record"] = str(verify_record)
    # written after the verification: an interrupted --verify leaves no C files
    if output is not None:
        result["files"] = [str(p) for p in firmware.write(output)]
    if library is not None:
        from creepcomp.digital.firmware_library import write_library

        result["files"] += [str(p) for p in write_library(firmware, library)]
    if as_json:
        print_json(result)
    else:
        _render(result, firmware, check)
    if check is not None and not check.passed:
        if check.load is not None and check.load["max_error"] > check.load["bound"]:
            fail(f"measured load error {check.load['max_error']:.3e} load units at sample "
                 f"{check.load['worst_sample']} exceeds the proven bound {check.load['bound']:.3e}",
                 BOUND_EXCEEDED)
            raise typer.Exit(BOUND_EXCEEDED)
        fail(f"measured error {check.max_error_fs:.3e} of full scale at sample {check.worst_sample} "
             f"exceeds the proven bound {firmware.bound.total_fs:.3e}", BOUND_EXCEEDED)
        raise typer.Exit(BOUND_EXCEEDED)


def _full_scale(text: str | None):
    """``--full-scale``: a number (the largest |signal - offset|), or ``LOW:HIGH`` (a raw range,
    for a model with static maps)."""
    if text is None or ":" not in str(text):
        return quantity(text, "number", "--full-scale", positive=True)
    parts = str(text).split(":")
    if len(parts) != 2:
        raise InputError(f"--full-scale = '{text}': expected VALUE or LOW:HIGH (a raw range)")
    low, high = (quantity(p, "number", "--full-scale") for p in parts)
    if not low < high:
        raise InputError(f"--full-scale = '{text}': LOW must be below HIGH")
    return low, high


def _linear_part(model):
    """The model without its extensions, the static polynomial of the one the C corrector
    applies or the map of another (None: no extension); a refusal naming an extension it
    cannot apply."""
    if not model.extensions:
        return model, None, None
    from creepcomp.diagnose.effects import firmware_output
    from creepcomp.model import CreepModel

    out = firmware_output(model)
    linear = CreepModel(model.beta, model.tau, model.gain, model.offset,
                        temperature=model.temperature, transfer=model.transfer)
    if "polynomial" in out:
        return linear, out["polynomial"], None
    return linear, None, out


def _extended_reference(model, firmware, record):
    """For a model with extensions: the exact inverse of the whole model, which ``creepcomp
    correct`` prints (started and held as the firmware is); None otherwise."""
    if not model.extensions:
        return None
    from creepcomp.diagnose.effects import compensate_extended
    from creepcomp.digital.correctors import default_initial

    return compensate_extended(record.time, record.signal, model, record.temperature,
                               initial=default_initial(firmware.method), hold="zero", strict=True)


def _celsius_range(text: str | None) -> tuple[float, float] | None:
    """``LOW:HIGH`` in °C (e.g. ``-40:85``), or None."""
    from creepcomp.cli.correct import celsius

    if text is None:
        return None
    parts = str(text).split(":")
    if len(parts) != 2:
        raise InputError(f"--temperature-range = '{text}': expected LOW:HIGH in °C, e.g. -40:85")
    low, high = (celsius(p, "--temperature-range") for p in parts)
    if not low < high:
        raise InputError(f"--temperature-range = '{text}': LOW must be below HIGH")
    return low, high


def _render(result: dict, firmware, check) -> None:
    from creepcomp.units import format_quantity

    console.print(f"[bold]creepcomp firmware[/bold]: {result['model']}, {result['method']} method, "
                  f"{result['precision']}, "
                  + ("plain states, " if firmware.state == "plain" else "")
                  + (format_quantity(result['rate'], 'Hz') if result["rate"] is not None else
                     f"dt step (irregular sampling, up to {format_quantity(result['max_interval'], 's')})")
                  + ", full scale "
                  f"{result['full_scale']:.6g} {result['signal_unit']}"
                  + ("" if firmware.temperature_range is None else
                     f"; temperature per update, {firmware.temperature_range[0]:g} to "
                     f"{firmware.temperature_range[1]:g} °C (clamped)"), soft_wrap=True)
    if firmware.maps is not None:
        _render_maps(firmware, check, result["signal_unit"])
        if result["files"]:
            console.print("written: " + ", ".join(result["files"]), soft_wrap=True)
        else:
            console.print("no files written (give -o DIR or --library DIR)")
        return
    from creepcomp.report.results import bound_table

    console.print(bound_table(firmware.bound).to_rich())
    if check is not None:
        verdict = "within the bound" if check.passed else "ABOVE THE BOUND"
        if check.switching is not None and "events" in check.switching:
            console.print(f"the load's turns within the overshoot's decay on this record (discounted): "
                          f"{check.switching['events']:.3g}; bound on this record {check.bound_fs:.3e}",
                          soft_wrap=True)
        elif check.switching is not None:
            console.print(f"mode decisions within the switching margin on this record: "
                          f"{check.switching['steps']}, adding {check.switching['added_fs']:.3e} of full "
                          f"scale: bound on this record {check.bound_fs:.3e}", soft_wrap=True)
        cost = _cost(check)
        console.print(f"verified on {result['record']}: {check.samples} samples, largest error "
                      f"{check.max_error_fs:.3e} of full scale ({verdict}); {cost}", soft_wrap=True)
    if result["files"]:
        console.print("written: " + ", ".join(result["files"]), soft_wrap=True)
    else:
        console.print("no files written (give -o DIR or --library DIR)")


def _render_maps(firmware, check, unit: str) -> None:
    """The bound of a corrector with static maps, stage by stage, and its verification."""
    from creepcomp.units import format_quantity

    maps = firmware.maps
    low, high = maps["raw_range"]
    window = maps.get("load_filter")
    console.print(f"maps: {firmware.model.transfer.describe() if firmware.model.transfer else 'none'}"
                  f"; raw range {low:.9g} to {high:.9g} {unit}"
                  + ("" if window is None else
                     f"; load filter: the mean of the last {window['samples']} loads "
                     f"({format_quantity(window['window'], 's')})"), soft_wrap=True)
    from creepcomp.report.results import maps_bound_table

    console.print(maps_bound_table(firmware, unit).to_rich())
    if check is not None:
        verdict = "within the bounds" if check.passed else "ABOVE A BOUND"
        console.print(f"verified on {check.samples} samples ({check.load['compared']} compared, "
                      f"{check.load['outside']} with the exact corrected value outside the bounds' "
                      f"range): largest error {check.max_error_fs:.3e} of full scale in the compensated "
                      f"signal, {check.load['max_error']:.3e} load units in the load ({verdict}); "
                      + _cost(check), soft_wrap=True)


def _cost(check) -> str:
    """The verified step's cost: time and object size on this machine, or on the chip."""
    from creepcomp.digital.firmware_target import TOOLCHAINS

    run = check.on_target
    if run is None:
        return (f"{check.ns_per_sample:.1f} ns per sample on this machine; object "
                f"{check.object_bytes} bytes (gcc -O2, text + data)")
    return (f"on {TOOLCHAINS[run.target].chip}: {run.per_sample:.0f} {run.counts} per sample "
            + ("(mean)" if run.largest is None else f"(mean; largest {run.largest})")
            + f", flash {run.flash_bytes} bytes, RAM {run.ram_bytes} "
            f"bytes (state {run.state_bytes} bytes, stack {run.stack_bytes} bytes)")
