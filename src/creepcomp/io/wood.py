"""Tensile creep tests of spruce tissue (Excel workbooks, one sheet per specimen).

Each sheet has a header block (``key | value`` rows: thickness, area, creep load (N), creep
stress (MPa), loading degree, relative humidity ...) and then a table with ``Time [h]``,
``Creep Strain [-]`` and creep compliance (and, in the mechanosorptive tests,
``Moisture [%]``). As a record: ``time`` in seconds, ``load`` the creep stress (MPa), constant,
applied as a step at the first sample (fit with ``load_step_at=0``), ``signal`` the strain.

The files' creep strain starts at 0: the instantaneous (elastic) strain was taken out, and
without it a creep fraction ``beta`` is not defined. ``elastic_modulus="auto"`` adds it back
as ``stress / E`` with the mean modulus the same authors measured on LR slices at the sheet's
humidity (:data:`LR_ELASTIC_MODULUS_MPA`); the creep strain itself is kept unchanged, so
retardation times and the residual do not depend on ``E``, only ``beta`` does (about 10 %
specimen-to-specimen spread). Moisture, where present, goes into the ``temperature`` column:
it is the environmental input that drives mechanosorptive creep as temperature drives
thermal creep (the thermal effects' coefficients then read per % moisture, not per K).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from creepcomp.errors import InputError
from creepcomp.io.inputs import check_input_file
from creepcomp.io.records import Record

__all__ = ["LR_ELASTIC_MODULUS_MPA", "WoodSheet", "wood_sheets", "read_wood_sheet", "wood_record",
           "read_wood"]

#: Mean elastic (tensile) modulus of LR spruce slices by nominal relative humidity (%), in MPa,
#: and the standard deviation and number of specimens: from
#: ``ve_creep_python_routine/Creep_Tests_Dataset/elastic_stiffnesses_Ferrara_Wittel_2024.csv``
#: of alessiafe/Mesoscale-Creep-Evaluation-Routines (commit 0863aaf, MIT; Ferrara and Wittel,
#: Holzforschung 2024, doi:10.1515/hf-2024-0046).
LR_ELASTIC_MODULUS_MPA = {30: (6777.3, 646.4, 13), 65: (6203.1, 578.2, 10), 90: (6051.2, 388.7, 12)}

TIME_COLUMN = "Time [h]"
STRAIN_COLUMN = "Creep Strain [-]"
MOISTURE_COLUMN = "Moisture [%]"
STRESS_KEY = "Creep Stress [MPa]"


@dataclass(frozen=True)
class WoodSheet:
    """One specimen's sheet as read.

    Attributes
    ----------
    name : str
        Sheet (specimen) name.
    header : dict
        The header block, key as written (with its unit) -> value (number or text).
    columns : dict
        Table column name as written -> values (numpy arrays, as in the file: time in hours).
    source : str
    """

    name: str
    header: dict
    columns: dict
    source: str

    def number(self, key: str) -> float:
        """A numeric header value, or a clear error when it is absent."""
        value = self.header.get(key)
        if not isinstance(value, (int, float)):
            raise InputError(f"{self.source}: header '{key}' is missing or not a number "
                             f"({value!r})")
        return float(value)


def _open(path: str | Path):
    from openpyxl import load_workbook

    p = Path(path)
    check_input_file(p, "workbook")
    try:
        return load_workbook(p, read_only=True, data_only=True)
    except Exception as exc:  # openpyxl raises zipfile, KeyError, InvalidFileException ...
        raise InputError(f"{p}: not a readable .xlsx workbook ({type(exc).__name__}: {exc})") from None


def wood_sheets(path: str | Path) -> list[str]:
    """The sheet (specimen) names of a workbook."""
    wb = _open(path)
    try:
        return list(wb.sheetnames)
    finally:
        wb.close()


def read_wood_sheet(path: str | Path, sheet: str | None = None) -> WoodSheet:
    """Read one specimen's sheet: its header block and its table.

    Parameters
    ----------
    path : str or Path
        The ``.xlsx`` workbook.
    sheet : str, optional
        Sheet name; may be left out only when the workbook has one sheet.

    Raises
    ------
    InputError
        For a missing sheet (listing some), a table without ``Time [h]``, or a cell that is
        not a number (naming sheet, row and column).
    """
    wb = _open(path)
    try:
        names = list(wb.sheetnames)
        if sheet is None:
            if len(names) != 1:
                raise InputError(f"{path}: {len(names)} sheets (specimens); name one (--sheet), "
                                 f"e.g. {', '.join(names[:4])}")
            sheet = names[0]
        if sheet not in names:
            raise InputError(f"{path}: no sheet '{sheet}'; sheets: {', '.join(names[:8])}"
                             f"{' ...' if len(names) > 8 else ''}")
        rows = list(wb[sheet].iter_rows(values_only=True))
    finally:
        wb.close()
    source = f"{path} [{sheet}]"
    header: dict = {}
    table_at = None
    for i, row in enumerate(rows):
        if row and row[0] == TIME_COLUMN:
            table_at = i
            break
        if row and isinstance(row[0], str) and row[0].strip():
            header[row[0].strip()] = row[1] if len(row) > 1 else None
    if table_at is None:
        raise InputError(f"{source}: no table header row starting with '{TIME_COLUMN}'")
    names_row = [str(c).strip() if c is not None else "" for c in rows[table_at]]
    columns: dict = {n: [] for n in names_row if n}
    for i, row in enumerate(rows[table_at + 1:], start=table_at + 2):   # Excel row numbers
        if not row or all(c is None for c in row):
            continue
        for j, name in enumerate(names_row):
            if not name:
                continue
            cell = row[j] if j < len(row) else None
            if not isinstance(cell, (int, float)) or isinstance(cell, bool) or not np.isfinite(cell):
                raise InputError(f"{source}, row {i}, column '{name}': {cell!r} is not a finite number")
            columns[name].append(float(cell))
    return WoodSheet(name=sheet, header=header, source=source,
                     columns={k: np.array(v, dtype=float) for k, v in columns.items()})


def _modulus(ws: WoodSheet, elastic_modulus) -> tuple[float | None, str]:
    if elastic_modulus is None:
        return None, "not included (the file's creep strain starts at 0; beta is not defined)"
    if elastic_modulus != "auto":
        e = float(elastic_modulus)
        if not e > 0:
            raise InputError(f"elastic modulus {elastic_modulus}: must be positive (MPa)")
        return e, f"creep stress / {e:.6g} MPa (given)"
    kind = str(ws.header.get("Sample Type", "")).strip()
    rh = ws.header.get("Nominal RH [%]")
    if kind == "LR" and rh in LR_ELASTIC_MODULUS_MPA:
        e, sd, n = LR_ELASTIC_MODULUS_MPA[rh]
        return e, (f"creep stress / {e:.5g} MPa, the mean modulus of {n} LR slices at {rh} % RH "
                   f"(SD {sd:.3g} MPa; Ferrara and Wittel 2024), not this specimen's own")
    return None, (f"not included: no modulus known for sample type '{kind}' at RH {rh} (give "
                  "one; without it beta is not defined)")


def wood_record(ws: WoodSheet, elastic_modulus: float | str | None = "auto") -> Record:
    """A specimen's sheet as a record (see the module's description).

    Parameters
    ----------
    ws : WoodSheet
    elastic_modulus : float, "auto" or None
        Modulus (MPa) whose instantaneous strain ``stress / E`` is added to the creep strain;
        ``"auto"``: the LR mean at the sheet's humidity where known; ``None``: none added.

    Returns
    -------
    Record
        ``metadata`` holds every header value as ``wood.<key>``, the units and how the
        signal was made.
    """
    for col in (TIME_COLUMN, STRAIN_COLUMN):
        if col not in ws.columns:
            raise InputError(f"{ws.source}: no column '{col}'; columns: {', '.join(ws.columns)}")
    stress = ws.number(STRESS_KEY)
    creep = ws.columns[STRAIN_COLUMN]
    e, how = _modulus(ws, elastic_modulus)
    signal = creep + stress / e if e is not None else creep
    metadata = {f"wood.{k}": str(v) for k, v in ws.header.items() if v is not None}
    metadata.update({"units.time": "s (converted from h)", "units.load": "MPa", "units.signal": "m/m",
                     "wood.instantaneous_strain": how,
                     "wood.load": f"creep stress, a step at t = 0 ({STRESS_KEY} of the header)"})
    moisture = ws.columns.get(MOISTURE_COLUMN)
    if moisture is not None:
        metadata["units.temperature"] = "% moisture content (in the temperature column)"
    return Record(time=ws.columns[TIME_COLUMN] * 3600.0, load=np.full(len(creep), stress),
                  signal=signal, temperature=moisture, metadata=metadata, source=ws.source)


def read_wood(path: str | Path, sheet: str | None = None,
              elastic_modulus: float | str | None = "auto") -> Record:
    """Read one specimen of a wood creep workbook as a record (see :func:`wood_record`)."""
    return wood_record(read_wood_sheet(path, sheet), elastic_modulus=elastic_modulus)
