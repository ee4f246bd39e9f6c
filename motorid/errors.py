"""Every exception of motorid, in one module.

The error a user can act on is told apart from motorid's own bugs.

:class:`DataError` is raised where input from outside motorid is checked (a
record file, a column, a signal, a model file, an argument a user typed): its
message names what is wrong and where (file, column, row or sample index,
argument), so the user can fix it. It subclasses ValueError, so code that
catches ValueError keeps working. The ``motorid`` command reports a DataError
as one line with exit status 2; any other exception is a bug in motorid and is
reported as one (exit status 1, the traceback with ``-v``).
:class:`ModelFileError` is the DataError of one key of a model file.

:class:`OutputError` is a file motorid writes that could not be written whole;
:class:`FilterDivergenceError` a friction filter that no longer describes its data;
:class:`DAQError` and its subclasses a DAQ backend that cannot measure.
"""

from __future__ import annotations

import math

#: Characters of an offending value a message quotes (:func:`quoted`, a helper beside the exceptions,
#: outside ``__all__``, which lists exceptions only).
QUOTE_LIMIT = 80

__all__ = [
    "DAQConnectionError",
    "DAQError",
    "DAQValueError",
    "DataError",
    "FilterDivergenceError",
    "ModelFileError",
    "OutputError",
    "RigBusyError",
    "RigFaultError",
    "UniformGridError",
]


def quoted(value: object, limit: int = QUOTE_LIMIT) -> str:
    """``repr(value)`` for a message, cut to about ``limit`` characters (a field may hold 200 MB).

    A longer text ends in ``...`` and its full length: ``'xxxx...' (200,000,000 characters)``.

    Parameters
    ----------
    value : object
        The offending value (a string is cut before its ``repr`` is made).
    limit : int
        Characters kept.
    """
    length = len(value) if isinstance(value, str | bytes) else None
    if length is not None and length > limit:
        return f"{value[:limit]!r}... ({length:,} characters)"
    text = repr(value)
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text):,} characters)"


class DataError(ValueError):
    """Input that cannot support the requested work: a bad file, column, value or argument.

    The message names what is wrong and where (file, column, 0-based row or
    sample index, argument name).
    """


class ModelFileError(DataError):
    """A bad value at one key of a model file or of a drive's description.

    Its message is ``"{key}: {problem}"`` (``friction[1].alpha1: missing``); the
    reader of a whole file puts the file's name in front.

    Parameters
    ----------
    key : str
        Where in the JSON object: dotted names and ``[index]`` (``model.J_m``), empty
        for the object itself.
    problem : str
        What is wrong there.
    """

    def __init__(self, key: str, problem: str) -> None:
        super().__init__(f"{key}: {problem}" if key else problem)
        self.key = key
        self.problem = problem


class UniformGridError(DataError):
    """The time stamps of a record read in blocks jitter (or have gaps, with ``resample``): the
    record is put on a uniform grid by :func:`motorid.io.records.read_record`, which reads it whole
    (:func:`motorid.io.records.iter_record`)."""


class OutputError(OSError):
    """A file or folder motorid writes could not be written whole, or is another writer's.

    The disk is full, the name was taken by another writer meanwhile, or another
    run holds the folder. The message names the file and what is on disk now
    (nothing, the file as it was, or the rows kept); no half-written file is left
    where a whole one was expected. The ``motorid`` command reports it as one line
    with exit status 2.
    """


class FilterDivergenceError(RuntimeError):
    """The filter no longer describes the data: its innovations are far larger than
    its own covariance predicts, or the covariance broke down numerically.

    Parameters
    ----------
    message : str
        What diverged, naming the sample.
    sample : int
        Index of the sample at which it was detected.
    nis_mean : float
        Mean normalised innovation squared over the window at that sample (NaN for a
        numerical breakdown).

    Attributes
    ----------
    sample : int
        Index of the sample at which it was detected.
    nis_mean : float
        Mean normalised innovation squared over the window at that sample (NaN for a
        numerical breakdown).
    """

    def __init__(self, message: str, sample: int, nis_mean: float = math.nan):
        super().__init__(message)
        self.sample = sample
        self.nis_mean = nis_mean


class DAQError(RuntimeError):
    """Base class of every error raised by a DAQ backend."""


class DAQConnectionError(DAQError, ConnectionError):
    """The link to the rig is down: no answer within the timeout, or refused."""


class DAQValueError(DAQError, ValueError):
    """A value read from the rig is not a valid measurement (NaN, inf, out of range)."""


class RigFaultError(DAQError):
    """The rig reports a fault (for example its heartbeat watchdog tripped).

    Parameters
    ----------
    message : str
        What the fault is, naming the rig.
    status : int
        The status word read from the rig.

    Attributes
    ----------
    status : int
        The status word read from the rig.
    """

    def __init__(self, message: str, status: int) -> None:
        super().__init__(message)
        self.status = status


class RigBusyError(DAQError):
    """The rig refused a write because another client owns it (Modbus exception 6, device busy).

    A rig has one owner at a time: the first client that writes to it, until its
    heartbeat stalls for the watchdog's time or it disconnects
    (:class:`motorid.io.RigServer`). A run that gets this error has lost the rig.
    """
