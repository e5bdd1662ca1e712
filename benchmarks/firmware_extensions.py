"""``creepcomp firmware --verify`` with a diagnosed model of each kind of extension the C
corrector writes: proven bound and measured error against ``creepcomp correct``.

    nice -n 10 .venv/bin/python benchmarks/firmware_extensions.py OUT_DIR [--max-samples 3000]

For each kind, the synthetic records of the confusion benchmark
(:func:`creepcomp.synth.random_spec`, uniformly sampled, seeds from 0) hiding that effect are
diagnosed until the extended model carries it (for Mullins softening by the largest magnitude
the record hides the ``peak`` form, for the temperature law the model keeps its
``temperature`` block and drops its ``thermal_retardation`` entry, which neither ``correct`` nor
``firmware`` applies together with the law, and its step is generated for the record's
temperatures, whole degrees outward); the record and ``model.json`` are written into
``OUT_DIR`` and ``creepcomp firmware MODEL --verify RECORD --precision P --json`` is run for
float32 and q31. Prints a Markdown table: the command, the bound (and the bound on the
record, for the kinds whose bound depends on it), the measured error, or the refusal.
"""

from __future__ import annotations

import argparse
import json
import math
import shlex
import subprocess
import sys
from pathlib import Path

from creepcomp import synth
from creepcomp.diagnose.sensor import diagnose
from creepcomp.digital.correctors import uniform_interval
from creepcomp.io.jsonfiles import write_json
from creepcomp.io.records import write_record

#: (label, hidden effect, its form, the extension the model must carry, a value it must have)
KINDS = [("temperature law", "thermal_retardation", None, "thermal_retardation", None),
         ("static nonlinearity", "static_nonlinearity", None, "static_nonlinearity", None),
         ("asymmetric recovery", "asymmetric_recovery", None, "asymmetric_recovery", None),
         ("play hysteresis", "rate_independent_hysteresis", None, "rate_independent_hysteresis", None),
         ("Mullins, reloading curve", "mullins_softening", None, "mullins_softening", None),
         ("Mullins, largest magnitude", "mullins_softening", "peak", "mullins_softening", ("form", "peak")),
         ("transition overshoot", "transition_overshoot", None, "transition_overshoot", None)]


def diagnosed(out: Path, label: str, effect: str, form, carries: str, value, max_samples: int):
    """Write the first record (and its extended model) whose diagnosis carries the extension."""
    tag = label.replace(" ", "-").replace(",", "")
    for seed in range(40):
        spec = synth.random_spec(effect, seed, max_samples=max_samples, form=form, irregular=0.0)
        record = synth.generate(spec).record
        if uniform_interval(record.time) is None:
            continue
        model = diagnose(record).extended_model
        entry = (model.get("extensions") or {}).get(carries)
        if entry is None or (value is not None and entry.get(value[0]) != value[1]):
            continue
        extra = []
        if label == "temperature law":
            model = {k: v for k, v in model.items() if k != "extensions"}
            # the record's temperatures, whole degrees outward: q31's a_k series needs T/tau_k <= 1/2
            extra = ["--temperature-range",
                     f"{math.floor(record.temperature.min())}:{math.ceil(record.temperature.max())}"]
        write_record(out / f"{tag}.csv", record)
        return write_json(out / f"{tag}.model.json", model), out / f"{tag}.csv", seed, extra
    raise SystemExit(f"no record of {effect} within 40 seeds is diagnosed with it")


def verify(model: Path, record: Path, precision: str, extra=()) -> tuple[str, str]:
    args = ["firmware", str(model), "--verify", str(record), "--precision", precision, *extra, "--json"]
    proc = subprocess.run([sys.executable, "-c", "from creepcomp.cli import run; run()", *args],
                          capture_output=True, text=True)
    command = "creepcomp " + " ".join(shlex.quote(a) for a in args[:-1])
    if proc.returncode != 0:
        return command, "refused: " + " ".join(proc.stderr.split()).removeprefix("creepcomp: error: ")
    r = json.loads(proc.stdout)
    bound = f"{r['bound_fs']:.3e}"
    if r.get("record_bound_fs") is not None:
        bound += f" (on the record {r['record_bound_fs']:.3e})"
    return command, f"bound {bound}, measured {r['max_error_fs']:.3e} of full scale, {r['ns_per_sample']:.0f} ns/sample"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--max-samples", type=int, default=3000)
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    print("| kind | seed | precision | result | command |\n|---|---|---|---|---|")
    for label, effect, form, carries, value in KINDS:
        model, record, seed, extra = diagnosed(args.out, label, effect, form, carries, value, args.max_samples)
        for precision in ("float32", "q31"):
            command, result = verify(model, record, precision, extra)
            print(f"| {label} | {seed} | {precision} | {result} | `{command}` |", flush=True)


if __name__ == "__main__":
    main()
