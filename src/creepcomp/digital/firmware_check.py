"""Compile the generated corrector with the system's C compiler, run it over a record and
compare it with the float64 corrector (``creepcomp firmware --verify``)."""

from __future__ import annotations

import math
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from creepcomp.errors import CreepcompError, InputError
from creepcomp.digital.firmware import Firmware

__all__ = ["STRICT_FLAGS", "Verification", "find_compiler", "compile_object", "run_firmware",
           "verify_firmware"]

#: The flags the generated code must compile under without a warning.
STRICT_FLAGS = ("-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic")
#: Optimisation used for the timed run and the object size.
OPTIMISATION = "-O2"


@dataclass(frozen=True)
class Verification:
    """The generated corrector run over a record against the float64 corrector.

    Attributes
    ----------
    samples : int
    max_error_fs : float
        Largest ``|C output - float64 output| / full_scale``.
    worst_sample : int
        Where it occurs.
    ns_per_sample : float
        Best of the timed runs of the step loop on this machine (host harness, ``-O2``).
    object_bytes : int
        Code and constant data of the compiled corrector (``size``: text + data, ``-O2``).
    bound_fs : float or None
        The proven bound (None for the naive recursion).
    """

    samples: int
    max_error_fs: float
    worst_sample: int
    ns_per_sample: float
    object_bytes: int
    bound_fs: float | None

    @property
    def passed(self) -> bool:
        """True when the measured error is within the bound."""
        return self.bound_fs is None or self.max_error_fs <= self.bound_fs

    def to_dict(self) -> dict:
        """JSON form."""
        return {"samples": self.samples, "max_error_fs": self.max_error_fs,
                "worst_sample": self.worst_sample, "ns_per_sample": self.ns_per_sample,
                "object_bytes": self.object_bytes, "within_bound": self.passed}


def find_compiler(compiler: str | None = None) -> str:
    """Path of the C compiler (``gcc`` by default); raises when it is not installed."""
    name = compiler or "gcc"
    path = shutil.which(name)
    if path is None:
        raise CreepcompError(f"C compiler '{name}' not found: install it (Debian: apt-get install "
                             "gcc) to verify the generated code")
    return path


def _run(args: list, what: str) -> str:
    proc = subprocess.run([str(a) for a in args], capture_output=True, text=True)
    if proc.returncode != 0:
        detail = (proc.stderr or proc.stdout).strip().splitlines()
        raise CreepcompError(f"{what} failed: {detail[0] if detail else f'status {proc.returncode}'}")
    return proc.stdout


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
    _run([find_compiler(compiler), *STRICT_FLAGS, *flags, "-c", folder / firmware.filenames[1],
          "-o", obj], f"compiling {firmware.filenames[1]}")
    return obj


def _object_bytes(obj: Path) -> int:
    tool = shutil.which("size")
    if tool is None:
        return -1
    fields = _run([tool, "-B", obj], "size").splitlines()[1].split()
    return int(fields[0]) + int(fields[1])


def run_firmware(firmware: Firmware, signal, start: str, repeats: int = 5,
                 compiler: str | None = None) -> tuple[np.ndarray, float, int]:
    """Compile the corrector and its host harness in a temporary folder and run it.

    Parameters
    ----------
    firmware : Firmware
    signal : array_like
        Raw samples (signal units).
    start : {"relaxed", "settled"}
    repeats : int
        Timed runs (the best is kept).

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
    cc = find_compiler(compiler)
    with tempfile.TemporaryDirectory(prefix="creepcomp-firmware-") as tmp:
        folder = Path(tmp)
        obj = compile_object(firmware, folder, compiler=cc)
        (folder / "harness.c").write_text(firmware.harness, encoding="utf-8")
        exe = folder / "harness"
        _run([cc, "-std=c99", OPTIMISATION, "-I", folder, folder / "harness.c", obj, "-o", exe, "-lm"],
             "compiling the harness")
        x.tofile(folder / "in.bin")
        out = _run([exe, folder / "in.bin", folder / "out.bin", start, max(1, int(repeats))],
                   "running the harness")
        y = np.fromfile(folder / "out.bin", dtype="<f8")
        return y, float(out.strip()), _object_bytes(obj)


def verify_firmware(firmware: Firmware, time, signal, repeats: int = 5, compiler: str | None = None) -> Verification:
    """Run the generated corrector over a record and compare it with :func:`compensate`.

    The record must be sampled at the firmware's rate and stay within its full scale (the
    range the bound assumes). Both start as the method's default (relaxed for subtractive,
    settled for supplemental), with the load held between samples.

    Returns
    -------
    Verification
        ``passed`` is False when the measured error exceeds the bound.
    """
    from creepcomp.digital.correctors import compensate, default_initial, uniform_interval

    t = np.asarray(time, dtype=float)
    x = np.asarray(signal, dtype=float)
    if t.ndim != 1 or x.shape != t.shape or len(t) < 2:
        raise InputError("verify needs a record of at least 2 samples (time and signal of equal length)")
    dt = uniform_interval(t)
    if dt is None:
        raise InputError("the record is not uniformly sampled: the generated corrector runs at a fixed rate")
    if not math.isclose(dt * firmware.rate, 1.0, rel_tol=1e-6):
        raise InputError(f"the record is sampled at {1 / dt:.6g} Hz and the corrector was generated "
                         f"for {firmware.rate:.6g} Hz: give --rate {1 / dt:.6g}")
    excess = np.abs(x - firmware.model.offset)
    if not np.all(np.isfinite(x)):
        raise InputError(f"signal sample {int(np.flatnonzero(~np.isfinite(x))[0])} is not a finite number")
    if excess.max() > firmware.full_scale:
        i = int(np.argmax(excess))
        raise InputError(f"signal sample {i} is {excess[i]:.6g} from the offset, beyond the full scale "
                         f"{firmware.full_scale:.6g} that the bound assumes: give a larger --full-scale")
    start = default_initial(firmware.method)
    reference = compensate(t, x, firmware.model, firmware.method, initial=start, hold="zero")
    y, ns, size = run_firmware(firmware, x, start, repeats, compiler)
    error = np.abs(y - reference) / firmware.full_scale
    worst = int(np.argmax(error))
    return Verification(samples=len(x), max_error_fs=float(error[worst]), worst_sample=worst,
                        ns_per_sample=ns, object_bytes=size,
                        bound_fs=None if firmware.bound is None else firmware.bound.total_fs)
