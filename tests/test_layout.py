"""The package's layout: stages import only earlier stages, no import circles, no library
module imports the command line. Every import counts, including those inside functions, but
one: the results' display mixin (``creepcomp.display``) reaches the report stage inside its
methods, as python-control's ``plot()`` reaches its plotting module (see ``LATE_IMPORTS``)."""

import ast
import re
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "creepcomp"

#: The stages in the order of their dependencies: a module may import its own stage and the
#: ones before it (``docs/layout.md`` says what each holds).
STAGES = (
    ("edges", ("errors", "units", "interrupts", "display")),
    ("kernel", ("recursions", "lti", "temperature", "transfer", "load_filter", "model", "network", "active_stage", "programs")),
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


#: The one import allowed against the stages: the display mixin of every result reaches the
#: report stage (tables, plots) inside its methods, never at load time.
LATE_IMPORTS = {"creepcomp.display": ("creepcomp.report",)}


def _late(name: str, target: str, tree: ast.Module, node: ast.AST) -> bool:
    """An import of ``LATE_IMPORTS`` made inside a function."""
    allowed = LATE_IMPORTS.get(name, ())
    in_function = any(node is inner for f in ast.walk(tree)
                      if isinstance(f, (ast.FunctionDef, ast.AsyncFunctionDef)) for inner in ast.walk(f))
    return in_function and any(target == a or target.startswith(a + ".") for a in allowed)


def imports_of(name: str) -> set[str]:
    """The project's modules that ``name`` imports anywhere in its text (but the late
    imports of ``LATE_IMPORTS``)."""
    path = MODULES[name]
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            targets = {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[:len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module
            targets = {f"{target}.{a.name}" if f"{target}.{a.name}" in MODULES else target
                       for a in node.names}
        else:
            continue
        found.update(t for t in targets if not _late(name, t, tree, node))
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


def test_the_display_mixin_reaches_the_report_stage_only_inside_functions():
    tree = ast.parse("from creepcomp.report import results\nif True:\n    from creepcomp.report import tables\n"
                     "def f():\n    from creepcomp.report import plots\n")
    top, guarded, inner = tree.body[0], tree.body[1].body[0], tree.body[2].body[0]
    assert not _late("creepcomp.display", "creepcomp.report.results", tree, top)
    assert not _late("creepcomp.display", "creepcomp.report.tables", tree, guarded)
    assert _late("creepcomp.display", "creepcomp.report.plots", tree, inner)
    assert not _late("creepcomp.model", "creepcomp.report.plots", tree, inner)


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


LAYOUT_DOC = PACKAGE.parents[1] / "docs" / "layout.md"


def documented_in_layout(name: str, text: str, package: bool = False) -> bool:
    """A module is documented when ``docs/layout.md`` names it in backticks, or names its
    package with a wildcard (``cli.*``); a package, also when it names a module of it."""
    parts = name.split(".")[1:]
    if not parts:
        return True
    names = {f"`{'.'.join(parts)}`"} | {f"`{'.'.join(parts[:i])}.*`" for i in range(1, len(parts))}
    if package:
        names.add(f"`{'.'.join(parts)}.")
    return any(n in text for n in names)


def test_every_module_is_in_the_layout_doc():
    text = LAYOUT_DOC.read_text(encoding="utf-8")
    missing = sorted(n for n, p in MODULES.items()
                     if not documented_in_layout(n, text, package=p.name == "__init__.py"))
    assert missing == []


def test_the_layout_check_sees_a_missing_module():
    assert documented_in_layout("creepcomp.cli.fit", "`cli.*`")
    assert documented_in_layout("creepcomp.fit.reduce", "| `fit.reduce` |")
    assert not documented_in_layout("creepcomp.fit.reduce", "`fit.prony`, `fit.reducer`")
    assert documented_in_layout("creepcomp.fit", "`fit.prony`", package=True)
    assert not documented_in_layout("creepcomp.fit", "`fitting.prony`", package=True)


EFFECTS_PACKAGE = PACKAGE / "diagnose" / "effects"


def strings_in_code(source: str) -> list[str]:
    """The string constants of a module's code: docstrings excepted, f-strings' literal parts
    included."""
    tree = ast.parse(source)
    docstrings = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                docstrings.add(id(body[0].value))
    return [node.value for node in ast.walk(tree)
            if isinstance(node, ast.Constant) and isinstance(node.value, str)
            and id(node) not in docstrings]


def names_an_effect(strings: list[str], effects) -> set[str]:
    """The effect identifiers that occur as words in ``strings``."""
    return {e for e in effects for s in strings if re.search(rf"\b{re.escape(e)}\b", s)}


def test_no_module_outside_the_effects_names_an_effect():
    from creepcomp.diagnose.effects import REGISTRY

    offenders = {}
    for name, path in MODULES.items():
        if EFFECTS_PACKAGE in path.parents:
            continue
        found = names_an_effect(strings_in_code(path.read_text(encoding="utf-8")), REGISTRY)
        if found:
            offenders[name] = sorted(found)
    assert offenders == {}


def test_the_effect_name_check_sees_code_not_docstrings():
    source = '"""Mentions viscous_flow."""\nx = {"viscous_flow": 1}\ny = f"{x} time_offset"\n'
    assert names_an_effect(strings_in_code(source), ("viscous_flow", "time_offset", "other")) == \
        {"viscous_flow", "time_offset"}
    assert names_an_effect(strings_in_code('"""Only viscous_flow here."""\n'), ("viscous_flow",)) == set()


#: The longest a function of the diagnosis may be: its decision loops are short named steps.
DIAGNOSE_MAX_LINES = 80


def test_no_function_in_the_diagnosis_is_over_80_lines():
    long = []
    for name, path in MODULES.items():
        if not name.startswith("creepcomp.diagnose"):
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                lines = node.end_lineno - node.lineno + 1
                if lines > DIAGNOSE_MAX_LINES:
                    long.append(f"{name}.{node.name}: {lines} lines")
    assert long == []
