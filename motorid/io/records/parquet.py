"""Parquet records (pyarrow): read whole, or in batches across the row groups; the record's
attributes in the schema metadata (:data:`~motorid.io.records.files.ATTRS_KEY`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from motorid.errors import DataError
from motorid.io.records.columns import Blocks, Choose, binary_column, column_chooser
from motorid.io.records.files import ATTRS_KEY, attrs_from_json, one_line_reason, regular_file_size
from motorid.io.records.normalise import stamped_in_ns


def _parquet_file(name: str) -> tuple[Any, dict[str, Any]]:
    """A Parquet file opened (a ``pyarrow.parquet.ParquetFile``) and its record attributes."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        parquet = pq.ParquetFile(name)
    except (pa.ArrowException, OSError) as exc:
        raise DataError(f"{name} is not a readable Parquet file: {one_line_reason(exc)}") from None
    metadata = parquet.schema_arrow.metadata or {}
    return parquet, attrs_from_json(metadata.get(ATTRS_KEY.encode()), name, "the schema metadata")


def read_parquet(name: str, choose: Choose) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    import pyarrow as pa

    parquet, attrs = _parquet_file(name)
    schema = parquet.schema_arrow
    rows = parquet.metadata.num_rows
    chosen = choose({column: (rows,) for column in schema.names})
    try:
        table = parquet.read(columns=chosen)
    except (pa.ArrowException, OSError) as exc:  # a corrupt page or a cut file
        raise DataError(
            f"{name}: its Parquet data cannot be read (corrupt or cut?): {one_line_reason(exc)}"
        ) from None
    return {column: table.column(column).to_numpy() for column in chosen}, attrs


def parquet_blocks(
    name: str, kind: str, mapping: dict[str, str], optional: set[str], chunk_rows: int
) -> Blocks:
    """A Parquet record in batches of at most ``chunk_rows`` rows (pyarrow reads them across row groups)."""
    import pyarrow as pa

    if regular_file_size(name) == 0:
        raise DataError(f"{name} is empty")
    parquet, attrs = _parquet_file(name)
    with parquet:
        found: dict[str, str] = {}
        rows = parquet.metadata.num_rows
        chosen = column_chooser(name, mapping, False, None, found, optional)(
            {column: (rows,) for column in parquet.schema_arrow.names}
        )
        for key in chosen:
            if found[key] == "t" and (pa.types.is_timestamp(parquet.schema_arrow.field(key).type)
                                      or pa.types.is_duration(parquet.schema_arrow.field(key).type)):  # fmt: skip
                attrs = stamped_in_ns(name, attrs, mapping["t"], "date and time")
        yield attrs
        yield None
        first_row = 0
        batches = parquet.iter_batches(batch_size=chunk_rows, columns=chosen)
        while True:
            try:
                batch = next(batches, None)
            except (pa.ArrowException, OSError) as exc:  # a corrupt page or a cut file
                raise DataError(
                    f"{name}: its Parquet data cannot be read (corrupt or cut?): {one_line_reason(exc)}"
                ) from None
            if batch is None:
                return
            yield {
                found[key]: binary_column(
                    name, key, batch.column(key).to_numpy(zero_copy_only=False), found[key] == "t", first_row
                )
                for key in chosen
            }
            first_row += batch.num_rows
