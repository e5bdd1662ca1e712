"""A design in ngspice and in python-control on the same time points, and their agreement.

The python-control reference simulates the same ``H(s) G(s)`` cascade as the netlist; the
two are compared as a fraction of full scale (the step, for a step program). A measured
record's reference is the network's exact lag discretisation at ngspice's own time points.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from creepcomp.analog.parts import PartsPlan, network_at
from creepcomp.analog.quality import corrected_system
from creepcomp.display import Shown, data_frame
from creepcomp.errors import InputError
from creepcomp.lti import is_uniform
from creepcomp.model import CreepModel
from creepcomp.network import Network
from creepcomp.programs import LoadProgram
from creepcomp.verify.drive import (DEFAULT_POINTS, DEFAULT_SIGNAL, checked_times,
                                    default_duration, largest_step, program_breakpoints, spice_program,
                                    synthetic_program, transient_times)
from creepcomp.verify.netlist import (Deck, program_deck, record_arrays, record_deck,
                                      write_record_data)
from creepcomp.verify.ngspice_engine import (Ngspice, NgspiceUnavailable, Waveforms, ngspice,
                                             waveforms_from_run)

if TYPE_CHECKING:
    import control

__all__ = ["reference_transient", "Comparison", "compare_program", "compare_temperatures", "compare_record",
           "at_sample_times"]


def _settled(sys: "control.StateSpace", u0: float) -> np.ndarray:
    A, B = np.asarray(sys.A), np.asarray(sys.B)[:, 0]
    return np.linalg.solve(A, -B * u0) if u0 else np.zeros(A.shape[0])


def _piecewise_response(sys: "control.StateSpace", t, u, edges) -> np.ndarray:
    """python-control ``forced_response`` segment by segment (uniform steps within each)."""
    import control

    y = np.empty(len(t))
    x = _settled(sys, u[0])
    y[0] = (np.asarray(sys.C) @ x + np.asarray(sys.D)[:, 0] * u[0])[0]
    for a, b in zip(edges[:-1], edges[1:]):
        idx = np.flatnonzero((t >= a) & (t <= b))
        if len(idx) < 2:
            continue
        seg = t[idx]
        if not is_uniform(seg):
            raise InputError(f"times between {a:g} and {b:g} s are not uniform: python-control "
                             "needs uniform steps (use transient_times)")
        r = control.forced_response(sys, seg - seg[0], u[idx], X0=x, return_states=True)
        y[idx] = np.atleast_1d(r.outputs)
        x = np.atleast_2d(r.states)[:, -1]
    return y


def reference_transient(network: Network, model: CreepModel, program: LoadProgram, times,
                        signal: float = DEFAULT_SIGNAL, max_step: float | None = None) -> Waveforms:
    """python-control's transient of the same experiment, on the same time points.

    ``G(s)`` (the sensor) and ``H(s) G(s)`` (the corrected output) are simulated with
    ``control.forced_response`` on each segment of ``times`` between the program's
    breakpoints (uniform steps; the input is linear in between, so the result is exact).
    ``max_step`` is the netlist's largest step (it sets the ramps, as in the netlist).
    """
    t = checked_times(times)
    prog = spice_program(program, model, network, max_step)
    edges = program_breakpoints(prog, float(t[-1]))
    missing = [e for e in edges if not np.any(np.isclose(t, e, rtol=0, atol=1e-9 * t[-1]))]
    if missing:
        raise InputError(f"times must include the program's breakpoints (missing {missing[0]:g} s); "
                         "use transient_times")
    u = prog.sample(t)
    sensor = _piecewise_response(model.state_space(), t, u, edges)
    output = _piecewise_response(corrected_system(model, network), t, u, edges)
    return Waveforms(t, signal * sensor, signal * output, signal * u)


@dataclass(frozen=True, eq=False)
class Comparison(Shown):
    """One design simulated by python-control and by ngspice on the same time points.

    Attributes
    ----------
    drive : str
        What drives the network (program name, or the record).
    full_scale : float
        Full-scale sensor signal (V): the step of a step program; the range of a record.
    hf_gain : float
        ``H(inf)``: the network's gain with its capacitors shorted.
    reference : Waveforms
        python-control (or, for an irregular record, the exact lag discretisation of H).
    spice : Waveforms or None
        ngspice on the same time points; None when ngspice is unavailable.
    reference_method : str
        How the reference was computed.
    ngspice_seconds : float or None
        Wall time of the ngspice run (load, transient, read back).
    ngspice_version : int or None
    ngspice_points : int or None
        ngspice's own time points.
    temperature : float or None
        Simulated temperature (°C); None: the design as it is.
    unavailable : str or None
        Why ngspice did not run.
    deck : Deck
        The netlist that ran (or would have run).
    """

    drive: str
    full_scale: float
    hf_gain: float
    reference: Waveforms
    spice: Waveforms | None
    reference_method: str
    ngspice_seconds: float | None
    ngspice_version: int | None
    ngspice_points: int | None
    unavailable: str | None
    deck: Deck
    temperature: float | None = None

    def residual(self, which: str = "spice") -> np.ndarray | None:
        """Residual creep ``(y - H(inf) S_ins) / (H(inf) FS)`` (None without ``S_ins``)."""
        w = self.spice if which == "spice" else self.reference
        if w is None or self.reference.instantaneous is None:
            return None
        return (w.output - self.hf_gain * self.reference.instantaneous) / (self.hf_gain * self.full_scale)

    def uncorrected_residual(self) -> np.ndarray | None:
        """The sensor's own creep ``(S_raw - S_ins) / FS`` (python-control)."""
        if self.reference.instantaneous is None:
            return None
        return (self.reference.sensor - self.reference.instantaneous) / self.full_scale

    @property
    def agreement_output(self) -> float | None:
        """Largest ``|ngspice - python-control|`` of the output, fraction of ``H(inf) FS``."""
        if self.spice is None:
            return None
        return float(np.max(np.abs(self.spice.output - self.reference.output))
                     / (self.hf_gain * self.full_scale))

    @property
    def agreement_sensor(self) -> float | None:
        """Largest ``|ngspice - python-control|`` of the creeping sensor signal, fraction of FS."""
        if self.spice is None or self.reference.instantaneous is None:
            return None
        return float(np.max(np.abs(self.spice.sensor - self.reference.sensor)) / self.full_scale)

    @property
    def agreement_max_abs(self) -> float | None:
        """The larger of :attr:`agreement_output` and :attr:`agreement_sensor`."""
        values = [v for v in (self.agreement_output, self.agreement_sensor) if v is not None]
        return max(values) if values else None

    def _residual_figures(self, which: str):
        e = self.residual(which)
        if e is None:
            return None, None, None
        k = int(np.argmax(np.abs(e)))
        return float(abs(e[k])), float(self.reference.time[k]), float(e[-1])

    @property
    def residual_creep_peak(self) -> float | None:
        """Largest ``|residual creep|``, from ngspice (python-control when it did not run)."""
        return self._residual_figures("spice" if self.spice is not None else "reference")[0]

    @property
    def residual_creep_final(self) -> float | None:
        """Residual creep at the end, from ngspice (python-control when it did not run)."""
        return self._residual_figures("spice" if self.spice is not None else "reference")[2]

    def __repr__(self) -> str:
        from creepcomp.units import format_percent

        peak = self.residual_creep_peak
        creep = "" if peak is None else f"peak residual creep {format_percent(peak)} of FS, "
        agree = (f"ngspice agrees to {self.agreement_max_abs:.2g} of FS" if self.spice is not None
                 else "ngspice not run")
        at = "" if self.temperature is None else f" at {self.temperature:g} °C"
        return f"<Comparison {self.drive}{at}: {creep}{agree}>"

    def to_pandas(self):
        """The waveforms (V) on the common time points (s): python-control's sensor and
        output, ngspice's output when it ran."""
        ref = self.reference
        columns = {"time": ref.time, "sensor": ref.sensor, "output": ref.output}
        if self.spice is not None:
            columns["output_ngspice"] = self.spice.output
        return data_frame(columns)

    def to_dict(self) -> dict:
        """JSON form (``simulate --json``): fractions of full scale, seconds, volts."""
        ref = self._residual_figures("reference")
        out = {
            "agreement_max_abs": self.agreement_max_abs,
            "residual_creep_peak": self.residual_creep_peak,
            "residual_creep_final": self.residual_creep_final,
            "drive": self.drive,
            "full_scale_signal": self.full_scale,
            "hf_gain": self.hf_gain,
            "duration": float(self.reference.time[-1]),
            "points": len(self.reference.time),
            "python_control": {"method": self.reference_method, "residual_creep_peak": ref[0],
                               "residual_creep_peak_time": ref[1], "residual_creep_final": ref[2]},
            "ngspice": {"available": self.unavailable is None, "reason": self.unavailable},
            "agreement": {"output_max_abs": self.agreement_output,
                          "sensor_max_abs": self.agreement_sensor},
            "netlist_bytes": len(self.deck.text().encode()),
        }
        if self.temperature is not None:
            out["temperature"] = self.temperature
        if self.spice is not None:
            spice = self._residual_figures("spice")
            out["ngspice"].update({"version": self.ngspice_version, "seconds": self.ngspice_seconds,
                                   "time_points": self.ngspice_points,
                                   "residual_creep_peak": spice[0],
                                   "residual_creep_peak_time": spice[1],
                                   "residual_creep_final": spice[2]})
        return out


def compare_program(network: Network, model: CreepModel, program: LoadProgram | str = "step",
                    duration: float | None = None, points: int = DEFAULT_POINTS,
                    signal: float = DEFAULT_SIGNAL, engine: Ngspice | None = None,
                    temperature: float | None = None, plan: PartsPlan | None = None) -> Comparison:
    """A design driven by synthetic creep, in python-control and in ngspice, compared.

    Parameters
    ----------
    network : Network
    model : CreepModel
    program : LoadProgram or {"step", "staircase", "sweep"}
        The load history (see :func:`synthetic_program`).
    duration : float, optional
        Simulated time (s); default :func:`default_duration`.
    points : int
        Time points (uniform within each segment of the program).
    signal : float
        Instantaneous signal at full scale (V).
    engine : Ngspice, optional
        Default: :func:`ngspice`. When it cannot be loaded, the comparison carries the
        python-control result alone and says why.
    temperature : float, optional
        Simulate at this temperature (°C): python-control with ``model.at_temperature(T)``
        cascaded with ``network_at(network, plan, T)``, ngspice with the netlist's
        temperature behaviour at ``.options temp = T``.
    plan : PartsPlan, optional
        The parts' temperature behaviour (with ``temperature``); None keeps the parts fixed.

    Returns
    -------
    Comparison
    """
    model_t = model.at_temperature(temperature) if temperature is not None else model
    network_t = (network_at(network, plan, temperature)
                 if temperature is not None and plan is not None else network)
    if isinstance(program, str):
        program = synthetic_program(model_t, program, network_t)
    if duration is None:
        duration = default_duration(program, model_t, network_t)
    max_step = largest_step(duration, points)
    as_simulated = spice_program(program, model_t, network_t, max_step)
    times = transient_times(as_simulated, duration, points)
    reference = reference_transient(network_t, model_t, program, times, signal, max_step)
    deck = program_deck(network, model, program, duration, points, signal,
                        temperature=temperature, plan=plan)
    hf = network_t.lag_expansion().direct
    spice, seconds, version, n_points, unavailable = None, None, None, None, None
    try:
        engine = engine or ngspice()
    except NgspiceUnavailable as exc:
        unavailable = str(exc)
    else:
        run = engine.run(deck)
        spice = waveforms_from_run(run, deck, times, program_breakpoints(as_simulated, duration))
        seconds, version, n_points = run.seconds, engine.version, len(run.time)
    return Comparison(program.name, signal, hf, reference, spice,
                      "python-control forced_response, uniform steps between the program's "
                      "breakpoints (exact for its piecewise-linear input)",
                      seconds, version, n_points, unavailable, deck, temperature)


def compare_temperatures(network: Network, model: CreepModel, plan: PartsPlan | None,
                         temperatures, program: str = "step", duration: float | None = None,
                         points: int = DEFAULT_POINTS, signal: float = DEFAULT_SIGNAL,
                         engine: Ngspice | None = None) -> list[Comparison]:
    """:func:`compare_program` at each of ``temperatures`` (°C), one comparison each."""
    return [compare_program(network, model, program, duration, points, signal, engine,
                            float(t), plan) for t in temperatures]


def compare_record(network: Network, time, signal, engine: Ngspice | None = None,
                   name: str = "measured record") -> Comparison:
    """A network driven by a measured signal, in ngspice (file source) and in Python, compared.

    ngspice reads the signal from a temporary file; the reference is the network's
    ``H(s)`` (from its state-space model) discretised exactly for a signal linear between
    samples, evaluated at ngspice's own time points, so nothing is interpolated.

    Parameters
    ----------
    network : Network
    time, signal : array_like
        The record's time (s, strictly increasing) and signal (treated as volts).
    engine : Ngspice, optional
    name : str
        Description for reports.

    Returns
    -------
    Comparison
    """
    rel, s = record_arrays(time, signal, name)
    full = float(np.ptp(s))
    lag = network.lag_expansion()
    hf = lag.direct
    deck = record_deck(network, rel, s, name=name)
    method = ("exact discretisation of H(s) from its state-space model, signal linear "
              "between samples, at ngspice's time points")
    try:
        engine = engine or ngspice()
    except NgspiceUnavailable as exc:
        out = lag.simulate(rel, s, hold="linear", initial="settled")
        return Comparison(name, full, hf, Waveforms(rel, s, out), None, method, None, None, None,
                          str(exc), deck)
    with tempfile.TemporaryDirectory(prefix="creepcomp-") as tmp:
        data = write_record_data(Path(tmp) / deck.data_file, rel, s)
        run = engine.run(deck.with_data_file(str(data)))
    # the netlist gives the stop time to 12 digits: its last point may lie a rounding past
    # the last sample, and is the one that holds the last sample's value
    keep = (run.time >= 0) & (run.time <= rel[-1] * (1.0 + 1e-11))
    tk = run.time[keep]
    grid = np.union1d(rel, tk)
    ref = lag.simulate(grid, np.interp(grid, rel, s), hold="linear", initial="settled")
    reference = Waveforms(tk, np.interp(tk, rel, s), ref[np.searchsorted(grid, tk)])
    spice = Waveforms(tk, run.vectors["emf"][keep], run.vectors["out"][keep])
    return Comparison(name, full, hf, reference, spice, method, run.seconds, engine.version,
                      len(run.time), None, deck)


def at_sample_times(points, values, times) -> np.ndarray:
    """An ngspice waveform read at a record's sample times.

    ngspice's own time points do not fall on the samples, where the (linear between
    samples) drive has its kinks: interpolating across a kink would mix both sides. Each
    sample's value is extrapolated from the last two ngspice points at or before it, which
    lie between it and the previous sample when ngspice steps at most half a sample
    interval (:data:`creepcomp.verify.netlist.RECORD_MAX_STEP_FRACTION`): the waveform is smooth there.

    Parameters
    ----------
    points, values : array_like
        ngspice's time points (s, increasing) and the waveform there.
    times : array_like
        Sample times on the same clock.

    Returns
    -------
    numpy.ndarray
    """
    tp, yp, ts = (np.asarray(a, float) for a in (points, values, times))
    tol = 1e-9 * max(float(np.max(np.abs(ts))), 1e-300)
    j = np.clip(np.searchsorted(tp, ts + tol, side="right") - 1, 1, len(tp) - 1)
    t1, y1, t0, y0 = tp[j], yp[j], tp[j - 1], yp[j - 1]
    slope = (y1 - y0) / (t1 - t0)
    return np.where(np.abs(t1 - ts) <= tol, y1, y1 + slope * (ts - t1))
