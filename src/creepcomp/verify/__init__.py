"""Proof of a design: ngspice netlists and simulation, Monte Carlo and worst-case tolerances.

By job, each module importing only the ones before it: :mod:`~creepcomp.verify.drive` (load
programs and time points), :mod:`~creepcomp.verify.netlist` (netlist text, reference
netlists), :mod:`~creepcomp.verify.netlist_export` (the network as a plain ``.subckt`` and
an LTspice schematic), :mod:`~creepcomp.verify.ngspice_engine` (the shared ngspice library and its runs),
:mod:`~creepcomp.verify.compare` (ngspice against python-control);
:mod:`~creepcomp.verify.tolerances` (what varies), :mod:`~creepcomp.verify.variants` (the
metrics of many variants at once), :mod:`~creepcomp.verify.montecarlo`,
:mod:`~creepcomp.verify.worstcase`, :mod:`~creepcomp.verify.sensitivities` and
:mod:`~creepcomp.verify.tolerance_analysis` (all of them, as ``creepcomp mc`` reports them).
"""

from creepcomp.verify.drive import (DEFAULT_POINTS, DEFAULT_SIGNAL, PROGRAMS, default_duration,
                                    spice_program, synthetic_program, transient_times)
from creepcomp.verify.netlist import (Deck, program_deck, record_data, record_deck, write_record_data,
                                      reference_designs, write_deck, write_reference_netlists)
from creepcomp.verify.netlist_export import asc_text, subckt_text
from creepcomp.verify.ngspice_engine import (Ngspice, NgspiceError, NgspiceUnavailable, SpiceRun,
                                             Waveforms, ngspice, run_batch, run_transient,
                                             time_transient)
from creepcomp.verify.compare import (Comparison, at_sample_times, compare_program, compare_temperatures,
                                      compare_record, reference_transient)
from creepcomp.verify.tolerances import (DIELECTRICS, Dielectric, Factor, Tolerance,
                                         ToleranceSpec)
from creepcomp.verify.variants import Metrics
from creepcomp.verify.montecarlo import MonteCarloResult, run_monte_carlo, spot_check
from creepcomp.verify.worstcase import WorstCase, worst_case
from creepcomp.verify.sensitivities import Sensitivity, Tightening, sensitivity, tighter_parts
from creepcomp.verify.tolerance_analysis import ToleranceReport, analyse

__all__ = [
    "DEFAULT_POINTS", "DEFAULT_SIGNAL", "PROGRAMS", "default_duration", "spice_program",
    "synthetic_program", "transient_times",
    "Deck", "program_deck", "record_data", "record_deck", "write_record_data", "reference_designs", "write_deck",
    "write_reference_netlists", "asc_text", "subckt_text",
    "Ngspice", "NgspiceError", "NgspiceUnavailable", "SpiceRun", "Waveforms", "ngspice",
    "run_batch", "run_transient", "time_transient",
    "Comparison", "at_sample_times", "compare_program", "compare_temperatures", "compare_record", "reference_transient",
    "DIELECTRICS", "Dielectric", "Factor", "Tolerance", "ToleranceSpec",
    "Metrics",
    "MonteCarloResult", "run_monte_carlo", "spot_check",
    "WorstCase", "worst_case",
    "Sensitivity", "Tightening", "sensitivity", "tighter_parts",
    "ToleranceReport", "analyse",
]
