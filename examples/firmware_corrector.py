"""Creep correction on a microcontroller: the generated C corrector in an HX711 scale sketch.

The sensor is an elastomer force sensor read by an HX711 (24-bit ADC, 10 samples/s) in counts:
three creep terms (1 %, 1 %, 1.5 % at 5 s, 50 s, 500 s), 400 counts per gram, tare at 84210
counts. The script

- generates the corrector as C99 in q31 fixed point (no floating point: an AVR has none) for
  10 Hz and a full scale of 2^23 counts, and prints its proven worst-case error bound;
- builds the Arduino sketch ``examples/firmware/hx711_scale/hx711_scale.ino`` on this host with
  gcc and the simulated HX711 of ``hx711_host.c`` (the sketch reads the simulated chip bit by
  bit, as on the target), feeds it a synthetic record of codes (load steps of up to 20 kg, held
  up to 30 min, with 2 counts of noise) and compares its output with the float64 corrector;
- prints the creep error of the raw and of the corrected signal against the true load, and the
  corrector's time per sample and object size on this host (``creepcomp.digital.firmware_check``).

It writes into ``--out``: ``model.json``, ``record.csv`` (time, load in g, signal in counts),
``hx711_scale/`` (the sketch, the host stub, ``creep.h``, ``creep.c``) and ``sketch-output.csv``.
Without gcc it writes the files and says that it did not build them. Try
``creepcomp firmware model.json --precision q31 --verify record.csv`` on the same files.

Run it::

    python examples/firmware_corrector.py          # writes examples-output/firmware_corrector/

``--fast`` makes a shorter record: holds of up to 5 min, 2 hours in all.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
from pathlib import Path

import numpy as np

from creepcomp import CreepModel, Record, compensate, creep_error, write_model, write_record
from creepcomp.digital.firmware import FULL_SCALE_WORD, generate_firmware
from creepcomp.digital.firmware_check import STRICT_FLAGS, verify_firmware
from creepcomp.units import format_percent, format_quantity

HERE = Path(__file__).resolve().parent / "firmware" / "hx711_scale"
#: The sensor in HX711 counts: creep terms, counts per gram, tare (counts at zero load).
SENSOR = CreepModel(beta=(0.01, 0.01, 0.015), tau=(5.0, 50.0, 500.0), gain=400.0, offset=84210.0)
RATE = 10.0                  # Hz: the HX711 with its RATE pin low
FULL_SCALE = 2.0 ** 23       # counts: the sketch's FULL_SCALE_COUNTS
NOISE = 2.0                  # counts RMS
SEED = 711
#: (longest hold in s, record length in s)
FULL = (1800.0, 8 * 3600.0)
FAST = (300.0, 2 * 3600.0)


def synthetic_codes(longest_hold: float, duration: float) -> Record:
    """Load steps between random weights (0 to 20 kg); the HX711's integer codes with noise."""
    rng = np.random.default_rng(SEED)
    n = int(duration * RATE)
    time = np.arange(n) / RATE
    load = np.zeros(n)
    i = int(60 * RATE)
    while i < n:
        hold = int(rng.uniform(10.0, longest_hold) * RATE)
        load[i:i + hold] = rng.choice([0.0, rng.uniform(0.0, 20000.0)])
        i += hold
    signal = SENSOR.response(time, load, hold="zero") + rng.normal(0.0, NOISE, n)
    return Record(time, load, np.round(signal), metadata={"units.load": "g", "units.signal": "counts",
                                                          "description": "HX711 codes of a creeping "
                                                                         "force sensor"})


def build_sketch(folder: Path) -> Path | None:
    """Compile the sketch, the host stub and the corrector with gcc; the executable or None."""
    gcc = shutil.which("gcc")
    if gcc is None:
        return None
    exe = folder / "hx711_scale"
    subprocess.run([gcc, *STRICT_FLAGS, "-O2", "-DHOST_BUILD", "-I", str(folder),
                    "-x", "c", str(folder / "hx711_scale.ino"), "-x", "none",
                    str(folder / "hx711_host.c"), str(folder / "creep.c"), "-o", str(exe)], check=True)
    return exe


def main(argv: list[str] | None = None) -> int:
    """Generate the corrector, build and run the sketch on the host, print the errors."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("examples-output/firmware_corrector"),
                        help="folder for the model, the record, the sketch and its output")
    parser.add_argument("--fast", action="store_true", help="a shorter record (2 h)")
    args = parser.parse_args(argv)
    longest, duration = FAST if args.fast else FULL

    args.out.mkdir(parents=True, exist_ok=True)
    write_model(args.out / "model.json", SENSOR)
    record = synthetic_codes(longest, duration)
    write_record(args.out / "record.csv", record)
    firmware = generate_firmware(SENSOR, "subtractive", "q31", RATE, FULL_SCALE)
    sketch = args.out / "hx711_scale"
    sketch.mkdir(exist_ok=True)
    for name in ("hx711_scale.ino", "hx711_host.c", "hx711_host.h"):
        shutil.copyfile(HERE / name, sketch / name)
    firmware.write(sketch)
    bound = firmware.bound.total_fs
    print(f"corrector: q31, {format_quantity(RATE, 'Hz')}, full scale {FULL_SCALE:.0f} counts; "
          f"proven worst-case error {bound:.3e} of full scale = {bound * FULL_SCALE:.3g} counts")
    print(f"sketch and corrector written to {sketch}")

    exe = build_sketch(sketch)
    if exe is None:
        print("gcc not found: the sketch was not built or run")
        return 0
    codes = "\n".join(str(int(c)) for c in record.signal) + "\n"
    lines = subprocess.run([str(exe)], input=codes, capture_output=True, text=True,
                           check=True).stdout.split()
    words = np.array(lines[1::2], dtype=float)
    corrected = SENSOR.offset + words * (FULL_SCALE / FULL_SCALE_WORD)
    write_record(args.out / "sketch-output.csv", record, extra={"corrected": corrected})
    exact = compensate(record.time, record.signal, SENSOR, "subtractive")
    sketch_error = float(np.max(np.abs(corrected - exact))) / FULL_SCALE
    print(f"sketch on the simulated HX711: {len(words)} samples ({record.duration / 3600:.3g} h); "
          f"largest difference from the float64 corrector {sketch_error:.3e} of full scale "
          f"({'within' if sketch_error <= bound else 'ABOVE'} the bound)")
    print(f"\ncreep error against the true load         {'peak':>12} {'(of FS)':>10}")
    for label, values in (("raw codes", record.signal), ("corrected by the sketch", corrected)):
        error = creep_error(record.time, values, record.load, SENSOR)
        print(f"  {label:<39}{error.peak / SENSOR.gain:>10.2f} g {format_percent(error.peak / FULL_SCALE):>10}")
    print("  (the corrected signal keeps the ADC's 2 counts of noise)")
    check = verify_firmware(firmware, record.time, record.signal)
    print(f"\ncorrector on this host: {check.ns_per_sample:.1f} ns per sample (gcc -O2), object "
          f"{check.object_bytes} bytes (text + data)")
    return 0 if sketch_error <= bound else 1


if __name__ == "__main__":
    raise SystemExit(main())
