"""Digital creep correction of sampled signals: the recursive correctors (``correctors``), the
paper's literal formulas (``paper_methods``, for comparison) and its test scenarios
(``scenarios``)."""

from creepcomp.digital.correctors import (METHODS, HOLDS, INITIAL_STATES, BLOCK, PASS_SAMPLES,
                                          default_initial, saturation_factor, Corrector,
                                          check_invertible, compensate, uniform_interval, reference,
                                          CreepError, creep_error)
from creepcomp.digital.paper_methods import subtractive, supplemental
from creepcomp.digital.scenarios import (paper_model, SyntheticRecord, step_record, sweep_record,
                                         sweep_hysteresis, Outcome, outcomes, LongRun, long_run)

__all__ = ["METHODS", "HOLDS", "INITIAL_STATES", "BLOCK", "PASS_SAMPLES", "default_initial",
           "saturation_factor", "Corrector", "check_invertible", "compensate", "uniform_interval",
           "reference", "CreepError", "creep_error", "subtractive", "supplemental", "paper_model",
           "SyntheticRecord", "step_record", "sweep_record", "sweep_hysteresis", "Outcome",
           "outcomes", "LongRun", "long_run"]
