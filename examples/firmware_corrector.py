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
  corrector's time per sample and object size on this host (``creepcomp.digital.firmware_check``);
- over temperature: the same sensor with an Arrhenius law (43 kJ/mol about 20 °C) in a
  record a quarter as long whose temperature swings from 10 to 40 °C and back; the float32 corrector that takes a
  temperature with every sample (range -10 to 50 °C), run in the same HX711 sketch reading a
  thermistor (``board_temperature_c``) and in a NAU7802 sketch reading the chip's own
  temperature sensor (``firmware/nau7802_scale/``, a simulated chip on a simulated I2C bus);
  both against the float64 corrector with the temperatures they read, and the creep left
  when the temperature is ignored.

It writes into ``--out``: ``model.json``, ``record.csv`` (time, load in g, signal in counts),
``hx711_scale/`` (the sketch, the host stub, ``creep.h``, ``creep.c``), ``sketch-output.csv``,
and for the temperature part ``model-temperature.json``, ``record-temperature.csv``,
``hx711_scale_temperature/`` and ``nau7802_scale/``.
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
from creepcomp.temperature import TemperatureLaw
from creepcomp.units import format_percent, format_quantity

FIRMWARE = Path(__file__).resolve().parent / "firmware"
HERE = FIRMWARE / "hx711_scale"
#: The sensor in HX711 counts: creep terms, counts per gram, tare (counts at zero load).
SENSOR = CreepModel(beta=(0.01, 0.01, 0.015), tau=(5.0, 50.0, 500.0), gain=400.0, offset=84210.0)
RATE = 10.0                  # Hz: the HX711 with its RATE pin low
FULL_SCALE = 2.0 ** 23       # counts: the sketch's FULL_SCALE_COUNTS
NOISE = 2.0                  # counts RMS
SEED = 711
#: The same sensor with the creep's temperature law.
SENSOR_T = CreepModel(SENSOR.beta, SENSOR.tau, SENSOR.gain, SENSOR.offset,
                      temperature=TemperatureLaw.arrhenius(43000.0, 20.0))
#: The record's temperature swing and the range the temperature corrector is generated for (°C).
SWING = (10.0, 40.0)
TEMPERATURE_RANGE = (-10.0, 50.0)
#: (longest hold in s, record length in s)
FULL = (1800.0, 8 * 3600.0)
FAST = (300.0, 2 * 3600.0)


def synthetic_codes(longest_hold: float, duration: float, sensor: CreepModel = SENSOR) -> Record:
    """Load steps between random weights (0 to 20 kg); the HX711's integer codes with noise.
    A sensor with a temperature law sees a temperature swinging over :data:`SWING` once."""
    rng = np.random.default_rng(SEED)
    n = int(duration * RATE)
    time = np.arange(n) / RATE
    load = np.zeros(n)
    i = int(60 * RATE)
    while i < n:
        hold = int(rng.uniform(10.0, longest_hold) * RATE)
        load[i:i + hold] = rng.choice([0.0, rng.uniform(0.0, 20000.0)])
        i += hold
    temperature = None
    if sensor.temperature is not None:
        low, high = SWING
        temperature = low + (high - low) * 0.5 * (1.0 - np.cos(2 * np.pi * time / duration))
    signal = sensor.response(time, load, hold="zero", temperature=temperature) + rng.normal(0.0, NOISE, n)
    return Record(time, load, np.round(signal), temperature=temperature,
                  metadata={"units.load": "g", "units.signal": "counts",
                            "description": "HX711 codes of a creeping force sensor"})


def build_sketch(folder: Path, sketch: str = "hx711_scale", host: str = "hx711_host") -> Path | None:
    """Compile the sketch, the host stub and the corrector with gcc; the executable or None."""
    gcc = shutil.which("gcc")
    if gcc is None:
        return None
    exe = folder / sketch
    subprocess.run([gcc, *STRICT_FLAGS, "-O2", "-DHOST_BUILD", "-I", str(folder),
                    "-x", "c", str(folder / f"{sketch}.ino"), "-x", "none",
                    str(folder / f"{host}.c"), str(folder / "creep.c"), "-o", str(exe)], check=True)
    return exe


def over_temperature(out: Path, longest: float, duration: float) -> bool:
    """The temperature part (module docstring); True when both sketches are within the bound."""
    write_model(out / "model-temperature.json", SENSOR_T)
    record = synthetic_codes(longest, duration, SENSOR_T)
    write_record(out / "record-temperature.csv", record)
    firmware = generate_firmware(SENSOR_T, "subtractive", "float32", RATE, FULL_SCALE,
                                 temperature_range=TEMPERATURE_RANGE)
    bound = firmware.bound.total_fs
    print(f"\nover temperature ({SWING[0]:g} to {SWING[1]:g} °C in the record; Arrhenius "
          f"{SENSOR_T.temperature.activation_energy / 1e3:g} kJ/mol about "
          f"{SENSOR_T.temperature.reference:g} °C): float32 corrector with a temperature per "
          f"sample, {TEMPERATURE_RANGE[0]:g} to {TEMPERATURE_RANGE[1]:g} °C; proven worst-case "
          f"error {bound:.3e} of full scale = {bound * FULL_SCALE:.3g} counts")
    lines = "".join(f"{int(c)} {x:.9g}\n" for c, x in zip(record.signal, record.temperature))
    runs = {}
    for sketch, host, label in (("hx711_scale", "hx711_host", "HX711 sketch, thermistor"),
                                ("nau7802_scale", "nau7802_host", "NAU7802 sketch, chip sensor")):
        folder = out / ("hx711_scale_temperature" if sketch == "hx711_scale" else sketch)
        folder.mkdir(exist_ok=True)
        source = FIRMWARE / sketch
        for name in (f"{sketch}.ino", f"{host}.c", f"{host}.h"):
            shutil.copyfile(source / name, folder / name)
        firmware.write(folder)
        exe = build_sketch(folder, sketch, host)
        if exe is None:
            print("gcc not found: the temperature sketches were not built or run")
            return True
        columns = np.array(subprocess.run([str(exe)], input=lines, capture_output=True, text=True,
                                          check=True).stdout.split(), dtype=float).reshape(-1, 3)
        read = columns[:, 1].astype(np.float32).astype(float)       # the temperature the sketch used
        exact = compensate(record.time, record.signal, SENSOR_T, "subtractive", temperature=read)
        error = float(np.max(np.abs(columns[:, 2] - exact))) / FULL_SCALE
        runs[label] = (error, columns[:, 2])
        print(f"  {label}: {len(columns)} samples, temperature read {read.min():.2f} to "
              f"{read.max():.2f} °C; largest difference from the float64 corrector {error:.3e} "
              f"of full scale ({'within' if error <= bound else 'ABOVE'} the bound)")
    ignoring = compensate(record.time, record.signal, SENSOR, "subtractive")
    print(f"  creep error against the true load        {'peak':>12} {'(of FS)':>10}")
    for label, values in (("raw codes", record.signal),
                          ("corrected at 20 °C (temperature ignored)", ignoring),
                          ("corrected by the HX711 sketch over temperature", runs["HX711 sketch, thermistor"][1])):
        error = creep_error(record.time, values, record.load, SENSOR)
        print(f"    {label:<47}{error.peak / SENSOR.gain:>10.2f} g {format_percent(error.peak / FULL_SCALE):>10}")
    return all(error <= bound for error, _ in runs.values())


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
    within = over_temperature(args.out, longest / 4, duration / 4)
    return 0 if sketch_error <= bound and within else 1


if __name__ == "__main__":
    raise SystemExit(main())
