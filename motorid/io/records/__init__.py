"""The records wing: records read, checked and written, whatever file they come in.

A record is a pandas DataFrame with columns ``t`` [s], ``u`` [V], ``y`` [rad/s]
(and any extra signals) and ``attrs`` holding at least ``dt`` [s] and ``units``
(column -> unit). motorid writes one as a CSV file whose first line is a comment
carrying the attributes as JSON (:func:`write_record`)::

    # motorid-record {"dt": 0.04, "units": {"t": "s", ...}, "rig": {...}}
    t,u,y,...
    0.0,1.2,0.0,...

pandas reads such a file with ``pd.read_csv(path, comment="#")`` and most CSV
tools skip the comment line, so the data stay readable without motorid;
:func:`read_record` restores the attributes and checks the data.

:func:`read_record` also reads the files DAQs, loggers and analysis tools write, by
extension (:data:`RECORD_FORMATS`), one module per format with its whole-file reader
and, where the format allows, its reader in blocks beside it:

- :mod:`~motorid.io.records.text`: CSV and other text, as loggers write it, also compressed;
- :mod:`~motorid.io.records.parquet`, :mod:`~motorid.io.records.matlab`,
  :mod:`~motorid.io.records.tdms`, :mod:`~motorid.io.records.hdf5`,
  :mod:`~motorid.io.records.excel`: the binary formats.

Every reader ends in one place, :mod:`~motorid.io.records.normalise`, which brings the
columns to motorid's names and units with the options of one :class:`RecordOptions`
(:mod:`~motorid.io.records.options`): time in s from 0, jittered stamps put on a uniform
grid, units converted. :func:`normalise_record` applies the same to a DataFrame from the
user's own code; :func:`iter_record` (:mod:`~motorid.io.records.blocks`) reads a record of
any length as blocks of rows in bounded memory. Errors name the option's field
(``time_unit=...``), never a command-line flag.
"""

from motorid.units import TIME_UNITS

from .blocks import CHUNK_ROWS, iter_record, read_head
from .files import (
    ATTRS_KEY,
    COMPRESSIONS,
    FORMATS_READ,
    MAT_ATTRS_VARIABLE,
    RECORD_FORMATS,
    UNREAD_FORMATS,
    check_attrs,
    compression,
    count_data_lines,
    record_format,
)
from .normalise import normalise_record, speed_from_position, trim_record
from .options import (
    COMMENT,
    DRIVE_ATTR,
    DUPLICATES,
    JITTER_LIMIT,
    REQUIRED_COLUMNS,
    THOUSANDS,
    TIME_ATTR,
    TIMINGS,
    RecordOptions,
    record_timing,
)
from .read import read_record
from .text import ATTRS_MARKER, SEPARATORS, attrs_line, csv_layout, write_record

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
    "attrs_line",
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
