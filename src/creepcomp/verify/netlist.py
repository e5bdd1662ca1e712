"""ngspice netlists of a design driven by synthetic or measured creep.

The netlist holds the whole experiment, not just the network:

* synthetic creep: the load program is a PWL source (normalised to full scale 1); a VCVS
  turns it into the sensor's instantaneous signal ``S_ins`` (``signal`` volts at full
  scale); each Prony term is an RC lag of ``S_ins`` (``R C = tau_k``); a B source sums
  ``S_ins + sum beta_k lag_k``, the creeping sensor output, which drives the network
  through the sensor's source resistance. The netlist stays small whatever the duration,
  and ngspice simulates the creep itself.
* a measured record: its ``signal`` column drives the network through an XSPICE
  ``filesource`` that reads a two-column text file next to the netlist (linear
  interpolation between samples), so a long record never becomes inline PWL text.

The bundled reference designs and their netlists (``netlists/``) are written here too.
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from creepcomp.analog.parts import PART_REFERENCE, PartsPlan, ThermistorUse, network_at
from creepcomp.errors import InputError
from creepcomp.io.atomic import atomic_path, write_text_atomic
from creepcomp.model import CreepModel
from creepcomp.network import Network
from creepcomp.programs import LoadProgram
from creepcomp.temperature import GAS_CONSTANT, ZERO_CELSIUS, TemperatureLaw
from creepcomp.units import format_quantity
from creepcomp.verify.drive import (DEFAULT_POINTS, DEFAULT_SIGNAL, MAX_STEP_FRACTION,
                                    default_duration, largest_step, rise_time, spice_number,
                                    spice_program, synthetic_program)

__all__ = [
    "MAX_STEP_FRACTION", "RECORD_MAX_STEP_FRACTION", "RELTOL", "TRTOL", "VOLTAGE_TOLERANCE",
    "REFERENCE_CAPACITANCE", "OP_AMP_GAIN", "ascii_text", "Deck", "program_deck", "shift_expression", "record_arrays",
    "record_deck", "record_data", "write_record_data", "write_deck", "reference_designs", "reference_deck",
    "write_reference_netlists",
]

#: ngspice's largest time step while a record drives the netlist, as a fraction of the
#: median sample interval (ngspice does not step on the samples: the finer, the closer).
RECORD_MAX_STEP_FRACTION = 0.5
#: ngspice's relative tolerance (default 1e-3) and its truncation-error factor (default 7).
RELTOL = 1e-7
TRTOL = 1.0
#: ngspice's voltage tolerance relative to full scale (default VNTOL is an absolute 1 uV,
#: as large as 1 % of a 100 uV sensor signal).
VOLTAGE_TOLERANCE = 1e-9
#: Largest capacitor of the bundled reference designs (F).
REFERENCE_CAPACITANCE = 10e-6


def ascii_text(text: str) -> str:
    """Netlist-safe text: the few non-ASCII symbols the project prints, spelled out."""
    for a, b in (("µ", "u"), ("μ", "u"), ("Ω", "ohm"), ("±", "+/-"), ("−", "-")):
        text = text.replace(a, b)
    return text.encode("ascii", "replace").decode()


@dataclass(frozen=True)
class Deck:
    """An ngspice input deck: circuit, options, transient analysis, and what a standalone
    run (``ngspice -b FILE.cir``) prints.

    Attributes
    ----------
    title : str
        First line.
    circuit : str
        Element, model and comment lines (built with PySpice).
    options : tuple of (str, str)
        ``.options`` values.
    tran : (float, float, float)
        ``TSTEP``, ``TSTOP``, ``TMAX`` (s).
    control : tuple of str
        Lines of the ``.control`` block of a standalone run (after ``run``).
    data_file : str or None
        The file a ``filesource`` reads, as named in the netlist.
    nodes : dict
        Role (``load``, ``instantaneous``, ``sensor``, ``output``) -> node name.
    """

    title: str
    circuit: str
    options: tuple[tuple[str, str], ...]
    tran: tuple[float, float, float]
    control: tuple[str, ...] = ()
    data_file: str | None = None
    nodes: dict = field(default_factory=dict)

    def text(self, standalone: bool = True) -> str:
        """The netlist; ``standalone`` adds the ``.control`` block for ``ngspice -b``."""
        lines = [ascii_text(self.title), self.circuit.rstrip("\n")]
        lines.append(".options " + " ".join(f"{k}={v}" for k, v in self.options))
        tstep, tstop, tmax = self.tran
        lines.append(f".tran {spice_number(tstep)} {spice_number(tstop)} 0 {spice_number(tmax)}")
        if standalone:
            lines += [".control", "run", *self.control, "quit", ".endc"]
        lines.append(".end")
        return "\n".join(lines) + "\n"

    def with_data_file(self, path: str) -> "Deck":
        """The same deck reading its ``filesource`` data from ``path``."""
        if self.data_file is None:
            return self
        old = f'file="{self.data_file}"'
        return replace(self, circuit=self.circuit.replace(old, f'file="{path}"'), data_file=path)


class _Lines:
    """Netlist text built from PySpice elements, in order, with comments between them."""

    def __init__(self, title: str):
        from PySpice.Spice.Netlist import Circuit

        self.circuit = Circuit(title)
        self.lines: list[str] = []

    def comment(self, text: str) -> None:
        self.lines.append(f"* {ascii_text(text)}")

    def add(self, kind: str, name: str, *args, **kwargs) -> None:
        element = getattr(self.circuit, kind)(name, *args, **kwargs)
        self.lines.append(str(element))

    def add_with(self, suffix: str, kind: str, name: str, *args) -> None:
        """An element with ``suffix`` (instance parameters such as ``tc1=...``) after its value."""
        element = str(getattr(self.circuit, kind)(name, *args))
        self.lines.append(f"{element} {suffix}" if suffix else element)

    def raw(self, line: str) -> None:
        self.lines.append(line)

    def model(self, name: str, kind: str, **parameters) -> None:
        self.lines.append(str(self.circuit.model(name, kind, **parameters)))

    def text(self) -> str:
        return "\n".join(self.lines) + "\n"


def shift_expression(law: TemperatureLaw) -> str:
    """The law's shift factor ``a_T`` as an ngspice expression of ``temper`` (°C)."""
    n = spice_number
    if law.law == "arrhenius":
        return (f"exp({n(law.activation_energy / GAS_CONSTANT)}*(1/(temper+{n(ZERO_CELSIUS)})"
                f"-1/{n(law.reference + ZERO_CELSIUS)}))")
    return (f"exp(-{n(law.c1 * math.log(10.0))}*(temper-{n(law.reference)})"
            f"/({n(law.c2)}+temper-{n(law.reference)}))")


def _thermistor_expression(use: ThermistorUse) -> str:
    """An NTC thermistor's ``R(T)`` (:func:`creepcomp.analog.parts.ntc_resistance`) in ``temper``."""
    n = spice_number
    return (f"{n(use.r25)}*exp({n(use.b)}*(1/(temper+{n(ZERO_CELSIUS)})"
            f"-1/{n(PART_REFERENCE + ZERO_CELSIUS)}))")


def _resistor(out: _Lines, name: str, a: str, b: str, label: str, value: float,
              plan: PartsPlan | None) -> None:
    """A part resistor: plain, with its temperature coefficient, or an NTC thermistor (a
    behavioural resistor of ``temper``) with its series and parallel fixed resistors."""
    n = spice_number
    if plan is None:
        out.add("R", name, a, b, n(value))
        return
    use = plan.thermistors.get(label)
    if use is None:
        out.add_with(f"tc1={n(plan.resistor_tc)}", "R", name, a, b, n(value))
        return
    extra = (f", {format_quantity(use.series, 'ohm')} in series" if use.series > 0 else "") + (
        f", {format_quantity(use.parallel, 'ohm')} in parallel" if use.parallel is not None else "")
    out.comment(f"{label}: NTC thermistor {use.part} (R25 = {format_quantity(use.r25, 'ohm')}, "
                f"B = {use.b:g} K){extra}")
    mid = a
    if use.series > 0:
        mid = f"ntc{name}"
        out.add("R", f"{name}s", a, mid, n(use.series))
    out.raw(f"R{name} {mid} {b} R={{{_thermistor_expression(use)}}}")
    if use.parallel is not None:
        out.add("R", f"{name}p", a, b, n(use.parallel))


def _capacitor(out: _Lines, name: str, a: str, b: str, value: float, plan: PartsPlan | None) -> None:
    if plan is None:
        out.add("C", name, a, b, spice_number(value))
    else:
        out.add_with(f"tc1={spice_number(plan.capacitor_tc)}", "C", name, a, b, spice_number(value))


def _network_lines(out: _Lines, network: Network, input_node: str, ground: str = "0",
                   plan: PartsPlan | None = None) -> None:
    """The correction network between ``input_node`` and ``out`` (ground ``ground``); the
    next stage's input resistance when the network has one. With a ``plan``, its parts move
    with ``temper`` (TCs about ``tnom``, thermistors)."""
    n = spice_number
    if getattr(network, "topology", None) == "active":
        _active_lines(out, network, input_node, ground, plan)
        return
    many = len(network.cells) > 1
    out.comment("correction network: series cells R1 || C1 from the sensor to the output")
    node = input_node
    for k, cell in enumerate(network.cells, 1):
        suffix = f"_{k}" if many else ""
        nxt = "out" if k == len(network.cells) else f"n{k}"
        _resistor(out, f"1{suffix}", node, nxt, network.cell_label("R", k - 1), cell.R, plan)
        if cell.C > 0:
            _capacitor(out, f"1{suffix}", node, nxt, cell.C, plan)
        if cell.leakage is not None:
            out.comment(f"leakage of C1{suffix}")
            out.add("R", f"leak{suffix or '_1'}", node, nxt, n(cell.leakage))
        if cell.has_absorption:
            out.comment(f"dielectric absorption of C1{suffix}: a series R-C across it")
            mid = f"da{k}"
            out.add("R", f"da{suffix or '_1'}", node, mid, n(cell.absorption_R))
            out.add("C", f"da{suffix or '_1'}", mid, nxt, n(cell.absorption_C))
        node = nxt
    if network.R2 is not None:
        out.comment("R2 from the output to ground")
        _resistor(out, "2", "out", ground, "R2", network.R2, plan)
    for j, branch in enumerate(network.shunt, 1):
        suffix = f"_{j}" if len(network.shunt) > 1 else ""
        if j == 1:
            out.comment("lag network: series R-C branches from the output to ground")
        label = f"3{suffix.replace('_', '.')}"
        _resistor(out, f"3{suffix}", "out", f"s{j}", f"R{label}", branch.R, plan)
        _capacitor(out, f"3{suffix}", f"s{j}", ground, branch.C, plan)
    if network.load_resistance is not None:
        out.comment("input resistance of the next stage")
        out.add("R", "L", "out", ground, n(network.load_resistance))


#: Open-loop gain of the op amps of an active stage (VCVS): the ideal op amp of its
#: ``H(s)`` within ``1e-9``.
OP_AMP_GAIN = 1e9


def _active_lines(out: _Lines, stage, input_node: str, ground: str = "0",
                  plan: PartsPlan | None = None) -> None:
    """The active stage (:class:`creepcomp.active_stage.ActiveStage`) between ``input_node``
    and ``out``: op amps as voltage-controlled voltage sources of gain :data:`OP_AMP_GAIN`."""
    n = spice_number
    gain = n(OP_AMP_GAIN)
    out.comment(f"active correction stage: op amps as VCVS of gain {gain} (+ input at ground for "
                "an integrator)")
    if stage.input_buffer:
        out.comment("input follower Uin: the stage's input current does not load the sensor")
        out.raw(f"EUin buf {ground} {input_node} buf {gain}")
        input_node = "buf"
    for j, t in enumerate(stage.terms, 1):
        out.comment(f"term {j}: divider RA{j}/RB{j}/RG{j} at e{j}; integrator U{j} (RT{j}, C{j}) "
                    f"with output w{j}; summing resistor RS{j}")
        _resistor(out, f"A{j}", input_node, f"e{j}", f"RA{j}", t.RA, plan)
        _resistor(out, f"B{j}", f"w{j}", f"e{j}", f"RB{j}", t.RB, plan)
        _resistor(out, f"G{j}", f"e{j}", ground, f"RG{j}", t.RG, plan)
        _resistor(out, f"T{j}", f"e{j}", f"m{j}", f"RT{j}", t.RT, plan)
        _capacitor(out, f"{j}", f"m{j}", f"w{j}", t.C, plan)
        if t.leakage is not None:
            out.add("R", f"leak{j}", f"m{j}", f"w{j}", n(t.leakage))
        out.raw(f"EU{j} w{j} {ground} {ground} m{j} {gain}")
        _resistor(out, f"S{j}", f"w{j}", "s", f"RS{j}", t.RS, plan)
    out.comment("output summer RS0 from the input; follower U0")
    _resistor(out, "S0", input_node, "s", "RS0", stage.RS0, plan)
    out.raw(f"EU0 out {ground} s out {gain}")
    if stage.load_resistance is not None:
        out.comment("input resistance of the next stage")
        out.add("R", "L", "out", ground, n(stage.load_resistance))


def _source_resistance_lines(out: _Lines, network: Network, emf_node: str) -> str:
    """The sensor's source resistance; returns the node that drives the network."""
    if network.source_resistance > 0:
        out.comment("the sensor's source resistance")
        out.add("R", "s", emf_node, "sensor", spice_number(network.source_resistance))
        return "sensor"
    return emf_node


def _options(full_scale: float, network: Network) -> tuple[tuple[str, str], ...]:
    """Tolerances scaled to the signal level and the network: VNTOL a fraction
    :data:`VOLTAGE_TOLERANCE` of full scale, ABSTOL the current it drives through the
    smallest resistor, CHGTOL the charge it puts on the largest capacitor."""
    vntol = VOLTAGE_TOLERANCE * full_scale
    resistors = [v for _, kind, v in network.parts() if kind == "R"]
    resistors += [network.source_resistance or math.inf]
    capacitors = [v for _, kind, v in network.parts() if kind == "C"] or [1e-12]
    return (("reltol", spice_number(RELTOL)), ("trtol", spice_number(TRTOL)),
            ("vntol", spice_number(vntol)), ("abstol", spice_number(vntol / min(resistors))),
            ("chgtol", spice_number(vntol * max(capacitors))))


def program_deck(network: Network, model: CreepModel, program: LoadProgram, duration: float,
                 points: int = DEFAULT_POINTS, signal: float = DEFAULT_SIGNAL,
                 title: str = "creepcomp: correction network driven by a creeping sensor",
                 temperature: float | None = None, plan: PartsPlan | None = None) -> Deck:
    """The netlist of a design driven by synthetic creep.

    Parameters
    ----------
    network : Network
        Part values at :data:`creepcomp.analog.parts.PART_REFERENCE` when ``plan`` is given.
    model : CreepModel
        The sensor's creep (its ``gain`` and ``offset`` are not used: the drive is set by
        ``signal``).
    program : LoadProgram
        Load history; it is normalised to full scale 1 (the largest ``|load|``) and its
        steps become ramps (:func:`creepcomp.verify.drive.rise_time`).
    duration : float
        Simulated time (s).
    points : int
        Output spacing is ``duration / points``; ngspice's largest step is
        :data:`MAX_STEP_FRACTION` of it.
    signal : float
        Instantaneous sensor signal at full scale (V).
    title : str
        The netlist's title line.
    temperature : float, optional
        Simulated temperature (°C, ``.options temp``). The sensor's lags follow its
        temperature law in ``temper`` (lag resistor ``a_T`` ohm, amplitudes ``beta_k(T)``).
    plan : PartsPlan, optional
        With ``temperature``: the parts' temperature coefficients (``tc1`` about
        ``tnom = 25``) and thermistors (behavioural resistors of ``temper``).

    Returns
    -------
    Deck
    """
    if not signal > 0 or not math.isfinite(signal):
        raise InputError(f"signal = {signal!r}: must be a positive voltage")
    law = model.temperature if temperature is not None else None
    plan = plan if temperature is not None else None
    model_t = model.at_temperature(temperature) if temperature is not None else model
    network_t = network_at(network, plan, temperature) if plan is not None else network
    max_step = largest_step(duration, points)
    spice_prog = spice_program(program, model_t, network_t, max_step)
    n = spice_number
    out = _Lines(title)
    if temperature is not None:
        out.comment(f"simulated at {temperature:g} C (.options temp); "
                    + ("parts hold their values at 25 C (tnom) and move with their temperature "
                       "coefficients" if plan is not None else "parts fixed")
                    + ("; the sensor's retardation times follow its temperature law"
                       if law is not None else ""))
    out.comment(f"load program: {program.name}, normalised to full scale 1"
                + ("; steps as ramps of " + format_quantity(rise_time(model_t, network_t, max_step), "s")
                   if len(set(program.times)) < len(program.times) else ""))
    pwl = list(zip(spice_prog.times, spice_prog.loads))
    out.add("PieceWiseLinearVoltageSource", "load", "load", "0", values=pwl)
    out.comment(f"instantaneous (creep-free) sensor signal: {format_quantity(signal, 'V')} at full scale")
    out.add("VCVS", "ins", "ins", "0", "load", "0", n(signal))
    terms = []
    for k, (beta, tau) in enumerate(zip(model.beta, model.tau), 1):
        if law is None:
            out.comment(f"creep term {k}: beta = {beta:.6g}, tau = {tau:.6g} s: a lag of the "
                        "instantaneous signal (R = 1 ohm, C = tau)")
            out.add("R", f"creep{k}", "ins", f"creep{k}", "1")
        else:
            out.comment(f"creep term {k}: beta = {beta:.6g}, tau = {tau:.6g} s at "
                        f"{law.reference:g} C: a lag of the instantaneous signal (R = a_T ohm, "
                        "C = tau)")
            out.raw(f"Rcreep{k} ins creep{k} R={{{shift_expression(law)}}}")
        out.add("C", f"creep{k}", f"creep{k}", "0", n(tau))
        amplitude = n(abs(beta))
        if law is not None and law.beta_per_kelvin and law.beta_per_kelvin[k - 1]:
            amplitude += f"*(1+{n(law.beta_per_kelvin[k - 1])}*(temper-{n(law.reference)}))"
        terms.append(f"{'-' if beta < 0 else '+'} {amplitude}*V(creep{k})")
    out.comment("creeping sensor output: S_ins + sum beta_k lag_k")
    out.add("B", "sensor", "emf", "0", v="V(ins) " + " ".join(terms))
    node = _source_resistance_lines(out, network, "emf")
    _network_lines(out, network, node, plan=plan)
    spacing = duration / points
    hf = network_t.lag_expansion().direct
    control_lines = (
        f"* residual creep: (v(out) - H(inf) S_ins) / (H(inf) full scale); H(inf) = {hf:.12g} "
        "(capacitors shorted)",
        f"let hinf = {hf:.12g}",
        f"let full_scale = {n(signal)}",
        "let residual = (v(out) - hinf * v(ins)) / (hinf * full_scale)",
        "let residual_abs = abs(residual)",
        "meas tran residual_creep_peak max residual_abs",
        f"meas tran residual_creep_final find residual at={n(duration)}",
        "let uncorrected = (v(emf) - v(ins)) / full_scale",
        f"meas tran uncorrected_creep_final find uncorrected at={n(duration)}",
    )
    options = _options(signal, network_t)
    if temperature is not None:
        options += (("tnom", n(PART_REFERENCE)), ("temp", n(temperature)))
    return Deck(title, out.text(), options, (spacing, duration, max_step), control_lines, None,
                {"load": "load", "instantaneous": "ins", "sensor": "emf", "output": "out"})


def record_arrays(time, signal, name: str) -> tuple[np.ndarray, np.ndarray]:
    """A record's time (from 0) and signal as arrays, checked for a netlist.

    Raises
    ------
    InputError
        Unequal lengths, time not strictly increasing, values not finite, constant signal.
    """
    t = np.asarray(time, float)
    v = np.asarray(signal, float)
    if t.ndim != 1 or t.shape != v.shape or len(t) < 2 or np.any(np.diff(t) <= 0):
        raise InputError(f"{name}: time and signal must be equal-length, time strictly increasing")
    if not np.all(np.isfinite(v)):
        raise InputError(f"{name}: the signal has values that are not finite")
    if np.ptp(v) == 0:
        raise InputError(f"{name}: the signal is constant: nothing to simulate")
    return t - t[0], v


def record_deck(network: Network, time, signal, data_file: str = "record-signal.txt",
                title: str = "creepcomp: correction network driven by a measured record",
                name: str = "record") -> Deck:
    """The netlist of a design driven by a measured signal read from ``data_file``.

    The file (see :func:`record_data`) holds two columns, time from 0 (s) and signal (V),
    read by an XSPICE ``filesource`` (linear between samples). ngspice steps at most
    :data:`RECORD_MAX_STEP_FRACTION` of the median sample interval.
    """
    rel, v = record_arrays(time, signal, name)
    duration = float(rel[-1])
    interval = float(np.median(np.diff(rel)))
    n = spice_number
    out = _Lines(title)
    out.comment(f"measured sensor signal, read from {data_file} (time and volts, "
                "linear between samples)")
    out.add("A", "record", "%vd([emf 0])", model="record_signal")
    out.model("record_signal", "filesource", file=f'"{data_file}"', amploffset="[0]",
              amplscale="[1]", timeoffset=0, timescale=1, timerelative="false", amplstep="false")
    node = _source_resistance_lines(out, network, "emf")
    _network_lines(out, network, node)
    control_lines = (
        "meas tran output_min min v(out)",
        "meas tran output_max max v(out)",
        f"meas tran output_final find v(out) at={n(duration)}",
    )
    return Deck(title, out.text(), _options(float(np.ptp(v)), network),
                (interval, duration, interval * RECORD_MAX_STEP_FRACTION),
                control_lines, data_file, {"sensor": "emf", "output": "out"})


def record_data(time, signal) -> str:
    """Text of a ``filesource`` file: time from 0 (s) and signal, each number in its shortest
    exact form, and one more line an interval after the last sample holding its value: the
    netlist's stop time (12 digits) can lie a rounding past the last sample, where a
    filesource with no next line gives 0 V over the whole last interval."""
    buf = io.BytesIO()
    _write_record_data(buf, time, signal)
    return buf.getvalue().decode("ascii")


def _write_record_data(fh, time, signal, rows: int = 500_000) -> None:
    import pyarrow as pa
    import pyarrow.csv as pacsv

    t0 = float(time[0])
    t = np.asarray(time, float)
    v = np.asarray(signal, float)
    n = len(t)
    options = pacsv.WriteOptions(include_header=False, delimiter=" ")
    for lo in range(0, n, rows):
        hi = min(lo + rows, n)
        tt, vv = t[lo:hi] - t0, v[lo:hi]
        if hi == n:
            tt = np.append(tt, 2.0 * (t[-1] - t0) - (t[-2] - t0))
            vv = np.append(vv, v[-1])
        pacsv.write_csv(pa.table({"t": tt, "v": vv}), fh, options)


def write_record_data(path: str | Path, time, signal) -> Path:
    """Write :func:`record_data`'s text to ``path`` atomically, in blocks (for long records)."""
    p = Path(path)
    with atomic_path(p) as tmp, tmp.open("wb") as fh:
        _write_record_data(fh, time, signal)
    return p


def write_deck(path: str | Path, deck: Deck, data=None) -> Path:
    """Write a standalone netlist (and the data file its ``filesource`` reads, beside it),
    each atomically; ``data`` is the data file's text or a ``(time, signal)`` pair."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    if deck.data_file is not None:
        if data is None:
            raise InputError("a record netlist needs its data")
        target = p.parent / deck.data_file
        if isinstance(data, str):
            write_text_atomic(target, data)
        else:
            write_record_data(target, *data)
    write_text_atomic(p, deck.text(standalone=True))
    return p


def reference_designs() -> dict:
    """The bundled designs whose netlists live in ``netlists/``, by file stem.

    The default sensor by the paper's rule and exactly, a 3-term Foster chain, and a lag
    network for an overshooting (negative-creep) sensor; all with ideal part values at
    C = 10 uF, so their residual creep is the rule's own.

    Returns
    -------
    dict
        Stem -> (:class:`creepcomp.io.jsonfiles.Design`, description).
    """
    from creepcomp.data import default_sensor
    from creepcomp.io.jsonfiles import Design
    from creepcomp.analog.sizing import ideal_network

    default = default_sensor()
    foster = CreepModel((0.01, 0.01, 0.015), (5.0, 50.0, 500.0))
    negative = CreepModel((-0.02, -0.01), (20.0, 120.0))
    c = REFERENCE_CAPACITANCE
    return {
        "default-paper": (Design(default, ideal_network(default, "paper", c), {"rule": "paper"}),
                          "default sensor (beta0 = 3 %, tau = 45 s), paper's rule, ideal parts"),
        "default-exact": (Design(default, ideal_network(default, "exact", c), {"rule": "exact"}),
                          "default sensor (beta0 = 3 %, tau = 45 s), exact rule, ideal parts"),
        "foster3-exact": (Design(foster, ideal_network(foster, "exact", c), {"rule": "exact"}),
                          "3-term Prony sensor (tau = 5, 50, 500 s), exact Foster chain"),
        "negative-lag": (Design(negative, ideal_network(negative, "exact", c), {"rule": "exact"}),
                         "overshooting sensor (beta = -2 %, -1 %), exact lag network"),
    }


def reference_deck(design, description: str) -> Deck:
    """The netlist of a bundled design: a load step, default drive and time points."""
    program = synthetic_program(design.model, "step", design.network)
    duration = default_duration(program, design.model, design.network)
    return program_deck(design.network, design.model, program, duration,
                        title=f"creepcomp: {description}; load step")


def write_reference_netlists(folder: str | Path = "netlists") -> list[Path]:
    """Write each bundled design (``STEM.json``) and its netlist (``STEM.cir``) into ``folder``.

    The text is deterministic (no dates, no absolute paths): a test regenerates it and
    compares with the committed files.
    """
    from creepcomp.io.jsonfiles import write_design

    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for stem, (design, description) in reference_designs().items():
        written.append(write_design(out / f"{stem}.json", design))
        deck = reference_deck(design, description)
        header = (f"* {ascii_text(description)}\n* written by creepcomp (make netlists); "
                  f"run it with: ngspice -b {stem}.cir\n")
        path = out / f"{stem}.cir"
        text = deck.text()
        first, rest = text.split("\n", 1)
        write_text_atomic(path, f"{first}\n{header}{rest}")
        written.append(path)
    return written
