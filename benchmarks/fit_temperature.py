"""Fitting a temperature law: the activation energy from three records and from one ramp,
the WLF shift factors, and whether the stated uncertainty is what it says.

The records are synthetic, so that the law is known: the default sensor (3 % of creep at
45 s at 20 °C) whose retardation time follows an Arrhenius law of 43 kJ/mol (or a WLF law,
c1 = 5, c2 = 150 K at 20 °C), loaded with a staircase (full scale, half, full, zero, 0.6,
zero; each held 180 s) over 20 min sampled at 10 Hz, with noise of 1e-4 of full scale white
plus as much again correlated over 2 s (an AR(1) process). Three records at -10, 20 and
40 °C, whose gain and offset drift with temperature (0.2 %/K, 1e-3 of full scale per K) and
whose temperature column carries 0.05 K of sensor noise; one record whose temperature ramps
from 10 to 40 °C under the same load steps.

Prints a markdown table: each fit's law (with its standard deviation) against the truth,
and the seconds. With ``--out DIR`` the records of the first set are written there as CSV
(``arrhenius_-10C.csv`` ..., ``arrhenius_ramp.csv``, ``wlf_-10C.csv`` ...), for the command
line::

    creepcomp fit DIR/arrhenius_-10C.csv DIR/arrhenius_20C.csv DIR/arrhenius_40C.csv
    creepcomp fit DIR/arrhenius_ramp.csv --law arrhenius
    creepcomp fit DIR/wlf_-10C.csv DIR/wlf_20C.csv DIR/wlf_40C.csv --law wlf

With ``--sets N`` (default 20) the Arrhenius fits are repeated on N sets of other noise
(one term, 2 Hz), and the errors divided by the stated standard deviations are summarised
(their RMS is 1 when the uncertainty is right).

Usage::

    python benchmarks/fit_temperature.py [--out DIR] [--sets 20]
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from creepcomp.data import default_sensor
from creepcomp.fit.data import prepare
from creepcomp.fit.temperature import fit_temperature_law
from creepcomp.io.records import Record, write_record
from creepcomp.programs import staircase
from creepcomp.synth.common import NoiseSpec, sample_noise
from creepcomp.temperature import TemperatureLaw

ARRHENIUS = TemperatureLaw.arrhenius(43e3, 20.0)
WLF = TemperatureLaw(20.0, "wlf", c1=5.0, c2=150.0)
TEMPERATURES = (-10.0, 20.0, 40.0)
NOISE = NoiseSpec(white=1e-4, coloured=1e-4, correlation_time=2.0)
DURATION = 1200.0        # s
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
        out.append(Record(t, load, signal, column + rng.normal(0.0, 0.05, t.size), source=f"{temp:g} °C"))
    return out


def ramp_record(law: TemperatureLaw, rate: float, rng) -> Record:
    """One record whose temperature ramps from 10 to 40 °C."""
    model = replace(default_sensor(), temperature=law)
    t, load = load_history(rate)
    temp = 10.0 + 30.0 * t / t[-1]
    return Record(t, load, model.response(t, load, temperature=temp) + sample_noise(t, NOISE, rng), temp,
                  source="ramp")


def timed_fit(records: list[Record], law: str, **options):
    """The joint fit and its seconds."""
    start = time.perf_counter()
    fit = fit_temperature_law([prepare(r) for r in records], law=law, **options)
    return fit, time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, help="write the records of the first set here")
    parser.add_argument("--sets", type=int, default=20, help="noise sets for the uncertainty check")
    args = parser.parse_args()
    rng = np.random.default_rng(SEED)
    three, wlf, ramp = records_at(ARRHENIUS, 10.0, rng), records_at(WLF, 10.0, rng), ramp_record(ARRHENIUS, 10.0, rng)
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        for name, recs in (("arrhenius", three), ("wlf", wlf)):
            for temp, rec in zip(TEMPERATURES, recs):
                write_record(args.out / f"{name}_{temp:g}C.csv", rec)
        write_record(args.out / "arrhenius_ramp.csv", ramp)
    truth = ARRHENIUS.activation_energy
    print("| records (20 min at 10 Hz) | fitted (1 sigma) | truth | error | terms | seconds |")
    print("|---|---|---|---|---|---|")
    for label, recs in (("three, at -10, 20, 40 °C", three), ("one, 10 → 40 °C ramp", [ramp])):
        fit, sec = timed_fit(recs, "arrhenius")
        ea, sd = fit.law_estimates()["activation_energy"]
        print(f"| {label} | E_a = {ea / 1e3:.3f} ± {sd / 1e3:.3f} kJ/mol | {truth / 1e3:g} kJ/mol | "
              f"{100 * (ea - truth) / truth:+.2f} % = {(ea - truth) / sd:+.2f} sigma | {fit.n_terms} | {sec:.1f} |")
    fit, sec = timed_fit(wlf, "wlf")
    (c1, s1), (c2, s2) = fit.law_estimates().values()
    shifts = ", ".join(f"{100 * (float(fit.law.shift(t)) / float(WLF.shift(t)) - 1):+.2f} %"
                       for t in (TEMPERATURES[0], TEMPERATURES[2]))
    print(f"| three, WLF | c1 = {c1:.3f} ± {s1:.3f}, c2 = {c2:.1f} ± {s2:.1f} K | c1 = {WLF.c1:g}, "
          f"c2 = {WLF.c2:g} K | a_T at -10 and 40 °C: {shifts} | {fit.n_terms} | {sec:.1f} |")
    if args.sets <= 0:
        return
    z = {"three": [], "ramp": []}
    for k in range(args.sets):
        set_rng = np.random.default_rng(1000 + k)
        for name, recs in (("three", records_at(ARRHENIUS, 2.0, set_rng)),
                           ("ramp", [ramp_record(ARRHENIUS, 2.0, set_rng)])):
            ea, sd = timed_fit(recs, "arrhenius", n_terms=1)[0].law_estimates()["activation_energy"]
            z[name].append((ea - truth) / sd)
    print(f"\n{args.sets} noise sets (2 Hz, one term): error / stated sigma of E_a")
    print("\n| records | mean | RMS | largest | within 2 sigma |\n|---|---|---|---|---|")
    for name, values in z.items():
        v = np.array(values)
        print(f"| {name} | {v.mean():+.2f} | {np.sqrt(np.mean(v ** 2)):.2f} | {np.max(np.abs(v)):.2f} | "
              f"{np.mean(np.abs(v) <= 2):.0%} |")


if __name__ == "__main__":
    main()
