"""creepcomp: remove creep from elastomer-based sensors.

The Python API behind the ``creepcomp`` command, by stage of the data's way: records and
files (:mod:`creepcomp.io`), creep models and networks (:mod:`creepcomp.model`,
:mod:`creepcomp.network`), sizing and E-series parts (:mod:`creepcomp.analog`), digital
correction (:mod:`creepcomp.digital`), fitting (:mod:`creepcomp.fit`), proof in ngspice and
tolerances (:mod:`creepcomp.verify`), diagnosis (:mod:`creepcomp.diagnose`), plots and reports
(:mod:`creepcomp.report`).

The names below are imported when first used, so that ``import creepcomp`` (and the command
line's start) costs nothing until a name is needed.
"""

from importlib import import_module

__version__ = "0.1.0"

#: Public name -> module that defines it.
_API = {
    "CreepcompError": "creepcomp.errors", "InputError": "creepcomp.errors",
    "NotRealisableError": "creepcomp.errors",
    "LagExpansion": "creepcomp.lti", "CreepModel": "creepcomp.model",
    "Branch": "creepcomp.network", "Cell": "creepcomp.network", "Network": "creepcomp.network",
    "LoadProgram": "creepcomp.programs", "step": "creepcomp.programs",
    "staircase": "creepcomp.programs", "triangle_sweep": "creepcomp.programs",
    "Record": "creepcomp.io.records", "read_record": "creepcomp.io.records",
    "write_record": "creepcomp.io.records", "read_any": "creepcomp.io.formats",
    "Design": "creepcomp.io.jsonfiles", "read_design": "creepcomp.io.jsonfiles",
    "read_model": "creepcomp.io.jsonfiles", "write_design": "creepcomp.io.jsonfiles",
    "write_model": "creepcomp.io.jsonfiles",
    "Quality": "creepcomp.analog.quality", "predict": "creepcomp.analog.quality",
    "SizingReport": "creepcomp.analog.sizing", "ideal_network": "creepcomp.analog.sizing",
    "size": "creepcomp.analog.sizing", "suggest_fixes": "creepcomp.analog.faults",
    "Corrector": "creepcomp.digital.correctors", "compensate": "creepcomp.digital.correctors",
    "creep_error": "creepcomp.digital.correctors",
    "correct_record": "creepcomp.digital.correction", "Correction": "creepcomp.digital.correction",
    "design_network": "creepcomp.analog.network_design", "NetworkDesign": "creepcomp.analog.network_design",
    "generate_firmware": "creepcomp.digital.firmware", "firmware_bound": "creepcomp.digital.firmware",
    "verify_firmware": "creepcomp.digital.firmware_check",
    "prepare": "creepcomp.fit.data", "fit_prony": "creepcomp.fit.prony",
    "diagnose": "creepcomp.diagnose.sensor", "diagnose_circuit": "creepcomp.diagnose.circuit",
    "FleetResult": "creepcomp.fleet.batch",
    "default_sensor": "creepcomp.data",
    "compare_program": "creepcomp.verify.compare", "compare_record": "creepcomp.verify.compare",
}

__all__ = sorted(_API)


def __getattr__(name: str):
    if name in _API:
        value = getattr(import_module(_API[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'creepcomp' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_API))
