"""mkdocs hook: the docstrings' Sphinx roles (``:func:`x```) as cross-references.

mkdocstrings renders ``:func:`creepcomp.lti.lag_states``` as the text ``:func:`` before a code
span. This hook turns each such pair into an optional cross-reference, which mkdocs-autorefs
resolves to the object's API entry when it has one (and leaves as plain code otherwise).
"""

import html
import re

ROLE = re.compile(r":(?:py:)?(?:func|meth|class|mod|data|attr|exc|obj):<code>([^<]+)</code>")


def _reference(match: re.Match) -> str:
    text = match.group(1)
    target = html.unescape(text).lstrip("~.").strip()
    if not re.fullmatch(r"[A-Za-z_][\w.]*", target):
        return f"<code>{text}</code>"
    shown = target.rsplit(".", 1)[-1] if text.startswith("~") else text
    return f'<autoref identifier="{target}" optional><code>{shown}</code></autoref>'


def on_page_content(html_text: str, **kwargs) -> str:
    """Replace the roles left in a page's HTML by optional cross-references."""
    return ROLE.sub(_reference, html_text)
