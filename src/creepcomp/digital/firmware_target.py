"""The generated corrector on the chips it runs on: cross-compiled with Debian's toolchains and
run over a record in a simulator (``creepcomp firmware --verify RECORD --target ...``).

- ``avr``: the ATmega328P (Arduino Uno and Nano) at 16 MHz, ``avr-gcc -Os`` with avr-libc, run
  on simavr's cycle-counting core by a small host program against libsimavr
  (``digital/targets/simavr_run.c``) that feeds the samples through a mailbox in the chip's
  SRAM and counts the clock cycles between two markers around each step.
- ``cortex-m0plus`` and ``cortex-m4f``: ``arm-none-eabi-gcc -O2`` with newlib, run on QEMU
  (see :func:`run_on_target`).

The flash and RAM of the corrector are measured on the linked program: the program with the
corrector, less the same program without it (both linked with unused sections dropped), so
they include the library routines the corrector pulls in (avr-libc's float arithmetic, the
64-bit integer routines); RAM adds the deepest stack the step reached below its caller.
"""

from __future__ import annotations

import atexit
import functools
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from creepcomp.digital.firmware_bound import check_target_arithmetic
from creepcomp.errors import CreepcompError, InputError

__all__ = ["STRICT_FLAGS", "TARGETS", "Toolchain", "TOOLCHAINS", "TargetRun", "find_toolchain",
           "run_on_target", "run_tool", "build_program",
           "target_words", "from_target_words"]

#: The flags the generated code must compile under without a warning.
STRICT_FLAGS = ("-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic")

#: The targets of ``--verify``: the machine itself, and the simulated chips.
TARGETS = ("host", "avr", "cortex-m0plus", "cortex-m4f")


@dataclass(frozen=True)
class Toolchain:
    """How the corrector is built and run for one simulated chip.

    Attributes
    ----------
    target : str
        One of :data:`TARGETS` but ``host``.
    chip : str
        What is simulated, for messages and reports.
    compiler : str
        The cross compiler.
    flags : tuple of str
        Its machine and optimisation flags (the corrector's own strict flags are added).
    programs : tuple of str
        The executables the run needs (compiler, size, simulator).
    debs : tuple of str
        The Debian packages that provide them (``make toolchains`` installs them).
    counts : str
        ``cycles`` (clock cycles, simavr) or ``instructions`` (QEMU's instruction count).
    """

    target: str
    chip: str
    compiler: str
    flags: tuple
    programs: tuple
    debs: tuple
    counts: str


TOOLCHAINS = {
    "avr": Toolchain("avr", "ATmega328P at 16 MHz (simavr)", "avr-gcc",
                     ("-mmcu=atmega328p", "-Os", "-ffunction-sections", "-fdata-sections"),
                     ("avr-gcc", "avr-size", "avr-nm", "gcc"),
                     ("gcc-avr", "avr-libc", "simavr", "libsimavr-dev"), "cycles"),
    "cortex-m0plus": Toolchain("cortex-m0plus", "Cortex-M0+ instruction set, no FPU (QEMU mps2-an385)",
                               "arm-none-eabi-gcc",
                               ("-mcpu=cortex-m0plus", "-mthumb", "-mfloat-abi=soft", "-O2",
                                "-ffunction-sections", "-fdata-sections"),
                               ("arm-none-eabi-gcc", "arm-none-eabi-size", "arm-none-eabi-nm",
                                "qemu-system-arm"),
                               ("gcc-arm-none-eabi", "libnewlib-arm-none-eabi", "qemu-system-arm"),
                               "instructions"),
    "cortex-m4f": Toolchain("cortex-m4f", "Cortex-M4F with its single-precision FPU (QEMU mps2-an386)",
                            "arm-none-eabi-gcc",
                            ("-mcpu=cortex-m4", "-mthumb", "-mfpu=fpv4-sp-d16", "-mfloat-abi=hard",
                             "-O2", "-ffunction-sections", "-fdata-sections"),
                            ("arm-none-eabi-gcc", "arm-none-eabi-size", "arm-none-eabi-nm",
                             "qemu-system-arm"),
                            ("gcc-arm-none-eabi", "libnewlib-arm-none-eabi", "qemu-system-arm"),
                            "instructions"),
}


@dataclass(frozen=True)
class TargetRun:
    """The corrector run over a record on a simulated chip.

    Attributes
    ----------
    target : str
    outputs : numpy.ndarray
        Corrected samples (signal units).
    flash_bytes : int
        Flash the corrector adds to a program: its code, its constants and the library
        routines it pulls in.
    ram_bytes : int
        RAM it adds: its state, the constants a chip copies to RAM (the ATmega's ``.data``),
        and the deepest stack its step reached below its caller.
    state_bytes : int
        ``sizeof`` of the state the caller owns.
    stack_bytes : int
        The deepest stack of a step (bytes below the caller's stack pointer).
    per_sample : float
        Mean cycles (``avr``: simavr's clock cycles between two markers around the call) or
        instructions (Cortex-M: QEMU counting one nanosecond of its virtual clock per
        instruction, ``-icount shift=0``, read off the board's 25 MHz timer over the whole
        loop, less a loop that only reads the samples) per step, its call included.
    largest : int or None
        The most a step took (simavr counts each step; QEMU's timer only the whole loop: None).
    counts : str
        ``cycles`` or ``instructions``.
    refused : int
        Samples the dt step refused.
    """

    target: str
    outputs: np.ndarray
    flash_bytes: int
    ram_bytes: int
    state_bytes: int
    stack_bytes: int
    per_sample: float
    largest: int | None
    counts: str
    refused: int = 0

    def to_dict(self) -> dict:
        """JSON form: the keys of ``firmware --verify --json`` (``cycles_per_sample`` or
        ``instructions_per_sample``)."""
        return {"target": self.target, "flash_bytes": self.flash_bytes, "ram_bytes": self.ram_bytes,
                "state_bytes": self.state_bytes, "stack_bytes": self.stack_bytes,
                f"{self.counts}_per_sample": self.per_sample, f"largest_{self.counts}": self.largest}


def find_toolchain(target: str) -> Toolchain:
    """The toolchain of a simulated target, checked installed; raises naming what is missing.

    Raises
    ------
    InputError
        For an unknown target.
    CreepcompError
        When a program of the toolchain is not installed (names the Debian packages).

    Examples
    --------
    >>> find_toolchain("avr").compiler  # doctest: +SKIP
    'avr-gcc'
    """
    if target not in TOOLCHAINS:
        raise InputError(f"target '{target}': use one of {', '.join(TARGETS)}")
    chain = TOOLCHAINS[target]
    missing = [p for p in chain.programs if shutil.which(p) is None]
    if target == "avr" and not Path("/usr/include/simavr/sim_avr.h").exists():
        missing.append("libsimavr headers")
    if missing:
        raise CreepcompError(f"target {target}: {', '.join(missing)} not installed; install Debian's "
                             f"{' '.join(chain.debs)} (make toolchains does, from Debian)")
    return chain


def run_tool(args, what: str) -> str:
    """Run a program (compiler, size, simulator); its standard output, or a CreepcompError
    naming ``what`` failed with the first line it printed."""
    proc = subprocess.run([str(a) for a in args], capture_output=True, text=True)
    if proc.returncode != 0:
        detail = (proc.stderr or proc.stdout).strip().splitlines()
        raise CreepcompError(f"{what} failed: {detail[0] if detail else f'status {proc.returncode}'}")
    return proc.stdout


def target_words(firmware, signal) -> np.ndarray:
    """The samples as the step takes them: float32 in signal units, or the q31 words
    ``round((raw - offset) / full scale * 2^30)`` (half away from zero, as the host harness)."""
    x = np.asarray(signal, dtype=float)
    if firmware.precision == "float32":
        return x.astype("<f4")
    scaled = (x - firmware.model.offset) / firmware.full_scale * 2.0 ** 30
    return (np.sign(scaled) * np.floor(np.abs(scaled) + 0.5)).astype("<i4")


def from_target_words(firmware, words) -> np.ndarray:
    """The step's outputs in signal units (the inverse of :func:`target_words`)."""
    if firmware.precision == "float32":
        return np.asarray(words, dtype="<f4").astype(float)
    return firmware.model.offset + np.asarray(words, dtype="<i4") * (firmware.full_scale / 2.0 ** 30)


def _aux_words(firmware, aux) -> np.ndarray | None:
    """The step's second argument per sample (interval or temperature) in its C type, or None."""
    if aux is None:
        return None
    values = np.asarray(aux, dtype=float)
    if firmware.precision == "float32":
        return values.astype("<f4")
    return values.astype("<u4" if firmware.irregular else "<i4")


def run_on_target(firmware, signal, start: str, target: str, aux=None,
                  load: bool = False) -> TargetRun:
    """Cross-compile the corrector for a chip, run it over the samples in a simulator.

    Parameters
    ----------
    firmware : Firmware
    signal : array_like
        Raw samples (signal units).
    start : {"relaxed", "settled"}
    target : {"avr", "cortex-m0plus", "cortex-m4f"}
    aux : array_like, optional
        The step's second argument per sample: the interval of the dt step (seconds for
        float32, ticks for q31), or the temperature of the temperature step (°C for float32,
        1/256 °C for q31).
    load : bool
        For a corrector with static maps: output the load (``PREFIX_step_load``) instead of
        the compensated signal.

    Returns
    -------
    TargetRun

    Examples
    --------
    >>> from creepcomp.model import CreepModel
    >>> from creepcomp.digital.firmware import generate_firmware
    >>> fw = generate_firmware(CreepModel((0.01,), (5.0,), 1.0, 0.0), rate=80.0)
    >>> run = run_on_target(fw, [0.0, 1.0, 1.0], "relaxed", "avr")  # doctest: +SKIP
    >>> run.counts  # doctest: +SKIP
    'cycles'
    """
    if start not in ("relaxed", "settled"):
        raise InputError(f"start '{start}': use 'relaxed' or 'settled'")
    chain = find_toolchain(target)
    check_target_arithmetic(target, firmware.uses_double)
    words = target_words(firmware, signal)
    extra = _aux_words(firmware, aux)
    with tempfile.TemporaryDirectory(prefix=f"creepcomp-{target}-") as tmp:
        folder = Path(tmp)
        defines = ["-DTARGET_LOAD"] if load else []
        if target == "avr":
            return _run_avr(firmware, chain, folder, words, extra, start, defines)
        return _run_qemu(firmware, chain, folder, words, extra, start, defines)


# ------------------------------------------------------------------------ the ATmega328P

def _sizes(size_tool: str, elf: Path) -> tuple[int, int]:
    """(flash, static RAM) of a linked program: text + data, data + bss."""
    text, data, bss = (int(v) for v in run_tool([size_tool, elf], "size").splitlines()[1].split()[:3])
    return text + data, data + bss


def _symbol_size(nm_tool: str, elf: Path, symbol: str) -> int:
    for line in run_tool([nm_tool, "-S", elf], "nm").splitlines():
        parts = line.split()
        if len(parts) == 4 and parts[3] == symbol:
            return int(parts[1], 16)
    raise CreepcompError(f"the program has no symbol {symbol}")  # pragma: no cover


def build_program(firmware, chain: Toolchain, folder: Path, program: str, extra_sources=(),
                  link_flags=(), defines=()) -> tuple[Path, Path]:
    """Compile the corrector strictly and link it with a target program (``defines``: the
    program's macros), and the same program without it (``TARGET_BASELINE``). Returns the two
    linked programs."""
    firmware.write(folder)
    source = folder / firmware.filenames[1]
    (folder / "program.c").write_text(program, encoding="utf-8")
    flags = list(chain.flags)
    obj = folder / f"{firmware.name}.o"
    run_tool([chain.compiler, *STRICT_FLAGS, *flags, "-c", source, "-o", obj],
             f"compiling {firmware.filenames[1]} with {chain.compiler}")
    linked = []
    for label, define in (("program", []), ("baseline", ["-DTARGET_BASELINE"])):
        elf = folder / f"{label}.elf"
        objects = [obj] if not define else []
        run_tool([chain.compiler, "-std=gnu99", *flags, *defines, *define, "-I", folder, folder / "program.c",
                  *extra_sources, *objects, "-Wl,--gc-sections", *link_flags, "-lm", "-o", elf],
                 f"linking the {label} for {chain.target}")
        linked.append(elf)
    return linked[0], linked[1]


@functools.cache
def _runner() -> Path:
    """The simavr host runner, compiled against libsimavr once per process (into a folder
    removed at exit)."""
    folder = Path(tempfile.mkdtemp(prefix="creepcomp-simavr-"))
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    source = resources.files("creepcomp.digital").joinpath("targets", "simavr_run.c")
    exe = folder / "simavr_run"
    run_tool(["gcc", "-O2", "-o", exe, str(source), "-lsimavr"], "compiling the simavr runner")
    return exe


def _run_avr(firmware, chain, folder, words, aux, start, defines) -> TargetRun:
    from creepcomp.digital.firmware import render_target_program

    program = render_target_program(firmware, "avr_program.c.j2")
    elf, baseline = build_program(firmware, chain, folder, program, defines=defines)
    words.tofile(folder / "in.bin")
    aux_path = "-"
    if aux is not None:
        aux.tofile(folder / "aux.bin")
        aux_path = folder / "aux.bin"
    line = run_tool([_runner(), elf, folder / "in.bin", folder / "out.bin", aux_path, start],
                    "running the corrector on simavr").strip().splitlines()[-1]
    n, largest, mean, stack, refused = line.split()
    flash, ram = _sizes("avr-size", elf)
    flash0, ram0 = _sizes("avr-size", baseline)
    out = np.fromfile(folder / "out.bin", dtype="<f4" if firmware.precision == "float32" else "<i4")
    return TargetRun(target="avr", outputs=from_target_words(firmware, out),
                     flash_bytes=flash - flash0, ram_bytes=ram - ram0 + int(stack),
                     state_bytes=_symbol_size("avr-nm", elf, "state"), stack_bytes=int(stack),
                     per_sample=float(mean), largest=int(largest), counts="cycles",
                     refused=int(refused))


# ------------------------------------------------------------------------------- Cortex-M

#: QEMU's board per target: the mps2-an385 (a Cortex-M3) runs the M0+'s ARMv6-M instructions
#: (a subset of its own), the mps2-an386 is a Cortex-M4F.
QEMU_BOARDS = {"cortex-m0plus": "mps2-an385", "cortex-m4f": "mps2-an386"}
#: The mps2 timer's clock (Hz) against QEMU's virtual clock: with ``-icount shift=0`` every
#: instruction advances that clock by 1 ns, so one tick of the timer is 40 instructions.
QEMU_TIMER_HZ = 25e6
#: Seconds a QEMU run may take before it is stopped.
QEMU_TIMEOUT = 600.0


def _run_qemu(firmware, chain, folder, words, aux, start, defines) -> TargetRun:
    from creepcomp.digital.firmware import render_target_program

    targets = resources.files("creepcomp.digital").joinpath("targets")
    program = render_target_program(firmware, "arm_program.c.j2")
    elf, baseline = build_program(firmware, chain, folder, program,
                                  extra_sources=[str(targets.joinpath("cortex_m_start.c"))],
                                  link_flags=["-nostartfiles", "-T", str(targets.joinpath("cortex_m.ld")),
                                              "--specs=rdimon.specs"], defines=defines)
    words.tofile(folder / "in.bin")
    if aux is not None:
        aux.tofile(folder / "aux.bin")
    if start == "settled":
        (folder / "settled").write_bytes(b"")
    args = ["qemu-system-arm", "-M", QEMU_BOARDS[chain.target], "-nographic", "-monitor", "none",
            "-serial", "none", "-semihosting-config", "enable=on,target=native",
            "-icount", "shift=0", "-kernel", elf]
    try:
        proc = subprocess.run([str(a) for a in args], capture_output=True, text=True, cwd=folder,
                              timeout=QEMU_TIMEOUT)
    except subprocess.TimeoutExpired:
        raise CreepcompError(f"the corrector did not finish on QEMU ({chain.target}) within "
                             f"{QEMU_TIMEOUT:g} s") from None
    lines = proc.stdout.strip().splitlines()
    if proc.returncode != 0 or not lines:
        raise CreepcompError(f"running the corrector on QEMU ({chain.target}) failed: status "
                             f"{proc.returncode} {proc.stderr.strip()[:200]}")
    n, ticks, idle, stack, refused = (int(v) for v in lines[-1].split())
    per_tick = 1e9 / QEMU_TIMER_HZ                       # instructions per tick (1 ns each)
    flash, ram = _sizes("arm-none-eabi-size", elf)
    flash0, ram0 = _sizes("arm-none-eabi-size", baseline)
    out = np.fromfile(folder / "out.bin", dtype="<f4" if firmware.precision == "float32" else "<i4")
    return TargetRun(target=chain.target, outputs=from_target_words(firmware, out),
                     flash_bytes=flash - flash0, ram_bytes=ram - ram0 + stack,
                     state_bytes=_symbol_size("arm-none-eabi-nm", elf, "state"), stack_bytes=stack,
                     per_sample=(ticks - idle) * per_tick / max(n, 1), largest=None,
                     counts="instructions", refused=refused)
