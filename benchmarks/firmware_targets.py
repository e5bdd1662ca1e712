"""The generated C corrector on the chips it runs on: flash, RAM, cost per sample, bound and
measured error, per target, precision, number of creep terms and temperature law.

    nice -n 10 .venv/bin/python benchmarks/firmware_targets.py [--samples 2000] [--rate 80]

Models: the first 1, 2 or 3 terms of beta (1 %, 1 %, 1.5 %), tau (5 s, 50 s, 500 s), offset
1e-3, with and without an Arrhenius temperature law (43 kJ/mol, the range -40 to 85 °C). The
record: ``--samples`` samples at ``--rate`` (an HX711 at 80 samples/s): a relaxed lead-in, load
steps between full scale and minus half scale every 5 s, sample-to-sample full-scale swings at
the end; the temperature swings between 5 and 45 °C, a new value every sample (and, in its own
column, read once a second to 0.1 °C and held in between: the float32 step keeps its ``a_k``
while the temperature holds). float32 without a temperature law has a row for each form of the
states: ``compensated`` (the default) and ``plain`` (``--state plain``). Each row is ``creepcomp firmware --verify
--target`` through the Python API (subtractive method, the method's relaxed start):
``avr`` the ATmega328P at 16 MHz on simavr (``avr-gcc -Os``, clock cycles per step, its call
included), ``cortex-m0plus`` and ``cortex-m4f`` on QEMU's mps2 boards (``arm-none-eabi-gcc
-O2``, instructions per step with ``-icount shift=0``). Flash and RAM: what the corrector adds
to a program, library routines included; RAM includes the state and the step's deepest stack.
The error: the largest ``|C output - float64 corrector|`` over the record, against the proven
bound, both as fractions of full scale.

Needs ``make toolchains``. Prints a Markdown table for docs/firmware.md.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from creepcomp.digital.firmware import generate_firmware
from creepcomp.digital.firmware_check import verify_firmware
from creepcomp.model import CreepModel
from creepcomp.temperature import TemperatureLaw

BETA = (0.01, 0.01, 0.015)
TAU = (5.0, 50.0, 500.0)
OFFSET = 1e-3
TARGETS = ("avr", "cortex-m0plus", "cortex-m4f")


def record(model: CreepModel, n: int, rate: float):
    """Time, signal and temperature (°C) of the benchmark's record (a new temperature every
    sample)."""
    t = np.arange(n) / rate
    load = np.where((np.arange(n) // int(5 * rate)) % 2 == 0, 1.0, -0.5)
    load[: n // 20] = 0.0
    swings = n // 10
    load[-swings:] = np.where(np.arange(swings) % 2 == 0, 1.0, -1.0)
    temperature = 25.0 + 20.0 * np.sin(2 * np.pi * np.arange(n) / n)
    return t, model.response(t, load, hold="zero", temperature=temperature
                             if model.temperature is not None else None), temperature


def held(temperature, rate: float):
    """The same temperatures read once a second (held in between), to 0.1 °C."""
    every = int(rate)
    return np.repeat(np.round(temperature[::every], 1), every)[: len(temperature)]


def rows(precision: str):
    """The temperature laws and state forms of a precision's rows: without a law and with
    one; float32 without a law also with plain states."""
    law = TemperatureLaw.arrhenius(43000.0)
    if precision == "float32":
        return [(None, "compensated"), (None, "plain"), (law, "compensated")]
    return [(None, "compensated"), (law, "compensated")]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=2000)
    parser.add_argument("--rate", type=float, default=80.0)
    args = parser.parse_args(argv)
    print(f"{args.samples} samples at {args.rate:g} Hz; subtractive; error and bound as fractions "
          "of full scale.\n")
    print("| target | precision | states | terms | temperature law | flash (bytes) | RAM (bytes) | "
          "state (bytes) | cost per sample | temperature read once a second | bound | "
          "measured error | within |")
    print("|---|---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---|")
    failed = 0
    for target in TARGETS:
        for precision in ("float32", "q31"):
            for terms in (1, 2, 3):
                for law, state in rows(precision):
                    model = CreepModel(BETA[:terms], TAU[:terms], 1.0, OFFSET, temperature=law)
                    t, signal, temperature = record(model, args.samples, args.rate)
                    fs = float(np.max(np.abs(signal - OFFSET)))
                    fw = generate_firmware(model, "subtractive", precision, args.rate, fs,
                                           state=state)
                    check = verify_firmware(fw, t, signal, target=target,
                                            temperature=temperature if law is not None else None)
                    run = check.on_target
                    failed += not check.passed
                    slow = "-"
                    if law is not None:
                        again = verify_firmware(fw, t, signal, target=target,
                                                temperature=held(temperature, args.rate))
                        failed += not again.passed
                        slow = f"{again.on_target.per_sample:.0f} {run.counts}"
                    print(f"| {target} | {precision} | {state if precision == 'float32' else '-'} | "
                          f"{terms} | "
                          f"{'Arrhenius' if law else 'none'} | "
                          f"{run.flash_bytes} | {run.ram_bytes} | {run.state_bytes} | "
                          f"{run.per_sample:.0f} {run.counts} | {slow} | {fw.bound.total_fs:.2e} | "
                          f"{check.max_error_fs:.2e} | {'yes' if check.passed else 'NO'} |",
                          flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
