"""Three cases of a correct design built with one wrong resistor.

The default sensor (3 % creep, 45 s) and its exact network snapped to E24/E6 parts
(R1 3 Mohm, C1 15 uF, R2 100 Mohm); the network as built has R2 15 % low, R1 20 % low or
R1 20 % high. The record holds ``signal`` and ``corrected`` sampled every 0.1 s for 30 min
through a staircase of load steps, each channel with white noise of 2e-4 of the step; the
network is driven by the sampled signal. Each record is diagnosed against the nominal
design; printed: the cause, its part and parameters, the alternatives, and the misfit ratios
(where the library reports them).

Usage::

    python benchmarks/circuit_why_cases.py
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from creepcomp.analog.sizing import size
from creepcomp.diagnose.circuit import diagnose_circuit
from creepcomp.io.jsonfiles import Design
from creepcomp.io.records import Record
from creepcomp.model import CreepModel

NOISE = 2e-4


def case_record(built, model, seed: int = 17) -> Record:
    """A staircase record through the sensor and the built network (see the module text)."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 1800.0, 0.1)
    levels = [0.0, 1.0, 2.0, 3.0, 1.5, 0.5, 2.5, 0.0]
    load = np.array(levels)[np.minimum((t // 225.0).astype(int), len(levels) - 1)]
    signal = model.lag_expansion().simulate(t, load, initial="settled") + NOISE * rng.standard_normal(len(t))
    corrected = built.lag_expansion().simulate(t, signal, initial="settled") + NOISE * rng.standard_normal(len(t))
    return Record(t, load, signal, corrected=corrected, source="why-case")


def cases():
    """(name, built network, design) of the three cases."""
    model = CreepModel((0.03,), (45.0,))
    nominal = size(model).chosen
    design = Design(model, nominal)
    c = nominal.cells[0]
    return model, design, [
        ("R2 15 % low", replace(nominal, R2=0.85 * nominal.R2)),
        ("R1 20 % low", replace(nominal, cells=(replace(c, R=0.8 * c.R),))),
        ("R1 20 % high", replace(nominal, cells=(replace(c, R=1.2 * c.R),))),
    ]


def main():
    model, design, todo = cases()
    for name, built in todo:
        d = diagnose_circuit(case_record(built, model), design, spice_check=False)
        out = d.to_dict()
        print(f"== {name}")
        print(f"  cause: {out['cause']}")
        for f in out["findings"]:
            params = ", ".join(f"{k} = {v:.4g}" for k, v in f["parameters"].items() if isinstance(v, float))
            print(f"  finding {f['effect']} {f.get('part') or ''}: {params}"
                  + (f"  [{f['note']}]" if f.get("note") else ""))
            for a in f.get("alternatives", []):
                ap = ", ".join(f"{k} = {v:.4g}" for k, v in a["parameters"].items())
                print(f"    alternative {a['effect']} {a.get('part') or ''}: {ap}")
        base, ext = out["baseline"], out["extended"]
        print(f"  misfit ratio: baseline {base.get('misfit_ratio', 'n/a')}, extended {ext.get('misfit_ratio', 'n/a')}"
              f"; noise floor {out.get('noise_floor', 'n/a')}; residual RMS baseline {base['residual_rms']:.3g},"
              f" extended {ext['residual_rms']:.3g} (noise per channel {NOISE:g})")
        print(f"  fixes: {[(f['part'], f['to']) for f in out['fixes']]}")


if __name__ == "__main__":
    main()
