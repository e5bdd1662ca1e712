"""The analog correction network: sizing (``sizing``), predicted quality (``quality``), E-series
parts (``eseries``), faults of a built network and their fixes (``faults``)."""

from creepcomp.analog.quality import (Quality, SEGMENT_POINTS, SEGMENT_SPAN, SWEEP_QUARTER_POINTS,
                                      default_sweep_period, corrected_system, step_residual,
                                      sweep_hysteresis, sweep_branches, step_peak, predict,
                                      screening_times, residual_curves, screening_deviation,
                                      step_deviation)
from creepcomp.analog.eseries import (SERIES, TOLERANCE, series_values, values_in_range, neighbours,
                                      nearest)
from creepcomp.analog.sizing import (RULES, DEFAULT_CAPACITANCE, DEFAULT_CAP_RANGE,
                                     DEFAULT_RES_RANGE, FILM_CAP_RANGE, HIGH_IMPEDANCE,
                                     ASSUMED_LEAKAGE, MAX_COMBINATIONS_PER_LEVEL, EXACT_RECHECKS,
                                     explain_unrealisable, ideal_network, PartChoice, SizingReport,
                                     size, nearest_snap, output_resistance, design_warnings)
from creepcomp.analog.faults import (CIRCUIT_EFFECTS, FIX_SPAN, IMPROVEMENT, capacitor_cells,
                                     largest_capacitor, apply_fault, FixOption, suggest_fixes)

__all__ = ["Quality", "SEGMENT_POINTS", "SEGMENT_SPAN", "SWEEP_QUARTER_POINTS",
           "default_sweep_period", "corrected_system", "step_residual", "sweep_hysteresis",
           "sweep_branches", "step_peak", "predict", "screening_times", "residual_curves",
           "screening_deviation", "step_deviation", "SERIES", "TOLERANCE", "series_values",
           "values_in_range", "neighbours", "nearest", "RULES", "DEFAULT_CAPACITANCE",
           "DEFAULT_CAP_RANGE", "DEFAULT_RES_RANGE", "FILM_CAP_RANGE", "HIGH_IMPEDANCE",
           "ASSUMED_LEAKAGE", "MAX_COMBINATIONS_PER_LEVEL", "EXACT_RECHECKS",
           "explain_unrealisable", "ideal_network", "PartChoice", "SizingReport", "size",
           "nearest_snap", "output_resistance", "design_warnings", "CIRCUIT_EFFECTS", "FIX_SPAN",
           "IMPROVEMENT", "capacitor_cells", "largest_capacitor", "apply_fault", "FixOption",
           "suggest_fixes"]
