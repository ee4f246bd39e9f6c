"""The per-record work of the commands, with typed options and no argparse.

- :mod:`motorid.app.identify`: ``motorid identify`` on a record (:func:`~motorid.app.identify.identify`
  on a DataFrame of the user's own, :func:`~motorid.app.identify.identify_record` on a motorid
  record, :func:`~motorid.app.identify.identify_file` on a file read in blocks), its options
  :class:`~motorid.app.identify.IdentifyOptions`.
- :mod:`motorid.app.doctor`: ``motorid doctor`` on a record or on the records of one drive
  (:func:`~motorid.app.doctor.doctor` on DataFrames of the user's own), its options
  :class:`~motorid.app.doctor.DoctorOptions`.
- :mod:`motorid.app.compare`: ``motorid compare`` on a record (:func:`~motorid.app.compare.compare`
  on a DataFrame of the user's own, :func:`~motorid.app.compare.compare_file` on a file), its
  options :class:`~motorid.app.compare.CompareOptions`.

The command line builds the options from its arguments and calls these, with one
:class:`motorid.io.records.RecordOptions` saying how each record is read; so does the fleet
(:mod:`motorid.fleet`), on each record of a run.
"""

from motorid.app.compare import CompareOptions, compare
from motorid.app.doctor import DoctorOptions, doctor
from motorid.app.identify import IdentifyOptions, identify, identify_file, identify_record

__all__ = [
    "CompareOptions",
    "DoctorOptions",
    "IdentifyOptions",
    "compare",
    "doctor",
    "identify",
    "identify_file",
    "identify_record",
]
