"""The command line's documentation renders: every table row a row, every command in the
command table, every example named where the examples are listed."""

import re
from pathlib import Path

import markdown
import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = sorted((ROOT / "docs").glob("*.md"))


def source_table_rows(text: str) -> int:
    """Lines of Markdown tables outside code blocks (header and body rows, not the ``|---|``
    lines)."""
    rows, fenced = 0, False
    for line in text.splitlines():
        if line.lstrip().startswith("```"):
            fenced = not fenced
        elif not fenced and line.startswith("|") and not re.fullmatch(r"\|[\s:|-]+\|?", line.strip()):
            rows += 1
    return rows


def rendered_tables(text: str) -> list[list[int]]:
    """The tables as mkdocs renders them (its ``tables`` extension): cells per row."""
    page = markdown.markdown(text, extensions=["tables"])
    return [[len(re.findall(r"<t[dh][ >]", row)) for row in re.findall(r"<tr>(.*?)</tr>", table, re.S)]
            for table in re.findall(r"<table>(.*?)</table>", page, re.S)]


@pytest.mark.parametrize("path", DOCS, ids=lambda p: p.name)
def test_every_table_row_renders_as_a_row_of_its_table(path):
    text = path.read_text(encoding="utf-8")
    tables = rendered_tables(text)
    assert sum(len(t) for t in tables) == source_table_rows(text), \
        "a table line renders as text: a blank line inside a table, or a row without its header"
    for table in tables:
        assert all(cells == table[0] for cells in table), f"rows with other cell counts: {table}"


def test_the_checks_find_a_broken_table():
    broken = "| a | b |\n|---|---|\n| 1 | 2 |\n\n| 3 | 4 |\n"
    assert source_table_rows(broken) == 3 and sum(map(len, rendered_tables(broken))) == 2
    assert rendered_tables("| a | b |\n|---|---|\n| 1 | 2 | 3 |\n") == [[2, 2]]


def test_the_command_table_lists_every_command_once_in_the_order_of_the_help():
    from creepcomp.cli import register_commands
    from creepcomp.cli.common import app

    register_commands([])          # every command (a command alone imports only its own)

    text = (ROOT / "docs" / "cli.md").read_text(encoding="utf-8")
    page = markdown.markdown(text, extensions=["tables"])
    table = next(t for t in re.findall(r"<table>(.*?)</table>", page, re.S) if "subcommand" in t)
    listed = re.findall(r'<a href="#creepcomp-([\w-]+)"><code>', table)
    assert listed == [info.name for info in app.registered_commands]
    sections = re.findall(r"^## `creepcomp ([\w-]+)`", text, re.MULTILINE)
    assert sorted(sections) == sorted(listed)


EXAMPLES = sorted(p.name for p in (ROOT / "examples").glob("*.py"))


@pytest.mark.parametrize("page", [
    "docs/index.md",
    "README.md",
])
def test_every_example_is_named_where_the_examples_are_listed(page):
    text = (ROOT / page).read_text(encoding="utf-8")
    missing = [name for name in EXAMPLES if f"`{name}`" not in text]
    assert len(EXAMPLES) >= 9 and missing == []
