"""The table model: one place for each table a result shows, rendered three ways.

A :class:`Table` is a title, columns and rows of formatted cells (every number already carries
its unit); a :class:`Summary` is a result's heading lines, its tables and its notes. The
command line prints them with Rich (:meth:`Table.to_rich`), a notebook and the HTML reports
show :meth:`Summary.to_html` (every cell escaped), ``report()`` returns :meth:`Summary.to_text`.
"""

from __future__ import annotations

import html
from dataclasses import dataclass, field
from typing import Mapping

__all__ = ["Column", "Table", "Summary"]


@dataclass(frozen=True)
class Column:
    """A column: its heading (with the unit when every cell shares it) and its alignment
    (``"left"`` or ``"right"``)."""

    name: str
    justify: str = "right"


@dataclass(frozen=True)
class Table:
    """A titled table of text cells.

    Attributes
    ----------
    title : str
    columns : tuple of Column
    rows : tuple of tuple of str
        Formatted cells, one per column, numbers with their units.
    marks : mapping of str to str
        A Rich style for the cells of a given text (``{"FAIL": "red"}``): the terminal's
        colour; the text is the same everywhere.
    """

    title: str
    columns: tuple[Column, ...]
    rows: tuple[tuple[str, ...], ...] = ()
    marks: Mapping[str, str] = field(default_factory=dict)

    @classmethod
    def of(cls, title: str, columns, rows, marks: Mapping[str, str] | None = None) -> "Table":
        """A table from column names (or :class:`Column`) and rows of cells (made text)."""
        cols = tuple(c if isinstance(c, Column) else Column(str(c)) for c in columns)
        return cls(title, cols, tuple(tuple(str(c) for c in row) for row in rows), dict(marks or {}))

    def to_rich(self):
        """A ``rich.table.Table`` (the terminal's rendering): every text taken as written (a
        ``[`` from a file is no markup), the cells of :attr:`marks` styled."""
        from rich.markup import escape
        from rich.table import Table as RichTable

        table = RichTable(title=escape(self.title) if self.title else None, title_justify="left")
        for c in self.columns:
            table.add_column(escape(c.name), justify=c.justify)
        for row in self.rows:
            table.add_row(*(f"[{self.marks[v]}]{escape(v)}[/{self.marks[v]}]" if v in self.marks else escape(v)
                            for v in row))
        return table

    def to_text(self) -> str:
        """Plain text: the title, then aligned columns."""
        cells = [[c.name for c in self.columns]] + [list(r) for r in self.rows]
        widths = [max(len(row[k]) for row in cells) for k in range(len(self.columns))]

        def line(row):
            return "  ".join(v.rjust(w) if c.justify == "right" else v.ljust(w)
                             for v, w, c in zip(row, widths, self.columns)).rstrip()

        body = [line(cells[0]), "  ".join("-" * w for w in widths)] + [line(r) for r in cells[1:]]
        return "\n".join(([self.title] if self.title else []) + body)

    def to_html(self) -> str:
        """An HTML table with its title as caption, every cell escaped."""
        head = "".join(f'<th style="text-align:{c.justify}">{html.escape(c.name)}</th>'
                       for c in self.columns)
        body = "".join("<tr>" + "".join(f'<td style="text-align:{c.justify}">{html.escape(v)}</td>'
                                        for v, c in zip(row, self.columns)) + "</tr>"
                       for row in self.rows)
        caption = f"<caption style=\"text-align:left\">{html.escape(self.title)}</caption>" if self.title else ""
        return f"<table>{caption}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


@dataclass(frozen=True)
class Summary:
    """What a result shows: a heading, lines under it, tables, lines after them and warnings
    (all text)."""

    heading: str
    lines: tuple[str, ...] = ()
    tables: tuple[Table, ...] = ()
    footer: tuple[str, ...] = ()
    warnings: tuple[str, ...] = field(default_factory=tuple)

    def to_text(self) -> str:
        """The plain-text report."""
        parts = ["\n".join((self.heading,) + tuple(self.lines))]
        parts += [t.to_text() for t in self.tables]
        tail = list(self.footer) + [f"warning: {w}" for w in self.warnings]
        if tail:
            parts.append("\n".join(tail))
        return "\n\n".join(parts)

    def to_html(self) -> str:
        """An HTML fragment (a notebook cell's output, a report's section), every text escaped."""
        out = [f"<div><strong>{html.escape(self.heading)}</strong>"]
        out += [f"<div>{html.escape(line)}</div>" for line in self.lines]
        out += [t.to_html() for t in self.tables]
        out += [f"<div>{html.escape(line)}</div>" for line in self.footer]
        out += [f'<div style="color:#a60">warning: {html.escape(w)}</div>' for w in self.warnings]
        return "".join(out) + "</div>"
