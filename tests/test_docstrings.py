"""Every public function and class of the package says what it does (numpydoc summary line)."""

import importlib
import inspect
import pkgutil

import creepcomp


def public_objects():
    for info in pkgutil.walk_packages(creepcomp.__path__, "creepcomp."):
        module = importlib.import_module(info.name)
        yield info.name, module
        for name, obj in vars(module).items():
            if name.startswith("_") or getattr(obj, "__module__", None) != module.__name__:
                continue
            if inspect.isfunction(obj) or inspect.isclass(obj):
                yield f"{info.name}.{name}", obj


def test_public_api_is_documented():
    missing = [name for name, obj in public_objects() if not (inspect.getdoc(obj) or "").strip()]
    assert missing == []
