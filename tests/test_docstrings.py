"""Every public function and class of the package says what it does (numpydoc summary line)."""

import doctest
import importlib
import inspect
import pkgutil

import pytest

import creepcomp


def package_modules():
    """Every module of the package, imported."""
    for info in pkgutil.walk_packages(creepcomp.__path__, "creepcomp."):
        yield importlib.import_module(info.name)


def public_objects():
    for module in package_modules():
        yield module.__name__, module
        for name, obj in vars(module).items():
            if name.startswith("_") or getattr(obj, "__module__", None) != module.__name__:
                continue
            if inspect.isfunction(obj) or inspect.isclass(obj):
                yield f"{module.__name__}.{name}", obj


def test_public_api_is_documented():
    missing = [name for name, obj in public_objects() if not (inspect.getdoc(obj) or "").strip()]
    assert missing == []


#: The public entry points whose docstrings carry a worked example.
WITH_EXAMPLES = ("creepcomp.analog.sizing.size", "creepcomp.digital.correctors.compensate",
                 "creepcomp.fit.prony.fit_prony", "creepcomp.diagnose.sensor.diagnose",
                 "creepcomp.verify.montecarlo.run_monte_carlo", "creepcomp.io.records.read_record")


def _resolve(dotted: str):
    module, _, name = dotted.rpartition(".")
    return getattr(importlib.import_module(module), name)


@pytest.mark.parametrize("dotted", WITH_EXAMPLES)
def test_public_api_has_an_example(dotted):
    doc = inspect.getdoc(_resolve(dotted)) or ""
    assert "Examples\n--------" in doc and ">>>" in doc


def _doctests():
    finder = doctest.DocTestFinder(exclude_empty=True)
    for module in package_modules():
        for test in finder.find(module):
            if test.examples:
                yield pytest.param(test, id=test.name)


@pytest.mark.parametrize("test", list(_doctests()))
def test_docstring_examples_run(test):
    report: list[str] = []
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    result = runner.run(test, out=report.append)
    assert result.failed == 0, "".join(report)
