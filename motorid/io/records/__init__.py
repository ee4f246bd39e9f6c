"""The records wing: reading, checking and writing records, whatever file they come in.

A record is a pandas DataFrame with columns ``t`` [s], ``u`` [V], ``y`` [rad/s] (and any
extra signals) and ``attrs`` holding at least ``dt`` [s] and ``units``. :func:`read_record`
reads one whole, :func:`iter_record` in blocks of rows, :func:`normalise_record` brings a
DataFrame from the user's own code to the same names and units, :func:`write_record` writes
one as CSV with its attributes.
"""

from .blocks import CHUNK_ROWS, iter_record, read_head
from .read import (
    ATTRS_KEY,
    ATTRS_MARKER,
    COMMENT,
    COMPRESSIONS,
    DRIVE_ATTR,
    DUPLICATES,
    FORMATS_READ,
    JITTER_LIMIT,
    MAT_ATTRS_VARIABLE,
    RECORD_FORMATS,
    REQUIRED_COLUMNS,
    SEPARATORS,
    THOUSANDS,
    TIME_ATTR,
    TIME_UNITS,
    TIMINGS,
    UNREAD_FORMATS,
    RecordOptions,
    check_attrs,
    compression,
    count_data_lines,
    csv_layout,
    normalise_record,
    read_record,
    record_format,
    record_timing,
    speed_from_position,
    trim_record,
    write_record,
)

__all__ = [
    "ATTRS_KEY",
    "ATTRS_MARKER",
    "CHUNK_ROWS",
    "COMMENT",
    "COMPRESSIONS",
    "DRIVE_ATTR",
    "DUPLICATES",
    "FORMATS_READ",
    "JITTER_LIMIT",
    "MAT_ATTRS_VARIABLE",
    "RECORD_FORMATS",
    "REQUIRED_COLUMNS",
    "SEPARATORS",
    "THOUSANDS",
    "TIME_ATTR",
    "TIME_UNITS",
    "TIMINGS",
    "UNREAD_FORMATS",
    "RecordOptions",
    "check_attrs",
    "compression",
    "count_data_lines",
    "csv_layout",
    "iter_record",
    "normalise_record",
    "read_head",
    "read_record",
    "record_format",
    "record_timing",
    "speed_from_position",
    "trim_record",
    "write_record",
]
