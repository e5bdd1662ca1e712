"""The documentation cannot rot: the site builds without a warning (a renamed module breaks an
API page, a dead link or anchor breaks the build), and the code cites only pages it has."""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: A Markdown file named in the code, with the folder it is named in: ``docs/physics.md``,
#: ``physics.md`` (a dangling citation of a contract kept outside the repository) ...
CITATION = re.compile(r"(?<![\w.-])((?:[\w.-]+/)*)([\w-]+\.md)\b")


@pytest.mark.slow
def test_the_site_builds_without_warnings(tmp_path):
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1")
    run = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--config-file", str(ROOT / "mkdocs.yml"),
         "--site-dir", str(tmp_path / "site")],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=120)
    assert "No module named mkdocs" not in run.stderr, "install the docs extra: pip install -e '.[docs]'"
    warnings = [line for line in run.stderr.splitlines() if "WARNING" in line or "ERROR" in line]
    assert run.returncode == 0 and warnings == [], run.stderr[-3000:]
    assert (tmp_path / "site" / "api" / "fit" / "index.html").exists()


def citations(text: str) -> list[tuple[int, str]]:
    """Markdown files named in ``text`` that are not an existing page under ``docs/``."""
    bad = []
    for match in CITATION.finditer(text):
        folder, name = match.groups()
        if folder != "docs/" or not (ROOT / "docs" / name).is_file():
            bad.append((text.count("\n", 0, match.start()) + 1, match.group(0)))
    return bad


def test_the_code_cites_only_pages_the_repository_has():
    dangling = [f"{path.relative_to(ROOT)}:{line}: {name}"
                for path in sorted((ROOT / "src").rglob("*.py"))
                for line, name in citations(path.read_text(encoding="utf-8"))]
    assert dangling == []


@pytest.mark.parametrize("text, bad", [
    ("(``docs/physics.md``, section 3)", []),
    ("(physics.md, section 3)", [(1, "physics.md")]),
    ("see\n``data-format.md``", [(2, "data-format.md")]),
    ("docs/no-such-page.md", [(1, "docs/no-such-page.md")]),
    ("spec/cli.md", [(1, "spec/cli.md")]),
])
def test_the_citation_check_finds_dangling_citations(text, bad):
    assert citations(text) == bad
