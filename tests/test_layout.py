"""The package's layout: stages import only earlier stages, no import circles, no library
module imports the command line. Every import counts, including those inside functions."""

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "creepcomp"

#: The stages in the order of their dependencies: a module may import its own stage and the
#: ones before it (``docs/layout.md`` says what each holds).
STAGES = (
    ("edges", ("errors", "units")),
    ("kernel", ("lti", "model", "network", "programs")),
    ("io", ("io",)),
    ("data", ("data",)),
    ("analog", ("analog",)),
    ("digital", ("digital",)),
    ("fit", ("fit",)),
    ("verify", ("verify",)),
    ("diagnose", ("diagnose",)),
    ("report", ("report",)),
    ("synth", ("synth",)),
    ("fleet", ("fleet",)),
    ("cli", ("cli",)),
)


def module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


MODULES = {module_name(p): p for p in PACKAGE.rglob("*.py")}


def imports_of(name: str) -> set[str]:
    """The project's modules that ``name`` imports anywhere in its text."""
    path = MODULES[name]
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[:len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module
            for a in node.names:
                sub = f"{target}.{a.name}"
                found.add(sub if sub in MODULES else target)
    return {m for m in found if m in MODULES and m != name}


GRAPH = {name: imports_of(name) for name in MODULES}


def stage_of(name: str) -> int | None:
    """Index of the stage a module belongs to (None for the package's face)."""
    parts = name.split(".")
    if len(parts) == 1:
        return None
    for i, (_, members) in enumerate(STAGES):
        if parts[1] in members:
            return i
    raise AssertionError(f"{name}: in no stage of STAGES")


def test_every_module_belongs_to_a_stage():
    for name in MODULES:
        stage_of(name)


def test_stages_import_only_earlier_stages():
    upward = []
    for name, targets in GRAPH.items():
        own = stage_of(name)
        for t in targets:
            if own is not None and (stage_of(t) is None or stage_of(t) > own):
                upward.append(f"{name} -> {t}")
    assert upward == []


def test_the_library_never_imports_the_command_line():
    cli = stage_of("creepcomp.cli.common")
    offenders = [f"{n} -> {t}" for n, ts in GRAPH.items() for t in ts
                 if stage_of(n) != cli and stage_of(t) == cli]
    assert offenders == []


def strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's algorithm: the graph's strongly connected components of two or more nodes."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in graph:
        if v not in index:
            visit(v)
    return found


def test_no_import_circles():
    assert strongly_connected(GRAPH) == []


@pytest.mark.parametrize("graph, circles", [
    ({"a": {"b"}, "b": {"a"}, "c": set()}, [["a", "b"]]),
    ({"a": {"b"}, "b": {"c"}, "c": set()}, []),
])
def test_the_circle_finder_finds_circles(graph, circles):
    assert strongly_connected(graph) == circles


def test_modules_declare_their_public_names():
    missing = [n for n, p in MODULES.items()
               if "__all__" not in p.read_text(encoding="utf-8") and not n.startswith("creepcomp.cli")]
    assert missing == []
