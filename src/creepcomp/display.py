"""How a result shows itself: a text report, an HTML table for notebooks, a plot into the
caller's Axes, and a pandas table.

:class:`Shown` is the mixin of every result a user gets from the API. Its methods reach the
``report`` package (the only one that imports matplotlib) inside the method, as
python-control's ``plot()`` methods reach its plotting module: a computation never imports
plotting or HTML on load, and ``report`` finds the right tables and plot by the result's type
(:func:`creepcomp.report.results.summary_of`, :func:`creepcomp.report.results.plot_of`).
"""

from __future__ import annotations

from creepcomp.errors import InputError

__all__ = ["Shown", "data_frame"]


class Shown:
    """A result that shows itself: :meth:`report`, ``_repr_html_`` and :meth:`plot`.

    A class using it gives ``__repr__`` (one line, no arrays) and ``to_dict``; the tables
    and the plot live in ``creepcomp.report.results``.

    Examples
    --------
    >>> from creepcomp.model import CreepModel
    >>> model = CreepModel.voigt(0.03, 45.0)
    >>> model
    <CreepModel 1 term: 3 % at 45 s (beta0 3 %), gain 1, offset 0>
    >>> print(model.report())
    Creep model
    1 creep term (3 % at 45 s); beta0 = 3 %
    gain 1 signal units per load unit, offset 0 signal units
    <BLANKLINE>
    Creep terms
    term  beta   tau
    ----  ----  ----
       0   3 %  45 s

    In a notebook the same tables show as HTML (``_repr_html_``), and ``model.plot(ax=ax)``
    draws the creep of a load step into ``ax``.
    """

    __slots__ = ()

    def tables(self):
        """The result's tables (:class:`creepcomp.report.tables.Summary`): what ``report()``,
        the notebook and the command line show."""
        from creepcomp.report.results import summary_of

        return summary_of(self)

    def report(self) -> str:
        """The result as plain text: a heading and the tables the command line prints."""
        return self.tables().to_text()

    def _repr_html_(self) -> str:
        return self.tables().to_html()

    def plot(self, ax=None, **options):
        """Draw the result into ``ax`` (a matplotlib Axes; None: a new figure) and return the
        Axes. Nothing is closed or saved: save with ``ax.figure.savefig(path)``.

        ``options`` are those of the type's plot function in ``creepcomp.report`` (see
        :func:`creepcomp.report.results.plot_of`).
        """
        from creepcomp.report.results import plot_of

        return plot_of(self, ax=ax, **options)


def data_frame(columns: dict):
    """A pandas DataFrame of ``columns`` (name to values); pandas is imported here, when a
    table is asked for.

    Raises
    ------
    InputError
        When pandas is not installed (it is optional: ``pip install pandas``).
    """
    try:
        import pandas
    except ImportError:
        raise InputError("to_pandas() needs pandas, which is not installed: pip install pandas") from None
    return pandas.DataFrame(columns)
