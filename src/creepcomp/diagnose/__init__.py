"""Diagnosis of a record: what the creep model (sensor side, :mod:`~creepcomp.diagnose.sensor`)
or the nominal network (circuit side, :mod:`~creepcomp.diagnose.circuit`) gets wrong, and which
effect explains it (:mod:`~creepcomp.diagnose.effects`, one module per effect)."""

from creepcomp.diagnose import effects
from creepcomp.diagnose.circuit import (CircuitDiagnosis, CircuitFinding, CircuitTrial, combine,
                                        diagnose_circuit)
from creepcomp.diagnose.sensor import Diagnosis, Finding, Trial, diagnose

__all__ = ["effects", "diagnose", "Diagnosis", "Finding", "Trial", "diagnose_circuit",
           "CircuitDiagnosis", "CircuitFinding", "CircuitTrial", "combine"]
