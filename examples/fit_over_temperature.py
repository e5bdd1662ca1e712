"""Fit a temperature law: the activation energy from three records, and from one ramp.

The records are synthetic, so that the law is known: the default sensor (3 % of creep at
45 s at 20 °C) whose retardation time follows an Arrhenius law of 43 kJ/mol, loaded with a
staircase (full scale, half, full, zero, 0.6, zero; each held 180 s) over 20 min sampled at
10 Hz, with noise of 1e-4 of full scale white plus as much again correlated over 2 s (an
AR(1) process). The script writes

- three records at -10, 20 and 40 °C (``arrhenius_-10C.csv`` ...), whose gain and offset
  drift with temperature (0.2 %/K, 1e-3 of full scale per K) and whose temperature column
  carries 0.05 K of sensor noise;
- one record whose temperature ramps from 10 to 40 °C under the same load steps
  (``arrhenius_ramp.csv``);
- three records at the same temperatures made with a WLF law (c1 = 5, c2 = 150 K at 20 °C:
  ``wlf_-10C.csv`` ...);

then fits one model and its law to each set (:func:`creepcomp.fit.temperature.fit_temperature_law`,
what ``creepcomp fit a.csv b.csv c.csv`` runs), prints the fitted activation energy with its
standard deviation against the truth, the WLF shift factors against the truth, and writes
the model files (``model-three.json``, ``model-ramp.json``, ``model-wlf.json``). The same
from the command line::

    creepcomp fit arrhenius_-10C.csv arrhenius_20C.csv arrhenius_40C.csv -o model.json
    creepcomp fit arrhenius_ramp.csv --law arrhenius
    creepcomp fit wlf_-10C.csv wlf_20C.csv wlf_40C.csv --law wlf

Run it::

    python examples/fit_over_temperature.py          # writes examples-output/fit_over_temperature/

``--fast`` samples at 2 Hz instead of 10 Hz.
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

import numpy as np

from creepcomp.data import default_sensor
from creepcomp.fit.data import prepare
from creepcomp.fit.temperature import fit_temperature_law
from creepcomp.io.jsonfiles import write_json
from creepcomp.io.records import Record, read_record, write_record
from creepcomp.programs import staircase
from creepcomp.synth.common import NoiseSpec, sample_noise
from creepcomp.temperature import TemperatureLaw

ARRHENIUS = TemperatureLaw.arrhenius(43e3, 20.0)
WLF = TemperatureLaw(20.0, "wlf", c1=5.0, c2=150.0)
TEMPERATURES = (-10.0, 20.0, 40.0)
NOISE = NoiseSpec(white=1e-4, coloured=1e-4, correlation_time=2.0)
DURATION = 1200.0        # s
RATE, FAST_RATE = 10.0, 2.0
SEED = 43


def load_history(rate: float) -> tuple[np.ndarray, np.ndarray]:
    """Sample times and the staircase of loads (full scale 1)."""
    t = np.arange(0.0, DURATION, 1.0 / rate)
    return t, staircase(levels=(1.0, 0.5, 1.0, 0.0, 0.6, 0.0), hold=180.0, start=60.0).sample(t)


def records_at(law: TemperatureLaw, rate: float, rng) -> list[Record]:
    """One record per temperature; gain and offset drift with temperature."""
    model = replace(default_sensor(), temperature=law)
    t, load = load_history(rate)
    out = []
    for temp in TEMPERATURES:
        column = np.full(t.size, temp)
        signal = ((1.0 + 0.002 * (temp - 20.0)) * model.response(t, load, temperature=column)
                  + 1e-3 * temp + sample_noise(t, NOISE, rng))
        out.append(Record(t, load, signal, column + rng.normal(0.0, 0.05, t.size)))
    return out


def ramp_record(law: TemperatureLaw, rate: float, rng) -> Record:
    """One record whose temperature ramps from 10 to 40 °C."""
    model = replace(default_sensor(), temperature=law)
    t, load = load_history(rate)
    temp = 10.0 + 30.0 * t / t[-1]
    return Record(t, load, model.response(t, load, temperature=temp) + sample_noise(t, NOISE, rng), temp)


def fit_files(paths: list[Path], law: str):
    """Read the records back as measured ones and fit one model and its law."""
    return fit_temperature_law([prepare(read_record(p)) for p in paths], law=law)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("examples-output/fit_over_temperature"))
    parser.add_argument("--fast", action="store_true", help="sample at 2 Hz")
    args = parser.parse_args()
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    rate = FAST_RATE if args.fast else RATE
    rng = np.random.default_rng(SEED)
    sets = {}
    for name, law in (("arrhenius", ARRHENIUS), ("wlf", WLF)):
        sets[name] = [write_record(out / f"{name}_{temp:g}C.csv", rec)
                      for temp, rec in zip(TEMPERATURES, records_at(law, rate, rng))]
    ramp = write_record(out / "arrhenius_ramp.csv", ramp_record(ARRHENIUS, rate, rng))
    print(f"records: {DURATION / 60:g} min at {rate:g} Hz, noise 1e-4 of full scale white + "
          f"1e-4 AR(1) (2 s); truth E_a = {ARRHENIUS.activation_energy / 1e3:g} kJ/mol")
    for label, paths, file in (("three records at -10, 20, 40 °C", sets["arrhenius"], "model-three.json"),
                               ("one record, 10 -> 40 °C ramp", [ramp], "model-ramp.json")):
        fit = fit_files(paths, "arrhenius")
        ea, sd = fit.law_estimates()["activation_energy"]
        err = ea - ARRHENIUS.activation_energy
        print(f"{label}: E_a = {ea / 1e3:.3f} ± {sd / 1e3:.3f} kJ/mol (1 sigma), error "
              f"{err / 1e3:+.3f} kJ/mol = {100 * err / ARRHENIUS.activation_energy:+.2f} % "
              f"= {err / sd:+.2f} sigma; reference {fit.law.reference:.3g} °C")
        write_json(out / file, fit.to_dict())
    fit = fit_files(sets["wlf"], "wlf")
    (c1, s1), (c2, s2) = fit.law_estimates().values()
    print(f"WLF: c1 = {c1:.3f} ± {s1:.3f} (truth {WLF.c1:g}), c2 = {c2:.1f} ± {s2:.1f} K "
          f"(truth {WLF.c2:g} K)")
    for temp in TEMPERATURES:
        got, truth = float(fit.law.shift(temp)), float(WLF.shift(temp))
        print(f"  a_T at {temp:g} °C: {got:.4g} (truth {truth:.4g}, {100 * (got / truth - 1):+.2f} %)")
    write_json(out / "model-wlf.json", fit.to_dict())
    print(f"files written to {out}")


if __name__ == "__main__":
    main()
