"""Fleets of drives: many records on a Dask cluster, one results table, friction trends.

- :func:`~motorid.fleet.sources.find_records` and
  :class:`~motorid.fleet.sources.FilenamePattern`: which records, which drive and time;
- :func:`~motorid.fleet.runner.run_fleet` on :func:`~motorid.fleet.runner.fleet_client`:
  one task per record on ``dask.distributed``, resumable, each row stored as it completes;
- :func:`~motorid.fleet.runner.run` with a :class:`~motorid.fleet.jobs.DoctorJob` or
  :class:`~motorid.fleet.jobs.IdentifyJob` (and :class:`~motorid.io.records.RecordOptions`):
  a whole run from Python, per record or (the doctor) per drive, as ``motorid fleet`` does;
  the jobs are the application layer's options (:class:`motorid.app.DoctorOptions`,
  :class:`motorid.app.IdentifyOptions`, :class:`motorid.io.records.RecordOptions`) under the fleet's names;
- :func:`~motorid.fleet.results.load_results`: the results table;
- :func:`~motorid.fleet.trend.friction_trends` and :func:`~motorid.fleet.trend.flag_drives`:
  friction against time per drive, the drives whose friction rose or that grew an effect.

``motorid fleet identify|doctor|trend`` is the command line over these.
"""

from motorid.fleet.jobs import DoctorJob, IdentifyJob, RecordOptions
from motorid.fleet.results import ResultsStore, flatten, load_results
from motorid.fleet.runner import FleetRun, fleet_client, run, run_fleet, run_fleet_per_drive
from motorid.fleet.sources import FilenamePattern, find_records, identity

__all__ = [
    "DoctorJob",
    "FilenamePattern",
    "FleetRun",
    "IdentifyJob",
    "RecordOptions",
    "ResultsStore",
    "find_records",
    "flatten",
    "fleet_client",
    "identity",
    "load_results",
    "run",
    "run_fleet",
    "run_fleet_per_drive",
]
