"""Synthetic records with known hidden effects, for tests, the demo and benchmarks: of a sensor
(:mod:`~creepcomp.synth.sensor`) and of a built correction network (:mod:`~creepcomp.synth.circuit`),
with the noise and detectability rules they share (:mod:`~creepcomp.synth.common`)."""

from creepcomp.synth.circuit import (DEMO_CIRCUIT_SPEC, CircuitSpec, CircuitSynthetic, alternative_faults,
                                     circuit_detectability, circuit_precision, demo_circuit_record, fault_parts,
                                     generate_circuit, random_circuit_spec, random_fault, scaled_part,
                                     write_demo_circuit)
from creepcomp.synth.common import (DETECTABLE_Z, DISTINCT_Z, PRECISE_TO, NoiseSpec, heldout_z, sample_noise,
                                    scaled_noise)
from creepcomp.synth.sensor import (DEMO_SPEC, EFFECTS, PROGRAMS, PROGRAMS_FOR, Spec, Synthetic, detectability,
                                    generate, make_program, random_hidden, random_record, random_spec,
                                    reported_truth, sample_times, simulate_signal, temperature_profile)

__all__ = ["DETECTABLE_Z", "DISTINCT_Z", "PRECISE_TO", "NoiseSpec", "sample_noise", "scaled_noise", "heldout_z",
           "EFFECTS", "PROGRAMS", "PROGRAMS_FOR", "Spec", "Synthetic", "make_program", "sample_times",
           "temperature_profile", "simulate_signal", "detectability", "generate", "random_hidden",
           "random_spec", "random_record", "DEMO_SPEC", "reported_truth",
           "CircuitSpec", "CircuitSynthetic", "generate_circuit", "circuit_detectability", "alternative_faults",
           "fault_parts", "scaled_part", "circuit_precision", "random_fault", "random_circuit_spec",
           "DEMO_CIRCUIT_SPEC", "demo_circuit_record", "write_demo_circuit"]
