"""The error a user can act on, told apart from motorid's own bugs.

:class:`DataError` is raised where input from outside motorid is checked (a
record file, a column, a signal, a model file, an argument a user typed): its
message names what is wrong and where (file, column, row or sample index,
argument), so the user can fix it. It subclasses ValueError, so code that
catches ValueError keeps working. The ``motorid`` command reports a DataError
as one line with exit status 2; any other exception is a bug in motorid and is
reported as one (exit status 1, the traceback with ``-v``).
"""

from __future__ import annotations

__all__ = ["DataError", "OutputError"]


class DataError(ValueError):
    """Input that cannot support the requested work: a bad file, column, value or argument.

    The message names what is wrong and where (file, column, 0-based row or
    sample index, argument name).
    """


class OutputError(OSError):
    """A file or folder motorid writes could not be written whole, or is another writer's.

    The disk is full, the name was taken by another writer meanwhile, or another
    run holds the folder. The message names the file and what is on disk now
    (nothing, the file as it was, or the rows kept); no half-written file is left
    where a whole one was expected. The ``motorid`` command reports it as one line
    with exit status 2.
    """
