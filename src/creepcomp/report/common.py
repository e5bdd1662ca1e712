"""Shared pieces of the plots and HTML reports: saving figures, PNG for HTML, pages and tables.

This package is the only place that imports matplotlib. It never chooses a backend: the
command line selects a file backend at its edge, a notebook keeps its own.
"""

from __future__ import annotations

import base64
import html
import io
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from creepcomp.io.atomic import atomic_path
import jinja2
from markupsafe import Markup
from creepcomp.units import format_parameter, format_percent, format_quantity

__all__ = ["save_figure", "save_axes", "png_base64", "figure_data_uri", "html_page", "html_table", "thin",
           "format_cell", "format_named", "named_text", "plot_text", "render_template", "MAX_POINTS"]

#: Most points drawn of one curve (longer records are thinned evenly).
MAX_POINTS = 20000


def thin(n: int, limit: int = MAX_POINTS) -> np.ndarray:
    """Indices of ``n`` samples thinned evenly to at most about ``limit``."""
    return np.arange(0, n, max(1, n // limit))


def format_cell(x, unit: str | None = None) -> str:
    """A table cell: floats to 4 significant digits (with ``unit``: engineering notation and
    the unit, ``%`` for a fraction as percent), ``–`` for None and non-finite values."""
    if x is None:
        return "–"
    if isinstance(x, (float, np.floating)):
        if not np.isfinite(x):
            return "–"
        if unit == "%":
            return format_percent(float(x))
        if unit:
            return html.escape(format_quantity(float(x), unit))
        return f"{x:.4g}"
    return html.escape(str(x))


def named_text(name: str, value) -> str:
    """A value with the unit its name implies (:func:`creepcomp.units.format_parameter`:
    parts such as ``R1.2`` in Ω, ``C1`` in F, ``beta`` in percent, ``tau`` in s ...), as
    plain text; ``–`` for a missing number."""
    if not isinstance(value, (str, list, tuple)) and (value is None or not np.isfinite(value)):
        return "–"
    return format_parameter(name, value if isinstance(value, (str, list, tuple)) else float(value))


def format_named(name: str, value) -> str:
    """:func:`named_text`, escaped for HTML."""
    return html.escape(named_text(name, value))


def plot_text(text) -> str:
    """Text from a file or an option made safe for a matplotlib label: every ``$`` escaped,
    so that matplotlib never reads it as mathtext (and shows the text as written)."""
    return str(text).replace("$", r"\$")


_ENVIRONMENT = None


def render_template(name: str, **context) -> str:
    """Render the HTML template ``report/templates/<name>``: every value is escaped unless
    it is :class:`markupsafe.Markup` (the ``cell`` filter: :func:`format_cell`), and a name
    the template uses but the context lacks is an error."""
    global _ENVIRONMENT
    if _ENVIRONMENT is None:
        env = jinja2.Environment(loader=jinja2.PackageLoader("creepcomp.report", "templates"),
                                 autoescape=True, undefined=jinja2.StrictUndefined)
        env.filters["cell"] = lambda x, unit=None: Markup(format_cell(x, unit))
        _ENVIRONMENT = env
    return _ENVIRONMENT.get_template(name).render(**context)


def save_figure(fig, path, dpi: int = 110) -> Path:
    """Save a matplotlib figure to ``path`` atomically (folders made as needed) and close it."""
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    try:
        with atomic_path(out) as tmp:
            fig.savefig(tmp, dpi=dpi, format=out.suffix.lstrip(".").lower() or "png")
    finally:
        plt.close(fig)
    return out


def save_axes(ax, path, dpi: int = 110) -> Path:
    """Save the figure a plot function drew ``ax`` in to ``path`` (laid out tightly,
    atomically) and close it: the command line's file output of a plot."""
    fig = ax.figure
    fig.tight_layout()
    return save_figure(fig, path, dpi=dpi)


def png_base64(fig, dpi: int = 100) -> str:
    """A matplotlib figure as base64 PNG text (the figure is closed)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    plt.close(fig)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def figure_data_uri(fig) -> str:
    """A matplotlib figure as an inline PNG ``data:`` URI (the figure is closed)."""
    return "data:image/png;base64," + png_base64(fig)


def html_page(title: str, sections: list[tuple[str, str]]) -> str:
    """A self-contained HTML page (``templates/page.html.j2``): a title and ``(heading, html)``
    sections, each section's body HTML already made by :func:`html_table` or a template (a
    plain ``str`` body is taken as HTML: build it only from escaped pieces)."""
    return render_template("page.html.j2", title=title,
                           sections=[(h, Markup(content)) for h, content in sections])


def html_table(header: list[str], rows: list[list]) -> str:
    """An HTML table (``templates/table.html.j2``) from a header and rows of formatted cells,
    every cell escaped."""
    return render_template("table.html.j2", header=[str(h) for h in header],
                           rows=[[str(c) for c in row] for row in rows])
