"""A creep model fitted to one record, as ``creepcomp fit`` fits it: :func:`fit`.

It lives beside the diagnosis because a fit with viscous flow takes the diagnosis's flow
effect (:func:`creepcomp.diagnose.effects.flow_effect`); the fit itself is
:func:`creepcomp.fit.prony.fit_record`, which the command line calls too.
"""

from __future__ import annotations

from typing import Mapping

from creepcomp.fit.prony import FIT_MAX_TERMS, PronyResult, fit_record
from creepcomp.fit.reduce import GROWN_FIT_SAMPLES, MAX_FIT_SAMPLES, read_reduced
from creepcomp.fit.structure import Applied

__all__ = ["fit"]


def fit(record, columns: Mapping[str, str] | None = None, *, initial: str = "free",
        load_step_at: float | None = None, n_terms: int | None = None,
        max_terms: int = FIT_MAX_TERMS, flow: bool = False, delimiter: str | None = None,
        duplicate_times: str = "error", taxel: int | None = None,
        sheet: str | None = None) -> PronyResult:
    """Fit gain, offset and creep terms to a record; the number of terms by evidence.

    What ``creepcomp fit RECORD`` does: a record longer than
    :data:`~creepcomp.fit.reduce.MAX_FIT_SAMPLES` samples is reduced first
    (:func:`~creepcomp.fit.reduce.read_reduced`; a long CSV file is never held whole), then
    terms are added while the evidence supports them (:func:`~creepcomp.fit.prony.fit_prony`).

    Parameters
    ----------
    record : Record, path, open file, data frame or mapping of arrays
        Read by :func:`~creepcomp.io.formats.read_any` unless a :class:`~creepcomp.io.records.Record`.
    columns : mapping, optional
        Record column -> the file's or frame's column name (or a constant number).
    initial : {"free", "relaxed", "settled"}
        Creep state at the first sample (:func:`~creepcomp.fit.data.prepare`).
    load_step_at : float, optional
        Time (s) of a single load step before the first sample (creep tests).
    n_terms : int, optional
        A fixed number of creep terms (default: chosen by evidence).
    max_terms : int
        Most terms tried.
    flow : bool
        Add viscous flow (a dashpot in series, the Burgers model) to every model.
    delimiter, duplicate_times, taxel, sheet
        For a file, as :func:`~creepcomp.io.formats.read_any` (``creepcomp fit``'s options of
        the same names): a text file's delimiter and repeated time stamps, an insole ``.mat``
        file's taxel, a workbook's sheet.

    Returns
    -------
    PronyResult
        ``.model()`` the chosen creep model, ``.to_dict()`` the model file's content.

    Examples
    --------
    The bundled force-sensor record, from a data frame's worth of columns:

    >>> from creepcomp import data, fit
    >>> record = data.hidden_effect()
    >>> result = fit(record.columns())
    >>> model = result.model()
    >>> model.n_terms, round(model.tau[0], -1)
    (1, 110.0)
    """
    [(record, _)] = read_reduced(record, (MAX_FIT_SAMPLES,), columns, delimiter=delimiter,
                                 duplicate_times=duplicate_times, taxel=taxel, sheet=sheet,
                                 grown_samples=GROWN_FIT_SAMPLES)
    effects = ()
    if flow:
        from creepcomp.diagnose.effects import flow_effect

        effects = (Applied(flow_effect()),)
    return fit_record(record, initial, load_step_at, n_terms, max_terms, effects)
