"""The pages that introduce the project: the API index lists every top-level name once, in
the package's order (most used first), each with its line; Getting started shows the README's
tour from the README itself; the notebooks are pages of the site."""

import importlib.util
import re
from pathlib import Path

import creepcomp

ROOT = Path(__file__).resolve().parents[1]


def test_the_api_index_lists_every_top_level_name_in_order():
    text = (ROOT / "docs" / "api" / "index.md").read_text(encoding="utf-8")
    listed = re.findall(r"^\| \[`(\w+)`\]\[([\w.]+)\] \| (.+) \|$", text, re.MULTILINE)
    assert [name for name, _, _ in listed] == list(creepcomp._API)
    for name, target, line in listed:
        assert target == f"{creepcomp._API[name]}.{name}"
        assert line.strip() and "\n" not in line


def test_getting_started_shows_the_readme_tour():
    spec = importlib.util.spec_from_file_location("readme_tour", ROOT / "docs" / "_hooks" / "readme_tour.py")
    hook = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(hook)
    page = (ROOT / "docs" / "getting-started.md").read_text(encoding="utf-8")
    assert page.count(hook.PLACEHOLDER) == 1
    config = {"config_file_path": str(ROOT / "mkdocs.yml")}
    shown = hook.on_page_markdown(page, page=None, config=config)
    assert hook.PLACEHOLDER not in shown
    assert "$ creepcomp data export hidden_effect" in shown and "\n## A five-minute tour\n" in shown


def test_every_notebook_is_a_page_of_the_site():
    nav = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    for notebook in sorted((ROOT / "examples").glob("*.ipynb")):
        link = ROOT / "docs" / "notebooks" / notebook.name
        assert link.resolve() == notebook.resolve()
        assert f"notebooks/{notebook.name}" in nav
