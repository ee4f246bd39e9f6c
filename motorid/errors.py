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

__all__ = ["DataError"]


class DataError(ValueError):
    """Input that cannot support the requested work: a bad file, column, value or argument.

    The message names what is wrong and where (file, column, 0-based row or
    sample index, argument name).
    """
