"""creepcomp: remove creep from elastomer-based sensors.

The Python API behind the ``creepcomp`` command, by stage of the data's way: records and
files (:mod:`creepcomp.io`), creep models and networks (:mod:`creepcomp.model`,
:mod:`creepcomp.network`), sizing and E-series parts (:mod:`creepcomp.analog`), digital
correction (:mod:`creepcomp.digital`), fitting (:mod:`creepcomp.fit`), proof in ngspice and
tolerances (:mod:`creepcomp.verify`), diagnosis (:mod:`creepcomp.diagnose`), plots and reports
(:mod:`creepcomp.report`).

The names below are imported when first used, so that ``import creepcomp`` (and the command
line's start) costs nothing until a name is needed. ``creepcomp.fit`` and
``creepcomp.diagnose`` are subpackages and functions at once: ``creepcomp.fit(record)`` fits a
record, ``creepcomp.fit.prony`` is a module.
"""

import sys
from importlib import import_module
from types import ModuleType

__version__ = "0.1.0"

#: Public name -> module that defines it, most used first (the order of the API index page).
_API = {
    # measured records in, a creep model out
    "read_record": "creepcomp.io.records", "fit": "creepcomp.diagnose.fitting",
    "diagnose": "creepcomp.diagnose.sensor", "CreepModel": "creepcomp.model",
    "Record": "creepcomp.io.records", "read_model": "creepcomp.io.jsonfiles",
    "write_model": "creepcomp.io.jsonfiles",
    # soft sensors: static maps around the creep, the load given back
    "fit_signal_path": "creepcomp.fit.signal_path", "recommend": "creepcomp.diagnose.recommend",
    "estimate_load": "creepcomp.digital.correctors", "model_load": "creepcomp.diagnose.recommend",
    "StaticMap": "creepcomp.transfer", "Transfer": "creepcomp.transfer",
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


#: Names that are both a subpackage and a function: ``creepcomp.fit`` is the subpackage (so
#: ``creepcomp.fit.prony`` and ``import creepcomp.fit.prony as prony`` work), and calling it
#: calls the function (``creepcomp.fit(record)``), whichever was reached first.
_CALLABLE_PACKAGES = ("fit", "diagnose")


def __getattr__(name: str):
    if name in _CALLABLE_PACKAGES:
        return import_module(f"{__name__}.{name}")       # (made callable as it is set here)
    if name in _API:
        value = getattr(import_module(_API[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'creepcomp' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_API))


def _function_of(package: ModuleType):
    """The API function a callable subpackage stands for (``_API``)."""
    name = package.__name__.rpartition(".")[2]
    return getattr(import_module(_API[name]), name)


class _CallablePackage(ModuleType):
    """A subpackage that is also the API function of its name."""

    def __call__(self, *args, **kwargs):
        """Call the function of this name: ``creepcomp.fit(record)`` is
        :func:`creepcomp.diagnose.fitting.fit`, ``creepcomp.diagnose(record)``
        :func:`creepcomp.diagnose.sensor.diagnose`."""
        return _function_of(self)(*args, **kwargs)

    @property
    def __signature__(self):
        import inspect

        return inspect.signature(_function_of(self))


class _Package(ModuleType):
    """The package's module type: the subpackages ``fit`` and ``diagnose`` become callable as
    the import system sets them on the package."""

    def __setattr__(self, name, value):
        if name in _CALLABLE_PACKAGES and type(value) is ModuleType:
            value.__class__ = _CallablePackage
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
