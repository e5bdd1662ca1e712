"""mkdocs hook: the README's tour on the Getting started page, from the one copy of it.

A page line ``<!-- README tour -->`` is replaced by the part of ``README.md`` between
``<!-- tour -->`` and ``<!-- /tour -->`` (the part ``tests/test_readme_tour.py`` runs), so the
site and the README show the same commands and outputs.
"""

from pathlib import Path

from mkdocs.exceptions import PluginError

PLACEHOLDER = "<!-- README tour -->"
START, END = "<!-- tour -->", "<!-- /tour -->"


def readme_tour(readme: Path) -> str:
    """The tour of ``readme`` (its heading is a second-level one, as the page's sections)."""
    text = readme.read_text(encoding="utf-8")
    if text.count(START) != 1 or text.count(END) != 1:
        raise PluginError(f"{readme}: the tour must be between one {START} and one {END} line")
    return text.split(START, 1)[1].split(END, 1)[0]


def on_page_markdown(markdown: str, page, config, **kwargs) -> str:
    """Put the README's tour where the page asks for it."""
    if PLACEHOLDER not in markdown:
        return markdown
    readme = Path(config["config_file_path"]).parent / "README.md"
    return markdown.replace(PLACEHOLDER, readme_tour(readme))
