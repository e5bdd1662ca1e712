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
from creepcomp.units import format_parameter, format_percent, format_quantity

__all__ = ["save_figure", "png_base64", "figure_data_uri", "html_page", "html_table", "thin",
           "format_cell", "format_named", "MAX_POINTS"]

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


def format_named(name: str, value) -> str:
    """A value with the unit its name implies (:func:`creepcomp.units.format_parameter`:
    parts such as ``R1.2`` in Ω, ``C1`` in F, ``beta`` in percent, ``tau`` in s ...), for
    HTML; ``–`` for a missing number."""
    if not isinstance(value, (str, list, tuple)) and (value is None or not np.isfinite(value)):
        return "–"
    return html.escape(format_parameter(name, value if isinstance(value, (str, list, tuple))
                                        else float(value)))


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
    """A self-contained HTML page: a title and ``(heading, html)`` sections."""
    body = "\n".join(f"<section><h2>{html.escape(h)}</h2>\n{content}\n</section>" for h, content in sections)
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>
body {{ font-family: system-ui, sans-serif; max-width: 1100px; margin: 2em auto; color: #222; }}
table {{ border-collapse: collapse; margin: 0.5em 0; }}
td, th {{ border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: right; }}
th {{ background: #f3f3f3; }} td:first-child, th:first-child {{ text-align: left; }}
img {{ max-width: 100%; }} .note {{ color: #555; font-size: 0.9em; }}
</style></head><body>
<h1>{html.escape(title)}</h1>
{body}
</body></html>
"""


def html_table(header: list[str], rows: list[list]) -> str:
    """An HTML table from a header and rows of already formatted cells."""
    head = "".join(f"<th>{html.escape(str(h))}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in row) + "</tr>"
                   for row in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


