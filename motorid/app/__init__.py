"""The per-record work of the commands, with typed options and no argparse.

- :mod:`motorid.app.identify`: ``motorid identify`` on a record (:func:`~motorid.app.identify.identify`
  on a DataFrame of the user's own, :func:`~motorid.app.identify.identify_record` on a motorid
  record, :func:`~motorid.app.identify.identify_file` on a file read in blocks), its options
  :class:`~motorid.app.identify.IdentifyOptions`.

The command line builds the options from its arguments and calls these; so does the fleet
(:mod:`motorid.fleet`), on each record of a run.
"""

from motorid.app.identify import IdentifyOptions, identify, identify_file, identify_record

__all__ = ["IdentifyOptions", "identify", "identify_file", "identify_record"]
