"""Excel workbooks (``.xlsx``, ``.xlsm``) read with openpyxl, as pandas reads them: a column per
header cell of the first row of a sheet, a row of units under it.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np

from motorid.errors import DataError
from motorid.io.records.columns import Choose
from motorid.io.records.files import one_line_reason
from motorid.io.records.normalise import unit_cell
from motorid.io.records.options import quoted, quoted_names


def read_excel(name: str, choose: Choose, sheet: str | None) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """The columns of a sheet of an Excel workbook (openpyxl, read-only: row by row), named by the
    cells of its first row; a second row that names units (``s``, ``%``, ``rpm``) gives theirs.

    A cell that is a date and time (or a time of day) makes its column datetime64 (timedelta64);
    an empty cell is NaN, text a non-numeric value, both refused by row where they are read."""
    import openpyxl

    try:
        workbook = openpyxl.load_workbook(name, read_only=True, data_only=True)
    except Exception as exc:  # zipfile, KeyError, XML errors ... on a file that is not a workbook
        raise DataError(f"{name} is not a readable Excel workbook: {one_line_reason(exc)}") from None
    try:
        if sheet is not None and sheet not in workbook.sheetnames:
            raise DataError(
                f"{name} has no sheet {quoted(sheet)}; its sheets are {quoted_names(workbook.sheetnames)} (sheet=...)"
            )
        worksheet = workbook[sheet] if sheet is not None else workbook.worksheets[0]
        rows = worksheet.iter_rows(values_only=True)
        header = next(rows, None)
        if header is None or all(cell is None for cell in header):
            raise DataError(f"{name}: sheet {quoted(worksheet.title)} has no header in its first row")
        width = max(i for i, cell in enumerate(header) if cell is not None) + 1
        names = [str(cell).strip() if cell is not None else "" for cell in header[:width]]
        for position, column in enumerate(names):
            if not column:
                raise DataError(f"{name}: column {position + 1} of the header of sheet {quoted(worksheet.title)} "
                                "has no name")  # fmt: skip
        attrs: dict[str, Any] = {}
        second = next(rows, None)
        units = None
        if second is not None and all(isinstance(c, str | type(None)) for c in second[:width]):
            cells = ["" if c is None else c for c in second[:width]]
            if any(unit_cell(c) for c in cells):
                units = {
                    column: unit for column, c in zip(names, cells, strict=True) if (unit := unit_cell(c))
                }
        pending = [] if second is None or units else [second]
        stored = worksheet.max_row  # the sheet's stored dimension; None when it stores none
        if stored is None:  # counted as read
            body = [*pending, *rows]
            count, source = len(body), iter(body)
        else:
            count, source = stored - 1 - (units is not None), itertools.chain(pending, rows)
        chosen = choose({column: (max(count, 0),) for column in names})
        positions = [names.index(column) for column in chosen]
        cells_by_column: list[list[Any]] = [[] for _ in chosen]
        for row in source:
            if all(cell is None for cell in row):
                continue  # a blank row (openpyxl's dimension may count trailing ones)
            for slot, position in enumerate(positions):
                cells_by_column[slot].append(row[position] if position < len(row) else None)
    finally:
        workbook.close()
    if units:
        attrs["units"] = units
    return {column: _excel_column(name, column, cells) for column, cells in zip(chosen, cells_by_column,
                                                                                 strict=True)}, attrs  # fmt: skip


def _excel_column(name: str, column: str, cells: list[Any]) -> np.ndarray:
    """The cells of an Excel column as an array: float64, or datetime64/timedelta64 when they are
    dates and times; an empty cell is NaN and text is refused, naming the row."""
    import datetime

    kinds = {type(cell) for cell in cells}
    if kinds and kinds <= {datetime.datetime, datetime.date}:
        return np.array(cells, dtype="datetime64[ns]")
    if kinds and kinds <= {datetime.time, datetime.timedelta}:
        return np.array([
            cell if isinstance(cell, datetime.timedelta) else datetime.timedelta(
                hours=cell.hour, minutes=cell.minute, seconds=cell.second, microseconds=cell.microsecond)
            for cell in cells
        ], dtype="timedelta64[ns]")  # fmt: skip
    values = np.empty(len(cells))
    for row, cell in enumerate(cells):
        if cell is None:
            values[row] = np.nan
        elif isinstance(cell, bool) or not isinstance(cell, int | float):
            raise DataError(
                f"column {quoted(column)} has a non-numeric value {quoted(cell)} at row {row} of {name}"
            )
        else:
            values[row] = cell
    return values
