"""What motorid writes: one writer per file and per folder, no half-written file, no name from data as a path.

- :func:`write_file` writes a file under a temporary name in its folder (unique
  to the process) and puts it in place whole once written: with ``overwrite``
  by a rename over the old file; without, by a hard link that fails when the
  name exists, so the check and the create are one step and of two writers of
  one new name exactly one wins. A full disk or a lost race leaves the name as
  it was and raises :class:`~motorid.errors.OutputError` naming the file.
- :func:`create_in_place` gives a file that is written as a run goes (a run's
  CSV, row by row) its name at once, by the same link or rename.
- :class:`FolderLock` locks a folder a run writes (a fleet's results, a
  command's figures) for as long as the run lasts.

No writer follows a symbolic link at the name it writes: a link there is
replaced by the new file (with ``overwrite``) or refused, never written
through, and the lock file is opened with ``O_NOFOLLOW`` and must be a regular
file.
- :func:`safe_file_name` turns a name that comes from data (a drive id in a
  record's attrs, a file's stem) into one file name that stays in its folder.
- :func:`jsonable`: numpy and pandas values as plain JSON, as ``--json`` and a fleet's rows write them.
- :func:`spreadsheet_safe`: a table's text cells as a spreadsheet shows them and never executes them,
  for the CSV tables motorid writes.
"""

from __future__ import annotations

import errno
import hashlib
import logging
import math
import os
import secrets
import socket
import stat
import sys
from collections.abc import Callable
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

from motorid.errors import QUOTE_LIMIT, OutputError

if TYPE_CHECKING:
    import pandas as pd

logger = logging.getLogger(__name__)

__all__ = [
    "LOCK_NAME",
    "FolderLock",
    "create_in_place",
    "disk_full",
    "jsonable",
    "safe_file_name",
    "spreadsheet_safe",
    "write_file",
]

#: The lock file a run keeps in the folder it writes (:class:`FolderLock`).
LOCK_NAME = ".motorid.lock"
#: Longest file name :func:`safe_file_name` returns, in UTF-8 bytes (file systems allow 255).
MAX_NAME_BYTES = 120
#: Characters besides letters and digits a name from data keeps.
_NAME_CHARACTERS = frozenset("-_.+=@ ")
#: First characters that make a spreadsheet read a cell as a formula (and tab, carriage return).
FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")
#: Longest text cell a CSV table keeps whole [characters]; a longer one is cut (:func:`spreadsheet_safe`).
MAX_TEXT_CELL = 1000
#: errno of a file system that has no hard links (then the name is claimed with O_EXCL first).
_NO_LINKS = {errno.EPERM, errno.EOPNOTSUPP, errno.ENOTSUP, errno.EXDEV, errno.EMLINK, errno.ENOSYS}


def disk_full(exc: OSError) -> bool:
    """True when ``exc`` says the disk (or the user's quota) is full.

    Parameters
    ----------
    exc : OSError
        The error a write raised.
    """
    return exc.errno in (errno.ENOSPC, errno.EDQUOT)


def _temporary_name(target: Path) -> Path:
    """A name beside ``target`` no other process uses: ``.NAME.PID.RANDOM.tmp``."""
    return target.with_name(f".{target.name[:80]}.{os.getpid()}.{secrets.token_hex(4)}.tmp")


def _put_in_place(tmp: Path, target: Path, overwrite: bool) -> None:
    if overwrite:
        os.replace(tmp, target)
        return
    try:
        os.link(tmp, target)  # fails if target exists: one step, one winner
    except OSError as exc:
        if exc.errno not in _NO_LINKS:  # FileExistsError among them
            raise
        # no hard links here: claim the name exclusively (an empty file for a moment), then fill it whole
        os.close(os.open(target, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
        os.replace(tmp, target)
        return
    os.unlink(tmp)


def write_file(
    path: str | os.PathLike[str],
    write: Callable[[IO[Any]], object],
    *,
    overwrite: bool = False,
    binary: bool = False,
    sync: bool = True,
) -> Path:
    """Write a file whole: ``write(fh)`` fills a temporary file, which then takes the name ``path``.

    The temporary file is in ``path``'s folder (so the last step is a rename or a
    link on one file system), flushed to the disk before it takes the name. Until
    then ``path`` is as it was: a reader sees the old file or the new one, never a
    part.

    Parameters
    ----------
    path : path-like
        The file to write.
    write : callable
        ``write(fh)`` writes the content into the open file ``fh`` (text, UTF-8,
        newlines as written; or bytes with ``binary``).
    overwrite : bool
        Replace an existing file. Without it an existing ``path`` is refused, also
        one another process created while ``write`` ran.
    binary : bool
        Open the temporary file in binary mode.
    sync : bool
        Flush the content to the disk before the file takes its name, so that not
        even a power cut leaves the name on an empty file (False for what is cheap
        to make again, such as a figure).

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    motorid.errors.OutputError
        ``path`` exists (without ``overwrite``; ``errno`` is ``EEXIST``), or the disk
        is full, or the folder cannot be written: the message names the file and
        says it was left as it was. An exception of ``write`` itself passes
        through, with nothing written.
    """
    target = Path(path)
    existed = os.path.lexists(target)
    kept = f"{target} is as it was" if existed else "nothing was written"
    tmp = _temporary_name(target)
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        text = {} if binary else {"encoding": "utf-8", "newline": ""}
        with os.fdopen(fd, "wb" if binary else "w", **text) as fh:
            write(fh)
            fh.flush()
            if sync:
                os.fsync(fh.fileno())
        _put_in_place(tmp, target, overwrite)
    except FileExistsError:
        taken = OutputError(
            f"{target}: the file exists (another writer created it meanwhile); nothing was written"
        )
        taken.errno = errno.EEXIST  # for a caller that takes the next free name
        raise taken from None
    except OSError as exc:
        if disk_full(exc):
            raise OutputError(f"{target}: the disk is full ({exc.strerror}); {kept}") from None
        raise OutputError(f"{target}: cannot write the file: {exc.strerror or exc}; {kept}") from None
    finally:
        tmp.unlink(missing_ok=True)
    logger.debug("wrote %s whole", target)
    return target


def create_in_place(path: str | os.PathLike[str], *, overwrite: bool = False) -> int:
    """Create an empty file at ``path`` for this process alone; return its descriptor, open for writing.

    For a file written as a run goes (a run's CSV, row by row). The file is made
    under a temporary name beside ``path``, locked (:func:`fcntl.flock`, held
    until the descriptor is closed) and then takes the name as :func:`write_file`
    puts a file in place: without ``overwrite`` by a link that fails when the name
    exists; with it by a rename over the old entry. A symbolic link at ``path`` is
    so refused or replaced, never written through, and what it points at is left
    as it was. With ``overwrite``, a regular file at ``path`` that another process
    holds locked (another run writing it) is refused.

    Parameters
    ----------
    path : path-like
        The file to create.
    overwrite : bool
        Replace what is at ``path`` (a file or a link).

    Returns
    -------
    int
        A descriptor open for writing on the new, empty file (the caller closes it).

    Raises
    ------
    motorid.errors.OutputError
        ``path`` exists (without ``overwrite``; ``errno`` is ``EEXIST``), another
        run writes it, or the folder cannot be written; nothing was changed.
    """
    import fcntl

    target = Path(path)
    if overwrite:
        _refuse_a_file_in_use(target)
    tmp = _temporary_name(target)
    fd = -1
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o666)
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        _put_in_place(tmp, target, overwrite)
    except FileExistsError:
        if fd >= 0:
            os.close(fd)
        taken = OutputError(
            f"{target}: the file exists (another writer created it meanwhile); nothing was written"
        )
        taken.errno = errno.EEXIST
        raise taken from None
    except OSError as exc:
        if fd >= 0:
            os.close(fd)
        raise OutputError(
            f"{target}: cannot create the file: {exc.strerror or exc}; nothing was written"
        ) from None
    finally:
        tmp.unlink(missing_ok=True)
    return fd


def _refuse_a_file_in_use(target: Path) -> None:
    """Raise OutputError when ``target`` is a regular file another process holds locked."""
    import fcntl

    try:
        fd = os.open(target, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_NOCTTY)
    except OSError:  # no file, a link, or unreadable: nothing anyone writes through this name
        return
    try:
        if stat.S_ISREG(os.fstat(fd).st_mode):
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        raise OutputError(f"{target}: another run is writing this file; it was left as it was") from None
    finally:
        os.close(fd)


class FolderLock:
    """The lock of a folder a run writes, held until :meth:`release` (or the end of a ``with``).

    The lock is :func:`fcntl.flock` on the file :data:`LOCK_NAME` in the folder:
    the kernel releases it when the holding process ends, however it ends, so a
    lock left by a killed run is taken over by the next run without a stale-lock
    test. The holder writes its process id and command into the file, for the
    message that refuses a second run. The file stays in the folder (removing it
    would let two runs lock two different files of one name). The lock file is
    opened with ``O_NOFOLLOW``: a symbolic link (or anything but a regular file)
    at its name is refused, so the lock never truncates or creates a file
    elsewhere.

    Parameters
    ----------
    folder : path-like
        The folder (it must exist).
    wait : bool
        Wait for the holder to finish instead of refusing.

    Raises
    ------
    motorid.errors.OutputError
        From :meth:`acquire`: another process holds the lock (and ``wait`` is
        false; ``errno`` is ``EWOULDBLOCK``); the message names it (:meth:`holder`)
        and the lock file. Or the lock file's name is a symbolic link or not a
        regular file (``errno`` is ``ELOOP``), left as it is.
    """

    def __init__(self, folder: str | os.PathLike[str], *, wait: bool = False) -> None:
        self.folder = Path(folder)
        self.path = self.folder / LOCK_NAME
        self.wait = bool(wait)
        self._fd: int | None = None

    def __repr__(self) -> str:
        return f"FolderLock({str(self.folder)!r}, held={self.held})"

    @property
    def held(self) -> bool:
        """True while this object holds the lock."""
        return self._fd is not None

    def holder(self) -> str:
        """What the lock file says of its holder: ``process PID on HOST``, or ``an unknown process``.

        The file's line is ``PID HOST COMMAND`` (its first 4096 bytes are read, never through a link).
        """
        try:
            fd = os.open(self.path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_NOCTTY)
        except OSError:
            return "an unknown process"
        try:
            regular = stat.S_ISREG(os.fstat(fd).st_mode)
            text = os.pread(fd, 4096, 0).decode("utf-8", errors="replace") if regular else ""
        except OSError:
            text = ""
        finally:
            os.close(fd)
        pid, host = ([*text.split(maxsplit=2), "", ""])[:2]
        return f"process {pid} on {host}" if pid.isdigit() else "an unknown process"

    def acquire(self) -> FolderLock:
        """Take the lock (waiting for it with ``wait``); returns ``self``."""
        import fcntl

        if self._fd is not None:
            return self
        fd = self._open_lock_file()
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = self.holder()
                if not self.wait:
                    busy = OutputError(
                        f"{self.folder}: another run writes this folder: {holder} holds its lock file {self.path}"
                    )
                    busy.errno = errno.EWOULDBLOCK
                    raise busy from None
                logger.warning("%s: waiting for %s to finish (lock file %s)", self.folder, holder, self.path)
                fcntl.flock(fd, fcntl.LOCK_EX)
            command = " ".join(os.path.basename(a) if i == 0 else a for i, a in enumerate(sys.argv))
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"{os.getpid()} {socket.gethostname()} {command[:200]}\n".encode(), 0)
        except BaseException:
            os.close(fd)
            raise
        self._fd = fd
        logger.debug("%s: locked (%s)", self.folder, self.path)
        return self

    def _open_lock_file(self) -> int:
        """Open (or create) the lock file without following a link; refuse anything but a regular file."""
        flags = os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_NOCTTY
        try:
            fd = os.open(self.path, flags, 0o666)
        except OSError as exc:
            if exc.errno == errno.ELOOP:
                problem = "is a symbolic link"
            else:
                problem = f"cannot be opened: {exc.strerror or exc}"
            refused = OutputError(f"{self.folder}: the lock file {self.path} {problem}; it was left as it is")
            refused.errno = exc.errno
            raise refused from None
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            os.close(fd)
            refused = OutputError(
                f"{self.folder}: the lock file {self.path} is not a regular file; it was left as it is"
            )
            refused.errno = errno.ELOOP
            raise refused
        return fd

    def release(self) -> None:
        """Let the lock go (safe to call twice)."""
        fd, self._fd = self._fd, None
        if fd is None:
            return
        try:
            os.ftruncate(fd, 0)  # the next reader sees no holder that has gone
        except OSError:
            pass
        os.close(fd)  # closing the descriptor releases the flock

    def __enter__(self) -> FolderLock:
        return self.acquire()

    def __exit__(self, *exc_info: object) -> None:
        self.release()


def safe_file_name(text: str) -> str:
    """``text`` (a name that comes from data) as one file name that stays in its folder.

    Letters, digits and ``- _ . + = @`` and spaces are kept; anything else (``/``,
    ``\\``, NUL, control characters, ``:``) becomes ``_``; leading dots and spaces
    are dropped (no ``.``, ``..`` or hidden name), trailing spaces too; the name is
    cut to :data:`MAX_NAME_BYTES` bytes. A name that had to change ends in ``-`` and
    8 hex digits of a SHA-256 of ``text``, so two different ids get two names (but
    for a collision of those 32 bits): ``"drive_1"`` stays ``"drive_1"``,
    ``"../../x"`` becomes ``"_.._x-9cdf6a50"``.

    Parameters
    ----------
    text : str
        The name as the data gives it.
    """
    text = str(text)
    kept = "".join(c if c.isalnum() or c in _NAME_CHARACTERS else "_" for c in text)
    kept = kept.lstrip(". ").rstrip(" ")
    if kept == text and 0 < len(kept.encode("utf-8")) <= MAX_NAME_BYTES:
        return kept
    digest = hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest()[:8]
    room = MAX_NAME_BYTES - len(digest) - 1
    cut = kept.encode("utf-8")[:room].decode("utf-8", "ignore").rstrip(" ")
    return f"{cut}-{digest}" if cut else digest


def jsonable(value: Any) -> Any:
    """numpy and pandas values as plain JSON (NaN and inf as null).

    Parameters
    ----------
    value : Any
        A value to write as JSON: dicts (their keys made text), lists and tuples (as lists),
        arrays, numpy scalars and paths are converted, element by element; anything else is
        returned as it is.
    """
    import numpy as np

    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, np.floating | float):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, Path):
        return str(value)
    return value


def _safe_cell(value: Any) -> Any:
    if not isinstance(value, str):
        return value
    if len(value) > MAX_TEXT_CELL:
        value = f"{value[:QUOTE_LIMIT]}... ({len(value):,} characters)"
    if value.startswith(FORMULA_STARTS):
        try:
            float(value)
        except ValueError:
            return "'" + value
    return value


def spreadsheet_safe(table: pd.DataFrame) -> pd.DataFrame:
    """A copy of ``table`` whose text cells a spreadsheet shows as text and never evaluates.

    A text cell that begins with ``=``, ``+``, ``-``, ``@``, a tab or a carriage return
    (a drive id ``=HYPERLINK(...)`` from a record) gets a leading ``'``, which spreadsheets
    take as "text follows" (OWASP's advice for CSV injection). Numbers are left as they
    are, a negative number included, and so is a text cell that reads as a number
    (``"-1.5"``). A text cell longer than :data:`MAX_TEXT_CELL` characters keeps its first
    :data:`~motorid.errors.QUOTE_LIMIT` and says how long it was.

    Parameters
    ----------
    table : pandas.DataFrame
        The table to write as CSV (not changed).
    """
    import pandas as pd

    safe = table.copy()
    for column in safe.columns:
        if safe[column].dtype == object or pd.api.types.is_string_dtype(safe[column]):
            safe[column] = safe[column].map(_safe_cell)
    safe.columns = [_safe_cell(str(c)) for c in safe.columns]
    return safe
