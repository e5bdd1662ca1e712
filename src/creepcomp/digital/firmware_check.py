"""Compile the generated corrector with the system's C compiler, run it over a record and
compare it with the float64 corrector (``creepcomp firmware --verify``)."""

from __future__ import annotations

import math
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from creepcomp.display import Shown
from creepcomp.errors import CreepcompError, InputError
from creepcomp.digital.firmware import TEMPERATURE_STEP_Q, Firmware
from creepcomp.digital.firmware_target import (STRICT_FLAGS, TARGETS, TargetRun, run_on_target,
                                              run_tool)

__all__ = ["STRICT_FLAGS", "Verification", "find_compiler", "compile_object", "run_firmware",
           "step_intervals", "verify_firmware"]

#: Optimisation used for the timed run and the object size.
OPTIMISATION = "-O2"


@dataclass(frozen=True)
class Verification(Shown):
    """The generated corrector run over a record against the float64 corrector.

    Attributes
    ----------
    samples : int
    max_error_fs : float
        Largest ``|C output - float64 output| / full_scale``.
    worst_sample : int
        Where it occurs.
    ns_per_sample : float or None
        Best of the timed runs of the step loop on this machine (host harness, ``-O2``); None
        for a run on a simulated chip.
    object_bytes : int or None
        Code and constant data of the compiled corrector (``size``: text + data, ``-O2``); None
        for a run on a simulated chip (see ``on_target``).
    bound_fs : float or None
        The proven bound (None for the naive recursion), with what the record's mode
        decisions near their threshold add for a recovery extension.
    switching : dict or None
        For a recovery extension: ``steps`` (decisions within the switching margin),
        ``largest`` (signal units) and ``added_fs`` (see
        :func:`creepcomp.digital.firmware_extension.recovery_ambiguity`); for an overshoot:
        ``events`` (the record's discounted count of the load's turns), ``bound_fs``,
        ``reference_fs`` and ``added_fs`` (see
        :func:`creepcomp.digital.firmware_extension.overshoot_record_bound`).
    on_target : TargetRun or None
        The run on a simulated chip (flash, RAM, cycles or instructions per sample); None for
        the host.
    load : dict or None
        For a corrector with static maps: ``max_error`` and ``bound`` of the load (load units),
        ``worst_sample``, ``compared`` (samples whose exact corrected value lies in the range
        the bounds hold over) and ``outside`` (the others, not compared); None otherwise.
    """

    samples: int
    max_error_fs: float
    worst_sample: int
    ns_per_sample: float
    object_bytes: int
    bound_fs: float | None
    switching: dict | None = None
    on_target: TargetRun | None = None
    load: dict | None = None

    @property
    def passed(self) -> bool:
        """True when the measured error is within the bound (and the load's within its own)."""
        within = self.bound_fs is None or self.max_error_fs <= self.bound_fs
        return within and (self.load is None or self.load["max_error"] <= self.load["bound"])

    def __repr__(self) -> str:
        bound = "no bound" if self.bound_fs is None else (
            f"{'within' if self.passed else 'ABOVE'} the bound {self.bound_fs:.3g}")
        return (f"<Verification {self.samples} samples: largest error {self.max_error_fs:.3g} of FS, "
                f"{bound}; {self.ns_per_sample:.3g} ns per sample, {self.object_bytes} bytes>")

    def to_dict(self) -> dict:
        """JSON form."""
        out = {"samples": self.samples, "max_error_fs": self.max_error_fs,
               "worst_sample": self.worst_sample, "ns_per_sample": self.ns_per_sample,
               "object_bytes": self.object_bytes, "within_bound": self.passed,
               "target": "host" if self.on_target is None else self.on_target.target}
        if self.on_target is not None:
            out.update(self.on_target.to_dict())
        if self.switching is not None:
            out.update(switching=dict(self.switching), record_bound_fs=self.bound_fs)
        if self.load is not None:
            out["load"] = dict(self.load)
        return out


def find_compiler(compiler: str | None = None) -> str:
    """Path of the C compiler (``gcc`` by default); raises when it is not installed."""
    name = compiler or "gcc"
    path = shutil.which(name)
    if path is None:
        raise CreepcompError(f"C compiler '{name}' not found: install it (Debian: apt-get install "
                             "gcc) to verify the generated code")
    return path


def compile_object(firmware: Firmware, folder, flags=(OPTIMISATION,), compiler: str | None = None) -> Path:
    """Write the firmware into ``folder`` and compile its source with :data:`STRICT_FLAGS`.

    Returns
    -------
    Path
        The object file.
    """
    folder = Path(folder)
    firmware.write(folder)
    obj = folder / f"{firmware.name}.o"
    run_tool([find_compiler(compiler), *STRICT_FLAGS, *flags, "-c", folder / firmware.filenames[1],
          "-o", obj], f"compiling {firmware.filenames[1]}")
    return obj


def _object_bytes(obj: Path) -> int:
    tool = shutil.which("size")
    if tool is None:
        return -1
    fields = run_tool([tool, "-B", obj], "size").splitlines()[1].split()
    return int(fields[0]) + int(fields[1])


def run_firmware(firmware: Firmware, signal, start: str, repeats: int = 5,
                 compiler: str | None = None, intervals=None,
                 temperatures=None) -> tuple[np.ndarray, float, int]:
    """Compile the corrector and its host harness in a temporary folder and run it.

    Parameters
    ----------
    firmware : Firmware
    signal : array_like
        Raw samples (signal units).
    start : {"relaxed", "settled"}
    repeats : int
        Timed runs (the best is kept).
    intervals : array_like, optional
        For the dt step: the interval passed with each sample (seconds for float32, ticks for
        q31), exactly representable in the step's argument type.
    temperatures : array_like, optional
        For the temperature step: the temperature (°C) of each sample (q31 passes it rounded
        to 1/256 °C).

    Returns
    -------
    outputs : numpy.ndarray
        Corrected samples (signal units) of the first run.
    ns_per_sample : float
    object_bytes : int
    """
    if start not in ("relaxed", "settled"):
        raise InputError(f"start '{start}': use 'relaxed' or 'settled'")
    x = np.ascontiguousarray(signal, dtype="<f8")
    if firmware.irregular and (intervals is None or len(intervals) != len(x)):
        raise InputError("the dt step needs one interval per sample")
    if firmware.temperature_range is not None:
        if temperatures is None or len(temperatures) != len(x):
            raise InputError("the temperature step needs one temperature per sample")
        intervals = (np.asarray(temperatures, dtype=float) if firmware.precision == "float32"
                     else np.round(np.asarray(temperatures, dtype=float) / TEMPERATURE_STEP_Q))
    cc = find_compiler(compiler)
    with tempfile.TemporaryDirectory(prefix="creepcomp-firmware-") as tmp:
        folder = Path(tmp)
        obj = compile_object(firmware, folder, compiler=cc)
        (folder / "harness.c").write_text(firmware.harness, encoding="utf-8")
        exe = folder / "harness"
        run_tool([cc, "-std=c99", OPTIMISATION, "-I", folder, folder / "harness.c", obj, "-o", exe, "-lm"],
             "compiling the harness")
        x.tofile(folder / "in.bin")
        files = [folder / "in.bin"]
        if intervals is not None:
            np.ascontiguousarray(intervals, dtype="<f8").tofile(folder / "dt.bin")
            files.append(folder / "dt.bin")
        out = run_tool([exe, *files, folder / "out.bin", start, max(1, int(repeats))],
                   "running the harness")
        y = np.fromfile(folder / "out.bin", dtype="<f8")
        return y, float(out.strip()), _object_bytes(obj)


def verify_firmware(firmware: Firmware, time, signal, repeats: int = 5, compiler: str | None = None,
                    temperature=None, reference=None, target: str = "host") -> Verification:
    """Run the generated corrector over a record and compare it with :func:`compensate`.

    The record must be sampled at the firmware's rate (fixed-rate step) or have intervals
    within the dt step's range (each sample's own interval is passed), and stay within its
    full scale (the range the bound assumes). Both start as the method's default (relaxed for subtractive,
    settled for supplemental), with the load held between samples. The temperature step
    (a model with a temperature law) takes ``temperature`` (°C, one per sample, within its
    range); the float64 corrector gets the same temperatures, rounded as the step receives them
    (to float32, or to 1/256 °C for q31). ``reference``: the exact corrector's output to
    compare with instead (a model with an extension the firmware applies: the caller's exact
    inverse of the whole model, started and held as the firmware is). ``target``: ``host``
    (this machine's gcc), or a chip of :data:`~creepcomp.digital.firmware_target.TARGETS` the
    corrector is cross-compiled for and run on in a simulator
    (:func:`~creepcomp.digital.firmware_target.run_on_target`).

    Returns
    -------
    Verification
        ``passed`` is False when the measured error exceeds the bound.
    """
    from creepcomp.digital.correctors import compensate, default_initial, uniform_interval

    if target not in TARGETS:
        raise InputError(f"target '{target}': use one of {', '.join(TARGETS)}")
    t = np.asarray(time, dtype=float)
    x = np.asarray(signal, dtype=float)
    if t.ndim != 1 or x.shape != t.shape or len(t) < 2:
        raise InputError("verify needs a record of at least 2 samples (time and signal of equal length)")
    if firmware.irregular:
        return _verify_irregular(firmware, t, x, repeats, compiler, target)
    if firmware.maps is not None and firmware.model.is_static:   # no dynamics: any sampling
        return _verify_maps(firmware, t, x, repeats, compiler, target)
    dt = uniform_interval(t)
    if dt is None:
        raise InputError("the record is not uniformly sampled: the generated corrector runs at a "
                         "fixed rate (generate the dt step with --max-interval for irregular sampling)")
    if not math.isclose(dt * firmware.rate, 1.0, rel_tol=1e-6):
        raise InputError(f"the record is sampled at {1 / dt:.6g} Hz and the corrector was generated "
                         f"for {firmware.rate:.6g} Hz: give --rate {1 / dt:.6g}")
    if firmware.maps is not None:
        return _verify_maps(firmware, t, x, repeats, compiler, target)
    _check_range(firmware, x)
    start = default_initial(firmware.method)
    temps = _temperatures(firmware, temperature, len(x))
    if reference is None:
        reference = compensate(t, x, firmware.model, firmware.method, initial=start, hold="zero",
                               temperature=temps)
    reference = np.asarray(reference, dtype=float)
    y, ns, size, on_target = _execute(firmware, x, start, repeats, compiler, target,
                                      temperatures=temps)
    switching = None
    kind = (firmware.extension or {}).get("kind")
    if kind == "recovery":
        from creepcomp.digital.firmware_extension import recovery_ambiguity

        switching = recovery_ambiguity(firmware.extension, t, reference, firmware.model.offset)
    elif kind == "overshoot":
        from creepcomp.digital.firmware_extension import overshoot_record_bound

        on_record = overshoot_record_bound(firmware.extension, reference, firmware.model.offset,
                                           firmware.bound)
        switching = dict(on_record, added_fs=on_record["bound_fs"] - firmware.bound.total_fs)
    return _compare(firmware, y, reference, ns, size, switching, on_target)


def _execute(firmware, x, start, repeats, compiler, target, intervals=None, temperatures=None):
    """Run the corrector on the host (timed) or on a simulated chip: ``(outputs, ns per
    sample, object bytes, TargetRun)``, the host's or the chip's parts None."""
    if target == "host":
        y, ns, size = run_firmware(firmware, x, start, repeats, compiler, intervals=intervals,
                                   temperatures=temperatures)
        return y, ns, size, None
    aux = intervals
    if temperatures is not None:
        aux = (temperatures if firmware.precision == "float32"
               else np.round(np.asarray(temperatures, dtype=float) / TEMPERATURE_STEP_Q))
    run = run_on_target(firmware, x, start, target, aux=aux)
    if run.refused:
        raise CreepcompError(f"the dt step refused {run.refused} interval(s) on {target}")
    return run.outputs, None, None, run


def _temperatures(firmware: Firmware, temperature, n: int) -> np.ndarray | None:
    """The temperatures (°C) the temperature step receives (float32, or q31's 1/256 °C), checked."""
    if firmware.temperature_range is None:
        if temperature is not None:
            raise InputError("a temperature was given but the firmware's model has no temperature "
                             "law: its step takes no temperature")
        return None
    if temperature is None:
        raise InputError("the firmware's model has a temperature law: verifying it needs the "
                         "record's 'temperature' column (°C)")
    temps = np.asarray(temperature, dtype=float).reshape(-1)
    if len(temps) != n:
        raise InputError(f"{len(temps)} temperatures for {n} samples")
    if firmware.precision == "float32":
        temps = temps.astype(np.float32).astype(float)
    else:
        temps = np.round(temps / TEMPERATURE_STEP_Q) * TEMPERATURE_STEP_Q
    low, high = firmware.temperature_range
    outside = np.flatnonzero(~((temps >= low) & (temps <= high)))
    if outside.size:
        i = int(outside[0])
        raise InputError(f"temperature of sample {i} is {temps[i]:g} °C, outside the range "
                         f"{low:g} to {high:g} °C of the bound: give a wider --temperature-range")
    return temps


def step_intervals(firmware: Firmware, time) -> tuple[np.ndarray, np.ndarray]:
    """The intervals the dt step is given for a record, and the times they add up to.

    float32 takes each interval rounded to float32 (seconds), q31 rounded to whole ticks
    (microseconds). The times are rebuilt from those intervals (seconds from the first sample;
    exact sums for q31) so that the float64 reference sees what the firmware sees.

    Returns
    -------
    intervals : numpy.ndarray
        One per sample (the first repeats the second), in the step's unit (s or ticks).
    time : numpy.ndarray
        The sample times (s) those intervals give, for :func:`compensate`.
    """
    from creepcomp.digital.firmware import MIN_INTERVAL, TICK

    t = np.asarray(time, dtype=float)
    gaps = np.diff(t)
    if firmware.precision == "float32":
        step = gaps.astype(np.float32).astype(float)
        limits, unit = (np.float32(MIN_INTERVAL), np.float32(firmware.max_interval)), 1.0
    else:
        step = np.round(gaps / TICK)
        limits, unit = (1.0, round(firmware.max_interval / TICK)), TICK
    bad = np.flatnonzero(~((step >= limits[0]) & (step <= limits[1])))
    if bad.size:
        i = int(bad[0])
        raise InputError(f"the interval before sample {i + 1} is {gaps[i]:.6g} s, outside the dt "
                         f"step's range {float(limits[0]) * unit:.6g} s to {float(limits[1]) * unit:.6g} s: "
                         "give a larger --max-interval")
    rebuilt = np.concatenate([[0.0], np.cumsum(step)]) * unit
    return np.concatenate([step[:1], step]), rebuilt


def _verify_irregular(firmware, t, x, repeats, compiler, target) -> Verification:
    from creepcomp.digital.correctors import compensate, default_initial
    from creepcomp.digital.firmware import TICK
    from creepcomp.model import CreepModel

    _check_range(firmware, x)
    intervals, rebuilt = step_intervals(firmware, t)
    model = firmware.model
    if firmware.precision == "q31":       # integer microseconds: the reference's intervals are exact
        rebuilt = np.round(rebuilt / TICK)
        model = CreepModel(model.beta, tuple(tau / TICK for tau in model.tau), model.gain, model.offset)
    start = default_initial(firmware.method)
    reference = compensate(rebuilt, x, model, firmware.method, initial=start, hold="zero")
    y, ns, size, on_target = _execute(firmware, x, start, repeats, compiler, target,
                                      intervals=intervals)
    return _compare(firmware, y, reference, ns, size, on_target=on_target)


def _verify_maps(firmware, t, x, repeats, compiler, target) -> Verification:
    """A corrector with static maps: its compensated signal against :func:`compensate`, its
    load against :func:`estimate_load` (with the model's load filter), on the samples whose
    exact corrected value lies in the range the bounds hold over (with a filter: the values
    of every sample the filtered load averages)."""
    from creepcomp.digital.correctors import (compensate, default_initial, filter_load,
                                              load_from_compensated, mean_interval)

    model, maps = firmware.model, firmware.maps
    low, high = maps["raw_range"]
    if not np.all(np.isfinite(x)):
        raise InputError(f"signal sample {int(np.flatnonzero(~np.isfinite(x))[0])} is not a finite number")
    outside = np.flatnonzero((x < low) | (x > high))
    if outside.size:
        i = int(outside[0])
        raise InputError(f"signal sample {i} is {x[i]:.9g}, outside the raw range {low:.9g} to "
                         f"{high:.9g} that the bound assumes: give a wider --full-scale LOW:HIGH")
    start = default_initial(firmware.method)
    compensated = compensate(t, x, model, firmware.method, initial=start, hold="zero")
    samples = maps.get("load_filter", {}).get("samples", 1)
    if samples > 1 and (record_samples := model.load_filter.samples_at(mean_interval(t))) != samples:
        raise InputError(f"the record's mean sample interval gives its load filter {record_samples} "
                         f"samples, the corrector's {samples} at {firmware.rate:.6g} Hz: give --rate "
                         f"{1 / mean_interval(t):.6g}")
    load = filter_load(load_from_compensated(compensated, model, firmware.method), model, t)
    path = model.transfer
    corrected = compensated if path is None else path.linearise(compensated)
    c_lo, c_hi = maps["corrected_range"]
    slack = 1e-12 * (c_hi - c_lo)
    inside = np.isfinite(corrected) & (corrected >= c_lo - slack) & (corrected <= c_hi + slack)
    # a filtered load is bounded where every load it averages is
    load_inside = np.convolve(~inside, np.ones(samples, dtype=int))[:len(x)] == 0
    on_target = None
    if target == "host":
        y, ns, size, _ = _execute(firmware, x, start, repeats, compiler, target)
    else:           # a run per output; the chip's costs are the load's (the whole path)
        signal_run = run_on_target(firmware, x, start, target)
        on_target = run_on_target(firmware, x, start, target, load=True)
        y, ns, size = np.concatenate([signal_run.outputs, on_target.outputs]), None, None
    n = len(x)
    signal_error = np.where(inside, np.abs(y[:n] - compensated), 0.0) / firmware.full_scale
    load_error = np.where(load_inside, np.abs(y[n:] - load), 0.0)
    worst, worst_load = int(np.argmax(signal_error)), int(np.argmax(load_error))
    return Verification(samples=n, max_error_fs=float(signal_error[worst]), worst_sample=worst,
                        ns_per_sample=ns, object_bytes=size, bound_fs=firmware.bound.total_fs,
                        on_target=on_target, load={"max_error": float(load_error[worst_load]), "bound": maps["bound_load"],
                              "worst_sample": worst_load, "compared": int(np.count_nonzero(load_inside)),
                              "outside": int(n - np.count_nonzero(load_inside))})


def _compare(firmware, y, reference, ns, size, switching=None, on_target=None) -> Verification:
    error = np.abs(y - reference) / firmware.full_scale
    worst = int(np.argmax(error))
    bound = None if firmware.bound is None else firmware.bound.total_fs
    if switching is not None:
        bound += switching["added_fs"]
    return Verification(samples=len(y), max_error_fs=float(error[worst]), worst_sample=worst,
                        ns_per_sample=ns, object_bytes=size, bound_fs=bound, switching=switching,
                        on_target=on_target)


def _check_range(firmware, x) -> None:
    excess = np.abs(x - firmware.model.offset)
    if not np.all(np.isfinite(x)):
        raise InputError(f"signal sample {int(np.flatnonzero(~np.isfinite(x))[0])} is not a finite number")
    if excess.max() > firmware.full_scale:
        i = int(np.argmax(excess))
        raise InputError(f"signal sample {i} is {excess[i]:.6g} from the offset, beyond the full scale "
                         f"{firmware.full_scale:.6g} that the bound assumes: give a larger --full-scale")


def jittered_record(model, n: int, seed: int = 0, rate: float = 100.0, max_interval: float = 0.04,
                    max_hold: float = 200.0):
    """A test record for the dt step: ``(time, load, signal)`` of ``n`` samples.

    Intervals uniform in [0.5, 1.5] / ``rate`` (whole microseconds) with 20 gaps of
    ``max_interval`` (s); load steps between random levels (up to full scale) held up to
    ``max_hold`` (s) until three quarters of the record, then full-scale swings every sample.
    """
    rng = np.random.default_rng(seed)
    gaps = rng.uniform(0.5, 1.5, n - 1) / rate
    gaps[rng.integers(0, n - 1, 20)] = max_interval
    gaps = np.round(gaps * 1e6) / 1e6
    t = np.concatenate([[0.0], np.cumsum(gaps)])
    load = np.zeros(n)
    i = n // 20
    while i < 3 * n // 4:
        hold = int(rng.integers(5, int(max_hold * rate)))
        load[i:i + hold] = rng.choice([-1.0, 1.0, rng.uniform(-1, 1)])
        i += hold
    load[3 * n // 4:] = np.where(np.arange(n - 3 * n // 4) % 2 == 0, 1.0, -1.0)
    return t, load, model.response(t, load, hold="zero")
