"""The results table of a fleet run: one row per record, on disk as soon as the record is done.

On disk, in the run's ``--out`` folder:

- ``results.parquet/``: a Parquet dataset, one part file per batch of finished
  records, each written to a temporary name (unique to the process) and linked into
  place under a part name no other file has, so a run that is killed loses no
  finished row and never leaves a half-written part, and no part replaces another. pandas
  (``pd.read_parquet(folder)``) and pyarrow read it as one table; :func:`load_results`
  also keeps one row per record (the last written).
- ``results.csv``: the same table as CSV, rewritten (atomically) every few seconds
  during a run and at its end.

A row holds the record's identity (``record`` path, ``drive``, ``time``), the
``command``, ``status`` (``ok`` or ``failed``), ``error`` (the message of a
failed record), ``warnings`` (what the computation warned, e.g. a diverging filter),
``run_time_s`` and ``worker``, then the command's ``--json``
output flattened (:func:`flatten`): ``params.coulomb``, ``scores.one_step.mse``,
``final_gap.overall``, ``model.params.viscous``, ...
"""

from __future__ import annotations

import errno
import logging
import math
import os
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

logger = logging.getLogger(__name__)

#: Names in a run's folder.
PARQUET_NAME = "results.parquet"
CSV_NAME = "results.csv"
#: The columns every row starts with.
IDENTITY_COLUMNS = (
    "record",
    "drive",
    "time",
    "command",
    "status",
    "error",
    "warnings",
    "run_time_s",
    "worker",
)
_PART = re.compile(r"part-(\d+)\.parquet\Z")


def flatten(payload: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """A nested JSON object as one flat row: ``{"a": {"b": 1}}`` -> ``{"a.b": 1}``.

    Lists of numbers become ``key[0]``, ``key[1]``, ...; lists of text one comma-joined
    value; empty lists and lists of objects (a doctor's steps and rankings) are left out; NaN and inf
    become None, as in ``--json``.

    Parameters
    ----------
    payload : Mapping
        The JSON object (a command's ``--json`` payload).
    prefix : str
        Put in front of every key (the nested object's own key and a dot, when recursing).

    Returns
    -------
    dict
        One flat row: dotted keys, scalar values.
    """
    row: dict[str, Any] = {}
    for key, value in payload.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping):
            row.update(flatten(value, name + "."))
        elif isinstance(value, list | tuple):
            if not value:
                continue
            if all(isinstance(v, str) for v in value):
                row[name] = ",".join(value)
            elif all(isinstance(v, bool | int | float | np.number) or v is None for v in value):
                row.update({f"{name}[{i}]": _scalar(v) for i, v in enumerate(value)})
        else:
            row[name] = _scalar(value)
    return row


def _scalar(value: Any) -> Any:
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    return value


class ResultsStore:
    """The results of a run in ``folder`` (see the module docstring); rows appended as they come.

    The parts on disk are read once and kept in memory beside the rows appended since, so the
    CSV rewrites of a long run do not read the folder again. One run writes to a folder at a time
    (the command line locks it: :class:`motorid.outputs.FolderLock`); even without the lock, a
    store deletes only parts whose rows it has merged into a part already on disk.

    Parameters
    ----------
    folder : str or PathLike
        The run folder; its ``results.parquet/`` is made when missing.
    """

    def __init__(self, folder: str | os.PathLike[str]):
        self.folder = Path(folder)
        self.parts = self.folder / PARQUET_NAME
        self.csv = self.folder / CSV_NAME
        self.parts.mkdir(parents=True, exist_ok=True)
        indices = [int(m.group(1)) for p in self.parts.iterdir() if (m := _PART.match(p.name))]
        self._next = max(indices, default=-1) + 1
        self._tables: list[Any] | None = (
            None  # what is on disk (pyarrow tables), read once, then kept in step
        )
        self._paths: list[Path] = []  # the part file of each of those tables

    def _part_files(self) -> list[Path]:
        return sorted((p for p in self.parts.iterdir() if _PART.match(p.name)), key=lambda p: p.name)

    def append(self, rows: list[dict[str, Any]]) -> Path | None:
        """Write ``rows`` as the next part file (temporary name, then renamed); its path."""
        import pyarrow as pa

        if not rows:
            return None
        # every key of every row (from_pylist alone takes the first row's keys and drops the rest)
        columns = list(dict.fromkeys(key for row in rows for key in row))
        table = pa.table({column: [row.get(column) for row in rows] for column in columns})
        path = self._write_part(table)
        if self._tables is not None:
            self._tables.append(table)
            self._paths.append(path)
        return path

    def _write_part(self, table: Any) -> Path:
        """Write ``table`` whole as the next part name no file has yet."""
        import pyarrow.parquet as pq

        from motorid.outputs import write_file

        while True:
            path = self.parts / f"part-{self._next:06d}.parquet"
            self._next += 1
            try:
                return write_file(path, lambda fh: pq.write_table(table, fh), binary=True)
            except OSError as exc:
                if exc.errno != errno.EEXIST:  # a full disk: the rows are in the parts before
                    raise

    def rows(self) -> pd.DataFrame:
        """Every row written so far, one per record (the last written), sorted by record, identity columns first.

        The parts are joined as one Arrow table (their schemas unified: a column missing
        from a part is null there) and converted once, so a column's type does not
        depend on how the rows happened to be batched into parts.
        """
        import pyarrow as pa
        import pyarrow.parquet as pq

        if self._tables is None:
            self._paths = self._part_files()
            self._tables = [pq.read_table(p) for p in self._paths]
        tables = [t for t in self._tables if t.num_rows]
        if not tables:
            return pd.DataFrame(columns=list(IDENTITY_COLUMNS))
        table = pa.concat_tables(tables, promote_options="permissive").to_pandas()
        table = table.drop_duplicates("record", keep="last").sort_values("record", ignore_index=True)
        first = [c for c in IDENTITY_COLUMNS if c in table.columns]
        return table[first + [c for c in table.columns if c not in first]]

    def write_csv(self, reread: bool = False) -> Path:
        """Rewrite ``results.csv`` from the Parquet parts (temporary name, then renamed).

        Text cells are written as :func:`motorid.outputs.spreadsheet_safe` makes them (a leading
        ``'`` before ``=``, ``+``, ``-``, ``@``; text longer than 1000 characters cut); the Parquet
        parts keep every value as it was.

        ``reread`` reads the parts from disk again first: a run stopped between writing a part
        and keeping it in memory still gets every row on disk into the CSV.
        """
        from motorid.outputs import spreadsheet_safe, write_file

        if reread:
            self._tables = None
        rows = spreadsheet_safe(self.rows())  # a drive id "=..." from a record is shown, never evaluated
        return write_file(self.csv, lambda fh: rows.to_csv(fh, index=False), overwrite=True)

    def compact(self) -> None:
        """Merge the parts whose rows this store holds into one.

        The merged part is on disk, whole, before any part goes, and only the parts
        merged into it go: a part another process wrote since this store read the
        folder stays.
        """
        self.rows()  # the parts on disk, read if they are not yet
        merged_parts = list(self._paths)
        if len(merged_parts) <= 1:
            return
        import pyarrow as pa

        from motorid.errors import OutputError

        merged = pa.Table.from_pandas(self.rows(), preserve_index=False)  # NaN in text columns: null
        try:
            path = self._write_part(merged)
        except OutputError as exc:  # a full disk: nothing merged, nothing deleted
            raise OutputError(f"{exc}; every row is in the parts of {self.parts}/ as before") from None
        for part in merged_parts:
            part.unlink(missing_ok=True)
        self._tables, self._paths = [merged], [path]


def load_results(folder: str | os.PathLike[str]) -> pd.DataFrame:
    """The results table of a run folder (one row per record), ``time`` as datetime.

    Parameters
    ----------
    folder : str or PathLike
        The run folder (``motorid fleet --out``), holding ``results.parquet/``.

    Raises
    ------
    motorid.errors.DataError
        When ``folder`` holds no results.
    """
    from motorid.errors import DataError

    path = Path(folder)
    if not (path / PARQUET_NAME).is_dir():
        raise DataError(
            f"{path} holds no fleet results ({PARQUET_NAME}/ is missing): run motorid fleet first"
        )
    table = ResultsStore(path).rows()
    if "time" in table.columns:
        table["time"] = pd.to_datetime(table["time"])
    return table


__all__ = ["CSV_NAME", "IDENTITY_COLUMNS", "PARQUET_NAME", "ResultsStore", "flatten", "load_results"]
