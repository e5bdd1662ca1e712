"""The sensor side of the bundled built-network record drawn with other seeds: its spec
(:data:`creepcomp.synth.circuit.DEMO_CIRCUIT_SPEC`: one creep term, 3 % at 45 s, 5 Hz, a
staircase, white noise of 2e-5 of the step) is quiet enough that where each load step falls
within its sample interval shows. Prints each seed's cause, findings and baseline misfit
ratio (residual RMS / noise floor).

Usage::

    python benchmarks/built_network_seeds.py [FIRST [END]]   # seeds FIRST .. END-1 (2009 .. 2020)
"""

import sys
from dataclasses import replace

from creepcomp.diagnose.sensor import diagnose
from creepcomp.synth.circuit import DEMO_CIRCUIT_SPEC, generate_circuit


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    first = int(argv[0]) if argv else DEMO_CIRCUIT_SPEC.seed
    end = int(argv[1]) if len(argv) > 1 else first + 12
    named = 0
    for seed in range(first, end):
        record = generate_circuit(replace(DEMO_CIRCUIT_SPEC, seed=seed)).record
        d = diagnose(replace(record, corrected=None), correction=False)
        named += d.cause != "none"
        print(f"seed {seed}: {d.cause:22s} {', '.join(f.effect for f in d.findings) or '-':40s} "
              f"baseline misfit ratio {d.baseline.residual_rms / d.floor.rms:.4f}", flush=True)
    print(f"{named} of {end - first} records with a finding")


if __name__ == "__main__":
    main()
