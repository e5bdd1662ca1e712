"""Correct a record digitally: subtractive and supplemental methods, and streaming in blocks.

The record is synthetic, so that the true load is known: a force sensor with three creep
terms (0.6 % at 6 s, 1.5 % at 45 s, 0.9 % at 150 s), 0.2 mV/N and 0.5 mV of offset, loaded
in steps of 10 N up to 30 N and back, each held for 300 s, sampled at 20 Hz with 0.5 µV of
white noise. The script writes the record as CSV and reads it back (as a measured one would
be), then

- corrects it with the subtractive method (estimate of the instantaneous signal) and the
  supplemental method (estimate of the saturated signal, (1 + beta0) times it);
- prints the creep error of the raw and of each corrected signal against the true load
  (peak and RMS, in volts and in % of full scale);
- runs the subtractive ``Corrector`` as firmware would, on blocks of 64 samples, and prints
  how far it is from the whole-record correction.

It writes into ``--out``: ``record.csv`` (time, load, signal), ``model.json`` (the creep
model), ``corrected.csv`` (the record plus both corrected signals) and
``correction-subtractive.png`` / ``correction-supplemental.png`` (signals and errors). Try
``creepcomp correct record.csv --model model.json`` on the same files.

Run it::

    python examples/correct_record.py             # writes examples-output/correct_record/

``--fast`` makes a shorter record: each load held for 100 s, sampled at 5 Hz.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import numpy as np

os.environ.setdefault("MPLBACKEND", "Agg")  # the plots go to files

from creepcomp import (Corrector, CreepModel, Record, compensate, creep_error, read_record,
    staircase, write_model, write_record)
from creepcomp.digital.correctors import reference, uniform_interval
from creepcomp.report.common import save_axes
from creepcomp.report.digital import plot_correction
from creepcomp.units import format_percent, format_quantity

#: The example force sensor: creep terms, volts per newton, volts at zero load.
SENSOR = CreepModel(beta=(0.006, 0.015, 0.009), tau=(6.0, 45.0, 150.0), gain=0.2e-3, offset=0.5e-3)
LEVELS = (10.0, 20.0, 30.0, 20.0, 10.0, 0.0)   # N
NOISE = 0.5e-6                                 # V RMS
LEAD = 30.0                                    # s unloaded before the first step
#: (seconds each load is held, sampling rate in Hz).
FULL = (300.0, 20.0)
FAST = (100.0, 5.0)
BLOCK = 64
SEED = 2008


def synthetic_record(hold: float, rate: float) -> Record:
    """The sensor's raw signal for the staircase of loads, with white noise."""
    program = staircase(LEVELS, hold, start=LEAD)
    time = np.arange(int(round(program.end * rate)) + 1) / rate
    load = program.sample(time)
    # The steps fall on sample instants: the load is held between samples.
    signal = SENSOR.response(time, load, hold="zero")
    signal += np.random.default_rng(SEED).normal(0.0, NOISE, len(time))
    return Record(time, load, signal, metadata={"units.load": "N", "units.signal": "V",
                                                "description": "creepcomp example: force sensor "
                                                               "in load steps"})


def main(argv: list[str] | None = None) -> int:
    """Make the record, correct it both ways and in blocks, print the errors, plot."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("examples-output/correct_record"),
                        help="folder for the record, the model, the corrected record and plots")
    parser.add_argument("--fast", action="store_true", help="a shorter record (100 s holds, 5 Hz)")
    args = parser.parse_args(argv)

    hold, rate = FAST if args.fast else FULL
    path = write_record(args.out / "record.csv", synthetic_record(hold, rate))
    model_path = write_model(args.out / "model.json", SENSOR)
    record = read_record(path)
    dt = uniform_interval(record.time)
    print(f"record {path}: {len(record)} samples every {format_quantity(dt, 's')}, "
          f"{record.duration:.4g} s; loads up to {max(LEVELS):g} N held {hold:g} s each; "
          f"noise {format_quantity(NOISE, 'V')} RMS")
    print(f"model {model_path}: beta = " + ", ".join(format_percent(b) for b in SENSOR.beta)
          + ", tau = " + ", ".join(format_quantity(t, "s") for t in SENSOR.tau)
          + f"; beta0 = {format_percent(SENSOR.beta0)}")

    corrected = {}
    print(f"\ncreep error against the true load      {'peak':>10} {'(of FS)':>10} "
          f"{'RMS':>10} {'(of FS)':>10}")
    for method in ("subtractive", "supplemental"):
        corrected[method] = compensate(record.time, record.signal, SENSOR, method)
        for label, values in (("raw signal", record.signal), ("corrected", corrected[method])):
            error = creep_error(record.time, values, record.load, SENSOR, method)
            print(f"  {method + ', ' + label:<37}{format_quantity(error.peak, 'V'):>10} "
                  f"{format_percent(error.peak_fraction):>10} {format_quantity(error.rms, 'V'):>10} "
                  f"{format_percent(error.rms_fraction):>10}")
        save_axes(plot_correction(record.time, record.signal, corrected[method],
                                  reference(record.load, SENSOR, method),
                                  title=f"{method} correction", signal_unit="V",
                                  full_scale=error.full_scale), args.out / f"correction-{method}.png")
    print("  (subtractive: against offset + gain * load; supplemental: against offset + "
          "(1 + beta0) * gain * load)")

    corrector = Corrector(SENSOR, "subtractive", dt=dt)
    streamed = np.concatenate([corrector.process(record.signal[i:i + BLOCK])
                               for i in range(0, len(record), BLOCK)])
    difference = float(np.max(np.abs(streamed - corrected["subtractive"])))
    print(f"\nstreamed in blocks of {BLOCK} samples: largest difference from the whole-record "
          f"correction {difference:.3g} V")

    out = write_record(args.out / "corrected.csv", record, extra={
        "compensated_subtractive": corrected["subtractive"],
        "compensated_supplemental": corrected["supplemental"]})
    print(f"corrected record written to {out}; plots correction-subtractive.png and "
          f"correction-supplemental.png in {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
