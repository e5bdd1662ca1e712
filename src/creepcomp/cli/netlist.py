"""``creepcomp netlist``: an ngspice netlist of a design driven by synthetic creep or a record."""

from __future__ import annotations

import shlex

from dataclasses import dataclass
from pathlib import Path
from typing import Optional

import typer

from creepcomp.verify.drive import (DEFAULT_POINTS, DEFAULT_SIGNAL, PROGRAMS, default_duration,
                                    synthetic_program)
from creepcomp.verify.netlist import Deck, program_deck, record_deck, write_deck
from creepcomp.errors import InputError
from creepcomp.io.jsonfiles import Design
from creepcomp.io.outputs import check_outputs
from creepcomp.programs import LoadProgram
from creepcomp.io.records import Record, parse_columns, read_record
from creepcomp.units import format_quantity
from creepcomp.cli.common import (app, console, count_option, print_json, quantity, read_checked_design, si_text,
                                  temperatures_option)

#: Most time points of a synthetic drive.
MAX_POINTS = 1_000_000

PROGRAM_HELP = ("step: one load step; staircase: loading and unloading steps (the paper's "
                "fig. 2); sweep: triangular sweep between -FS and +FS (its fig. 6).")


@dataclass(frozen=True)
class Drive:
    """What the command line asked to drive the design with.

    Attributes
    ----------
    design : Design
    name : str
        ``step``, ``staircase``, ``sweep`` or ``record``.
    program : LoadProgram or None
        The synthetic load program (None for a record).
    record : Record or None
    duration : float or None
        Simulated time asked for (s).
    points : int
    signal : float
        Instantaneous signal at full scale (V).
    """

    design: Design
    name: str
    program: LoadProgram | None
    record: Record | None
    duration: float | None
    points: int
    signal: float


def read_drive(design_path: Path, program: str, record: Path | None, columns: str | None,
               duration: str | None, points: int, signal: str) -> Drive:
    """Check and read the options shared by ``netlist`` and ``simulate``."""
    design = read_checked_design(design_path, active=True)
    name = program.strip().lower()
    if name not in PROGRAMS:
        raise InputError(f"--program '{program}': choose one of {', '.join(PROGRAMS)}")
    if columns and record is None:
        raise InputError("--columns maps a record's columns: give --record FILE too")
    if not 10 <= points <= MAX_POINTS:
        raise InputError(f"--points {points}: use 10 to {MAX_POINTS} (more time points than a "
                         "plot or a residual-creep figure needs, at a cost in time and memory)")
    duration_s = quantity(duration, "second", "--duration", positive=True)
    signal_v = quantity(signal, "volt", "--signal", positive=True)
    if record is not None:
        if duration is not None:
            raise InputError("--duration does not apply to a record: it runs for the record's length")
        rec = read_record(record, parse_columns(columns))
        rec.require(n_samples=2, what="driving a netlist")
        return Drive(design, "record", None, rec, None, points, signal_v)
    prog = synthetic_program(design.model, name, design.network)
    return Drive(design, name, prog, None, duration_s, points, signal_v)


def drive_deck(drive: Drive, data_file: str = "record-signal.txt",
               temperature: float | None = None) -> tuple[Deck, tuple | None]:
    """The netlist of a drive, and its data file's ``(time, signal)`` (for a record; see
    :func:`creepcomp.verify.netlist.write_deck`); with ``temperature`` (°C) the netlist
    carries the parts' and the sensor's temperature behaviour and runs at it."""
    net, model = drive.design.network, drive.design.model
    if drive.record is not None:
        rec = drive.record
        source = Path(rec.source).name
        deck = record_deck(net, rec.time, rec.signal, data_file,
                           title=f"creepcomp: design driven by the record {source}",
                           name=rec.source)
        return deck, (rec.time, rec.signal)
    plan = None
    if temperature is not None:
        from creepcomp.analog.parts import network_at, plan_of

        plan = plan_of(drive.design)
        duration = drive.duration or default_duration(
            drive.program, model.at_temperature(temperature), network_at(net, plan, temperature))
    else:
        duration = drive.duration or default_duration(drive.program, model, net)
    deck = program_deck(net, model, drive.program, duration, drive.points, drive.signal,
                        title=f"creepcomp: design driven by synthetic creep, {drive.program.name}",
                        temperature=temperature, plan=plan)
    return deck, None


@app.command("netlist")
def netlist_command(
    design: Path = typer.Argument(..., metavar="DESIGN", help="Design file (creepcomp size -o)."),
    output: Optional[Path] = typer.Option(None, "-o", "--output", metavar="FILE.cir",
                                          help="Write the netlist here (default: print it)."),
    program: str = typer.Option("step", "--program", metavar="step|staircase|sweep",
                                help=PROGRAM_HELP),
    record: Optional[Path] = typer.Option(None, "--record", metavar="FILE.csv",
                                          help="Drive the network with a measured record's signal "
                                               "(read by an XSPICE file source from a data file "
                                               "written beside the netlist)."),
    columns: Optional[str] = typer.Option(None, "--columns", metavar="MAP",
                                          help="Column mapping of the record, e.g. time=tR,signal=Ri."),
    duration: Optional[str] = typer.Option(None, "--duration", metavar="TIME",
                                           help="Simulated time (default: the program's, and 20 "
                                                "time constants after a final step)."),
    points: int = typer.Option(DEFAULT_POINTS, "--points", metavar="N", parser=count_option("--points"),
                               help="Output time points; ngspice steps at most half their spacing."),
    signal: str = typer.Option(si_text(DEFAULT_SIGNAL), "--signal", metavar="VOLT",
                               help="Instantaneous sensor signal at full scale, e.g. 100u or 1V."),
    temperature: Optional[str] = typer.Option(
        None, "--temperature", metavar="T",
        help="Simulate at T °C: thermistors as behavioural resistors of temper, TCs on the "
             "fixed parts (tc1 about tnom = 25 °C), the sensor's tau(T) from its temperature law."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
    subckt: Optional[Path] = typer.Option(None, "--subckt", metavar="FILE.lib",
                                          help="Write the network alone as a plain SPICE "
                                               ".subckt (ports in, out, gnd) for any simulator."),
    asc: Optional[Path] = typer.Option(None, "--asc", metavar="FILE.asc",
                                       help="Write an LTspice schematic of the network with a "
                                            "step test bench."),
) -> None:
    """Write an ngspice netlist of the design, driven by synthetic creep or a measured record.

    The netlist runs on its own: ngspice -b FILE.cir prints the residual creep it measures.
    With --subckt or --asc, write the network for other simulators instead.
    """
    if subckt is not None or asc is not None:
        export_network(design, subckt, asc, output, record, as_json)
        return
    files = {"-o": output}
    if record is not None and output is not None:
        files["-o (its data file)"] = output.parent / f"{output.stem}-signal.txt"
    check_outputs(files, inputs=[design, record])
    drive = read_drive(design, program, record, columns, duration, points, signal)
    if drive.record is not None and output is None:
        raise InputError("--record needs -o FILE.cir: its data file is written beside the netlist")
    temp = None
    if temperature is not None:
        if drive.record is not None:
            raise InputError("--temperature applies to a synthetic drive (--program), not a record")
        temps = temperatures_option(temperature, "--temperature")
        if len(temps) != 1:
            raise InputError(f"--temperature '{temperature}': one temperature (°C) per netlist")
        temp = temps[0]
    data_name = f"{output.stem}-signal.txt" if output is not None else "record-signal.txt"
    deck, data = drive_deck(drive, data_name, temp)
    text = deck.text()
    if output is None:
        if as_json:
            print_json({"netlist": text, "bytes": len(text.encode())})
        else:
            console.print(text, markup=False, highlight=False, end="", soft_wrap=True)
        return
    write_deck(output, deck, data)
    info = {"netlist": str(output), "bytes": output.stat().st_size,
            "lines": text.count("\n"), "run": f"ngspice -b {shlex.quote(str(output))}"}
    if deck.data_file is not None:
        data_path = output.parent / deck.data_file
        info.update({"data_file": str(data_path), "data_bytes": data_path.stat().st_size,
                     "samples": len(drive.record)})
    if as_json:
        print_json(info)
        return
    console.print(f"netlist written to {output} ({info['lines']} lines, "
                  f"{format_quantity(info['bytes'], 'B')})")
    if deck.data_file is not None:
        console.print(f"signal data written to {info['data_file']} ({info['samples']} samples, "
                      f"{format_quantity(info['data_bytes'], 'B')}), read by an XSPICE filesource")
    console.print(f"run it with: ngspice -b {shlex.quote(str(output))}", markup=False)


def export_network(design_path: Path, subckt: Path | None, asc: Path | None,
                   output: Path | None, record: Path | None, as_json: bool) -> None:
    """``netlist --subckt/--asc``: the network for other simulators."""
    from creepcomp.analog.parts import plan_of
    from creepcomp.io.atomic import write_text_atomic
    from creepcomp.verify.netlist_export import SUBCKT_NAME, asc_text, subckt_text

    if output is not None or record is not None:
        raise InputError("--subckt and --asc write the network alone: leave out -o and --record")
    check_outputs({"--subckt": subckt, "--asc": asc}, inputs=[design_path])
    design = read_checked_design(design_path)
    plan = plan_of(design, str(design_path))
    written = {}
    if subckt is not None:
        write_text_atomic(subckt, subckt_text(design.network, plan=plan,
                                              title=f"creepcomp correction network of {design_path.name}"))
        written["subckt"] = str(subckt)
    if asc is not None:
        write_text_atomic(asc, asc_text(design.network))
        written["asc"] = str(asc)
    if as_json:
        print_json(dict(written, name=SUBCKT_NAME, ports=["in", "out", "gnd"]))
        return
    if subckt is not None:
        console.print(f"subcircuit {SUBCKT_NAME} (ports in out gnd) written to {subckt}: "
                      f".include it and place X1 IN OUT 0 {SUBCKT_NAME}", soft_wrap=True)
    if asc is not None:
        console.print(f"LTspice schematic with a step test bench written to {asc}", soft_wrap=True)
