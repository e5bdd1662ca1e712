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

import sys
from importlib import import_module
from types import ModuleType

__version__ = "0.1.0"

#: Public name -> module that defines it, most used first (the order of ``docs/api/index.md``).
_API = {
    # measured records in, a creep model out
    "read_record": "creepcomp.io.records", "fit": "creepcomp.diagnose.fitting",
    "diagnose": "creepcomp.diagnose.sensor", "CreepModel": "creepcomp.model",
    "Record": "creepcomp.io.records", "read_model": "creepcomp.io.jsonfiles",
    "write_model": "creepcomp.io.jsonfiles",
    # the analog network
    "size": "creepcomp.analog.sizing", "SizingReport": "creepcomp.analog.sizing",
    "design_network": "creepcomp.analog.network_design",
    "NetworkDesign": "creepcomp.analog.network_design",
    "predict": "creepcomp.analog.quality", "Quality": "creepcomp.analog.quality",
    "ideal_network": "creepcomp.analog.sizing", "Network": "creepcomp.network",
    "Cell": "creepcomp.network", "Branch": "creepcomp.network",
    "Design": "creepcomp.io.jsonfiles", "read_design": "creepcomp.io.jsonfiles",
    "write_design": "creepcomp.io.jsonfiles",
    # proof and tolerances
    "compare_program": "creepcomp.verify.compare", "compare_record": "creepcomp.verify.compare",
    "analyse": "creepcomp.verify.tolerance_analysis", "ToleranceSpec": "creepcomp.verify.tolerances",
    "Tolerance": "creepcomp.verify.tolerances", "run_monte_carlo": "creepcomp.verify.montecarlo",
    # digital correction and firmware
    "correct_record": "creepcomp.digital.correction", "Correction": "creepcomp.digital.correction",
    "compensate": "creepcomp.digital.correctors",
    "Corrector": "creepcomp.digital.correctors", "creep_error": "creepcomp.digital.correctors",
    "generate_firmware": "creepcomp.digital.firmware", "verify_firmware": "creepcomp.digital.firmware_check",
    "firmware_bound": "creepcomp.digital.firmware",
    # built networks, fleets
    "diagnose_circuit": "creepcomp.diagnose.circuit", "suggest_fixes": "creepcomp.analog.faults",
    "FleetResult": "creepcomp.fleet.batch",
    # the fit's parts, other readers, load programs, kernel
    "prepare": "creepcomp.fit.data", "fit_prony": "creepcomp.fit.prony",
    "read_any": "creepcomp.io.formats", "write_record": "creepcomp.io.records",
    "default_sensor": "creepcomp.data",
    "LoadProgram": "creepcomp.programs", "step": "creepcomp.programs",
    "staircase": "creepcomp.programs", "triangle_sweep": "creepcomp.programs",
    "LagExpansion": "creepcomp.lti",
    # errors
    "InputError": "creepcomp.errors", "CreepcompError": "creepcomp.errors",
    "NotRealisableError": "creepcomp.errors",
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


def _function_first(name: str) -> property:
    """``creepcomp.<name>``: the function, although a subpackage has the same name (importing
    the subpackage sets the package's attribute to it; this keeps the function, and the
    subpackage stays where ``import`` finds it, in ``sys.modules``)."""
    def get(module):
        return getattr(import_module(_API[name]), name)

    def keep_function(module, value):
        pass

    return property(get, keep_function, doc=f"The function :func:`{_API[name]}.{name}`.")


class _Package(ModuleType):
    """The package's module type: ``creepcomp.fit`` and ``creepcomp.diagnose`` are the
    functions, whichever of their subpackages was imported first."""

    fit = _function_first("fit")
    diagnose = _function_first("diagnose")


sys.modules[__name__].__class__ = _Package
